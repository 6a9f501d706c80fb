//! The one error type of the crate. Every variant carries enough context (field, valid range,
//! file, step, log tail) for a user to fix the cause without reading code.

use std::path::PathBuf;

/// All errors the harness reports. `main` maps any of them to exit code 2.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A case or command-line value outside its valid range.
    #[error("invalid value for `{field}`: {value} (valid: {valid})")]
    Invalid {
        field: String,
        value: String,
        valid: String,
    },
    /// A name (case, model, preset) that is not known; lists the valid ones.
    #[error("unknown {what} `{name}`; valid: {valid}")]
    Unknown {
        what: &'static str,
        name: String,
        valid: String,
    },
    /// A case file that is not valid TOML or has unknown/missing fields.
    #[error("cannot read case file {path}: {source}")]
    CaseFile {
        path: PathBuf,
        source: toml::de::Error,
    },
    /// The LIGGGHTS binary could not be found.
    #[error(
        "LIGGGHTS binary `{binary}` not found. Install it with\n  \
         apt-get update && apt-get install -y liggghts libliggghts-dev\n\
         or pass --liggghts PATH. Without LIGGGHTS: `verify contact --reference` compares \
         against its stored outputs, `verify shear --native-only` runs the native solver alone"
    )]
    LiggghtsMissing { binary: String },
    /// LIGGGHTS ran but failed (non-zero exit, timeout, or missing outputs).
    #[error("LIGGGHTS run failed: {reason}\n--- tail of {log} ---\n{tail}")]
    LiggghtsFailed {
        reason: String,
        log: PathBuf,
        tail: String,
    },
    /// A LIGGGHTS output file that could not be parsed.
    #[error("study file {path} is not valid TOML: {msg}")]
    StudyFile { path: PathBuf, msg: String },
    #[error("cannot parse LIGGGHTS output {path}: {msg}")]
    Parse { path: PathBuf, msg: String },
    /// The native solver reached a non-finite or unsupported state.
    #[error("native solver stopped at step {step}: {msg}")]
    Solver { step: u64, msg: String },
    /// Stored LIGGGHTS reference data missing or inconsistent.
    #[error("reference data at {path}: {msg}")]
    Reference { path: PathBuf, msg: String },
    /// Two series that cannot be compared (other columns, other output steps).
    #[error("series cannot be compared: {0}")]
    Mismatch(String),
    /// Results a study wrote and then needs are not there (or not complete).
    #[error("{what} missing in {dir}")]
    Missing { what: String, dir: PathBuf },
    #[error("I/O error on {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("CSV error on {path}: {source}")]
    Csv { path: PathBuf, source: csv::Error },
    /// A CSV that reads but is not what it should be (header, numbers).
    #[error("CSV file {path}: {msg}")]
    CsvFormat { path: PathBuf, msg: String },
    /// A JSON file of ours (summary, manifest, history) that does not parse.
    #[error("cannot parse {path}{}: {source}", line.map(|l| format!(" line {l}")).unwrap_or_default())]
    JsonFile {
        path: PathBuf,
        line: Option<usize>,
        source: serde_json::Error,
    },
    /// A run of several cases in which some could not be run (each named in the message).
    #[error("{0}")]
    Cases(String),
    /// A run over MPI ranks that failed (the launcher, or a rank), with its log's tail.
    #[error("{0}")]
    Ranks(String),
    #[error("JSON error: {0}")]
    Json(#[from] serde_json::Error),
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// Shorthand for [`Error::Invalid`].
    pub fn invalid(
        field: impl Into<String>,
        value: impl ToString,
        valid: impl Into<String>,
    ) -> Self {
        Error::Invalid {
            field: field.into(),
            value: value.to_string(),
            valid: valid.into(),
        }
    }
    /// Wraps an I/O error with the path it happened on.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

/// A drawing error of an in-memory SVG (plotters), as an I/O error: the one conversion of the
/// report's figures and the runs' rotation maps.
pub(crate) fn draw_err(e: impl std::fmt::Display) -> Error {
    Error::io("(SVG in memory)", std::io::Error::other(e.to_string()))
}
