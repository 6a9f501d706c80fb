//! Command-line interface: the grammar (cli/command.rs, clap), then each command as a
//! function that returns a [`Verdict`]; this file dispatches. `main` maps verdicts to exit
//! codes: 0 agree, 1 disagree, 2 error, 3 inconclusive.

pub mod args;
pub mod bench;
pub mod chung_ooi;
pub mod command;
pub mod console;
pub mod contact;
pub mod convergence;
pub mod nightly;
pub mod replay;
pub mod shear;
pub mod study;
pub mod sweep;

pub use command::{Cli, Command};

use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::run::contact::write_decks;
use crate::run::Verdict;
use crate::solver::shear::pairs::KernelPath;
use clap::{ArgMatches, FromArgMatches};

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<Verdict> {
    match cli.command {
        Command::Contact(a) => contact::contact(a),
        Command::Shear(a) => shear::shear(a),
        Command::Bench(a) => bench::bench(a),
        Command::ChungOoi(a) => chung_ooi::chung_ooi(a),
        Command::Replay(a) => replay::replay(a),
        Command::Nightly(a) => nightly::nightly(a),
        Command::Sweep(a) => sweep::sweep(a),
        Command::Convergence(a) => convergence::convergence(a),
        Command::Run(a) => study::run_study(a, execute),
        Command::Profile { dir } => {
            let (profiles, maps) = crate::run::displacement::run(&dir)?;
            crate::report::shear::displacement_plot(
                &dir.join("displacement_profile.svg"),
                &profiles,
            )?;
            for p in &profiles {
                println!(
                    "stage {} ({} m/s): slip bottom {:+.4} ± {:.4}, top {:+.4} ± {:.4}, band width {:.3} mm ({} snapshots)",
                    p.stage + 1,
                    p.speed,
                    p.slip_bottom,
                    p.slip_bottom_ci95,
                    p.slip_top,
                    p.slip_top_ci95,
                    p.band_width * 1e3,
                    p.samples
                );
            }
            println!(
                "profiles: {}; {maps} stage rotation map(s): {}",
                dir.join("native_displacement_profile.csv").display(),
                dir.join("rotation_map_stage<k>.svg").display()
            );
            Ok(Verdict::Done)
        }
        Command::Decks { out } => {
            let n = write_decks(&out)?;
            println!("wrote {n} decks under {}", out.display());
            Ok(Verdict::Done)
        }
        Command::Completions { shell } => {
            use clap::CommandFactory;
            clap_complete::generate(shell, &mut Cli::command(), "verify", &mut std::io::stdout());
            Ok(Verdict::Done)
        }
        Command::Man => {
            use clap::CommandFactory;
            let mut out = Vec::new();
            clap_mangen::Man::new(Cli::command())
                .render(&mut out)
                .map_err(|e| Error::io("stdout", e))?;
            use std::io::Write;
            std::io::stdout()
                .write_all(&out)
                .map_err(|e| Error::io("stdout", e))?;
            Ok(Verdict::Done)
        }
    }
}

/// Runs parsed command-line matches; a command that wrote a summary also gets its resolved
/// study, `study.toml`, beside it.
pub fn execute(matches: &ArgMatches) -> Result<Verdict> {
    let cli = Cli::from_arg_matches(matches)
        .map_err(|e| Error::invalid("command line", "", e.to_string()))?;
    // a bad DEM_VERIFY_MAX_KERNEL is refused here, before any solver reads it
    KernelPath::max_from_env()?;
    if let Some(n) = cli.bricks {
        crate::ranks::choose_bricks(n)?;
    }
    let study = study::resolve(matches);
    let verdict = run(cli);
    if let (Some(study), Some(summary)) = (study, crate::run::summary_written()) {
        if let Some(dir) = summary.parent() {
            write_atomic(&dir.join("study.toml"), study.as_bytes())?;
        }
    }
    verdict
}
