//! Particle snapshots for ParaView: VTK XML unstructured grids (`.vtu`, binary, appended raw
//! data, little endian, UInt64 block headers), one file of particles (one vertex cell each)
//! and one of the two plates (their triangles) per snapshot, tied by a `.pvd` collection
//! whose `timestep` is the physical time [s]. Open `native.pvd` (or `liggghts.pvd`) and render
//! the particles as spheres with a Glyph filter scaled by `radius`, coloured by
//! `rotation_magnitude` for the paper's rotation maps (Figs 8-11).
//!
//! Fields: particle `id` (1-based, LIGGGHTS' atom id), `radius`, `velocity`, `omega` and, for
//! the native solver, the accumulated `rotation` vector and its magnitude (LIGGGHTS' dumps do
//! not integrate rotations). Plates: a cell field `plate` (0 bottom, 1 top).

use crate::error::{Error, Result};
use crate::fsutil::{read_to_string, write_atomic};
use crate::solver::shear::observe::Snapshot;
use std::fmt::Write;
use std::path::Path;

/// One array of a dataset.
pub enum Field<'a> {
    I64(&'a [i64]),
    F64(&'a [f64]),
    V3(&'a [[f64; 3]]),
}

impl Field<'_> {
    fn vtk_type(&self) -> &'static str {
        match self {
            Field::I64(_) => "Int64",
            _ => "Float64",
        }
    }
    fn components(&self) -> usize {
        match self {
            Field::V3(_) => 3,
            _ => 1,
        }
    }
    fn bytes(&self) -> Vec<u8> {
        match self {
            Field::I64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Field::F64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Field::V3(v) => v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
}

/// The cells of a dataset: one vertex per point, or consecutive point triples as triangles.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Cells {
    Vertices,
    Triangles,
}

/// A `.vtu` document: `points`, their cells, point and cell arrays, and the physical time as
/// the field `TimeValue`.
pub fn vtu(
    points: &[[f64; 3]],
    cells: Cells,
    point_data: &[(&str, Field)],
    cell_data: &[(&str, Field)],
    time: f64,
) -> Vec<u8> {
    let n = points.len();
    let (ncell, per, vtk_type) = match cells {
        Cells::Vertices => (n, 1, 1u8),
        Cells::Triangles => (n / 3, 3, 5u8),
    };
    let connectivity: Vec<i64> = (0..(ncell * per) as i64).collect();
    let offsets: Vec<i64> = (1..=ncell as i64).map(|k| k * per as i64).collect();
    let types = vec![vtk_type; ncell];
    let mut blocks: Vec<Vec<u8>> = Vec::new();
    let mut xml = String::new();
    let mut offset = 0usize;
    let mut array = |xml: &mut String, name: &str, ty: &str, comps: usize, bytes: Vec<u8>| {
        writeln!(
            xml,
            r#"<DataArray type="{ty}" Name="{name}" NumberOfComponents="{comps}" format="appended" offset="{offset}"/>"#
        )
        .unwrap();
        offset += 8 + bytes.len();
        blocks.push(bytes);
    };
    writeln!(
        xml,
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">
<UnstructuredGrid>
<FieldData><DataArray type="Float64" Name="TimeValue" NumberOfTuples="1" format="ascii">{time:e}</DataArray></FieldData>
<Piece NumberOfPoints="{n}" NumberOfCells="{ncell}">"#
    )
    .unwrap();
    xml.push_str("<PointData>\n");
    for (name, f) in point_data {
        array(&mut xml, name, f.vtk_type(), f.components(), f.bytes());
    }
    xml.push_str("</PointData>\n<CellData>\n");
    for (name, f) in cell_data {
        array(&mut xml, name, f.vtk_type(), f.components(), f.bytes());
    }
    xml.push_str("</CellData>\n<Points>\n");
    array(&mut xml, "Points", "Float64", 3, Field::V3(points).bytes());
    xml.push_str("</Points>\n<Cells>\n");
    array(
        &mut xml,
        "connectivity",
        "Int64",
        1,
        Field::I64(&connectivity).bytes(),
    );
    array(
        &mut xml,
        "offsets",
        "Int64",
        1,
        Field::I64(&offsets).bytes(),
    );
    array(&mut xml, "types", "UInt8", 1, types);
    xml.push_str("</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_");
    let mut out = xml.into_bytes();
    for b in blocks {
        out.extend_from_slice(&(b.len() as u64).to_le_bytes());
        out.extend_from_slice(&b);
    }
    out.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");
    out
}

/// File names of one code's snapshot at `step`: particles and plates.
pub fn snapshot_names(code: &str, step: u64) -> (String, String) {
    (
        format!("{code}_{step:09}.vtu"),
        format!("{code}_plates_{step:09}.vtu"),
    )
}

/// The plates' triangles as a `.vtu` (cell field `plate`: 0 bottom, 1 top).
fn plates_vtu(plates: &[Vec<[[f64; 3]; 3]>; 2], time: f64) -> Vec<u8> {
    let points: Vec<[f64; 3]> = plates.iter().flatten().flatten().copied().collect();
    let which: Vec<i64> = plates
        .iter()
        .enumerate()
        .flat_map(|(k, t)| std::iter::repeat_n(k as i64, t.len()))
        .collect();
    vtu(
        &points,
        Cells::Triangles,
        &[],
        &[("plate", Field::I64(&which))],
        time,
    )
}

/// Writes one native snapshot (particles and plates) into `dir` and rewrites `native.pvd`.
pub fn write_snapshot(dir: &Path, s: &Snapshot, dt: f64) -> Result<()> {
    let rot_mag = crate::rotation_map::magnitudes(&s.rotation);
    let ids: Vec<i64> = (1..=s.x.len() as i64).collect();
    let time = s.step as f64 * dt;
    let (particles, plates) = snapshot_names("native", s.step);
    write_atomic(
        &dir.join(particles),
        &vtu(
            &s.x,
            Cells::Vertices,
            &[
                ("id", Field::I64(&ids)),
                ("radius", Field::F64(&s.radius)),
                ("velocity", Field::V3(&s.v)),
                ("omega", Field::V3(&s.omega)),
                ("rotation", Field::V3(&s.rotation)),
                ("rotation_magnitude", Field::F64(&rot_mag)),
            ],
            &[],
            time,
        ),
    )?;
    write_atomic(&dir.join(plates), &plates_vtu(&s.plates, time))?;
    write_pvd(dir, "native", dt)
}

/// Rewrites `<code>.pvd` in `dir` from the snapshots there (so a resumed run's collection
/// holds the snapshots written before the interruption too): particles as part 0, plates as
/// part 1, `timestep` = step x dt [s].
pub fn write_pvd(dir: &Path, code: &str, dt: f64) -> Result<()> {
    let prefix = format!("{code}_");
    let mut steps: Vec<u64> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| {
            let name = e.ok()?.file_name().into_string().ok()?;
            name.strip_prefix(&prefix)?
                .strip_suffix(".vtu")?
                .parse()
                .ok()
        })
        .collect();
    steps.sort_unstable();
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n<Collection>\n",
    );
    for step in steps {
        let (particles, plates) = snapshot_names(code, step);
        let t = step as f64 * dt;
        writeln!(
            s,
            r#"<DataSet timestep="{t:e}" part="0" file="{particles}"/>"#
        )
        .unwrap();
        if dir.join(&plates).is_file() {
            writeln!(s, r#"<DataSet timestep="{t:e}" part="1" file="{plates}"/>"#).unwrap();
        }
    }
    s.push_str("</Collection>\n</VTKFile>\n");
    write_atomic(&dir.join(format!("{code}.pvd")), s.as_bytes())
}

/// Converts LIGGGHTS `dump custom` snapshots (`id radius x y z vx vy vz omegax omegay
/// omegaz`, files `<prefix><step>.dump` in `dir`) to `liggghts_<step>.vtu` in `out`, with the
/// plates `plates(step)` gives (None: no plate file for that step), and writes `liggghts.pvd`.
pub fn convert_liggghts_snapshots(
    dir: &Path,
    prefix: &str,
    out: &Path,
    dt: f64,
    plates: impl Fn(u64) -> Option<[Vec<[[f64; 3]; 3]>; 2]>,
) -> Result<usize> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
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
        let (mut ids, mut x, mut radius, mut v, mut w) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
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
            ids.push(f[0] as i64);
            radius.push(f[1]);
            x.push([f[2], f[3], f[4]]);
            v.push([f[5], f[6], f[7]]);
            w.push([f[8], f[9], f[10]]);
        }
        let time = step as f64 * dt;
        let (particles, plate_file) = snapshot_names("liggghts", step);
        write_atomic(
            &out.join(particles),
            &vtu(
                &x,
                Cells::Vertices,
                &[
                    ("id", Field::I64(&ids)),
                    ("radius", Field::F64(&radius)),
                    ("velocity", Field::V3(&v)),
                    ("omega", Field::V3(&w)),
                ],
                &[],
                time,
            ),
        )?;
        if let Some(pl) = plates(step) {
            write_atomic(&out.join(plate_file), &plates_vtu(&pl, time))?;
        }
        n += 1;
    }
    write_pvd(out, "liggghts", dt)?;
    Ok(n)
}

/// A `.vtu` [`vtu`] wrote, opened with nothing trusted: the header must be this module's
/// (little endian, UInt64 block headers, appended raw data) and every array read must lie
/// inside the file with the length its tuple count gives (checked arithmetic: an absurd count
/// or offset is an error, not a wrap).
struct Appended<'a> {
    path: &'a Path,
    head: &'a str,
    data: &'a [u8],
    points: usize,
    cells: usize,
}

impl<'a> Appended<'a> {
    fn bad(path: &Path, why: &str) -> Error {
        Error::invalid(
            "snapshot",
            path.display(),
            format!("a particle snapshot written by verify ({why})"),
        )
    }

    fn parse(path: &'a Path, b: &'a [u8]) -> Result<Self> {
        let bad = |why: &str| Self::bad(path, why);
        if !b.ends_with(b"\n</AppendedData>\n</VTKFile>\n") {
            return Err(bad("it does not end as one does: cut short?"));
        }
        let marker = b"<AppendedData encoding=\"raw\">\n_";
        let start = b
            .windows(marker.len())
            .position(|w| w == marker)
            .ok_or_else(|| bad("no appended raw data"))?;
        let head = std::str::from_utf8(&b[..start]).map_err(|_| bad("its header is not text"))?;
        if !head.contains(r#"byte_order="LittleEndian" header_type="UInt64""#) {
            return Err(bad("not little endian with UInt64 block headers"));
        }
        let piece = head.split("<Piece ").nth(1);
        let count = |name: &str| -> Result<usize> {
            piece
                .and_then(|t| Self::attr(t, name))
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| bad(&format!("no {name}")))
        };
        Ok(Appended {
            path,
            head,
            data: &b[start + marker.len()..],
            points: count("NumberOfPoints")?,
            cells: count("NumberOfCells")?,
        })
    }

    fn attr(tag: &str, name: &str) -> Option<String> {
        let i = tag.find(&format!("{name}=\""))? + name.len() + 2;
        Some(tag[i..].split('"').next()?.to_string())
    }

    /// The 8-byte words of the array `name` of type `ty` (Int64 or Float64) with `comps`
    /// components over `tuples` tuples.
    fn words(&self, name: &str, ty: &str, comps: usize, tuples: usize) -> Result<Vec<[u8; 8]>> {
        let bad = |why: &str| Self::bad(self.path, why);
        let tag = self
            .head
            .split("<DataArray ")
            .find(|t| Self::attr(t, "Name").as_deref() == Some(name))
            .ok_or_else(|| bad(&format!("no array {name}")))?;
        let ok = Self::attr(tag, "type").as_deref() == Some(ty)
            && Self::attr(tag, "NumberOfComponents").as_deref() == Some(&comps.to_string())
            && Self::attr(tag, "format").as_deref() == Some("appended");
        let off: usize = Self::attr(tag, "offset")
            .and_then(|v| v.parse().ok())
            .filter(|_| ok)
            .ok_or_else(|| bad(&format!("array {name} is not {comps} x {ty}, appended")))?;
        let len = tuples.checked_mul(comps * 8).ok_or_else(|| {
            bad(&format!(
                "array {name}'s length ({tuples} tuples) out of range"
            ))
        })?;
        let (body, end) = off
            .checked_add(8)
            .and_then(|b| Some((b, b.checked_add(len)?)))
            .ok_or_else(|| bad(&format!("array {name}'s offset out of range")))?;
        let size = self
            .data
            .get(off..body)
            .map(|h| u64::from_le_bytes(h.try_into().expect("8 bytes")));
        if size != Some(len as u64) {
            return Err(bad(&format!("array {name}'s block is not {len} bytes")));
        }
        let bytes = self
            .data
            .get(body..end)
            .ok_or_else(|| bad(&format!("array {name} runs past the end")))?;
        Ok(bytes
            .chunks_exact(8)
            .map(|c| c.try_into().expect("8 bytes"))
            .collect())
    }

    /// The finite Float64 array `name`, 3 components a point.
    fn vectors(&self, name: &str, tuples: usize) -> Result<Vec<[f64; 3]>> {
        let v = self.finite(name, 3, tuples)?;
        Ok(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    fn finite(&self, name: &str, comps: usize, tuples: usize) -> Result<Vec<f64>> {
        let v: Vec<f64> = self
            .words(name, "Float64", comps, tuples)?
            .into_iter()
            .map(f64::from_le_bytes)
            .collect();
        if v.iter().any(|x| !x.is_finite()) {
            return Err(Self::bad(
                self.path,
                &format!("a value of {name} is not finite"),
            ));
        }
        Ok(v)
    }

    /// The `id` array: 1..=n in order (the particles in id order).
    fn ids_in_order(&self) -> Result<()> {
        let ids = self.words("id", "Int64", 1, self.points)?;
        if ids
            .iter()
            .enumerate()
            .any(|(k, w)| i64::from_le_bytes(*w) != k as i64 + 1)
        {
            return Err(Self::bad(self.path, "its ids are not 1..=n in order"));
        }
        Ok(())
    }
}

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// The particle positions of a snapshot [`write_snapshot`] wrote, in id order. Nothing in
/// it is trusted ([`Appended`]): the `id` and `Points` arrays must lie inside the file with
/// the lengths `NumberOfPoints` gives, the ids must be 1..=n in order and every coordinate
/// finite.
pub fn read_positions(path: &Path) -> Result<Vec<[f64; 3]>> {
    let b = read(path)?;
    let f = Appended::parse(path, &b)?;
    f.ids_in_order()?;
    f.vectors("Points", f.points)
}

/// The whole native snapshot of `step` in `dir` as [`write_snapshot`] wrote it: the
/// particles (positions, radii, velocities, spins, accumulated rotations; ids 1..=n in order,
/// every value finite) and the plates' triangles (three points a triangle, the cell field
/// `plate` 0 or 1). Nothing trusted, as [`read_positions`].
pub fn read_snapshot(dir: &Path, step: u64) -> Result<Snapshot> {
    let (particles, plates) = snapshot_names("native", step);
    let path = dir.join(particles);
    let b = read(&path)?;
    let f = Appended::parse(&path, &b)?;
    f.ids_in_order()?;
    let n = f.points;
    let radius = f.finite("radius", 1, n)?;
    let (x, v) = (f.vectors("Points", n)?, f.vectors("velocity", n)?);
    let (omega, rotation) = (f.vectors("omega", n)?, f.vectors("rotation", n)?);
    let path = dir.join(plates);
    let b = read(&path)?;
    let f = Appended::parse(&path, &b)?;
    if f.points != 3 * f.cells {
        return Err(Appended::bad(&path, "three points a triangle"));
    }
    let corners = f.vectors("Points", f.points)?;
    let mut tris: [Vec<[[f64; 3]; 3]>; 2] = [Vec::new(), Vec::new()];
    for (w, t) in f
        .words("plate", "Int64", 1, f.cells)?
        .into_iter()
        .zip(corners.chunks_exact(3))
    {
        let k = usize::try_from(i64::from_le_bytes(w))
            .ok()
            .filter(|k| *k < 2)
            .ok_or_else(|| Appended::bad(&path, "a plate is 0 or 1"))?;
        tris[k].push([t[0], t[1], t[2]]);
    }
    Ok(Snapshot {
        step,
        x,
        v,
        omega,
        radius,
        rotation,
        plates: tris,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What [`write_snapshot`] wrote, [`read_positions`] reads back bit for bit; a file cut
    /// short, an id out of order or a foreign file is an error naming the snapshot.
    #[test]
    fn positions_read_back_and_bad_files_are_refused() {
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let x = vec![[0.1, 1.0, 2.0], [3.0, -4.5, 5.0e-300], [7.0, 8.0, 9.0]];
        let s = Snapshot {
            step: 7,
            x: x.clone(),
            v: vec![[0.0; 3]; 3],
            omega: vec![[0.0; 3]; 3],
            radius: vec![0.1; 3],
            rotation: vec![[0.0; 3]; 3],
            plates: [vec![tri], vec![tri]],
        };
        let dir = tempfile::tempdir().unwrap();
        write_snapshot(dir.path(), &s, 1e-3).unwrap();
        let path = dir.path().join("native_000000007.vtu");
        assert_eq!(read_positions(&path).unwrap(), x);
        let good = std::fs::read(&path).unwrap();
        let refused = |bytes: &[u8]| {
            std::fs::write(&path, bytes).unwrap();
            let e = read_positions(&path).unwrap_err().to_string();
            assert!(
                e.contains("snapshot") && e.contains("native_000000007.vtu"),
                "{e}"
            );
        };
        refused(&good[..good.len() - 60]);
        let mut swapped = good.clone();
        let one = 1i64.to_le_bytes();
        let at = swapped.windows(8).position(|w| w == one).unwrap();
        swapped[at..at + 8].copy_from_slice(&2i64.to_le_bytes());
        refused(&swapped);
        refused(b"<VTKFile/>");
        // an absurd count or offset is an error, not an overflow (the header edited, the
        // binary data kept byte for byte)
        let edited = |from: &str, to: &str| {
            let at = good
                .windows(from.len())
                .position(|w| w == from.as_bytes())
                .unwrap();
            [&good[..at], to.as_bytes(), &good[at + from.len()..]].concat()
        };
        let max = u64::MAX;
        refused(&edited(
            r#"NumberOfPoints="3""#,
            &format!(r#"NumberOfPoints="{max}""#),
        ));
        refused(&edited(r#"offset="0""#, &format!(r#"offset="{max}""#)));
        // the plates' file holds no particles
        let e = read_positions(&dir.path().join("native_plates_000000007.vtu")).unwrap_err();
        assert!(e.to_string().contains("no array id"), "{e}");
    }

    /// [`read_snapshot`] gives back every field [`write_snapshot`] wrote, bit for bit, the
    /// plates' triangles each to its plate; a plate index other than 0 or 1 is refused.
    #[test]
    fn a_whole_snapshot_reads_back_bit_for_bit() {
        let t = |k: f64| [[k, 0.0, 0.0], [1.0, k, 0.0], [0.0, 0.0, 1.0 / 3.0]];
        let s = Snapshot {
            step: 42,
            x: vec![[0.1, 1.0, 2.0], [3.0, -4.5, 5.0e-300]],
            v: vec![[1e-9, -2.0, 3.5], [0.0, -0.0, 7.0]],
            omega: vec![[4.0, 5.0, 6.0], [-1.0, 1.0 / 7.0, 0.0]],
            radius: vec![0.1, 0.2],
            rotation: vec![[0.0, 3.0, 4.0], [1e3, -2.0, 0.5]],
            plates: [vec![t(0.0), t(1.0)], vec![t(2.0)]],
        };
        let dir = tempfile::tempdir().unwrap();
        write_snapshot(dir.path(), &s, 1e-3).unwrap();
        let r = read_snapshot(dir.path(), 42).unwrap();
        let bits =
            |v: &[[f64; 3]]| -> Vec<u64> { v.iter().flatten().map(|x| x.to_bits()).collect() };
        for (a, b) in [
            (&r.x, &s.x),
            (&r.v, &s.v),
            (&r.omega, &s.omega),
            (&r.rotation, &s.rotation),
        ] {
            assert_eq!(bits(a), bits(b));
        }
        assert_eq!(r.radius, s.radius);
        assert_eq!(r.plates, s.plates);
        assert_eq!(r.step, 42);
        let plates = dir.path().join("native_plates_000000042.vtu");
        let mut b = std::fs::read(&plates).unwrap();
        // the cell array `plate` (0, 0, 1) is the first block: its third value made 2
        let marker = b"<AppendedData encoding=\"raw\">\n_";
        let data = b.windows(marker.len()).position(|w| w == marker).unwrap() + marker.len();
        let at = data + 8 + 16;
        assert_eq!(b[at..at + 8], 1i64.to_le_bytes());
        b[at..at + 8].copy_from_slice(&2i64.to_le_bytes());
        std::fs::write(&plates, &b).unwrap();
        let e = read_snapshot(dir.path(), 42).unwrap_err().to_string();
        assert!(
            e.contains("a plate is 0 or 1") && e.contains("native_plates_000000042"),
            "{e}"
        );
    }

    #[test]
    fn snapshot_files_hold_binary_arrays_and_the_collection_the_time() {
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let s = Snapshot {
            step: 5,
            x: vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]],
            v: vec![[0.0; 3]; 2],
            omega: vec![[1.0, 0.0, 0.0]; 2],
            radius: vec![0.1, 0.2],
            rotation: vec![[0.0, 3.0, 4.0]; 2],
            plates: [vec![tri], vec![tri, tri]],
        };
        let dir = tempfile::tempdir().unwrap();
        write_snapshot(dir.path(), &s, 1e-3).unwrap();
        let b = std::fs::read(dir.path().join("native_000000005.vtu")).unwrap();
        let head = String::from_utf8_lossy(&b[..b.len().min(1500)]).to_string();
        assert!(
            head.contains(r#"NumberOfPoints="2" NumberOfCells="2""#),
            "{head}"
        );
        assert!(head.contains(r#"Name="rotation_magnitude""#));
        // the magnitude 5 as little-endian f64 bits after its block header
        let five = 5.0f64.to_le_bytes();
        assert!(b.windows(8).any(|w| w == five));
        let pl = std::fs::read(dir.path().join("native_plates_000000005.vtu")).unwrap();
        assert!(String::from_utf8_lossy(&pl).contains(r#"NumberOfPoints="9" NumberOfCells="3""#));
        let pvd = std::fs::read_to_string(dir.path().join("native.pvd")).unwrap();
        assert!(
            pvd.contains(r#"timestep="5e-3" part="0" file="native_000000005.vtu""#),
            "{pvd}"
        );
        assert!(
            pvd.contains(r#"part="1" file="native_plates_000000005.vtu""#),
            "{pvd}"
        );
    }
}
