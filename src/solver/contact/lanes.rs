//! Lane arithmetic for batched contact kernels: one generic kernel body, instantiated for a
//! single contact (`f64`, masks `bool`), for 8 contacts at once (AVX-512, [`F8`]) and for 4
//! (AVX2, [`F4`], on CPUs without AVX-512).
//!
//! Bit-identity with the scalar kernels rests on three facts, each kept here:
//! - every operation is one IEEE operation per lane in the scalar order: `+ - * /` and `sqrt`
//!   are correctly rounded in AVX-512 and AVX as in scalar SSE2, and nothing is fused (no FMA: Rust
//!   never contracts, and these wrappers call the separate add and multiply instructions);
//! - negation and `abs` flip or clear the sign bit, as Rust's `-x` and `f64::abs` do (not
//!   `0 - x`, which differs for zeros);
//! - comparisons keep Rust's NaN semantics: `<`, `<=`, `>`, `>=` are false on NaN (ordered
//!   predicates), `!=` is true on NaN (unordered predicate).
//!
//! Why no safe call can run an instruction the CPU lacks: a value of [`F8`] (AVX-512) or
//! [`F4`] (AVX) is made only by an `unsafe` constructor ([`F8::load`], [`F8::gather`],
//! [`F8::from_raw`], [`F4::load`], [`F4::from_raw`]), whose caller states that the CPU has the
//! features (the pair passes, after `is_x86_feature_detected!`), or from values that already
//! exist: the operators, [`Lanes::splat`] (which takes a value of its type as that proof) and
//! the comparisons (whose masks [`M8`], [`M4`] are likewise made only from vectors). Their
//! fields are private. So every safe method that executes AVX-512 or AVX has, in `self` or an
//! argument, a value whose existence proves the CPU runs it.
//!
//! Branches of the scalar code become masks: both sides are computed for every lane and
//! [`Lanes::select`] keeps the side the scalar code would have taken. A side that is not
//! taken may compute a NaN or an infinity (a division by zero), which is discarded; floating
//! point exceptions do not trap.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A mask of lanes (one `bool` per lane).
pub trait Mask: Copy {
    fn and(self, o: Self) -> Self;
    fn or(self, o: Self) -> Self;
    fn not(self) -> Self;
    /// Some lane is set: lets a kernel skip work whose result every lane would discard.
    fn any(self) -> bool;
}

impl Mask for bool {
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        self & o
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        self | o
    }
    #[inline(always)]
    fn not(self) -> Self {
        !self
    }
    #[inline(always)]
    fn any(self) -> bool {
        self
    }
}

/// Lanes of `f64`: the operations a contact kernel uses, each the IEEE operation per lane.
pub trait Lanes:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    type M: Mask;
    /// A vector of this type with `v` in every lane. `self` is not read: it is the proof
    /// that this type's instructions run on this CPU (module doc).
    fn splat(self, v: f64) -> Self;
    fn sqrt(self) -> Self;
    /// Clears the sign bit (`f64::abs`).
    fn abs(self) -> Self;
    /// `self > o`, false on NaN.
    fn gt(self, o: Self) -> Self::M;
    /// `self >= o`, false on NaN.
    fn ge(self, o: Self) -> Self::M;
    /// `self <= o`, false on NaN.
    fn le(self, o: Self) -> Self::M;
    /// `self != o`, true on NaN.
    fn ne(self, o: Self) -> Self::M;
    /// Per lane: `if m { t } else { f }`.
    fn select(m: Self::M, t: Self, f: Self) -> Self;
}

impl Lanes for f64 {
    type M = bool;
    #[inline(always)]
    fn splat(self, v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: Self) -> bool {
        self >= o
    }
    #[inline(always)]
    fn le(self, o: Self) -> bool {
        self <= o
    }
    #[inline(always)]
    fn ne(self, o: Self) -> bool {
        self != o
    }
    #[inline(always)]
    fn select(m: bool, t: Self, f: Self) -> Self {
        if m {
            t
        } else {
            f
        }
    }
}

/// Per-lane `select` of three-vectors.
#[inline(always)]
pub fn select3<L: Lanes>(m: L::M, t: [L; 3], f: [L; 3]) -> [L; 3] {
    [
        L::select(m, t[0], f[0]),
        L::select(m, t[1], f[1]),
        L::select(m, t[2], f[2]),
    ]
}

#[cfg(target_arch = "x86_64")]
pub use avx512::{F8, M8};

#[cfg(target_arch = "x86_64")]
mod avx512 {
    //! 8 lanes of f64 in one AVX-512 register. A value of [`F8`] exists only where the CPU
    //! has avx512f: it is made by an `unsafe` constructor that states so, or from an existing
    //! one (parent module doc). The wrappers are `#[inline(always)]` so that they are compiled
    //! into the `avx512f` function that uses them, with its target features.
    use super::{Lanes, Mask};
    use std::arch::x86_64::*;
    use std::ops::{Add, Div, Mul, Neg, Sub};

    #[derive(Clone, Copy)]
    pub struct F8(__m512d);

    /// A lane mask of [`F8`]: made only by comparing two of them.
    #[derive(Clone, Copy)]
    pub struct M8(__mmask8);

    impl Mask for M8 {
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            M8(self.0 & o.0)
        }
        #[inline(always)]
        fn or(self, o: Self) -> Self {
            M8(self.0 | o.0)
        }
        #[inline(always)]
        fn not(self) -> Self {
            M8(!self.0)
        }
        #[inline(always)]
        fn any(self) -> bool {
            self.0 != 0
        }
    }

    macro_rules! binop {
        ($tr:ident, $f:ident, $intr:ident) => {
            impl $tr for F8 {
                type Output = F8;
                #[inline(always)]
                fn $f(self, o: F8) -> F8 {
                    // SAFETY: `self` exists, so the CPU has avx512f (module doc).
                    F8(unsafe { $intr(self.0, o.0) })
                }
            }
        };
    }
    binop!(Add, add, _mm512_add_pd);
    binop!(Sub, sub, _mm512_sub_pd);
    binop!(Mul, mul, _mm512_mul_pd);
    binop!(Div, div, _mm512_div_pd);

    impl Neg for F8 {
        type Output = F8;
        #[inline(always)]
        fn neg(self) -> F8 {
            // SAFETY: `self` exists, so the CPU has avx512f (module doc). Flips the sign
            // bit, as Rust's `-x`.
            F8(unsafe {
                _mm512_castsi512_pd(_mm512_xor_si512(
                    _mm512_castpd_si512(self.0),
                    _mm512_set1_epi64(i64::MIN),
                ))
            })
        }
    }

    impl Lanes for F8 {
        type M = M8;
        #[inline(always)]
        fn splat(self, v: f64) -> Self {
            // SAFETY: `self` exists, so the CPU has avx512f (module doc).
            F8(unsafe { _mm512_set1_pd(v) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            // SAFETY: `self` exists, so the CPU has avx512f (module doc).
            F8(unsafe { _mm512_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn abs(self) -> Self {
            // SAFETY: `self` exists, so the CPU has avx512f (module doc).
            F8(unsafe { _mm512_abs_pd(self.0) })
        }
        #[inline(always)]
        fn gt(self, o: Self) -> M8 {
            // SAFETY: `self` exists, so the CPU has avx512f (module doc).
            M8(unsafe { _mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn ge(self, o: Self) -> M8 {
            // SAFETY: `self` exists, so the CPU has avx512f (module doc).
            M8(unsafe { _mm512_cmp_pd_mask::<_CMP_GE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> M8 {
            // SAFETY: `self` exists, so the CPU has avx512f (module doc).
            M8(unsafe { _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn ne(self, o: Self) -> M8 {
            // SAFETY: `self` exists, so the CPU has avx512f (module doc).
            M8(unsafe { _mm512_cmp_pd_mask::<_CMP_NEQ_UQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn select(m: M8, t: Self, f: Self) -> Self {
            // blend(k, a, b): b where k is set, else a
            // SAFETY: `t` exists, so the CPU has avx512f (module doc).
            F8(unsafe { _mm512_mask_blend_pd(m.0, f.0, t.0) })
        }
    }

    impl F8 {
        /// `base[idx[l]]` per lane (a gather).
        ///
        /// # Safety
        /// avx512f; every index in bounds of the allocation `base` points into.
        #[inline(always)]
        pub unsafe fn gather(base: *const f64, idx: __m512i) -> F8 {
            F8(_mm512_i64gather_pd::<8>(idx, base as *const _))
        }

        /// The 8 lanes from an array (lane `l` is `a[l]`).
        ///
        /// # Safety
        /// The CPU has avx512f.
        #[inline(always)]
        pub unsafe fn load(a: &[f64; 8]) -> F8 {
            F8(_mm512_loadu_pd(a.as_ptr()))
        }

        /// The vector of a register.
        ///
        /// # Safety
        /// The CPU has avx512f.
        #[inline(always)]
        pub unsafe fn from_raw(v: __m512d) -> F8 {
            F8(v)
        }

        /// The register of the vector.
        #[inline(always)]
        pub fn raw(self) -> __m512d {
            self.0
        }

        /// The 8 lanes as an array.
        #[inline(always)]
        pub fn to_array(self) -> [f64; 8] {
            let mut a = [0.0; 8];
            // SAFETY: an unaligned store of 64 bytes into a 64-byte array; `self` exists, so
            // the CPU has avx512f (module doc).
            unsafe { _mm512_storeu_pd(a.as_mut_ptr(), self.0) };
            a
        }
    }

    impl M8 {
        /// One bit per lane (lane 0 lowest).
        pub fn bits(self) -> u8 {
            self.0
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx2::{F4, M4};

#[cfg(target_arch = "x86_64")]
mod avx2 {
    //! 4 lanes of f64 in one AVX register (the path of CPUs with AVX2 but without AVX-512).
    //! As for [`super::F8`]: a value of [`F4`] exists only where the CPU has avx and avx2 (an
    //! `unsafe` constructor states so, or it is made from an existing one); the wrappers are
    //! `#[inline(always)]`. A mask is the comparison's result, all ones or all zeros per lane,
    //! made only by comparing two vectors.
    use super::{Lanes, Mask};
    use std::arch::x86_64::*;
    use std::ops::{Add, Div, Mul, Neg, Sub};

    #[derive(Clone, Copy)]
    pub struct F4(__m256d);

    #[derive(Clone, Copy)]
    pub struct M4(__m256d);

    impl Mask for M4 {
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            // SAFETY: `self` exists, so the CPU has avx (module doc).
            M4(unsafe { _mm256_and_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn or(self, o: Self) -> Self {
            // SAFETY: `self` exists, so the CPU has avx (module doc).
            M4(unsafe { _mm256_or_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn not(self) -> Self {
            // SAFETY: `self` exists, so the CPU has avx (module doc).
            M4(unsafe { _mm256_xor_pd(self.0, _mm256_castsi256_pd(_mm256_set1_epi64x(-1))) })
        }
        #[inline(always)]
        fn any(self) -> bool {
            // SAFETY: `self` exists, so the CPU has avx (module doc).
            unsafe { _mm256_movemask_pd(self.0) != 0 }
        }
    }

    macro_rules! binop {
        ($tr:ident, $f:ident, $intr:ident) => {
            impl $tr for F4 {
                type Output = F4;
                #[inline(always)]
                fn $f(self, o: F4) -> F4 {
                    // SAFETY: `self` exists, so the CPU has avx (module doc).
                    F4(unsafe { $intr(self.0, o.0) })
                }
            }
        };
    }
    binop!(Add, add, _mm256_add_pd);
    binop!(Sub, sub, _mm256_sub_pd);
    binop!(Mul, mul, _mm256_mul_pd);
    binop!(Div, div, _mm256_div_pd);

    impl Neg for F4 {
        type Output = F4;
        #[inline(always)]
        fn neg(self) -> F4 {
            // SAFETY: `self` exists, so the CPU has avx (module doc). Flips the sign bit,
            // as Rust's `-x`.
            F4(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
        }
    }

    impl Lanes for F4 {
        type M = M4;
        #[inline(always)]
        fn splat(self, v: f64) -> Self {
            // SAFETY: `self` exists, so the CPU has avx (module doc).
            F4(unsafe { _mm256_set1_pd(v) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            // SAFETY: `self` exists, so the CPU has avx and avx2 (module doc).
            F4(unsafe { _mm256_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn abs(self) -> Self {
            // clears the sign bit, as `f64::abs`
            // SAFETY: `self` exists, so the CPU has avx and avx2 (module doc).
            F4(unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0) })
        }
        #[inline(always)]
        fn gt(self, o: Self) -> M4 {
            // SAFETY: `self` exists, so the CPU has avx (module doc).
            M4(unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn ge(self, o: Self) -> M4 {
            // SAFETY: `self` exists, so the CPU has avx (module doc).
            M4(unsafe { _mm256_cmp_pd::<_CMP_GE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> M4 {
            // SAFETY: `self` exists, so the CPU has avx (module doc).
            M4(unsafe { _mm256_cmp_pd::<_CMP_LE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn ne(self, o: Self) -> M4 {
            // SAFETY: `self` exists, so the CPU has avx (module doc).
            M4(unsafe { _mm256_cmp_pd::<_CMP_NEQ_UQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn select(m: M4, t: Self, f: Self) -> Self {
            // blendv(a, b, m): b where the mask lane's sign bit is set, else a
            // SAFETY: `self` exists, so the CPU has avx and avx2 (module doc).
            F4(unsafe { _mm256_blendv_pd(f.0, t.0, m.0) })
        }
    }

    impl F4 {
        /// The 4 lanes from a slice's first 4 values (lane `l` is `a[l]`).
        ///
        /// # Safety
        /// The CPU has avx and avx2.
        #[inline(always)]
        pub unsafe fn load(a: &[f64]) -> F4 {
            assert!(a.len() >= 4);
            // an unaligned load of 32 bytes from at least 4 values
            F4(_mm256_loadu_pd(a.as_ptr()))
        }

        /// The vector of a register.
        ///
        /// # Safety
        /// The CPU has avx and avx2.
        #[inline(always)]
        pub unsafe fn from_raw(v: __m256d) -> F4 {
            F4(v)
        }

        /// The register of the vector.
        #[inline(always)]
        pub fn raw(self) -> __m256d {
            self.0
        }

        /// The 4 lanes into a slice's first 4 values.
        #[inline(always)]
        pub fn store(self, a: &mut [f64]) {
            assert!(a.len() >= 4);
            // SAFETY: an unaligned store of 32 bytes into at least 4 values; `self` exists,
            // so the CPU has avx (module doc).
            unsafe { _mm256_storeu_pd(a.as_mut_ptr(), self.0) };
        }
    }

    impl M4 {
        /// One bit per lane (lane 0 lowest).
        #[inline(always)]
        pub fn bits(self) -> u8 {
            // SAFETY: `self` exists, so the CPU has avx and avx2 (module doc).
            (unsafe { _mm256_movemask_pd(self.0) }) as u8
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_lanes_keep_rust_semantics() {
        assert!(!f64::NAN.ge(1.0));
        assert!(f64::NAN.ne(f64::NAN));
        assert_eq!((-0.0f64).abs().to_bits(), 0.0f64.to_bits());
        assert_eq!(<f64 as Lanes>::select(true, 1.0, 2.0), 1.0);
    }

    /// Every lane operation against the scalar one, lane by lane, bit for bit, on values
    /// with signed zeros, a NaN, subnormal-range products and an infinity.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn check_lanes<L: Lanes>(
        width: usize,
        load: impl Fn(&[f64]) -> L,
        store: impl Fn(L) -> Vec<f64>,
        mask_bits: impl Fn(L::M) -> u8,
    ) {
        let a = [1.0, -0.0, 0.0, f64::NAN, 3.5e-300, -7.25, 1e300, 2.0];
        let b = [3.0, 0.0, -0.0, 1.0, 1e-20, 0.1, 1e-300, f64::INFINITY];
        for at in (0..8).step_by(width) {
            let (a, b) = (&a[at..at + width], &b[at..at + width]);
            let (va, vb) = (load(a), load(b));
            let bits = |v: L| store(v).iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let each = |f: fn(f64, f64) -> f64| {
                (0..width)
                    .map(|l| f(a[l], b[l]).to_bits())
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(va + vb), each(|x, y| x + y));
            assert_eq!(bits(va - vb), each(|x, y| x - y));
            assert_eq!(bits(va * vb), each(|x, y| x * y));
            assert_eq!(bits(va / vb), each(|x, y| x / y));
            assert_eq!(bits(-va), each(|x, _| -x));
            assert_eq!(bits(va.abs()), each(|x, _| x.abs()));
            assert_eq!(bits(va.sqrt()), each(|x, _| x.sqrt()));
            let m = |mk: L::M, f: fn(f64, f64) -> bool| {
                (0..width).all(|l| ((mask_bits(mk) >> l) & 1 == 1) == f(a[l], b[l]))
            };
            assert!(m(va.gt(vb), |x, y| x > y));
            assert!(m(va.ge(vb), |x, y| x >= y));
            assert!(m(va.le(vb), |x, y| x <= y));
            assert!(m(va.ne(vb), |x, y| x != y));
            assert!(m(va.gt(vb).not(), |x, y| x.partial_cmp(&y)
                != Some(std::cmp::Ordering::Greater)));
            assert!(m(va.gt(vb).and(va.ne(vb)), |x, y| x > y && x != y));
            assert!(m(va.le(vb).or(va.ne(vb)), |x, y| x <= y || x != y));
            assert_eq!(va.ne(va).any(), a.iter().any(|x| x.is_nan()));
            let s = L::select(va.gt(vb), va, vb);
            assert_eq!(bits(va.splat(-0.0)), vec![(-0.0f64).to_bits(); width]);
            assert_eq!(bits(s), each(|x, y| if x > y { x } else { y }));
        }
    }

    // A path this build's CPU lacks (or DEM_VERIFY_MAX_KERNEL excludes) is listed as
    // ignored with its reason, never passed (build.rs sets path_avx2 / path_avx512).
    #[cfg(target_arch = "x86_64")]
    #[test]
    #[cfg_attr(
        not(path_avx512),
        ignore = "the AVX-512 path does not run here (no AVX-512F/DQ, or DEM_VERIFY_MAX_KERNEL)"
    )]
    fn avx512_lanes_give_the_scalar_bits() {
        assert!(
            std::arch::is_x86_feature_detected!("avx512f"),
            "built where AVX-512F runs, run where it does not: rebuild here"
        );
        // SAFETY: avx512f detected above.
        unsafe { check() }

        #[target_feature(enable = "avx512f")]
        unsafe fn check() {
            check_lanes(
                8,
                // SAFETY: avx512f detected by the caller
                |a| unsafe { F8::load(a.try_into().unwrap()) },
                |v| v.to_array().to_vec(),
                |m| m.bits(),
            );
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    #[cfg_attr(
        not(path_avx2),
        ignore = "the AVX2 path does not run here (no AVX2, or DEM_VERIFY_MAX_KERNEL)"
    )]
    fn avx2_lanes_give_the_scalar_bits() {
        assert!(
            std::arch::is_x86_feature_detected!("avx")
                && std::arch::is_x86_feature_detected!("avx2"),
            "built where AVX2 runs, run where it does not: rebuild here"
        );
        // SAFETY: avx2 detected above.
        unsafe { check() }

        #[target_feature(enable = "avx,avx2")]
        unsafe fn check() {
            check_lanes(
                4,
                // SAFETY: avx2 detected by the caller
                |a| unsafe { F4::load(a) },
                |v| {
                    let mut a = [0.0; 4];
                    v.store(&mut a);
                    a.to_vec()
                },
                |m| m.bits(),
            );
        }
    }
}
