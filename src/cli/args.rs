//! Arguments shared by several commands (rolling model, engine, preset, where LIGGGHTS is),
//! apart from the dispatcher in cli/mod.rs so that the commands import these and not their
//! parent.

use crate::run::{Engine, LiggghtsRequest};
use crate::spec::shear::Preset;
use crate::spec::RollingModel;
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// Rolling models on the command line (LIGGGHTS' keywords and the native epsd_implicit).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RollingArg {
    Off,
    Cdt,
    Epsd,
    Epsd2,
    Epsd3,
    #[value(name = "epsd_implicit")]
    EpsdImplicit,
}

impl From<RollingArg> for RollingModel {
    fn from(r: RollingArg) -> Self {
        match r {
            RollingArg::Off => RollingModel::Off,
            RollingArg::Cdt => RollingModel::Cdt,
            RollingArg::Epsd => RollingModel::Epsd,
            RollingArg::Epsd2 => RollingModel::Epsd2,
            RollingArg::Epsd3 => RollingModel::Epsd3,
            RollingArg::EpsdImplicit => RollingModel::EpsdImplicit,
        }
    }
}

/// Which codes run (convergence, sweep).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EngineArg {
    Native,
    Liggghts,
    Both,
}

impl From<EngineArg> for Engine {
    fn from(e: EngineArg) -> Self {
        match e {
            EngineArg::Native => Engine::Native,
            EngineArg::Liggghts => Engine::Liggghts,
            EngineArg::Both => Engine::Both,
        }
    }
}

/// Shear presets on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PresetArg {
    Ci,
    Fast,
    Paper,
}

impl From<PresetArg> for Preset {
    fn from(p: PresetArg) -> Self {
        match p {
            PresetArg::Ci => Preset::Ci,
            PresetArg::Fast => Preset::Fast,
            PresetArg::Paper => Preset::Paper,
        }
    }
}

impl PresetArg {
    pub fn keyword(self) -> &'static str {
        Preset::from(self).keyword()
    }
}

/// Where LIGGGHTS is and how long one run may take (every command that runs it).
#[derive(Args, Debug, Clone, PartialEq)]
pub struct LiggghtsArgs {
    /// LIGGGHTS binary.
    #[arg(long, help_heading = "LIGGGHTS")]
    pub liggghts: Option<PathBuf>,
    /// Timeout of one LIGGGHTS run [s] (default: 600 for contact cases, 7 days for shear runs).
    #[arg(long, help_heading = "LIGGGHTS")]
    pub timeout: Option<u64>,
}

impl LiggghtsArgs {
    /// The request, with the study's default timeout when --timeout is not given.
    pub fn request(&self, default_timeout_s: u64) -> LiggghtsRequest {
        LiggghtsRequest {
            binary: self.liggghts.clone(),
            timeout_s: self.timeout.unwrap_or(default_timeout_s),
        }
    }
}

/// `verify run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// The study file (TOML: version, command, [options])
    pub study: PathBuf,
    /// Print the plan (runs, steps, estimated core-hours and disk) and stop
    #[arg(long)]
    pub dry_run: bool,
    /// Options that override the study's fields, as on the command line (after the file, with
    /// or without `--`)
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    pub overrides: Vec<String>,
}
