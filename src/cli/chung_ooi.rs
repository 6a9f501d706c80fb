//! `verify chung-ooi`: the Chung & Ooi (2011) benchmark ([`crate::chung_ooi`]) in both codes
//! -> [`crate::run::chung_ooi`] -> a line per figure and code, and the verdict.

use crate::cli::args::LiggghtsArgs;
use crate::error::Result;
use crate::run::chung_ooi::{run_all, select};
use crate::run::{out_or_default, Verdict, CONTACT_TIMEOUT_S};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct ChungOoiArgs {
    /// Only the cases whose name contains this (e.g. `chung_ooi_4`, `al_oxide`).
    #[arg(long)]
    pub case: Option<String>,
    /// Output directory (default: a new directory under ./runs/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub liggghts: LiggghtsArgs,
}

/// Runs `verify chung-ooi`.
pub fn chung_ooi(a: ChungOoiArgs) -> Result<Verdict> {
    let chosen = select(a.case.as_deref())?;
    let lig = a.liggghts.request(CONTACT_TIMEOUT_S).locate()?;
    let out = out_or_default(a.out.as_deref(), "chung-ooi");
    println!(
        "verify chung-ooi: Chung & Ooi (2011) tests 1-4 and unequal radii, native and live \
         LIGGGHTS, output {}",
        out.display()
    );
    println!(
        "{:<28} {:<8} {:<44} {:>12} {:>12} {:>10}",
        "case", "code", "figure", "benchmark", "measured", "tolerance"
    );
    let outcomes = run_all(&chosen, &lig, &out, |o| {
        for (code, checks) in [("native", &o.native), ("liggghts", &o.liggghts)] {
            for c in checks {
                let (expected, tol, mark) = if c.judged {
                    (
                        format!("{:.6e}", c.expected),
                        format!("{:.1e}", c.tolerance),
                        if c.pass { "ok" } else { "FAIL" },
                    )
                } else {
                    ("-".into(), "-".into(), "reported")
                };
                println!(
                    "{:<28} {:<8} {:<44} {:>12} {:>12.6e} {:>10} {mark}",
                    o.case.trim_start_matches("chung_ooi_"),
                    code,
                    c.figure,
                    expected,
                    c.measured,
                    tol
                );
            }
        }
        println!(
            "{:<28} codes: max |native - LIGGGHTS| {:e} over every channel and step ({})",
            o.case.trim_start_matches("chung_ooi_"),
            o.max_abs_diff,
            if o.codes_agree { "agree" } else { "DISAGREE" }
        );
    })?;
    let failed: Vec<&str> = outcomes
        .iter()
        .filter(|o| !o.pass())
        .map(|o| o.case.as_str())
        .collect();
    println!(
        "\n{} case(s), {} failed{}\nsummary: {}",
        outcomes.len(),
        failed.len(),
        if failed.is_empty() {
            String::new()
        } else {
            format!(": {}", failed.join(", "))
        },
        out.join("summary.json").display()
    );
    Ok(Verdict::from_pass(failed.is_empty()))
}
