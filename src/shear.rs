//! The shear experiment in both codes from one case and one initial packing: runs, progress,
//! and the common time series (plate forces, mu, height, kinetic energies).

use crate::deck::shear::{
    shear_deck_with, DeckExtras, PROFILE_PREFIX, RESTART_PREFIX, SNAPSHOT_PREFIX, THERMO_COLUMNS,
};
use crate::error::{Error, Result};
use crate::fsutil::{sha256_hex, write_atomic};
use crate::liggghts::{dump_atoms, last_thermo_step, parse_err, read_thermo, Liggghts, LOG_NAME};
use crate::packing::Packing;
use crate::profile::{profiles, ProfileSample, VelocityProfile};
use crate::run::progress::Progress;
use crate::series::Series;
use crate::solver::shear::decompose::{Stepper, Traffic};
use crate::solver::shear::observe::PlateRecord;
use crate::solver::shear::plate::{plate_triangles, Plate, Side};
use crate::solver::shear::{PhaseTimes, ShearSim};
use crate::spec::shear::ShearCase;
use crate::spec::windows::{is_sample, schedule};
use crate::vtk;
use std::path::Path;
use std::time::Instant;

/// One output row of either code (SI units; forces are the particles' on the plates).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Row {
    pub step: u64,
    pub top_force: [f64; 3],
    pub bottom_force: [f64; 3],
    /// y of the top plate's base [m].
    pub top_y: f64,
    /// Translational and rotational kinetic energy [J].
    pub ke: f64,
    pub erot: f64,
    /// Fraction of touching pairs at full rolling mobilisation (native only; NaN for LIGGGHTS).
    pub mobilised: f64,
}

impl From<&PlateRecord> for Row {
    /// The native solver's output record as a row (its shear displacement is recomputed from
    /// the case in [`shear_series`], as for LIGGGHTS).
    fn from(r: &PlateRecord) -> Self {
        Row {
            step: r.step,
            top_force: r.top_force,
            bottom_force: r.bottom_force,
            top_y: r.top_y,
            ke: r.ke,
            erot: r.erot,
            mobilised: r.mobilised,
        }
    }
}

impl Row {
    /// The values in [`ROW_COLUMNS`] order.
    pub fn values(&self) -> [f64; 10] {
        let (t, b) = (self.top_force, self.bottom_force);
        [
            t[0],
            t[1],
            t[2],
            b[0],
            b[1],
            b[2],
            self.top_y,
            self.ke,
            self.erot,
            self.mobilised,
        ]
    }

    /// The row of values in [`ROW_COLUMNS`] order.
    pub fn from_values(step: u64, v: [f64; 10]) -> Self {
        Row {
            step,
            top_force: [v[0], v[1], v[2]],
            bottom_force: [v[3], v[4], v[5]],
            top_y: v[6],
            ke: v[7],
            erot: v[8],
            mobilised: v[9],
        }
    }
}

/// Series columns holding a [`Row`]'s values, in the row's order.
pub const ROW_COLUMNS: [&str; 10] = [
    "top_f_x[N]",
    "top_f_y[N]",
    "top_f_z[N]",
    "bottom_f_x[N]",
    "bottom_f_y[N]",
    "bottom_f_z[N]",
    "top_y[m]",
    "ke[J]",
    "erot[J]",
    // native only (LIGGGHTS: NaN): see `PlateRecord::mobilised`
    "mobilised[-]",
];

/// Result of one code's run.
#[derive(Clone, Debug)]
pub struct CodeRun {
    pub rows: Vec<Row>,
    pub wall_time: f64,
    pub steps: u64,
    /// Native runs: the state at the end of compression.
    pub compacted: Option<Packing>,
    /// The steady velocity profile of each stage ([`crate::profile`]).
    pub profiles: Vec<VelocityProfile>,
    /// LIGGGHTS runs: the restart steps it was continued from after an interruption (the
    /// series is then the uninterrupted run's up to the first of them, not after it).
    pub resumed_from: Vec<u64>,
}

impl CodeRun {
    /// Particle-steps per second of wall time.
    pub fn throughput(&self, particles: usize) -> f64 {
        self.steps as f64 * particles as f64 / self.wall_time.max(1e-9)
    }
}

/// Bottom plate displacement along x at `step` [m] (0 during compression).
pub fn displacement(case: &ShearCase, step: u64) -> f64 {
    let mut d = 0.0;
    let mut start = case.compression_steps;
    for (stage, n) in case.stages.iter().zip(case.stage_steps()) {
        if step <= start {
            break;
        }
        let k = (step - start).min(n);
        d += stage.speed * case.dt * k as f64;
        start += n;
    }
    d
}

/// Index of the stage `step` belongs to (None during compression).
pub fn stage_of(case: &ShearCase, step: u64) -> Option<usize> {
    let ends = case.run_ends();
    (1..ends.len())
        .find(|&k| step > ends[k - 1] && step <= ends[k])
        .map(|k| k - 1)
}

/// Whether the native solver records at `step`: every `output_every`, and the last step of
/// each run (LIGGGHTS' thermo prints both).
fn is_output(case: &ShearCase, step: u64, ends: &[u64]) -> bool {
    step.is_multiple_of(case.output_every) || ends.contains(&step)
}

/// When a native run writes its checkpoint ([`run_native`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Checkpointing {
    /// Never (short runs: lockstep, tests).
    Off,
    /// At the first output step after this much wall time since the last checkpoint (or the
    /// start); `Duration::ZERO` checkpoints at every output step.
    Every(std::time::Duration),
}

/// Wall time between checkpoints of long runs: a machine restart or a cluster job's time
/// limit loses at most this much work.
pub const CHECKPOINT_EVERY: std::time::Duration = std::time::Duration::from_secs(300);

/// File name of a native run's checkpoint in its output directory.
pub const CHECKPOINT_NAME: &str = "native_checkpoint.bin";

/// Version of the checkpoint format; a checkpoint of another version is not read (3: the
/// per-pair state split from epsd_implicit's per-pair dashpot, 2026-12-02; 4: sealed, with the
/// case's hash and the payload's SHA-256 in a header, 2026-12-04; 5: the solver holds its
/// own constants, not the case description, 2026-12-05).
const CHECKPOINT_VERSION: u32 = 5;

/// What the seal of a checkpoint names ([`crate::fsutil::seal`]).
const CHECKPOINT_KIND: &str = "native shear checkpoint";

/// Everything a native run holds part way: the whole solver state (particles, pair and wall
/// histories, neighbour list and its rebuild state, servo, plates and meshes, step), the rows
/// and profile samples so far, the compacted state, the stage, and the wall time spent.
/// MessagePack (every f64 as its 64 bits), so the resumed run is bit-identical to an
/// uninterrupted one, sealed with the case's hash and the payload's SHA-256 and written
/// atomically: a checkpoint that does not verify is never resumed.
#[derive(serde::Serialize, serde::Deserialize)]
struct NativeCheckpoint {
    stage: usize,
    wall_time: f64,
    sim: ShearSim,
    rows: Vec<Row>,
    compacted: Option<Packing>,
    profile: Vec<ProfileSample>,
}

/// The checkpoint in `out` if it verifies against `case` (JSON) and this format. One that
/// exists but does not verify is refused with a note on stderr saying why, and kept as
/// `native_checkpoint.rejected` for inspection: the run starts over.
fn load_checkpoint(out: &Path, case_json: &str) -> Option<NativeCheckpoint> {
    let path = out.join(CHECKPOINT_NAME);
    let bytes = std::fs::read(&path).ok()?;
    let refuse = |why: String| {
        let kept = out.join("native_checkpoint.rejected");
        let _ = std::fs::rename(&path, &kept);
        crate::run::tell::note(&format!(
            "{} is not resumed: {why}; the run starts over (the file is kept as {})",
            path.display(),
            kept.display()
        ));
        None
    };
    let payload = match crate::fsutil::unseal(
        &bytes,
        CHECKPOINT_KIND,
        CHECKPOINT_VERSION,
        case_json.as_bytes(),
    ) {
        Ok(p) => p,
        Err(why) => return refuse(why),
    };
    match rmp_serde::from_slice(payload) {
        Ok(cp) => Some(cp),
        Err(e) => refuse(format!("its content does not decode ({e})")),
    }
}

/// Runs the native solver. Outputs as LIGGGHTS' thermo: step 0, every `output_every`, and
/// the last step of each run. Snapshots (VTK) go to `out/vtk/`. On failure the rows so far
/// are written to `out/native_partial.csv` before the error is returned.
///
/// With `checkpointing` on, the run writes `out/native_checkpoint.bin` ([`NativeCheckpoint`])
/// at output steps and resumes from it when called again with the same case: the finished
/// run is bit-identical to one never interrupted. The checkpoint is deleted when the run ends.
///
/// Under `mpirun` (the `mpi` feature, issue #39) the run is decomposed over the ranks
/// ([`crate::ranks`]): this rank (0) hands the initial state to the others and steps brick 0;
/// the outputs, identical to one process's, are written here.
pub fn run_native(
    case: &ShearCase,
    packing: &Packing,
    out: &Path,
    progress: &Progress,
    checkpointing: Checkpointing,
) -> Result<CodeRun> {
    let t0 = Instant::now();
    let case_json = serde_json::to_string(case)?;
    let resumed = match checkpointing {
        Checkpointing::Off => None,
        Checkpointing::Every(_) => load_checkpoint(out, &case_json),
    };
    let (sim, mut run, first_stage) = match resumed {
        Some(cp) => {
            progress.resume_at(
                cp.sim.step,
                &format!("resumed from checkpoint at step {}", cp.sim.step),
            );
            let run = NativeLoop {
                rows: cp.rows,
                compacted: cp.compacted,
                profile: cp.profile,
                wall_before: cp.wall_time,
                t0,
            };
            (cp.sim, run, cp.stage)
        }
        None => (
            ShearSim::new(&case.setup(), packing),
            NativeLoop::new(t0),
            0,
        ),
    };
    let writes = Writes {
        out,
        progress,
        checkpointing,
        case_json: &case_json,
    };
    let result = step_native(case, packing, sim, first_stage, None, |stepper| {
        drive(case, packing, Some(&writes), stepper, first_stage, &mut run)
    });
    let last = match result {
        Ok(last) => last,
        Err(e) => {
            let _ = shear_series(case, &run.rows).write_csv(&out.join("native_partial.csv"));
            return Err(e);
        }
    };
    progress.finish();
    // the paper's rotation map of the final state (rotations accumulated over the whole run)
    crate::rotation_map::rotation_map(
        &out.join("rotation_map.svg"),
        &format!(
            "native, mu_r {}, eta_r {}, seed {}: accumulated rotation at step {}",
            case.material.rolling_friction, case.material.rolling_damping, case.seed, last.step
        ),
        &last.snapshot(),
        case.box_x,
    )?;
    let code_run = CodeRun {
        wall_time: run.wall_before + t0.elapsed().as_secs_f64(),
        rows: run.rows,
        steps: last.step,
        compacted: run.compacted,
        profiles: profiles(case, &run.profile)?,
        resumed_from: Vec::new(),
    };
    match std::fs::remove_file(out.join(CHECKPOINT_NAME)) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(Error::io(out.join(CHECKPOINT_NAME), e))
        }
        _ => {}
    }
    Ok(code_run)
}

/// Runs `f` (a native run's time loop) on this process's stepper of a run of `case` from
/// `sim` at `first_stage`: `sim` itself in one process; under `mpirun` (the `mpi` feature)
/// brick 0 of the run decomposed over the ranks, which are handed the run here
/// ([`crate::ranks`], [`serve`]).
fn step_native<R>(
    case: &ShearCase,
    packing: &Packing,
    sim: ShearSim,
    first_stage: usize,
    timing: Option<crate::ranks::Timing>,
    f: impl FnOnce(&mut dyn Stepper) -> Result<R>,
) -> Result<R> {
    #[cfg(feature = "mpi")]
    if let Some(world) = crate::ranks::world() {
        use crate::ranks::{Job, Work};
        use crate::solver::shear::decompose::{split_as, split_for, Brick, BrickRun, Transport};
        // the split (`--bricks`, else the least boundary), checked before any rank starts
        let bricks = match crate::ranks::chosen_bricks() {
            Some(n) => split_as(n, &sim)?,
            None => split_for(world.size(), &sim),
        };
        let job = Job {
            case: case.clone(),
            packing: packing.clone(),
            sim,
            first_stage,
            threads: rayon::current_num_threads(),
            bricks: [bricks.nx, bricks.ny, bricks.nz],
        };
        let work = match timing {
            Some(t) => Work::Bench(job, t),
            None => Work::Run(job),
        };
        let _turn = crate::ranks::hand_out(&world, &work);
        let (Work::Run(job) | Work::Bench(job, _)) = work else {
            unreachable!("a run or a bench was handed out")
        };
        crate::run::tell::note(&format!(
            "native run decomposed over {} MPI ranks: {} x {} x {} bricks along x, across \
             the gap (y) and along z, {} thread(s) each",
            world.size(),
            bricks.nx,
            bricks.ny,
            bricks.nz,
            job.threads
        ));
        let mut stepper = BrickRun {
            brick: Brick::of(&job.sim, &bricks, 0),
            transport: &world,
        };
        drop(job);
        return f(&mut stepper);
    }
    let _ = (case, packing, first_stage, timing);
    let mut sim = sim;
    f(&mut sim)
}

/// A rank other than 0 under `mpirun`: steps its brick of every native run rank 0 hands out
/// ([`step_native`]), through the same time loop (or a bench's timed steps), writing
/// nothing, until told to end.
#[cfg(feature = "mpi")]
pub fn serve(world: &crate::solver::shear::mpi::Mpi) {
    use crate::ranks::Work;
    use crate::solver::shear::decompose::{bricks_of, probe_link, Brick, BrickRun, Transport};
    while let Some(work) = crate::ranks::next_work(world) {
        let (job, timing) = match work {
            Work::Run(job) => (job, None),
            Work::Bench(job, t) => (job, Some(t)),
            Work::Link => {
                probe_link(world);
                continue;
            }
        };
        let bricks = bricks_of(job.bricks, &job.sim);
        let pool = match rayon::ThreadPoolBuilder::new()
            .num_threads(job.threads.max(1))
            .build()
        {
            Ok(pool) => pool,
            Err(e) => {
                // this rank cannot take part: end it, and mpirun ends the others (a serving
                // rank has no sink: its last word goes to stderr itself)
                eprintln!("error: rank {}: no thread pool: {e}", world.rank());
                std::process::exit(2);
            }
        };
        pool.install(|| {
            let world = crate::solver::shear::mpi::Mpi::world();
            let mut stepper = BrickRun {
                brick: Brick::of(&job.sim, &bricks, world.rank()),
                transport: &world,
            };
            // rank 0 reports the outcome; an error is every rank's (agreed on)
            match timing {
                Some(t) => {
                    let _ = timed_steps(&mut stepper, t);
                }
                None => {
                    let mut run = NativeLoop::new(Instant::now());
                    let _ = drive(
                        &job.case,
                        &job.packing,
                        None,
                        &mut stepper,
                        job.first_stage,
                        &mut run,
                    );
                }
            }
        });
    }
}

/// What a bench's timed steps measured on one process or on rank 0's brick: wall and CPU
/// time, phases, neighbour builds and (decomposed) what the exchanges carried.
#[derive(Clone, Debug)]
pub struct Timed {
    pub seconds: f64,
    pub cpu_seconds: Option<f64>,
    pub phases: Option<PhaseTimes>,
    /// Every rank's phases (decomposed; one process: its own).
    pub rank_phases: Vec<Option<PhaseTimes>>,
    /// Every rank's own particles at the end (decomposed; one process: all).
    pub rank_particles: Vec<u64>,
    pub rebuilds: u64,
    pub traffic: Option<Traffic>,
}

/// CPU time used by this process so far [s] (Linux /proc/self/stat utime + stime, in
/// USER_HZ = 100 ticks per second): robust to other load on the machine, unlike wall time.
pub fn process_cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &s[s.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

/// A bench's steps ([`crate::ranks::Timing`]) of a stepper: every brick of a decomposed
/// run makes the same calls.
pub fn timed_steps(s: &mut dyn Stepper, t: crate::ranks::Timing) -> Result<Timed> {
    s.local().set_kernel(t.kernel)?;
    s.setup(0.0)?;
    s.step()?;
    s.setup(t.speed)?;
    for _ in 0..t.warm {
        s.step()?;
    }
    s.setup(t.speed)?;
    s.local().time_phases(true);
    let builds0 = s.local().neighbor_builds();
    let traffic0 = s.traffic();
    let (t0, c0) = (Instant::now(), process_cpu_seconds());
    for _ in 0..t.timed {
        s.step()?;
    }
    s.settle()?;
    let seconds = t0.elapsed().as_secs_f64();
    let cpu_seconds = c0.zip(process_cpu_seconds()).map(|(a, b)| b - a);
    let rank_phases = s.phases_by_rank();
    let rank_particles = s.own_by_rank();
    let local = s.local();
    local.check_finite()?;
    Ok(Timed {
        seconds,
        cpu_seconds,
        rank_phases,
        rank_particles,
        phases: local.phase_times(),
        rebuilds: local.neighbor_builds() - builds0,
        traffic: s.traffic().zip(traffic0).map(|(b, a)| b.since(&a)),
    })
}

/// A bench's native run of `case` from `packing`: this process's, or under `mpirun` (the
/// `mpi` feature) decomposed over the ranks, timed on rank 0's brick; `after` reads the
/// stepper at the end (one process's state, or rank 0's brick) with what was measured.
pub fn bench_native<R>(
    case: &ShearCase,
    packing: &Packing,
    timing: crate::ranks::Timing,
    after: impl FnOnce(&Timed, &mut dyn Stepper) -> R,
) -> Result<(Timed, R)> {
    let sim = ShearSim::new(&case.setup(), packing);
    step_native(case, packing, sim, 0, Some(timing), |s| {
        let timed = timed_steps(s, timing)?;
        let got = after(&timed, s);
        Ok((timed, got))
    })
}

/// The link between the ranks under `mpirun` (the `mpi` feature), measured by every rank
/// ([`crate::solver::shear::decompose::probe_link`]); None in one process.
pub fn probe_ranks_link() -> Option<crate::solver::shear::decompose::Link> {
    #[cfg(feature = "mpi")]
    if let Some(world) = crate::ranks::world() {
        let _turn = crate::ranks::hand_out(&world, &crate::ranks::Work::Link);
        return Some(crate::solver::shear::decompose::probe_link(&world));
    }
    None
}

/// What a native run collects as it goes (and its checkpoint holds).
pub struct NativeLoop {
    pub rows: Vec<Row>,
    pub compacted: Option<Packing>,
    pub profile: Vec<ProfileSample>,
    /// Wall time of the run before this process resumed it [s], and when this one started.
    pub wall_before: f64,
    pub t0: Instant,
}

impl NativeLoop {
    pub fn new(t0: Instant) -> Self {
        NativeLoop {
            rows: Vec::new(),
            compacted: None,
            profile: Vec::new(),
            wall_before: 0.0,
            t0,
        }
    }
}

/// Where a run's outputs go: the writing rank's (none on the other ranks of a decomposed
/// run).
pub struct Writes<'a> {
    pub out: &'a Path,
    pub progress: &'a Progress,
    pub checkpointing: Checkpointing,
    pub case_json: &'a str,
}

/// The time loop of a native run from `first_stage`, one process's or one brick's
/// ([`Stepper`]): every stage's setup and steps, the rows, profile samples and compacted
/// state collected in `run`, and with `writes` the snapshots, progress and checkpoints.
/// Every brick of a decomposed run makes the same calls at the same steps (the whole state
/// is gathered on rank 0 at output, sample and snapshot steps, where the checks and writes
/// are made); a check or a write that fails there stops every brick. Returns the final
/// whole state (an error on the ranks other than 0, which hold none).
pub fn drive<S: Stepper + ?Sized>(
    case: &ShearCase,
    packing: &Packing,
    writes: Option<&Writes>,
    stepper: &mut S,
    first_stage: usize,
    run: &mut NativeLoop,
) -> Result<ShearSim> {
    let ends = case.run_ends();
    let windows = schedule(case);
    let rec = |sim: &ShearSim| Row::from(&sim.record());
    let mut last_checkpoint = Instant::now();
    if first_stage == 0 && stepper.steps() == 0 {
        stepper.setup(0.0)?;
        let done = match stepper.whole() {
            None => Ok(()),
            Some(w) => {
                run.rows.push(rec(&w));
                // the initial state, as LIGGGHTS' dump writes it at its first run's setup
                match writes {
                    Some(o) if case.snapshot_every > 0 => {
                        vtk::write_snapshot(&o.out.join("vtk"), &w.snapshot(), case.dt)
                    }
                    _ => Ok(()),
                }
            }
        };
        all_done(stepper, done)?;
    }
    for (k, &end) in ends.iter().enumerate().skip(first_stage) {
        // a stage starts with its setup; a run resumed inside the stage is past it
        if k > 0 && stepper.steps() == ends[k - 1] {
            stepper.setup(case.stages[k - 1].speed)?;
        }
        while stepper.steps() < end {
            stepper.step()?;
            let step = stepper.steps();
            let output = is_output(case, step, &ends);
            let sample = is_sample(&windows, step);
            let snapshot = case.snapshot_every > 0 && step.is_multiple_of(case.snapshot_every);
            if !(output || sample || snapshot) {
                continue;
            }
            stepper.settle()?;
            let Some(w) = stepper.whole() else {
                all_done(stepper, Ok(()))?;
                continue;
            };
            let done = (|| -> Result<()> {
                if output {
                    w.check_finite()?;
                    let lost = w.lost_particles(packing.box_y_lo, packing.box_y_hi);
                    if lost > 0 {
                        return Err(Error::Solver {
                            step,
                            msg: format!("{lost} particles left the box through a plate"),
                        });
                    }
                    run.rows.push(rec(&w));
                }
                if sample {
                    run.profile.push(ProfileSample {
                        step,
                        top_y: w.record().top_y,
                        y: w.x.iter().map(|x| x[1]).collect(),
                        vx: w.v.iter().map(|v| v[0]).collect(),
                    });
                }
                let Some(o) = writes else {
                    return Ok(());
                };
                if output {
                    o.progress.set(step);
                }
                if snapshot {
                    vtk::write_snapshot(&o.out.join("vtk"), &w.snapshot(), case.dt)?;
                }
                let checkpoint = match o.checkpointing {
                    Checkpointing::Every(every) => {
                        output && last_checkpoint.elapsed() >= every && step < end
                    }
                    Checkpointing::Off => false,
                };
                if checkpoint {
                    // the stage index is k here; a checkpoint at a stage's last step would
                    // need the next stage's setup, so none is taken there
                    write_checkpoint(o, k, run, &w)?;
                    last_checkpoint = Instant::now();
                }
                Ok(())
            })();
            drop(w);
            all_done(stepper, done)?;
        }
        stepper.settle()?;
        if k == 0 {
            run.compacted = stepper.whole().map(|w| w.state(packing));
        }
    }
    stepper.settle()?;
    let last = stepper.whole().map(|w| w.into_owned());
    last.ok_or_else(|| Error::Solver {
        step: stepper.steps(),
        msg: "this rank holds no whole state (rank 0 does)".into(),
    })
}

/// `done` (an output step's checks and writes, made where the whole state is), agreed on by
/// every brick: an error here, or on another brick.
fn all_done<S: Stepper + ?Sized>(stepper: &mut S, done: Result<()>) -> Result<()> {
    let ok = stepper.all_ok(done.is_ok());
    done?;
    if ok {
        Ok(())
    } else {
        Err(Error::Solver {
            step: stepper.steps(),
            msg: "the run stopped on another rank".into(),
        })
    }
}

/// Writes the checkpoint of a run at stage `stage` with the whole state `sim`.
fn write_checkpoint(o: &Writes, stage: usize, run: &NativeLoop, sim: &ShearSim) -> Result<()> {
    let cp = NativeCheckpoint {
        stage,
        wall_time: run.wall_before + run.t0.elapsed().as_secs_f64(),
        sim: sim.clone(),
        rows: run.rows.clone(),
        compacted: run.compacted.clone(),
        profile: run.profile.clone(),
    };
    let bytes = rmp_serde::to_vec(&cp).map_err(|e| Error::Solver {
        step: sim.step,
        msg: format!("cannot encode the checkpoint: {e}"),
    })?;
    write_atomic(
        &o.out.join(CHECKPOINT_NAME),
        &crate::fsutil::seal(
            CHECKPOINT_KIND,
            CHECKPOINT_VERSION,
            o.case_json.as_bytes(),
            &bytes,
        ),
    )
}

/// LIGGGHTS' particle-steps per second on one core, about (`verify bench`, 2026-12-02:
/// 2.48e6): turns a checkpoint interval in wall time into a restart interval in steps.
const LIGGGHTS_RATE: f64 = 2.5e6;

/// Steps between LIGGGHTS restart files for a checkpoint interval: about that much wall time,
/// a multiple of the output interval; None when off or when the run is shorter.
pub fn restart_interval(case: &ShearCase, checkpoint: Checkpointing) -> Option<u64> {
    let Checkpointing::Every(d) = checkpoint else {
        return None;
    };
    let out = case.output_every.max(1);
    let steps = d.as_secs_f64() * LIGGGHTS_RATE / case.particles.max(1) as f64;
    let n = ((steps / out as f64).ceil().max(1.0) as u64).saturating_mul(out);
    (n < case.total_steps()).then_some(n)
}

/// What a LIGGGHTS run directory holds of its interruptions (`resume.json`): the deck it
/// belongs to, the logs of the earlier parts with the step each started from, and the step
/// the running part (`log.liggghts`) started from.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
struct ResumeState {
    deck_sha256: String,
    earlier: Vec<(String, u64)>,
    current_from: u64,
}

const RESUME_NAME: &str = "resume.json";

/// The run directory's [`ResumeState`]: none yet when the file is absent (a fresh run); a file
/// that cannot be read or parsed is an error naming it, never a fresh start (which would
/// delete the restart files and the earlier parts' logs a carried or interrupted run continues
/// from).
fn read_resume_state(path: &Path) -> Result<ResumeState> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(ResumeState::default()),
        Err(e) => return Err(Error::io(path, e)),
    };
    serde_json::from_str(&text).map_err(|e| {
        parse_err(
            path,
            format!(
                "not a LIGGGHTS resume record ({e}); move it away to start this run afresh \
                 (its restart files and logs are then removed)"
            ),
        )
    })
}

/// Restart files `restart.<step>` in `dir`, by step.
fn restart_files(dir: &Path) -> Vec<u64> {
    let mut steps: Vec<u64> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| {
            let name = e.ok()?.file_name().into_string().ok()?;
            name.strip_prefix(RESTART_PREFIX)?.parse().ok()
        })
        .collect();
    steps.sort_unstable();
    steps
}

/// Removes all but the newest `keep` restart files.
fn prune_restarts(dir: &Path, keep: usize) {
    let steps = restart_files(dir);
    for s in &steps[..steps.len().saturating_sub(keep)] {
        let _ = std::fs::remove_file(dir.join(format!("{RESTART_PREFIX}{s}")));
    }
}

/// Where an interrupted LIGGGHTS run of this deck can continue: the newest restart file whose
/// step has a thermo line in the running part's log and lies past the part's start (the deck
/// writes a restart file before the thermo line of its step, so such a file is complete), or
/// else the restart file the running part itself started from (a part killed before it wrote
/// a newer one, even before its first thermo line, continues from where it started: before
/// 2026-12-07 such a run started again from step 0 and its restart files were removed).
fn resume_point(dir: &Path, state: &ResumeState, deck_sha: &str, ncol: usize) -> Option<u64> {
    if state.deck_sha256 != deck_sha {
        return None;
    }
    let last = last_thermo_step(&dir.join(LOG_NAME), ncol);
    restart_files(dir).into_iter().rfind(|s| {
        (*s > state.current_from && last.is_some_and(|l| *s <= l))
            || (*s == state.current_from && *s > 0)
    })
}

/// The thermo rows of a run made of parts: the row of step `t` comes from the last part that
/// started before `t` (the first part holds step 0; a part's own first row, at its restart
/// step, has no forces yet and the part before it has that step).
fn stitched_thermo(dir: &Path, state: &ResumeState, ncol: usize) -> Result<Vec<(u64, Vec<f64>)>> {
    let mut rows = std::collections::BTreeMap::new();
    let parts = state
        .earlier
        .iter()
        .map(|(log, from)| (log.as_str(), *from))
        .chain([(LOG_NAME, state.current_from)]);
    for (k, (log, from)) in parts.enumerate() {
        for (t, v) in read_thermo(&dir.join(log), ncol)? {
            if t > from || k == 0 {
                rows.insert(t, v);
            }
        }
    }
    Ok(rows.into_iter().collect())
}

/// Runs LIGGGHTS on the generated deck in `out/liggghts/` (kept: deck, data, meshes, log),
/// converts its snapshots to VTK, and checks that no particle was lost.
///
/// With checkpointing on and a run long enough, the deck writes restart files about every
/// `checkpoint` of wall time (the newest two kept, all removed at the end); a run of the same
/// deck that was interrupted continues from the newest complete one. That continuation is not
/// bit-identical to an uninterrupted run (see [`crate::deck::shear`]'s resume notes): the
/// series is identical up to the restart step and statistically equivalent after it, and the
/// run records the step in [`CodeRun::resumed_from`].
pub fn run_liggghts(
    case: &ShearCase,
    packing: &Packing,
    lig: &Liggghts,
    out: &Path,
    progress: &Progress,
    checkpoint: Checkpointing,
) -> Result<CodeRun> {
    let dir = out.join("liggghts");
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let extras = DeckExtras {
        restart_every: restart_interval(case, checkpoint),
        ..DeckExtras::default()
    };
    let full = shear_deck_with(case, packing, &extras);
    let deck_sha = sha256_hex(
        full.files
            .iter()
            .flat_map(|(n, t)| [n.as_bytes(), t.as_bytes()])
            .collect::<Vec<_>>()
            .concat()
            .as_slice(),
    );
    let ncol = THERMO_COLUMNS.len();
    let state_path = dir.join(RESUME_NAME);
    let mut state = read_resume_state(&state_path)?;
    let deck = match resume_point(&dir, &state, &deck_sha, ncol) {
        Some(step) => {
            // keep the interrupted part's log; the new part writes log.liggghts (a part
            // killed before LIGGGHTS opened its log left none: it continues from its own
            // start, `step` is `current_from`, and there is no part to keep)
            if dir.join(LOG_NAME).exists() {
                let part = format!("log.{}.liggghts", state.earlier.len());
                std::fs::rename(dir.join(LOG_NAME), dir.join(&part))
                    .map_err(|e| Error::io(dir.join(LOG_NAME), e))?;
                state.earlier.push((part, state.current_from));
            }
            state.current_from = step;
            crate::run::tell::note(&format!(
                "LIGGGHTS seed {}: continuing from its restart file at step {step} (from there \
                 on not bit-identical to an uninterrupted run)",
                case.seed
            ));
            shear_deck_with(
                case,
                packing,
                &DeckExtras {
                    resume_from: Some(step),
                    ..extras.clone()
                },
            )
        }
        None => {
            let old = restart_files(&dir);
            if !old.is_empty() {
                crate::run::tell::note(&format!(
                    "LIGGGHTS seed {}: restart files in {} at steps {old:?} are not this run's \
                     to continue from (another deck, or none complete): removed, starting from \
                     step 0",
                    case.seed,
                    dir.display()
                ));
            }
            for s in old {
                let _ = std::fs::remove_file(dir.join(format!("{RESTART_PREFIX}{s}")));
            }
            for (log, _) in &state.earlier {
                let _ = std::fs::remove_file(dir.join(log));
            }
            state = ResumeState {
                deck_sha256: deck_sha,
                ..ResumeState::default()
            };
            full
        }
    };
    let state_json = serde_json::to_string_pretty(&state).expect("plain data");
    write_atomic(&state_path, state_json.as_bytes())?;
    let t0 = Instant::now();
    lig.run_with_progress(&deck, &dir, |d| {
        if let Some(s) = last_thermo_step(&d.join(LOG_NAME), ncol) {
            progress.set(s);
        }
        prune_restarts(d, 2);
    })?;
    let wall = t0.elapsed().as_secs_f64();
    progress.finish();
    prune_restarts(&dir, 0);
    let thermo = stitched_thermo(&dir, &state, ncol)?;
    let mut rows = Vec::with_capacity(thermo.len());
    for (step, v) in thermo {
        let atoms = v[9] as usize;
        if atoms != packing.radius.len() {
            return Err(Error::LiggghtsFailed {
                reason: format!(
                    "LIGGGHTS lost particles: {atoms} of {} left at step {step}",
                    packing.radius.len()
                ),
                log: dir.join(LOG_NAME),
                tail: String::new(),
            });
        }
        // the mobilised fraction is not in LIGGGHTS' thermo output
        let mut row = [f64::NAN; 10];
        row[..9].copy_from_slice(&v[..9]);
        rows.push(Row::from_values(step, row));
    }
    if rows.last().map(|r| r.step) != Some(case.total_steps()) {
        return Err(Error::LiggghtsFailed {
            reason: format!(
                "the log ends {}, expected at step {}",
                rows.last()
                    .map_or("before its first thermo line".to_string(), |r| format!(
                        "at step {}",
                        r.step
                    )),
                case.total_steps()
            ),
            log: dir.join(LOG_NAME),
            tail: String::new(),
        });
    }
    if case.snapshot_every > 0 {
        // the plates where LIGGGHTS had them: the top at its thermo row's height, the bottom
        // moved along x by the stages' displacement
        let plates = |step: u64| {
            let top_y = rows.iter().find(|r| r.step == step)?.top_y;
            let d = displacement(case, step);
            let bottom = Plate::new(Side::Bottom, 0.0, case.plates.shape(case.box_x), case.box_x);
            let top = Plate::new(Side::Top, top_y, case.plates.shape(case.box_x), case.box_x);
            let mut b = plate_triangles(&bottom, case.box_z);
            for t in &mut b {
                for n in t.iter_mut() {
                    n[0] += d;
                }
            }
            Some([b, plate_triangles(&top, case.box_z)])
        };
        vtk::convert_liggghts_snapshots(&dir, SNAPSHOT_PREFIX, &out.join("vtk"), case.dt, plates)?;
    }
    let samples = read_profile_dumps(case, &dir, &rows, packing.radius.len())?;
    let mut resumed_from: Vec<u64> = state.earlier.iter().skip(1).map(|p| p.1).collect();
    if !state.earlier.is_empty() {
        resumed_from.push(state.current_from);
    }
    Ok(CodeRun {
        rows,
        wall_time: wall,
        steps: case.total_steps(),
        compacted: None,
        profiles: profiles(case, &samples)?,
        resumed_from,
    })
}

/// LIGGGHTS' velocity-profile dumps (`id y vx` at every step of the schedule), with the top
/// plate's position from the thermo row of the same step.
fn read_profile_dumps(
    case: &ShearCase,
    dir: &Path,
    rows: &[Row],
    atoms: usize,
) -> Result<Vec<ProfileSample>> {
    let mut out = Vec::new();
    for w in schedule(case) {
        for step in w.steps() {
            let path = dir.join(format!("{PROFILE_PREFIX}{step}.dump"));
            let d = dump_atoms(&path, step, 3, atoms)?;
            let top_y = rows
                .iter()
                .find(|r| r.step == step)
                .map(|r| r.top_y)
                .ok_or_else(|| parse_err(&path, format!("no thermo row at step {step}")))?;
            out.push(ProfileSample {
                step,
                top_y,
                y: d.iter().map(|r| r[1]).collect(),
                vx: d.iter().map(|r| r[2]).collect(),
            });
        }
    }
    Ok(out)
}

/// The common series of a shear run. Sign convention: forces are those the particles exert on
/// the plates; the top plate is pushed up (`top_f_y > 0`) and dragged along the shear
/// direction, so `mu = top_f_x / top_f_y` is positive (0 when the plate is not loaded).
/// `strain` = bottom plate displacement / current height; `height` = distance between the
/// plates' mean surfaces.
pub fn shear_series(case: &ShearCase, rows: &[Row]) -> Series {
    let (forces, energies) = ROW_COLUMNS.split_at(7);
    let columns: Vec<&str> = ["time[s]", "strain[-]"]
        .into_iter()
        .chain(forces.iter().copied())
        .chain(["height[m]", "mu[-]"])
        .chain(energies.iter().copied())
        .collect();
    let t = case.plates.tooth_height();
    let mut s = Series {
        columns: columns.iter().map(|c| c.to_string()).collect(),
        steps: Vec::with_capacity(rows.len()),
        rows: Vec::with_capacity(rows.len()),
    };
    for r in rows {
        let (top, bottom) = (r.top_force, r.bottom_force);
        let h = r.top_y - t;
        let mu = if top[1] != 0.0 { top[0] / top[1] } else { 0.0 };
        s.steps.push(r.step);
        s.rows.push(vec![
            r.step as f64 * case.dt,
            displacement(case, r.step) / h,
            top[0],
            top[1],
            top[2],
            bottom[0],
            bottom[1],
            bottom[2],
            r.top_y,
            h,
            mu,
            r.ke,
            r.erot,
            r.mobilised,
        ]);
    }
    s
}

/// Writes a run's series atomically.
pub fn write_series(case: &ShearCase, run: &CodeRun, path: &Path) -> Result<Series> {
    let s = shear_series(case, &run.rows);
    s.write_csv(path)?;
    Ok(s)
}

/// Saves the packing both codes start from (for the record).
pub fn write_packing(packing: &Packing, path: &Path) -> Result<()> {
    let mut s = String::from("id,radius[m],x[m],y[m],z[m]\n");
    for (k, (r, p)) in packing.radius.iter().zip(&packing.position).enumerate() {
        s.push_str(&format!(
            "{},{r:e},{:e},{:e},{:e}\n",
            k + 1,
            p[0],
            p[1],
            p[2]
        ));
    }
    write_atomic(path, s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::RollingModel;

    /// Where a LIGGGHTS run continues: the newest restart file the running part's log shows
    /// complete; a newer one being written is passed over; a part killed before it wrote its
    /// own continues from the file it started from, even with no thermo line yet; a first part
    /// with no thermo line, or another deck, starts afresh.
    #[test]
    fn a_liggghts_run_continues_from_its_newest_complete_restart_file() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let ncol = THERMO_COLUMNS.len();
        let log = |steps: &[u64]| {
            let mut t = String::from("Setting up run\nStep a b\n");
            for s in steps {
                t += &format!("{s}{}\n", " 1.5".repeat(ncol));
            }
            std::fs::write(d.join(LOG_NAME), t).unwrap();
        };
        let restart =
            |s: u64| std::fs::write(d.join(format!("{RESTART_PREFIX}{s}")), b"r").unwrap();
        let state = |from: u64| ResumeState {
            deck_sha256: "deck".into(),
            earlier: Vec::new(),
            current_from: from,
        };
        // the first part: no thermo line yet, nothing to continue from
        restart(300_000);
        log(&[]);
        assert_eq!(resume_point(d, &state(0), "deck", ncol), None);
        log(&[0, 1000, 299_000, 300_000, 301_000]);
        assert_eq!(resume_point(d, &state(0), "deck", ncol), Some(300_000));
        assert_eq!(resume_point(d, &state(0), "other deck", ncol), None);
        // restart.600000 being written: its thermo line not yet in the log
        restart(600_000);
        log(&[0, 300_000, 599_000]);
        assert_eq!(resume_point(d, &state(0), "deck", ncol), Some(300_000));
        log(&[0, 300_000, 600_000]);
        assert_eq!(resume_point(d, &state(0), "deck", ncol), Some(600_000));
        // a part started from 600,000, killed before it wrote restart.900000: from 600,000
        // again, with its first thermo line or without
        log(&[600_000, 601_000]);
        assert_eq!(
            resume_point(d, &state(600_000), "deck", ncol),
            Some(600_000)
        );
        log(&[]);
        assert_eq!(
            resume_point(d, &state(600_000), "deck", ncol),
            Some(600_000)
        );
        std::fs::remove_file(d.join(LOG_NAME)).unwrap();
        assert_eq!(
            resume_point(d, &state(600_000), "deck", ncol),
            Some(600_000)
        );
    }

    /// A LIGGGHTS run's resume record: absent is a fresh run; present and valid is read back;
    /// present and damaged (cut short by a full disk, or edited) is an error naming the file
    /// (`run_liggghts` stops there; a fresh start would remove the restart files).
    #[test]
    fn a_damaged_resume_record_is_an_error_not_a_fresh_start() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(RESUME_NAME);
        let fresh = read_resume_state(&p).unwrap();
        assert!(fresh.deck_sha256.is_empty() && fresh.earlier.is_empty());
        let state = ResumeState {
            deck_sha256: "ab".repeat(32),
            earlier: vec![("log.0.liggghts".into(), 0)],
            current_from: 300_000,
        };
        std::fs::write(&p, serde_json::to_string(&state).unwrap()).unwrap();
        let back = read_resume_state(&p).unwrap();
        assert_eq!(
            (back.deck_sha256, back.earlier, back.current_from),
            (state.deck_sha256, state.earlier, state.current_from)
        );
        let text = serde_json::to_string(&ResumeState::default()).unwrap();
        std::fs::write(&p, &text[..text.len() / 2]).unwrap();
        let e = read_resume_state(&p).unwrap_err().to_string();
        assert!(
            e.contains(RESUME_NAME) && e.contains("not a LIGGGHTS resume record"),
            "{e}"
        );
    }

    #[test]
    fn displacement_follows_the_stage_schedule() {
        let mut c = ShearCase::preset(
            crate::spec::shear::Preset::Ci,
            RollingModel::Epsd,
            0.5,
            0.0,
            1,
        )
        .unwrap();
        c.stages = vec![
            crate::spec::shear::Stage {
                speed: 0.01,
                strain: 0.1,
            },
            crate::spec::shear::Stage {
                speed: 0.02,
                strain: 0.1,
            },
        ];
        let n = c.stage_steps();
        let ends = c.run_ends();
        assert_eq!(displacement(&c, c.compression_steps), 0.0);
        let d1 = displacement(&c, ends[1]);
        assert!((d1 - 0.01 * c.dt * n[0] as f64).abs() < 1e-15);
        let d2 = displacement(&c, ends[2]);
        assert!((d2 - d1 - 0.02 * c.dt * n[1] as f64).abs() < 1e-15);
        assert_eq!(stage_of(&c, 5), None);
        assert_eq!(stage_of(&c, ends[1]), Some(0));
        assert_eq!(stage_of(&c, ends[1] + 1), Some(1));
    }
}
