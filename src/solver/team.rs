//! A fixed team of threads for the time loop's per-step parallel regions.
//!
//! A step of the shear box has four short parallel regions (the drift, the pair pass, the
//! per-particle sums with the plate contacts, the final kick), each 20-150 us at 2,500
//! particles. Handing such a region to rayon's pool cost more than the region saved on this
//! 2-vCPU VM: a 2-thread bench counted 583,000 context switches in 52,500 steps (11 per
//! step: rayon's idle worker and the waiting caller go to sleep on a futex and are woken by
//! the hypervisor tens of microseconds later), and the sums with the plate contacts were
//! slower on 2 threads than on 1. A team keeps its workers awake between regions: a worker
//! spins on the job counter for [`SPIN`] after its last job before it parks, so inside a run
//! (regions microseconds apart) a region starts and ends without a system call.
//!
//! The team runs one closure per region on every member, the caller being member 0; each
//! member's share of the work is fixed by its index ([`bounds`]), never stolen, so a region's
//! partition, and with it every bit of the result, depends only on the team size (and the
//! regions used here are bit-identical for any size, see the shear box's thread test).
//! The neighbour rebuild's passes (divergence check, pair search, plate candidates) run on
//! the team too: a rayon region there would wake rayon's worker beside the team's spinning
//! one, three runnable threads on two cores. The rarer whole-state passes (output checks)
//! keep using rayon.

use std::cell::UnsafeCell;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long an idle worker spins before it parks: longer than the serial gaps between the
/// regions of one step (a few microseconds) and than a neighbour rebuild's rayon regions
/// are apart, short enough that a finished run frees its cores at once.
const SPIN: Duration = Duration::from_micros(100);

/// The closure of the current region, its lifetime erased (see [`Team::run`]).
type Job = &'static (dyn Fn(usize) + Sync);

struct Shared {
    /// Regions started so far; a worker runs the job once per increment.
    epoch: AtomicU64,
    /// The current region's closure; written by `run` while every worker is idle (before
    /// the `epoch` increment that publishes it), read by workers after they see it.
    job: UnsafeCell<Option<Job>>,
    /// Workers still running the current region.
    pending: AtomicUsize,
    /// A worker's closure panicked in the current region.
    panicked: AtomicBool,
    quit: AtomicBool,
    /// Per worker: parked (or about to park) and waiting for an unpark.
    sleeping: Vec<AtomicBool>,
}

// SAFETY: `job` is written only by `Team::run` holding `Team::lock` while no worker reads
// it (every worker finished the previous region: `pending == 0`), and read by workers only
// between seeing a new `epoch` (Acquire, after the Release increment that follows the write)
// and decrementing `pending`.
unsafe impl Sync for Shared {}

/// A team of `threads` members: the caller and `threads - 1` workers.
pub struct Team {
    shared: Arc<Shared>,
    workers: Vec<JoinHandle<()>>,
    /// One region at a time (clones of a simulation may share a team).
    lock: Mutex<()>,
}

impl std::fmt::Debug for Team {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Team({} threads)", self.threads())
    }
}

impl Team {
    /// A team of `threads` (at least 1; 1 runs every region on the caller, no worker).
    pub fn new(threads: usize) -> Team {
        let threads = threads.max(1);
        let shared = Arc::new(Shared {
            epoch: AtomicU64::new(0),
            job: UnsafeCell::new(None),
            pending: AtomicUsize::new(0),
            panicked: AtomicBool::new(false),
            quit: AtomicBool::new(false),
            sleeping: (1..threads).map(|_| AtomicBool::new(false)).collect(),
        });
        let workers = (1..threads)
            .map(|t| {
                let s = Arc::clone(&shared);
                std::thread::Builder::new()
                    .name(format!("dem-team-{t}"))
                    .spawn(move || worker(&s, t))
                    .expect("spawning a team worker")
            })
            .collect();
        Team {
            shared,
            workers,
            lock: Mutex::new(()),
        }
    }

    /// Members, the caller included.
    pub fn threads(&self) -> usize {
        self.workers.len() + 1
    }

    /// Runs `f(t)` on every member `t` (the caller is 0) and returns when all have finished.
    /// A panic in any member is raised here after all have finished.
    pub fn run(&self, f: &(dyn Fn(usize) + Sync)) {
        if self.workers.is_empty() {
            return f(0);
        }
        let _one_at_a_time = self.lock.lock().unwrap_or_else(|e| e.into_inner());
        let s = &*self.shared;
        // SAFETY: `f` outlives the region: this function returns only after every worker
        // has decremented `pending`, after its last use of the job.
        let job: Job = unsafe { std::mem::transmute::<&(dyn Fn(usize) + Sync), Job>(f) };
        // SAFETY: no worker reads `job` now (see `Shared`)
        unsafe { *s.job.get() = Some(job) };
        s.pending.store(self.workers.len(), Ordering::Relaxed);
        s.epoch.fetch_add(1, Ordering::SeqCst);
        self.wake();
        let mine = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(0)));
        wait_until(|| s.pending.load(Ordering::Acquire) == 0);
        let theirs = s.panicked.swap(false, Ordering::Relaxed);
        if let Err(p) = mine {
            std::panic::resume_unwind(p);
        }
        assert!(!theirs, "a team worker panicked");
    }

    /// Runs `f(t, parts[t])` on every member `t`; `parts` has one entry per member.
    pub fn each<P: Send>(&self, parts: Vec<P>, f: impl Fn(usize, P) + Sync) {
        self.map(parts, f);
    }

    /// [`Team::each`] with each member's result, in member order.
    pub fn map<P: Send, R: Send>(&self, parts: Vec<P>, f: impl Fn(usize, P) -> R + Sync) -> Vec<R> {
        assert_eq!(parts.len(), self.threads(), "one part per member");
        let slots: Vec<Mutex<(Option<P>, Option<R>)>> = parts
            .into_iter()
            .map(|p| Mutex::new((Some(p), None)))
            .collect();
        self.run(&|t| {
            let mut slot = slots[t].lock().unwrap_or_else(|e| e.into_inner());
            let p = slot.0.take().expect("each part taken once");
            slot.1 = Some(f(t, p));
        });
        slots
            .into_iter()
            .map(|m| {
                m.into_inner()
                    .unwrap_or_else(|e| e.into_inner())
                    .1
                    .expect("every member ran")
            })
            .collect()
    }

    /// Unparks the workers that parked.
    fn wake(&self) {
        for (w, asleep) in self.workers.iter().zip(&self.shared.sleeping) {
            if asleep.swap(false, Ordering::SeqCst) {
                w.thread().unpark();
            }
        }
    }
}

impl Drop for Team {
    fn drop(&mut self) {
        self.shared.quit.store(true, Ordering::SeqCst);
        self.shared.epoch.fetch_add(1, Ordering::SeqCst);
        self.wake();
        for w in self.workers.drain(..) {
            let _ = w.join();
        }
    }
}

/// Spins until `done`, then yields the core between checks (a member descheduled by an
/// oversubscribed machine is not waited for with a spinning core).
fn wait_until(done: impl Fn() -> bool) {
    let t0 = Instant::now();
    let mut k = 0u32;
    while !done() {
        k = k.wrapping_add(1);
        if k.is_multiple_of(64) && t0.elapsed() > SPIN {
            std::thread::yield_now();
        } else {
            std::hint::spin_loop();
        }
    }
}

fn worker(s: &Shared, t: usize) {
    let mut seen = 0u64;
    loop {
        // wait for the next region: spin, then park
        let t0 = Instant::now();
        let mut k = 0u32;
        loop {
            let e = s.epoch.load(Ordering::Acquire);
            if e != seen {
                seen = e;
                break;
            }
            k = k.wrapping_add(1);
            if k.is_multiple_of(64) && t0.elapsed() > SPIN {
                s.sleeping[t - 1].store(true, Ordering::SeqCst);
                if s.epoch.load(Ordering::SeqCst) == seen {
                    std::thread::park();
                }
                s.sleeping[t - 1].store(false, Ordering::SeqCst);
            } else {
                std::hint::spin_loop();
            }
        }
        if s.quit.load(Ordering::SeqCst) {
            return;
        }
        // SAFETY: see `Shared`
        let job = unsafe { (*s.job.get()).expect("a job with every region") };
        if std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(t))).is_err() {
            s.panicked.store(true, Ordering::Relaxed);
        }
        s.pending.fetch_sub(1, Ordering::Release);
    }
}

/// `f` run in a rayon pool of `threads` threads, where the shear box's team takes its size
/// (tests that compare thread counts).
#[cfg(test)]
pub fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon pool")
        .install(f)
}

/// Member `t`'s share of `n` items among `threads`: contiguous, in order, sizes differing
/// by at most one.
pub fn bounds(n: usize, threads: usize, t: usize) -> std::ops::Range<usize> {
    let (q, r) = (n / threads, n % threads);
    let start = t * q + t.min(r);
    start..start + q + usize::from(t < r)
}

/// `s` split into the members' shares ([`bounds`]).
pub fn split_mut<T>(mut s: &mut [T], threads: usize) -> Vec<&mut [T]> {
    let n = s.len();
    (0..threads)
        .map(|t| {
            let (a, b) = std::mem::take(&mut s).split_at_mut(bounds(n, threads, t).len());
            s = b;
            a
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_member_runs_every_region_once_with_its_share() {
        for threads in 1..=3 {
            let team = Team::new(threads);
            assert_eq!(team.threads(), threads);
            let mut v: Vec<u64> = (0..1001).collect();
            for region in 0..2000u64 {
                let parts = split_mut(&mut v, threads);
                team.each(parts, |_, part| {
                    for x in part {
                        *x += region;
                    }
                });
            }
            let add: u64 = (0..2000).sum();
            assert!(v.iter().enumerate().all(|(i, &x)| x == i as u64 + add));
            let ids = team.map((0..threads).collect(), |t, p| (t, p));
            assert_eq!(ids, (0..threads).map(|t| (t, t)).collect::<Vec<_>>());
        }
    }

    #[test]
    fn shares_cover_the_items_in_order() {
        for n in [0, 1, 7, 2500] {
            for threads in 1..=4 {
                let b: Vec<_> = (0..threads).map(|t| bounds(n, threads, t)).collect();
                assert_eq!(b[0].start, 0);
                assert_eq!(b[threads - 1].end, n);
                assert!(b.windows(2).all(|w| w[0].end == w[1].start));
                assert!(b
                    .iter()
                    .all(|r| r.len() == n / threads || r.len() == n / threads + 1));
            }
        }
    }

    #[test]
    fn a_parked_worker_wakes_and_a_worker_panic_reaches_the_caller() {
        let team = Team::new(2);
        std::thread::sleep(SPIN * 20);
        let ran = AtomicUsize::new(0);
        team.run(&|_| {
            ran.fetch_add(1, Ordering::Relaxed);
        });
        assert_eq!(ran.load(Ordering::Relaxed), 2);
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            team.run(&|t| assert!(t == 0, "member {t} fails"))
        }));
        assert!(r.is_err());
        // the team still works after a panic
        team.run(&|_| {
            ran.fetch_add(1, Ordering::Relaxed);
        });
        assert_eq!(ran.load(Ordering::Relaxed), 4);
    }
}
