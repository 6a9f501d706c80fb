//! `verify shear`: flags -> [`ShearRequest`] -> the shear study ([`crate::run::shear`]) ->
//! printed figures, exit status.

use crate::cli::args::{LiggghtsArgs, PresetArg, RollingArg};
use crate::compare::{MU_MARGIN, STRESS_RTOL};
use crate::error::Result;
use crate::report::shear_text::{print_seed, print_summary};
use crate::run::shear::{run, ShearRequest};
use crate::run::{out_or_default, Engine, Verdict, SHEAR_TIMEOUT_S};
use crate::shear::{Checkpointing, CHECKPOINT_EVERY};
use crate::spec::shear::{CaseRequest, Overrides, Protocol};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct ShearArgs {
    /// Rolling friction coefficient mu_r.
    #[arg(long, default_value_t = 0.0, help_heading = "Case")]
    pub mu_r: f64,
    /// Rolling viscous damping eta_r (epsd and epsd3 only).
    #[arg(long, default_value_t = 0.0, help_heading = "Case")]
    pub eta_r: f64,
    /// Rolling model (the paper's: epsd).
    #[arg(long, value_enum, default_value = "epsd", help_heading = "Case")]
    pub rolling: RollingArg,
    /// Preset: ci (few hundred particles, minutes), fast (paper box, nightly), paper.
    #[arg(long, value_enum, default_value = "fast", help_heading = "Case")]
    pub preset: PresetArg,
    /// Number of seeds (initial packings).
    #[arg(long, default_value_t = 3, help_heading = "Case")]
    pub seeds: u64,
    /// First seed: runs seeds first-seed ..= first-seed + seeds - 1.
    #[arg(long, default_value_t = 1, help_heading = "Case")]
    pub first_seed: u64,
    #[command(flatten)]
    pub protocol: ProtocolArgs,
    /// Threads of the native solver (default: all cores, minus one while LIGGGHTS runs).
    #[arg(long, help_heading = "Run")]
    pub threads: Option<usize>,
    /// Output directory (default: a new directory under ./runs/).
    #[arg(long, help_heading = "Run")]
    pub out: Option<PathBuf>,
    /// Run only the native solver.
    #[arg(long, conflicts_with = "liggghts_only", help_heading = "Run")]
    pub native_only: bool,
    /// Run only LIGGGHTS.
    #[arg(long, help_heading = "Run")]
    pub liggghts_only: bool,
    /// Allow stages with inertial number I > 1e-3.
    #[arg(long, help_heading = "Checks")]
    pub allow_inertial: bool,
    /// Write particle and plate snapshots for ParaView (.vtu tied by seedN/vtk/<code>.pvd) every
    /// N steps (0: the preset's choice: ci 10,000, fast 50,000, paper 100,000).
    #[arg(long, default_value_t = 0, help_heading = "Run")]
    pub snapshot_every: u64,
    /// Refuse to run (exit 2) when the explicit rolling dashpot is expected to be unstable.
    #[arg(long, help_heading = "Checks")]
    pub strict_stability: bool,
    /// Flat plates instead of plates with teeth (flat plates let the gouge slip).
    #[arg(long, help_heading = "Changes to the preset")]
    pub flat_plates: bool,
    /// Wall time between checkpoints of each native run [s] (default 300; 0: at every output
    /// step; -1: none); LIGGGHTS runs longer than that write restart files about as often.
    /// Rerunning the same command resumes from them.
    #[arg(long, allow_negative_numbers = true, value_parser = checkpoint_seconds, help_heading = "Run")]
    pub checkpoint_every: Option<f64>,
    /// Tooth height [m] of the plates (default 2e-4).
    #[arg(long, help_heading = "Changes to the preset")]
    pub tooth_height: Option<f64>,
    /// Tooth wavelength [m] along x; box_x must hold a whole number of teeth (default 5e-4).
    #[arg(long, help_heading = "Changes to the preset")]
    pub tooth_wavelength: Option<f64>,
    /// Particle count (the preset's box is scaled in x and z to keep the sample height).
    #[arg(long, help_heading = "Changes to the preset")]
    pub particles: Option<usize>,
    /// Coefficient of normal restitution (the presets use the paper's Table 2: 1, no normal
    /// damping). LIGGGHTS accepts 0.05 < e <= 1.
    #[arg(long, help_heading = "Changes to the preset")]
    pub restitution: Option<f64>,
    /// Sliding friction coefficient mu_p (the presets use the paper's 0.5); in (0, 10].
    #[arg(long, help_heading = "Changes to the preset")]
    pub friction: Option<f64>,
    /// epsd3's rolling stiffness factor (k_r = factor kn mu_r^2 R*^2; epsd's is 2.25), with
    /// `--rolling epsd3` only; in [1, 100].
    #[arg(long, help_heading = "Changes to the preset")]
    pub rolling_stiffness: Option<f64>,
    /// Equivalence margin of steady mu: the codes agree when the 90 % CI of the seed-paired
    /// difference native - LIGGGHTS lies within +-margin, DISAGREE when it lies wholly beyond,
    /// and the verdict is inconclusive (exit 3) otherwise (docs/verdicts.md).
    #[arg(long, visible_alias = "mu-atol", default_value_t = MU_MARGIN, help_heading = "Checks")]
    pub mu_margin: f64,
    /// Largest accepted relative deviation of each code's mean normal stress (steady window,
    /// mean over seeds) from the target. One seed of the ci preset fluctuates by about 1-2 %.
    #[arg(long, default_value_t = STRESS_RTOL, help_heading = "Checks")]
    pub stress_rtol: f64,
    #[command(flatten)]
    pub liggghts: LiggghtsArgs,
}

/// Changes to a preset's shear protocol, shared by `verify shear`, `verify sweep` and
/// `verify convergence` ([`Protocol`]).
#[derive(Args, Debug, Clone, PartialEq)]
pub struct ProtocolArgs {
    /// Shear speeds [m/s], comma separated: stages in sequence, as in the paper (replaces the
    /// preset's stages).
    #[arg(long, value_delimiter = ',', help_heading = "Changes to the preset")]
    pub speeds: Option<Vec<f64>>,
    /// Shear strain of each stage (replaces the preset's).
    #[arg(long, help_heading = "Changes to the preset")]
    pub strain: Option<f64>,
    /// Time step as a multiple of the preset's (compression steps and output interval scale
    /// with 1 / factor, so the same physical time and strain are covered): runs a case at a
    /// converged dt, e.g. 0.25.
    #[arg(long, default_value_t = 1.0, help_heading = "Changes to the preset")]
    pub dt_factor: f64,
}

impl From<&ProtocolArgs> for Protocol {
    fn from(p: &ProtocolArgs) -> Self {
        Protocol {
            speeds: p.speeds.clone(),
            strain: p.strain,
            dt_factor: p.dt_factor,
        }
    }
}

impl ShearArgs {
    /// The engine the flags ask for.
    pub fn engine(&self) -> Engine {
        match (self.native_only, self.liggghts_only) {
            (true, _) => Engine::Native,
            (_, true) => Engine::Liggghts,
            _ => Engine::Both,
        }
    }

    /// The case the flags describe (its seed: --first-seed).
    pub fn case_request(&self) -> CaseRequest {
        CaseRequest {
            preset: self.preset.into(),
            rolling: self.rolling.into(),
            mu_r: self.mu_r,
            eta_r: self.eta_r,
            seed: self.first_seed,
            protocol: (&self.protocol).into(),
            overrides: Overrides {
                snapshot_every: self.snapshot_every,
                restitution: self.restitution,
                friction: self.friction,
                rolling_stiffness: self.rolling_stiffness,
                flat_plates: self.flat_plates,
                tooth_height: self.tooth_height,
                tooth_wavelength: self.tooth_wavelength,
                particles: self.particles,
            },
            allow_inertial: self.allow_inertial,
        }
    }

    /// The request the flags describe, run by `engine`, written to `prefix`'s default
    /// directory when --out is not given.
    pub fn request(&self, engine: Engine, prefix: &str) -> ShearRequest {
        ShearRequest {
            case: self.case_request(),
            seeds: self.seeds,
            engine,
            threads: self.threads,
            out: out_or_default(self.out.as_deref(), prefix),
            quiet: false,
            progress_label: None,
            strict_stability: self.strict_stability,
            mu_margin: self.mu_margin,
            stress_rtol: self.stress_rtol,
            liggghts: self.liggghts.request(SHEAR_TIMEOUT_S),
            checkpoint: match self.checkpoint_every {
                None => Checkpointing::Every(CHECKPOINT_EVERY),
                Some(s) if s < 0.0 => Checkpointing::Off,
                Some(s) => Checkpointing::Every(std::time::Duration::from_secs_f64(s)),
            },
        }
    }
}

/// `verify shear`: runs, prints, writes `summary.json`; the verdict of its comparisons.
pub fn shear(a: ShearArgs) -> Result<Verdict> {
    let req = a.request(a.engine(), &format!("shear-{}", a.preset.keyword()));
    let summary = run(&req, &print_seed)?;
    crate::report::shear::figures(&req.out, &summary)?;
    print_summary(&summary, &req.out);
    Ok(summary.verdict())
}

/// `--checkpoint-every`: -1 (none) or 0 ..= 1e6 seconds.
fn checkpoint_seconds(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
    if v == -1.0 || (0.0..=1e6).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{v}: valid are -1 (no checkpoints) and 0 ..= 1e6 seconds"
        ))
    }
}
