//! Study files: a command line as TOML, and back.
//!
//! ```toml
//! version = 1
//! command = "shear"          # shear, convergence, sweep, nightly, bench, contact
//! [options]                  # the command's long options, `-` written `_`
//! mu_r = 0.5
//! eta_r = 0.5
//! preset = "fast"
//! native_only = true         # a flag: true or false
//! speeds = [0.002, 0.006, 0.02]
//! ```
//!
//! `verify run STUDY.toml [--dry-run] [FLAGS...]` turns the file into the command's
//! arguments (flags after the file override its fields) and parses them with the same
//! definitions as the command line, so a study is validated exactly as the flags are. Every
//! command that writes a summary also writes `study.toml` beside it: the resolved options,
//! defaults included, so `verify run DIR/study.toml` repeats the run (in the same directory:
//! finished parts are reused). Before it starts, a study prints its plan (runs, steps,
//! estimated core-hours and disk); `--dry-run` prints only that.

use super::args::RunArgs;
use super::command::{Cli, Command};
use crate::error::{Error, Result};
use crate::run::convergence::StudyCode;
use crate::run::{Engine, Verdict};
use crate::solver::shear::pairs::KernelPath;
use crate::spec::shear::ShearCase;
use clap::{ArgAction, ArgMatches, CommandFactory, FromArgMatches};
use std::path::{Path, PathBuf};

/// Version of the study format.
pub const STUDY_VERSION: i64 = 1;

/// Commands a study can hold.
const STUDY_COMMANDS: [&str; 6] = [
    "shear",
    "convergence",
    "sweep",
    "nightly",
    "bench",
    "contact",
];

/// The resolved options of a parsed study-able command (defaults included), as a study file;
/// None for other commands (and for `sweep` with a subcommand).
pub fn resolve(matches: &ArgMatches) -> Option<String> {
    let (name, sub) = matches.subcommand()?;
    if !STUDY_COMMANDS.contains(&name) || sub.subcommand().is_some() {
        return None;
    }
    let root = Cli::command();
    let cmd = root.find_subcommand(name)?;
    let mut options = toml::Table::new();
    for arg in cmd.get_arguments() {
        let id = arg.get_id().as_str();
        let Some(long) = arg.get_long() else {
            continue;
        };
        if matches!(id, "help" | "version" | "json") {
            continue;
        }
        let key = long.replace('-', "_");
        if matches!(arg.get_action(), ArgAction::SetTrue) {
            options.insert(key, toml::Value::Boolean(sub.get_flag(id)));
            continue;
        }
        let Ok(Some(raw)) = sub.try_get_raw(id) else {
            continue;
        };
        let vals: Vec<toml::Value> = raw.map(|v| toml_value(&v.to_string_lossy())).collect();
        let multiple = arg.get_value_delimiter().is_some() || vals.len() > 1;
        options.insert(
            key,
            if multiple {
                toml::Value::Array(vals)
            } else {
                vals.into_iter().next()?
            },
        );
    }
    let mut doc = toml::Table::new();
    doc.insert("version".into(), toml::Value::Integer(STUDY_VERSION));
    doc.insert("command".into(), toml::Value::String(name.into()));
    doc.insert("options".into(), toml::Value::Table(options));
    Some(format!(
        "# dem-verify study: `verify run study.toml` repeats this run (finished parts are reused)\n{}",
        toml::to_string(&doc).ok()?
    ))
}

/// A raw option value as TOML: a number when it reads as one, else a string.
fn toml_value(s: &str) -> toml::Value {
    if let Ok(i) = s.parse::<i64>() {
        toml::Value::Integer(i)
    } else if let Some(f) = s.parse::<f64>().ok().filter(|f| f.is_finite()) {
        toml::Value::Float(f)
    } else {
        toml::Value::String(s.into())
    }
}

fn scalar(key: &str, v: &toml::Value) -> Result<String> {
    match v {
        toml::Value::Integer(i) => Ok(i.to_string()),
        toml::Value::Float(f) => Ok(format!("{f:?}")),
        toml::Value::String(s) => Ok(s.clone()),
        other => Err(Error::invalid(
            format!("study option `{key}`"),
            other,
            "a number, a string, true/false, or an array of numbers or strings",
        )),
    }
}

/// The command line a study describes: `[command, --opt=value, ...]`, then `overrides`
/// (which replace the study's fields of the same names).
pub fn study_args(path: &Path, overrides: &[String]) -> Result<Vec<String>> {
    let text = crate::fsutil::read_to_string(path)?;
    let doc: toml::Table = toml::from_str(&text).map_err(|e| Error::StudyFile {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    match doc.get("version") {
        Some(toml::Value::Integer(STUDY_VERSION)) => {}
        other => {
            return Err(Error::invalid(
                "study field `version`",
                other.map_or("(missing)".into(), |v| v.to_string()),
                STUDY_VERSION.to_string(),
            ))
        }
    }
    let command = match doc.get("command") {
        Some(toml::Value::String(c)) if STUDY_COMMANDS.contains(&c.as_str()) => c.clone(),
        other => {
            return Err(Error::invalid(
                "study field `command`",
                other.map_or("(missing)".into(), |v| v.to_string()),
                STUDY_COMMANDS.join(", "),
            ))
        }
    };
    for key in doc.keys() {
        if !matches!(key.as_str(), "version" | "command" | "options") {
            return Err(Error::invalid(
                "study field",
                key,
                "version, command, options",
            ));
        }
    }
    let empty = toml::Table::new();
    let options = match doc.get("options") {
        Some(toml::Value::Table(t)) => t,
        None => &empty,
        Some(other) => return Err(Error::invalid("study field `options`", other, "a table")),
    };
    let root = Cli::command();
    let cmd = root
        .find_subcommand(&command)
        .expect("a study command is a subcommand");
    let valid: Vec<String> = cmd
        .get_arguments()
        .flat_map(|a| {
            // a renamed option's old name (a visible alias) still reads older study files
            a.get_long()
                .into_iter()
                .chain(a.get_visible_aliases().into_iter().flatten())
        })
        .filter(|l| !matches!(*l, "help" | "json"))
        .map(|l| l.replace('-', "_"))
        .collect();
    let overridden: Vec<String> = overrides
        .iter()
        .filter_map(|o| o.strip_prefix("--"))
        .map(|o| o.split('=').next().unwrap_or(o).replace('-', "_"))
        .collect();
    // options that take no value (flags): the only ones a boolean may set
    let flags: Vec<String> = cmd
        .get_arguments()
        .filter(|a| !a.get_action().takes_values())
        .filter_map(|a| a.get_long())
        .map(|l| l.replace('-', "_"))
        .collect();
    let mut args = vec![command.clone()];
    for (key, v) in options {
        if matches!(v, toml::Value::Boolean(_)) && !flags.contains(key) {
            // `seeds = false` would otherwise be dropped and the default run
            return Err(Error::invalid(
                format!("[options] {key}"),
                v,
                "a value of the option (true/false only for flags)",
            ));
        }
        if !valid.contains(key) {
            return Err(Error::invalid(
                format!("[options] {key}"),
                format!("not an option of verify {command}"),
                valid.join(", "),
            ));
        }
        if overridden.contains(key) {
            continue;
        }
        let flag = format!("--{}", key.replace('_', "-"));
        match v {
            toml::Value::Boolean(true) => args.push(flag),
            toml::Value::Boolean(false) => {}
            toml::Value::Array(items) => {
                let parts: Vec<String> = items
                    .iter()
                    .map(|x| scalar(key, x))
                    .collect::<Result<_>>()?;
                args.push(format!("{flag}={}", parts.join(",")));
            }
            other => args.push(format!("{flag}={}", scalar(key, other)?)),
        }
    }
    args.extend(overrides.iter().cloned());
    Ok(args)
}

/// Particle-steps per second per core measured by `verify bench` on the reference machine
/// (AMD EPYC with AVX-512, fast state, 2,500 particles): LIGGGHTS 2.37e6 (median of 4
/// invocations, 2026-12-02), each native path at its ratio to LIGGGHTS measured in one
/// invocation on 2026-12-03 (`reference/bench/20261203-epyc/`: AVX-512 2.88x, AVX2 2.33x,
/// scalar 1.24x; the machine's speed drifts by up to 30 %, its ratios much less). A plan's
/// core-hours are these rates applied to its steps.
fn rate(code: Engine) -> f64 {
    match code {
        Engine::Liggghts => 2.37e6,
        _ => match KernelPath::detect() {
            KernelPath::Avx512 => 6.8e6,
            KernelPath::Avx2 => 5.5e6,
            KernelPath::Scalar => 2.95e6,
        },
    }
}

/// Runs, steps and the estimated cost of a list of (code, case) runs.
struct Plan {
    runs: usize,
    steps: u64,
    core_hours: f64,
    disk_bytes: f64,
}

impl Plan {
    /// The plan of these runs, each native run checked against the machine's memory as the
    /// run will check it.
    fn of(runs: &[(Engine, ShearCase)]) -> Result<Plan> {
        for (code, c) in runs {
            if *code == Engine::Native {
                crate::run::check_memory("particles", c.particles)?;
            }
        }
        let mut p = Plan {
            runs: runs.len(),
            steps: 0,
            core_hours: 0.0,
            disk_bytes: 0.0,
        };
        for (code, c) in runs {
            let steps = c.total_steps();
            p.steps += steps;
            p.core_hours += steps as f64 * c.particles as f64 / rate(*code) / 3600.0;
            // series rows (~300 B), snapshots (~100 B per particle; LIGGGHTS also its text
            // dump, ~200 B), checkpoints (~600 B per particle)
            let snaps = steps
                .checked_div(c.snapshot_every)
                .map_or(0.0, |n| (n + 1) as f64);
            let per_particle = if *code == Engine::Liggghts {
                300.0
            } else {
                100.0
            };
            p.disk_bytes += (steps / c.output_every.max(1)) as f64 * 300.0
                + snaps * c.particles as f64 * per_particle
                + 600.0 * c.particles as f64;
        }
        Ok(p)
    }

    fn print(&self, what: &str, cores: usize) {
        println!(
            "plan ({what}): {} run(s), {} steps in all, about {:.2} core-hours ({:.2} h on {cores} core(s)), {:.0} MB on disk",
            self.runs,
            self.steps,
            self.core_hours,
            self.core_hours / cores.max(1) as f64,
            self.disk_bytes / 1e6
        );
        println!(
            "  (rates of `verify bench` on the reference machine's dense state: native {:.2e}, LIGGGHTS {:.2e} \
             particle-steps/s per core; the e = 1 fast map's runs took 1.1x this on a free core, up to 8x \
             with development and CI sharing the 2 cores)",
            rate(Engine::Native),
            rate(Engine::Liggghts)
        );
    }
}

fn codes(e: Engine) -> Vec<Engine> {
    match e {
        Engine::Both => vec![Engine::Liggghts, Engine::Native],
        e => vec![e],
    }
}

/// The plan of a parsed study command; None for commands without one (nightly, bench, contact).
fn plan(cli: &Cli) -> Result<Option<(Plan, String)>> {
    Ok(match &cli.command {
        Command::Shear(a) => {
            let req = a.request(a.engine(), "shear");
            req.validate()?;
            let mut runs = Vec::new();
            for s in req.seed_range() {
                let (c, _) = req.seed_case(s)?;
                for code in codes(req.engine) {
                    runs.push((code, c.clone()));
                }
            }
            Some((Plan::of(&runs)?, "verify shear".into()))
        }
        Command::Convergence(a) => {
            // the study's own list of runs, and its compaction once per seed (native, at the
            // preset's dt, shared by every factor and code)
            let req = a.request();
            req.validate()?;
            let mut runs = Vec::new();
            for seed in req.shear.seed_range() {
                let (c, _) = req.shear.seed_case(seed)?;
                runs.push((Engine::Native, c.compaction_only()));
            }
            for (_, code, _, c) in req.planned_runs()? {
                let engine = match code {
                    StudyCode::Liggghts => Engine::Liggghts,
                    StudyCode::Native | StudyCode::Implicit => Engine::Native,
                };
                runs.push((engine, c));
            }
            Some((Plan::of(&runs)?, "verify convergence".into()))
        }
        Command::Sweep(a) if a.action.is_none() => {
            // the manifest the sweep would store, each run's case as the run builds it
            let m = a.plan.request(PathBuf::new()).manifest()?;
            let mut runs = Vec::new();
            for r in &m.runs {
                let c = crate::run::sweep::run_case(&m.base, r)?;
                for code in codes(m.base.engine) {
                    runs.push((code, c.clone()));
                }
            }
            Some((Plan::of(&runs)?, "verify sweep".into()))
        }
        Command::Nightly(a) => {
            // the shear points dominate (23 contact runs and the replay take minutes)
            let mut runs = Vec::new();
            for c in crate::run::nightly::shear_cases(a.quick)? {
                for code in codes(Engine::Both) {
                    runs.push((code, c.clone()));
                }
            }
            Some((Plan::of(&runs)?, "verify nightly, its shear points".into()))
        }
        _ => None,
    })
}

/// `verify run STUDY.toml`: prints the plan, then (unless --dry-run) runs the command.
///
/// A study runs any command: `execute` is the dispatcher (cli/mod.rs's [`execute`](super::execute)),
/// given rather than imported, so that this file and the dispatcher do not import each other.
pub fn run_study(mut a: RunArgs, execute: fn(&ArgMatches) -> Result<Verdict>) -> Result<Verdict> {
    // after the file everything is an override, but for a `--` separator and --dry-run
    a.dry_run |= a.overrides.iter().any(|o| o == "--dry-run");
    a.overrides.retain(|o| o != "--dry-run" && o != "--");
    let args = study_args(&a.study, &a.overrides)?;
    println!("study {}: verify {}", a.study.display(), args.join(" "));
    // clap's own message, first line, names the option (`--mu-r`: the field mu_r)
    let clap_err = |e: clap::Error| {
        let text = e.to_string();
        let first = text
            .lines()
            .next()
            .unwrap_or("")
            .trim_start_matches("error: ");
        Error::invalid("study", a.study.display(), first.to_string())
    };
    let matches = Cli::command()
        .try_get_matches_from(std::iter::once("verify".to_string()).chain(args))
        .map_err(clap_err)?;
    let cli = Cli::from_arg_matches(&matches).map_err(clap_err)?;
    // under `mpirun` this rank sees the core it is bound to; the run has one per rank
    let cores =
        crate::ranks::native_ranks() * std::thread::available_parallelism().map_or(1, |n| n.get());
    match plan(&cli)? {
        Some((p, what)) => p.print(&what, cores),
        None => println!("plan: no estimate for this command"),
    }
    if a.dry_run {
        return Ok(Verdict::Done);
    }
    execute(&matches)
}
