//! `verify replay`: flags -> [`ReplayRequest`] -> table, exit status. Thin: the work is in
//! [`crate::run::replay`].

use crate::cli::args::LiggghtsArgs;
use crate::error::{Error, Result};
use crate::report::replay::{plot, table};
use crate::run::replay::{default_states, run, ReplayRequest, REPLAY_TIMEOUT_S};
use crate::run::{out_or_default, Verdict};
use crate::spec::shear::{CaseRequest, Overrides, Preset, Protocol, ShearCase};
use crate::spec::RollingModel;
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// Rolling models LIGGGHTS has (epsd_implicit is native only and cannot be replayed).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ReplayRolling {
    Off,
    Cdt,
    Epsd,
    Epsd2,
    Epsd3,
}

impl From<ReplayRolling> for RollingModel {
    fn from(r: ReplayRolling) -> Self {
        match r {
            ReplayRolling::Off => RollingModel::Off,
            ReplayRolling::Cdt => RollingModel::Cdt,
            ReplayRolling::Epsd => RollingModel::Epsd,
            ReplayRolling::Epsd2 => RollingModel::Epsd2,
            ReplayRolling::Epsd3 => RollingModel::Epsd3,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ReplayPreset {
    Ci,
    Fast,
}

#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  \
    verify replay --mu-r 0.5 --eta-r 0 --preset ci\n  \
    verify replay --mu-r 0.5 --eta-r 0.5 --rolling epsd3 --restitution 1 --states 6 --steps 20\n  \
    verify replay --mu-r 0.5 --preset fast --at 30000,42017 --steps 5\n\n\
    Exit status: 0 agree, 1 disagree, 2 error.")]
pub struct ReplayArgs {
    /// Rolling friction coefficient mu_r.
    #[arg(long, default_value_t = 0.5)]
    pub mu_r: f64,
    /// Rolling viscous damping eta_r (epsd and epsd3 only).
    #[arg(long, default_value_t = 0.0)]
    pub eta_r: f64,
    #[arg(long, value_enum, default_value = "epsd")]
    pub rolling: ReplayRolling,
    #[arg(long, value_enum, default_value = "ci")]
    pub preset: ReplayPreset,
    /// Coefficient of restitution (the paper's: 1; 0.05 < e <= 1).
    #[arg(long)]
    pub restitution: Option<f64>,
    /// Seed of the initial packing.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of recorded states (half in compaction, half in the first shear steps).
    #[arg(long, default_value_t = 6)]
    pub states: usize,
    /// Steps replayed from each state.
    #[arg(long, default_value_t = 12)]
    pub steps: u64,
    /// Explicit window starts (steps), comma separated, instead of --states.
    #[arg(long, value_delimiter = ',', conflicts_with = "states")]
    pub at: Option<Vec<u64>>,
    /// Shear steps the default states spread over.
    #[arg(long, default_value_t = 20_000)]
    pub shear_span: u64,
    /// Step-1 tolerance: max |error| / channel peak.
    #[arg(long, default_value_t = crate::run::replay::STEP1_RTOL)]
    pub rtol: f64,
    /// Output directory (default: a new directory under ./runs/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub liggghts: LiggghtsArgs,
}

/// The request these flags describe (validated).
pub fn request(a: &ReplayArgs) -> Result<ReplayRequest> {
    let rolling: RollingModel = a.rolling.into();
    crate::spec::check_rolling_point(rolling, a.mu_r, a.eta_r)?;
    if !(a.rtol.is_finite() && a.rtol > 0.0 && a.rtol < 1.0) {
        return Err(Error::invalid("--rtol", a.rtol, "0 < rtol < 1"));
    }
    if !(1..=1000).contains(&a.steps) {
        return Err(Error::invalid("--steps", a.steps, "1 ..= 1000"));
    }
    if !(1..=200).contains(&a.states) {
        return Err(Error::invalid("--states", a.states, "1 ..= 200"));
    }
    let preset = match a.preset {
        ReplayPreset::Ci => Preset::Ci,
        ReplayPreset::Fast => Preset::Fast,
    };
    let (case, _) = ShearCase::build(&CaseRequest {
        preset,
        rolling,
        mu_r: a.mu_r,
        eta_r: a.eta_r,
        seed: a.seed,
        protocol: Protocol::default(),
        overrides: Overrides {
            restitution: a.restitution,
            ..Overrides::default()
        },
        allow_inertial: false,
    })?;
    let states = match &a.at {
        Some(v) => v.clone(),
        None => default_states(&case, a.states, a.steps, a.shear_span),
    };
    let out = out_or_default(a.out.as_deref(), "replay");
    Ok(ReplayRequest {
        case,
        states,
        steps: a.steps,
        rtol: a.rtol,
        out,
    })
}

pub fn replay(a: ReplayArgs) -> Result<Verdict> {
    let req = request(&a)?;
    let lig = a.liggghts.request(REPLAY_TIMEOUT_S).locate()?;
    std::fs::create_dir_all(&req.out).map_err(|e| Error::io(&req.out, e))?;
    let o = run(&req, &lig, |m| eprintln!("{m}"))?;
    plot(&req.out, &o)?;
    print!("{}", table(&o));
    println!(
        "summary: {}  plot: {}",
        req.out.join("summary.json").display(),
        req.out.join("error.svg").display()
    );
    Ok(Verdict::from_pass(o.pass))
}
