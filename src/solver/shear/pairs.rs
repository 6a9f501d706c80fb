//! The pair pass of the shear box: every listed pair's contact force, history and state, by
//! one of two kernel paths that give the same bits (tested on dense sheared states):
//! - [`KernelPath::Scalar`]: [`surfaces_intersect`], the kernels that mirror LIGGGHTS'
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

use super::neighbor::{resize_snug, Pair};
use super::{pair_contact, PairContact, PairDamp, PairState};
use crate::error::{Error, Result};
use crate::solver::contact::{surfaces_intersect, ContactHistory, ForceData};
use crate::solver::material::PairParams;
use crate::solver::team::{bounds, split_mut, Team};
use crate::solver::vec3::V3;
use serde::{Deserialize, Serialize};

/// Which implementation evaluates the pair contacts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KernelPath {
    /// One contact at a time ([`surfaces_intersect`]).
    Scalar,
    /// 8 contacts per AVX-512 vector ([`batch::pair`]).
    Avx512,
    /// 4 contacts per AVX vector ([`batch::pair`]), on CPUs with AVX2 but without AVX-512.
    Avx2,
}

impl KernelPath {
    /// The fastest path this CPU runs (and [`MAX_KERNEL_VAR`] allows).
    pub fn detect() -> Self {
        [KernelPath::Avx512, KernelPath::Avx2]
            .into_iter()
            .find(|k| k.runs_here())
            .unwrap_or(KernelPath::Scalar)
    }

    /// Every path this CPU runs, the scalar one first.
    pub fn available() -> Vec<Self> {
        [KernelPath::Scalar, KernelPath::Avx2, KernelPath::Avx512]
            .into_iter()
            .filter(|k| k.runs_here())
            .collect()
    }

    /// This CPU has the path's instructions, and [`MAX_KERNEL_VAR`] does not exclude it.
    pub fn runs_here(self) -> bool {
        let cpu = match self {
            KernelPath::Scalar => true,
            KernelPath::Avx512 => avx512_available(),
            KernelPath::Avx2 => avx2_available(),
        };
        cpu && self.rank() <= max_kernel().rank()
    }

    /// Scalar < AVX2 < AVX-512.
    fn rank(self) -> u8 {
        match self {
            KernelPath::Scalar => 0,
            KernelPath::Avx2 => 1,
            KernelPath::Avx512 => 2,
        }
    }

    /// The fastest path [`MAX_KERNEL_VAR`] allows: Ok(None) when it is unset; an error
    /// naming the variable and its values for anything else than a path's name.
    pub fn max_from_env() -> Result<Option<Self>> {
        match std::env::var(MAX_KERNEL_VAR) {
            Err(std::env::VarError::NotPresent) => Ok(None),
            Ok(v) => [KernelPath::Scalar, KernelPath::Avx2, KernelPath::Avx512]
                .into_iter()
                .find(|k| k.name() == v)
                .map(Some)
                .ok_or_else(|| Error::invalid(MAX_KERNEL_VAR, v, "one of scalar, avx2, avx512")),
            Err(e) => Err(Error::invalid(
                MAX_KERNEL_VAR,
                "(not unicode)",
                format!("one of scalar, avx2, avx512 ({e})"),
            )),
        }
    }

    /// `path` if this CPU can run it, else an error naming `field`.
    pub fn checked(self, field: &str) -> Result<Self> {
        if !self.runs_here() {
            let names: Vec<_> = Self::available().iter().map(|k| k.name()).collect();
            return Err(Error::invalid(
                field,
                self.name(),
                format!("one of {} on this CPU", names.join(", ")),
            ));
        }
        Ok(self)
    }

    pub fn name(self) -> &'static str {
        match self {
            KernelPath::Scalar => "scalar",
            KernelPath::Avx512 => "avx512",
            KernelPath::Avx2 => "avx2",
        }
    }
}

/// The environment variable that makes the solver act as a CPU without the faster paths
/// (`scalar`: neither AVX2 nor AVX-512; `avx2`: no AVX-512; `avx512` or unset: what the CPU
/// has), so that a machine with AVX-512 runs the whole test suite as one without it would.
pub const MAX_KERNEL_VAR: &str = "DEM_VERIFY_MAX_KERNEL";

/// The fastest path allowed in this process (read once; `verify` checks the variable at
/// start and refuses a bad value before any solver runs).
fn max_kernel() -> KernelPath {
    static MAX: std::sync::OnceLock<KernelPath> = std::sync::OnceLock::new();
    *MAX.get_or_init(|| match KernelPath::max_from_env() {
        Ok(k) => k.unwrap_or(KernelPath::Avx512),
        Err(e) => panic!("{e}"),
    })
}

fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx") && std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

fn avx512_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512dq")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The particle arrays a pair reads.
#[derive(Clone, Copy)]
pub(super) struct Particles<'a> {
    pub x: &'a [V3],
    pub v: &'a [V3],
    pub omega: &'a [V3],
    pub radius: &'a [f64],
    pub mass: &'a [f64],
    /// The same values packed per particle ([`Packed`]): read by the SIMD paths, which
    /// require it whole; empty on the scalar path.
    pub packed: &'a [Packed],
}

/// One particle's pass inputs in three 32-byte rows, `[x0 x1 x2 r | v0 v1 v2 m | w0 w1 w2 0]`,
/// so that a SIMD path loads a row with one instruction and transposes 8 (AVX-512) or 4
/// (AVX2) of them into 4 vectors of lanes, instead of copying 11 scalars per particle into
/// lane arrays. Copies of the particle arrays (the same bits): the moving values written by
/// the drift ([`super::ShearSim::step`]), the radius and mass when the records are made.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub(super) struct Packed(pub [f64; 12]);

impl Packed {
    #[inline(always)]
    pub fn new(x: V3, r: f64, v: V3, m: f64, w: V3) -> Self {
        Packed([
            x[0], x[1], x[2], r, v[0], v[1], v[2], m, w[0], w[1], w[2], 0.0,
        ])
    }

    /// The values that change as a particle moves (its radius and mass kept).
    #[inline(always)]
    pub fn moved(&mut self, x: V3, v: V3, w: V3) {
        self.0[0..3].copy_from_slice(&x);
        self.0[4..7].copy_from_slice(&v);
        self.0[8..11].copy_from_slice(&w);
    }
}

/// Adds one increment to a particle's sum.
#[inline(always)]
fn add_force(a: &mut ForceData, d: &ForceData) {
    for c in 0..3 {
        a.delta_f[c] += d.delta_f[c];
        a.delta_torque[c] += d.delta_torque[c];
    }
}

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

/// The first `len` items of `s` (all of an empty `s`: an unwritten array), `s` advanced past them.
fn take_front<'a, T>(s: &mut &'a mut [T], len: usize) -> &'a mut [T] {
    if s.is_empty() {
        return &mut [];
    }
    let (a, b) = std::mem::take(s).split_at_mut(len);
    *s = b;
    a
}

/// Where a piece's increments go.
enum Sink<'a> {
    /// Every particle's sum (one block: the serial pass).
    Acc(&'a mut [ForceData]),
    /// The sums of the particles whose first pair lies in this piece's `block` (`first`,
    /// [`BlockPlan::first`]); the others' side of the pair goes to the pair's `out` slot,
    /// added after the pass.
    Block {
        acc: SharedAcc<'a>,
        first: &'a [u32],
        block: u32,
    },
}

impl Sink<'_> {
    /// The first particle's sum (for prefetching only: nothing is read or written through it).
    #[inline(always)]
    fn sums_ptr(&self) -> *const ForceData {
        match self {
            Sink::Acc(acc) => acc.as_ptr(),
            Sink::Block { acc, .. } => acc.ptr,
        }
    }

    /// Delivers pair `k`'s increments `di` (to its `i`) and `dj` (to its `j`); `out` is the
    /// pair's slot when held, written whole when `record`.
    #[inline(always)]
    fn deliver(
        &mut self,
        i: usize,
        j: usize,
        di: &ForceData,
        dj: &ForceData,
        out: Option<&mut (ForceData, ForceData)>,
        record: bool,
    ) {
        match self {
            Sink::Acc(acc) => {
                add_force(&mut acc[i], di);
                add_force(&mut acc[j], dj);
                if let (Some(o), true) = (out, record) {
                    *o = (*di, *dj);
                }
            }
            Sink::Block { acc, first, block } => {
                let (mi, mj) = (first[i] & !MIXED == *block, first[j] & !MIXED == *block);
                for (q, d, mine) in [(i, di, mi), (j, dj, mj)] {
                    if mine {
                        // SAFETY: q's first pair lies in this block, which one thread
                        // evaluates piece after piece: no other thread adds to q's sum
                        unsafe { acc.add(q, d) }
                    }
                }
                match out {
                    Some(o) if record => *o = (*di, *dj),
                    Some(o) => {
                        if !mi {
                            o.0 = *di;
                        }
                        if !mj {
                            o.1 = *dj;
                        }
                    }
                    None => {}
                }
            }
        }
    }
}

/// The particles' sums shared by the blocks of a parallel pass, each sum added to by one
/// block only ([`Sink::Block`]).
#[derive(Clone, Copy)]
struct SharedAcc<'a> {
    ptr: *mut ForceData,
    len: usize,
    _sums: std::marker::PhantomData<&'a mut [ForceData]>,
}

// SAFETY: the blocks write disjoint elements (a particle's sum belongs to one block).
unsafe impl Send for SharedAcc<'_> {}
// SAFETY: as for Send: no two threads touch one element.
unsafe impl Sync for SharedAcc<'_> {}

impl<'a> SharedAcc<'a> {
    fn new(acc: &'a mut [ForceData]) -> Self {
        SharedAcc {
            ptr: acc.as_mut_ptr(),
            len: acc.len(),
            _sums: std::marker::PhantomData,
        }
    }

    /// Adds `d` to particle `q`'s sum.
    ///
    /// # Safety
    /// No other thread reads or writes `q`'s sum meanwhile.
    #[inline(always)]
    unsafe fn add(&self, q: usize, d: &ForceData) {
        assert!(q < self.len);
        add_force(&mut *self.ptr.add(q), d);
    }
}

/// Where [`pass`] left the particles' pair sums.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) enum Sums {
    /// In `acc`, made in pair order as the pairs were evaluated (one thread).
    Accumulated,
    /// Per particle ([`BlockPlan::first`]): the increments of its pairs in the block of its
    /// first pair summed in `acc` as above (all of them for 94 % of the particles on the
    /// fast state with 2 threads); those of its pairs in later blocks per touching pair in
    /// `out`, its side only (an apart pair's slot is not written unless recorded), added
    /// to that sum by [`PairSums::add`].
    Blocks,
}

/// What the parallel [`pass`] keeps between steps.
#[derive(Clone, Debug, Default)]
pub(super) struct BlockPlan {
    /// The list (its build in this process) and team size `first` was found for.
    key: Option<(u64, usize)>,
    /// Per particle: the block of its first pair, with [`MIXED`] when it has pairs in a
    /// later block too (its own member's block for a particle without pairs: nothing is
    /// delivered to it). A particle's pairs are in increasing pair index, so those in the
    /// block of its first pair come before all the others: that block sums their increments in `acc` as the serial pass does (the
    /// prefix of its sum), and the later blocks' increments are added to that prefix in
    /// pair order after the pass, the serial pass's additions in its order. Measured on the
    /// fast state (2 threads, avx512, alternating every 250 steps in one process), against
    /// summing every pair of such a particle from `out` (read by the core that did not
    /// write them): time per step 0.927-1.000x, 0.965x on average over 9 runs (identical
    /// variants alternated: 0.967-1.008x, 0.994x over 6).
    pub first: Vec<u32>,
    /// The blocks' first pairs (and the list's length) this plan was made for.
    pub cut: Vec<usize>,
    /// Every particle's `acc` is zero: [`PairSums::add`] zeroes a sum it read, and the
    /// blocks write only the sums of the particles whose first pair they hold. Set by the
    /// caller after summing every particle; a pass that finds it unset zeroes `acc` itself. Measured on the fast state
    /// (2 threads, avx512, alternating every 250 steps in one process): finding the owners
    /// and zeroing the sums every step in a region of their own cost
    /// about 2.6 ns per particle-step.
    pub acc_zero: bool,
    /// Prefetching forced on or off (tests); `None`: when it pays ([`prefetch_pays`]).
    pub prefetch: Option<bool>,
}

/// What the particles' pair sums are made from after a [`pass`].
#[derive(Clone, Copy)]
pub(super) struct PairSums<'a> {
    /// Per particle, the block of its first pair and whether it has pairs in later blocks
    /// ([`BlockPlan::first`]); empty with one thread (every sum whole in `acc`).
    pub first: &'a [u32],
    /// The blocks' first pairs ([`BlockPlan::cut`]).
    pub cut: &'a [usize],
    pub csr: Csr<'a>,
    pub out: &'a [(ForceData, ForceData)],
    pub state: &'a [PairState],
}

impl PairSums<'_> {
    /// Adds particle `q`'s pair sum to its force `f` and torque `t` (both +0 before): its
    /// sum `acc` as the pass made it (then zeroed for the next pass, see
    /// [`BlockPlan::acc_zero`]), whole unless `q` has pairs in a block after that of its
    /// first pair; then those pairs' increments from `out` for its touching pairs (`state`)
    /// in increasing pair index (the CSR `entries` are in that order), the additions of the
    /// serial pass in its order, so the same bits (`+0 + a` is `a`: a sum started at +0 is
    /// never -0); the serial pass adds zeros for apart pairs, which change no bit, so
    /// skipping them changes none either.
    #[inline(always)]
    pub fn add(&self, q: usize, acc: &mut ForceData, f: &mut V3, t: &mut V3) {
        let PairSums {
            first,
            cut,
            csr,
            out,
            state,
        } = *self;
        for c in 0..3 {
            f[c] += acc.delta_f[c];
            t[c] += acc.delta_torque[c];
        }
        *acc = ForceData::default();
        let Some(&b) = first.get(q).filter(|&&b| b & MIXED != 0) else {
            return;
        };
        // the pairs of the first block: in the prefix
        let later = cut[(b & !MIXED) as usize + 1];
        for &(k, is_i) in &csr.entries[csr.start[q] as usize..csr.start[q + 1] as usize] {
            if (k as usize) < later || state[k as usize].contact == PairContact::Apart {
                continue;
            }
            let o = &out[k as usize];
            let d = if is_i { &o.0 } else { &o.1 };
            for c in 0..3 {
                f[c] += d.delta_f[c];
                t[c] += d.delta_torque[c];
            }
        }
    }
}

/// Pairs per piece of the pass.
const CHUNK: usize = 256;

/// [`BlockPlan::first`]'s flag of a particle with pairs in more than one block.
const MIXED: u32 = 1 << 31;

/// The block holding pair `k`, the blocks starting at pairs `cut` (`cut[0]` = 0, the last
/// entry the list's length).
fn block_of(cut: &[usize], k: usize) -> usize {
    cut[1..].partition_point(|&c| c <= k)
}

/// One thread's block of the pair list with its per-pair slots (`out`, `damp` empty where
/// not written), cut into [`Piece`]s as it is evaluated. Measured on the fast state (2
/// threads, avx512, 2 runs each): the pass's serial set-up 1.7-3.6 us per step with every
/// piece made beforehand in a vector per block, 0.7-1.1 us with the blocks cut lazily.
struct Block<'a> {
    pairs: &'a [Pair],
    hist: &'a mut [ContactHistory],
    state: &'a mut [PairState],
    out: &'a mut [(ForceData, ForceData)],
    damp: &'a mut [PairDamp],
    /// Apart pairs' `out` slots written too ([`Piece::out_apart`]).
    record: bool,
    /// Each piece with the next one's pairs ([`Piece::ahead`]).
    prefetch: bool,
}

impl<'a> Block<'a> {
    /// The block's pieces of [`CHUNK`] pairs in order.
    fn pieces(self) -> impl Iterator<Item = Piece<'a>> {
        let Block {
            pairs,
            mut hist,
            mut state,
            mut out,
            mut damp,
            record,
            prefetch,
        } = self;
        (0..pairs.len().div_ceil(CHUNK)).map(move |k| {
            let r = k * CHUNK..((k + 1) * CHUNK).min(pairs.len());
            let len = r.len();
            Piece {
                pairs: &pairs[r],
                ahead: match prefetch {
                    true => pairs
                        .get((k + 1) * CHUNK..((k + 2) * CHUNK).min(pairs.len()))
                        .unwrap_or_default(),
                    false => &[],
                },
                hist: take_front(&mut hist, len),
                state: take_front(&mut state, len),
                out: take_front(&mut out, len),
                out_apart: record,
                damp: take_front(&mut damp, len),
            }
        })
    }
}

/// One piece of the pair list (at most [`CHUNK`] pairs) with its per-pair slots: `out` (the
/// increments) empty unless written, `damp` (epsd_implicit's dashpot) empty unless held.
pub(super) struct Piece<'a> {
    pub pairs: &'a [Pair],
    /// The pairs of the block's next piece (empty for the last): the SIMD paths prefetch
    /// their particles' records while this piece is evaluated.
    pub ahead: &'a [Pair],
    pub hist: &'a mut [ContactHistory],
    pub state: &'a mut [PairState],
    pub out: &'a mut [(ForceData, ForceData)],
    /// Apart pairs' `out` slots cleared too (observers read every slot); otherwise only the
    /// touching pairs' slots are written, and readers skip the apart ones by their state.
    /// Measured on the fast state, 2 threads, avx512: clearing every slot (96 bytes per
    /// listed pair, 1 MB per step, beyond this machine's 1 MB L2 with the rest) was a third
    /// of the pass.
    pub out_apart: bool,
    pub damp: &'a mut [PairDamp],
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

/// The per-particle index of the pairs (`NeighborList::start`, `entries`).
#[derive(Clone, Copy)]
pub(super) struct Csr<'a> {
    pub start: &'a [u32],
    pub entries: &'a [(u32, bool)],
}

/// One pair by the scalar kernels: its history (updated in place); returns i's and j's
/// increments (zero when apart), its state and its dashpot.
fn scalar_one(
    p: &Pair,
    hist: &mut ContactHistory,
    s: Particles,
    params: &PairParams,
    update_history: bool,
) -> (ForceData, ForceData, PairState, PairDamp) {
    let (i, j) = (p.i as usize, p.j as usize);
    let Some(mut cd) = pair_contact(
        p,
        (s.x[i], s.x[j]),
        (s.radius[i], s.radius[j]),
        (s.mass[i], s.mass[j]),
        (s.v[i], s.v[j]),
        (s.omega[i], s.omega[j]),
    ) else {
        return Default::default();
    };
    let (fi, fj, o) = surfaces_intersect(&mut cd, params, hist, update_history);
    let ft2 = o.ft[0] * o.ft[0] + o.ft[1] * o.ft[1] + o.ft[2] * o.ft[2];
    let cap = params.coeff_frict * o.normal.fn_.abs();
    let state = PairState {
        contact: if o.rolling_mobilised {
            PairContact::RollingMobilised
        } else {
            PairContact::Touching
        },
        sliding: ft2 >= cap * cap * (1.0 - 1e-9),
    };
    let damp = PairDamp {
        damping: o.implicit_damping,
        en: cd.en,
    };
    (fi, fj, state, damp)
}

#[cfg(target_arch = "x86_64")]
mod simd {
    use super::super::neighbor::Pair;
    use super::super::{PairContact, PairDamp, PairState};
    use super::{KernelPath, Particles, Piece, Sink, CHUNK};
    use crate::solver::contact::batch::{self, PairIn};
    use crate::solver::contact::lanes::{Lanes, F4, F8};
    use crate::solver::contact::{ContactHistory, ForceData};
    use crate::solver::material::PairParams;
    use std::arch::x86_64::*;

    /// The outputs of 8 lanes: the increments and histories as rows (lane `l` at `[l]`:
    /// `di` `[f | torque | 0 0]` of `i`, `dj` of `j`, `hist` `[shear | r_torque | 0 0]`),
    /// the dashpot as arrays (lane `l` of component `c` at `[c][l]`), the masks as bits
    /// (lane `l` at bit `l`).
    pub(super) struct Out8 {
        di: [[f64; 8]; 8],
        dj: [[f64; 8]; 8],
        hist: [[f64; 8]; 8],
        en: [[f64; 8]; 3],
        damping: [f64; 8],
        touch: u8,
        mobilised: u8,
        sliding: u8,
    }

    /// A SIMD width evaluating 8 lanes through [`batch::pair`].
    pub(super) trait Eval8 {
        /// The pairs `ks` (8 indices into `pairs` and `hist`) as 8 lanes.
        ///
        /// # Safety
        /// The target features of the implementing path; every index in `ks` in bounds of
        /// `pairs` and `hist`, every particle index of those pairs in bounds of `s` and of
        /// `s.packed`.
        unsafe fn eval8(
            ks: &[u16],
            pairs: &[Pair],
            hist: &[ContactHistory],
            s: Particles,
            params: &PairParams,
            update_history: bool,
        ) -> Out8;

        /// Which of the 8 `pairs` touch (bit `l`: `pairs[l]`), [`touch_lanes`].
        ///
        /// # Safety
        /// The target features of the implementing path; every particle index of `pairs`
        /// in bounds of `s.packed`.
        unsafe fn touch8(pairs: &[Pair], s: Particles) -> u8;
    }

    /// 8 rows of 4 doubles (`a[l]`, lane `l`) as 4 vectors of 8 lanes (vector `c` holds
    /// element `c` of every row): 4 inserts, 4 unpacks and 4 two-source permutes.
    #[inline(always)]
    unsafe fn transpose8x4(a: [__m256d; 8]) -> [F8; 4] {
        let z0 = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(a[0]), a[4]);
        let z1 = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(a[1]), a[5]);
        let z2 = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(a[2]), a[6]);
        let z3 = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(a[3]), a[7]);
        // u0 = [a0.0 a1.0 a0.2 a1.2 | a4.0 a5.0 a4.2 a5.2], u1 likewise with elements 1, 3
        let u0 = _mm512_unpacklo_pd(z0, z1);
        let u1 = _mm512_unpackhi_pd(z0, z1);
        let u2 = _mm512_unpacklo_pd(z2, z3);
        let u3 = _mm512_unpackhi_pd(z2, z3);
        let lo = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0);
        let hi = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);
        [
            F8(_mm512_permutex2var_pd(u0, lo, u2)),
            F8(_mm512_permutex2var_pd(u1, lo, u3)),
            F8(_mm512_permutex2var_pd(u0, hi, u2)),
            F8(_mm512_permutex2var_pd(u1, hi, u3)),
        ]
    }

    /// Which of `pairs` (one per lane of `L`) touch: [`batch::touching`] on the rows of the
    /// packed records (`[x r]`) and the pair records (`[i j | shift]`). Measured on the fast
    /// state (1 thread, avx512, alternating every 250 steps in one process with the test one
    /// pair at a time): 0.4-1.0 % less time per step (2.4 % on the AVX2 path).
    ///
    /// # Safety
    /// The target features of `L`; every particle index of `pairs` in bounds of `s.packed`.
    #[inline(always)]
    unsafe fn touch_lanes<L: Rows + Lanes>(pairs: &[Pair], s: Particles) -> L::M {
        let n = pairs.len();
        let [pi, pj, pp] = record_ptrs(pairs.iter(), s);
        let [xi0, xi1, xi2, radi] = L::rows(&pi[..n]);
        let [xj0, xj1, xj2, radj] = L::rows(&pj[..n]);
        let [_, s0, s1, s2] = L::rows(&pp[..n]);
        batch::touching([xi0, xi1, xi2], [xj0, xj1, xj2], [s0, s1, s2], radi, radj)
    }

    /// Per lane (at most 8), the addresses of its pair's records: its `i`'s and its `j`'s
    /// packed particle records, and the pair record.
    ///
    /// # Safety
    /// Every particle index of the pairs in bounds of `s.packed`.
    #[inline(always)]
    unsafe fn record_ptrs<'a>(
        lanes: impl Iterator<Item = &'a Pair>,
        s: Particles,
    ) -> [[*const f64; 8]; 3] {
        let mut at = [[std::ptr::null(); 8]; 3];
        for (l, p) in lanes.enumerate() {
            at[0][l] = s.packed.get_unchecked(p.i as usize).0.as_ptr();
            at[1][l] = s.packed.get_unchecked(p.j as usize).0.as_ptr();
            at[2][l] = p as *const Pair as *const f64;
        }
        at
    }

    /// Lanes that load 32-byte rows and transpose them ([`lane_inputs`]).
    pub(super) trait Rows: Copy {
        /// The rows at `at[l]` (lane `l`, one per lane) as 4 vectors of lanes, vector `c`
        /// holding element `c` of every row.
        ///
        /// # Safety
        /// The target features of the lanes; 32 readable bytes at each pointer, as many
        /// pointers as lanes.
        unsafe fn rows(at: &[*const f64]) -> [Self; 4];
    }

    impl Rows for F8 {
        #[inline(always)]
        unsafe fn rows(at: &[*const f64]) -> [F8; 4] {
            transpose8x4(std::array::from_fn(|l| _mm256_loadu_pd(at[l])))
        }
    }

    impl Rows for F4 {
        #[inline(always)]
        unsafe fn rows(at: &[*const f64]) -> [F4; 4] {
            transpose4x4(std::array::from_fn(|l| _mm256_loadu_pd(at[l])))
        }
    }

    /// The kernel's inputs of the pairs `ks` (indices into `pairs` and `hist`, one per lane
    /// of `L`): every row a lane needs is loaded whole (32 bytes) from the particles' packed
    /// records (`[x r | v m | w 0]`, [`super::Packed`]), the pair record (`[i j | shift]`)
    /// and the history (`[shear | r_torque]`, read as its first and last 32 bytes), and
    /// transposed into vectors of lanes ([`Rows`]). Measured on the fast state (1 thread,
    /// avx512, alternating every 250 steps in one process with lane arrays filled by 31
    /// scalar copies per lane): 19-20 % less time per step (the copies were bound by their
    /// stores, which the kernel's vector loads then waited for).
    ///
    /// # Safety
    /// As [`Eval8::eval8`], with the target features of `L`.
    #[inline(always)]
    unsafe fn lane_inputs<L: Rows>(
        ks: &[u16],
        pairs: &[Pair],
        hist: &[ContactHistory],
        s: Particles,
    ) -> PairIn<L> {
        let n = ks.len();
        let [pi, pj, pp] = record_ptrs(ks.iter().map(|&k| &pairs[k as usize]), s);
        let ph: [*const f64; 8] = std::array::from_fn(|l| match ks.get(l) {
            Some(&k) => &hist[k as usize] as *const ContactHistory as *const f64,
            None => std::ptr::null(),
        });
        let at = |base: &[*const f64; 8], off: usize| -> [*const f64; 8] {
            std::array::from_fn(|l| base[l].wrapping_add(off))
        };
        let [xi0, xi1, xi2, radi] = L::rows(&at(&pi, 0)[..n]);
        let [vi0, vi1, vi2, mi] = L::rows(&at(&pi, 4)[..n]);
        let [wi0, wi1, wi2, _] = L::rows(&at(&pi, 8)[..n]);
        let [xj0, xj1, xj2, radj] = L::rows(&at(&pj, 0)[..n]);
        let [vj0, vj1, vj2, mj] = L::rows(&at(&pj, 4)[..n]);
        let [wj0, wj1, wj2, _] = L::rows(&at(&pj, 8)[..n]);
        let [_, s0, s1, s2] = L::rows(&pp[..n]);
        let [sh0, sh1, sh2, rt0] = L::rows(&ph[..n]);
        let [_, _, rt1, rt2] = L::rows(&at(&ph, 2)[..n]);
        PairIn {
            xi: [xi0, xi1, xi2],
            xj: [xj0, xj1, xj2],
            shift: [s0, s1, s2],
            radi,
            radj,
            mi,
            mj,
            vi: [vi0, vi1, vi2],
            vj: [vj0, vj1, vj2],
            wi: [wi0, wi1, wi2],
            wj: [wj0, wj1, wj2],
            shear: [sh0, sh1, sh2],
            r_torque: [rt0, rt1, rt2],
        }
    }

    /// 4 rows of 4 doubles (`a[l]`, lane `l`) as 4 vectors of 4 lanes (vector `c` holds
    /// element `c` of every row): 4 unpacks and 4 lane permutes.
    #[inline(always)]
    unsafe fn transpose4x4(a: [__m256d; 4]) -> [F4; 4] {
        // t0 = [a0.0 a1.0 a0.2 a1.2], t1 likewise with elements 1, 3
        let t0 = _mm256_unpacklo_pd(a[0], a[1]);
        let t1 = _mm256_unpackhi_pd(a[0], a[1]);
        let t2 = _mm256_unpacklo_pd(a[2], a[3]);
        let t3 = _mm256_unpackhi_pd(a[2], a[3]);
        [
            F4(_mm256_permute2f128_pd::<0x20>(t0, t2)),
            F4(_mm256_permute2f128_pd::<0x20>(t1, t3)),
            F4(_mm256_permute2f128_pd::<0x31>(t0, t2)),
            F4(_mm256_permute2f128_pd::<0x31>(t1, t3)),
        ]
    }

    /// Two vectors of 3 components (`a`, `b`) of 8 lanes as 8 rows `[a0 a1 a2 b0 b1 b2 0 0]`
    /// (row `l`: lane `l`), an 8x8 transpose with two zero vectors: 6 unpacks, 8 two-source
    /// permutes and 8 128-bit-block shuffles. A row is then one particle's increment
    /// ([`ForceData`]: force, torque) or one history ([`ContactHistory`]: shear, rolling
    /// torque), read whole by the write-back instead of 6 scalars from 6 lane arrays.
    #[inline(always)]
    unsafe fn rows6x8(a: [F8; 3], b: [F8; 3]) -> [[f64; 8]; 8] {
        let v = [a[0].0, a[1].0, a[2].0, b[0].0, b[1].0, b[2].0];
        let z = _mm512_setzero_pd();
        // t0 = [v0.0 v1.0 v0.2 v1.2 v0.4 v1.4 v0.6 v1.6], t1 the odd elements; likewise
        // (v2, v3) and (v4, v5); (v6, v7) are zero
        let t = [
            _mm512_unpacklo_pd(v[0], v[1]),
            _mm512_unpackhi_pd(v[0], v[1]),
            _mm512_unpacklo_pd(v[2], v[3]),
            _mm512_unpackhi_pd(v[2], v[3]),
            _mm512_unpacklo_pd(v[4], v[5]),
            _mm512_unpackhi_pd(v[4], v[5]),
        ];
        // u0 = [v0.0 v1.0 v2.0 v3.0 v0.4 v1.4 v2.4 v3.4] (elements 0 and 4 of v0-v3), u1
        // elements 1 and 5, u2 2 and 6, u3 3 and 7; u4-u7 the same of v4-v7
        let ev = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0);
        let od = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);
        let u = [
            _mm512_permutex2var_pd(t[0], ev, t[2]),
            _mm512_permutex2var_pd(t[1], ev, t[3]),
            _mm512_permutex2var_pd(t[0], od, t[2]),
            _mm512_permutex2var_pd(t[1], od, t[3]),
            _mm512_permutex2var_pd(t[4], ev, z),
            _mm512_permutex2var_pd(t[5], ev, z),
            _mm512_permutex2var_pd(t[4], od, z),
            _mm512_permutex2var_pd(t[5], od, z),
        ];
        // row r < 4: the low halves of u[r] and u[r + 4]; row r + 4 the high halves
        let lo = |k: usize| _mm512_shuffle_f64x2::<0b01_00_01_00>(u[k], u[k + 4]);
        let hi = |k: usize| _mm512_shuffle_f64x2::<0b11_10_11_10>(u[k], u[k + 4]);
        let rows = [lo(0), lo(1), lo(2), lo(3), hi(0), hi(1), hi(2), hi(3)];
        rows.map(|r| F8(r).to_array())
    }

    /// [`rows6x8`] for 4 lanes: rows `[a0 a1 a2 b0 b1 b2 0 0]` into `dst` (4 rows), two 4x4
    /// transposes.
    #[inline(always)]
    unsafe fn rows6x4(dst: &mut [[f64; 8]], a: [F4; 3], b: [F4; 3]) {
        let z = _mm256_setzero_pd();
        let front = transpose4x4([a[0].0, a[1].0, a[2].0, b[0].0]);
        let back = transpose4x4([b[1].0, b[2].0, z, z]);
        for (l, row) in dst.iter_mut().enumerate().take(4) {
            front[l].store(&mut row[..4]);
            back[l].store(&mut row[4..]);
        }
    }

    /// AVX-512: the 8 lanes in one vector.
    pub(super) struct Avx512;
    /// AVX2: the 8 lanes as two vectors of 4, lanes 0-3 then 4-7.
    pub(super) struct Avx2;

    impl Eval8 for Avx512 {
        #[inline(always)]
        unsafe fn touch8(pairs: &[Pair], s: Particles) -> u8 {
            touch_lanes::<F8>(pairs, s).bits()
        }

        #[inline(always)]
        unsafe fn eval8(
            ks: &[u16],
            pairs: &[Pair],
            hist: &[ContactHistory],
            s: Particles,
            params: &PairParams,
            update_history: bool,
        ) -> Out8 {
            let inp = lane_inputs::<F8>(ks, pairs, hist, s);
            let o = batch::pair(&inp, params, update_history);
            let arr = |v: [F8; 3]| [v[0].to_array(), v[1].to_array(), v[2].to_array()];
            Out8 {
                di: rows6x8(o.fi, o.ti),
                dj: rows6x8(o.fj, o.tj),
                hist: rows6x8(o.shear, o.r_torque),
                en: arr(o.en),
                damping: o.damping.to_array(),
                touch: o.touch.bits(),
                mobilised: o.mobilised.bits(),
                sliding: o.sliding.bits(),
            }
        }
    }

    impl Eval8 for Avx2 {
        #[inline(always)]
        unsafe fn touch8(pairs: &[Pair], s: Particles) -> u8 {
            touch_lanes::<F4>(&pairs[..4], s).bits() | touch_lanes::<F4>(&pairs[4..], s).bits() << 4
        }

        #[inline(always)]
        unsafe fn eval8(
            ks: &[u16],
            pairs: &[Pair],
            hist: &[ContactHistory],
            s: Particles,
            params: &PairParams,
            update_history: bool,
        ) -> Out8 {
            let mut r = Out8 {
                di: [[0.0; 8]; 8],
                dj: [[0.0; 8]; 8],
                hist: [[0.0; 8]; 8],
                en: [[0.0; 8]; 3],
                damping: [0.0; 8],
                touch: 0,
                mobilised: 0,
                sliding: 0,
            };
            for half in [0, 4] {
                let inp = lane_inputs::<F4>(&ks[half..half + 4], pairs, hist, s);
                let o = batch::pair(&inp, params, update_history);
                let put = |dst: &mut [[f64; 8]; 3], v: [F4; 3]| {
                    for c in 0..3 {
                        v[c].store(&mut dst[c][half..half + 4]);
                    }
                };
                rows6x4(&mut r.di[half..half + 4], o.fi, o.ti);
                rows6x4(&mut r.dj[half..half + 4], o.fj, o.tj);
                rows6x4(&mut r.hist[half..half + 4], o.shear, o.r_torque);
                put(&mut r.en, o.en);
                o.damping.store(&mut r.damping[half..half + 4]);
                r.touch |= o.touch.bits() << half;
                r.mobilised |= o.mobilised.bits() << half;
                r.sliding |= o.sliding.bits() << half;
            }
            r
        }
    }

    /// [`chunk`] on `path`'s lanes.
    ///
    /// # Safety
    /// `path` is [`KernelPath::Avx512`] or [`KernelPath::Avx2`] and runs on this CPU; the
    /// rest as [`chunk`].
    pub(super) unsafe fn chunk_on(
        path: KernelPath,
        pc: Piece,
        sink: &mut Sink,
        s: Particles,
        params: &PairParams,
        update_history: bool,
    ) {
        match path {
            KernelPath::Avx512 => chunk_avx512(pc, sink, s, params, update_history),
            KernelPath::Avx2 => chunk_avx2(pc, sink, s, params, update_history),
            KernelPath::Scalar => unreachable!("the scalar path has no SIMD chunk"),
        }
    }

    /// The entry of one width: [`chunk`] compiled with the width's target features.
    macro_rules! entry {
        ($name:ident, $features:literal, $width:ty) => {
            /// [`chunk`] with this width's lanes.
            ///
            /// # Safety
            #[doc = concat!("The CPU has ", $features, "; the rest as [`chunk`].")]
            #[target_feature(enable = $features)]
            unsafe fn $name(
                pc: Piece,
                sink: &mut Sink,
                s: Particles,
                params: &PairParams,
                update_history: bool,
            ) {
                chunk::<$width>(pc, sink, s, params, update_history)
            }
        };
    }
    entry!(chunk_avx512, "avx512f,avx512dq", Avx512);
    entry!(chunk_avx2, "avx,avx2", Avx2);

    /// Asks the caches for the records of the `j` particles of `pairs` (the next piece's,
    /// 8 at a time, one piece ahead): the particle record ([`super::Packed`], 96 bytes, two
    /// cache lines) and the particle's sum (48 bytes, one or two lines). A pair's `i` runs
    /// through the particles in order, which the hardware prefetcher follows; its `j` lies
    /// within a few hundred particles of it in any order, and at 250,000 particles
    /// (records and sums about 36 MB, beyond L3) perf put a third of the pass on the first
    /// touch of `j`'s sum. Prefetches only: no value changes.
    #[inline(always)]
    unsafe fn prefetch_records(pairs: &[Pair], s: Particles, sums: *const ForceData) {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        for p in pairs {
            let j = p.j as usize;
            debug_assert!(j < s.packed.len());
            let rec = s.packed.as_ptr().add(j) as *const i8;
            _mm_prefetch::<_MM_HINT_T0>(rec);
            _mm_prefetch::<_MM_HINT_T0>(rec.add(95));
            let sum = sums.add(j) as *const i8;
            _mm_prefetch::<_MM_HINT_T0>(sum);
            _mm_prefetch::<_MM_HINT_T0>(sum.add(47));
        }
    }

    /// The pairs of one piece: first which of them touch (8 at a time on lanes of `E`, the
    /// last few one at a time: the kernel's own test [`batch::touching`] on the same
    /// operations, so the same answer); then the
    /// touching ones, 8 at a time, through [`batch::pair`] (8 lanes of `E`), their
    /// increments added to `sum` in pair order when given (the serial pass) and written to
    /// `out` when it is held (the parallel pass, which sums afterwards, and observers), the
    /// dashpot to `damp` when held (epsd_implicit); the apart pairs' slots cleared. A last
    /// group's missing lanes repeat earlier pairs of the piece and are not written back.
    ///
    /// # Safety
    /// The target features of `E` (entered through [`chunk_avx512`], [`chunk_avx2`]); the
    /// piece's slices as [`Piece`] says, at most [`CHUNK`] pairs; particle indices in
    /// bounds of `s` (whose `packed` records are current).
    #[inline(always)]
    unsafe fn chunk<E: Eval8>(
        pc: Piece,
        sink: &mut Sink,
        s: Particles,
        params: &PairParams,
        update_history: bool,
    ) {
        let Piece {
            pairs,
            ahead,
            hist,
            state,
            out,
            out_apart,
            damp,
        } = pc;
        let (held, implicit) = (!out.is_empty(), !damp.is_empty());
        let n = pairs.len();
        assert!(state.len() == n && hist.len() == n && n <= CHUNK);
        assert!((!held || out.len() == n) && (!implicit || damp.len() == n));
        let np = s.x.len();
        assert!(s.v.len() == np && s.omega.len() == np && s.radius.len() == np);
        assert!(s.mass.len() == np && s.packed.len() == np);
        // 1. which pairs touch; every state (and recorded force) slot starts cleared, the
        // touching pairs' are written in step 2
        state.fill(PairState::default());
        damp.fill(PairDamp::default());
        if out_apart {
            out.fill(Default::default());
        }
        // (8 spare slots: the last group of step 2 reads 8 and writes back `count`)
        let mut touching = [0u16; CHUNK + 8];
        let mut nt = 0;
        // 8 pairs at a time on lanes, the rest one at a time
        let whole = n / 8 * 8;
        let sums = sink.sums_ptr();
        for k0 in (0..whole).step_by(8) {
            prefetch_records(ahead.get(k0..k0 + 8).unwrap_or_default(), s, sums);
            let m = E::touch8(pairs.get_unchecked(k0..k0 + 8), s);
            for l in 0..8 {
                // appended without a branch: the slot is overwritten unless the pair touches
                touching[nt] = (k0 + l) as u16;
                nt += usize::from((m >> l) & 1);
            }
        }
        for (k, p) in pairs.iter().enumerate().skip(whole) {
            let (i, j) = (p.i as usize, p.j as usize);
            debug_assert!(i < np && j < np);
            let t = batch::touching::<f64>(
                *s.x.get_unchecked(i),
                *s.x.get_unchecked(j),
                p.shift,
                *s.radius.get_unchecked(i),
                *s.radius.get_unchecked(j),
            );
            // appended without a branch: the slot is overwritten unless the pair touches
            touching[nt] = k as u16;
            nt += usize::from(t);
        }
        // 2. the touching pairs
        let mut t0 = 0;
        while t0 < nt {
            let count = (nt - t0).min(8);
            // lanes beyond `count` hold earlier or zero indices of this chunk: valid pairs,
            // computed and not written back
            let ks = &touching[t0..t0 + 8];
            let rows = E::eval8(ks, pairs, hist, s, params, update_history);
            let en = &rows.en;
            let damping = rows.damping;
            let (touch, mob, slide) = (rows.touch, rows.mobilised, rows.sliding);
            for (l, &k) in ks[..count].iter().enumerate() {
                let k = k as usize;
                let at = |a: &[[f64; 8]; 3]| [a[0][l], a[1][l], a[2][l]];
                let row = |r: &[f64; 8]| ([r[0], r[1], r[2]], [r[3], r[4], r[5]]);
                let force = |r: &[f64; 8]| {
                    let (delta_f, delta_torque) = row(r);
                    ForceData {
                        delta_f,
                        delta_torque,
                    }
                };
                let (di, dj) = (force(&rows.di[l]), force(&rows.dj[l]));
                let p = pairs.get_unchecked(k);
                let o = if held { Some(&mut out[k]) } else { None };
                sink.deliver(p.i as usize, p.j as usize, &di, &dj, o, out_apart);
                let bit = |m: u8| (m >> l) & 1 == 1;
                debug_assert!(bit(touch));
                state[k] = PairState {
                    contact: match (bit(touch), bit(mob)) {
                        (false, _) => PairContact::Apart,
                        (true, false) => PairContact::Touching,
                        (true, true) => PairContact::RollingMobilised,
                    },
                    sliding: bit(slide),
                };
                if implicit {
                    damp[k] = PairDamp {
                        damping: damping[l],
                        en: at(en),
                    };
                }
                if update_history {
                    let (shear, r_torque) = row(&rows.hist[l]);
                    *hist.get_unchecked_mut(k) = ContactHistory { shear, r_torque };
                }
            }
            t0 += count;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::ShearSim;
    use super::*;
    use crate::packing::loose_packing;
    use crate::spec::shear::{Preset, ShearCase};
    use crate::spec::RollingModel;

    /// A dense sheared ci-preset state of `model` (mu_r 0.5, restitution `e`, eta_r `eta`
    /// where it applies): compacted, then sheared so that contacts carry built-up, capped and
    /// new histories.
    fn sheared(model: RollingModel, e: f64, eta: f64) -> ShearSim {
        let eta = if model.has_damping() { eta } else { 0.0 };
        let c = ShearCase::preset(Preset::Ci, model, 0.5, eta, 2)
            .unwrap()
            .with_restitution("e", e)
            .unwrap();
        let mut s = ShearSim::new(&c, &loose_packing(&c));
        s.setup(0.0).unwrap();
        for _ in 0..c.compression_steps {
            s.step().unwrap();
        }
        s.setup(c.stages[0].speed).unwrap();
        for _ in 0..3000 {
            s.step().unwrap();
        }
        s
    }

    /// sysfs spells cache sizes with a unit letter; anything else is not a size.
    #[test]
    fn cache_sizes_parse() {
        assert_eq!(parse_cache_size("1024K\n"), Some(1 << 20));
        assert_eq!(parse_cache_size("2M"), Some(2 << 20));
        assert_eq!(parse_cache_size("65536"), Some(65536));
        assert_eq!(parse_cache_size("big"), None);
        assert!(!prefetch_pays(2500) || l2_bytes() < 2500 * 144);
    }

    /// With many members a particle can have pairs in three blocks or more: the block of its
    /// first pair sums the prefix of its pair sum, the later blocks' increments are added
    /// from `out` ([`BlockPlan::first`]). One force evaluation of a dense sheared state on 1
    /// and on 7 threads: equal bits, with such particles present.
    #[test]
    fn pair_sums_across_three_blocks_give_the_serial_bits() {
        let base = sheared(RollingModel::Epsd, 1.0, 0.5);
        let on = |threads: usize| {
            crate::solver::team::on_threads(threads, || {
                let mut s = base.clone();
                s.evaluate_forces().unwrap();
                s
            })
        };
        let (one, seven) = (on(1), on(7));
        let (nl, cut) = (&seven.nl, &seven.plan.cut);
        assert_eq!(cut.len(), 8, "one block per member");
        let blocks = |q: usize| {
            let entries = &nl.entries[nl.start[q] as usize..nl.start[q + 1] as usize];
            let mut b: Vec<usize> = entries
                .iter()
                .map(|&(k, _)| block_of(cut, k as usize))
                .collect();
            b.dedup();
            b.len()
        };
        let spread = (0..seven.x.len()).filter(|&q| blocks(q) >= 3).count();
        assert!(spread > 0, "no particle with pairs in three blocks");
        let bits = |s: &ShearSim| {
            let v: Vec<u64> = (s.f.iter().chain(&s.torque))
                .flatten()
                .chain(s.top_force.iter().chain(&s.bottom_force))
                .map(|x| x.to_bits())
                .collect();
            v
        };
        assert!(bits(&one) == bits(&seven), "7 threads differ from 1");
        assert!(one.f.iter().flatten().any(|&x| x != 0.0));
    }

    /// Each SIMD path this CPU runs against the scalar one over every listed pair of dense
    /// sheared states of every rolling model, with and without history update, then 200
    /// whole steps each: equal bits everywhere. Two materials: the paper's (e = 1, eta_r
    /// 0.5) and a damped one without rolling dashpot (e = 0.5, eta_r 0), which take
    /// different branches of the kernel.
    #[test]
    fn simd_passes_give_the_scalar_bits_on_dense_sheared_states() {
        let simd: Vec<_> = KernelPath::available()
            .into_iter()
            .filter(|&k| k != KernelPath::Scalar)
            .collect();
        for k in [KernelPath::Avx2, KernelPath::Avx512] {
            assert_eq!(k.checked("kernel").is_ok(), simd.contains(&k));
            if !simd.contains(&k) {
                // said, not passed over: this run does not test that path
                eprintln!(
                    "{k:?} is not on this CPU: its pair pass is NOT tested by this run (only on a CPU that has it)"
                );
            }
        }
        if simd.is_empty() {
            // the scalar path is the only one here; the rest of the suite tests it
            eprintln!("neither AVX2 nor AVX-512 on this CPU: only the scalar path exists here");
            return;
        }
        for (model, e, eta, path) in RollingModel::ALL
            .into_iter()
            .flat_map(|m| [(m, 1.0, 0.5), (m, 0.5, 0.0)])
            .flat_map(|(m, e, eta)| simd.iter().map(move |&p| (m, e, eta, p)))
        {
            let mut base = sheared(model, e, eta);
            // contacts that start now (zero history) besides the built-up ones: every 7th pair
            for h in base.nl.hist.iter_mut().step_by(7) {
                *h = Default::default();
            }
            let (mut touching, mut sliding, mut mobilised, mut fresh) = (0, 0, 0, 0);
            for update in [true, false] {
                let mut a = base.clone();
                let mut b = base.clone();
                a.set_kernel(KernelPath::Scalar).unwrap();
                b.set_kernel(path).unwrap();
                // the next piece's records prefetched or not (a few thousand particles
                // are too few for it to pay): the same bits either way
                b.plan.prefetch = Some(update);
                a.record_pair_forces = true;
                b.record_pair_forces = true;
                a.compute_forces(update).unwrap();
                b.compute_forces(update).unwrap();
                assert_eq!(a.nl.pairs.len(), b.nl.pairs.len());
                for k in 0..a.nl.pairs.len() {
                    let (pa, pb) = (&a.nl.hist[k], &b.nl.hist[k]);
                    let bits = |h: &crate::solver::contact::ContactHistory| {
                        (h.shear.map(f64::to_bits), h.r_torque.map(f64::to_bits))
                    };
                    assert_eq!(bits(pa), bits(pb), "{model:?} pair {k} history");
                    let fb = |f: &(ForceData, ForceData)| {
                        [f.0.delta_f, f.0.delta_torque, f.1.delta_f, f.1.delta_torque]
                            .map(|v| v.map(f64::to_bits))
                    };
                    assert_eq!(
                        fb(&a.pair_force[k]),
                        fb(&b.pair_force[k]),
                        "{model:?} pair {k} forces"
                    );
                    let (xa, xb) = (&a.pair_state[k], &b.pair_state[k]);
                    assert_eq!(xa, xb, "{model:?} pair {k} state");
                    assert_eq!(a.pair_damp.len(), b.pair_damp.len());
                    // the dashpot slots are held by epsd_implicit only
                    assert_eq!(a.pair_damp.is_empty(), model != RollingModel::EpsdImplicit);
                    if let (Some(da), Some(db)) = (a.pair_damp.get(k), b.pair_damp.get(k)) {
                        assert_eq!(da.damping.to_bits(), db.damping.to_bits());
                        assert_eq!(da.en.map(f64::to_bits), db.en.map(f64::to_bits));
                    }
                    if update && xa.contact != PairContact::Apart {
                        touching += 1;
                        sliding += usize::from(xa.sliding);
                        mobilised += usize::from(xa.contact == PairContact::RollingMobilised);
                        fresh += usize::from(base.nl.hist[k] == Default::default());
                    }
                }
                assert_eq!(a.f.len(), b.f.len());
                for (fa, fb) in a.f.iter().zip(&b.f) {
                    assert_eq!(fa.map(f64::to_bits), fb.map(f64::to_bits));
                }
            }
            // the states exercise what the kernel branches on
            assert!(touching > 200, "{model:?}: {touching} touching pairs");
            assert!(sliding > 0, "{model:?}: no sliding contact");
            assert!(fresh > 0, "{model:?}: no new contact");
            if model != RollingModel::Off {
                assert!(mobilised > 0, "{model:?}: no contact at the rolling limit");
            }
            let mut a = base.clone();
            let mut b = base;
            a.set_kernel(KernelPath::Scalar).unwrap();
            b.set_kernel(path).unwrap();
            b.plan.prefetch = Some(true);
            for _ in 0..200 {
                a.step().unwrap();
                b.step().unwrap();
            }
            for (xa, xb) in a.x.iter().zip(&b.x).chain(a.omega.iter().zip(&b.omega)) {
                assert_eq!(xa.map(f64::to_bits), xb.map(f64::to_bits), "{model:?}");
            }
            eprintln!(
                "{} {model:?}, e {e}, eta_r {eta}: {touching} touching, {sliding} sliding, {mobilised} at the \
                 rolling limit, {fresh} new: equal bits",
                path.name()
            );
        }
    }
}
