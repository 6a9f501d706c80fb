//! The command line's grammar: the `verify` parser and its subcommands (clap), apart from the
//! dispatcher in cli/mod.rs, so that a study (cli/study.rs) can parse a command line without
//! importing the dispatcher that runs it.

use super::args::RunArgs;
use super::{bench, chung_ooi, contact, convergence, nightly, replay, shear, sweep};
use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "verify",
    version,
    about = "Native DEM solver cross-validated against LIGGGHTS 3.8.0",
    after_help = "Examples:\n  \
        verify contact --case rolling_plastic          # one case, every rolling model, live LIGGGHTS\n  \
        verify contact                                 # every built-in case\n  \
        verify contact --reference                     # against stored LIGGGHTS outputs, no LIGGGHTS needed\n  \
        verify contact --spec my_case.toml --rolling epsd2\n  \
        verify contact --list\n  \
        verify decks                                   # regenerate liggghts_inputs/\n  \
        verify shear --mu-r 0.5 --eta-r 0.5 --preset ci  # shear box, both codes, 3 seeds\n  \
        verify replay --mu-r 0.5 --preset ci             # the gouge contact by contact from LIGGGHTS' states\n  \
        verify nightly --out runs/nightly/today          # everything, report.html\n\n\
        Exit status: 0 agree, 1 disagree, 2 error, 3 inconclusive (a statistical verdict its seeds cannot decide)."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// Print one JSON document on stdout at the end (verdict, exit code, error, and the
    /// summary file the command wrote, parsed); everything else goes to stderr.
    #[arg(long, global = true)]
    pub json: bool,
    /// Under `mpirun`: how each native run is split into bricks, NXxNYxNZ along x, across
    /// the gap between the plates (y) and along z, their product the rank count (as LAMMPS'
    /// `processors`). Default: the split with the least boundary between the bricks.
    #[arg(long, global = true, value_name = "NXxNYxNZ", value_parser = parse_bricks)]
    pub bricks: Option<[usize; 3]>,
}

/// `--bricks`: three whole numbers from 1 to 4096 joined by `x`.
fn parse_bricks(s: &str) -> Result<[usize; 3], String> {
    let n: Vec<Option<usize>> = s
        .split('x')
        .map(|v| v.trim().parse().ok().filter(|n| (1..=4096).contains(n)))
        .collect();
    match n[..] {
        [Some(a), Some(b), Some(c)] => Ok([a, b, c]),
        _ => Err("expected NXxNYxNZ, three whole numbers from 1 to 4096, e.g. 2x1x1".into()),
    }
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Two-particle (and particle-wall) contact histories: native vs LIGGGHTS, channel by channel.
    #[command(after_help = "Examples:\n  \
        verify contact --case rolling_plastic            # one case, every model it lists, live LIGGGHTS\n  \
        verify contact --reference                       # every case against the stored LIGGGHTS outputs\n  \
        verify contact --spec my_case.toml --rolling epsd2\n\n\
        Exit status: 0 agree, 1 disagree, 2 error.")]
    Contact(contact::ContactArgs),
    /// The paper's shear box in LIGGGHTS and natively: plate forces, mu(strain), steady mu.
    #[command(after_help = "Examples:\n  \
        verify shear --mu-r 0.5 --eta-r 0.5 --preset ci   # both codes, 3 seeds, minutes\n  \
        verify shear --mu-r 0.5 --preset fast --native-only --seeds 6\n  \
        verify shear --preset paper --mu-r 1 --eta-r 0.5 --native-only   # hours; rerun to resume\n\n\
        Exit status: 0 agree, 1 disagree, 2 error, 3 inconclusive (the paired CI straddles the margin; the line before the verdict says how many seeds would decide).")]
    Shear(shear::ShearArgs),
    /// Time-step convergence: the same case from the same compacted state at smaller dt.
    #[command(after_help = "Examples:\n  \
        verify convergence --mu-r 1 --eta-r 0.5 --preset ci --dt-factors 1,0.5,0.25\n  \
        verify convergence --mu-r 1 --eta-r 0.5 --engine both --liggghts-dt-factors 1,0.5 --with-implicit\n\n\
        Exit status: 0 converged, 1 not converged, 2 error.")]
    // the shear flags that choose the codes are --engine here (given, they are refused)
    #[command(mut_arg("native_only", |a| a.hide(true)), mut_arg("liggghts_only", |a| a.hide(true)))]
    Convergence(convergence::ConvergenceArgs),
    /// Every contact case and the nightly shear cases in both codes: report.html, summary.json,
    /// history.
    #[command(after_help = "Examples:\n  \
        verify nightly --quick --out runs/nightly/quick   # minutes: ci preset, one seed\n  \
        tools/nightly.sh                                  # the full night into runs/nightly/<date>\n  \
        verify nightly --rerender --out reference/nightly/20261202-e1  # a stored night judged and drawn again\n\n\
        Exit status: 0 agree, 1 disagree, 2 error, 3 inconclusive.")]
    Nightly(nightly::NightlyArgs),
    /// The paper's parametric study: plan, run (resumable, N at a time), SLURM array, collect,
    /// report with the paper's figures and conclusions.
    #[command(after_help = "Examples:\n  \
        verify sweep --preset ci --mu-r 0,1 --eta-r 0,0.5 --seeds 2 --jobs 2 --out runs/sweep-ci\n  \
        verify sweep --emit slurm --out /scratch/sweep && sbatch /scratch/sweep/sweep.sbatch\n  \
        verify sweep report runs/sweep-ci --converged runs/conv-1-0.5")]
    Sweep(sweep::SweepArgs),
    /// The sheared gouge contact by contact: native restarted from LIGGGHTS' recorded states
    /// (histories included) and compared with LIGGGHTS' next steps.
    Replay(replay::ReplayArgs),
    /// Throughput of both codes on the same dense shear state (particle-steps per second).
    #[command(after_help = "Examples:\n  \
        verify bench --preset fast --steps 10000 --threads 1,2 --kernels scalar,avx2,avx512\n  \
        verify bench --preset fast --particles 250000 --native-only")]
    Bench(bench::BenchArgs),
    /// The Chung & Ooi (2011) DEM benchmark (tests 1-4, unequal radii) in both codes: each
    /// code against the benchmark's analytic values, and the codes against each other.
    #[command(after_help = "Examples:\n  \
        verify chung-ooi                          # every case, live LIGGGHTS, about 20 s\n  \
        verify chung-ooi --case chung_ooi_4       # the oblique impacts only\n\n\
        Exit status: 0 every figure within its tolerance and the codes agree, 1 otherwise, 2 error.")]
    ChungOoi(chung_ooi::ChungOoiArgs),
    /// The steady velocity profile of a finished native run from its ParaView snapshots: each
    /// grain's displacement between snapshots over each stage's steady window (x unwrapped
    /// across the periodic side), layers, slip at both plates and band width with 95 % CIs over
    /// 10 blocks, where 20 velocity samples cannot resolve them (at the paper's speeds a
    /// grain's velocity fluctuates 20-40 times the plate's); and per stage the paper's rotation
    /// map of the rotation each grain made over the steady window (one colour scale a run).
    #[command(after_help = "Examples:\n  \
        verify profile runs/shear-x/seed1      # writes native_displacement_profile.{csv,json}, displacement_profile.svg, rotation_map_stage<k>.svg\n\n\
        DIR holds case.toml, native.csv and vtk/native_*.vtu (a run with snapshots). \
        Exit status: 0 written, 2 error.")]
    Profile { dir: PathBuf },
    /// Write the LIGGGHTS decks of every built-in contact case (default: ./liggghts_inputs).
    Decks {
        #[arg(long, default_value = "liggghts_inputs")]
        out: PathBuf,
    },
    /// Print a shell completion script, e.g. `verify completions bash > ~/.local/share/bash-completion/completions/verify`.
    Completions {
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff), e.g. `verify man > verify.1 && man ./verify.1`.
    Man,
    /// Runs a study file (a command's options as TOML; see studies/): prints its plan
    /// (runs, steps, core-hours, disk), then runs it; flags after the file override its fields.
    #[command(after_help = "Examples:\n  \
        verify run studies/fast-map.toml --dry-run      # the plan only\n  \
        verify run runs/shear-x/study.toml              # repeat a run (finished parts reused)\n  \
        verify run studies/paper.toml --jobs 2          # a field overridden\n\n\
        Exit status: the command's (0 agree, 1 disagree, 2 error, 3 inconclusive).")]
    Run(RunArgs),
}
