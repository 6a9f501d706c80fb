//! The run layer: one request and one typed outcome per study (contact, shear, convergence,
//! sweep, nightly, replay, bench). Commands build requests from their arguments and print
//! outcomes; sweep, nightly and convergence build requests of the studies they are made of and
//! use those outcomes in memory. Nothing here imports a command module.
//!
//! Data flows one way: request -> case (built once, by the spec layer) -> {deck + LIGGGHTS run,
//! native run} -> series -> comparison (one agreement rule, [`crate::compare`]) -> outcome.

pub mod bench;
pub mod chung_ooi;
pub mod contact;
pub mod convergence;
pub mod convergence_outcome;
pub mod displacement;
pub mod history;
pub mod limits;
pub mod nightly;
pub mod nightly_outcome;
pub mod progress;
pub mod replay;
pub mod scaling;
pub mod shear;
pub mod sweep;
pub mod tell;

pub use limits::{check_memory, check_threads, max_threads};

use crate::error::{Error, Result};
use crate::liggghts::Liggghts;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Version of the outcome and summary files (`summary.json`, `outcome.json`) written by the run
/// layer; readers refuse other versions.
pub const SCHEMA: u32 = 2;

/// The summary file the running command wrote last (what `--json` prints).
static SUMMARY: std::sync::Mutex<Option<PathBuf>> = std::sync::Mutex::new(None);

/// Records that a command wrote its summary (summary.json, bench.json, a sweep's report.json).
pub fn note_summary(path: &Path) {
    *SUMMARY.lock().unwrap_or_else(|e| e.into_inner()) = Some(path.to_path_buf());
}

/// The summary file noted last, if any.
pub fn summary_written() -> Option<PathBuf> {
    SUMMARY.lock().unwrap_or_else(|e| e.into_inner()).clone()
}

/// What a study concluded (a command's exit status: 0 agree, 1 disagree).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    Agree,
    Disagree,
    /// A statistical comparison whose data cannot decide (its CI straddles the margin): exit
    /// 3, `verdict: inconclusive` with the seeds that would decide.
    Inconclusive,
    /// A command that compares nothing (decks, lists, plans, completions): exit 0, no
    /// verdict line.
    Done,
}

impl Verdict {
    pub fn from_pass(pass: bool) -> Self {
        if pass {
            Verdict::Agree
        } else {
            Verdict::Disagree
        }
    }
}

/// Which codes a study runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Engine {
    Native,
    Liggghts,
    Both,
}

impl Engine {
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "native" => Ok(Engine::Native),
            "liggghts" => Ok(Engine::Liggghts),
            "both" => Ok(Engine::Both),
            _ => Err(Error::Unknown {
                what: "engine",
                name: s.into(),
                valid: "native, liggghts, both".into(),
            }),
        }
    }
    /// The CLI's word for it.
    pub fn keyword(self) -> &'static str {
        match self {
            Engine::Native => "native",
            Engine::Liggghts => "liggghts",
            Engine::Both => "both",
        }
    }
    pub fn runs_native(self) -> bool {
        self != Engine::Liggghts
    }
    pub fn runs_liggghts(self) -> bool {
        self != Engine::Native
    }
    /// CPU cores one run occupies (both codes run side by side).
    pub fn cores(self) -> usize {
        if self == Engine::Both {
            2
        } else {
            1
        }
    }
}

/// One of the two codes compared (ordered LIGGGHTS first, as every table lists them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Code {
    Liggghts,
    Native,
}

impl Code {
    pub const BOTH: [Code; 2] = [Code::Liggghts, Code::Native];

    pub fn keyword(self) -> &'static str {
        match self {
            Code::Liggghts => "liggghts",
            Code::Native => "native",
        }
    }
}

impl std::fmt::Display for Code {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.keyword())
    }
}

/// Where LIGGGHTS is and how long one of its runs may take.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LiggghtsRequest {
    /// The binary (default: `liggghts` on the PATH).
    pub binary: Option<PathBuf>,
    /// Timeout of one run [s].
    pub timeout_s: u64,
}

/// Default timeout of one LIGGGHTS run of a two-body contact case [s] (they take seconds).
pub const CONTACT_TIMEOUT_S: u64 = 600;
/// Default timeout of one LIGGGHTS shear-box run [s] (a paper-preset seed takes days).
pub const SHEAR_TIMEOUT_S: u64 = 7 * 24 * 3600;

impl LiggghtsRequest {
    /// Locates the binary (the one place the crate does): an error naming the install command
    /// when it is missing.
    pub fn locate(&self) -> Result<Liggghts> {
        Liggghts::locate(self.binary.as_deref(), Duration::from_secs(self.timeout_s))
    }
}

/// Where stored reference outputs are read and written when no `--reference-dir` is given:
/// `$DEM_VERIFY_REFERENCE`, else the `reference/` of the repository this binary was built
/// from (so `cargo install --path .` works from any directory while the clone exists), else
/// an error that says how to point at one.
pub fn default_reference_dir() -> Result<PathBuf> {
    if let Some(d) = std::env::var_os("DEM_VERIFY_REFERENCE") {
        return Ok(PathBuf::from(d));
    }
    let built = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/reference"));
    if built.is_dir() {
        return Ok(built);
    }
    Err(Error::Missing {
        what: format!(
            "the stored reference outputs (this binary was built from {}, which is gone; pass \
             --reference-dir DIR or set DEM_VERIFY_REFERENCE to a clone's reference/)",
            env!("CARGO_MANIFEST_DIR")
        ),
        dir: built,
    })
}

/// The default output directory of a study: `runs/<prefix>-<UTC stamp>`.
pub fn default_out(prefix: &str) -> PathBuf {
    PathBuf::from("runs").join(format!("{prefix}-{}", utc_stamp()))
}

/// The output directory asked for, or the study's default.
pub fn out_or_default(out: Option<&Path>, prefix: &str) -> PathBuf {
    out.map(Path::to_path_buf)
        .unwrap_or_else(|| default_out(prefix))
}

/// `YYYYmmdd-HHMMSS` in UTC.
pub fn utc_stamp() -> String {
    jiff::Timestamp::now().strftime("%Y%m%d-%H%M%S").to_string()
}

/// An outcome stored with a schema version.
pub trait Versioned: serde::de::DeserializeOwned {
    fn schema(&self) -> u32;
}

/// Reads a stored outcome (`summary.json`, `bench.json`), refusing other schema versions.
pub fn load<T: Versioned>(path: &Path) -> Result<T> {
    let v: T = serde_json::from_str(&crate::fsutil::read_to_string(path)?).map_err(|source| {
        Error::JsonFile {
            path: path.to_path_buf(),
            line: None,
            source,
        }
    })?;
    if v.schema() != SCHEMA {
        return Err(Error::invalid(
            format!("schema of {}", path.display()),
            v.schema(),
            SCHEMA.to_string(),
        ));
    }
    Ok(v)
}
