//! Command-line interface: argument parsing (clap), then each command as a function that
//! returns an [`Outcome`]. `main` maps outcomes to exit codes: 0 agree, 1 disagree, 2 error.

use crate::compare::{compare, ChannelResult, CONTACT_RTOL};
use crate::deck::{contact_deck, run_name, Deck};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::{read_contact_frames, Liggghts, LOG_NAME};
use crate::report::{channel_table, worst_table, ContactSummary};
use crate::series::{contact_series, Series};
use crate::solver::two_body;
use crate::spec::{builtin_case, builtin_names, Case, CaseFile, RollingModel, BUILTIN_CASES};
use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What a command concluded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Agree,
    Disagree,
}

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
        Exit status: 0 agree, 1 disagree, 2 error."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Two-particle (and particle-wall) contact histories: native vs LIGGGHTS, channel by channel.
    Contact(ContactArgs),
    /// The paper's shear box in LIGGGHTS and natively: plate forces, mu(strain), steady mu.
    Shear(crate::cli_shear::ShearArgs),
    /// Time-step convergence: the same case from the same compacted state at smaller dt.
    Convergence(crate::cli_convergence::ConvergenceArgs),
    /// Every contact case and the nightly shear cases in both codes: report.html, summary.json,
    /// history.
    Nightly(crate::cli_nightly::NightlyArgs),
    /// The paper's parametric study: plan, run (resumable, N at a time), SLURM array, collect,
    /// report with the paper's figures and conclusions.
    Sweep(crate::cli_sweep::SweepArgs),
    /// The sheared gouge contact by contact: native restarted from LIGGGHTS' recorded states
    /// (histories included) and compared with LIGGGHTS' next steps.
    Replay(crate::cli_replay::ReplayArgs),
    /// Throughput of both codes on the same dense shear state (particle-steps per second).
    Bench(crate::bench::BenchArgs),
    /// Write the LIGGGHTS decks of every built-in contact case (default: ./liggghts_inputs).
    Decks {
        #[arg(long, default_value = "liggghts_inputs")]
        out: PathBuf,
    },
}

#[derive(Args, Debug)]
pub struct ContactArgs {
    /// Built-in case name, or `all`.
    #[arg(long, default_value = "all", conflicts_with = "spec")]
    pub case: String,
    /// A case file (TOML) of your own instead of a built-in case.
    #[arg(long)]
    pub spec: Option<PathBuf>,
    /// Rolling model: off, cdt, epsd, epsd2, epsd3, or `all` (those the case lists).
    #[arg(long, default_value = "all")]
    pub rolling: String,
    /// Relative tolerance: max |error| / channel peak.
    #[arg(long, default_value_t = CONTACT_RTOL)]
    pub rtol: f64,
    /// Output directory (default: a new directory under ./runs/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Compare against the stored LIGGGHTS outputs in reference/ instead of running LIGGGHTS.
    #[arg(long)]
    pub reference: bool,
    /// Run LIGGGHTS and store its outputs as the new reference (with provenance).
    #[arg(long, conflicts_with = "reference")]
    pub update_reference: bool,
    /// Directory of stored reference outputs.
    #[arg(long, default_value = concat!(env!("CARGO_MANIFEST_DIR"), "/reference"))]
    pub reference_dir: PathBuf,
    /// List the built-in cases and exit.
    #[arg(long)]
    pub list: bool,
    /// LIGGGHTS binary.
    #[arg(long)]
    pub liggghts: Option<PathBuf>,
    /// Timeout of one LIGGGHTS run [s].
    #[arg(long, default_value_t = 600)]
    pub timeout: u64,
}

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<Outcome> {
    match cli.command {
        Command::Contact(a) => contact(a),
        Command::Shear(a) => crate::cli_shear::shear(a),
        Command::Bench(a) => crate::bench::bench(a),
        Command::Replay(a) => crate::cli_replay::replay(a),
        Command::Nightly(a) => crate::cli_nightly::nightly(a),
        Command::Sweep(a) => crate::cli_sweep::sweep(a),
        Command::Convergence(a) => crate::cli_convergence::convergence(a),
        Command::Decks { out } => {
            let n = write_decks(&out)?;
            println!("wrote {n} decks under {}", out.display());
            Ok(Outcome::Agree)
        }
    }
}

/// The (case, rolling model) runs a `verify contact` invocation asks for, validated.
pub fn contact_runs(case: &str, spec: Option<&Path>, rolling: &str) -> Result<Vec<Case>> {
    let files: Vec<CaseFile> = match spec {
        Some(p) => vec![CaseFile::load(p)?],
        None if case == "all" => builtin_names().map(builtin_case).collect::<Result<_>>()?,
        None => vec![builtin_case(case)?],
    };
    let mut runs = Vec::new();
    for f in files {
        let models = if rolling == "all" {
            f.applicable_rolling()
        } else {
            vec![RollingModel::parse(rolling)?]
        };
        for m in models {
            runs.push(f.with_rolling(m).validate()?);
        }
    }
    Ok(runs)
}

/// Writes the decks of every built-in case and rolling model under `out/contact/`.
pub fn write_decks(out: &Path) -> Result<usize> {
    let runs = contact_runs("all", None, "all")?;
    for c in &runs {
        write_deck(&contact_deck(c), &out.join("contact").join(run_name(c)))?;
    }
    Ok(runs.len())
}

fn write_deck(deck: &Deck, dir: &Path) -> Result<()> {
    for (name, text) in &deck.files {
        write_atomic(&dir.join(name), text.as_bytes())?;
    }
    Ok(())
}

pub fn default_out(prefix: &str) -> PathBuf {
    PathBuf::from("runs").join(format!("{prefix}-{}", utc_stamp()))
}

/// `YYYYmmdd-HHMMSS` in UTC.
pub fn utc_stamp() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let (days, rem) = ((secs / 86400) as i64, secs % 86400);
    // Civil-from-days (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}{m:02}{d:02}-{:02}{:02}{:02}",
        rem / 3600,
        (rem % 3600) / 60,
        rem % 60
    )
}

fn contact(a: ContactArgs) -> Result<Outcome> {
    if a.list {
        for (name, _) in BUILTIN_CASES {
            let c = builtin_case(name)?;
            let models: Vec<&str> = c.applicable_rolling().iter().map(|m| m.keyword()).collect();
            println!("{name:<22} [{}] {}", models.join(","), c.description);
        }
        return Ok(Outcome::Agree);
    }
    if !(a.rtol.is_finite() && a.rtol > 0.0) {
        return Err(Error::invalid("--rtol", a.rtol, "a finite number > 0"));
    }
    let runs = contact_runs(&a.case, a.spec.as_deref(), &a.rolling)?;
    let lig = if a.reference {
        None
    } else {
        Some(Liggghts::locate(
            a.liggghts.as_deref(),
            Duration::from_secs(a.timeout),
        )?)
    };
    let version = match &lig {
        Some(l) => l.version(),
        None => read_reference_version(&a.reference_dir),
    };
    let out = a.out.clone().unwrap_or_else(|| default_out("contact"));
    println!(
        "verify contact: {} run(s), against {}, rtol {:e}, output {}",
        runs.len(),
        if a.reference {
            "stored reference"
        } else {
            "live LIGGGHTS"
        },
        a.rtol,
        out.display()
    );
    let mut all = Vec::new();
    for case in &runs {
        for w in &case.warnings {
            eprintln!("warning: {}/{}: {w}", case.name, case.models.rolling);
        }
        let t0 = Instant::now();
        let results = contact_one(case, &a, lig.as_ref(), &out)?;
        let pass = results.iter().all(|r| r.pass);
        let worst = results.iter().map(|r| r.max_rel_err).fold(0.0, f64::max);
        println!(
            "{:<22} {:<6} max rel err {:>10.3e}  {}  ({:.1} s)",
            case.name,
            case.models.rolling.keyword(),
            worst,
            if pass { "agree" } else { "DISAGREE" },
            t0.elapsed().as_secs_f64()
        );
        if !pass {
            print!("{}", channel_table(&results));
        }
        all.extend(results);
    }
    let against = if a.reference { "reference" } else { "live" };
    let summary = ContactSummary::new(against, version, a.rtol, all);
    summary.write(&out.join("summary.json"))?;
    println!("\n{}", worst_table(&summary));
    println!("summary: {}", out.join("summary.json").display());
    Ok(if summary.pass {
        Outcome::Agree
    } else {
        Outcome::Disagree
    })
}

/// Runs one case in both codes (or native against the stored reference) and compares.
pub fn contact_one(
    case: &Case,
    a: &ContactArgs,
    lig: Option<&Liggghts>,
    out: &Path,
) -> Result<Vec<ChannelResult>> {
    let name = run_name(case);
    let dir = out.join(&name);
    let deck = contact_deck(case);
    write_deck(&deck, &dir.join("deck"))?;
    let reference_csv = a
        .reference_dir
        .join("contact")
        .join(&name)
        .join("liggghts.csv");
    let lig_series = match lig {
        None => {
            if !reference_csv.is_file() {
                return Err(Error::Reference(format!(
                    "no stored LIGGGHTS output for {name} at {} (built-in cases only; run \
                     without --reference to use LIGGGHTS)",
                    reference_csv.display()
                )));
            }
            Series::read_csv(&reference_csv)?
        }
        Some(l) => {
            let s = liggghts_contact_series(case, &deck, l, &dir)?;
            if a.update_reference {
                store_reference(case, &s, l, &a.reference_dir)?;
            }
            s
        }
    };
    lig_series.write_csv(&dir.join("liggghts.csv"))?;
    let mut native = contact_series(case, &two_body::run(case)?);
    if lig.is_none() {
        native = native.at_steps(&lig_series.steps)?;
    }
    native.write_csv(&dir.join("native.csv"))?;
    crate::report::contact::contact_plots(
        &dir,
        &name,
        &lig_series,
        &native,
        case.models.rolling != RollingModel::Off,
    )?;
    compare(
        &case.name,
        case.models.rolling.keyword(),
        &lig_series,
        &native,
        a.rtol,
    )
}

/// Runs the deck in a temporary directory and returns its channels; keeps the log in `dir`.
pub fn liggghts_contact_series(
    case: &Case,
    deck: &Deck,
    lig: &Liggghts,
    dir: &Path,
) -> Result<Series> {
    let tmp = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
    let result = lig.run(deck, tmp.path());
    if let Ok(log) = std::fs::read(tmp.path().join(LOG_NAME)) {
        write_atomic(&dir.join(LOG_NAME), &log)?;
    }
    result?;
    let n_hist = if case.models.rolling.has_history() {
        6
    } else {
        3
    };
    let frames = read_contact_frames(tmp.path(), n_hist, case.wall.is_some())?;
    Ok(contact_series(case, &frames))
}

/// Stored references keep every `REFERENCE_STRIDE`-th output step (and the last), to keep
/// the repository small; `--reference` compares the native run at exactly those steps.
pub const REFERENCE_STRIDE: u64 = 10;

#[derive(serde::Serialize, serde::Deserialize)]
struct Provenance {
    liggghts_version: String,
    command: String,
    deck: String,
    date_utc: String,
}

fn store_reference(case: &Case, s: &Series, lig: &Liggghts, root: &Path) -> Result<()> {
    let name = run_name(case);
    let dir = root.join("contact").join(&name);
    s.decimate(REFERENCE_STRIDE)
        .write_csv(&dir.join("liggghts.csv"))?;
    let prov = Provenance {
        liggghts_version: lig.version(),
        command: format!("{} -in in.deck -log log.liggghts", lig.binary.display()),
        deck: format!("liggghts_inputs/contact/{name}/in.deck"),
        date_utc: utc_stamp(),
    };
    write_atomic(
        &dir.join("provenance.json"),
        serde_json::to_string_pretty(&prov)?.as_bytes(),
    )
}

fn read_reference_version(root: &Path) -> String {
    let p = root.join("contact/rolling_plastic__epsd/provenance.json");
    std::fs::read_to_string(p)
        .ok()
        .and_then(|t| serde_json::from_str::<Provenance>(&t).ok())
        .map(|p| format!("{} (stored {})", p.liggghts_version, p.date_utc))
        .unwrap_or_else(|| "stored reference (no provenance found)".into())
}
