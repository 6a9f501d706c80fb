//! What the pair pass hands its kernels and sums: the particle arrays ([`Particles`], and
//! [`Packed`] records for the SIMD paths), a piece of the pair list with its slots
//! ([`Piece`]) and the per-particle index ([`Csr`]). In a file of their own so that the
//! kernels (scalar, SIMD) and the sums import them and not the pass that runs them (issue
//! #38).

use super::super::neighbor::Pair;
use super::super::records::{PairDamp, PairState};
use crate::solver::contact::{ContactHistory, ForceData};
use crate::solver::vec3::V3;

/// The particle arrays a pair reads.
#[derive(Clone, Copy)]
pub(in crate::solver::shear) struct Particles<'a> {
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
pub(in crate::solver::shear) struct Packed(pub [f64; 12]);

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
pub(super) fn add_force(a: &mut ForceData, d: &ForceData) {
    for c in 0..3 {
        a.delta_f[c] += d.delta_f[c];
        a.delta_torque[c] += d.delta_torque[c];
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

/// The per-particle index of the pairs (`NeighborList::start`, `entries`).
#[derive(Clone, Copy)]
pub(in crate::solver::shear) struct Csr<'a> {
    pub start: &'a [u32],
    pub entries: &'a [(u32, bool)],
}

/// The first `len` items of `s` (all of an empty `s`: an unwritten array), `s` advanced past them.
pub(super) fn take_front<'a, T>(s: &mut &'a mut [T], len: usize) -> &'a mut [T] {
    if s.is_empty() {
        return &mut [];
    }
    let (a, b) = std::mem::take(s).split_at_mut(len);
    *s = b;
    a
}
