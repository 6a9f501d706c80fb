//! epsd_implicit (native only): the rolling dashpot integrated implicitly per particle. The
//! force loop collects, per particle, `A = sum C P` and `B = sum C P w_j` of its dashpots
//! ([`add_dashpot`]); after the explicit half-kick the angular velocity solves the 3x3 system
//! of the trapezoidal rule ([`ShearSim::implicit_rotation`]).

use super::ShearSim;
use crate::solver::vec3::V3;
use rayon::prelude::*;

impl ShearSim {
    /// epsd_implicit, after the explicit half-kick of the non-dashpot torques: solves the
    /// dashpot implicitly, `(I/h + A) w = (I/h) w* + B` with `w*` the kicked angular velocity
    /// and `h = dt/2`; neighbours' angular velocities enter at their values during the force
    /// computation (Jacobi), so the result does not depend on thread count. The dashpot
    /// torque `B - A w` is added to the stored torque for the next initial half-kick: the
    /// damping is integrated by the trapezoidal rule, A-stable for any `C_r dt / I`.
    pub(super) fn implicit_rotation(&mut self) {
        let h = self.nve.dtf;
        let (radius, mass) = (&self.radius, &self.mass);
        self.omega
            .par_iter_mut()
            .zip(self.torque.par_iter_mut())
            .zip(self.imp.par_iter())
            .enumerate()
            .for_each(|(i, ((w, t), (a, b)))| {
                if a.iter().all(|x| *x == 0.0) {
                    return;
                }
                let ih = 0.4 * mass[i] * radius[i] * radius[i] / h;
                let m = [a[0] + ih, a[1] + ih, a[2] + ih, a[3], a[4], a[5]];
                let rhs = [ih * w[0] + b[0], ih * w[1] + b[1], ih * w[2] + b[2]];
                let x = solve_sym3(m, rhs);
                let ax = sym_mul(*a, x);
                for k in 0..3 {
                    t[k] += b[k] - ax[k];
                }
                *w = x;
            });
    }
}

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
