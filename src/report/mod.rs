//! Verdicts to people: terminal tables, `summary.json`, SVG plots, VTK snapshots, progress.

pub mod bars;
pub mod contact;
pub mod convergence;
pub mod history;
pub mod html;
pub mod nightly;
pub mod paper;
pub mod plot;
pub mod progress;
pub mod replay;
pub mod rotation;
pub mod shear;
pub mod sweep;
pub mod vtk;

use crate::compare::ChannelResult;
use crate::error::Result;
use crate::fsutil::write_atomic;
use serde::Serialize;
use std::path::Path;

/// `summary.json` of `verify contact`.
#[derive(Clone, Debug, Serialize)]
pub struct ContactSummary {
    pub pass: bool,
    /// `live` (LIGGGHTS run now) or `reference` (stored LIGGGHTS outputs).
    pub against: String,
    pub liggghts_version: String,
    pub rtol: f64,
    pub results: Vec<ChannelResult>,
    /// Largest relative error per case and model.
    pub worst: Vec<Worst>,
    /// Runs that could not be compared (the others still ran and are in `results`).
    pub errors: Vec<CaseError>,
}

/// A run of a multi-case study that failed, with the error's text.
#[derive(Clone, Debug, Serialize)]
pub struct CaseError {
    pub case: String,
    pub model: String,
    pub error: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct Worst {
    pub case: String,
    pub model: String,
    pub channel: String,
    pub max_rel_err: f64,
    pub pass: bool,
}

impl ContactSummary {
    pub fn new(
        against: &str,
        liggghts_version: String,
        rtol: f64,
        results: Vec<ChannelResult>,
        errors: Vec<CaseError>,
    ) -> Self {
        let mut worst: Vec<Worst> = Vec::new();
        for r in &results {
            match worst
                .iter_mut()
                .find(|w| w.case == r.case && w.model == r.model)
            {
                Some(w) => {
                    if r.max_rel_err > w.max_rel_err || r.max_rel_err.is_nan() {
                        w.max_rel_err = r.max_rel_err;
                        w.channel = r.channel.clone();
                    }
                    w.pass &= r.pass;
                }
                None => worst.push(Worst {
                    case: r.case.clone(),
                    model: r.model.clone(),
                    channel: r.channel.clone(),
                    max_rel_err: r.max_rel_err,
                    pass: r.pass,
                }),
            }
        }
        ContactSummary {
            pass: results.iter().all(|r| r.pass) && !results.is_empty() && errors.is_empty(),
            against: against.into(),
            liggghts_version,
            rtol,
            results,
            worst,
            errors,
        }
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        write_atomic(path, serde_json::to_string_pretty(self)?.as_bytes())
    }
}

/// The per-channel table of one case run.
pub fn channel_table(results: &[ChannelResult]) -> String {
    let mut s = format!(
        "  {:<12} {:>12} {:>12} {:>12} {:>8}  {}\n",
        "channel", "peak", "max abs err", "max rel err", "at step", "verdict"
    );
    for r in results {
        s.push_str(&format!(
            "  {:<12} {:>12.4e} {:>12.3e} {:>12.3e} {:>8}  {}\n",
            format!("{} [{}]", r.channel, r.unit)
                .chars()
                .take(12)
                .collect::<String>(),
            r.peak,
            r.max_abs_err,
            r.max_rel_err,
            r.worst_step,
            if r.pass { "ok" } else { "FAIL" }
        ));
    }
    s
}

/// One line per case and model with its worst channel.
pub fn worst_table(summary: &ContactSummary) -> String {
    let mut s = format!(
        "{:<22} {:<6} {:<10} {:>12}  verdict (rtol {:.0e})\n",
        "case", "model", "worst", "max rel err", summary.rtol
    );
    for w in &summary.worst {
        s.push_str(&format!(
            "{:<22} {:<6} {:<10} {:>12.3e}  {}\n",
            w.case,
            w.model,
            w.channel,
            w.max_rel_err,
            if w.pass { "agree" } else { "DISAGREE" }
        ));
    }
    s
}
