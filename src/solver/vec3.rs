//! Three-vectors as `[f64; 3]` with the exact operation order of LIGGGHTS' vector_liggghts.h.
//!
//! Kernels use these instead of a linear-algebra crate so that every sum is associated as in
//! LIGGGHTS (`a0*b0 + a1*b1 + a2*b2`, left to right): that is what makes round-off agreement
//! possible, and why the mirrored kernels do not use nalgebra: its products and norms may
//! associate (or fuse, or vectorise) sums differently, and one reordered sum is enough to lose
//! the bit-identity with LIGGGHTS that the contact cases show. nalgebra is used where nothing
//! is mirrored (the implicit dashpot's 3x3 solve, `solver::shear::implicit`). Nothing here
//! allocates.

use super::contact::lanes::Lanes;

pub type V3 = [f64; 3];

/// `vectorDot3D`: `a0*b0 + a1*b1 + a2*b2`, for one vector or per lane of SIMD vectors
/// ([`Lanes`]: the contact kernels use it over lanes).
#[inline(always)]
pub fn dot<L: Lanes>(a: [L; 3], b: [L; 3]) -> L {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `vectorMag3D`: `sqrt(v0*v0 + v1*v1 + v2*v2)`.
#[inline]
pub fn mag(v: V3) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// `vectorSubtract3D`: `a - b`.
#[inline]
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `vectorAdd3D`: `a + b`.
#[inline]
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `vectorScalarMult3D`: `v * s` (component times scalar).
#[inline]
pub fn scale(v: V3, s: f64) -> V3 {
    [v[0] * s, v[1] * s, v[2] * s]
}

/// `vectorCross3D`: `a x b`.
#[inline]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `pointDistance`: `sqrt((a0-b0)^2 + (a1-b1)^2 + (a2-b2)^2)` with each square as a product.
#[inline]
pub fn point_distance(a: V3, b: V3) -> f64 {
    ((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]))
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_is_right_handed() {
        assert_eq!(cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
        assert_eq!(dot([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]), 32.0);
        assert_eq!(mag([3.0, 4.0, 0.0]), 5.0);
        assert_eq!(point_distance([1.0, 1.0, 1.0], [1.0, 4.0, 5.0]), 5.0);
    }
}
