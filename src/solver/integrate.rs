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

    /// One particle's half-kick factors `dtf / m` and `dtfrotate / (r r m)`: the divisions
    /// nve/sphere makes every half-step, the same operations on the same constants, so a run
    /// may make them once per particle (the shear box does: two divisions fewer per
    /// particle and half-step, same bits).
    #[inline]
    pub fn kick(&self, r: f64, m: f64) -> Kick {
        Kick {
            dtfm: self.dtf / (m * 1.0),
            dtirotate: self.dtfrotate / (r * r * m),
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
        self.initial_kicked(x, v, omega, f, torque, self.kick(r, m))
    }

    /// [`NveSphere::initial`] with the particle's factors made beforehand.
    #[inline]
    pub fn initial_kicked(
        &self,
        x: &mut V3,
        v: &mut V3,
        omega: &mut V3,
        f: V3,
        torque: V3,
        k: Kick,
    ) {
        for c in 0..3 {
            v[c] += k.dtfm * f[c];
        }
        for c in 0..3 {
            x[c] += self.dtv * v[c];
        }
        for c in 0..3 {
            omega[c] += k.dtirotate * torque[c];
        }
    }

    /// Second half-kick of one particle.
    #[inline]
    pub fn finish(&self, v: &mut V3, omega: &mut V3, f: V3, torque: V3, r: f64, m: f64) {
        self.finish_kicked(v, omega, f, torque, self.kick(r, m))
    }

    /// [`NveSphere::finish`] with the particle's factors made beforehand.
    #[inline]
    pub fn finish_kicked(&self, v: &mut V3, omega: &mut V3, f: V3, torque: V3, k: Kick) {
        for c in 0..3 {
            v[c] += k.dtfm * f[c];
        }
        for c in 0..3 {
            omega[c] += k.dtirotate * torque[c];
        }
    }
}

/// A particle's half-kick factors ([`NveSphere::kick`]).
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Kick {
    pub dtfm: f64,
    pub dtirotate: f64,
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
