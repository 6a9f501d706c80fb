//! The nightly history: one JSON line per case per night, appended atomically (the whole file is
//! rewritten to a temporary file and renamed), so a failed or interrupted night never leaves a
//! torn line behind and the report can always read every earlier night.

use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One case of one night.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// UTC start of the night, `YYYYMMDD-HHMMSS`.
    pub night: String,
    /// Seconds since the Unix epoch at the start of the night (the trend plots' time axis).
    pub unix_time: u64,
    /// The night's output directory; a resumed night replaces the records it wrote before.
    pub out: String,
    pub quick: bool,
    pub commit: String,
    pub liggghts_version: String,
    /// `contact` or `shear`.
    pub kind: String,
    /// e.g. `rolling_plastic/epsd` or `fast/epsd mu_r=0.5 eta_r=0.5`.
    pub case: String,
    pub pass: bool,
    /// Set when the case could not be run or compared.
    pub error: Option<String>,
    /// Contact: largest relative error over channels; shear: |mu_LIGGGHTS - mu_native|.
    pub max_err: Option<f64>,
    pub tolerance: f64,
    pub mu_liggghts: Option<f64>,
    pub mu_liggghts_ci95: Option<f64>,
    pub mu_native: Option<f64>,
    pub mu_native_ci95: Option<f64>,
}

/// Reads every record; lines that do not parse (e.g. written by a future schema) are reported
/// as an error naming the line, never silently dropped.
pub fn read(path: &Path) -> Result<Vec<Record>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(path, e)),
    };
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(k, l)| {
            serde_json::from_str(l).map_err(|source| Error::JsonFile {
                path: path.to_path_buf(),
                line: Some(k + 1),
                source,
            })
        })
        .collect()
}

/// Appends `records` atomically: existing content plus the new lines go to a temporary file
/// that replaces the history in one rename. Records of earlier attempts of the same night (same
/// output directory, an interrupted night resumed) are replaced. Returns every record.
pub fn append(path: &Path, records: &[Record]) -> Result<Vec<Record>> {
    let mut all = read(path)?;
    all.retain(|r| !records.iter().any(|n| n.out == r.out));
    all.extend_from_slice(records);
    let mut text = String::new();
    for r in &all {
        text += &serde_json::to_string(r)?;
        text.push('\n');
    }
    write_atomic(path, text.as_bytes())?;
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(night: &str, case: &str) -> Record {
        Record {
            night: night.into(),
            unix_time: 1,
            out: format!("runs/{night}"),
            quick: true,
            commit: "abc".into(),
            liggghts_version: "3.8.0".into(),
            kind: "contact".into(),
            case: case.into(),
            pass: true,
            error: None,
            max_err: Some(0.0),
            tolerance: 1e-9,
            mu_liggghts: None,
            mu_liggghts_ci95: None,
            mu_native: None,
            mu_native_ci95: None,
        }
    }

    #[test]
    fn appends_nights_and_refuses_a_torn_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("h/history.jsonl");
        assert!(read(&p).unwrap().is_empty());
        append(&p, &[rec("n1", "a"), rec("n1", "b")]).unwrap();
        let all = append(&p, &[rec("n2", "a")]).unwrap();
        assert_eq!(all.len(), 3);
        assert_eq!(read(&p).unwrap(), all);
        assert_eq!(std::fs::read_dir(p.parent().unwrap()).unwrap().count(), 1);
        // a resumed night replaces its own earlier records
        let all = append(&p, &[rec("n2", "a"), rec("n2", "b")]).unwrap();
        assert_eq!(all.len(), 4);
        std::fs::write(&p, "{\"night\": \"n1\"").unwrap();
        let e = append(&p, &[rec("n3", "a")]).unwrap_err().to_string();
        assert!(e.contains("line 1"), "{e}");
        // the bad file is left as it was, not overwritten
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "{\"night\": \"n1\"");
    }
}
