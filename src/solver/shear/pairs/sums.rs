//! Where the pair pass's increments go: each particle's sum made in pair order whatever
//! the thread count (blocks of pairs, their boundary particles' shares kept apart and added
//! in order).

use super::super::neighbor::Pair;
use super::super::records::{PairContact, PairDamp, PairState};
use super::data::{add_force, take_front, Csr, Piece};
use crate::solver::contact::{ContactHistory, ForceData};
use crate::solver::vec3::V3;

/// Where a piece's increments go.
pub(super) enum Sink<'a> {
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
    pub(super) fn sums_ptr(&self) -> *const ForceData {
        match self {
            Sink::Acc(acc) => acc.as_ptr(),
            Sink::Block { acc, .. } => acc.ptr,
        }
    }

    /// Delivers pair `k`'s increments `di` (to its `i`) and `dj` (to its `j`); `out` is the
    /// pair's slot when held, written whole when `record`.
    #[inline(always)]
    pub(super) fn deliver(
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
pub(super) struct SharedAcc<'a> {
    pub(super) ptr: *mut ForceData,
    pub(super) len: usize,
    pub(super) _sums: std::marker::PhantomData<&'a mut [ForceData]>,
}

// SAFETY: the blocks write disjoint elements (a particle's sum belongs to one block).
unsafe impl Send for SharedAcc<'_> {}
// SAFETY: as for Send: no two threads touch one element.
unsafe impl Sync for SharedAcc<'_> {}

impl<'a> SharedAcc<'a> {
    pub(super) fn new(acc: &'a mut [ForceData]) -> Self {
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
pub(in crate::solver::shear) enum Sums {
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
pub(in crate::solver::shear) struct BlockPlan {
    /// The list (its build in this process) and team size `first` was found for.
    pub(in crate::solver::shear) key: Option<(u64, usize)>,
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
pub(in crate::solver::shear) struct PairSums<'a> {
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
pub(super) const CHUNK: usize = 256;

/// [`BlockPlan::first`]'s flag of a particle with pairs in more than one block.
pub(super) const MIXED: u32 = 1 << 31;

/// The block holding pair `k`, the blocks starting at pairs `cut` (`cut[0]` = 0, the last
/// entry the list's length).
pub(super) fn block_of(cut: &[usize], k: usize) -> usize {
    cut[1..].partition_point(|&c| c <= k)
}

/// One thread's block of the pair list with its per-pair slots (`out`, `damp` empty where
/// not written), cut into [`Piece`]s as it is evaluated. Measured on the fast state (2
/// threads, avx512, 2 runs each): the pass's serial set-up 1.7-3.6 us per step with every
/// piece made beforehand in a vector per block, 0.7-1.1 us with the blocks cut lazily.
pub(super) struct Block<'a> {
    pub(super) pairs: &'a [Pair],
    pub(super) hist: &'a mut [ContactHistory],
    pub(super) state: &'a mut [PairState],
    pub(super) out: &'a mut [(ForceData, ForceData)],
    pub(super) damp: &'a mut [PairDamp],
    /// Apart pairs' `out` slots written too ([`Piece::out_apart`]).
    pub(super) record: bool,
    /// Each piece with the next one's pairs ([`Piece::ahead`]).
    pub(super) prefetch: bool,
}

impl<'a> Block<'a> {
    /// The block's pieces of [`CHUNK`] pairs in order.
    pub(super) fn pieces(self) -> impl Iterator<Item = Piece<'a>> {
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
