//! `verify`: parses the command line and maps the outcome to an exit code
//! (0 agree, 1 disagree, 2 error, 3 inconclusive).
#![warn(clippy::undocumented_unsafe_blocks, clippy::missing_safety_doc)]

use clap::CommandFactory;
use dem_verify::cli::{execute, Cli};
use dem_verify::run::{summary_written, Verdict};
use std::io::Write;
use std::os::fd::FromRawFd;
use std::process::ExitCode;

fn main() -> ExitCode {
    // `verify ... | head`: end quietly when the reader goes away, as Unix tools do, instead
    // of panicking on the broken pipe in println!
    // SAFETY: restores the default disposition of one signal before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // glibc serves an allocation below its mmap threshold from the heap, and raises that
    // threshold (up to 32 MB) whenever a mapped block is freed; freed heap blocks in the
    // middle of the heap stay resident. The solver's arrays (5-60 MB at 250,000 particles)
    // are freed and made again at every neighbour rebuild, so with the sliding threshold
    // each rebuild left some resident. Measured (`verify bench --particles 250000`): the
    // solver's peak 1,034 bytes per particle without and 942 with this fixed 1 MB
    // threshold, at the same speed.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: an allocator setting made before any thread exists or allocates in parallel.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 20);
    }
    // under mpirun (the `mpi` feature): rank 0 runs the command, each native run decomposed
    // over the ranks; the other ranks serve those runs and end with it (issue #39)
    let _lead = match dem_verify::ranks::start() {
        dem_verify::ranks::Start::Alone => None,
        dem_verify::ranks::Start::Lead(lead) => Some(lead),
        dem_verify::ranks::Start::Refused(why) => {
            eprintln!("error: {why}");
            return ExitCode::from(2);
        }
        #[cfg(feature = "mpi")]
        dem_verify::ranks::Start::Serve(world) => {
            dem_verify::shear::serve(&world);
            drop(world);
            dem_verify::ranks::finish();
            return ExitCode::SUCCESS;
        }
    };
    // diagnostics on request only: RUST_LOG=trace (every particle-plate contact), =debug, ...
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("off")).init();
    // what the library says (a command's account, warnings, progress) goes to the terminal
    dem_verify::cli::console::install();
    let matches = match Cli::command().try_get_matches() {
        Ok(m) => m,
        Err(e) => {
            // --json promises one document on stdout, a refusal at the parser included
            let wants_json = std::env::args().any(|a| a == "--json");
            let refusal = !matches!(
                e.kind(),
                clap::error::ErrorKind::DisplayHelp
                    | clap::error::ErrorKind::DisplayVersion
                    | clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            );
            if wants_json && refusal {
                let text = e.render().to_string();
                eprint!("{text}");
                let first = text
                    .lines()
                    .next()
                    .unwrap_or("")
                    .trim_start_matches("error: ");
                let doc = serde_json::json!({
                    "verdict": "error",
                    "exit_code": 2,
                    "error": first,
                    "summary_file": null,
                    "summary": null,
                });
                println!("{doc}");
                return ExitCode::from(2);
            }
            e.exit()
        }
    };
    // --json: stdout holds one JSON document; every line the command prints goes to stderr
    // (file descriptor 1 pointed at stderr, the real stdout kept for the document)
    let json_out = matches.get_flag("json").then(|| {
        // SAFETY: plain descriptor duplication before any thread exists; both descriptors
        // are valid for the whole process
        unsafe {
            let saved = libc::dup(1);
            libc::dup2(2, 1);
            std::fs::File::from_raw_fd(saved)
        }
    });
    // every comparing command ends with one verdict line (stdout), errors with one `error:`
    // line (stderr)
    let outcome = execute(&matches);
    let (code, word, error) = match &outcome {
        Ok(Verdict::Agree) => {
            println!("verdict: agree");
            (0, "agree", None)
        }
        Ok(Verdict::Disagree) => {
            println!("verdict: DISAGREE");
            (1, "disagree", None)
        }
        Ok(Verdict::Inconclusive) => {
            println!("verdict: inconclusive");
            (3, "inconclusive", None)
        }
        Ok(Verdict::Done) => (0, "done", None),
        Err(e) => {
            eprintln!("error: {e}");
            (2, "error", Some(e.to_string()))
        }
    };
    if let Some(mut out) = json_out {
        let _ = std::io::stdout().flush();
        let file = summary_written();
        let summary = file
            .as_ref()
            .and_then(|p| std::fs::read_to_string(p).ok())
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
        let doc = serde_json::json!({
            "verdict": word,
            "exit_code": code,
            "error": error,
            "summary_file": file,
            "summary": summary,
        });
        let _ = writeln!(out, "{doc}");
    }
    ExitCode::from(code)
}
