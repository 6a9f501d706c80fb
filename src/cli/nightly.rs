//! `verify nightly`: flags -> [`NightlyRequest`] -> [`crate::run::nightly`] (every contact case
//! and the nightly shear points in both codes, summary.json, history, the runs' figures as they
//! finish) -> report.html ([`write_page`]).

use crate::cli::args::LiggghtsArgs;
use crate::error::Result;
use crate::report::nightly::{write_page, NightFigures};
use crate::run::nightly::{rerender, run, NightlyRequest};
use crate::run::{Verdict, SHEAR_TIMEOUT_S};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct NightlyArgs {
    /// Output directory of this night (report.html, summary.json, every run's files).
    #[arg(long)]
    pub out: PathBuf,
    /// CI-sized night: the ci shear preset with one seed (minutes instead of hours).
    #[arg(long)]
    pub quick: bool,
    /// History file (JSON lines, one per case per night; default: history.jsonl next to --out).
    #[arg(long)]
    pub history: Option<PathBuf>,
    /// No runs: judge the stored night in --out again by this version's rules from its
    /// summary.json's per-seed figures and make its report.html again (summary.json is kept).
    #[arg(long, conflicts_with = "quick")]
    pub rerender: bool,
    #[command(flatten)]
    pub liggghts: LiggghtsArgs,
}

pub fn nightly(a: NightlyArgs) -> Result<Verdict> {
    let req = NightlyRequest {
        out: a.out,
        quick: a.quick,
        history: a.history,
        liggghts: a.liggghts.request(SHEAR_TIMEOUT_S),
    };
    let night = if a.rerender {
        rerender(&req)?
    } else {
        run(&req, &NightFigures)?
    };
    Ok(write_page(night, &req.out)?.verdict())
}
