//! What a shear study keeps per seed and code so that it resumes: each finished run's
//! series and profiles with a record that a resumed study checks before it trusts them.

use crate::error::Result;
use crate::fsutil::write_atomic;
use crate::series::Series;
use crate::shear::{CodeRun, Row};
use crate::spec::shear::ShearCase;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What is kept per seed and code so that an interrupted `verify shear` resumes.
/// The series' row count and SHA-256 and the profile's SHA-256 let a resumed study refuse a
/// cut or edited file instead of reporting it; a record without them (stored before they were
/// kept) is not trusted: its seed runs again.
#[derive(Serialize, Deserialize)]
struct RunRecord {
    case: String,
    wall_time: f64,
    steps: u64,
    #[serde(default)]
    rows: Option<usize>,
    #[serde(default)]
    sha256: Option<String>,
    #[serde(default)]
    profile_sha256: Option<String>,
    /// LIGGGHTS: the restart steps an interrupted run continued from ([`CodeRun::resumed_from`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    resumed_from: Vec<u64>,
}

/// A finished run stored in `dir` by [`store`], if it is of `case` and complete: the record
/// names the same case, the series checks against the record, starts at step 0, rises, and
/// holds the end of every run of the case (a truncated file lacks the last). Anything else
/// is run again.
pub(super) fn cached(dir: &Path, code: &str, case: &ShearCase) -> Option<CodeRun> {
    let rec: RunRecord =
        serde_json::from_str(&std::fs::read_to_string(dir.join(format!("{code}_run.json"))).ok()?)
            .ok()?;
    if rec.case != serde_json::to_string(case).ok()? {
        return None;
    }
    let csv_path = dir.join(format!("{code}.csv"));
    let bytes = std::fs::read(&csv_path).ok()?;
    if rec.sha256.as_ref()? != &crate::fsutil::sha256_hex(&bytes) {
        return None;
    }
    let profile_bytes = std::fs::read(dir.join(format!("{code}_profile.json"))).ok()?;
    if rec.profile_sha256.as_ref()? != &crate::fsutil::sha256_hex(&profile_bytes) {
        return None;
    }
    let s = Series::read_csv(&csv_path).ok()?;
    let ends = case.run_ends();
    let complete = s.steps.first() == Some(&0)
        && s.steps.windows(2).all(|w| w[0] < w[1])
        && ends.iter().all(|e| s.steps.binary_search(e).is_ok())
        && rec.rows == Some(s.rows.len());
    if !complete {
        return None;
    }
    let col = |h: &str| s.col(h);
    // results stored before the mobilised column existed read it as NaN
    let cols: Vec<Option<usize>> = crate::shear::ROW_COLUMNS.iter().map(|h| col(h)).collect();
    if cols[..9].iter().any(Option::is_none) {
        return None;
    }
    let rows: Vec<Row> = s
        .steps
        .iter()
        .zip(&s.rows)
        .map(|(st, r)| {
            let mut v = [f64::NAN; 10];
            for (k, c) in cols.iter().enumerate() {
                if let Some(c) = c {
                    v[k] = r[*c];
                }
            }
            Row::from_values(*st, v)
        })
        .collect();
    // results stored without a velocity profile are run again
    let profiles = serde_json::from_slice(&profile_bytes).ok()?;
    Some(CodeRun {
        rows,
        wall_time: rec.wall_time,
        steps: rec.steps,
        compacted: None,
        profiles,
        resumed_from: rec.resumed_from,
    })
}

pub(super) fn store(dir: &Path, code: &str, case: &ShearCase, run: &CodeRun) -> Result<Series> {
    let csv_path = dir.join(format!("{code}.csv"));
    let s = crate::shear::shear_series(case, &run.rows);
    let bytes = s.csv_bytes(&csv_path)?;
    write_atomic(&csv_path, &bytes)?;
    let profile = serde_json::to_string_pretty(&run.profiles)?;
    let rec = RunRecord {
        case: serde_json::to_string(case)?,
        wall_time: run.wall_time,
        steps: run.steps,
        rows: Some(s.rows.len()),
        sha256: Some(crate::fsutil::sha256_hex(&bytes)),
        profile_sha256: Some(crate::fsutil::sha256_hex(profile.as_bytes())),
        resumed_from: run.resumed_from.clone(),
    };
    write_atomic(
        &dir.join(format!("{code}_profile.csv")),
        crate::profile::csv(&run.profiles).as_bytes(),
    )?;
    // the run record last: a seed counts as done only with its profile stored
    write_atomic(
        &dir.join(format!("{code}_profile.json")),
        profile.as_bytes(),
    )?;
    write_atomic(
        &dir.join(format!("{code}_run.json")),
        serde_json::to_string_pretty(&rec)?.as_bytes(),
    )?;
    Ok(s)
}
