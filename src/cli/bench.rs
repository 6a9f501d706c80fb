//! `verify bench`: flags -> [`BenchRequest`] -> [`crate::run::bench`].

use crate::cli::args::{LiggghtsArgs, PresetArg};
use crate::error::Result;
use crate::run::bench::{run, BenchRequest};
use crate::run::{out_or_default, Verdict, SHEAR_TIMEOUT_S};
use crate::solver::shear::KernelPath;
use clap::{Args, ValueEnum};

/// A pair-pass kernel path.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelArg {
    Scalar,
    Avx2,
    Avx512,
}

impl From<KernelArg> for KernelPath {
    fn from(k: KernelArg) -> Self {
        match k {
            KernelArg::Scalar => KernelPath::Scalar,
            KernelArg::Avx2 => KernelPath::Avx2,
            KernelArg::Avx512 => KernelPath::Avx512,
        }
    }
}
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Parameter preset of the state: fast or paper (same particles and materials).
    #[arg(long, value_enum, default_value = "fast")]
    pub preset: PresetArg,
    /// Timed steps per code.
    #[arg(long, default_value_t = 2000)]
    pub steps: u64,
    /// Native thread counts to measure.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    pub threads: Vec<usize>,
    /// Pair-pass kernel paths to measure (default: every path this CPU runs).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub kernels: Vec<KernelArg>,
    /// LIGGGHTS process counts to measure (2 runs `mpirun --allow-run-as-root -np 2`).
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    pub procs: Vec<usize>,
    /// Particle count: the 2500-particle sample tiled k x k times (rounded to a square).
    #[arg(long, default_value_t = 2500)]
    pub particles: usize,
    /// Compression steps that make the dense state.
    #[arg(long, default_value_t = 40_000)]
    pub compression_steps: u64,
    /// Skip LIGGGHTS (native only).
    #[arg(long)]
    pub native_only: bool,
    /// Rounds of every native and every LIGGGHTS run (in that order); the ratios are the
    /// medians of the rounds' ratios, robust to a machine whose speed drifts.
    #[arg(long, default_value_t = 1)]
    pub rounds: usize,
    /// MPI rank counts of the native runs (a build with the `mpi` feature): 1 in this
    /// process, more by `mpirun -np R` of this verify (e.g. `--ranks 1,2`).
    #[arg(long, value_delimiter = ',', default_value = "1")]
    pub ranks: Vec<usize>,
    #[command(flatten)]
    pub liggghts: LiggghtsArgs,
    /// Output directory (default: a new directory under ./runs/).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn bench(a: BenchArgs) -> Result<Verdict> {
    let req = BenchRequest {
        preset: a.preset.into(),
        steps: a.steps,
        threads: a.threads.clone(),
        kernels: if a.kernels.is_empty() {
            // every path this CPU runs, the fastest last
            KernelPath::available()
        } else {
            a.kernels.iter().map(|&k| k.into()).collect()
        },
        procs: a.procs.clone(),
        particles: a.particles,
        compression_steps: a.compression_steps,
        liggghts: (!a.native_only).then(|| a.liggghts.request(SHEAR_TIMEOUT_S)),
        rounds: a.rounds,
        ranks: a.ranks.clone(),
        out: out_or_default(a.out.as_deref(), "bench"),
    };
    run(&req)?;
    Ok(Verdict::Done)
}
