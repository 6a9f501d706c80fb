//! `verify bench`: throughput of both codes on the same dense shear state, measured in the
//! same invocation. The state is the native solver's compacted `fast`/`paper` sample, tiled
//! periodically in x and z for larger particle counts. Each code runs a warm-up run, then the
//! timed run of the same number of steps with output only at its end; LIGGGHTS' time is its
//! own `Loop time` of the timed run (setup and file reading excluded).

use super::{utc_stamp, LiggghtsRequest};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::{last_loop_time, last_neighbor_builds, LOG_NAME};
use crate::packing::{loose_packing, Packing};
use crate::solver::shear::{compact, KernelPath, PhaseTimes, ShearSim};
use crate::spec::shear::{Preset, ShearCase, Stage};
use crate::spec::RollingModel;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

/// A throughput measurement of both codes on the same dense state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchRequest {
    /// Parameter preset of the state: fast or paper (same particles and materials).
    pub preset: Preset,
    /// Timed steps per code.
    pub steps: u64,
    /// Native thread counts to measure.
    pub threads: Vec<usize>,
    /// Pair-pass kernel paths to measure natively (each with every thread count); every path
    /// must run on this CPU.
    pub kernels: Vec<KernelPath>,
    /// LIGGGHTS process counts to measure (2 runs `mpirun --allow-run-as-root -np 2`).
    pub procs: Vec<usize>,
    /// Particle count: the 2500-particle sample tiled k x k times (rounded to a square).
    pub particles: usize,
    /// Compression steps that make the dense state.
    pub compression_steps: u64,
    /// LIGGGHTS (None: native only).
    pub liggghts: Option<LiggghtsRequest>,
    /// Rounds of every native and every LIGGGHTS run, in that order: the ratios are the
    /// medians of the rounds' ratios (a round's two codes run a minute apart, so a machine
    /// whose speed drifts affects both alike), the rates the medians of the rounds' rates.
    #[serde(default = "one_round")]
    pub rounds: usize,
    pub out: PathBuf,
}

fn one_round() -> usize {
    1
}

/// The most rounds one bench makes.
pub const MAX_ROUNDS: usize = 50;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchRow {
    pub code: String,
    /// The round this run belongs to (0 to [`BenchRequest::rounds`] - 1).
    #[serde(default)]
    pub round: usize,
    /// Threads (native) or MPI processes (LIGGGHTS).
    pub workers: usize,
    pub particles: usize,
    pub steps: u64,
    pub seconds: f64,
    /// CPU time of the timed steps [s] (native: this process, from /proc/self/stat; robust to
    /// other load on the machine, unlike `seconds`). None for LIGGGHTS.
    pub cpu_seconds: Option<f64>,
    pub particle_steps_per_s: f64,
    pub per_core: f64,
    /// Native: the pair pass's kernel path.
    #[serde(default)]
    pub kernel: Option<KernelPath>,
    /// Native: wall time of each phase of the timed steps [s].
    #[serde(default)]
    pub phases: Option<PhaseTimes>,
    /// Native, at the end of the timed steps: listed pairs, touching pairs and plate contacts
    /// per particle.
    #[serde(default)]
    pub per_particle: Option<(f64, f64, f64)>,
    /// Neighbour list builds during the timed steps (LIGGGHTS: its `Neighbor list builds`
    /// of the timed run), None where not known: both codes rebuild on the same rule (an
    /// atom moved more than skin/2), so they should rebuild about equally often, and at
    /// large particle counts more often than at small ones.
    #[serde(default)]
    pub rebuilds: Option<u64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchReport {
    /// [`super::SCHEMA`].
    pub schema: u32,
    pub preset: Preset,
    pub rolling: RollingModel,
    pub particles: usize,
    pub rows: Vec<BenchRow>,
    /// native 1 thread / LIGGGHTS 1 process (the fastest kernel path measured): the median
    /// of the rounds' ratios.
    pub native_vs_liggghts_1: Option<f64>,
    /// native 2 threads / native 1 thread (the fastest kernel path measured): the median of
    /// the rounds' ratios.
    pub native_2_vs_1: Option<f64>,
    /// Each round's native 1 thread / LIGGGHTS 1 process.
    #[serde(default)]
    pub rounds_native_vs_liggghts_1: Vec<f64>,
    /// Each round's native 2 threads / native 1 thread.
    #[serde(default)]
    pub rounds_native_2_vs_1: Vec<f64>,
    /// The kernel path the ratios above use.
    #[serde(default)]
    pub kernel: Option<KernelPath>,
    /// Resident memory per particle of the native solver [bytes]: the peak resident set of
    /// its first run (made, warmed up, timed) over the resident set just before it was made,
    /// divided by the particle count (where Linux cannot reset the peak: the growth since
    /// the bench started, the input state and its compaction included).
    pub native_bytes_per_particle: Option<f64>,
    /// The heap the solver holds at the end of the first native run, by item [bytes per
    /// particle].
    #[serde(default)]
    pub native_held_per_particle: Vec<(String, f64)>,
    /// Estimated wall time of one full `paper` run (3 stages) per code [hours], from the
    /// median rate of its rounds.
    pub paper_run_hours: Vec<(String, f64)>,
    pub date_utc: String,
}

/// A size of this process from Linux /proc/self/status [bytes]: `VmHWM` (peak resident set)
/// or `VmRSS` (resident set now).
fn status_bytes(field: &str) -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let rest = s
        .lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))?;
    let kb: f64 = rest.split_whitespace().next()?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Peak resident set size of this process [bytes].
fn peak_rss() -> Option<f64> {
    status_bytes("VmHWM")
}

/// Resets the peak resident set size to the present one (Linux >= 4.0: `5` written to
/// /proc/self/clear_refs) and returns the present one [bytes]; None where that fails.
fn reset_peak_rss() -> Option<f64> {
    std::fs::write("/proc/self/clear_refs", "5").ok()?;
    status_bytes("VmRSS")
}

/// CPU time used by this process so far [s] (Linux /proc/self/stat utime + stime, in
/// USER_HZ = 100 ticks per second).
fn process_cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &s[s.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

/// `N neighbour rebuilds in S steps (every S/N steps)`.
fn rebuild_line(rebuilds: u64, steps: u64) -> String {
    match rebuilds {
        0 => format!("no neighbour rebuild in {steps} steps"),
        r => format!(
            "{r} neighbour rebuilds in {steps} steps (every {:.0} steps)",
            steps as f64 / r as f64
        ),
    }
}

/// The median of `v` (the mean of the two middle values of an even count); None if empty.
fn median(mut v: Vec<f64>) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}

/// Tiles a sample k x k times in x and z.
pub fn tile(case: &ShearCase, p: &Packing, k: usize) -> (ShearCase, Packing) {
    let mut c = case.clone();
    c.box_x *= k as f64;
    c.box_z *= k as f64;
    c.particles *= k * k;
    let mut q = Packing {
        radius: Vec::new(),
        position: Vec::new(),
        velocity: Vec::new(),
        omega: Vec::new(),
        ..p.clone()
    };
    for ix in 0..k {
        for iz in 0..k {
            for i in 0..p.radius.len() {
                q.radius.push(p.radius[i]);
                let x = p.position[i];
                q.position.push([
                    x[0] + ix as f64 * case.box_x,
                    x[1],
                    x[2] + iz as f64 * case.box_z,
                ]);
                q.velocity.push(p.velocity[i]);
                q.omega.push(p.omega[i]);
            }
        }
    }
    (c, q)
}

impl super::Versioned for BenchReport {
    fn schema(&self) -> u32 {
        self.schema
    }
}

/// Measures, prints, writes `bench.json`; the report.
pub fn run(a: &BenchRequest) -> Result<BenchReport> {
    if a.steps == 0 {
        return Err(Error::invalid("--steps", 0, ">= 1"));
    }
    for &t in &a.threads {
        super::check_threads("--threads", t)?;
    }
    for &p in &a.procs {
        super::check_threads("--procs", p)?;
    }
    crate::spec::shear::check_particles("--particles", a.particles)?;
    super::check_memory("--particles", a.particles)?;
    if a.rounds == 0 || a.rounds > MAX_ROUNDS {
        return Err(Error::invalid(
            "--rounds",
            a.rounds,
            format!("1 to {MAX_ROUNDS}"),
        ));
    }
    if a.kernels.is_empty() {
        return Err(Error::invalid(
            "--kernels",
            "(none)",
            "one or more of scalar, avx2, avx512",
        ));
    }
    for k in &a.kernels {
        k.checked("--kernels")?;
    }
    let base = ShearCase::preset(a.preset, RollingModel::Epsd, 0.5, 0.5, 1)?;
    base.validate(false)?;
    let k = ((a.particles as f64 / base.particles as f64).sqrt().round() as usize).max(1);
    let out = a.out.clone();
    std::fs::create_dir_all(&out).map_err(|e| Error::io(&out, e))?;
    let rss0 = peak_rss();
    println!(
        "verify bench: compacting the {} sample ({} particles, {} steps)...",
        a.preset, base.particles, a.compression_steps
    );
    let loose = loose_packing(&base);
    let dense = compact(&base.setup(), &loose, a.compression_steps)?;
    let (case, state) = tile(&base, &dense, k);
    let n = state.radius.len();
    println!(
        "  state: {n} particles ({k} x {k} tiles), {} timed steps per code, warm-up {} steps",
        a.steps,
        a.steps / 4
    );
    // A run of both codes: 1 servo step, warm-up run, timed run.
    let warm = (a.steps / 4).max(1);
    let mut c = case.clone();
    c.compression_steps = 1;
    let speed = base.stages[0].speed;
    let h = c.estimated_height();
    c.stages = vec![
        Stage {
            speed,
            strain: warm as f64 * speed * c.dt / h,
        },
        Stage {
            speed,
            strain: a.steps as f64 * speed * c.dt / h,
        },
    ];
    let steps = c.stage_steps();
    c.output_every = c.total_steps();
    c.snapshot_every = 0;
    let mut rows = Vec::new();
    let mut rss_native = None;
    let mut held_native: Vec<(String, f64)> = Vec::new();
    for round in 0..a.rounds {
        if a.rounds > 1 {
            println!("  round {} of {}", round + 1, a.rounds);
        }
        for &kernel in &a.kernels {
            for &t in &a.threads {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .map_err(|e| Error::invalid("--threads", t, e.to_string()))?;
                type Timed = (
                    f64,
                    Option<f64>,
                    Option<PhaseTimes>,
                    (usize, usize, usize),
                    Vec<(&'static str, usize)>,
                    (usize, usize),
                    u64,
                );
                // the solver's own peak: from the resident set just before it is made (the input
                // state and the compaction's leftovers excluded)
                let before = if rss_native.is_none() {
                    reset_peak_rss()
                } else {
                    None
                };
                let (secs, cpu, phases, counts, held, cand, rebuilds) =
                    pool.install(|| -> Result<Timed> {
                        let mut s = ShearSim::new(&c.setup(), &state);
                        s.set_kernel(kernel)?;
                        s.setup(0.0)?;
                        s.step()?;
                        s.setup(speed)?;
                        for _ in 0..steps[0] {
                            s.step()?;
                        }
                        s.setup(speed)?;
                        s.time_phases(true);
                        let builds0 = s.neighbor_builds();
                        let (t0, c0) = (Instant::now(), process_cpu_seconds());
                        for _ in 0..steps[1] {
                            s.step()?;
                        }
                        let el = t0.elapsed().as_secs_f64();
                        let cpu = c0.zip(process_cpu_seconds()).map(|(a, b)| b - a);
                        s.check_finite()?;
                        Ok((
                            el,
                            cpu,
                            s.phase_times(),
                            s.contact_counts(),
                            s.memory(),
                            s.plate_candidates(),
                            s.neighbor_builds() - builds0,
                        ))
                    })?;
                if rss_native.is_none() {
                    held_native = held
                        .iter()
                        .map(|&(item, b)| (item.to_string(), b as f64 / n as f64))
                        .collect();
                    rss_native = match (before, peak_rss()) {
                        (Some(a0), Some(a1)) => Some((a1 - a0) / n as f64),
                        _ => {
                            println!(
                                "  (the peak resident set cannot be reset here: the memory figure \
                             counts the input state and the compaction too)"
                            );
                            rss0.zip(peak_rss()).map(|(a0, a1)| (a1 - a0) / n as f64)
                        }
                    };
                }
                let r = steps[1] as f64 * n as f64 / secs;
                println!(
                    "  native   {t} thread(s), {} kernel: {secs:8.2} s  {r:.3e} particle-steps/s  \
                 ({:.3e} per core; CPU {})",
                    kernel.name(),
                    r / t as f64,
                    cpu.map(|c| format!(
                        "{c:.2} s, {:.3e} particle-steps per CPU-second",
                        steps[1] as f64 * n as f64 / c
                    ))
                    .unwrap_or_else(|| "time not available".into())
                );
                if let Some(ph) = &phases {
                    let per = 1e9 / (steps[1] as f64 * n as f64);
                    let parts: Vec<String> = ph
                        .named()
                        .iter()
                        .map(|(name, sec)| format!("{name} {:.1}", sec * per))
                        .collect();
                    println!("           ns per particle-step: {}", parts.join(", "));
                }
                let per_particle = (
                    counts.0 as f64 / n as f64,
                    counts.1 as f64 / n as f64,
                    counts.2 as f64 / n as f64,
                );
                println!(
                "           per particle: {:.2} listed pairs, {:.2} touching pairs, {:.3} plate \
                 contacts; {:.1} % of the particles test {:.1} plate triangles each",
                per_particle.0,
                per_particle.1,
                per_particle.2,
                100.0 * cand.0 as f64 / n as f64,
                cand.1 as f64 / cand.0.max(1) as f64
            );
                println!("           {}", rebuild_line(rebuilds, steps[1]));
                rows.push(BenchRow {
                    code: "native".into(),
                    round,
                    workers: t,
                    particles: n,
                    steps: steps[1],
                    seconds: secs,
                    cpu_seconds: cpu,
                    particle_steps_per_s: r,
                    per_core: r / t as f64,
                    kernel: Some(kernel),
                    phases,
                    per_particle: Some(per_particle),
                    rebuilds: Some(rebuilds),
                });
            }
        }
        if let Some(lr) = &a.liggghts {
            for &p in &a.procs {
                let mut lig = lr.locate()?;
                if p > 1 {
                    lig.mpi_procs = Some(p);
                }
                let dir = out.join(format!("liggghts_np{p}"));
                std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
                lig.run(&crate::deck::shear::shear_deck(&c, &state), &dir)?;
                let (secs, st) = last_loop_time(&dir.join(LOG_NAME))?;
                let rebuilds = last_neighbor_builds(&dir.join(LOG_NAME))?;
                let r = st as f64 * n as f64 / secs;
                println!("  LIGGGHTS {p} process(es): {secs:8.2} s  {r:.3e} particle-steps/s  ({:.3e} per core)", r / p as f64);
                if let Some(b) = rebuilds {
                    println!("           {}", rebuild_line(b, st));
                }
                rows.push(BenchRow {
                    code: "liggghts".into(),
                    round,
                    workers: p,
                    particles: n,
                    steps: st,
                    seconds: secs,
                    cpu_seconds: None,
                    particle_steps_per_s: r,
                    per_core: r / p as f64,
                    kernel: None,
                    phases: None,
                    per_particle: None,
                    rebuilds,
                });
            }
        }
    }
    // a configuration's rate: the median of its rounds
    let rate = |code: &str, w: usize, k: Option<KernelPath>| {
        median(
            rows.iter()
                .filter(|r| r.code == code && r.workers == w && r.kernel == k)
                .map(|r| r.particle_steps_per_s)
                .collect(),
        )
    };
    // the ratios use the fastest kernel path measured with one thread (median rates)
    let kernel = a
        .kernels
        .iter()
        .filter_map(|&k| rate("native", 1, Some(k)).map(|r| (k, r)))
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(k, _)| k);
    let in_round = |code: &str, w: usize, round: usize| {
        rows.iter()
            .find(|r| {
                r.code == code
                    && r.workers == w
                    && r.round == round
                    && (code != "native" || r.kernel == kernel)
            })
            .map(|r| r.particle_steps_per_s)
    };
    let per_round = |num: (&str, usize), den: (&str, usize)| -> Vec<f64> {
        (0..a.rounds)
            .filter_map(|k| {
                in_round(num.0, num.1, k)
                    .zip(in_round(den.0, den.1, k))
                    .map(|(x, y)| x / y)
            })
            .collect()
    };
    let rounds_native_vs_liggghts_1 = per_round(("native", 1), ("liggghts", 1));
    let rounds_native_2_vs_1 = per_round(("native", 2), ("native", 1));
    let native_vs_liggghts_1 = median(rounds_native_vs_liggghts_1.clone());
    let native_2_vs_1 = median(rounds_native_2_vs_1.clone());
    // one paper run: 2500 particles, the paper preset's steps
    let paper = ShearCase::preset(Preset::Paper, RollingModel::Epsd, 0.5, 0.5, 1)?;
    let paper_ps = paper.total_steps() as f64 * paper.particles as f64;
    let mut paper_run_hours = Vec::new();
    for r in rows.iter().filter(|r| r.round == 0) {
        let Some(median_rate) = rate(&r.code, r.workers, r.kernel) else {
            continue;
        };
        paper_run_hours.push((
            match r.kernel {
                Some(k) => format!("{} x{} ({})", r.code, r.workers, k.name()),
                None => format!("{} x{}", r.code, r.workers),
            },
            paper_ps / median_rate / 3600.0,
        ));
    }
    let report = BenchReport {
        schema: super::SCHEMA,
        preset: a.preset,
        rolling: RollingModel::Epsd,
        particles: n,
        rows,
        native_vs_liggghts_1,
        native_2_vs_1,
        rounds_native_vs_liggghts_1,
        rounds_native_2_vs_1,
        kernel,
        native_bytes_per_particle: rss_native,
        native_held_per_particle: held_native.clone(),
        paper_run_hours,
        date_utc: utc_stamp(),
    };
    let rounds = |v: &[f64]| match v.len() {
        0 | 1 => String::new(),
        _ => {
            let each: Vec<String> = v.iter().map(|x| format!("{x:.2}")).collect();
            format!(" (median of {} rounds: {})", v.len(), each.join(", "))
        }
    };
    if let Some(x) = native_vs_liggghts_1 {
        println!(
            "  native 1 thread / LIGGGHTS 1 process = {x:.2}{}",
            rounds(&report.rounds_native_vs_liggghts_1)
        );
    }
    if let Some(x) = native_2_vs_1 {
        println!(
            "  native 2 threads / native 1 thread = {x:.2}{}",
            rounds(&report.rounds_native_2_vs_1)
        );
    }
    if let Some(b) = rss_native {
        println!("  native memory: {b:.0} bytes per particle (peak RSS growth of the solver)");
    }
    if !held_native.is_empty() {
        let total: f64 = held_native.iter().map(|(_, b)| b).sum();
        let parts: Vec<String> = held_native
            .iter()
            .filter(|(_, b)| *b > 0.0)
            .map(|(item, b)| format!("{item} {b:.0}"))
            .collect();
        println!(
            "  held by the solver: {total:.0} bytes per particle ({})",
            parts.join(", ")
        );
    }
    for (who, hrs) in &report.paper_run_hours {
        println!(
            "  estimated full paper run ({} steps x 2500 particles): {who}: {hrs:.1} h",
            paper.total_steps()
        );
    }
    write_atomic(
        &out.join("bench.json"),
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    super::note_summary(&out.join("bench.json"));
    println!("bench.json: {}", out.join("bench.json").display());
    Ok(report)
}
