//! One native run over the ranks of `mpirun` (issue #39, docs/mpi.md): rank 0 runs the
//! command as one process would (LIGGGHTS, reports, every file); each of its native runs is
//! decomposed into one brick per rank ([`crate::solver::shear::decompose`]), the other
//! ranks serving: they receive the run's case and initial state, step their bricks in
//! lockstep through the same time loop (`shear::serve`, `shear::drive`) and write nothing.
//! The outputs are one process's, bit for bit, for any rank count.
//!
//! Built with the `mpi` cargo feature only; without it, or when not launched by `mpirun` /
//! `srun`, every run is one process's.

/// How this process takes part ([`start`]).
pub enum Start {
    /// One process (no `mpirun`, or one rank): run the command.
    Alone,
    /// Rank 0 of several: run the command; dropping this tells the other ranks to end.
    Lead(Lead),
    /// Another rank: serve rank 0's native runs (`shear::serve`), then exit.
    #[cfg(feature = "mpi")]
    Serve(crate::solver::shear::mpi::Mpi),
    /// Launched as one of several ranks by a build without the `mpi` feature: every rank
    /// would run the whole command (the same outputs, written N times over). Refused.
    Refused(String),
}

/// The rank count a launcher gave this process (OpenMPI's `mpirun`, PMI's, or the tasks
/// of the `srun` step it runs in), if any. (Not `SLURM_NTASKS`: a batch script has it
/// whether or not its commands are launched as tasks.)
fn launched_ranks() -> Option<usize> {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_STEP_NUM_TASKS"]
        .iter()
        .find_map(|v| std::env::var(v).ok()?.parse().ok())
}

/// Starts MPI when launched by `mpirun` or `srun` (with the `mpi` feature): rank 0 is to
/// run the command, the other ranks to serve its native runs.
pub fn start() -> Start {
    #[cfg(feature = "mpi")]
    {
        mpi_ranks::start()
    }
    #[cfg(not(feature = "mpi"))]
    match launched_ranks() {
        Some(n) if n > 1 => Start::Refused(format!(
            "launched as one of {n} MPI ranks, but this verify was built without MPI: every \
             rank would run the whole command. Build it with `cargo install --path . \
             --features mpi` (needs libopenmpi-dev, libclang-dev, clang), or run one process"
        )),
        _ => Start::Alone,
    }
}

#[cfg(feature = "mpi")]
pub use mpi_ranks::{finish, hand_out, next_work, world, Job, Work};

/// The split of every native run of this process into bricks that the command line chose
/// (`--bricks`), if it did.
static BRICKS: std::sync::Mutex<Option<[usize; 3]>> = std::sync::Mutex::new(None);

/// Chooses how every native run of this process is split into bricks (`--bricks NXxNYxNZ`:
/// along x, across the gap, along z; as LAMMPS' `processors`): refused unless their product
/// is the rank count. Whether each slab is wider than the ghost cut is checked against each
/// run's box (`decompose::split_as`).
pub fn choose_bricks(n: [usize; 3]) -> crate::error::Result<()> {
    let ranks = native_ranks();
    if n.iter().product::<usize>() != ranks {
        let alone = if ranks == 1 {
            " (one process: start it under `mpirun -np N`, built with the `mpi` feature)"
        } else {
            ""
        };
        return Err(crate::error::Error::invalid(
            "--bricks",
            format!("{}x{}x{}", n[0], n[1], n[2]),
            format!("NXxNYxNZ whose product is the rank count, {ranks}{alone}"),
        ));
    }
    *BRICKS.lock().unwrap_or_else(|e| e.into_inner()) = Some(n);
    Ok(())
}

/// The split [`choose_bricks`] chose, if any.
pub fn chosen_bricks() -> Option<[usize; 3]> {
    *BRICKS.lock().unwrap_or_else(|e| e.into_inner())
}

/// The ranks a native run of this process is decomposed over: the world's size under
/// `mpirun` (the `mpi` feature), else 1.
pub fn native_ranks() -> usize {
    #[cfg(feature = "mpi")]
    if let Some(w) = world() {
        use crate::solver::shear::decompose::Transport;
        return w.size();
    }
    1
}

/// A bench's run of a stepper (`shear::timed_steps`): one servo step at rest, `warm` steps
/// at `speed`, then `timed` steps at `speed`, timed.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Timing {
    pub warm: u64,
    pub timed: u64,
    pub speed: f64,
    /// The pair pass's kernel path (every rank's).
    pub kernel: crate::solver::shear::KernelPath,
}

/// Rank 0's hold on the other ranks: when dropped (the command ended), they are told to end.
pub struct Lead(());

#[cfg(feature = "mpi")]
mod mpi_ranks {
    use super::Start;
    use crate::packing::Packing;
    use crate::solver::shear::decompose::Transport;
    use crate::solver::shear::mpi::Mpi;
    use crate::solver::shear::ShearSim;
    use crate::spec::shear::ShearCase;
    use std::sync::{Mutex, MutexGuard, OnceLock};

    /// A native run handed to every rank: what it needs to step its brick.
    #[derive(Clone, serde::Serialize, serde::Deserialize)]
    pub struct Job {
        pub case: ShearCase,
        pub packing: Packing,
        pub sim: ShearSim,
        pub first_stage: usize,
        /// Threads per rank (rank 0's pool).
        pub threads: usize,
        /// The split into bricks along x, across the gap and along z (rank 0's choice).
        pub bricks: [usize; 3],
    }

    /// What rank 0 hands every rank.
    #[derive(Clone, serde::Serialize, serde::Deserialize)]
    pub enum Work {
        /// A native run of a command: its time loop (`shear::drive`).
        Run(Job),
        /// A bench's timed steps of a run (`shear::timed_steps`).
        Bench(Job, super::Timing),
        /// The link's latency and bandwidth (`decompose::probe_link`).
        Link,
    }

    /// The universe (MPI finalised when it drops), kept for the life of the process.
    static UNIVERSE: OnceLock<Mutex<Option<mpi::environment::Universe>>> = OnceLock::new();
    /// One decomposed run at a time (a sweep's parallel jobs on rank 0 take turns).
    static ONE_RUN: Mutex<()> = Mutex::new(());

    pub fn start() -> Start {
        if super::launched_ranks().is_none() {
            return Start::Alone;
        }
        // rank 0 may call MPI from any thread its native runs are on (one run at a time)
        let Some((universe, _)) = mpi::initialize_with_threading(mpi::Threading::Serialized) else {
            return Start::Alone;
        };
        let world = Mpi::new(universe.world());
        let (rank, size) = (world.rank(), world.size());
        let _ = UNIVERSE.set(Mutex::new(Some(universe)));
        match (size, rank) {
            (1, _) => Start::Alone,
            (_, 0) => Start::Lead(super::Lead(())),
            _ => Start::Serve(world),
        }
    }

    /// The world when this is rank 0 of several.
    pub fn world() -> Option<Mpi> {
        let u = UNIVERSE.get()?.lock().ok()?;
        let w = Mpi::new(u.as_ref()?.world());
        (w.size() > 1 && w.rank() == 0).then_some(w)
    }

    impl Drop for super::Lead {
        fn drop(&mut self) {
            if let Some(w) = world() {
                let _turn = ONE_RUN.lock().unwrap_or_else(|e| e.into_inner());
                let _ = w.exchange::<Option<Work>>(vec![None; w.size()]);
            }
            finish();
        }
    }

    /// Finalises MPI (every rank, once, at its end: `mpirun` counts a rank that exits
    /// without it as failed).
    pub fn finish() {
        if let Some(u) = UNIVERSE.get() {
            drop(u.lock().unwrap_or_else(|e| e.into_inner()).take());
        }
    }

    /// Rank 0: hands `work` to every rank; the turn returned is held for it.
    pub fn hand_out(world: &Mpi, work: &Work) -> MutexGuard<'static, ()> {
        let turn = ONE_RUN.lock().unwrap_or_else(|e| e.into_inner());
        let mut out = vec![Some(work.clone()); world.size()];
        out[0] = None;
        let _ = world.exchange(out);
        turn
    }

    /// Another rank: the next work rank 0 hands out, or None when told to end.
    pub fn next_work(world: &Mpi) -> Option<Work> {
        let got: Vec<Option<Work>> = world.exchange(vec![None; world.size()]);
        got.into_iter().next().flatten()
    }
}
