//! `verify profile DIR`: the steady profiles of a finished native run from its ParaView
//! snapshots (grain displacements, [`crate::profile::displacement_profile`]), where the
//! velocity samples cannot resolve them: at the paper's 0.1-1 mm/s a grain's velocity
//! fluctuates 20-40 times the plate speed. DIR is a run's seed folder: its `case.toml`, its
//! series `native.csv` (the top plate's height at each snapshot) and `vtk/native_*.vtu`.
//! Writes `DIR/native_displacement_profile.{csv,json}` (atomically), and the paper's rotation
//! maps (its Figs 8-11) stage by stage: the rotation each grain made over each stage's steady
//! window ([`stage_rotation_maps`]), where the map the run wrote at its end sums the whole
//! run's (compaction and all three speeds).

use crate::error::{Error, Result};
use crate::fsutil::{read_to_string, write_atomic};
use crate::profile::{csv, displacement_profile, PositionSample, VelocityProfile};
use crate::series::Series;
use crate::spec::shear::ShearCase;
use crate::spec::windows::steady_window;
use std::path::Path;

/// The snapshot steps in `dir/vtk` (particle files `native_<step>.vtu`, not the plates'), in
/// increasing order.
fn snapshot_steps(vtk: &Path) -> Result<Vec<u64>> {
    let mut steps: Vec<u64> = std::fs::read_dir(vtk)
        .map_err(|e| Error::io(vtk, e))?
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.strip_prefix("native_")?
                .strip_suffix(".vtu")?
                .parse::<u64>()
                .ok()
        })
        .collect();
    steps.sort_unstable();
    Ok(steps)
}

/// The top plate's height at `step`: its row's, or interpolated linearly between the rows
/// around it (the series is written every `output_every` steps, snapshots at their own
/// interval; the servo moves the plate by nanometres between rows). None outside the series.
fn top_y_at(series: &Series, col: usize, step: u64) -> Option<f64> {
    match series.steps.binary_search(&step) {
        Ok(k) => Some(series.rows[k][col]),
        Err(k) if k > 0 && k < series.steps.len() => {
            let (s0, s1) = (series.steps[k - 1] as f64, series.steps[k] as f64);
            let (y0, y1) = (series.rows[k - 1][col], series.rows[k][col]);
            Some(y0 + (y1 - y0) * (step as f64 - s0) / (s1 - s0))
        }
        Err(_) => None,
    }
}

/// Each stage's index, steady window (its second half, as the steady mu's) and the snapshot
/// steps in it.
fn stage_windows(case: &ShearCase, steps: &[u64]) -> Vec<(usize, (u64, u64), Vec<u64>)> {
    let ends = case.run_ends();
    (0..case.stages.len())
        .map(|k| {
            let (a, b) = steady_window(ends[k], ends[k + 1]);
            let window = steps
                .iter()
                .copied()
                .filter(|s| (a..=b).contains(s))
                .collect();
            (k, (a, b), window)
        })
        .collect()
}

/// A displacement profile needs this many snapshots in its stage's steady window (two
/// intervals: [`displacement_profile`]'s least).
const LEAST_SNAPSHOTS: usize = 3;

/// The run's profiles, one per stage, from the snapshots in each stage's steady window
/// (its second half, as the steady mu's): written to DIR and returned. A stage with fewer
/// than [`LEAST_SNAPSHOTS`] there (a run resumed on another machine from a carried
/// checkpoint, whose earlier snapshots stayed behind) has none, said as a note; a run with
/// none in any stage is an error. Also the stages' rotation maps: returns the profiles and
/// the number of maps.
pub fn run(dir: &Path) -> Result<(Vec<VelocityProfile>, usize)> {
    let case: ShearCase = toml::from_str(&read_to_string(&dir.join("case.toml"))?)
        .map_err(|e| Error::invalid("case.toml", dir.display(), e.to_string()))?;
    case.validate(true)?;
    let series = Series::read_csv(&dir.join("native.csv"))?;
    let top = series.col("top_y[m]").ok_or_else(|| {
        Error::invalid(
            "native.csv",
            dir.display(),
            "a native series with a top_y[m] column",
        )
    })?;
    let vtk = dir.join("vtk");
    let steps = snapshot_steps(&vtk)?;
    let mut profiles = Vec::new();
    for (k, (a, b), window) in stage_windows(&case, &steps) {
        if window.len() < LEAST_SNAPSHOTS {
            super::tell::note(&format!(
                "stage {} ({} m/s): {} snapshot(s) in its steady window (steps {a}-{b}), \
                 {LEAST_SNAPSHOTS} needed: no profile for it",
                k + 1,
                case.stages[k].speed,
                window.len()
            ));
            continue;
        }
        let samples: Vec<PositionSample> = window
            .into_iter()
            .map(|s| {
                let top_y = top_y_at(&series, top, s).ok_or_else(|| {
                    Error::invalid(
                        "native.csv",
                        dir.display(),
                        format!("rows around snapshot step {s}"),
                    )
                })?;
                let path = vtk.join(crate::vtk::snapshot_names("native", s).0);
                let x = crate::vtk::read_positions(&path)?;
                if x.len() != case.particles {
                    return Err(Error::invalid(
                        "snapshot",
                        path.display(),
                        format!("{} particles, as case.toml says", case.particles),
                    ));
                }
                Ok(PositionSample { step: s, top_y, x })
            })
            .collect::<Result<_>>()?;
        let refs: Vec<&PositionSample> = samples.iter().collect();
        profiles.push(displacement_profile(&case, k, &refs)?);
    }
    if profiles.is_empty() {
        return Err(Error::Missing {
            what: format!(
                "snapshots ({LEAST_SNAPSHOTS} or more in a stage's steady window: {} in all)",
                steps.len()
            ),
            dir: vtk,
        });
    }
    let maps = stage_rotation_maps(dir, &case, &steps)?;
    write_atomic(
        &dir.join("native_displacement_profile.csv"),
        csv(&profiles).as_bytes(),
    )?;
    write_atomic(
        &dir.join("native_displacement_profile.json"),
        serde_json::to_string_pretty(&profiles)?.as_bytes(),
    )?;
    Ok((profiles, maps))
}

/// Per stage, `DIR/rotation_map_stage<k>.svg`: each grain's rotation over the stage's steady
/// window (the magnitude of the difference of its accumulated rotation vector, the integral of
/// omega dt, between the window's first and last snapshots), drawn where the grains are at the
/// last. The same colour scale for every stage of the run (the largest of the stages' 99th
/// percentiles): the windows are the same strain (half of a stage's 100 %), so the maps compare
/// the speeds; each title gives its own stage's 99th percentile (a stage far below the scale's
/// top, washed out on it, still says how far it turned). A stage with fewer than two
/// snapshots in its window has none, said as a note.
/// Returns the number of maps written.
fn stage_rotation_maps(dir: &Path, case: &ShearCase, steps: &[u64]) -> Result<usize> {
    let vtk = dir.join("vtk");
    let mut maps = Vec::new();
    for (k, (a, b), window) in stage_windows(case, steps) {
        let (Some(&first), Some(&last)) = (window.first(), window.last()) else {
            continue;
        };
        if first == last {
            super::tell::note(&format!(
                "stage {}: one snapshot in its steady window (steps {a}-{b}): no rotation map",
                k + 1
            ));
            continue;
        }
        let (s0, s1) = (
            crate::vtk::read_snapshot(&vtk, first)?,
            crate::vtk::read_snapshot(&vtk, last)?,
        );
        if s0.x.len() != case.particles || s1.x.len() != case.particles {
            return Err(Error::invalid(
                "snapshot",
                vtk.display(),
                format!("{} particles, as case.toml says", case.particles),
            ));
        }
        let turned: Vec<[f64; 3]> = s0
            .rotation
            .iter()
            .zip(&s1.rotation)
            .map(|(r0, r1)| [r1[0] - r0[0], r1[1] - r0[1], r1[2] - r0[2]])
            .collect();
        let mag = crate::rotation_map::magnitudes(&turned);
        maps.push((k, first, s1, mag));
    }
    let hi = maps
        .iter()
        .map(|m| crate::rotation_map::scale_top(&m.3))
        .fold(0.0, f64::max);
    for (k, first, s, mag) in &maps {
        crate::rotation_map::draw(
            &dir.join(format!("rotation_map_stage{}.svg", k + 1)),
            &format!(
                "stage {} ({} m/s), mu_r {}, eta_r {}, seed {}: rotation over steps {}-{}, \
                 99 % under {:.3} rad",
                k + 1,
                case.stages[*k].speed,
                case.material.rolling_friction,
                case.material.rolling_damping,
                case.seed,
                first,
                s.step,
                crate::rotation_map::scale_top(mag)
            ),
            s,
            mag,
            hi,
            case.box_x,
        )?;
    }
    Ok(maps.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::contact::models::RollingModel;
    use crate::solver::shear::observe::Snapshot;
    use crate::spec::shear::Preset;

    /// A stage's map is the rotation each grain made between its steady window's first and
    /// last snapshots (the difference of the accumulated vectors, not the run's total), on
    /// one colour scale (the 99th percentile), titled with the steps; a snapshot outside the
    /// window is not read; a snapshot of another sample is an error.
    #[test]
    fn a_stage_map_is_the_rotation_over_its_steady_window() {
        let case = ShearCase::preset(Preset::Ci, RollingModel::Epsd, 0.5, 0.5, 1).unwrap();
        let n = case.particles;
        let ends = case.run_ends();
        let (a, b) = steady_window(ends[0], ends[1]);
        let tri = [[0.0, 0.0, 0.0], [1e-3, 0.0, 0.0], [0.0, 0.0, 1e-3]];
        let snap = |step, rot: &dyn Fn(usize) -> [f64; 3]| Snapshot {
            step,
            x: (0..n)
                .map(|i| [case.box_x * (i as f64 + 0.5) / n as f64, 1e-3, 0.0])
                .collect(),
            v: vec![[0.0; 3]; n],
            omega: vec![[0.0; 3]; n],
            radius: vec![2e-5; n],
            rotation: (0..n).map(rot).collect(),
            plates: [vec![tri], vec![tri]],
        };
        let dir = tempfile::tempdir().unwrap();
        let vtk = dir.path().join("vtk");
        std::fs::create_dir(&vtk).unwrap();
        // grain i turned 1000 rad before the window, then i / n rad about z within it
        let before = |i: usize| [1000.0, i as f64, 0.0];
        let within = |i: usize| [1000.0, i as f64, i as f64 / n as f64];
        for (step, rot) in [
            (a - 1, &before as &dyn Fn(usize) -> [f64; 3]),
            (a, &before),
            (b, &within),
        ] {
            crate::vtk::write_snapshot(&vtk, &snap(step, rot), case.dt).unwrap();
        }
        // the snapshot before the window is damaged: it must not be read
        std::fs::write(vtk.join(crate::vtk::snapshot_names("native", a - 1).0), "x").unwrap();
        let steps = [a - 1, a, b];
        assert_eq!(stage_rotation_maps(dir.path(), &case, &steps).unwrap(), 1);
        let t = std::fs::read_to_string(dir.path().join("rotation_map_stage1.svg")).unwrap();
        assert!(t.contains(&format!("rotation over steps {a}-{b}")), "{t}");
        assert_eq!(t.matches("<circle").count(), 2 * n);
        // the scale's top: the 99th percentile of i / n, not of the 1000 rad before
        let hi = crate::rotation_map::scale_top(
            &(0..n).map(|i| i as f64 / n as f64).collect::<Vec<_>>(),
        );
        assert!(
            t.contains(&format!("\n{hi:.2}\n"))
                && !t.contains("\n1000")
                && t.contains(&format!("99 % under {hi:.3} rad")),
            "{t}"
        );
        // the last snapshot of another sample
        let mut other = snap(b, &within);
        for f in [
            &mut other.x,
            &mut other.v,
            &mut other.omega,
            &mut other.rotation,
        ] {
            f.pop();
        }
        other.radius.pop();
        crate::vtk::write_snapshot(&vtk, &other, case.dt).unwrap();
        let e = stage_rotation_maps(dir.path(), &case, &steps).unwrap_err();
        assert!(e.to_string().contains(&format!("{n} particles")), "{e}");
    }
}
