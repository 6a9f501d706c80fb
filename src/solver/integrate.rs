//! Velocity-Verlet for spheres as fix_nve_sphere.cpp does it (3D).
//!
//! `dtf = 0.5 dt` (`ftm2v = 1` in SI), `dtfrotate = dtf / 0.4`.
//! initial_integrate: `v += dtf/m f`, `x += dt v`, `omega += dtfrotate/(r r m) torque`;
//! final_integrate: `v += dtf/m f`, `omega += dtfrotate/(r r m) torque`.
//! Verlet::run calls, per step: initial_integrate (all fixes), neighbour decision/rebuild,
//! force clear, pair forces, wall forces (fix wall/gran post_force), final_integrate, output.

use super::vec3::V3;

/// The nve/sphere constants of one run.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct NveSphere {
    pub dtv: f64,
    pub dtf: f64,
    pub dtfrotate: f64,
}

impl NveSphere {
    pub fn new(dt: f64) -> Self {
        let dtf = 0.5 * dt * 1.0;
        NveSphere {
            dtv: dt,
            dtf,
            dtfrotate: dtf / 0.4,
        }
    }

    /// First half-kick, drift and rotational half-kick of one particle.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn initial(
        &self,
        x: &mut V3,
        v: &mut V3,
        omega: &mut V3,
        f: V3,
        torque: V3,
        r: f64,
        m: f64,
    ) {
        let dtfm = self.dtf / (m * 1.0);
        for k in 0..3 {
            v[k] += dtfm * f[k];
        }
        for k in 0..3 {
            x[k] += self.dtv * v[k];
        }
        let dtirotate = self.dtfrotate / (r * r * m);
        for k in 0..3 {
            omega[k] += dtirotate * torque[k];
        }
    }

    /// Second half-kick of one particle.
    #[inline]
    pub fn finish(&self, v: &mut V3, omega: &mut V3, f: V3, torque: V3, r: f64, m: f64) {
        let dtfm = self.dtf / (m * 1.0);
        for k in 0..3 {
            v[k] += dtfm * f[k];
        }
        let dtirotate = self.dtfrotate / (r * r * m);
        for k in 0..3 {
            omega[k] += dtirotate * torque[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn constant_force_gives_exact_kinematics() {
        let nve = NveSphere::new(1e-3);
        let (mut x, mut v, mut w) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        let f = [2.0, 0.0, 0.0];
        let t = [0.0, 0.0, 0.4];
        for _ in 0..1000 {
            nve.initial(&mut x, &mut v, &mut w, f, t, 1.0, 1.0);
            nve.finish(&mut v, &mut w, f, t, 1.0, 1.0);
        }
        // a = 2, t = 1 s: v = 2, x = 1; alpha = torque / (0.4 m r^2) = 1.
        assert_relative_eq!(v[0], 2.0, max_relative = 1e-12);
        assert_relative_eq!(x[0], 1.0, max_relative = 1e-12);
        assert_relative_eq!(w[2], 1.0, max_relative = 1e-12);
    }
}
