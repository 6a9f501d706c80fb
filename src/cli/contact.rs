//! `verify contact`: flags -> the contact cases and rolling models they name ->
//! [`crate::run::contact`] (live LIGGGHTS or the stored reference) -> a line per run and the
//! worst-channel table.

use crate::cli::args::LiggghtsArgs;
use crate::compare::CONTACT_RTOL;
use crate::deck::run_name;
use crate::error::{Error, Result};
use crate::liggghts::Liggghts;
use crate::report::contact::plots_of_run;
use crate::report::{channel_table, worst_table};
use crate::run::contact::{
    check_reference_target, contact_runs, read_reference_version, run_all, ContactRequest,
    RollingChoice,
};
use crate::run::{out_or_default, Verdict, CONTACT_TIMEOUT_S};
use crate::spec::builtin::{builtin_case, BUILTIN_CASES};
use crate::spec::RollingModel;
use clap::Args;
use std::path::PathBuf;

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
    /// Directory of stored reference outputs (default: $DEM_VERIFY_REFERENCE, else the
    /// repository's reference/ this binary was built from).
    #[arg(long)]
    pub reference_dir: Option<PathBuf>,
    /// List the built-in cases and exit.
    #[arg(long)]
    pub list: bool,
    #[command(flatten)]
    pub liggghts: LiggghtsArgs,
}

/// Runs `verify contact`.
pub fn contact(a: ContactArgs) -> Result<Verdict> {
    if a.list {
        for (name, _) in BUILTIN_CASES {
            let c = builtin_case(name)?;
            let models: Vec<&str> = c.applicable_rolling().iter().map(|m| m.keyword()).collect();
            println!("{name:<22} [{}] {}", models.join(","), c.description);
        }
        return Ok(Verdict::Done);
    }
    if !(a.rtol.is_finite() && a.rtol > 0.0) {
        return Err(Error::invalid("--rtol", a.rtol, "a finite number > 0"));
    }
    let rolling = match a.rolling.as_str() {
        "all" => RollingChoice::All,
        m => RollingChoice::One(RollingModel::parse_liggghts(m)?),
    };
    let runs = contact_runs(&a.case, a.spec.as_deref(), rolling)?;
    let reference_dir = match &a.reference_dir {
        Some(d) => d.clone(),
        None => crate::run::default_reference_dir()?,
    };
    if a.update_reference {
        for c in &runs {
            check_reference_target(&c.name, a.spec.is_some())?;
        }
    }
    let lig: Option<Liggghts> = if a.reference {
        None
    } else {
        Some(a.liggghts.request(CONTACT_TIMEOUT_S).locate()?)
    };
    let req = ContactRequest {
        rtol: a.rtol,
        reference_dir: reference_dir.clone(),
        update_reference: a.update_reference,
    };
    let version = match &lig {
        Some(l) => l.version(),
        None => read_reference_version(&reference_dir),
    };
    let out = out_or_default(a.out.as_deref(), "contact");
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
    for case in &runs {
        for w in &case.warnings {
            eprintln!("warning: {}/{}: {w}", case.name, case.models.rolling);
        }
    }
    let against = if a.reference { "reference" } else { "live" };
    let figure_errors = std::cell::RefCell::new(Vec::new());
    let summary = run_all(
        &runs,
        &req,
        lig.as_ref(),
        &out,
        against,
        version,
        |case, results, secs| {
            let results = match results {
                Ok(r) => r,
                Err(e) => {
                    println!(
                        "{:<22} {:<6} ERROR ({secs:.1} s): {e}",
                        case.name,
                        case.models.rolling.keyword()
                    );
                    return;
                }
            };
            let name = run_name(case);
            if let Err(e) = plots_of_run(
                &out.join(&name),
                &name,
                case.models.rolling != RollingModel::Off,
            ) {
                figure_errors.borrow_mut().push(format!("{name}: {e}"));
            }
            let pass = results.iter().all(|r| r.pass);
            let worst = results.iter().map(|r| r.max_rel_err).fold(0.0, f64::max);
            println!(
                "{:<22} {:<6} max rel err {:>10.3e}  {}  ({secs:.1} s)",
                case.name,
                case.models.rolling.keyword(),
                worst,
                if pass { "agree" } else { "DISAGREE" },
            );
            if !pass {
                print!("{}", channel_table(results));
            }
        },
    )?;
    println!("\n{}", worst_table(&summary));
    println!("summary: {}", out.join("summary.json").display());
    let figure_errors = figure_errors.into_inner();
    if !figure_errors.is_empty() {
        return Err(Error::Cases(format!(
            "the figures of {} run(s) could not be drawn (the comparisons are in the summary):\n  {}",
            figure_errors.len(),
            figure_errors.join("\n  ")
        )));
    }
    Ok(Verdict::from_pass(summary.pass))
}
