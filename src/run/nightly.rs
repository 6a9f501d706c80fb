//! `verify nightly`: every built-in contact case with every applicable rolling model and the
//! nightly shear cases, in both codes, into one self-contained HTML report, a `summary.json`
//! and a history of nights (JSON lines) that the report draws trends from.
//!
//! Data flow: cases -> `verify contact` / `verify shear` runs (their outputs, CSVs and plots
//! under DIR/contact and DIR/shear) -> rows of `summary.json` -> history append -> report.html.
//! Interrupted nights resume: shear seeds already finished in DIR are reused.

use super::contact::{contact_one, contact_runs, ContactRequest, RollingChoice};
use super::history::{self, Record};
pub use super::nightly_outcome::*;
use super::replay::{default_states, ReplayOutcome, ReplayRequest, STEP1_RTOL};
use super::shear::{SeedResult, ShearRequest, ShearSummary};
use super::{utc_stamp, Code, Engine, LiggghtsRequest, Verdict};
use crate::compare::{within_cis, CONTACT_RTOL, MU_MARGIN, STRESS_RTOL};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::Liggghts;
use crate::run::tell::say;
use crate::spec::shear::{CaseRequest, Overrides, Preset, Protocol, ShearCase};
use crate::spec::RollingModel;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// A night: every contact case and the nightly shear points in both codes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NightlyRequest {
    /// Output directory of this night (report.html, summary.json, every run's files).
    pub out: PathBuf,
    /// CI-sized night: the ci shear preset with one seed (minutes instead of hours).
    pub quick: bool,
    /// History file (JSON lines; default: history.jsonl next to `out`).
    pub history: Option<PathBuf>,
    /// The shear runs' LIGGGHTS (contact runs use the binary with their own timeout).
    pub liggghts: LiggghtsRequest,
}

/// The shear cases of every night: (mu_r, eta_r, rolling model). The paper's model epsd over
/// the corners of its map, and epsd2 (no dashpot) at one point.
pub const SHEAR_POINTS: [(f64, f64, RollingModel); 5] = [
    (0.0, 0.0, RollingModel::Epsd),
    (0.5, 0.0, RollingModel::Epsd),
    (0.5, 0.5, RollingModel::Epsd),
    (1.0, 0.5, RollingModel::Epsd),
    (0.5, 0.0, RollingModel::Epsd2),
];

/// Seeds per shear point in a full night (paired: the same packings in both codes).
pub const FULL_SEEDS: u64 = 6;

/// Wall-time budget of a full night on the 2-core reference machine [s].
pub const FULL_BUDGET_S: f64 = 3.0 * 3600.0;

/// Steady |mu_LIGGGHTS - mu_native| accepted in a quick night: one seed of 300 particles; the
/// seed-to-seed spread of the ci preset is about 0.03, so two chaotic realisations differ by up
/// to about 0.1 (95 %). The 95 % CIs must overlap as well.
pub const QUICK_MU_MARGIN: f64 = 0.1;

/// Normal-stress tolerance of a quick night: the steady-window mean of one seed of 300
/// particles wanders 1-2 % around the servo target (0.1-1.3 % measured at the five points).
pub const QUICK_STRESS_RTOL: f64 = 0.03;

impl NightlySummary {
    /// The night passes when nothing failed to run and every contact and shear row passes.
    pub fn rows_pass(&self) -> bool {
        self.errors.is_empty()
            && self.contact.iter().all(|c| c.pass)
            && self.shear.iter().all(|r| r.pass)
    }

    pub fn verdict(&self) -> Verdict {
        if self.pass && self.shear.iter().any(|s| s.inconclusive) {
            Verdict::Inconclusive
        } else {
            Verdict::from_pass(self.pass)
        }
    }
}

/// The history file of a night: `a.history`, or history.jsonl next to its folder.
fn history_path(a: &NightlyRequest) -> PathBuf {
    a.history.clone().unwrap_or_else(|| {
        a.out
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .join("history.jsonl")
    })
}

/// What the night draws as each run finishes (the report layer's figures, given by the
/// command): the run layer runs and judges, and never imports the report layer.
pub trait Figures {
    /// A shear point's seed as it finishes (its lines on stdout).
    fn seed(&self, s: &SeedResult);
    /// A shear point's figures into its folder `out`, from its outcome, and its summary on
    /// stdout.
    fn shear(&self, out: &Path, s: &ShearSummary) -> Result<()>;
    /// A replay's figures into its folder `out`, and its table on stdout.
    fn replay(&self, out: &Path, o: &ReplayOutcome, ran: bool) -> Result<()>;
}

/// A night as run or judged again: its summary and the whole history (this night's records
/// included), which the report draws trends from.
pub struct Night {
    pub summary: NightlySummary,
    pub history: Vec<Record>,
}

impl Night {
    /// The night's outcome once its report is written (`page`): the summary, or the error of
    /// the cases that could not be run.
    pub fn finish(self, page: &Path) -> Result<NightlySummary> {
        let s = self.summary;
        if !s.errors.is_empty() {
            return Err(Error::Cases(format!(
                "{} case(s) of the night could not be run (report written to {}):\n  {}",
                s.errors.len(),
                page.display(),
                s.errors.join("\n  ")
            )));
        }
        Ok(s)
    }
}

/// Runs the night (resuming what DIR holds), drawing each run's `figures` as it finishes,
/// writes `summary.json` and appends the history. A case that could not be run is kept in its
/// row and makes the night an error ([`Night::finish`]) after everything else has run and been
/// reported.
pub fn run(a: &NightlyRequest, figures: &dyn Figures) -> Result<Night> {
    let t0 = Instant::now();
    let start = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let date = utc_stamp();
    let history_path = history_path(a);
    // fail early on an unreadable history, before hours of runs
    history::read(&history_path)?;
    let lig = a.liggghts.locate()?;
    let version = lig.version();
    let commit = git_commit();
    let machine = Machine::detect();
    std::fs::create_dir_all(&a.out).map_err(|e| Error::io(&a.out, e))?;
    say!(
        "verify nightly{}: output {}, history {}\n  {version}, commit {commit}, {}",
        if a.quick { " --quick" } else { "" },
        a.out.display(),
        history_path.display(),
        machine.describe()
    );
    let contact = contact_night(a)?;
    let shear: Vec<ShearRow> = SHEAR_POINTS
        .iter()
        .map(|&(mu_r, eta_r, rolling)| shear_night(a, &lig, mu_r, eta_r, rolling, figures))
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
    let mut summary = NightlySummary {
        schema: super::SCHEMA,
        pass: false,
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
        rejudged: None,
    };
    summary.pass = summary.rows_pass();
    write_atomic(
        &a.out.join("summary.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    super::note_summary(&a.out.join("summary.json"));
    let history = history::append(&history_path, &records(&summary, start, &a.out))?;
    Ok(Night { summary, history })
}

/// Every built-in contact case with every applicable rolling model, live LIGGGHTS.
fn contact_night(a: &NightlyRequest) -> Result<Vec<ContactRow>> {
    let out = a.out.join("contact");
    let req = ContactRequest {
        rtol: CONTACT_RTOL,
        reference_dir: super::default_reference_dir()?,
        update_reference: false,
    };
    let lig = LiggghtsRequest {
        binary: a.liggghts.binary.clone(),
        timeout_s: super::CONTACT_TIMEOUT_S,
    }
    .locate()?;
    let mut rows = Vec::new();
    for case in contact_runs("all", None, RollingChoice::All)? {
        let model = case.models.rolling.keyword().to_string();
        let t = Instant::now();
        let r = contact_one(&case, &req, Some(&lig), &out);
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
        say!(
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

fn shear_dir(mu_r: f64, eta_r: f64, rolling: RollingModel) -> String {
    format!("shear/{rolling}_mur{mu_r}_etar{eta_r}")
}

/// Every seed's shear case of a night (full: the fast preset, FULL_SEEDS seeds per point; quick:
/// the ci preset, one seed), both codes run each: what a study's plan counts.
pub fn shear_cases(quick: bool) -> Result<Vec<crate::spec::shear::ShearCase>> {
    let mut out = Vec::new();
    for &(mu_r, eta_r, rolling) in &SHEAR_POINTS {
        let seeds = if quick { 1 } else { FULL_SEEDS };
        for seed in 1..=seeds {
            let (c, _) = crate::spec::shear::ShearCase::build(&CaseRequest {
                preset: if quick { Preset::Ci } else { Preset::Fast },
                rolling,
                mu_r,
                eta_r,
                seed,
                protocol: Protocol::default(),
                overrides: Overrides::default(),
                allow_inertial: false,
            })?;
            out.push(c);
        }
    }
    Ok(out)
}

/// One shear case of the night (errors are kept in the row, the night goes on).
fn shear_night(
    a: &NightlyRequest,
    lig: &Liggghts,
    mu_r: f64,
    eta_r: f64,
    rolling: RollingModel,
    figures: &dyn Figures,
) -> ShearRow {
    let preset = if a.quick { Preset::Ci } else { Preset::Fast };
    let dir = shear_dir(mu_r, eta_r, rolling);
    let case = night_case(preset, rolling, mu_r, eta_r);
    let mut args = ShearRequest::new(
        case,
        if a.quick { 1 } else { FULL_SEEDS },
        Engine::Both,
        a.out.join(&dir),
    );
    (args.mu_margin, args.stress_rtol) = tolerances(a.quick);
    args.liggghts = a.liggghts.clone();
    let mut row = ShearRow {
        name: format!("{preset}/{rolling} mu_r={mu_r} eta_r={eta_r}"),
        preset,
        rolling,
        mu_r,
        eta_r,
        seeds: args.seeds,
        pass: false,
        inconclusive: false,
        error: None,
        dmu: None,
        mu_atol: args.mu_margin,
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
        mu_equivalence: None,
        replay: None,
        dir,
    };
    say!("\n== shear {} ==", row.name);
    match super::shear::run(&args, &|s| figures.seed(s)).and_then(|s| {
        figures.shear(&args.out, &s)?;
        fill_shear_row(&mut row, &s)
    }) {
        Ok(()) => {}
        Err(e) => row.error = Some(e.to_string()),
    }
    say!("\n== replay {} ==", row.name);
    match ShearCase::preset(preset, rolling, mu_r, eta_r, 1)
        .and_then(|case| replay_night(a, lig, case, &row.dir, figures))
    {
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

/// The steady-mu equivalence margin and the normal-stress tolerance of a night's shear rows
/// (quick: widened to what one seed of the ci preset resolves).
fn tolerances(quick: bool) -> (f64, f64) {
    if quick {
        (QUICK_MU_MARGIN, QUICK_STRESS_RTOL)
    } else {
        (MU_MARGIN, STRESS_RTOL)
    }
}

/// A row's figures from its judged channels: `dmu` from `mu_steady`, the stress error the
/// largest of the `normal_stress_*` channels (only those are stress errors: the 2026-12-02
/// night reported the paired statistic as one).
fn channel_figures(row: &mut ShearRow, results: &[crate::compare::ChannelResult]) {
    for r in results {
        if r.channel == "mu_steady" {
            row.dmu = Some(r.max_abs_err);
        } else if r.channel.starts_with("normal_stress") {
            row.stress_rel_err = Some(row.stress_rel_err.unwrap_or(0.0).max(r.max_rel_err));
        }
    }
}

/// The case of a nightly shear point (its first seed).
fn night_case(preset: Preset, rolling: RollingModel, mu_r: f64, eta_r: f64) -> CaseRequest {
    CaseRequest {
        preset,
        rolling,
        mu_r,
        eta_r,
        seed: 1,
        protocol: Protocol::default(),
        overrides: Overrides::default(),
        allow_inertial: false,
    }
}

/// A stored night's shear rows judged again by this version's rules from their stored
/// per-seed figures, as a night run now would judge them: the steady-mu equivalence test
/// ([`super::shear::mu_results`], margin [`MU_MARGIN`] or [`QUICK_MU_MARGIN`]) and each code's
/// normal stress against the preset's target ([`super::shear::stress_result`]); a row's
/// replay must still pass and its error stays an error. The slip channel is not stored in a
/// nightly row and is not judged again. Rows without both codes' per-seed figures keep
/// their stored verdict. The night's verdict follows its rows.
pub fn rejudge(s: &mut NightlySummary) -> Result<()> {
    let (margin, rtol) = tolerances(s.quick);
    for row in &mut s.shear {
        let (Some(l), Some(n)) = (&row.liggghts, &row.native) else {
            continue;
        };
        let (l, n) = (&l.steady.clone(), &n.steady.clone());
        let req = ShearRequest::new(
            night_case(row.preset, row.rolling, row.mu_r, row.eta_r),
            row.seeds,
            Engine::Both,
            PathBuf::new(),
        );
        let (case, _) = req.seed_case(1)?;
        let model = row.rolling.keyword();
        let (mut results, paired, eq) = super::shear::mu_results(&row.name, model, l, n, 0, margin);
        results.extend([("liggghts", l), ("native", n)].map(|(code, st)| {
            super::shear::stress_result(&row.name, model, code, st, case.normal_stress, 0, rtol)
        }));
        row.stress_rel_err = None;
        channel_figures(row, &results);
        row.mu_equivalence = Some(eq);
        row.mu_atol = margin;
        row.stress_rtol = rtol;
        row.ci_overlap = Some(within_cis(l.mu, l.mu_ci95, n.mu, n.mu_ci95));
        row.paired_dmu = paired;
        row.pass = row.error.is_none()
            && results.iter().all(|r| r.pass)
            && row.replay.as_ref().is_none_or(|r| r.pass);
        row.inconclusive = row.pass && results.iter().any(|r| r.inconclusive);
    }
    s.pass = s.rows_pass();
    s.rejudged = Some(format!(
        "verify {} (commit {}), {}",
        env!("CARGO_PKG_VERSION"),
        git_commit(),
        utc_stamp()
    ));
    Ok(())
}

/// `verify nightly --rerender`: the stored `summary.json` of `a.out` judged again
/// ([`rejudge`]) and its `report.html` made again by this version, with the history read (not
/// appended). No case runs; `summary.json` is kept as the night wrote it.
pub fn rerender(a: &NightlyRequest) -> Result<Night> {
    let mut summary: NightlySummary = super::load(&a.out.join("summary.json"))?;
    rejudge(&mut summary)?;
    let history = history::read(&history_path(a))?;
    Ok(Night { summary, history })
}

/// `verify replay` of a nightly point (`case`: its seed 1): windows in compaction and early shear (a stored
/// outcome of the same case and windows is reused, so a resumed night does not redo it).
fn replay_night(
    a: &NightlyRequest,
    lig: &Liggghts,
    case: ShearCase,
    dir: &str,
    figures: &dyn Figures,
) -> Result<ReplayRow> {
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
    let (o, ran) = match stored {
        Some(o) => (o, false),
        None => {
            std::fs::create_dir_all(&out).map_err(|e| Error::io(&out, e))?;
            let req = ReplayRequest {
                case,
                states,
                steps,
                rtol: STEP1_RTOL,
                out: out.clone(),
            };
            (super::replay::run(&req, lig, |m| say!("  {m}"))?, true)
        }
    };
    figures.replay(&out, &o, ran)?;
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

fn fill_shear_row(row: &mut ShearRow, s: &ShearSummary) -> Result<()> {
    row.pass = s.pass;
    row.inconclusive = s.verdict() == Verdict::Inconclusive;
    row.dashpot_stable = Some(s.stability.stable);
    row.worst_stability = s.stability.lines(1).into_iter().next();
    channel_figures(row, &s.results);
    if let (Some(l), Some(n)) = (&s.liggghts, &s.native) {
        row.ci_overlap = Some(within_cis(l.mu, l.mu_ci95, n.mu, n.mu_ci95));
    }
    row.paired_dmu = s.paired_dmu.clone();
    row.mu_equivalence = s.mu_equivalence.clone();
    let lock = |f: &dyn Fn(&SeedResult) -> Option<u64>| {
        s.seeds.iter().map(f).collect::<Option<Vec<u64>>>()
    };
    row.lockstep_steps = lock(&|r| r.shear_lockstep.as_ref().map(|h| h.last_agree_step))
        .and_then(|v| v.into_iter().min());
    row.chaos_baseline_steps =
        lock(&|r| r.shear_chaos_baseline.as_ref().map(|h| h.last_agree_step))
            .and_then(|v| v.into_iter().min());
    for code in Code::BOTH {
        let (st, slot, profiles) = match code {
            Code::Liggghts => (&s.liggghts, &mut row.liggghts, &s.profiles.liggghts),
            Code::Native => (&s.native, &mut row.native, &s.profiles.native),
        };
        let Some(st) = st else { continue };
        if st.per_seed_mu.len() != s.seeds.len() {
            return Err(Error::Missing {
                what: format!(
                    "{code} steady figures ({} for {} seeds)",
                    st.per_seed_mu.len(),
                    s.seeds.len()
                ),
                dir: PathBuf::from(&row.dir),
            });
        }
        let (wall, thr): (Vec<f64>, Vec<f64>) = s
            .seeds
            .iter()
            .filter_map(|r| match code {
                Code::Liggghts => r.liggghts_wall_s.zip(r.liggghts_particle_steps_per_s),
                Code::Native => r.native_wall_s.zip(r.native_particle_steps_per_s),
            })
            .unzip();
        *slot = Some(CodeStats {
            steady: st.clone(),
            profile: profiles.last().cloned(),
            wall_s: wall.iter().sum(),
            particle_steps_per_s: thr.iter().sum::<f64>() / thr.len().max(1) as f64,
        });
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
        mu_liggghts: r.liggghts.as_ref().map(|c| c.steady.mu),
        mu_liggghts_ci95: r.liggghts.as_ref().map(|c| c.steady.mu_ci95),
        mu_native: r.native.as_ref().map(|c| c.steady.mu),
        mu_native_ci95: r.native.as_ref().map(|c| c.steady.mu_ci95),
        ..base.clone()
    });
    contact.chain(shear).collect()
}
