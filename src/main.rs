//! `verify`: parses the command line and maps the outcome to an exit code
//! (0 agree, 1 disagree, 2 error).

use clap::Parser;
use dem_verify::cli::{run, Cli, Outcome};
use std::process::ExitCode;

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(Outcome::Agree) => ExitCode::SUCCESS,
        Ok(Outcome::Disagree) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
