//! `verify nightly`: every built-in contact case with every applicable rolling model and the
//! nightly shear cases, in both codes, into one self-contained HTML report, a `summary.json`
//! and a history of nights (JSON lines) that the report draws trends from.
//!
//! Data flow: cases -> `verify contact` / `verify shear` runs (their outputs, CSVs and plots
//! under DIR/contact and DIR/shear) -> rows of `summary.json` -> history append -> report.html.
//! Interrupted nights resume: shear seeds already finished in DIR are reused.

use crate::cli::{contact_one, contact_runs, utc_stamp, ContactArgs, Outcome};
use crate::cli_shear::{shear_run, ShearArgs, ShearSummary};
use crate::compare::{CONTACT_RTOL, MU_ATOL, STRESS_RTOL};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::Liggghts;
use crate::report::bars::{bar_chart, escape, Bar, BarGroup};
use crate::report::history::{self, Record};
use crate::report::html::{table, Page};
use crate::report::plot::{line_plot, Curve, CurveData};
use crate::series::Series;
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

#[derive(Args, Debug, Clone)]
pub struct NightlyArgs {
    /// Output directory of this night (report.html, summary.json, every run's files).
    #[arg(long)]
    pub out: PathBuf,
    /// CI-sized night: the ci shear preset with one seed (minutes instead of hours).
    #[arg(long)]
    pub quick: bool,
    /// History file (JSON lines, one per case per night; default: history.jsonl next to --out).
    #[arg(long)]
    pub history: Option<PathBuf>,
    /// LIGGGHTS binary.
    #[arg(long)]
    pub liggghts: Option<PathBuf>,
}

/// The shear cases of every night: (mu_r, eta_r, rolling model). The paper's model epsd over
/// the corners of its map, and epsd2 (no dashpot) at one point.
pub const SHEAR_POINTS: [(f64, f64, &str); 5] = [
    (0.0, 0.0, "epsd"),
    (0.5, 0.0, "epsd"),
    (0.5, 0.5, "epsd"),
    (1.0, 0.5, "epsd"),
    (0.5, 0.0, "epsd2"),
];

/// Seeds per shear point in a full night (paired: the same packings in both codes).
pub const FULL_SEEDS: u64 = 6;

/// Wall-time budget of a full night on the 2-core reference machine [s].
pub const FULL_BUDGET_S: f64 = 3.0 * 3600.0;

/// Steady |mu_LIGGGHTS - mu_native| accepted in a quick night: one seed of 300 particles; the
/// seed-to-seed spread of the ci preset is about 0.03, so two chaotic realisations differ by up
/// to about 0.1 (95 %). The 95 % CIs must overlap as well.
pub const QUICK_MU_ATOL: f64 = 0.1;

/// Normal-stress tolerance of a quick night: the steady-window mean of one seed of 300
/// particles wanders 1-2 % around the servo target (0.1-1.3 % measured at the five points).
pub const QUICK_STRESS_RTOL: f64 = 0.03;

/// The machine the night ran on.
#[derive(Clone, Debug, Serialize)]
pub struct Machine {
    pub hostname: String,
    pub cpu: String,
    pub cores: usize,
    pub memory_gib: f64,
    pub os: String,
    pub kernel: String,
}

impl Machine {
    pub fn detect() -> Self {
        let read = |p: &str| std::fs::read_to_string(p).unwrap_or_default();
        let field = |text: &str, key: &str| {
            text.lines()
                .find(|l| l.starts_with(key))
                .and_then(|l| l.split_once([':', '=']))
                .map(|(_, v)| v.trim().trim_matches('"').to_string())
                .unwrap_or_else(|| "unknown".into())
        };
        let mem_kib: f64 = field(&read("/proc/meminfo"), "MemTotal")
            .trim_end_matches("kB")
            .trim()
            .parse()
            .unwrap_or(f64::NAN);
        Machine {
            hostname: read("/proc/sys/kernel/hostname").trim().to_string(),
            cpu: field(&read("/proc/cpuinfo"), "model name"),
            cores: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
            memory_gib: mem_kib / 1024.0 / 1024.0,
            os: field(&read("/etc/os-release"), "PRETTY_NAME"),
            kernel: read("/proc/sys/kernel/osrelease").trim().to_string(),
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
#[derive(Clone, Debug, Serialize)]
pub struct ContactRow {
    pub case: String,
    pub model: String,
    pub pass: bool,
    pub error: Option<String>,
    pub max_rel_err: f64,
    pub worst_channel: String,
    pub rtol: f64,
    pub wall_s: f64,
    /// Run directory relative to the night's directory.
    pub dir: String,
}

/// One code's steady-state and cost figures in a shear case.
#[derive(Clone, Debug, Serialize)]
pub struct CodeStats {
    pub mu: f64,
    pub mu_ci95: f64,
    pub per_seed_mu: Vec<f64>,
    /// Mean normal stress on the top plate over the steady window and seeds [Pa].
    pub normal_stress: f64,
    /// Mean rotational and translational kinetic energy over the steady window and seeds [J].
    pub erot: f64,
    pub ke: f64,
    /// Mean fraction of touching particle pairs whose rolling resistance is at full
    /// mobilisation over the steady window (native only; null for LIGGGHTS).
    pub mobilised: f64,
    /// Wall time summed over seeds [s] and mean throughput [particle-steps/s].
    pub wall_s: f64,
    pub particle_steps_per_s: f64,
}

/// One shear case of the night.
#[derive(Clone, Debug, Serialize)]
pub struct ShearRow {
    pub name: String,
    pub preset: String,
    pub rolling: String,
    pub mu_r: f64,
    pub eta_r: f64,
    pub seeds: u64,
    pub pass: bool,
    pub error: Option<String>,
    /// |mu_LIGGGHTS - mu_native| and its limit (the 95 % CIs must overlap as well).
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
    pub paired_dmu: Option<crate::compare::Paired>,
    /// `verify replay` of the same point (seed 1): the codes contact by contact.
    pub replay: Option<ReplayRow>,
    pub dir: String,
}

/// The replay of a nightly shear point, in one line.
#[derive(Clone, Debug, Serialize)]
pub struct ReplayRow {
    pub pass: bool,
    pub windows: usize,
    pub steps: u64,
    /// Largest step-1 error over the windows (judged channels) and its limit.
    pub worst_step1: f64,
    pub rtol: f64,
    /// Shortest horizon over the windows [steps].
    pub min_horizon: u64,
}

/// `DIR/summary.json` of `verify nightly` (schema in the README).
#[derive(Clone, Debug, Serialize)]
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
}

pub fn nightly(a: NightlyArgs) -> Result<Outcome> {
    let t0 = Instant::now();
    let start = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let date = utc_stamp();
    let history_path = a.history.clone().unwrap_or_else(|| {
        a.out
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .join("history.jsonl")
    });
    // fail early on an unreadable history, before hours of runs
    history::read(&history_path)?;
    let lig = Liggghts::locate(a.liggghts.as_deref(), Duration::from_secs(24 * 3600))?;
    let version = lig.version();
    let commit = git_commit();
    let machine = Machine::detect();
    std::fs::create_dir_all(&a.out).map_err(|e| Error::io(&a.out, e))?;
    println!(
        "verify nightly{}: output {}, history {}\n  {version}, commit {commit}, {}",
        if a.quick { " --quick" } else { "" },
        a.out.display(),
        history_path.display(),
        machine.describe()
    );
    let contact = contact_night(&a, &lig)?;
    let shear: Vec<ShearRow> = SHEAR_POINTS
        .iter()
        .map(|&(mu_r, eta_r, rolling)| shear_night(&a, &lig, mu_r, eta_r, rolling))
        .collect();
    let errors: Vec<String> = contact
        .iter()
        .filter_map(|c| {
            c.error
                .as_ref()
                .map(|e| format!("contact {}/{}: {e}", c.case, c.model))
        })
        .chain(
            shear
                .iter()
                .filter_map(|s| s.error.as_ref().map(|e| format!("shear {}: {e}", s.name))),
        )
        .collect();
    let pass = errors.is_empty() && contact.iter().all(|c| c.pass) && shear.iter().all(|s| s.pass);
    let summary = NightlySummary {
        schema: 1,
        pass,
        quick: a.quick,
        date_utc: date.clone(),
        commit,
        liggghts_version: version,
        machine,
        wall_time_s: t0.elapsed().as_secs_f64(),
        budget_s: (!a.quick).then_some(FULL_BUDGET_S),
        contact,
        shear,
        errors,
    };
    write_atomic(
        &a.out.join("summary.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    let all = history::append(&history_path, &records(&summary, start, &a.out))?;
    let html = report(&summary, &all, &a.out)?;
    write_atomic(&a.out.join("report.html"), html.as_bytes())?;
    println!(
        "\nnightly {}: {} contact runs, {} shear cases, {:.0} s; report {}",
        if summary.pass { "PASS" } else { "FAIL" },
        summary.contact.len(),
        summary.shear.len(),
        summary.wall_time_s,
        a.out.join("report.html").display()
    );
    if !summary.errors.is_empty() {
        return Err(Error::Cases(format!(
            "{} case(s) of the night could not be run (report written to {}):\n  {}",
            summary.errors.len(),
            a.out.join("report.html").display(),
            summary.errors.join("\n  ")
        )));
    }
    Ok(if summary.pass {
        Outcome::Agree
    } else {
        Outcome::Disagree
    })
}

/// Every built-in contact case with every applicable rolling model, live LIGGGHTS.
fn contact_night(a: &NightlyArgs, lig: &Liggghts) -> Result<Vec<ContactRow>> {
    let out = a.out.join("contact");
    let args = ContactArgs {
        case: "all".into(),
        spec: None,
        rolling: "all".into(),
        rtol: CONTACT_RTOL,
        out: Some(out.clone()),
        reference: false,
        update_reference: false,
        reference_dir: PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/reference")),
        list: false,
        liggghts: a.liggghts.clone(),
        timeout: 600,
    };
    let mut rows = Vec::new();
    for case in contact_runs("all", None, "all")? {
        let model = case.models.rolling.keyword().to_string();
        let t = Instant::now();
        let r = contact_one(&case, &args, Some(lig), &out);
        let mut row = ContactRow {
            case: case.name.clone(),
            model: model.clone(),
            pass: false,
            error: None,
            max_rel_err: f64::NAN,
            worst_channel: String::new(),
            rtol: CONTACT_RTOL,
            wall_s: t.elapsed().as_secs_f64(),
            dir: format!("contact/{}", crate::deck::run_name(&case)),
        };
        match r {
            Ok(results) => {
                row.pass = results.iter().all(|r| r.pass);
                if let Some(w) = results
                    .iter()
                    .max_by(|x, y| x.max_rel_err.total_cmp(&y.max_rel_err))
                {
                    row.max_rel_err = w.max_rel_err;
                    row.worst_channel = if w.max_rel_err == 0.0 {
                        "every channel".into()
                    } else {
                        w.channel.clone()
                    };
                }
            }
            Err(e) => row.error = Some(e.to_string()),
        }
        println!(
            "  contact {:<22} {:<6} max rel err {:>10.3e}  {}  ({:.1} s)",
            row.case,
            row.model,
            row.max_rel_err,
            match (&row.error, row.pass) {
                (Some(_), _) => "ERROR",
                (None, true) => "agree",
                (None, false) => "DISAGREE",
            },
            row.wall_s
        );
        rows.push(row);
    }
    Ok(rows)
}

fn shear_dir(mu_r: f64, eta_r: f64, rolling: &str) -> String {
    format!("shear/{rolling}_mur{mu_r}_etar{eta_r}")
}

/// One shear case of the night (errors are kept in the row, the night goes on).
fn shear_night(a: &NightlyArgs, lig: &Liggghts, mu_r: f64, eta_r: f64, rolling: &str) -> ShearRow {
    let preset = if a.quick { "ci" } else { "fast" };
    let dir = shear_dir(mu_r, eta_r, rolling);
    let args = ShearArgs {
        mu_r,
        eta_r,
        rolling: rolling.into(),
        preset: preset.into(),
        seeds: if a.quick { 1 } else { FULL_SEEDS },
        out: Some(a.out.join(&dir)),
        mu_atol: if a.quick { QUICK_MU_ATOL } else { MU_ATOL },
        stress_rtol: if a.quick {
            QUICK_STRESS_RTOL
        } else {
            STRESS_RTOL
        },
        liggghts: a.liggghts.clone(),
        ..ShearArgs::defaults()
    };
    let mut row = ShearRow {
        name: format!("{preset}/{rolling} mu_r={mu_r} eta_r={eta_r}"),
        preset: preset.into(),
        rolling: rolling.into(),
        mu_r,
        eta_r,
        seeds: args.seeds,
        pass: false,
        error: None,
        dmu: None,
        mu_atol: args.mu_atol,
        stress_rtol: args.stress_rtol,
        ci_overlap: None,
        stress_rel_err: None,
        liggghts: None,
        native: None,
        lockstep_steps: None,
        chaos_baseline_steps: None,
        dashpot_stable: None,
        worst_stability: None,
        paired_dmu: None,
        replay: None,
        dir,
    };
    println!("\n== shear {} ==", row.name);
    match shear_run(&args).and_then(|s| fill_shear_row(&mut row, &s, &a.out)) {
        Ok(()) => {}
        Err(e) => row.error = Some(e.to_string()),
    }
    println!("\n== replay {} ==", row.name);
    match replay_night(a, lig, preset, mu_r, eta_r, rolling, &row.dir) {
        Ok(r) => {
            row.pass &= r.pass;
            row.replay = Some(r);
        }
        Err(e) => {
            let msg = format!("replay: {e}");
            row.error = Some(match row.error.take() {
                Some(prev) => format!("{prev}; {msg}"),
                None => msg,
            });
        }
    }
    row
}

/// `verify replay` of a nightly point: seed 1, windows in compaction and early shear (a stored
/// outcome of the same case and windows is reused, so a resumed night does not redo it).
fn replay_night(
    a: &NightlyArgs,
    lig: &Liggghts,
    preset: &str,
    mu_r: f64,
    eta_r: f64,
    rolling: &str,
    dir: &str,
) -> Result<ReplayRow> {
    use crate::replay::{default_states, run, ReplayOutcome, ReplayRequest};
    let case = crate::spec::shear::ShearCase::preset(
        preset,
        crate::spec::RollingModel::parse(rolling)?,
        mu_r,
        eta_r,
        1,
    )?;
    let steps = 12;
    let states = default_states(&case, if a.quick { 4 } else { 6 }, steps, 20_000);
    let out = a.out.join(dir).join("replay");
    let stored = std::fs::read_to_string(out.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<ReplayOutcome>(&t).ok())
        .filter(|o| {
            o.case == case.name
                && o.windows.len() == states.len()
                && o.windows.iter().all(|w| w.steps.len() as u64 == steps)
        });
    let o = match stored {
        Some(o) => o,
        None => {
            std::fs::create_dir_all(&out).map_err(|e| Error::io(&out, e))?;
            let req = ReplayRequest {
                case,
                states,
                steps,
                rtol: crate::replay::STEP1_RTOL,
                out,
            };
            run(&req, lig, |m| println!("  {m}"))?
        }
    };
    print!("{}", crate::replay::table(&o));
    Ok(ReplayRow {
        pass: o.pass,
        windows: o.windows.len(),
        steps,
        worst_step1: o
            .windows
            .iter()
            .map(|w| w.steps[0].max_rel_err)
            .fold(0.0, f64::max),
        rtol: o.rtol,
        min_horizon: o.windows.iter().map(|w| w.horizon).min().unwrap_or(0),
    })
}

fn fill_shear_row(row: &mut ShearRow, s: &ShearSummary, night: &Path) -> Result<()> {
    row.pass = s.pass;
    row.dashpot_stable = Some(s.stability.stable);
    row.worst_stability = s.stability.lines(1).into_iter().next();
    for r in &s.results {
        if r.channel == "mu_steady" {
            row.dmu = Some(r.max_abs_err);
        } else {
            row.stress_rel_err = Some(row.stress_rel_err.unwrap_or(0.0).max(r.max_rel_err));
        }
    }
    if let (Some(l), Some(n)) = (&s.liggghts, &s.native) {
        row.ci_overlap = Some((l.mu - n.mu).abs() <= l.mu_ci95 + n.mu_ci95);
    }
    row.paired_dmu = s.paired_dmu.clone();
    let lock = |f: &dyn Fn(&crate::cli_shear::SeedResult) -> Option<u64>| {
        s.seeds.iter().map(f).collect::<Option<Vec<u64>>>()
    };
    row.lockstep_steps = lock(&|r| r.shear_lockstep.as_ref().map(|h| h.last_agree_step))
        .and_then(|v| v.into_iter().min());
    row.chaos_baseline_steps =
        lock(&|r| r.shear_chaos_baseline.as_ref().map(|h| h.last_agree_step))
            .and_then(|v| v.into_iter().min());
    for (code, st) in [("liggghts", &s.liggghts), ("native", &s.native)] {
        let Some(st) = st else { continue };
        let (mut erot, mut ke, mut mob) = (0.0, 0.0, 0.0);
        for r in &s.seeds {
            let csv = night
                .join(&row.dir)
                .join(format!("seed{}", r.seed))
                .join(format!("{code}.csv"));
            let series = Series::read_csv(&csv)?;
            erot += series.window_mean("erot[J]", s.steady_window_steps);
            ke += series.window_mean("ke[J]", s.steady_window_steps);
            mob += series.window_mean("mobilised[-]", s.steady_window_steps);
        }
        let n = s.seeds.len().max(1) as f64;
        let (wall, thr): (Vec<f64>, Vec<f64>) = s
            .seeds
            .iter()
            .filter_map(|r| match code {
                "liggghts" => r.liggghts_wall_s.zip(r.liggghts_particle_steps_per_s),
                _ => r.native_wall_s.zip(r.native_particle_steps_per_s),
            })
            .unzip();
        let stats = CodeStats {
            mu: st.mu,
            mu_ci95: st.mu_ci95,
            per_seed_mu: st.per_seed_mu.clone(),
            normal_stress: st.per_seed_stress.iter().sum::<f64>() / n,
            erot: erot / n,
            ke: ke / n,
            mobilised: mob / n,
            wall_s: wall.iter().sum(),
            particle_steps_per_s: thr.iter().sum::<f64>() / thr.len().max(1) as f64,
        };
        if code == "liggghts" {
            row.liggghts = Some(stats);
        } else {
            row.native = Some(stats);
        }
    }
    Ok(())
}

/// The night's history records, one per case.
fn records(s: &NightlySummary, unix_time: u64, out: &Path) -> Vec<Record> {
    let base = Record {
        night: s.date_utc.clone(),
        unix_time,
        out: out.display().to_string(),
        quick: s.quick,
        commit: s.commit.clone(),
        liggghts_version: s.liggghts_version.clone(),
        kind: String::new(),
        case: String::new(),
        pass: false,
        error: None,
        max_err: None,
        tolerance: 0.0,
        mu_liggghts: None,
        mu_liggghts_ci95: None,
        mu_native: None,
        mu_native_ci95: None,
    };
    let contact = s.contact.iter().map(|c| Record {
        kind: "contact".into(),
        case: format!("{}/{}", c.case, c.model),
        pass: c.pass,
        error: c.error.clone(),
        max_err: c.max_rel_err.is_finite().then_some(c.max_rel_err),
        tolerance: c.rtol,
        ..base.clone()
    });
    let shear = s.shear.iter().map(|r| Record {
        kind: "shear".into(),
        case: r.name.clone(),
        pass: r.pass,
        error: r.error.clone(),
        max_err: r.dmu,
        tolerance: r.mu_atol,
        mu_liggghts: r.liggghts.as_ref().map(|c| c.mu),
        mu_liggghts_ci95: r.liggghts.as_ref().map(|c| c.mu_ci95),
        mu_native: r.native.as_ref().map(|c| c.mu),
        mu_native_ci95: r.native.as_ref().map(|c| c.mu_ci95),
        ..base.clone()
    });
    contact.chain(shear).collect()
}

fn status(pass: bool, error: &Option<String>) -> (String, &'static str) {
    match (error, pass) {
        (Some(_), _) => ("ERROR".into(), "fail"),
        (None, true) => ("agree".into(), "pass"),
        (None, false) => ("DISAGREE".into(), "fail"),
    }
}

fn num(v: Option<f64>, prec: usize) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x:.prec$}"),
        Some(x) => format!("{x}"),
        None => "–".into(),
    }
}

fn sci(v: f64) -> String {
    if v == 0.0 {
        "0 (bit for bit)".into()
    } else if v.is_finite() {
        format!("{v:.3e}")
    } else {
        format!("{v}")
    }
}

/// The report page.
fn report(s: &NightlySummary, history: &[Record], out: &Path) -> Result<String> {
    let plots = out.join("plots");
    let mut p = Page::new(&format!("verify nightly {}", s.date_utc));
    p.html("<h1>Native DEM vs LIGGGHTS: nightly agreement report</h1>");
    let (verdict, class) = if s.pass {
        ("ALL CASES AGREE", "pass")
    } else if s.errors.is_empty() {
        ("DISAGREEMENT", "fail")
    } else {
        ("ERRORS", "fail")
    };
    p.html(&format!("<div class=\"banner {class}\">{verdict}</div>"));
    let budget = match s.budget_s {
        Some(b) => format!(
            " (budget {:.1} h: {})",
            b / 3600.0,
            if s.wall_time_s <= b {
                "within"
            } else {
                "OVER BUDGET"
            }
        ),
        None => String::new(),
    };
    p.html(&format!(
        "<p class=\"meta\">Night {} UTC, {} night ({}) · project commit <b>{}</b> · {} · machine {} · \
         wall time <b>{:.1} min</b>{budget}</p>",
        escape(&s.date_utc),
        if s.quick { "quick" } else { "full" },
        if s.quick {
            "ci shear preset, 1 seed"
        } else {
            "fast shear preset, 3 seeds"
        },
        escape(&s.commit),
        escape(&s.liggghts_version),
        escape(&s.machine.describe()),
        s.wall_time_s / 60.0,
    ));
    for e in &s.errors {
        p.html(&format!("<p class=\"fail\">{}</p>", escape(e)));
    }
    let c_ok = s.contact.iter().filter(|c| c.pass).count();
    let c_bit = s.contact.iter().filter(|c| c.max_rel_err == 0.0).count();
    let s_ok = s.shear.iter().filter(|r| r.pass).count();
    let dmu_max = s.shear.iter().filter_map(|r| r.dmu).fold(0.0, f64::max);
    p.html(&format!(
        "<p style=\"font-size:18px\">Contact laws: <b>{c_ok}/{}</b> runs agree ({c_bit} bit for bit). \
         Shear box: <b>{s_ok}/{}</b> cases agree; largest |Δμ| between the codes {dmu_max:.3}.</p>",
        s.contact.len(),
        s.shear.len()
    ));

    // overview
    p.heading("overview", "Overview");
    let mut rows = Vec::new();
    for r in &s.shear {
        let (st, class) = status(r.pass, &r.error);
        rows.push(vec![
            (st, class),
            ("shear".into(), ""),
            (
                format!("<a href=\"#{}\">{}</a>", anchor(&r.dir), escape(&r.name)),
                "",
            ),
            (
                format!(
                    "|Δμ| = {}{}; normal stress off by {}",
                    num(r.dmu, 4),
                    match r.ci_overlap {
                        Some(true) => ", CIs overlap",
                        Some(false) => ", CIs do NOT overlap",
                        None => "",
                    },
                    r.stress_rel_err
                        .map(|e| format!("{:.2} %", 100.0 * e))
                        .unwrap_or("–".into())
                ),
                "",
            ),
            (
                format!(
                    "|Δμ| ≤ {} and 95 % CIs overlap; stress within {} %",
                    r.mu_atol,
                    100.0 * r.stress_rtol
                ),
                "",
            ),
            match r.dashpot_stable {
                Some(true) => ("stable".into(), "pass"),
                Some(false) => ("explicit dashpot UNSTABLE at this dt".into(), "warn"),
                None => ("–".into(), ""),
            },
        ]);
    }
    for r in &s.contact {
        let (st, class) = status(r.pass, &r.error);
        rows.push(vec![
            (st, class),
            ("contact".into(), ""),
            (
                format!(
                    "<a href=\"#{}\">{} / {}</a>",
                    anchor(&r.dir),
                    escape(&r.case),
                    escape(&r.model)
                ),
                "",
            ),
            (
                match &r.error {
                    Some(e) => escape(e),
                    None if r.max_rel_err == 0.0 => "bit for bit in every channel".into(),
                    None => format!(
                        "max rel err {} ({})",
                        sci(r.max_rel_err),
                        escape(&r.worst_channel)
                    ),
                },
                "",
            ),
            (format!("≤ {:.0e} of the channel peak", r.rtol), ""),
            ("–".into(), ""),
        ]);
    }
    p.html(&table(
        &[
            "status",
            "kind",
            "case",
            "measured",
            "tolerance",
            "rolling dashpot",
        ],
        &rows,
    ));

    // steady friction
    p.heading("steady", "Steady friction coefficient, both codes");
    let groups: Vec<BarGroup> = s
        .shear
        .iter()
        .map(|r| BarGroup {
            label: format!("{} μr={} ηr={}", r.rolling, r.mu_r, r.eta_r),
            bars: [&r.liggghts, &r.native]
                .iter()
                .enumerate()
                .map(|(k, c)| Bar {
                    value: c.as_ref().map(|c| c.mu).unwrap_or(f64::NAN),
                    ci95: c.as_ref().map(|c| c.mu_ci95).unwrap_or(f64::NAN),
                    color: k,
                })
                .collect(),
        })
        .collect();
    let bars = bar_chart(
        "steady mu = Fx / Fy (mean of the steady window, 95 % CI)",
        "mu",
        &groups,
        &["LIGGGHTS", "native"],
    );
    write_atomic(&plots.join("steady_mu.svg"), bars.as_bytes())?;
    let fig = p.svg(
        &bars,
        "Steady μ per shear case; whiskers: 95 % confidence interval (over seeds; one seed: over 10 blocks of the window).",
    );
    p.figures(&[fig]);

    // trends
    p.heading("trends", "Trends over nights");
    let figs = trend_plots(&mut p, history, s, &plots)?;
    p.figures(&figs);

    // shear cases
    p.heading("shear", "Shear cases");
    for r in &s.shear {
        shear_section(&mut p, r, out)?;
    }

    // performance
    p.heading("performance", "Wall time and throughput");
    let mut rows = Vec::new();
    for r in &s.shear {
        let c = |c: &Option<CodeStats>| {
            c.as_ref()
                .map(|c| {
                    (
                        format!("{:.0}", c.wall_s),
                        format!("{:.3e}", c.particle_steps_per_s),
                    )
                })
                .unwrap_or(("–".into(), "–".into()))
        };
        let (lw, lt) = c(&r.liggghts);
        let (nw, nt) = c(&r.native);
        let ratio = match (&r.liggghts, &r.native) {
            (Some(l), Some(n)) => format!("{:.2}", n.particle_steps_per_s / l.particle_steps_per_s),
            _ => "–".into(),
        };
        rows.push(vec![
            (escape(&r.name), ""),
            (lw, "num"),
            (lt, "num"),
            (nw, "num"),
            (nt, "num"),
            (ratio, "num"),
        ]);
    }
    let contact_wall: f64 = s.contact.iter().map(|c| c.wall_s).sum();
    p.html(&table(
        &[
            "shear case",
            "LIGGGHTS wall [s]",
            "LIGGGHTS particle-steps/s",
            "native wall [s]",
            "native particle-steps/s",
            "native / LIGGGHTS",
        ],
        &rows,
    ));
    p.para(&format!(
        "Each seed runs both codes side by side on this machine (LIGGGHTS one process, the native \
         solver on the remaining cores), so the throughputs are measured under the same load; \
         `verify bench` measures them on an idle machine. Contact cases: {} runs, {:.1} s in total \
         (both codes). Whole night: {:.1} min.",
        s.contact.len(),
        contact_wall,
        s.wall_time_s / 60.0
    ));

    // contact cases
    p.heading("contact", "Contact cases");
    p.para(
        "Per run: the main channel (rolling moment, tangential or normal force) of LIGGGHTS (solid) \
         and the native solver (dashed) overlaid, and the largest relative error over every channel \
         (forces, moments, contact history, positions, velocities, angular velocities, torques) \
         against time.",
    );
    for r in &s.contact {
        p.html(&format!(
            "<h3 id=\"{}\">{} / {} — {}</h3>",
            anchor(&r.dir),
            escape(&r.case),
            escape(&r.model),
            match &r.error {
                Some(e) => format!("<span class=\"fail\">error: {}</span>", escape(e)),
                None => format!(
                    "max rel err {} (tolerance {:.0e})",
                    sci(r.max_rel_err),
                    r.rtol
                ),
            }
        ));
        let dir = out.join(&r.dir);
        let mut figs = Vec::new();
        for (f, cap) in [
            ("history.svg", "both codes overlaid"),
            ("error.svg", "relative error against time"),
        ] {
            if dir.join(f).is_file() {
                figs.push(p.svg_file(&dir.join(f), cap)?);
            }
        }
        p.figures(&figs);
    }
    p.para(
        "Files: summary.json (schema in the README), contact/<case>_<model>/ and shear/<case>/ \
         with each code's CSV, decks and logs; the history file holds one JSON line per case per night.",
    );
    Ok(p.finish())
}

fn anchor(dir: &str) -> String {
    dir.replace(['/', '.'], "-")
}

fn shear_section(p: &mut Page, r: &ShearRow, out: &Path) -> Result<()> {
    let (st, class) = status(r.pass, &r.error);
    p.html(&format!(
        "<h3 id=\"{}\">{} — <span class=\"{class}\">{st}</span></h3>",
        anchor(&r.dir),
        escape(&r.name)
    ));
    if let Some(e) = &r.error {
        p.html(&format!("<pre class=\"fail\">{}</pre>", escape(e)));
    }
    if let Some(rp) = &r.replay {
        let (st, class) = status(rp.pass, &None);
        p.html(&format!(
            "<p>Contact by contact (<code>verify replay</code>, seed 1): {} windows of {} steps \
             from LIGGGHTS' recorded states, worst step-1 error {} (limit {}), shortest horizon \
             {} steps: <span class=\"{class}\">{st}</span>.</p>",
            rp.windows,
            rp.steps,
            sci(rp.worst_step1),
            sci(rp.rtol),
            rp.min_horizon
        ));
    }
    if let Some(pd) = &r.paired_dmu {
        p.html(&format!(
            "<p>Paired over the same seeds, native − LIGGGHTS: {:+.4} ± {:.4} (95 % CI, {} seeds), \
             t = {:.2}, native higher in {} of {}.</p>",
            pd.mean, pd.ci95, pd.n, pd.t, pd.b_higher, pd.n
        ));
    }
    let mut rows = Vec::new();
    for (code, c) in [("LIGGGHTS", &r.liggghts), ("native", &r.native)] {
        if let Some(c) = c {
            rows.push(vec![
                (code.to_string(), ""),
                (format!("{:.4} ± {:.4}", c.mu, c.mu_ci95), "num"),
                (
                    c.per_seed_mu
                        .iter()
                        .map(|m| format!("{m:.4}"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    "num",
                ),
                (format!("{:.3}", c.normal_stress / 1e6), "num"),
                (format!("{:.3e}", c.erot), "num"),
                (format!("{:.3e}", c.ke), "num"),
                (
                    if c.mobilised.is_finite() {
                        format!("{:.3}", c.mobilised)
                    } else {
                        "not output".into()
                    },
                    "num",
                ),
                (format!("{:.0}", c.wall_s), "num"),
            ]);
        }
    }
    p.html(&table(
        &[
            "code",
            "steady μ (95 % CI)",
            "per seed",
            "normal stress [MPa]",
            "mean E_rot [J]",
            "mean E_kin [J]",
            "rolling mobilised",
            "wall [s]",
        ],
        &rows,
    ));
    p.para(&format!(
        "Lockstep from a common compacted state: the codes agree (1e-6 of the peak: plate forces, \
         top plate position, kinetic energies) for {} shear steps (shortest over seeds); chaos baseline (native vs native \
         one ulp apart): {} steps. Stability of the explicit rolling dashpot: {}{}.",
        r.lockstep_steps
            .map(|v| v.saturating_sub(1).to_string())
            .unwrap_or("–".into()),
        r.chaos_baseline_steps
            .map(|v| v.saturating_sub(1).to_string())
            .unwrap_or("–".into()),
        match r.dashpot_stable {
            Some(true) => "stable",
            Some(false) =>
                "UNSTABLE (results may show the dashpot artefact; see `verify convergence`)",
            None => "–",
        },
        r.worst_stability
            .as_ref()
            .map(|l| format!("; worst contact: {l}"))
            .unwrap_or_default()
    ));
    let dir = out.join(&r.dir);
    let mut figs = Vec::new();
    for (f, cap) in [
        ("mu_strain.svg", "μ(strain), both codes, every seed"),
        ("shear_force.svg", "shear force on the top plate"),
        ("top_force.svg", "normal force on the top plate"),
        ("kinetic_energy.svg", "rotational kinetic energy"),
        (
            "mobilised.svg",
            "fraction of touching pairs at full rolling mobilisation (native)",
        ),
    ] {
        if dir.join(f).is_file() {
            figs.push(p.svg_file(&dir.join(f), cap)?);
        }
    }
    p.figures(&figs);
    Ok(())
}

/// Trend plots from the history: largest contact error per case, steady mu per code and shear
/// case, against days since the first night in the history.
fn trend_plots(
    p: &mut Page,
    history: &[Record],
    s: &NightlySummary,
    plots: &Path,
) -> Result<Vec<String>> {
    let t0 = history.iter().map(|r| r.unix_time).min().unwrap_or(0);
    let day = |r: &Record| (r.unix_time - t0) as f64 / 86400.0;
    let nights = {
        let mut n: Vec<&str> = history.iter().map(|r| r.night.as_str()).collect();
        n.sort();
        n.dedup();
        n.len()
    };
    let mut figs = Vec::new();
    // contact: one curve per case (largest over its models), and the tolerance
    let mut cases: Vec<String> = s.contact.iter().map(|c| c.case.clone()).collect();
    cases.dedup();
    let mut data: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for case in &cases {
        let mut pts: Vec<(f64, f64)> = Vec::new();
        for r in history
            .iter()
            .filter(|r| r.kind == "contact" && r.case.split('/').next() == Some(case))
        {
            let e = r.max_err.unwrap_or(f64::NAN);
            match pts.iter_mut().find(|q| q.0 == day(r)) {
                Some(q) => q.1 = q.1.max(e),
                None => pts.push((day(r), e)),
            }
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        data.push((case.clone(), pts));
    }
    let span = history.iter().map(day).fold(0.0, f64::max).max(1.0);
    let tol = vec![(0.0, CONTACT_RTOL), (span, CONTACT_RTOL)];
    let mut curves: Vec<Curve> = data
        .iter()
        .enumerate()
        .map(|(k, (l, pts))| Curve::new(l, pts, k + 2))
        .collect();
    curves.push(Curve::new("tolerance", &tol, 3).dashed());
    let path = plots.join("trend_contact.svg");
    line_plot(
        &path,
        "contact cases: largest relative error per night",
        "days since the first night in the history",
        "max rel err",
        &curves,
    )?;
    figs.push(p.svg_file(
        &path,
        &format!("{nights} night(s) in the history; tolerance dashed."),
    )?);
    // shear: steady mu of both codes per case (colour per case; native dashed)
    // entries alternate LIGGGHTS, native
    let mut data: Vec<CurveData> = Vec::new();
    for (k, r) in s.shear.iter().enumerate() {
        for (code, native) in [("LIGGGHTS", false), ("native", true)] {
            let mut v: Vec<(f64, f64)> = history
                .iter()
                .filter(|h| h.kind == "shear" && h.case == r.name)
                .filter_map(|h| {
                    let m = if native { h.mu_native } else { h.mu_liggghts };
                    m.map(|m| (day(h), m))
                })
                .collect();
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
            data.push((format!("{} {code}", r.name), k, v));
        }
    }
    let curves: Vec<Curve> = data
        .iter()
        .enumerate()
        .map(|(i, (l, k, v))| {
            let c = Curve::new(l, v, *k);
            if i % 2 == 1 {
                c.dashed()
            } else {
                c
            }
        })
        .collect();
    let path = plots.join("trend_shear.svg");
    line_plot(
        &path,
        "shear cases: steady mu per night",
        "days since the first night in the history",
        "steady mu",
        &curves,
    )?;
    figs.push(p.svg_file(
        &path,
        "Steady μ per night and shear case: LIGGGHTS solid, native dashed, one colour per case.",
    )?);
    Ok(figs)
}
