//! The shear study: the paper's shear experiment in LIGGGHTS and natively from one case and
//! one initial packing per seed, compared in lockstep and at steady state.

use super::{utc_stamp, Engine, LiggghtsRequest, Verdict, SHEAR_TIMEOUT_S};
use crate::compare::{lockstep, steady, Horizon, Steady, LOCKSTEP_RTOL, MU_MARGIN, STRESS_RTOL};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::Liggghts;
use crate::packing::loose_packing;
use crate::profile::VelocityProfile;
use crate::run::progress::Progress;
use crate::series::Series;
use crate::shear::{
    run_liggghts, run_native, write_packing, Checkpointing, CodeRun, Row, CHECKPOINT_EVERY,
};
use crate::spec::shear::{CaseRequest, Preset, ShearCase, Stage};
use crate::spec::windows::steady_window;
use crate::spec::RollingModel;
use indicatif::MultiProgress;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

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

/// What is kept per seed and code so that an interrupted `verify shear` resumes.
/// The series' row count and SHA-256 and the profile's SHA-256 let a resumed study refuse a
/// cut or edited file instead of reporting it; a record without them (stored before they were
/// kept) is not trusted: its seed runs again.
#[derive(Serialize, Deserialize)]
struct RunRecord {
    case: String,
    wall_time: f64,
    steps: u64,
    #[serde(default)]
    rows: Option<usize>,
    #[serde(default)]
    sha256: Option<String>,
    #[serde(default)]
    profile_sha256: Option<String>,
    /// LIGGGHTS: the restart steps an interrupted run continued from ([`CodeRun::resumed_from`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    resumed_from: Vec<u64>,
}

/// A finished run stored in `dir` by [`store`], if it is of `case` and complete: the record
/// names the same case, the series checks against the record, starts at step 0, rises, and
/// holds the end of every run of the case (a truncated file lacks the last). Anything else
/// is run again.
fn cached(dir: &Path, code: &str, case: &ShearCase) -> Option<CodeRun> {
    let rec: RunRecord =
        serde_json::from_str(&std::fs::read_to_string(dir.join(format!("{code}_run.json"))).ok()?)
            .ok()?;
    if rec.case != serde_json::to_string(case).ok()? {
        return None;
    }
    let csv_path = dir.join(format!("{code}.csv"));
    let bytes = std::fs::read(&csv_path).ok()?;
    if rec.sha256.as_ref()? != &crate::fsutil::sha256_hex(&bytes) {
        return None;
    }
    let profile_bytes = std::fs::read(dir.join(format!("{code}_profile.json"))).ok()?;
    if rec.profile_sha256.as_ref()? != &crate::fsutil::sha256_hex(&profile_bytes) {
        return None;
    }
    let s = Series::read_csv(&csv_path).ok()?;
    let ends = case.run_ends();
    let complete = s.steps.first() == Some(&0)
        && s.steps.windows(2).all(|w| w[0] < w[1])
        && ends.iter().all(|e| s.steps.binary_search(e).is_ok())
        && rec.rows == Some(s.rows.len());
    if !complete {
        return None;
    }
    let col = |h: &str| s.col(h);
    // results stored before the mobilised column existed read it as NaN
    let cols: Vec<Option<usize>> = crate::shear::ROW_COLUMNS.iter().map(|h| col(h)).collect();
    if cols[..9].iter().any(Option::is_none) {
        return None;
    }
    let rows: Vec<Row> = s
        .steps
        .iter()
        .zip(&s.rows)
        .map(|(st, r)| {
            let mut v = [f64::NAN; 10];
            for (k, c) in cols.iter().enumerate() {
                if let Some(c) = c {
                    v[k] = r[*c];
                }
            }
            Row::from_values(*st, v)
        })
        .collect();
    // results stored without a velocity profile are run again
    let profiles = serde_json::from_slice(&profile_bytes).ok()?;
    Some(CodeRun {
        rows,
        wall_time: rec.wall_time,
        steps: rec.steps,
        compacted: None,
        profiles,
        resumed_from: rec.resumed_from,
    })
}

fn store(dir: &Path, code: &str, case: &ShearCase, run: &CodeRun) -> Result<Series> {
    let csv_path = dir.join(format!("{code}.csv"));
    let s = crate::shear::shear_series(case, &run.rows);
    let bytes = s.csv_bytes(&csv_path)?;
    write_atomic(&csv_path, &bytes)?;
    let profile = serde_json::to_string_pretty(&run.profiles)?;
    let rec = RunRecord {
        case: serde_json::to_string(case)?,
        wall_time: run.wall_time,
        steps: run.steps,
        rows: Some(s.rows.len()),
        sha256: Some(crate::fsutil::sha256_hex(&bytes)),
        profile_sha256: Some(crate::fsutil::sha256_hex(profile.as_bytes())),
        resumed_from: run.resumed_from.clone(),
    };
    write_atomic(
        &dir.join(format!("{code}_profile.csv")),
        crate::profile::csv(&run.profiles).as_bytes(),
    )?;
    // the run record last: a seed counts as done only with its profile stored
    write_atomic(
        &dir.join(format!("{code}_profile.json")),
        profile.as_bytes(),
    )?;
    write_atomic(
        &dir.join(format!("{code}_run.json")),
        serde_json::to_string_pretty(&rec)?.as_bytes(),
    )?;
    Ok(s)
}

/// Channels compared step by step: plate forces, top plate position, and the translational and
/// rotational kinetic energies (LIGGGHTS: compute ke, compute erotate/sphere).
pub const LOCKSTEP_CHANNELS: [&str; 5] = ["top_f", "bottom_f", "top_y", "ke", "erot"];

/// Shear steps of the lockstep test from the compacted state.
pub const LOCKSTEP_SHEAR_STEPS: u64 = 10_000;

/// Lockstep from a common compacted state: both codes start from the native solver's state at
/// the end of compression (positions, velocities, angular velocities; histories and servo
/// state fresh in both) and shear at the first stage's speed for `steps` steps, with output
/// every 10 steps. Separates implementation differences in the shear phase from the chaos
/// that amplifies round-off during compression.
///
/// Returns (LIGGGHTS vs native, native vs native with one coordinate nudged by one ulp): the
/// second is the chaos baseline: no implementation that is not bit-identical can agree
/// longer than round-off takes to grow.
pub fn shear_lockstep(
    case: &ShearCase,
    compacted: &crate::packing::Packing,
    lig: &Liggghts,
    dir: &Path,
    steps: u64,
) -> Result<(Horizon, Horizon)> {
    let c = lockstep_case(case, steps);
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let (l, n) = std::thread::scope(|sc| {
        let h = sc.spawn(|| {
            run_liggghts(
                &c,
                compacted,
                lig,
                dir,
                &Progress::hidden(),
                Checkpointing::Off,
            )
        });
        let n = run_native(&c, compacted, dir, &Progress::hidden(), Checkpointing::Off);
        (h.join().expect("LIGGGHTS thread"), n)
    });
    store(dir, "liggghts", &c, &l?)?;
    store(dir, "native", &c, &n?)?;
    let mut nudged = compacted.clone();
    let k = crate::packing::chaos_probe(nudged.position.len());
    nudged.position[k][0] = f64::from_bits(nudged.position[k][0].to_bits() + 1);
    let pdir = dir.join("perturbed");
    store(
        &pdir,
        "native",
        &c,
        &run_native(&c, &nudged, &pdir, &Progress::hidden(), Checkpointing::Off)?,
    )?;
    cached_lockstep(case, dir, steps).ok_or_else(|| Error::Missing {
        what: "lockstep results".into(),
        dir: dir.to_path_buf(),
    })
}

/// The case of the lockstep from the compacted state: one servo step, then `steps` steps at the
/// first stage's speed, output every 10 steps.
pub fn lockstep_case(case: &ShearCase, steps: u64) -> ShearCase {
    let mut c = case.clone();
    c.compression_steps = 1;
    let speed = case.stages[0].speed;
    c.stages = vec![Stage {
        speed,
        strain: steps as f64 * speed * c.dt / c.estimated_height(),
    }];
    c.output_every = 10;
    c.snapshot_every = 0;
    c
}

/// Horizons from stored lockstep results (LIGGGHTS vs native, native vs 1-ulp native).
fn cached_lockstep(case: &ShearCase, dir: &Path, steps: u64) -> Option<(Horizon, Horizon)> {
    let c = lockstep_case(case, steps);
    let series =
        |d: &Path, code: &str| cached(d, code, &c).map(|r| crate::shear::shear_series(&c, &r.rows));
    let (l, n, p) = (
        series(dir, "liggghts")?,
        series(dir, "native")?,
        series(&dir.join("perturbed"), "native")?,
    );
    let chans = LOCKSTEP_CHANNELS;
    Some((
        lockstep(&l, &n, &chans, LOCKSTEP_RTOL),
        lockstep(&n, &p, &chans, LOCKSTEP_RTOL),
    ))
}

/// Per-seed outcome.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeedResult {
    pub seed: u64,
    pub horizon: Option<Horizon>,
    /// Steps of compression, and steps of shear the codes agreed for.
    pub compression_steps: u64,
    pub shear_steps_agreed: Option<u64>,
    /// Lockstep of the shear phase from a common compacted state ([`shear_lockstep`]); its
    /// `last_agree_step` counts shear steps (step 1 is the servo-only setup step).
    pub shear_lockstep: Option<Horizon>,
    /// Chaos baseline: native vs native with one coordinate one ulp apart, same protocol.
    pub shear_chaos_baseline: Option<Horizon>,
    pub liggghts_wall_s: Option<f64>,
    pub native_wall_s: Option<f64>,
    pub liggghts_particle_steps_per_s: Option<f64>,
    pub native_particle_steps_per_s: Option<f64>,
    /// Each code's steady velocity profile per stage ([`crate::profile`]).
    pub liggghts_profiles: Option<Vec<VelocityProfile>>,
    pub native_profiles: Option<Vec<VelocityProfile>>,
}

/// Per-code steady velocity profiles, per stage, the layer-by-layer mean over seeds (empty
/// for a code that did not run).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CodeProfiles {
    pub liggghts: Vec<VelocityProfile>,
    pub native: Vec<VelocityProfile>,
}

impl CodeProfiles {
    /// The mean over seeds of each stage's profiles.
    fn mean(per_seed: &[&Vec<VelocityProfile>]) -> Vec<VelocityProfile> {
        let stages = per_seed.iter().map(|p| p.len()).min().unwrap_or(0);
        (0..stages)
            .filter_map(|k| {
                let of_stage: Vec<&VelocityProfile> = per_seed.iter().map(|p| &p[k]).collect();
                VelocityProfile::mean(&of_stage)
            })
            .collect()
    }
}

/// The outcome of a shear study; `summary.json` of `verify shear`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShearSummary {
    /// [`super::SCHEMA`].
    pub schema: u32,
    pub pass: bool,
    pub preset: Preset,
    pub rolling: RollingModel,
    pub mu_r: f64,
    pub eta_r: f64,
    pub particles: usize,
    pub dt: f64,
    pub inertial_numbers: Vec<f64>,
    pub kappa: f64,
    /// How the case differs from the paper's Tables 1-2 ([`crate::spec::paper_table`]).
    pub paper_deviations: Vec<crate::spec::paper_table::Deviation>,
    pub steady_window_steps: (u64, u64),
    pub stability: crate::spec::stability_shear::StabilityReport,
    pub liggghts: Option<Steady>,
    pub native: Option<Steady>,
    /// The plates' grip: velocity profile, slip and shear-band width per stage and code.
    pub profiles: CodeProfiles,
    pub seeds: Vec<SeedResult>,
    pub results: Vec<crate::compare::ChannelResult>,
    /// Per-seed steady mu, native - LIGGGHTS (both codes ran every seed).
    pub paired_dmu: Option<crate::compare::Paired>,
    /// The equivalence test behind `mu_steady` (absent in summaries before 2026-12-04).
    #[serde(default)]
    pub mu_equivalence: Option<crate::compare::Equivalence>,
    pub liggghts_version: String,
    pub date_utc: String,
    /// Every seed's series per code, in seed order (in memory only: the CSVs hold them).
    #[serde(skip)]
    pub series: CodeSeries,
}

/// Per-code series of the seeds of a study (empty for a code that did not run).
#[derive(Clone, Debug, Default)]
pub struct CodeSeries {
    pub liggghts: Vec<Series>,
    pub native: Vec<Series>,
}

impl ShearSummary {
    /// The verdict of the study: a study that compared nothing (one code only) is not a
    /// disagreement.
    /// Agree or disagree on the comparisons made; `Done` when one code ran and nothing was
    /// compared (no verdict line is printed then).
    pub fn verdict(&self) -> Verdict {
        if self.results.is_empty() {
            Verdict::Done
        } else if !self.pass {
            Verdict::Disagree
        } else if self.results.iter().any(|r| r.inconclusive) {
            Verdict::Inconclusive
        } else {
            Verdict::Agree
        }
    }
}

impl super::Versioned for ShearSummary {
    fn schema(&self) -> u32 {
        self.schema
    }
}

/// The channel `normal_stress_<code>`: the code's mean normal stress on the top plate against
/// the servo's `target`, within `rtol` relative. The mean is over seeds and the whole steady
/// window: per-seed means of a few hundred particles fluctuate by several per cent.
pub fn stress_result(
    label: &str,
    model: &str,
    code: &str,
    st: &Steady,
    target: f64,
    window_end: u64,
    rtol: f64,
) -> crate::compare::ChannelResult {
    let worst = (st.normal_stress / target - 1.0).abs();
    crate::compare::ChannelResult {
        case: label.into(),
        model: model.into(),
        channel: format!("normal_stress_{code}"),
        unit: "Pa".into(),
        max_abs_err: worst * target,
        max_rel_err: worst,
        peak: target,
        worst_step: window_end,
        rtol,
        pass: worst <= rtol,
        inconclusive: false,
    }
}

/// The steady-friction channel `mu_steady` of two codes' steady means over the same seeds: an
/// equivalence test of the seed-paired difference native - LIGGGHTS against `mu_margin`
/// ([`crate::compare::equivalence`]: agree when its 90 % CI lies inside the margin, DISAGREE
/// when it lies wholly beyond, inconclusive otherwise; one seed: the two codes' block CIs).
/// Returns the channel, the paired difference (95 % CI, for the tables) and the test.
pub fn mu_results(
    label: &str,
    model: &str,
    l: &Steady,
    n: &Steady,
    window_end: u64,
    mu_margin: f64,
) -> (
    Vec<crate::compare::ChannelResult>,
    Option<crate::compare::Paired>,
    crate::compare::Equivalence,
) {
    use crate::compare::{equivalence, equivalence_one_seed, Outcome};
    let eq = equivalence(&l.per_seed_mu, &n.per_seed_mu, mu_margin)
        .unwrap_or_else(|| equivalence_one_seed(l.mu, l.mu_ci95, n.mu, n.mu_ci95, mu_margin));
    let results = vec![crate::compare::ChannelResult {
        case: label.into(),
        model: model.into(),
        channel: "mu_steady".into(),
        unit: "-".into(),
        max_abs_err: eq.mean.abs(),
        max_rel_err: eq.mean.abs() / l.mu.abs().max(1e-12),
        peak: l.mu.abs().max(n.mu.abs()),
        worst_step: window_end,
        rtol: mu_margin,
        pass: eq.outcome != Outcome::Disagree,
        inconclusive: eq.outcome == Outcome::Inconclusive,
    }];
    let paired_dmu = crate::compare::paired(&l.per_seed_mu, &n.per_seed_mu);
    (results, paired_dmu, eq)
}

/// Runs every seed of a shear case in the codes asked for (reusing stored per-seed results),
/// compares them, writes plots and `summary.json` into the output directory, and returns the
/// summary.
pub fn run(a: &ShearRequest) -> Result<ShearSummary> {
    a.validate()?;
    let cases: Vec<(ShearCase, Vec<String>)> = a
        .seed_range()
        .map(|s| a.seed_case(s))
        .collect::<Result<_>>()?;
    run_cases(a, cases)
}

/// [`run`] with the seeds' cases already built (`a.seed_case` of each seed, in order; a sweep
/// builds its case once to check the input hash and passes it on).
pub fn run_cases(a: &ShearRequest, cases: Vec<(ShearCase, Vec<String>)>) -> Result<ShearSummary> {
    if cases.len() as u64 != a.seeds || cases.is_empty() {
        return Err(Error::invalid(
            "cases",
            cases.len(),
            format!("one case per seed ({})", a.seeds),
        ));
    }
    // a caller with a display of its own (a sweep) gets warnings only
    let quiet = a.quiet;
    macro_rules! say {
        ($($t:tt)*) => {
            if !quiet {
                println!($($t)*)
            }
        };
    }
    a.validate()?;
    let case0 = &cases[0].0;
    let run_lig = a.engine.runs_liggghts();
    let run_nat = a.engine.runs_native();
    if run_nat {
        super::check_memory("particles", case0.particles)?;
    }
    let lig = if run_lig {
        Some(a.liggghts.locate()?)
    } else {
        None
    };
    let out = a.out.clone();
    // one owner per output folder, held to the end of the run (two runs into one --out
    // would overwrite each other's seeds and summary)
    let _lock = crate::fsutil::DirLock::acquire(&out, "--out")?;
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let threads = a
        .threads
        .unwrap_or(if run_lig { (cores - 1).max(1) } else { cores });
    super::check_threads("--threads", threads)?;
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
    for w in cases[0].1.iter().filter(|_| !quiet) {
        eprintln!("warning: {w}");
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
            eprintln!("warning: {msg}");
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::invalid("--threads", threads, e.to_string()))?;
    let ends = case0.run_ends();
    let window = steady_window(ends[ends.len() - 2], ends[ends.len() - 1]);
    let (mut lig_series, mut nat_series) = (Vec::new(), Vec::new());
    let mut seeds = Vec::new();
    for (case, _) in &cases {
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
        let multi = MultiProgress::new();
        let total = case.total_steps();
        // a bar (or decile lines off a terminal); quiet: lines under the caller's label, or none
        let progress = |code: &str| match (quiet, &a.progress_label) {
            (false, _) => Progress::new(&multi, &format!("{code} s{}", case.seed), total, case.dt),
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
        if !quiet {
            print_seed(&sr);
        }
        seeds.push(sr);
        lig_series.extend(ls);
        nat_series.extend(ns);
    }
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
    // the plates' grip in the last stage (the one whose mu is compared): each plate's slip,
    // agreeing when the difference is within the two CIs summed (as the steady mu). The
    // profile layer by layer is plotted, not judged: over 7 layers and 3 seeds one layer
    // falls outside the CIs by chance too often (ci preset, (0.5, 0.5), seeds 1-3: 1.37 CI
    // sums at one layer; 9 seeds: 0.71, every layer's paired difference consistent with 0).
    if let (Some(l), Some(n)) = (profiles.liggghts.last(), profiles.native.last()) {
        for (channel, (a, a_ci), (b, b_ci)) in [
            (
                "slip_bottom",
                (l.slip_bottom, l.slip_bottom_ci95),
                (n.slip_bottom, n.slip_bottom_ci95),
            ),
            (
                "slip_top",
                (l.slip_top, l.slip_top_ci95),
                (n.slip_top, n.slip_top_ci95),
            ),
        ] {
            let d = (a - b).abs();
            let ratio = d / (a_ci + b_ci);
            // a slip is a fraction of the plate speed: with CIs summing past 1 (the whole
            // range) the data say nothing either way
            let undecided = (a_ci + b_ci).is_nan() || a_ci + b_ci > 1.0;
            results.push(crate::compare::ChannelResult {
                case: label.clone(),
                model: model.clone(),
                channel: channel.into(),
                unit: "fraction of the plate speed".into(),
                max_abs_err: d,
                max_rel_err: ratio,
                peak: 1.0,
                worst_step: window.1,
                rtol: crate::profile::SLIP_CI_LIMIT,
                pass: undecided || ratio <= crate::profile::SLIP_CI_LIMIT,
                inconclusive: undecided,
            });
        }
    }
    let summary = ShearSummary {
        schema: super::SCHEMA,
        pass: results.iter().all(|r| r.pass) && !results.is_empty(),
        preset: a.case.preset,
        rolling: case0.models.rolling,
        mu_r: a.case.mu_r,
        eta_r: a.case.eta_r,
        particles: case0.particles,
        dt: case0.dt,
        inertial_numbers: inertial,
        kappa: case0.kappa(),
        paper_deviations: deviations,
        steady_window_steps: window,
        stability: stab.clone(),
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

/// Prints a study's steady figures, paired differences and verdicts.
pub fn print_summary(summary: &ShearSummary, out: &Path) {
    let (ls, ns) = (&summary.liggghts, &summary.native);
    let window = summary.steady_window_steps;
    macro_rules! say {
        ($($t:tt)*) => {
            println!($($t)*)
        };
    }
    say!();
    say!(
        "steady window: steps {}..{} (second half of the last stage)",
        window.0,
        window.1
    );
    for (code, st) in [("LIGGGHTS", &ls), ("native", &ns)] {
        if let Some(st) = st {
            say!(
                "  {code:<8} mu = {:.4} +- {:.4} (95 % CI)  per seed [{}]  normal stress [{}] MPa",
                st.mu,
                st.mu_ci95,
                st.per_seed_mu
                    .iter()
                    .map(|m| format!("{m:.4}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                st.per_seed_stress
                    .iter()
                    .map(|s| format!("{:.3}", s / 1e6))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    for (code, profiles) in [
        ("LIGGGHTS", &summary.profiles.liggghts),
        ("native", &summary.profiles.native),
    ] {
        for p in profiles {
            // a slip is a fraction of the plate speed: a CI wider than that range is no figure
            let slip = |v: f64, ci: f64| {
                if ci <= 1.0 {
                    format!("{:.1} +- {:.1} %", 100.0 * v, 100.0 * ci)
                } else {
                    format!(
                        "not resolved (95 % CI +-{:.0} % of the plate speed)",
                        100.0 * ci
                    )
                }
            };
            let band = if p.slip_bottom_ci95 <= 1.0 && p.slip_top_ci95 <= 1.0 {
                format!("{:.2} mm", 1e3 * p.band_width)
            } else {
                "not resolved".to_string()
            };
            say!(
                "  {code:<8} stage {} ({} m/s): slip at the bottom plate {}, at the top plate {}, shear band {} of a {:.2} mm gap ({} layers)",
                p.stage + 1,
                p.speed,
                slip(p.slip_bottom, p.slip_bottom_ci95),
                slip(p.slip_top, p.slip_top_ci95),
                band,
                1e3 * p.gap,
                p.layers.len()
            );
        }
    }
    if let Some(p) = &summary.paired_dmu {
        say!(
            "  paired (native - LIGGGHTS, same seeds): {:+.4} +- {:.4} (95 % CI, {} seeds), t = {:.2}, native higher in {} of {}",
            p.mean,
            p.ci95,
            p.n,
            p.t,
            p.b_higher,
            p.n
        );
    }
    if let Some(e) = &summary.mu_equivalence {
        for line in crate::calibration::describe(e, summary.preset) {
            say!("  {line}");
        }
    }
    for r in &summary.results {
        say!(
            "  {:<22} {:>10.4e} (limit {:.2e} {})  {}",
            r.channel,
            if r.channel == "mu_steady" {
                r.max_abs_err
            } else {
                r.max_rel_err
            },
            r.rtol,
            match r.channel.as_str() {
                "mu_steady" => "abs, equivalence margin of the paired mean",
                "slip_bottom" | "slip_top" => "x the CIs summed",
                _ => "rel",
            },
            match (r.pass, r.inconclusive) {
                (false, _) => "FAIL",
                (true, true) => "inconclusive",
                (true, false) => "ok",
            }
        );
    }
    say!(
        "plots: {}  summary: {}",
        out.join("mu_strain.svg").display(),
        out.join("summary.json").display()
    );
}

fn print_seed(s: &SeedResult) {
    let mut line = format!("  seed {}:", s.seed);
    if let Some(w) = s.liggghts_wall_s {
        line += &format!(
            " LIGGGHTS {w:.1} s ({:.3e} particle-steps/s)",
            s.liggghts_particle_steps_per_s.unwrap_or(0.0)
        );
    }
    if let Some(w) = s.native_wall_s {
        line += &format!(
            " native {w:.1} s ({:.3e} particle-steps/s)",
            s.native_particle_steps_per_s.unwrap_or(0.0)
        );
    }
    println!("{line}");
    if let Some(h) = &s.horizon {
        match (&h.first_diverge_step, &h.first_diverge_channel) {
            (Some(st), Some(ch)) => println!(
                "    lockstep: agree (rel {:.0e}) through step {} (compression {} steps, shear steps agreed {}); first divergence: {ch} at step {st}",
                h.rtol,
                h.last_agree_step,
                s.compression_steps,
                s.shear_steps_agreed.unwrap_or(0)
            ),
            _ => println!("    lockstep: agree (rel {:.0e}) through the whole run (step {})", h.rtol, h.last_agree_step),
        }
    }
    for (what, h) in [
        (
            "shear lockstep from the compacted state, LIGGGHTS vs native",
            &s.shear_lockstep,
        ),
        (
            "chaos baseline, native vs native 1 ulp apart",
            &s.shear_chaos_baseline,
        ),
    ] {
        if let Some(h) = h {
            match (&h.first_diverge_step, &h.first_diverge_channel) {
                (Some(st), Some(ch)) => println!(
                    "    {what}: agree through shear step {} (first divergence: {ch} at step {st})",
                    h.last_agree_step.saturating_sub(1)
                ),
                _ => println!(
                    "    {what}: agree through all {} shear steps",
                    h.last_agree_step.saturating_sub(1)
                ),
            }
        }
    }
}
