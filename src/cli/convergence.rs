//! `verify convergence`: flags -> [`ConvergenceRequest`] -> [`crate::run::convergence`].
//! The same shear case from the same compacted state at successively smaller time steps.

use crate::cli::args::EngineArg;
use crate::cli::shear::ShearArgs;
use crate::error::{Error, Result};
use crate::run::convergence::{run, ConvergenceRequest};
use crate::run::Verdict;
use clap::Args;

#[derive(Args, Debug, Clone)]
pub struct ConvergenceArgs {
    /// The shear case: every `verify shear` option (preset, mu_r, eta_r, rolling, seeds, ...).
    #[command(flatten)]
    pub case: ShearArgs,
    /// Factors applied to the preset's dt, largest first.
    #[arg(long, value_delimiter = ',', default_value = "1,0.5,0.25")]
    pub dt_factors: Vec<f64>,
    /// native, liggghts or both.
    #[arg(long, value_enum, default_value = "native")]
    pub engine: EngineArg,
    /// The dt factors at which LIGGGHTS runs (with --engine liggghts|both); a subset of
    /// --dt-factors. Default: all of them. LIGGGHTS at the smallest dt is the costliest run.
    #[arg(long, value_delimiter = ',')]
    pub liggghts_dt_factors: Option<Vec<f64>>,
    /// Also run the native stable-dashpot model (`epsd_implicit`) at the largest dt factor,
    /// from the same compacted state: does it give at that dt what epsd gives converged?
    /// Only with --rolling epsd.
    #[arg(long)]
    pub with_implicit: bool,
}

impl ConvergenceArgs {
    /// The request these flags describe (what the run and a study's plan use).
    pub fn request(&self) -> ConvergenceRequest {
        ConvergenceRequest {
            shear: self.case.request(self.engine.into(), "convergence"),
            dt_factors: self.dt_factors.clone(),
            liggghts_dt_factors: self.liggghts_dt_factors.clone(),
            with_implicit: self.with_implicit,
        }
    }
}

pub fn convergence(a: ConvergenceArgs) -> Result<Verdict> {
    if a.case.native_only || a.case.liggghts_only {
        return Err(Error::invalid(
            "--native-only/--liggghts-only",
            "given",
            "--engine native|liggghts|both for verify convergence",
        ));
    }
    let req = a.request();
    let summary = run(&req)?;
    let out = &req.shear.out;
    crate::report::convergence::plots(out, &summary.points)?;
    println!(
        "  plots: {} and erot_dt.svg",
        out.join("mu_dt.svg").display()
    );
    Ok(summary.verdict())
}
