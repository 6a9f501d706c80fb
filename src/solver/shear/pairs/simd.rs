//! The SIMD pair pass (AVX2: 2 x 4 lanes, AVX-512: 8 lanes): touching pairs gathered into
//! lanes of packed records, [`batch::pair`] on them, the results written back per pair in
//! pair order; the same bits as the scalar pass.
//!
//! [`batch::pair`]: crate::solver::contact::batch::pair

use super::super::neighbor::Pair;
use super::super::records::{PairContact, PairDamp, PairState};
use super::data::{Particles, Piece};
use super::path::KernelPath;
use super::sums::{Sink, CHUNK};
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
///
/// # Safety
/// The CPU has avx512f.
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
        F8::from_raw(_mm512_permutex2var_pd(u0, lo, u2)),
        F8::from_raw(_mm512_permutex2var_pd(u1, lo, u3)),
        F8::from_raw(_mm512_permutex2var_pd(u0, hi, u2)),
        F8::from_raw(_mm512_permutex2var_pd(u1, hi, u3)),
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
///
/// # Safety
/// The CPU has avx.
#[inline(always)]
unsafe fn transpose4x4(a: [__m256d; 4]) -> [F4; 4] {
    // t0 = [a0.0 a1.0 a0.2 a1.2], t1 likewise with elements 1, 3
    let t0 = _mm256_unpacklo_pd(a[0], a[1]);
    let t1 = _mm256_unpackhi_pd(a[0], a[1]);
    let t2 = _mm256_unpacklo_pd(a[2], a[3]);
    let t3 = _mm256_unpackhi_pd(a[2], a[3]);
    [
        F4::from_raw(_mm256_permute2f128_pd::<0x20>(t0, t2)),
        F4::from_raw(_mm256_permute2f128_pd::<0x20>(t1, t3)),
        F4::from_raw(_mm256_permute2f128_pd::<0x31>(t0, t2)),
        F4::from_raw(_mm256_permute2f128_pd::<0x31>(t1, t3)),
    ]
}

/// Two vectors of 3 components (`a`, `b`) of 8 lanes as 8 rows `[a0 a1 a2 b0 b1 b2 0 0]`
/// (row `l`: lane `l`), an 8x8 transpose with two zero vectors: 6 unpacks, 8 two-source
/// permutes and 8 128-bit-block shuffles. A row is then one particle's increment
/// ([`ForceData`]: force, torque) or one history ([`ContactHistory`]: shear, rolling
/// torque), read whole by the write-back instead of 6 scalars from 6 lane arrays.
///
/// # Safety
/// The CPU has avx512f (proven by `a` and `b`, kept `unsafe` for the raw intrinsics).
#[inline(always)]
unsafe fn rows6x8(a: [F8; 3], b: [F8; 3]) -> [[f64; 8]; 8] {
    let v = [
        a[0].raw(),
        a[1].raw(),
        a[2].raw(),
        b[0].raw(),
        b[1].raw(),
        b[2].raw(),
    ];
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
    rows.map(|r| F8::from_raw(r).to_array())
}

/// [`rows6x8`] for 4 lanes: rows `[a0 a1 a2 b0 b1 b2 0 0]` into `dst` (4 rows), two 4x4
/// transposes.
///
/// # Safety
/// The CPU has avx (proven by `a` and `b`, kept `unsafe` for the raw intrinsics).
#[inline(always)]
unsafe fn rows6x4(dst: &mut [[f64; 8]], a: [F4; 3], b: [F4; 3]) {
    let z = _mm256_setzero_pd();
    let front = transpose4x4([a[0].raw(), a[1].raw(), a[2].raw(), b[0].raw()]);
    let back = transpose4x4([b[1].raw(), b[2].raw(), z, z]);
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
///
/// # Safety
/// Every pair's `j` is in bounds of `s.packed` and of the allocation `sums` points into (a
/// prefetch does not fault, but the addresses are formed with `add`).
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
