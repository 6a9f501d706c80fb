//! The outcome of a convergence study (`summary.json`), apart from the study so that the
//! report (src/report/convergence.rs) reads it without importing the study.

use super::Verdict;
use crate::compare::{Equivalence, Steady};
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
    /// Its two smallest dt are equivalent (the equivalence test `finest_step` agrees).
    pub converged: bool,
    /// The equivalence test of the steady mu at its two smallest dt, paired by seed (the
    /// same compacted state); None with one dt only.
    pub finest_step: Option<Equivalence>,
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
    /// Every deciding code's two smallest dt are equivalent within `mu_margin`.
    pub converged: bool,
    /// Some deciding code's two smallest dt can be neither shown equivalent nor different by
    /// its seeds (and none differs): the study is inconclusive (exit 3).
    pub inconclusive: bool,
    /// The equivalence margin of every comparison below (steady mu, absolute).
    pub mu_margin: f64,
    /// Largest dt factor from which every step to the next smaller dt is equivalent (over
    /// codes: the smallest such factor).
    pub largest_converged_factor: Option<f64>,
    pub points: Vec<DtPoint>,
    /// Per code: its finest dt factor, converged there or not, its largest converged factor.
    pub per_code: Vec<CodeVerdict>,
    /// Per dt factor where both codes ran: the equivalence test of native - LIGGGHTS.
    pub codes_agree: Vec<(f64, Equivalence)>,
    /// With --with-implicit: the equivalence test of epsd_implicit at the largest dt against
    /// the native epsd result at the smallest dt.
    pub implicit_matches_finest: Option<Equivalence>,
    pub date_utc: String,
}

impl ConvergenceSummary {
    pub fn verdict(&self) -> Verdict {
        if self.converged {
            Verdict::Agree
        } else if self.inconclusive {
            Verdict::Inconclusive
        } else {
            Verdict::Disagree
        }
    }
}

impl super::Versioned for ConvergenceSummary {
    fn schema(&self) -> u32 {
        self.schema
    }
}
