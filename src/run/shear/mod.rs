//! The shear study: the paper's shear experiment in LIGGGHTS and natively from one case and
//! one initial packing per seed, compared in lockstep and at steady state.

mod cache;
mod lockstep;
mod outcome;

use super::{utc_stamp, Engine, LiggghtsRequest, SHEAR_TIMEOUT_S};
use crate::compare::{lockstep, steady, LOCKSTEP_RTOL, MU_MARGIN, STRESS_RTOL};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::Liggghts;
use crate::packing::loose_packing;
use crate::run::progress::Progress;
use crate::run::tell;
use crate::series::Series;
use crate::shear::{run_liggghts, run_native, write_packing, Checkpointing, CHECKPOINT_EVERY};
use crate::spec::shear::{CaseRequest, ShearCase};
use crate::spec::windows::steady_window;
use cache::{cached, store};
use lockstep::cached_lockstep;
pub use lockstep::{lockstep_case, shear_lockstep, LOCKSTEP_CHANNELS, LOCKSTEP_SHEAR_STEPS};
use outcome::slip_results;
pub use outcome::{mu_results, stress_result, CodeProfiles, CodeSeries, SeedResult, ShearSummary};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// A shear study: seeds of one case in the codes asked for, compared.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShearRequest {
    /// The case (its `seed` is the first seed).
    pub case: CaseRequest,
    /// Number of seeds: runs seeds case.seed ..= case.seed + seeds - 1.
    pub seeds: u64,
    pub engine: Engine,
    /// Threads of the native solver (default: all cores, minus one while LIGGGHTS runs).
    pub threads: Option<usize>,
    pub out: PathBuf,
    /// No progress display or per-seed lines (callers with a display of their own).
    pub quiet: bool,
    /// With `quiet`: still print a progress line (steps, simulated time, ETA) per 10 % of
    /// each run, labelled with this (a sweep's run id: its runs last hours).
    #[serde(default)]
    pub progress_label: Option<String>,
    /// Refuse to run when the explicit rolling dashpot is expected to be unstable.
    pub strict_stability: bool,
    /// Largest accepted |mu_LIGGGHTS - mu_native| of the steady means (CIs must overlap too).
    pub mu_margin: f64,
    /// Largest accepted relative deviation of each code's mean normal stress from the target.
    pub stress_rtol: f64,
    pub liggghts: LiggghtsRequest,
    /// When native runs write their checkpoint (and resume from it).
    pub checkpoint: Checkpointing,
}

impl ShearRequest {
    /// The request of `case` with the command line's defaults for everything else.
    pub fn new(case: CaseRequest, seeds: u64, engine: Engine, out: PathBuf) -> Self {
        ShearRequest {
            case,
            seeds,
            engine,
            threads: None,
            out,
            quiet: false,
            progress_label: None,
            strict_stability: false,
            mu_margin: MU_MARGIN,
            stress_rtol: STRESS_RTOL,
            liggghts: LiggghtsRequest {
                binary: None,
                timeout_s: SHEAR_TIMEOUT_S,
            },
            checkpoint: Checkpointing::Every(CHECKPOINT_EVERY),
        }
    }

    /// The validated case of seed `seed` (built by the spec layer, once per seed).
    pub fn seed_case(&self, seed: u64) -> Result<(ShearCase, Vec<String>)> {
        shear_case(&self.case, seed, self.engine)
    }

    /// The seeds of the study.
    pub fn seed_range(&self) -> std::ops::Range<u64> {
        self.case.seed..self.case.seed + self.seeds
    }

    /// The request's own fields, checked as the run checks them (the run, the sweep and a
    /// study's `--dry-run` plan call this one rule).
    pub fn validate(&self) -> Result<()> {
        if self.seeds == 0 || self.seeds > 1000 {
            return Err(Error::invalid("--seeds", self.seeds, "1 ..= 1000"));
        }
        if self.case.seed == 0 || self.case.seed > MAX_FIRST_SEED {
            return Err(Error::invalid(
                "--first-seed",
                self.case.seed,
                format!("1 ..= {MAX_FIRST_SEED}"),
            ));
        }
        if let Some(t) = self.threads {
            super::check_threads("--threads", t)?;
        }
        if !(self.mu_margin.is_finite() && self.mu_margin > 0.0 && self.mu_margin < 1.0) {
            return Err(Error::invalid(
                "--mu-margin",
                self.mu_margin,
                "a number in (0, 1)",
            ));
        }
        if !(self.stress_rtol.is_finite() && self.stress_rtol > 0.0 && self.stress_rtol < 1.0) {
            return Err(Error::invalid(
                "--stress-rtol",
                self.stress_rtol,
                "a number in (0, 1)",
            ));
        }
        Ok(())
    }
}

/// Largest first seed: seeds and their sums stay far from u64 overflow.
pub const MAX_FIRST_SEED: u64 = u64::MAX / 2;

/// The validated case of one seed run by `engine`: [`ShearCase::build`], and the check that a
/// native-only rolling model is not asked of LIGGGHTS.
pub fn shear_case(c: &CaseRequest, seed: u64, engine: Engine) -> Result<(ShearCase, Vec<String>)> {
    if c.rolling.native_only() && engine.runs_liggghts() {
        return Err(Error::invalid(
            "--rolling",
            c.rolling,
            "a LIGGGHTS model when LIGGGHTS runs; epsd_implicit exists only in the native solver (use --native-only or --engine native)",
        ));
    }
    ShearCase::build(&CaseRequest { seed, ..c.clone() })
}

/// Runs every seed of a shear case in the codes asked for (reusing stored per-seed results),
/// compares them, writes `summary.json` into the output directory, and returns the summary.
/// `on_seed` is given each seed's result as it finishes (the command prints it; the run
/// layer prints no result itself).
pub fn run(a: &ShearRequest, on_seed: &dyn Fn(&SeedResult)) -> Result<ShearSummary> {
    a.validate()?;
    let cases: Vec<(ShearCase, Vec<String>)> = a
        .seed_range()
        .map(|s| a.seed_case(s))
        .collect::<Result<_>>()?;
    run_cases(a, cases, on_seed)
}

/// [`run`] with the seeds' cases already built (`a.seed_case` of each seed, in order; a sweep
/// builds its case once to check the input hash and passes it on).
pub fn run_cases(
    a: &ShearRequest,
    cases: Vec<(ShearCase, Vec<String>)>,
    on_seed: &dyn Fn(&SeedResult),
) -> Result<ShearSummary> {
    if cases.len() as u64 != a.seeds || cases.is_empty() {
        return Err(Error::invalid(
            "cases",
            cases.len(),
            format!("one case per seed ({})", a.seeds),
        ));
    }
    a.validate()?;
    let case0 = &cases[0].0;
    let run_lig = a.engine.runs_liggghts();
    if a.engine.runs_native() {
        super::check_memory("particles", case0.particles)?;
    }
    let lig = if run_lig {
        Some(a.liggghts.locate()?)
    } else {
        None
    };
    // one owner per output folder, held to the end of the run (two runs into one --out
    // would overwrite each other's seeds and summary)
    let _lock = crate::fsutil::DirLock::acquire(&a.out, "--out")?;
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let threads = a
        .threads
        .unwrap_or(if run_lig { (cores - 1).max(1) } else { cores });
    super::check_threads("--threads", threads)?;
    let setting = announce(a, case0, &cases[0].1, threads)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::invalid("--threads", threads, e.to_string()))?;
    let mut runs = Runs::default();
    for (case, _) in &cases {
        let (sr, ls, ns) = run_seed(a, case, lig.as_ref(), &pool)?;
        on_seed(&sr);
        runs.seeds.push(sr);
        runs.liggghts.extend(ls);
        runs.native.extend(ns);
    }
    summarise(a, case0, lig.as_ref(), setting, runs)
}

/// What a study states before it runs (and keeps in its summary): the stages' inertial
/// numbers, the case's differences from the paper's tables, the rolling dashpot's stability.
struct Setting {
    inertial: Vec<f64>,
    deviations: Vec<crate::spec::paper_table::Deviation>,
    stability: crate::spec::stability_shear::StabilityReport,
}

/// The seeds' results and series as the runs give them.
#[derive(Default)]
struct Runs {
    seeds: Vec<SeedResult>,
    liggghts: Vec<Series>,
    native: Vec<Series>,
}

/// The study's set-up, printed (unless quiet) before the runs: preset, particles, model,
/// inertial numbers, snapshots, deviations from the paper, the case's warnings and the
/// stability table; refuses an unstable explicit dashpot with `--strict-stability`.
fn announce(
    a: &ShearRequest,
    case0: &ShearCase,
    warnings: &[String],
    threads: usize,
) -> Result<Setting> {
    // a caller with a display of its own (a sweep) gets warnings only
    let quiet = a.quiet;
    macro_rules! say {
        ($($t:tt)*) => {
            if !quiet {
                $crate::run::tell::say!($($t)*)
            }
        };
    }
    let out = &a.out;
    let inertial: Vec<f64> = (0..case0.stages.len())
        .map(|k| case0.inertial_number(k))
        .collect();
    say!(
        "verify shear: preset {}, {} particles, rolling {} (mu_r {}, eta_r {}), {} seed(s), dt {:e} s, {} steps per seed",
        a.case.preset,
        case0.particles,
        case0.models.rolling,
        a.case.mu_r,
        a.case.eta_r,
        a.seeds,
        case0.dt,
        case0.total_steps()
    );
    say!(
        "  inertial number I = {}; contact stiffness number kappa = {:.0}; native threads {threads}; output {}",
        inertial.iter().map(|i| format!("{i:.2e}")).collect::<Vec<_>>().join(", "),
        case0.kappa(),
        out.display()
    );
    if case0.snapshot_every > 0 {
        say!(
            "  particle snapshots for ParaView every {} steps ({:.3e} s): {}",
            case0.snapshot_every,
            case0.snapshot_every as f64 * case0.dt,
            out.join("seed*/vtk/{native,liggghts}.pvd").display()
        );
    } else {
        say!("  no particle snapshots (--snapshot-every N writes them)");
    }
    let deviations = crate::spec::paper_table::deviations(case0);
    say!("  differs from the paper's Tables 1-2 in:");
    for d in &deviations {
        say!("    {d}");
    }
    for w in warnings.iter().filter(|_| !quiet) {
        tell::warning(w);
    }
    let stab = crate::spec::stability_shear::stability(case0);
    say!("  stability (worst first; S = n (omega_r^2 dt^2 + 2 lambda dt), explicit dashpot unstable at S >= 4):");
    for l in stab.lines(3) {
        say!("    {l}");
    }
    if !stab.stable {
        let msg = format!(
            "the explicit rolling dashpot is expected to be unstable at dt = {:e} s (worst: {}, S = {:.2}); \
             results may show spurious rotational energy and friction weakening: check with `verify convergence`",
            case0.dt, stab.entries[0].contact, stab.entries[0].criterion
        );
        if a.strict_stability {
            return Err(Error::invalid(
                "dt",
                case0.dt,
                format!("a stable explicit rolling dashpot (--strict-stability): {msg}"),
            ));
        }
        if !quiet {
            tell::warning(&msg);
        }
    }
    Ok(Setting {
        inertial,
        deviations,
        stability: stab,
    })
}

/// One seed: both codes' runs (side by side; a finished run is reused), each stored before
/// the other's failure is reported, the lockstep comparisons, and the seed's figures.
fn run_seed(
    a: &ShearRequest,
    case: &ShearCase,
    lig: Option<&Liggghts>,
    pool: &rayon::ThreadPool,
) -> Result<(SeedResult, Option<Series>, Option<Series>)> {
    let (quiet, out) = (a.quiet, &a.out);
    let (run_lig, run_nat) = (a.engine.runs_liggghts(), a.engine.runs_native());
    macro_rules! say {
        ($($t:tt)*) => {
            if !quiet {
                $crate::run::tell::say!($($t)*)
            }
        };
    }
    let dir = out.join(format!("seed{}", case.seed));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    write_atomic(
        &dir.join("case.toml"),
        toml::to_string(case)
            .map_err(|e| Error::invalid("case", "", e.to_string()))?
            .as_bytes(),
    )?;
    let packing = loose_packing(case);
    write_packing(&packing, &dir.join("initial_packing.csv"))?;
    let total = case.total_steps();
    // a bar (or decile lines off a terminal); quiet: lines under the caller's label, or none
    let progress = |code: &str| match (quiet, &a.progress_label) {
        (false, _) => Progress::new(&format!("{code} s{}", case.seed), total, case.dt),
        (true, Some(l)) => Progress::lines(&format!("{l} {code}"), total, case.dt),
        (true, None) => Progress::hidden(),
    };
    let (lr, nr) = std::thread::scope(|sc| {
        let lh = match (&lig, cached(&dir, "liggghts", case)) {
            (_, Some(c)) if run_lig => {
                say!("  seed {}: LIGGGHTS result found, reused", case.seed);
                Some(sc.spawn(move || Ok(c)))
            }
            (Some(l), _) => {
                let p = progress("LIGGGHTS");
                let (packing, dir) = (&packing, &dir);
                Some(sc.spawn(move || run_liggghts(case, packing, l, dir, &p, a.checkpoint)))
            }
            _ => None,
        };
        let nr = if run_nat {
            Some(match cached(&dir, "native", case) {
                Some(c) => {
                    say!("  seed {}: native result found, reused", case.seed);
                    Ok(c)
                }
                None => {
                    let p = progress("native");
                    pool.install(|| run_native(case, &packing, &dir, &p, a.checkpoint))
                }
            })
        } else {
            None
        };
        (lh.map(|h| h.join().expect("LIGGGHTS thread")), nr)
    });
    // each code's finished run is stored before the other's failure is reported
    let (lr, nr) = (lr.transpose(), nr.transpose());
    let ns = match &nr {
        Ok(Some(r)) => Some(store(&dir, "native", case, r)?),
        _ => None,
    };
    let ls = match &lr {
        Ok(Some(r)) => Some(store(&dir, "liggghts", case, r)?),
        _ => None,
    };
    let (lr, nr) = (lr?, nr?);
    let horizon = match (&ls, &ns) {
        (Some(l), Some(n)) => Some(lockstep(l, n, &LOCKSTEP_CHANNELS, LOCKSTEP_RTOL)),
        _ => None,
    };
    let ls_dir = dir.join("lockstep_shear");
    let shear_pair = match (&lig, nr.as_ref().and_then(|r| r.compacted.as_ref())) {
        _ if ls.is_some()
            && ns.is_some()
            && cached_lockstep(case, &ls_dir, LOCKSTEP_SHEAR_STEPS).is_some() =>
        {
            cached_lockstep(case, &ls_dir, LOCKSTEP_SHEAR_STEPS)
        }
        (Some(l), Some(state)) if ls.is_some() => Some(shear_lockstep(
            case,
            state,
            l,
            &dir.join("lockstep_shear"),
            LOCKSTEP_SHEAR_STEPS,
        )?),
        _ => None,
    };
    let sr = SeedResult {
        seed: case.seed,
        compression_steps: case.compression_steps,
        shear_steps_agreed: horizon
            .as_ref()
            .map(|h| h.last_agree_step.saturating_sub(case.compression_steps)),
        horizon,
        shear_lockstep: shear_pair.as_ref().map(|p| p.0.clone()),
        shear_chaos_baseline: shear_pair.map(|p| p.1),
        liggghts_wall_s: lr.as_ref().map(|r| r.wall_time),
        native_wall_s: nr.as_ref().map(|r| r.wall_time),
        liggghts_particle_steps_per_s: lr.as_ref().map(|r| r.throughput(case.particles)),
        native_particle_steps_per_s: nr.as_ref().map(|r| r.throughput(case.particles)),
        liggghts_profiles: lr.as_ref().map(|r| r.profiles.clone()),
        native_profiles: nr.as_ref().map(|r| r.profiles.clone()),
    };
    Ok((sr, ls, ns))
}

/// The study's outcome from its seeds: each code's steady figures, the stress and mu
/// verdicts, the plates' grip, written to `summary.json`.
fn summarise(
    a: &ShearRequest,
    case0: &ShearCase,
    lig: Option<&Liggghts>,
    setting: Setting,
    runs: Runs,
) -> Result<ShearSummary> {
    let Runs {
        seeds,
        liggghts: lig_series,
        native: nat_series,
    } = runs;
    let ends = case0.run_ends();
    let window = steady_window(ends[ends.len() - 2], ends[ends.len() - 1]);
    let out = &a.out;
    let area = case0.box_x * case0.box_z;
    let ls = (!lig_series.is_empty()).then(|| steady(&lig_series, window, area));
    let ns = (!nat_series.is_empty()).then(|| steady(&nat_series, window, area));
    let mut results = Vec::new();
    let label = format!("shear_{}", a.case.preset);
    let model = case0.models.rolling.keyword().to_string();
    let target = case0.normal_stress;
    for (code, st) in [("liggghts", &ls), ("native", &ns)] {
        if let Some(st) = st {
            results.push(stress_result(
                &label,
                &model,
                code,
                st,
                target,
                window.1,
                a.stress_rtol,
            ));
        }
    }
    let (paired_dmu, mu_equivalence) = match (&ls, &ns) {
        (Some(l), Some(n)) => {
            let (r, p, eq) = mu_results(&label, &model, l, n, window.1, a.mu_margin);
            results.extend(r);
            (p, Some(eq))
        }
        _ => (None, None),
    };
    let profiles = CodeProfiles {
        liggghts: CodeProfiles::mean(
            &seeds
                .iter()
                .filter_map(|s| s.liggghts_profiles.as_ref())
                .collect::<Vec<_>>(),
        ),
        native: CodeProfiles::mean(
            &seeds
                .iter()
                .filter_map(|s| s.native_profiles.as_ref())
                .collect::<Vec<_>>(),
        ),
    };
    results.extend(slip_results(&profiles, &label, &model, window.1));
    let summary = ShearSummary {
        schema: super::SCHEMA,
        pass: results.iter().all(|r| r.pass) && !results.is_empty(),
        preset: a.case.preset,
        rolling: case0.models.rolling,
        mu_r: a.case.mu_r,
        eta_r: a.case.eta_r,
        particles: case0.particles,
        dt: case0.dt,
        inertial_numbers: setting.inertial,
        kappa: case0.kappa(),
        paper_deviations: setting.deviations,
        steady_window_steps: window,
        stability: setting.stability,
        liggghts: ls.clone(),
        native: ns.clone(),
        profiles,
        seeds,
        results,
        paired_dmu,
        mu_equivalence,
        liggghts_version: lig
            .as_ref()
            .map(|l| l.version())
            .unwrap_or_else(|| "not run".into()),
        date_utc: utc_stamp(),
        series: CodeSeries {
            liggghts: lig_series,
            native: nat_series,
        },
    };
    write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    super::note_summary(&out.join("summary.json"));
    Ok(summary)
}
