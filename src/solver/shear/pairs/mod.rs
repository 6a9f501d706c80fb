//! The pair pass of the shear box: every listed pair's contact force, history and state, by
//! one of two kernel paths that give the same bits (tested on dense sheared states):
//! - [`KernelPath::Scalar`]: [`surfaces_intersect`](crate::solver::contact::surfaces_intersect), the kernels that mirror LIGGGHTS'
//!   headers one contact at a time (also what the contact cases and the walls use);
//! - [`KernelPath::Avx512`]: [`batch::pair`] on 8 touching pairs at once (found by the same
//!   test on 8 listed pairs at once), their inputs loaded as 32-byte rows of packed particle
//!   records ([`Packed`]), pair records and histories and transposed into lanes, the
//!   results written back per pair. Chosen at run time where the CPU has AVX-512F and DQ;
//! - [`KernelPath::Avx2`]: the same pass on two AVX vectors of 4 lanes (CPUs with AVX2 but
//!   without AVX-512).
//!
//! [`batch::pair`]: crate::solver::contact::batch::pair
//!
//! Each pair writes only its own history, state and force slot, so the contacts are evaluated
//! in parallel; every particle's sum is made in pair order whatever the thread count
//! ([`pass`]), so the results do not depend on it.
//!
//! Files by job: `path` (which kernel path), `scalar` and `simd` (the two paths), `sums`
//! (each particle's sum in pair order over blocks and threads), `tests` (the paths against
//! each other); this file holds the pass that cuts the pair list into pieces.

use super::neighbor::{resize_snug, Pair};
use super::records::{PairDamp, PairState};
use crate::solver::contact::{ContactHistory, ForceData};
use crate::solver::material::PairParams;
use crate::solver::team::{bounds, split_mut, Team};

mod data;
mod path;
mod scalar;
mod sums;

use data::{take_front, Piece};
pub(super) use data::{Csr, Packed, Particles};
pub use path::{KernelPath, MAX_KERNEL_VAR};
use scalar::scalar_one;
use sums::*;
pub(super) use sums::{BlockPlan, PairSums, Sums};

/// Evaluates every listed pair: its state, (when `update_history`) its history and its force
/// and torque increments (zero when apart), each particle's increments summed in pair order.
/// With one thread they are added to the per-particle sums `acc` as the pairs are evaluated
/// ([`Sums::Accumulated`]). With more, the pairs are grouped in one block per member of the
/// `team` (the pairs found from its share of the particles), evaluated in parallel block by
/// block, each block's pieces in order: the block of a particle's first pair adds the
/// increments of its pairs there to `acc`, in pair order, alone; a later block writes them
/// to its side of the pair's `out` slot, added to that sum afterwards by [`PairSums::add`]
/// in pair order (the CSR), inside the caller's parallel loop over particles
/// ([`Sums::Blocks`]). Every sum is the same sequence of additions as the serial one: the same
/// bits for any thread count. Particles are numbered by height (`loose_packing`) and the
/// list is ordered by the lower index, so most particles' partners lie in their own block:
/// measured on the fast state with 2 threads, 94 % of the particles (with the placement
/// order, random in space, only particles numbered below the cut could be, not measured).
/// `out` is also written whole when `record` (observers); a serial pass
/// otherwise neither allocates nor writes it. `after_block(t)` runs on member `t` after its
/// block (on one thread, after the whole list), in the same region.
///
/// Pair order is the order of the per-particle (CSR) sums this pass replaced, so the results
/// are the bits of before (a whole ci run, native.csv identical to the previous binary's,
/// 1 and 2 threads). Per-block sums added up per particle would re-associate the sums of
/// the particles with pairs in several blocks: measured, the quick night's replay at (1,
/// 0.5) then fell short of the chaos envelope in one window (11 of 12 steps).
#[allow(clippy::too_many_arguments)]
pub(super) fn pass(
    team: &Team,
    path: KernelPath,
    pairs: &[Pair],
    csr: Csr,
    hist: &mut [ContactHistory],
    out: &mut Vec<(ForceData, ForceData)>,
    state: &mut [PairState],
    damp: &mut [PairDamp],
    acc: &mut [ForceData],
    s: Particles,
    params: &PairParams,
    update_history: bool,
    record: bool,
    after_block: &(dyn Fn(usize) + Sync),
    plan: &mut BlockPlan,
    generation: u64,
) -> Sums {
    let np = pairs.len();
    let n = s.x.len();
    assert!(acc.len() == n && state.len() == np && hist.len() == np);
    assert!(damp.is_empty() || damp.len() == np);
    assert!(csr.start.len() == n + 1 && csr.entries.len() == 2 * np);
    assert!(
        path.runs_here(),
        "the {} path on a CPU without it",
        path.name()
    );
    let serial = team.threads() == 1;
    // `out` is allocated only when written (a serial pass without `record` never does: 96
    // bytes per listed pair, about 430 B per particle, not held)
    let write_out = record || !serial;
    if write_out {
        resize_snug(out, np);
    }
    // One block of pairs per thread: block t holds the pairs found from the particles of
    // share t ([`bounds`]; the list is in the order of the particle a pair was found from,
    // min(i, j)), so that each thread evaluates the pairs of the particles it zeroes, sums
    // and integrates: a cache line written by one core and read by the other costs about
    // 35 ns to move (measured round trip 70 ns here), and with blocks of equal pair counts
    // the particles between the two boundaries moved every step.
    let th = team.threads();
    let cut: Vec<usize> = (0..=th)
        .map(|t| match t {
            t if t == th => np,
            t => {
                let first = bounds(n, th, t).start;
                pairs.partition_point(|p| (p.i.min(p.j) as usize) < first)
            }
        })
        .collect();
    // each block's pairs with their slots (`out` and `damp` empty where not written), cut
    // into pieces of CHUNK pairs by the thread that evaluates it ([`Block::pieces`])
    let prefetch = plan.prefetch.unwrap_or_else(|| prefetch_pays(n));
    let (mut hist, mut state) = (hist, state);
    let mut out: &mut [(ForceData, ForceData)] = if write_out { &mut out[..np] } else { &mut [] };
    let mut damp = damp;
    let mut blocks: Vec<Block> = (0..th)
        .map(|t| {
            let len = cut[t + 1] - cut[t];
            Block {
                pairs: &pairs[cut[t]..cut[t + 1]],
                hist: take_front(&mut hist, len),
                state: take_front(&mut state, len),
                out: take_front(&mut out, len),
                damp: take_front(&mut damp, len),
                record,
                prefetch,
            }
        })
        .collect();
    if serial {
        acc.fill(ForceData::default());
        for pc in blocks.pop().into_iter().flat_map(Block::pieces) {
            piece(
                path,
                pc,
                &mut Sink::Acc(&mut *acc),
                s,
                params,
                update_history,
            );
        }
        after_block(0);
        return Sums::Accumulated;
    }
    // the block of each particle's first pair (and whether it has pairs in later blocks)
    // depends only on the list and the team size, found once per list, by every thread for
    // its share of the particles
    let key = Some((generation, th));
    let acc_zero = std::mem::take(&mut plan.acc_zero);
    if plan.key != key || !acc_zero {
        let fresh = plan.key != key;
        plan.key = key;
        resize_snug(&mut plan.first, n);
        if fresh {
            plan.cut.clone_from(&cut);
        }
        let block_of = |k: u32| block_of(&cut, k as usize) as u32;
        let parts: Vec<_> = split_mut(acc, th)
            .into_iter()
            .zip(split_mut(&mut plan.first, th))
            .collect();
        team.each(parts, |t, (acc, first)| {
            acc.fill(ForceData::default());
            if !fresh {
                return;
            }
            let o = bounds(n, th, t).start;
            for (k, first) in first.iter_mut().enumerate() {
                let (a, b) = (csr.start[o + k] as usize, csr.start[o + k + 1] as usize);
                *first = match a == b {
                    // no pairs: nothing is delivered, its sum stays +0
                    true => t as u32,
                    false => {
                        let (f, l) = (block_of(csr.entries[a].0), block_of(csr.entries[b - 1].0));
                        if f == l {
                            f
                        } else {
                            f | MIXED
                        }
                    }
                };
            }
        });
    }
    let first = &plan.first;
    let shared = SharedAcc::new(acc);
    team.each(blocks, |t, block| {
        let mut sink = Sink::Block {
            acc: shared,
            first,
            block: t as u32,
        };
        for pc in block.pieces() {
            piece(path, pc, &mut sink, s, params, update_history);
        }
        after_block(t);
    });
    Sums::Blocks
}

/// Whether the SIMD passes prefetch the records and sums of the next piece's `j` particles
/// ([`Piece::ahead`]) for `n` particles: when those (144 bytes per particle) exceed this
/// core's L2 cache. Measured on the fast state, 1 thread, avx512, alternating with and
/// without every 20-40 steps in one process: time per step 0.86x at 10,000 particles
/// (1.4 MB), 0.83x at 22,500, 0.81x at 40,000, 0.79x at 90,000 and at 250,000; at 2,500
/// (360 kB, within the 1 MB L2) 1.03-1.06x, the prefetches' own cost. Prefetching never
/// changes a value, so the choice is free to depend on the machine.
fn prefetch_pays(n: usize) -> bool {
    n * (std::mem::size_of::<Packed>() + std::mem::size_of::<ForceData>()) > l2_bytes()
}

/// The L2 cache of CPU 0 in bytes, from Linux' sysfs; 1 MiB where it cannot be read.
fn l2_bytes() -> usize {
    static L2: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *L2.get_or_init(|| {
        let read = |d: &std::path::Path, f: &str| std::fs::read_to_string(d.join(f)).ok();
        let found = std::fs::read_dir("/sys/devices/system/cpu/cpu0/cache")
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path())
            .filter(|d| read(d, "level").is_some_and(|l| l.trim() == "2"))
            .find_map(|d| parse_cache_size(&read(&d, "size")?));
        found.unwrap_or(1 << 20)
    })
}

/// A sysfs cache size: `512K`, `1024K`, `2M` or plain bytes.
fn parse_cache_size(s: &str) -> Option<usize> {
    let s = s.trim();
    let (digits, unit) = match s.strip_suffix('K') {
        Some(d) => (d, 1 << 10),
        None => match s.strip_suffix('M') {
            Some(d) => (d, 1 << 20),
            None => (s, 1),
        },
    };
    digits.parse::<usize>().ok().map(|v| v * unit)
}

/// Evaluates one piece on `path`, its increments delivered to `sink` in pair order.
fn piece(
    path: KernelPath,
    pc: Piece,
    sink: &mut Sink,
    s: Particles,
    params: &PairParams,
    update_history: bool,
) {
    let n = pc.pairs.len();
    assert!(pc.hist.len() == n && pc.state.len() == n && n <= CHUNK);
    assert!((pc.out.is_empty() || pc.out.len() == n) && (pc.damp.is_empty() || pc.damp.len() == n));
    match path {
        KernelPath::Scalar => {
            for k in 0..n {
                let p = &pc.pairs[k];
                let (di, dj, st, dm) = scalar_one(p, &mut pc.hist[k], s, params, update_history);
                pc.state[k] = st;
                if let Some(d) = pc.damp.get_mut(k) {
                    *d = dm;
                }
                let (i, j) = (p.i as usize, p.j as usize);
                sink.deliver(i, j, &di, &dj, pc.out.get_mut(k), pc.out_apart);
            }
        }
        KernelPath::Avx512 | KernelPath::Avx2 => {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the path runs on this CPU (checked by `pass`); the piece's slices as
            // `chunk` asks (checked above); every particle index of a pair is in bounds
            // (the neighbour list is built over these particles).
            unsafe {
                simd::chunk_on(path, pc, sink, s, params, update_history)
            }
            #[cfg(not(target_arch = "x86_64"))]
            unreachable!("the SIMD paths are only selected on x86_64")
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod simd;

#[cfg(test)]
mod tests;
