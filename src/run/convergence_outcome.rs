//! The outcome of a convergence study (`summary.json`), apart from the study so that the
//! report (src/report/convergence.rs) reads it without importing the study.

use super::Verdict;
use crate::compare::Steady;
use crate::spec::shear::Preset;
use crate::spec::stability_shear::StabilityReport;
use crate::spec::RollingModel;
use serde::{Deserialize, Serialize};

/// The codes a convergence study can run: LIGGGHTS, the native solver with the case's rolling
/// model, and the native solver with the stable-dashpot model `epsd_implicit`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StudyCode {
    Native,
    Liggghts,
    Implicit,
}

impl StudyCode {
    pub const ALL: [StudyCode; 3] = [StudyCode::Native, StudyCode::Liggghts, StudyCode::Implicit];
    pub fn keyword(self) -> &'static str {
        match self {
            StudyCode::Native => "native",
            StudyCode::Liggghts => "liggghts",
            StudyCode::Implicit => "implicit",
        }
    }
}

impl std::fmt::Display for StudyCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.keyword())
    }
}

/// Figures of one (dt, code).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DtPoint {
    pub code: StudyCode,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub dt_factor: f64,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub dt: f64,
    /// mu, stress, E_rot (with their CIs), ke and mobilisation over the steady window.
    pub steady: Steady,
    pub stability: StabilityReport,
}

/// The convergence verdict of one code.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CodeVerdict {
    pub code: StudyCode,
    pub finest_factor: f64,
    /// Its two smallest dt agree within their CIs.
    pub converged: bool,
    /// Largest factor from which every step to the next smaller dt agrees (when converged).
    pub largest_converged_factor: Option<f64>,
}

/// The outcome of a convergence study; its `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceSummary {
    /// [`super::SCHEMA`].
    pub schema: u32,
    /// The case studied (what `verify sweep report --converged` matches points by).
    pub preset: Preset,
    pub rolling: RollingModel,
    pub mu_r: f64,
    pub eta_r: f64,
    /// Index and speed [m/s] of the stage whose steady window is measured (the last one).
    pub stage: usize,
    pub speed: f64,
    pub converged: bool,
    /// Largest dt factor from which every step to the next smaller dt agrees within the CIs
    /// (over codes: the smallest such factor).
    pub largest_converged_factor: Option<f64>,
    pub points: Vec<DtPoint>,
    /// Per code: its finest dt factor, converged there or not, its largest converged factor.
    pub per_code: Vec<CodeVerdict>,
    /// Per dt factor where both codes ran: their steady mu agree within the CIs.
    pub codes_agree: Vec<(f64, bool)>,
    /// With --with-implicit: whether epsd_implicit at the largest dt agrees (within the CIs)
    /// with the native epsd result at the smallest dt.
    pub implicit_matches_finest: Option<bool>,
    pub date_utc: String,
}

impl ConvergenceSummary {
    pub fn verdict(&self) -> Verdict {
        Verdict::from_pass(self.converged)
    }
}

impl super::Versioned for ConvergenceSummary {
    fn schema(&self) -> u32 {
        self.schema
    }
}
