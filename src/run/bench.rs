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
use crate::ranks::Timing;
use crate::run::tell::say;
use crate::shear::{bench_native, probe_ranks_link, Timed};
use crate::solver::shear::decompose::{Link, Traffic};
use crate::solver::shear::{compact, KernelPath, PhaseTimes};
use crate::spec::shear::{Preset, ShearCase, Stage};
use crate::spec::RollingModel;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

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
    #[serde(default = "one")]
    pub rounds: usize,
    /// MPI rank counts of the native runs (the `mpi` feature): 1 in this process, more by
    /// `mpirun -np R` of this binary's `verify bench` (each rank with every thread count).
    /// Under `mpirun` itself, the world's size alone.
    #[serde(default = "one_rank")]
    pub ranks: Vec<usize>,
    pub out: PathBuf,
}

fn one() -> usize {
    1
}

fn one_rank() -> Vec<usize> {
    vec![1]
}

/// The rank counts the scaling model predicts (where the bricks stay wider than the cut).
pub const MODEL_RANKS: [usize; 9] = [1, 2, 4, 16, 64, 128, 256, 512, 1024];

/// The most rounds one bench makes.
pub const MAX_ROUNDS: usize = 50;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchRow {
    pub code: String,
    /// The round this run belongs to (0 to [`BenchRequest::rounds`] - 1).
    #[serde(default)]
    pub round: usize,
    /// Threads (native: per rank) or MPI processes (LIGGGHTS).
    pub workers: usize,
    /// Native: MPI ranks the run was decomposed over (1: one process).
    #[serde(default = "one")]
    pub ranks: usize,
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
    /// Native over ranks: what rank 0's exchanges carried during the timed steps.
    #[serde(default)]
    pub traffic: Option<Traffic>,
    /// Native over ranks: every rank's phases, by rank (rank 0's are `phases`): a rank
    /// busier than the others makes them wait in `comm`.
    #[serde(default)]
    pub rank_phases: Vec<PhaseTimes>,
    /// Native over ranks: every rank's own particles at the end, by rank (where the
    /// balance by measured time put the cuts).
    #[serde(default)]
    pub rank_particles: Vec<u64>,
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
    /// native 2 ranks x 1 thread / native 1 rank x 1 thread (median of the rounds), and each
    /// round's.
    #[serde(default)]
    pub native_ranks_2_vs_1: Option<f64>,
    #[serde(default)]
    pub rounds_native_ranks_2_vs_1: Vec<f64>,
    /// LIGGGHTS 2 processes / LIGGGHTS 1 process (median of the rounds).
    #[serde(default)]
    pub liggghts_2_vs_1: Option<f64>,
    /// The link between the ranks, measured under `mpirun` (the first rank count above 1).
    #[serde(default)]
    pub link: Option<Link>,
    /// The scaling model fitted to the 1-rank run ([`super::scaling`]).
    #[serde(default)]
    pub scaling: Option<super::scaling::Scaling>,
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

/// The rank count this bench's native runs are decomposed over: the world's under `mpirun`
/// (then `--ranks` must be it alone, and LIGGGHTS is not run: the serving ranks would share
/// its cores), else 1 (more ranks are measured by child benches under `mpirun`).
fn world_ranks(a: &BenchRequest) -> Result<usize> {
    let world = crate::ranks::native_ranks();
    if world > 1 {
        if a.ranks != [world] && a.ranks != [1] {
            return Err(Error::invalid(
                "--ranks",
                format!("{:?}", a.ranks),
                format!(
                    "{world} alone under `mpirun -np {world}` (run verify bench without mpirun \
                     to measure several rank counts)"
                ),
            ));
        }
        if a.liggghts.is_some() {
            return Err(Error::invalid(
                "--native-only",
                "off",
                "on under mpirun (LIGGGHTS would share the cores the waiting ranks spin on; \
                 run verify bench without mpirun to measure both codes)",
            ));
        }
    } else if a.ranks.iter().any(|&r| r > 1) && !cfg!(feature = "mpi") {
        return Err(Error::invalid(
            "--ranks",
            format!("{:?}", a.ranks),
            "1 in a build without MPI (install with `cargo install --path . --features mpi`)",
        ));
    }
    Ok(world)
}

/// Prints one row's lines.
fn print_row(r: &BenchRow) {
    let per = 1e9 / (r.steps as f64 * r.particles as f64);
    match r.code.as_str() {
        "native" => {
            let ranks = if r.ranks > 1 {
                format!("{} ranks x ", r.ranks)
            } else {
                String::new()
            };
            say!(
                "  native   {ranks}{} thread(s), {} kernel: {:8.2} s  {:.3e} particle-steps/s  \
                 ({:.3e} per core; CPU {})",
                r.workers,
                r.kernel.map(|k| k.name()).unwrap_or("?"),
                r.seconds,
                r.particle_steps_per_s,
                r.per_core,
                r.cpu_seconds
                    .map(|c| format!(
                        "{c:.2} s{}, {:.3e} particle-steps per CPU-second",
                        if r.ranks > 1 { " on rank 0" } else { "" },
                        r.steps as f64 * r.particles as f64 / c / r.ranks as f64
                    ))
                    .unwrap_or_else(|| "time not available".into())
            );
            if let Some(ph) = &r.phases {
                let parts: Vec<String> = ph
                    .named()
                    .iter()
                    .filter(|(name, sec)| *sec > 0.0 || *name != "communication")
                    .map(|(name, sec)| format!("{name} {:.1}", sec * per))
                    .collect();
                say!(
                    "           ns per particle-step{}: {}",
                    if r.ranks > 1 { " (rank 0)" } else { "" },
                    parts.join(", ")
                );
            }
            if r.rank_phases.len() > 1 {
                // a rank's busy time: every phase but the exchanges (where it waits)
                let busy: Vec<String> = r
                    .rank_phases
                    .iter()
                    .map(|p| {
                        let all: f64 = p.named().iter().map(|x| x.1).sum();
                        format!("{:.1}", (all - p.comm) * per)
                    })
                    .collect();
                let comm: Vec<String> = r
                    .rank_phases
                    .iter()
                    .map(|p| format!("{:.1}", p.comm * per))
                    .collect();
                say!(
                    "           by rank, ns per particle-step: busy {}, communication {}",
                    busy.join(" / "),
                    comm.join(" / ")
                );
                let own: Vec<String> = r.rank_particles.iter().map(|n| n.to_string()).collect();
                say!(
                    "           own particles by rank at the end (bricks balanced by measured \
                     time): {}",
                    own.join(" / ")
                );
            }
            if let Some(t) = &r.traffic {
                let steps = r.steps as f64;
                say!(
                    "           rank 0 exchanged {:.1} times, sent {:.1} messages and {:.1} kB per \
                     step, {:.1} us per step in exchanges",
                    t.calls as f64 / steps,
                    t.messages as f64 / steps,
                    t.bytes as f64 / steps / 1e3,
                    t.seconds / steps * 1e6
                );
            }
            if let Some(pp) = r.per_particle {
                say!(
                    "           per particle: {:.2} listed pairs, {:.2} touching pairs, {:.3} \
                     plate contacts",
                    pp.0,
                    pp.1,
                    pp.2
                );
            }
            if let Some(b) = r.rebuilds {
                say!("           {}", rebuild_line(b, r.steps));
            }
        }
        _ => {
            say!(
                "  LIGGGHTS {} process(es): {:8.2} s  {:.3e} particle-steps/s  ({:.3e} per core)",
                r.workers,
                r.seconds,
                r.particle_steps_per_s,
                r.per_core
            );
            if let Some(b) = r.rebuilds {
                say!("           {}", rebuild_line(b, r.steps));
            }
        }
    }
}

/// The native rows of `ranks` ranks: this binary's `verify bench` under `mpirun -np ranks`
/// (native only, one round, every thread count and kernel path), its outputs in `dir`
/// (`bench.json`, `bench.log`); its rows and the link it measured.
fn rows_over_ranks(
    a: &BenchRequest,
    ranks: usize,
    dir: &Path,
) -> Result<(Vec<BenchRow>, Option<Link>)> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let exe = std::env::current_exe().map_err(|e| Error::io("verify", e))?;
    let log = dir.join("bench.log");
    let out = std::fs::File::create(&log).map_err(|e| Error::io(&log, e))?;
    let err = out.try_clone().map_err(|e| Error::io(&log, e))?;
    let list = |v: Vec<String>| v.join(",");
    let mut cmd = Command::new("mpirun");
    cmd.arg("--allow-run-as-root");
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if ranks * a.threads.iter().copied().max().unwrap_or(1) > cores {
        cmd.arg("--oversubscribe");
    }
    cmd.args(["-np", &ranks.to_string()])
        .arg(&exe)
        .arg("bench")
        .args(["--preset", a.preset.keyword()])
        .args(["--steps", &a.steps.to_string()])
        .args([
            "--threads",
            &list(a.threads.iter().map(|t| t.to_string()).collect()),
        ])
        .args([
            "--kernels",
            &list(a.kernels.iter().map(|k| k.name().to_string()).collect()),
        ])
        .args(["--particles", &a.particles.to_string()])
        .args(["--compression-steps", &a.compression_steps.to_string()])
        .args([
            "--ranks",
            &ranks.to_string(),
            "--native-only",
            "--rounds",
            "1",
        ])
        .arg("--out")
        .arg(dir)
        .stdin(Stdio::null())
        .stdout(out)
        .stderr(err);
    let status = cmd
        .status()
        .map_err(|e| Error::io("mpirun (is openmpi-bin installed?)", e))?;
    if !status.success() {
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        let tail: Vec<&str> = text.lines().rev().take(15).collect();
        return Err(Error::Ranks(format!(
            "verify bench on {ranks} ranks failed ({status}); the end of {}:\n{}",
            log.display(),
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        )));
    }
    let child: BenchReport = super::load(&dir.join("bench.json"))?;
    let rows: Vec<BenchRow> = child
        .rows
        .into_iter()
        .filter(|r| r.code == "native" && r.ranks == ranks)
        .collect();
    if rows.len() != a.threads.len() * a.kernels.len() {
        return Err(Error::Ranks(format!(
            "verify bench on {ranks} ranks gave {} native rows of {} ranks, not {} ({})",
            rows.len(),
            ranks,
            a.threads.len() * a.kernels.len(),
            dir.join("bench.json").display()
        )));
    }
    Ok((rows, child.link))
}

/// The bench's request checked field by field before anything is made.
fn check(a: &BenchRequest) -> Result<()> {
    if a.steps == 0 {
        return Err(Error::invalid("--steps", 0, ">= 1"));
    }
    for &t in &a.threads {
        super::check_threads("--threads", t)?;
    }
    for &p in &a.procs {
        super::check_threads("--procs", p)?;
    }
    if a.ranks.is_empty() {
        return Err(Error::invalid(
            "--ranks",
            "(none)",
            "one or more of 1 ..= 1024",
        ));
    }
    for &r in &a.ranks {
        if !(1..=1024).contains(&r) {
            return Err(Error::invalid("--ranks", r, "1 ..= 1024"));
        }
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
    Ok(())
}

/// What every code of every round runs: the dense state (the preset's sample compacted, tiled
/// `k x k`) and its case, cut to 1 servo step, a warm-up stage (a quarter of the timed steps)
/// and the timed stage.
struct Bench {
    case: ShearCase,
    state: Packing,
    /// Particles of the state.
    n: usize,
    /// Steps of the warm-up and of the timed stage.
    steps: Vec<u64>,
    speed: f64,
}

impl Bench {
    fn new(a: &BenchRequest) -> Result<Bench> {
        let base = ShearCase::preset(a.preset, RollingModel::Epsd, 0.5, 0.5, 1)?;
        base.validate(false)?;
        let k = ((a.particles as f64 / base.particles as f64).sqrt().round() as usize).max(1);
        say!(
            "verify bench: compacting the {} sample ({} particles, {} steps)...",
            a.preset,
            base.particles,
            a.compression_steps
        );
        let loose = loose_packing(&base);
        let dense = compact(&base.setup(), &loose, a.compression_steps)?;
        let (case, state) = tile(&base, &dense, k);
        let n = state.radius.len();
        say!(
            "  state: {n} particles ({k} x {k} tiles), {} timed steps per code, warm-up {} steps",
            a.steps,
            a.steps / 4
        );
        let warm = (a.steps / 4).max(1);
        let mut c = case;
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
        Ok(Bench {
            case: c,
            state,
            n,
            steps,
            speed,
        })
    }
}

/// What the first native runs leave beside their rows: the solver's memory (first run) and
/// the scaling model's fit of each kernel path (its first 1-rank, 1-thread run).
#[derive(Default)]
struct Firsts {
    /// The memory figures are taken (by the first native run of this process).
    measured: bool,
    bytes_per_particle: Option<f64>,
    held_per_particle: Vec<(String, f64)>,
    /// By kernel path: the report's model is fitted to the path its ratios and its check
    /// use (before 2026-12-07 the first path benched, scalar by default, was fitted and
    /// checked against avx2's 2-rank run: predicted/measured 0.65-0.74 from that alone).
    fits: Vec<(KernelPath, super::scaling::Fit)>,
}

/// One round's native runs in this process (or, under `mpirun`, this world of ranks): every
/// kernel path at every thread count.
fn native_rows(
    a: &BenchRequest,
    b: &Bench,
    world: usize,
    round: usize,
    rss0: Option<f64>,
    firsts: &mut Firsts,
) -> Result<Vec<BenchRow>> {
    let n = b.n;
    let mut rows = Vec::new();
    for &kernel in &a.kernels {
        for &t in &a.threads {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| Error::invalid("--threads", t, e.to_string()))?;
            // the solver's own peak: from the resident set just before it is made (the input
            // state and the compaction's leftovers excluded)
            let first = !firsts.measured && world == 1;
            let before = if first { reset_peak_rss() } else { None };
            let timing = Timing {
                warm: b.steps[0],
                timed: b.steps[1],
                speed: b.speed,
                kernel,
            };
            let model_now = world == 1 && t == 1 && !firsts.fits.iter().any(|(k, _)| *k == kernel);
            let (timed, (counts, held, cand, fit)) = pool.install(|| {
                bench_native(&b.case, &b.state, timing, |timed, s| {
                    let l = s.local();
                    // the 1-rank run's costs and its state's census for the scaling model,
                    // taken here (the state is not kept)
                    let fit = model_now
                        .then(|| {
                            let p = timed.phases.as_ref()?;
                            let costs =
                                super::scaling::Costs::of(p, l.listed_pairs(), n, timed.rebuilds)?;
                            Some(super::scaling::fit(l, costs, &MODEL_RANKS))
                        })
                        .flatten();
                    (l.contact_counts(), l.memory(), l.plate_candidates(), fit)
                })
            })?;
            if let Some(f) = fit {
                firsts.fits.push((kernel, f));
            }
            if first {
                firsts.measured = true;
                firsts.held_per_particle = held
                    .iter()
                    .map(|&(item, b)| (item.to_string(), b as f64 / n as f64))
                    .collect();
                firsts.bytes_per_particle = match (before, peak_rss()) {
                    (Some(a0), Some(a1)) => Some((a1 - a0) / n as f64),
                    _ => {
                        say!(
                            "  (the peak resident set cannot be reset here: the memory figure \
                             counts the input state and the compaction too)"
                        );
                        rss0.zip(peak_rss()).map(|(a0, a1)| (a1 - a0) / n as f64)
                    }
                };
            }
            let row = native_row(timed, counts, round, t, world, b, kernel);
            print_row(&row);
            if world == 1 {
                say!(
                    "           {:.1} % of the particles test {:.1} plate triangles each",
                    100.0 * cand.0 as f64 / n as f64,
                    cand.1 as f64 / cand.0.max(1) as f64
                );
            }
            rows.push(row);
        }
    }
    Ok(rows)
}

/// A native run's row.
fn native_row(
    timed: Timed,
    counts: (usize, usize, usize),
    round: usize,
    threads: usize,
    world: usize,
    b: &Bench,
    kernel: KernelPath,
) -> BenchRow {
    let (n, steps) = (b.n, b.steps[1]);
    let Timed {
        seconds,
        cpu_seconds,
        phases,
        rank_phases,
        rank_particles,
        rebuilds,
        traffic,
    } = timed;
    let r = steps as f64 * n as f64 / seconds;
    BenchRow {
        code: "native".into(),
        round,
        workers: threads,
        ranks: world,
        particles: n,
        steps,
        seconds,
        cpu_seconds,
        particle_steps_per_s: r,
        per_core: r / (threads * world) as f64,
        kernel: Some(kernel),
        phases,
        // a brick's counts are of its own particles and ghosts: one process's only
        per_particle: (world == 1).then(|| {
            (
                counts.0 as f64 / n as f64,
                counts.1 as f64 / n as f64,
                counts.2 as f64 / n as f64,
            )
        }),
        rebuilds: Some(rebuilds),
        traffic,
        rank_phases: if world > 1 {
            rank_phases.into_iter().flatten().collect()
        } else {
            Vec::new()
        },
        rank_particles: if world > 1 {
            rank_particles
        } else {
            Vec::new()
        },
    }
}

/// One round's native runs over more than one rank: `mpirun -np r verify bench` for each rank
/// count above 1 (from a 1-rank bench).
fn ranks_rows(a: &BenchRequest, round: usize, link: &mut Option<Link>) -> Result<Vec<BenchRow>> {
    let mut rows = Vec::new();
    for &r in a.ranks.iter().filter(|&&r| r > 1) {
        let dir = a.out.join(format!("ranks{r}_round{round}"));
        say!(
            "  native over {r} MPI ranks: `mpirun -np {r} verify bench` (log {})",
            dir.join("bench.log").display()
        );
        let (got, l) = rows_over_ranks(a, r, &dir)?;
        if link.is_none() {
            *link = l;
        }
        for mut row in got {
            row.round = round;
            print_row(&row);
            rows.push(row);
        }
    }
    Ok(rows)
}

/// One round's LIGGGHTS runs, one per process count, on the same state and steps.
fn liggghts_rows(
    a: &BenchRequest,
    lr: &LiggghtsRequest,
    b: &Bench,
    round: usize,
) -> Result<Vec<BenchRow>> {
    let mut rows = Vec::new();
    for &p in &a.procs {
        let mut lig = lr.locate()?;
        if p > 1 {
            lig.mpi_procs = Some(p);
        }
        let dir = a.out.join(format!("liggghts_np{p}"));
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        lig.run(&crate::deck::shear::shear_deck(&b.case, &b.state), &dir)?;
        let (secs, st) = last_loop_time(&dir.join(LOG_NAME))?;
        let rebuilds = last_neighbor_builds(&dir.join(LOG_NAME))?;
        let r = st as f64 * b.n as f64 / secs;
        let row = BenchRow {
            code: "liggghts".into(),
            round,
            workers: p,
            ranks: p,
            particles: b.n,
            steps: st,
            seconds: secs,
            cpu_seconds: None,
            particle_steps_per_s: r,
            per_core: r / p as f64,
            kernel: None,
            phases: None,
            per_particle: None,
            rebuilds,
            traffic: None,
            rank_phases: Vec::new(),
            rank_particles: Vec::new(),
        };
        print_row(&row);
        rows.push(row);
    }
    Ok(rows)
}

/// A configuration's rate (code, threads or processes, ranks, kernel path): the median of
/// its rounds.
fn rate(
    rows: &[BenchRow],
    code: &str,
    w: usize,
    ranks: usize,
    k: Option<KernelPath>,
) -> Option<f64> {
    median(
        rows.iter()
            .filter(|r| r.code == code && r.workers == w && r.ranks == ranks && r.kernel == k)
            .map(|r| r.particle_steps_per_s)
            .collect(),
    )
}

/// The rows' ratios (per round and their medians, on the fastest kernel path measured with
/// one thread), the estimated paper-run hours, the scaling model: the report.
fn summarise(
    a: &BenchRequest,
    n: usize,
    rows: Vec<BenchRow>,
    firsts: Firsts,
    link: Option<Link>,
) -> Result<BenchReport> {
    let kernel = a
        .kernels
        .iter()
        .filter_map(|&k| rate(&rows, "native", 1, 1, Some(k)).map(|r| (k, r)))
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(k, _)| k);
    let in_round = |code: &str, w: usize, ranks: usize, round: usize| {
        rows.iter()
            .find(|r| {
                r.code == code
                    && r.workers == w
                    && r.ranks == ranks
                    && r.round == round
                    && (code != "native" || r.kernel == kernel)
            })
            .map(|r| r.particle_steps_per_s)
    };
    let per_round = |num: (&str, usize, usize), den: (&str, usize, usize)| -> Vec<f64> {
        (0..a.rounds)
            .filter_map(|k| {
                in_round(num.0, num.1, num.2, k)
                    .zip(in_round(den.0, den.1, den.2, k))
                    .map(|(x, y)| x / y)
            })
            .collect()
    };
    let rounds_native_vs_liggghts_1 = per_round(("native", 1, 1), ("liggghts", 1, 1));
    let rounds_native_2_vs_1 = per_round(("native", 2, 1), ("native", 1, 1));
    let rounds_native_ranks_2_vs_1 = per_round(("native", 1, 2), ("native", 1, 1));
    let liggghts_2_vs_1 = median(per_round(("liggghts", 2, 2), ("liggghts", 1, 1)));
    // one paper run: 2500 particles, the paper preset's steps
    let paper = paper_case()?;
    let paper_ps = paper.total_steps() as f64 * paper.particles as f64;
    let mut paper_run_hours = Vec::new();
    for r in rows.iter().filter(|r| r.round == 0) {
        let Some(median_rate) = rate(&rows, &r.code, r.workers, r.ranks, r.kernel) else {
            continue;
        };
        let ranks = if r.code == "native" && r.ranks > 1 {
            format!("{} ranks ", r.ranks)
        } else {
            String::new()
        };
        paper_run_hours.push((
            match r.kernel {
                Some(k) => format!("{} {ranks}x{} ({})", r.code, r.workers, k.name()),
                None => format!("{} x{}", r.code, r.workers),
            },
            paper_ps / median_rate / 3600.0,
        ));
    }
    Ok(BenchReport {
        schema: super::SCHEMA,
        preset: a.preset,
        rolling: RollingModel::Epsd,
        particles: n,
        native_vs_liggghts_1: median(rounds_native_vs_liggghts_1.clone()),
        native_2_vs_1: median(rounds_native_2_vs_1.clone()),
        rounds_native_vs_liggghts_1,
        rounds_native_2_vs_1,
        native_ranks_2_vs_1: median(rounds_native_ranks_2_vs_1.clone()),
        rounds_native_ranks_2_vs_1,
        liggghts_2_vs_1,
        link,
        scaling: firsts
            .fits
            .iter()
            .find(|(k, _)| Some(*k) == kernel)
            .map(|(_, f)| super::scaling::model(f, link)),
        kernel,
        native_bytes_per_particle: firsts.bytes_per_particle,
        native_held_per_particle: firsts.held_per_particle,
        paper_run_hours,
        rows,
        date_utc: utc_stamp(),
    })
}

/// One `paper` run (2500 particles; its compaction and three stages): what the bench's rates
/// are turned into hours of.
fn paper_case() -> Result<ShearCase> {
    ShearCase::preset(Preset::Paper, RollingModel::Epsd, 0.5, 0.5, 1)
}

/// The report's ratios, memory, paper-run hours and scaling table, said line by line.
fn say_summary(report: &BenchReport) -> Result<()> {
    let rounds = |v: &[f64]| match v.len() {
        0 | 1 => String::new(),
        _ => {
            let each: Vec<String> = v.iter().map(|x| format!("{x:.2}")).collect();
            format!(" (median of {} rounds: {})", v.len(), each.join(", "))
        }
    };
    if let Some(x) = report.native_vs_liggghts_1 {
        say!(
            "  native 1 thread / LIGGGHTS 1 process = {x:.2}{}",
            rounds(&report.rounds_native_vs_liggghts_1)
        );
    }
    if let Some(x) = report.native_2_vs_1 {
        say!(
            "  native 2 threads / native 1 thread = {x:.2}{}",
            rounds(&report.rounds_native_2_vs_1)
        );
    }
    if let Some(x) = report.native_ranks_2_vs_1 {
        say!(
            "  native 2 ranks x 1 thread / native 1 thread = {x:.2}{}",
            rounds(&report.rounds_native_ranks_2_vs_1)
        );
    }
    if let Some(x) = report.liggghts_2_vs_1 {
        say!("  LIGGGHTS 2 processes / LIGGGHTS 1 process = {x:.2}");
    }
    if let Some(b) = report.native_bytes_per_particle {
        say!("  native memory: {b:.0} bytes per particle (peak RSS growth of the solver)");
    }
    let held = &report.native_held_per_particle;
    if !held.is_empty() {
        let total: f64 = held.iter().map(|(_, b)| b).sum();
        let parts: Vec<String> = held
            .iter()
            .filter(|(_, b)| *b > 0.0)
            .map(|(item, b)| format!("{item} {b:.0}"))
            .collect();
        say!(
            "  held by the solver: {total:.0} bytes per particle ({})",
            parts.join(", ")
        );
    }
    let paper = paper_case()?;
    for (who, hrs) in &report.paper_run_hours {
        say!(
            "  estimated full paper run ({} steps x {} particles): {who}: {hrs:.1} h",
            paper.total_steps(),
            paper.particles
        );
    }
    if let Some(sc) = &report.scaling {
        for line in super::scaling::table(sc) {
            say!("{line}");
        }
        // the model against what ran here: 2 ranks x 1 thread
        let measured = rate(&report.rows, "native", 1, 2, report.kernel);
        if let (Some(p2), Some(measured)) = (sc.points.iter().find(|p| p.ranks == 2), measured) {
            if let Some(pred) = p2.here_built_s {
                let measured_s = report.particles as f64 / measured;
                say!(
                    "  model check, 2 ranks x 1 thread here: predicted {:.1} us per step, \
                     measured {:.1} us (measured / predicted {:.2})",
                    pred * 1e6,
                    measured_s * 1e6,
                    measured_s / pred
                );
            }
        }
    }
    Ok(())
}

/// Measures, prints, writes `bench.json`; the report. Every round runs every configuration
/// once, in the same order (native here, native over ranks, LIGGGHTS), so that a ratio is
/// taken between runs minutes apart on the same machine.
pub fn run(a: &BenchRequest) -> Result<BenchReport> {
    check(a)?;
    let world = world_ranks(a)?;
    std::fs::create_dir_all(&a.out).map_err(|e| Error::io(&a.out, e))?;
    let rss0 = peak_rss();
    let b = Bench::new(a)?;
    let mut link = if world > 1 {
        let l = probe_ranks_link();
        if let Some(l) = &l {
            say!(
                "  link between the {world} ranks: {:.2} us per message, {:.2} GB/s",
                l.latency_s * 1e6,
                1e-9 / l.seconds_per_byte.max(1e-15)
            );
        }
        l
    } else {
        None
    };
    let mut rows = Vec::new();
    let mut firsts = Firsts::default();
    for round in 0..a.rounds {
        if a.rounds > 1 {
            say!("  round {} of {}", round + 1, a.rounds);
        }
        if world > 1 || a.ranks.contains(&1) {
            rows.extend(native_rows(a, &b, world, round, rss0, &mut firsts)?);
        }
        if world == 1 {
            rows.extend(ranks_rows(a, round, &mut link)?);
        }
        if let Some(lr) = &a.liggghts {
            rows.extend(liggghts_rows(a, lr, &b, round)?);
        }
    }
    let report = summarise(a, b.n, rows, firsts, link)?;
    say_summary(&report)?;
    let file = a.out.join("bench.json");
    write_atomic(&file, serde_json::to_string_pretty(&report)?.as_bytes())?;
    super::note_summary(&file);
    say!("bench.json: {}", file.display());
    Ok(report)
}
