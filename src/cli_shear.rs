//! `verify shear`: the paper's shear experiment in LIGGGHTS and natively from one case and
//! one initial packing per seed, compared in lockstep and at steady state.

use crate::cli::{utc_stamp, Outcome};
use crate::compare::{
    lockstep, steady, steady_window, Horizon, Steady, LOCKSTEP_RTOL, MU_ATOL, STRESS_RTOL,
};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::Liggghts;
use crate::packing::loose_packing;
use crate::report::plot::{decimate, line_plot, running_mean, Curve, CurveData};
use crate::report::progress::Progress;
use crate::series::Series;
use crate::shear::{run_ends, run_liggghts, run_native, write_packing, CodeRun, Row};
use crate::spec::shear::{ShearCase, Stage};
use crate::spec::RollingModel;
use clap::Args;
use indicatif::MultiProgress;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Args, Debug, Clone)]
pub struct ShearArgs {
    /// Rolling friction coefficient mu_r.
    #[arg(long, default_value_t = 0.0)]
    pub mu_r: f64,
    /// Rolling viscous damping eta_r (epsd and epsd3 only).
    #[arg(long, default_value_t = 0.0)]
    pub eta_r: f64,
    /// Rolling model (the paper's: epsd).
    #[arg(long, default_value = "epsd")]
    pub rolling: String,
    /// Preset: ci (few hundred particles, minutes), fast (paper box, nightly), paper.
    #[arg(long, default_value = "fast")]
    pub preset: String,
    /// Number of seeds (initial packings).
    #[arg(long, default_value_t = 3)]
    pub seeds: u64,
    /// First seed: runs seeds first-seed ..= first-seed + seeds - 1.
    #[arg(long, default_value_t = 1)]
    pub first_seed: u64,
    /// No progress bars (callers with a progress display of their own, e.g. a sweep).
    #[arg(skip)]
    pub hide_progress: bool,
    #[command(flatten)]
    pub protocol: Protocol,
    /// Threads of the native solver (default: all cores, minus one while LIGGGHTS runs).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Output directory (default: a new directory under ./runs/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run only the native solver.
    #[arg(long, conflicts_with = "liggghts_only")]
    pub native_only: bool,
    /// Run only LIGGGHTS.
    #[arg(long)]
    pub liggghts_only: bool,
    /// Allow stages with inertial number I > 1e-3.
    #[arg(long)]
    pub allow_inertial: bool,
    /// Write particle snapshots (VTK, for ParaView) every N steps (0: the preset's choice).
    #[arg(long, default_value_t = 0)]
    pub snapshot_every: u64,
    /// Refuse to run (exit 2) when the explicit rolling dashpot is expected to be unstable.
    #[arg(long)]
    pub strict_stability: bool,
    /// Flat plates instead of plates with teeth (flat plates let the gouge slip).
    #[arg(long)]
    pub flat_plates: bool,
    /// Tooth height [m] of the plates (default 2e-4).
    #[arg(long)]
    pub tooth_height: Option<f64>,
    /// Tooth wavelength [m] along x; box_x must hold a whole number of teeth (default 5e-4).
    #[arg(long)]
    pub tooth_wavelength: Option<f64>,
    /// Particle count (the preset's box is scaled in x and z to keep the sample height).
    #[arg(long)]
    pub particles: Option<usize>,
    /// Coefficient of normal restitution (the paper's Table 2: 1, no normal damping; the
    /// presets still use 0.5). LIGGGHTS accepts 0.05 < e <= 1.
    #[arg(long)]
    pub restitution: Option<f64>,
    /// Largest accepted |mu_LIGGGHTS - mu_native| of the steady means (their 95 % CIs must
    /// also overlap). The default suits 3 seeds of 2500 particles; one seed of the ci preset
    /// fluctuates more (seed-to-seed spread about 0.03).
    #[arg(long, default_value_t = MU_ATOL)]
    pub mu_atol: f64,
    /// Largest accepted relative deviation of each code's mean normal stress (steady window,
    /// mean over seeds) from the target. One seed of the ci preset fluctuates by about 1-2 %.
    #[arg(long, default_value_t = STRESS_RTOL)]
    pub stress_rtol: f64,
    /// LIGGGHTS binary.
    #[arg(long)]
    pub liggghts: Option<PathBuf>,
    /// Timeout of one LIGGGHTS run [s].
    #[arg(long, default_value_t = 7 * 24 * 3600)]
    pub timeout: u64,
}

/// Changes to a preset's shear protocol, shared by `verify shear` and `verify sweep`.
#[derive(Args, Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Protocol {
    /// Shear speeds [m/s], comma separated: stages in sequence, as in the paper (replaces the
    /// preset's stages).
    #[arg(long, value_delimiter = ',')]
    pub speeds: Option<Vec<f64>>,
    /// Shear strain of each stage (replaces the preset's).
    #[arg(long)]
    pub strain: Option<f64>,
    /// Time step as a multiple of the preset's (compression steps and output interval scale
    /// with 1 / factor, so the same physical time and strain are covered): runs a case at a
    /// converged dt, e.g. 0.25.
    #[arg(long, default_value_t = 1.0)]
    pub dt_factor: f64,
}

impl ShearArgs {
    /// The command line's defaults (what `verify shear` without options uses).
    pub fn defaults() -> Self {
        #[derive(clap::Parser)]
        struct Wrap {
            #[command(flatten)]
            a: ShearArgs,
        }
        <Wrap as clap::Parser>::parse_from(["verify"]).a
    }
}

/// The validated case of one seed.
pub fn shear_case(a: &ShearArgs, seed: u64) -> Result<(ShearCase, Vec<String>)> {
    let rolling = RollingModel::parse(&a.rolling)?;
    if rolling.native_only() && !a.native_only {
        return Err(Error::invalid(
            "--rolling",
            rolling,
            "a LIGGGHTS model when LIGGGHTS runs; epsd_implicit exists only in the native solver (use --native-only or --engine native)",
        ));
    }
    for (flag, v) in [("--mu-r", a.mu_r), ("--eta-r", a.eta_r)] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(Error::invalid(flag, v, "a finite number >= 0"));
        }
    }
    if rolling == RollingModel::Off && a.mu_r > 0.0 {
        return Err(Error::invalid("--mu-r", a.mu_r, "0 with --rolling off"));
    }
    let mut c = ShearCase::preset(&a.preset, rolling, a.mu_r, a.eta_r, seed)?;
    let pr = &a.protocol;
    if let Some(speeds) = &pr.speeds {
        let strain = pr.strain.unwrap_or(c.stages[0].strain);
        c.stages = speeds
            .iter()
            .map(|&speed| Stage { speed, strain })
            .collect();
    } else if let Some(strain) = pr.strain {
        for s in &mut c.stages {
            s.strain = strain;
        }
    }
    if a.snapshot_every > 0 {
        c.snapshot_every = a.snapshot_every;
    }
    if let Some(e) = a.restitution {
        c = c.with_restitution("--restitution", e)?;
    }
    if a.flat_plates {
        c.plates = crate::spec::shear::Plates::Flat;
    } else if let crate::spec::shear::Plates::Teeth {
        tooth_height,
        tooth_wavelength,
    } = &mut c.plates
    {
        if let Some(h) = a.tooth_height {
            *tooth_height = h;
        }
        if let Some(w) = a.tooth_wavelength {
            *tooth_wavelength = w;
        }
    }
    if let Some(n) = a.particles {
        if n < 10 {
            return Err(Error::invalid("--particles", n, ">= 10"));
        }
        // same area per particle (so the same height); box_x a whole number of teeth
        let area = c.box_x * c.box_z * n as f64 / c.particles as f64;
        let scale = (n as f64 / c.particles as f64).sqrt();
        let w = match &c.plates {
            crate::spec::shear::Plates::Teeth {
                tooth_wavelength, ..
            } => *tooth_wavelength,
            crate::spec::shear::Plates::Flat => c.box_x / 8.0,
        };
        c.box_x = (c.box_x * scale / w).round().max(1.0) * w;
        c.box_z = area / c.box_x;
        c.particles = n;
    }
    let f = pr.dt_factor;
    if !(f.is_finite() && f > 0.0 && f <= 1.0) {
        return Err(Error::invalid("--dt-factor", f, "a number in (0, 1]"));
    }
    if f != 1.0 {
        c.dt *= f;
        c.compression_steps = (c.compression_steps as f64 / f).round() as u64;
        c.output_every = ((c.output_every as f64 / f).round() as u64).max(1);
        c.snapshot_every = (c.snapshot_every as f64 / f).round() as u64;
    }
    let w = c.validate(a.allow_inertial)?;
    Ok((c, w))
}

/// What is kept per seed and code so that an interrupted `verify shear` resumes.
#[derive(Serialize, Deserialize)]
struct RunRecord {
    case: String,
    wall_time: f64,
    steps: u64,
}

fn cached(dir: &Path, code: &str, case: &ShearCase) -> Option<CodeRun> {
    let rec: RunRecord =
        serde_json::from_str(&std::fs::read_to_string(dir.join(format!("{code}_run.json"))).ok()?)
            .ok()?;
    if rec.case != serde_json::to_string(case).ok()? {
        return None;
    }
    let s = Series::read_csv(&dir.join(format!("{code}.csv"))).ok()?;
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
            (*st, v)
        })
        .collect();
    Some(CodeRun {
        rows,
        wall_time: rec.wall_time,
        steps: rec.steps,
        compacted: None,
    })
}

fn store(dir: &Path, code: &str, case: &ShearCase, run: &CodeRun) -> Result<Series> {
    let s = crate::shear::write_series(case, run, &dir.join(format!("{code}.csv")))?;
    let rec = RunRecord {
        case: serde_json::to_string(case)?,
        wall_time: run.wall_time,
        steps: run.steps,
    };
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
        let h = sc.spawn(|| run_liggghts(&c, compacted, lig, dir, &Progress::hidden()));
        let n = run_native(&c, compacted, dir, &Progress::hidden());
        (h.join().expect("LIGGGHTS thread"), n)
    });
    store(dir, "liggghts", &c, &l?)?;
    store(dir, "native", &c, &n?)?;
    let mut nudged = compacted.clone();
    nudged.position[0][0] = f64::from_bits(nudged.position[0][0].to_bits() + 1);
    let pdir = dir.join("perturbed");
    store(
        &pdir,
        "native",
        &c,
        &run_native(&c, &nudged, &pdir, &Progress::hidden())?,
    )?;
    cached_lockstep(case, dir, steps)
        .ok_or_else(|| Error::Reference(format!("lockstep results missing in {}", dir.display())))
}

/// The case of the lockstep from the compacted state: one servo step, then `steps` steps at the
/// first stage's speed, output every 10 steps.
fn lockstep_case(case: &ShearCase, steps: u64) -> ShearCase {
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
#[derive(Clone, Debug, Serialize)]
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
}

/// `summary.json` of `verify shear`.
#[derive(Clone, Debug, Serialize)]
pub struct ShearSummary {
    pub pass: bool,
    pub preset: String,
    pub rolling: String,
    pub mu_r: f64,
    pub eta_r: f64,
    pub particles: usize,
    pub dt: f64,
    pub inertial_numbers: Vec<f64>,
    pub kappa: f64,
    pub steady_window_steps: (u64, u64),
    pub stability: crate::spec::stability_shear::StabilityReport,
    pub liggghts: Option<Steady>,
    pub native: Option<Steady>,
    pub seeds: Vec<SeedResult>,
    pub results: Vec<crate::compare::ChannelResult>,
    /// Per-seed steady mu, native - LIGGGHTS (both codes ran every seed).
    pub paired_dmu: Option<crate::compare::Paired>,
    pub liggghts_version: String,
    pub date_utc: String,
}

/// `verify shear`: runs, prints, writes `summary.json`; the outcome of its comparisons.
pub fn shear(a: ShearArgs) -> Result<Outcome> {
    let summary = shear_run(&a)?;
    Ok(if summary.pass || summary.results.is_empty() {
        Outcome::Agree
    } else {
        Outcome::Disagree
    })
}

/// Runs every seed of a shear case in the codes asked for (reusing stored per-seed results),
/// compares them, writes plots and `summary.json` into the output directory, and returns the
/// summary.
pub fn shear_run(a: &ShearArgs) -> Result<ShearSummary> {
    // a caller with a display of its own (a sweep) gets warnings only
    let quiet = a.hide_progress;
    macro_rules! say {
        ($($t:tt)*) => {
            if !quiet {
                println!($($t)*)
            }
        };
    }
    if !(a.mu_atol.is_finite() && a.mu_atol > 0.0 && a.mu_atol < 1.0) {
        return Err(Error::invalid("--mu-atol", a.mu_atol, "a number in (0, 1)"));
    }
    if !(a.stress_rtol.is_finite() && a.stress_rtol > 0.0 && a.stress_rtol < 1.0) {
        return Err(Error::invalid(
            "--stress-rtol",
            a.stress_rtol,
            "a number in (0, 1)",
        ));
    }
    if a.seeds == 0 || a.seeds > 1000 {
        return Err(Error::invalid("--seeds", a.seeds, "1 ..= 1000"));
    }
    if a.first_seed == 0 || a.first_seed > u64::MAX / 2 {
        return Err(Error::invalid("--first-seed", a.first_seed, ">= 1"));
    }
    let cases: Vec<(ShearCase, Vec<String>)> = (a.first_seed..a.first_seed + a.seeds)
        .map(|s| shear_case(a, s))
        .collect::<Result<_>>()?;
    let case0 = &cases[0].0;
    let run_lig = !a.native_only;
    let run_nat = !a.liggghts_only;
    let lig = if run_lig {
        Some(Liggghts::locate(
            a.liggghts.as_deref(),
            Duration::from_secs(a.timeout),
        )?)
    } else {
        None
    };
    let out = a.out.clone().unwrap_or_else(|| {
        PathBuf::from("runs").join(format!("shear-{}-{}", a.preset, utc_stamp()))
    });
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let threads = a
        .threads
        .unwrap_or(if run_lig { (cores - 1).max(1) } else { cores });
    if threads == 0 {
        return Err(Error::invalid("--threads", 0, ">= 1"));
    }
    let inertial: Vec<f64> = (0..case0.stages.len())
        .map(|k| case0.inertial_number(k))
        .collect();
    say!(
        "verify shear: preset {}, {} particles, rolling {} (mu_r {}, eta_r {}), {} seed(s), dt {:e} s, {} steps per seed",
        a.preset,
        case0.particles,
        case0.models.rolling,
        a.mu_r,
        a.eta_r,
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
    let ends = run_ends(case0);
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
        let (lr, nr) = std::thread::scope(|sc| {
            let lh = match (&lig, cached(&dir, "liggghts", case)) {
                (_, Some(c)) if run_lig => {
                    say!("  seed {}: LIGGGHTS result found, reused", case.seed);
                    Some(sc.spawn(move || Ok(c)))
                }
                (Some(l), _) => {
                    let p = if a.hide_progress {
                        Progress::hidden()
                    } else {
                        Progress::new(&multi, &format!("LIGGGHTS s{}", case.seed), total, case.dt)
                    };
                    let (packing, dir) = (&packing, &dir);
                    Some(sc.spawn(move || run_liggghts(case, packing, l, dir, &p)))
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
                        let p = if a.hide_progress {
                            Progress::hidden()
                        } else {
                            Progress::new(&multi, &format!("native s{}", case.seed), total, case.dt)
                        };
                        pool.install(|| run_native(case, &packing, &dir, &p))
                    }
                })
            } else {
                None
            };
            (lh.map(|h| h.join().expect("LIGGGHTS thread")), nr)
        });
        let lr = lr.transpose()?;
        let nr = nr.transpose()?;
        let ls = lr
            .as_ref()
            .map(|r| store(&dir, "liggghts", case, r))
            .transpose()?;
        let ns = nr
            .as_ref()
            .map(|r| store(&dir, "native", case, r))
            .transpose()?;
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
    let label = format!("shear_{}", a.preset);
    let model = case0.models.rolling.keyword().to_string();
    let target = case0.normal_stress;
    for (code, st) in [("liggghts", &ls), ("native", &ns)] {
        if let Some(st) = st {
            // mean over seeds and the whole steady window: per-seed means of a few hundred
            // particles fluctuate by several per cent
            let mean = st.per_seed_stress.iter().sum::<f64>() / st.per_seed_stress.len() as f64;
            let worst = (mean / target - 1.0).abs();
            results.push(crate::compare::ChannelResult {
                case: label.clone(),
                model: model.clone(),
                channel: format!("normal_stress_{code}"),
                unit: "Pa".into(),
                max_abs_err: worst * target,
                max_rel_err: worst,
                peak: target,
                worst_step: window.1,
                rtol: a.stress_rtol,
                pass: worst <= a.stress_rtol,
            });
        }
    }
    if let (Some(l), Some(n)) = (&ls, &ns) {
        let dmu = (l.mu - n.mu).abs();
        let overlap = dmu <= l.mu_ci95 + n.mu_ci95;
        results.push(crate::compare::ChannelResult {
            case: label.clone(),
            model: model.clone(),
            channel: "mu_steady".into(),
            unit: "-".into(),
            max_abs_err: dmu,
            max_rel_err: dmu / l.mu.abs().max(1e-12),
            peak: l.mu.abs().max(n.mu.abs()),
            worst_step: window.1,
            rtol: a.mu_atol,
            pass: dmu <= a.mu_atol && overlap,
        });
    }
    plots(&out, &lig_series, &nat_series)?;
    let summary = ShearSummary {
        pass: results.iter().all(|r| r.pass) && !results.is_empty(),
        preset: a.preset.clone(),
        rolling: model,
        mu_r: a.mu_r,
        eta_r: a.eta_r,
        particles: case0.particles,
        dt: case0.dt,
        inertial_numbers: inertial,
        kappa: case0.kappa(),
        steady_window_steps: window,
        stability: stab.clone(),
        liggghts: ls.clone(),
        native: ns.clone(),
        seeds,
        results,
        paired_dmu: match (&ls, &ns) {
            (Some(l), Some(n)) => crate::compare::paired(&l.per_seed_mu, &n.per_seed_mu),
            _ => None,
        },
        liggghts_version: lig
            .as_ref()
            .map(|l| l.version())
            .unwrap_or_else(|| "not run".into()),
        date_utc: utc_stamp(),
    };
    write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
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
            if r.channel == "mu_steady" {
                "abs, CIs must overlap"
            } else {
                "rel"
            },
            if r.pass { "ok" } else { "FAIL" }
        );
    }
    say!(
        "plots: {}  summary: {}",
        out.join("mu_strain.svg").display(),
        out.join("summary.json").display()
    );
    Ok(summary)
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

/// Points per curve in the shear plots.
const PLOT_POINTS: usize = 1500;

fn plots(out: &Path, lig: &[Series], nat: &[Series]) -> Result<()> {
    let xy = |s: &Series, x: &str, y: &str| -> Vec<(f64, f64)> {
        let (cx, cy) = (s.col(x).expect("column"), s.col(y).expect("column"));
        s.rows.iter().map(|r| (r[cx], r[cy])).collect()
    };
    let mut data = Vec::new();
    for (k, s) in lig.iter().enumerate() {
        data.push((k, 0usize, s));
    }
    for (k, s) in nat.iter().enumerate() {
        data.push((k, 1usize, s));
    }
    for (file, title, x, xd, y, yd) in [
        (
            "mu_strain.svg",
            "friction coefficient mu = Fx / Fy on the top plate",
            "strain[-]",
            "shear strain",
            "mu[-]",
            "mu",
        ),
        (
            "top_force.svg",
            "normal force on the top plate",
            "time[s]",
            "time [s]",
            "top_f_y[N]",
            "Fy [N]",
        ),
        (
            "shear_force.svg",
            "shear force on the top plate",
            "strain[-]",
            "shear strain",
            "top_f_x[N]",
            "Fx [N]",
        ),
        (
            "mobilised.svg",
            "rolling contacts at full mobilisation (native; not in LIGGGHTS' output)",
            "strain[-]",
            "shear strain",
            "mobilised[-]",
            "fraction of touching pairs",
        ),
        (
            "height.svg",
            "sample height",
            "time[s]",
            "time [s]",
            "height[m]",
            "height [m]",
        ),
        (
            "kinetic_energy.svg",
            "rotational kinetic energy",
            "time[s]",
            "time [s]",
            "erot[J]",
            "E_rot [J]",
        ),
    ] {
        let pts: Vec<CurveData> = data
            .iter()
            .map(|(l, c, s)| {
                let mut p = xy(s, x, y);
                if x == "strain[-]" {
                    p.retain(|q| q.0 > 0.0);
                }
                (l.to_string(), *c, p)
            })
            .collect();
        // raw data faint, a running mean (+-10 outputs) per seed on top, one legend entry per code
        // (decimated to keep the SVGs light: the nightly report inlines them)
        let means: Vec<Vec<(f64, f64)>> = pts
            .iter()
            .map(|(_, _, p)| decimate(&running_mean(p, 10), PLOT_POINTS))
            .collect();
        let pts: Vec<CurveData> = pts
            .into_iter()
            .map(|(l, c, p)| (l, c, decimate(&p, PLOT_POINTS)))
            .collect();
        let mut cs: Vec<Curve> = pts
            .iter()
            .map(|(_, c, p)| Curve::new("", p, *c).faint())
            .collect();
        for ((seed, c, _), m) in pts.iter().zip(&means) {
            let label = if seed == "0" {
                format!(
                    "{} (running mean, each seed)",
                    if *c == 0 { "LIGGGHTS" } else { "native" }
                )
            } else {
                String::new()
            };
            cs.push(Curve::new(&label, m, *c));
        }
        line_plot(&out.join(file), title, xd, yd, &cs)?;
    }
    Ok(())
}
