//! The rows and summary of a night (`DIR/summary.json`, schema in docs/nightly.md), apart from the
//! orchestration so that the report (src/report/nightly.rs) reads them without importing it.

use crate::compare::Paired;
use crate::spec::shear::Preset;
use crate::spec::RollingModel;
use serde::{Deserialize, Serialize};

/// The machine the night ran on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Machine {
    pub hostname: String,
    pub cpu: String,
    pub cores: usize,
    pub memory_gib: f64,
    pub os: String,
    pub kernel: String,
}

impl Machine {
    /// The machine this process runs on (sysinfo; "unknown" for what it cannot tell).
    pub fn detect() -> Self {
        use sysinfo::{CpuRefreshKind, MemoryRefreshKind, RefreshKind, System};
        let sys = System::new_with_specifics(
            RefreshKind::nothing()
                .with_cpu(CpuRefreshKind::nothing())
                .with_memory(MemoryRefreshKind::nothing().with_ram()),
        )
        .ok();
        let known = |v: Option<String>| {
            v.map(|s| s.trim().to_string())
                .filter(|s| !s.is_empty())
                .unwrap_or_else(|| "unknown".into())
        };
        Machine {
            hostname: known(System::host_name().ok()),
            cpu: known(
                sys.as_ref()
                    .and_then(|s| s.cpus().first().map(|c| c.brand().to_string())),
            ),
            cores: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
            memory_gib: sys.as_ref().map_or(f64::NAN, |s| {
                s.total_memory() as f64 / (1024.0 * 1024.0 * 1024.0)
            }),
            os: known(System::long_os_version().ok()),
            kernel: known(System::kernel_version().ok()),
        }
    }

    pub fn describe(&self) -> String {
        format!(
            "{} ({}, {} cores, {:.0} GiB, {}, Linux {})",
            self.hostname, self.cpu, self.cores, self.memory_gib, self.os, self.kernel
        )
    }
}

/// The project's git commit (with `-dirty` for uncommitted changes), or why it is unknown.
pub fn git_commit() -> String {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .arg("-C")
            .arg(env!("CARGO_MANIFEST_DIR"))
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match git(&["rev-parse", "--short=12", "HEAD"]) {
        Some(c) => match git(&["status", "--porcelain", "--untracked-files=no"]) {
            Some(s) if !s.is_empty() => format!("{c}-dirty"),
            _ => c,
        },
        None => "unknown (not a git checkout)".into(),
    }
}

/// One contact run of the night.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactRow {
    pub case: String,
    pub model: String,
    pub pass: bool,
    pub error: Option<String>,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub max_rel_err: f64,
    pub worst_channel: String,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub rtol: f64,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub wall_s: f64,
    /// Run directory relative to the night's directory.
    pub dir: String,
}

/// One code's steady-state and cost figures in a shear case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CodeStats {
    /// mu (with CI and per seed), stress, E_rot, ke, mobilisation over the steady window.
    #[serde(flatten)]
    pub steady: crate::compare::Steady,
    /// The steady velocity profile of the last stage, mean over seeds (slip, band width).
    pub profile: Option<crate::profile::VelocityProfile>,
    /// Wall time summed over seeds [s] and mean throughput [particle-steps/s].
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub wall_s: f64,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub particle_steps_per_s: f64,
}

/// One shear case of the night.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShearRow {
    pub name: String,
    pub preset: Preset,
    pub rolling: RollingModel,
    pub mu_r: f64,
    pub eta_r: f64,
    pub seeds: u64,
    pub pass: bool,
    /// The row's statistical channels could not decide (its verdict is inconclusive);
    /// absent in nights before 2026-12-04.
    #[serde(default)]
    pub inconclusive: bool,
    pub error: Option<String>,
    /// |paired mean of mu_native - mu_LIGGGHTS| and its equivalence margin (stored nights
    /// before 2026-12-04: |difference of the means| and its fixed limit).
    pub dmu: Option<f64>,
    pub mu_atol: f64,
    pub ci_overlap: Option<bool>,
    /// Largest relative deviation of either code's mean normal stress from the target, and its
    /// limit.
    pub stress_rel_err: Option<f64>,
    pub stress_rtol: f64,
    pub liggghts: Option<CodeStats>,
    pub native: Option<CodeStats>,
    /// Shortest lockstep from the common compacted state over seeds [shear steps], and the
    /// chaos baseline (native vs native one ulp apart) of the same seeds.
    pub lockstep_steps: Option<u64>,
    pub chaos_baseline_steps: Option<u64>,
    /// Explicit rolling dashpot stable at this dt, and the worst stability line.
    pub dashpot_stable: Option<bool>,
    pub worst_stability: Option<String>,
    /// Per-seed steady mu, native - LIGGGHTS over the same seeds.
    pub paired_dmu: Option<Paired>,
    /// The equivalence test of that difference behind the row's steady-mu verdict (absent in
    /// nights before 2026-12-05 that were not judged again).
    #[serde(default)]
    pub mu_equivalence: Option<crate::compare::Equivalence>,
    /// `verify replay` of the same point (seed 1): the codes contact by contact.
    pub replay: Option<ReplayRow>,
    pub dir: String,
}

/// The replay of a nightly shear point, in one line.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReplayRow {
    pub pass: bool,
    pub windows: usize,
    pub steps: u64,
    /// Largest step-1 error over the windows (judged channels) and its limit.
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub worst_step1: f64,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub rtol: f64,
    /// Shortest horizon over the windows [steps].
    pub min_horizon: u64,
}

/// `DIR/summary.json` of `verify nightly` (schema in docs/nightly.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NightlySummary {
    pub schema: u32,
    pub pass: bool,
    pub quick: bool,
    pub date_utc: String,
    pub commit: String,
    pub liggghts_version: String,
    pub machine: Machine,
    pub wall_time_s: f64,
    /// The full night's budget [s] (None for quick nights).
    pub budget_s: Option<f64>,
    pub contact: Vec<ContactRow>,
    pub shear: Vec<ShearRow>,
    pub errors: Vec<String>,
    /// Set when the shear rows were judged again by a later version from their stored per-seed
    /// figures (`verify nightly --rerender`): which version, and when.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rejudged: Option<String>,
}

impl crate::run::Versioned for NightlySummary {
    fn schema(&self) -> u32 {
        self.schema
    }
}
