//! Verdicts to people: terminal tables, SVG plots, HTML pages, VTK snapshots.

pub mod bars;
pub mod claim_rates;
pub mod contact;
pub mod convergence;
pub mod html;
pub mod nightly;
pub mod paper;
pub mod plot;
pub mod replay;
pub mod shear;
pub mod shear_text;
pub mod sweep;

use crate::compare::ChannelResult;

pub use crate::run::contact::{CaseError, ContactSummary, Worst};

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
