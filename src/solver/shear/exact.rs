//! The plate forces summed exactly, in any order (issue #39, docs/mpi.md): each particle's
//! share of the bottom and top plate forces is put on a fixed grid of 2^-80 N as a 128-bit
//! integer, the integers are added (integer addition is associative, so every split of the
//! particles over threads, bricks or ranks gives the same total), and the total is rounded to
//! f64 once. A decomposed run then sums its own particles' shares and adds the ranks' totals
//! with one all-reduce of a few hundred bytes ([`PlateSum::limbs`]), instead of sending every
//! particle's share to every rank to be added in id order.
//!
//! Error against the exact sum of the f64 shares: at most 2^-81 N per term from the grid
//! (4e-25 N; 30,000 plate particles give at most 1.2e-20 N) and half an ulp of the total from
//! the final rounding: below the one f64 rounding per addition of a sequential sum (at a
//! total of 100 N one ulp is 1.4e-14 N). LIGGGHTS sums in its own order (per processor, then
//! MPI_Allreduce), so no order is its bits; the replay compares to round-off.
//!
//! A share must be finite and below 2^46 N (7.0e13 N) in magnitude: then no sum of fewer than
//! 2^80 shares leaves the 128-bit range. Anything else makes the total an error (a diverged
//! run), never a silently wrong number.

use crate::solver::vec3::V3;

/// The grid: one unit is 2^-80 N.
const SCALE: f64 = (1u128 << 80) as f64;
/// The largest share magnitude taken [N]: 2^46.
pub const MAX_SHARE: f64 = (1u64 << 46) as f64;
/// 32-bit limbs of each 128-bit component, as [`PlateSum::limbs`] carries them.
const LIMBS: usize = 4;
/// Length of [`PlateSum::limbs`]: 6 components of 4 limbs and the error count.
pub const LIMB_LEN: usize = 6 * LIMBS + 1;

/// Bottom (components 0-2) and top (3-5) plate force sums on the 2^-80 N grid, with a count
/// of shares that could not be taken (not finite or too large).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlateSum {
    acc: [i128; 6],
    bad: u32,
}

impl PlateSum {
    /// Adds one particle's shares of the bottom and top plate forces.
    #[inline]
    pub fn add(&mut self, bottom: V3, top: V3) {
        for (a, &v) in self.acc.iter_mut().zip(bottom.iter().chain(top.iter())) {
            if v.abs() < MAX_SHARE {
                // exact: a power-of-two scale, an integer-valued f64 below 2^127
                *a = a.wrapping_add((v * SCALE).round() as i128);
            } else if v != 0.0 {
                // NaN, infinite or too large (`abs() < MAX_SHARE` is false for NaN)
                self.bad = self.bad.saturating_add(1);
            }
        }
    }

    /// The sum of two partial sums (in either order: the same bits).
    pub fn merge(&mut self, other: &PlateSum) {
        for (a, b) in self.acc.iter_mut().zip(other.acc) {
            *a = a.wrapping_add(b);
        }
        self.bad = self.bad.saturating_add(other.bad);
    }

    /// The totals (bottom, top) rounded to f64 once, or None when a share was not finite or
    /// beyond [`MAX_SHARE`].
    pub fn totals(&self) -> Option<(V3, V3)> {
        if self.bad > 0 {
            return None;
        }
        // `as f64` rounds to nearest; dividing by a power of two is exact here
        let f = |c: usize| self.acc[c] as f64 / SCALE;
        Some(([f(0), f(1), f(2)], [f(3), f(4), f(5)]))
    }

    /// The sum as 32-bit limbs in u64 words ([`LIMB_LEN`] of them): adding the limbs of any
    /// number of partial sums below 2^32, word by word (an MPI_SUM all-reduce), then
    /// [`PlateSum::from_limbs`] gives their sum exactly, whatever the reduction order.
    pub fn limbs(&self) -> [u64; LIMB_LEN] {
        let mut out = [0u64; LIMB_LEN];
        for (c, a) in self.acc.iter().enumerate() {
            let u = *a as u128;
            for k in 0..LIMBS {
                out[c * LIMBS + k] = ((u >> (32 * k)) as u32).into();
            }
        }
        out[6 * LIMBS] = self.bad.into();
        out
    }

    /// The sum whose limbs (added word by word over partial sums) are `w`.
    pub fn from_limbs(w: &[u64; LIMB_LEN]) -> PlateSum {
        let mut acc = [0i128; 6];
        for (c, a) in acc.iter_mut().enumerate() {
            let mut u = 0u128;
            for k in 0..LIMBS {
                u = u.wrapping_add(u128::from(w[c * LIMBS + k]).wrapping_shl(32 * k as u32));
            }
            *a = u as i128;
        }
        PlateSum {
            acc,
            bad: u32::try_from(w[6 * LIMBS]).unwrap_or(u32::MAX),
        }
    }
}

/// The exact sum of the shares `(bottom, top)` given.
pub fn sum(shares: impl Iterator<Item = (V3, V3)>) -> PlateSum {
    let mut s = PlateSum::default();
    for (b, t) in shares {
        s.add(b, t);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shares(n: usize, seed: u64) -> Vec<(V3, V3)> {
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            // signed, spread over many magnitudes (1e-9 .. 1e3 N)
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            let mag = 10f64.powf(-9.0 + 12.0 * u);
            if s & 1 == 0 {
                mag
            } else {
                -mag
            }
        };
        (0..n)
            .map(|_| ([next(), next(), next()], [next(), next(), next()]))
            .collect()
    }

    /// Any order and any split into partial sums, merged directly or through limbs added
    /// word by word, gives the same bits; and the total is within 2 ulp of a compensated
    /// (Neumaier) f64 sum of the same terms.
    #[test]
    fn the_sum_does_not_depend_on_order_or_split() {
        let v = shares(5000, 3);
        let whole = sum(v.iter().copied()).totals().unwrap();
        let mut rev = v.clone();
        rev.reverse();
        assert_eq!(sum(rev.iter().copied()).totals().unwrap(), whole);
        for parts in [2usize, 3, 7, 64] {
            let chunk = v.len().div_ceil(parts);
            let partial: Vec<PlateSum> = v.chunks(chunk).map(|c| sum(c.iter().copied())).collect();
            // merged in reverse order
            let mut m = PlateSum::default();
            for p in partial.iter().rev() {
                m.merge(p);
            }
            assert_eq!(m.totals().unwrap(), whole, "{parts} parts merged");
            // limbs added word by word, as an MPI_SUM all-reduce does
            let mut w = [0u64; LIMB_LEN];
            for p in &partial {
                for (a, b) in w.iter_mut().zip(p.limbs()) {
                    *a += b;
                }
            }
            assert_eq!(PlateSum::from_limbs(&w), m, "{parts} parts through limbs");
        }
        // against a compensated (Neumaier) sum of the same terms: within a few ulp
        for c in 0..6 {
            let (mut s, mut comp) = (0.0f64, 0.0f64);
            for (b, t) in &v {
                let x = if c < 3 { b[c] } else { t[c - 3] };
                let t2 = s + x;
                comp += if s.abs() >= x.abs() {
                    (s - t2) + x
                } else {
                    (x - t2) + s
                };
                s = t2;
            }
            let exact = s + comp;
            let got = if c < 3 { whole.0[c] } else { whole.1[c - 3] };
            assert!(
                (got - exact).abs() <= 2.0 * f64::EPSILON * exact.abs() + 1e-20,
                "component {c}: {got} vs {exact}"
            );
        }
    }

    /// A share that is not finite or is beyond the range makes the total an error, also
    /// after merging and through limbs; zero and the largest share taken do not.
    #[test]
    fn a_share_out_of_range_is_an_error_not_a_number() {
        for bad in [f64::NAN, f64::INFINITY, -f64::INFINITY, MAX_SHARE, -1e20] {
            let mut s = PlateSum::default();
            s.add([1.0, 0.0, 0.0], [0.0, bad, 0.0]);
            assert_eq!(s.totals(), None, "{bad}");
            let mut m = PlateSum::default();
            m.merge(&s);
            assert_eq!(PlateSum::from_limbs(&m.limbs()).totals(), None, "{bad}");
        }
        let mut s = PlateSum::default();
        let big = MAX_SHARE - 1.0;
        s.add([big, -big, 0.0], [-0.0, 1e-30, 2.5]);
        let (b, t) = s.totals().unwrap();
        assert_eq!(b, [big, -big, 0.0]);
        assert_eq!(t, [0.0, 0.0, 2.5], "1e-30 N is below the grid");
    }
}
