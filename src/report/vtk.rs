//! Particle snapshots as legacy VTK polydata (ParaView reads them; render as spheres with a
//! Glyph filter scaled by `radius`). Fields: radius, velocity, angular velocity and, for the
//! native solver, the accumulated rotation (the paper's rotation colour maps).

use crate::error::{Error, Result};
use crate::fsutil::{read_to_string, write_atomic};
use crate::solver::shear::Snapshot;
use std::fmt::Write;
use std::path::Path;

/// Writes one snapshot.
pub fn write_snapshot(path: &Path, s: &Snapshot) -> Result<()> {
    let rot_mag: Vec<f64> = s
        .rotation
        .iter()
        .map(|r| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt())
        .collect();
    write_atomic(
        path,
        polydata(
            s.step,
            &s.x,
            &s.radius,
            &[
                ("velocity", &s.v),
                ("omega", &s.omega),
                ("rotation", &s.rotation),
            ],
            &[("rotation_magnitude", &rot_mag)],
        )
        .as_bytes(),
    )
}

fn polydata(
    step: u64,
    x: &[[f64; 3]],
    radius: &[f64],
    vectors: &[(&str, &[[f64; 3]])],
    scalars: &[(&str, &[f64])],
) -> String {
    let n = x.len();
    let mut s = format!("# vtk DataFile Version 3.0\ndem-verify snapshot step {step}\nASCII\nDATASET POLYDATA\nPOINTS {n} double\n");
    for p in x {
        writeln!(s, "{:e} {:e} {:e}", p[0], p[1], p[2]).unwrap();
    }
    writeln!(s, "VERTICES {n} {}", 2 * n).unwrap();
    for k in 0..n {
        writeln!(s, "1 {k}").unwrap();
    }
    writeln!(
        s,
        "POINT_DATA {n}\nSCALARS radius double 1\nLOOKUP_TABLE default"
    )
    .unwrap();
    for r in radius {
        writeln!(s, "{r:e}").unwrap();
    }
    for (name, vals) in scalars {
        writeln!(s, "SCALARS {name} double 1\nLOOKUP_TABLE default").unwrap();
        for v in *vals {
            writeln!(s, "{v:e}").unwrap();
        }
    }
    for (name, vals) in vectors {
        writeln!(s, "VECTORS {name} double").unwrap();
        for v in *vals {
            writeln!(s, "{:e} {:e} {:e}", v[0], v[1], v[2]).unwrap();
        }
    }
    s
}

/// Converts LIGGGHTS `dump custom` snapshots (`id radius x y z vx vy vz omegax omegay
/// omegaz`, files `<prefix><step>.dump` in `dir`) to VTK files `liggghts_<step>.vtk`.
pub fn convert_liggghts_snapshots(dir: &Path, prefix: &str, out: &Path) -> Result<usize> {
    let mut n = 0;
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    for e in entries {
        let p = e.map_err(|e| Error::io(dir, e))?.path();
        let name = p.file_name().and_then(|s| s.to_str()).unwrap_or("");
        let Some(step) = name
            .strip_prefix(prefix)
            .and_then(|s| s.strip_suffix(".dump"))
            .and_then(|s| s.parse::<u64>().ok())
        else {
            continue;
        };
        let text = read_to_string(&p)?;
        let (mut x, mut radius, mut v, mut w) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut in_atoms = false;
        for line in text.lines() {
            if line.starts_with("ITEM: ATOMS") {
                in_atoms = true;
                continue;
            }
            if !in_atoms {
                continue;
            }
            let f: Vec<f64> = line
                .split_whitespace()
                .filter_map(|t| t.parse().ok())
                .collect();
            if f.len() != 11 {
                return Err(Error::Parse {
                    path: p.clone(),
                    msg: format!("expected 11 columns, got {}", f.len()),
                });
            }
            radius.push(f[1]);
            x.push([f[2], f[3], f[4]]);
            v.push([f[5], f[6], f[7]]);
            w.push([f[8], f[9], f[10]]);
        }
        write_atomic(
            &out.join(format!("liggghts_{step:09}.vtk")),
            polydata(step, &x, &radius, &[("velocity", &v), ("omega", &w)], &[]).as_bytes(),
        )?;
        n += 1;
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snapshot_has_points_and_fields() {
        let s = Snapshot {
            step: 5,
            x: vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]],
            v: vec![[0.0; 3]; 2],
            omega: vec![[1.0, 0.0, 0.0]; 2],
            radius: vec![0.1, 0.2],
            rotation: vec![[0.0, 3.0, 4.0]; 2],
        };
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.vtk");
        write_snapshot(&p, &s).unwrap();
        let t = std::fs::read_to_string(p).unwrap();
        assert!(t.contains("POINTS 2 double"));
        assert!(t.contains("VECTORS omega double"));
        assert!(t.contains("SCALARS rotation_magnitude double 1\nLOOKUP_TABLE default\n5e0"));
    }
}
