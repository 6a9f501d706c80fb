//! `verify profile DIR`: the steady profiles of a finished native run from its ParaView
//! snapshots (grain displacements, [`crate::profile::displacement_profile`]), where the
//! velocity samples cannot resolve them: at the paper's 0.1-1 mm/s a grain's velocity
//! fluctuates 20-40 times the plate speed. DIR is a run's seed folder: its `case.toml`, its
//! series `native.csv` (the top plate's height at each snapshot) and `vtk/native_*.vtu`.
//! Writes `DIR/native_displacement_profile.{csv,json}` (atomically).

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

/// A displacement profile needs this many snapshots in its stage's steady window (two
/// intervals: [`displacement_profile`]'s least).
const LEAST_SNAPSHOTS: usize = 3;

/// The run's profiles, one per stage, from the snapshots in each stage's steady window
/// (its second half, as the steady mu's): written to DIR and returned. A stage with fewer
/// than [`LEAST_SNAPSHOTS`] there (a run resumed on another machine from a carried
/// checkpoint, whose earlier snapshots stayed behind) has none, said as a note; a run with
/// none in any stage is an error.
pub fn run(dir: &Path) -> Result<Vec<VelocityProfile>> {
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
    let ends = case.run_ends();
    let mut profiles = Vec::new();
    for k in 0..case.stages.len() {
        let (a, b) = steady_window(ends[k], ends[k + 1]);
        let window: Vec<u64> = steps
            .iter()
            .copied()
            .filter(|s| (a..=b).contains(s))
            .collect();
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
    write_atomic(
        &dir.join("native_displacement_profile.csv"),
        csv(&profiles).as_bytes(),
    )?;
    write_atomic(
        &dir.join("native_displacement_profile.json"),
        serde_json::to_string_pretty(&profiles)?.as_bytes(),
    )?;
    Ok(profiles)
}
