//! `verify`: parses the command line and maps the outcome to an exit code
//! (0 agree, 1 disagree, 2 error).

use clap::Parser;
use dem_verify::cli::{run, Cli};
use dem_verify::run::Verdict;
use std::process::ExitCode;

fn main() -> ExitCode {
    // `verify ... | head`: end quietly when the reader goes away, as Unix tools do, instead
    // of panicking on the broken pipe in println!
    // SAFETY: restores the default disposition of one signal before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // diagnostics on request only: RUST_LOG=trace (every particle-plate contact), =debug, ...
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("off")).init();
    // every comparing command ends with one verdict line (stdout), errors with one `error:`
    // line (stderr)
    match run(Cli::parse()) {
        Ok(Verdict::Agree) => {
            println!("verdict: agree");
            ExitCode::SUCCESS
        }
        Ok(Verdict::Disagree) => {
            println!("verdict: DISAGREE");
            ExitCode::from(1)
        }
        Ok(Verdict::Done) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
