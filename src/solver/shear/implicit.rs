//! epsd_implicit (native only): the rolling dashpot integrated implicitly per particle. The
//! force loop collects, per particle, `A = sum C P` and `B = sum C P w_j` of its dashpots
//! ([`add_dashpot`]); after the explicit half-kick the angular velocity solves the 3x3 system
//! of the trapezoidal rule ([`solve_sym3`], in `ShearSim::implicit_rotation`). Pure kernels:
//! the time loop imports them, they import nothing of it.

use crate::solver::vec3::V3;

/// Adds one implicit rolling dashpot `C P` (and `C P w_other`) to a particle's system.
pub(super) fn add_dashpot(imp: &mut ([f64; 6], V3), c: f64, n: V3, torsion: bool, w_other: V3) {
    let p = if torsion {
        [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
    } else {
        [
            1.0 - n[0] * n[0],
            1.0 - n[1] * n[1],
            1.0 - n[2] * n[2],
            -n[0] * n[1],
            -n[0] * n[2],
            -n[1] * n[2],
        ]
    };
    for k in 0..6 {
        imp.0[k] += c * p[k];
    }
    let pw = sym_mul(p, w_other);
    for k in 0..3 {
        imp.1[k] += c * pw[k];
    }
}

/// Symmetric 3x3 (xx yy zz xy xz yz) times a vector.
pub(super) fn sym_mul(a: [f64; 6], x: V3) -> V3 {
    [
        a[0] * x[0] + a[3] * x[1] + a[4] * x[2],
        a[3] * x[0] + a[1] * x[1] + a[5] * x[2],
        a[4] * x[0] + a[5] * x[1] + a[2] * x[2],
    ]
}

/// Solves the symmetric positive definite 3x3 system (xx yy zz xy xz yz) `a x = b` by
/// Cholesky (nalgebra): this system is not in LIGGGHTS, so no operation order is mirrored. The
/// matrix is `I/h + sum C P` with `I/h > 0` and each `C P` positive semi-definite, so the
/// factorisation exists; LU is the fallback should round-off ever break it.
pub(super) fn solve_sym3(a: [f64; 6], b: V3) -> V3 {
    use nalgebra::{Matrix3, Vector3};
    let [xx, yy, zz, xy, xz, yz] = a;
    let m = Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
    let rhs = Vector3::new(b[0], b[1], b[2]);
    let x = match m.cholesky() {
        Some(c) => c.solve(&rhs),
        None => m
            .lu()
            .solve(&rhs)
            .unwrap_or_else(|| Vector3::repeat(f64::NAN)),
    };
    [x[0], x[1], x[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_solve_inverts_sym_mul() {
        let a = [4.0, 3.0, 5.0, 1.0, -0.5, 0.25];
        let x = [0.3, -1.2, 2.0];
        let b = sym_mul(a, x);
        let y = solve_sym3(a, b);
        for k in 0..3 {
            assert!((x[k] - y[k]).abs() < 1e-14);
        }
        // a dashpot projects out the normal component
        let mut imp = ([0.0; 6], [0.0; 3]);
        add_dashpot(&mut imp, 2.0, [0.0, 1.0, 0.0], false, [1.0, 5.0, 0.0]);
        assert_eq!(imp.0, [2.0, 0.0, 2.0, -0.0, -0.0, -0.0]);
        assert_eq!(imp.1, [2.0, 0.0, 0.0]);
    }
}
