//! Imposed motions as fix_move.cpp applies them in `initial_integrate` (styles `rotate` about
//! the particle's own centre, and `linear`). `final_integrate` of these styles changes nothing.

use super::vec3::V3;

/// A `fix move` instance: created at step `time_origin` with the particle's position then.
#[derive(Clone, Copy, Debug)]
pub enum FixMove {
    /// `fix move rotate Px Py Pz Ax Ay Az period`: `omega_rotate = 2 pi / period`,
    /// `runit = A / |A|`; `point` is the particle's centre, so the displacement `d = 0` and
    /// x stays put, `v = omega_rotate (runit x disp) = 0`, `omega = omega_rotate runit`.
    Rotate {
        point: V3,
        omega_rotate: f64,
        runit: V3,
    },
    /// `fix move linear Vx Vy Vz`: `x = xoriginal + V (step - time_origin) dt`, `v = V`.
    Linear {
        xoriginal: V3,
        velocity: V3,
        time_origin: u64,
    },
}

impl FixMove {
    /// The `rotate` fix the deck writes for angular velocity `omega` (axis = omega,
    /// period = 2 pi / |omega|), with LIGGGHTS' own arithmetic for omega_rotate and runit.
    pub fn rotate(point: V3, axis: V3, period: f64) -> Self {
        let omega_rotate = 2.0 * std::f64::consts::PI / period;
        let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        FixMove::Rotate {
            point,
            omega_rotate,
            runit: [axis[0] / len, axis[1] / len, axis[2] / len],
        }
    }

    /// Sets x, v and omega of the moved particle at step `step` (after the increment).
    pub fn initial_integrate(&self, step: u64, dt: f64, x: &mut V3, v: &mut V3, omega: &mut V3) {
        match *self {
            FixMove::Rotate {
                point,
                omega_rotate,
                runit,
            } => {
                // d = xoriginal - point = 0 => c = a = b = disp = 0.
                let disp = [0.0; 3];
                *x = [
                    point[0] + 0.0 + disp[0],
                    point[1] + 0.0 + disp[1],
                    point[2] + 0.0 + disp[2],
                ];
                *v = [
                    omega_rotate * (runit[1] * disp[2] - runit[2] * disp[1]),
                    omega_rotate * (runit[2] * disp[0] - runit[0] * disp[2]),
                    omega_rotate * (runit[0] * disp[1] - runit[1] * disp[0]),
                ];
                *omega = [
                    omega_rotate * runit[0],
                    omega_rotate * runit[1],
                    omega_rotate * runit[2],
                ];
            }
            FixMove::Linear {
                xoriginal,
                velocity,
                time_origin,
            } => {
                let delta = (step - time_origin) as f64 * dt;
                *v = velocity;
                for k in 0..3 {
                    x[k] = xoriginal[k] + velocity[k] * delta;
                }
            }
        }
    }
}

/// The period written into the deck for angular speed `|omega|`: `2 pi / |omega|`.
pub fn rotation_period(omega: V3) -> f64 {
    2.0 * std::f64::consts::PI
        / (omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn rotate_sets_omega_and_keeps_position() {
        let w = [60.0, 80.0, 0.0];
        let fx = FixMove::rotate([1.0, 2.0, 3.0], w, rotation_period(w));
        let (mut x, mut v, mut o) = ([1.0, 2.0, 3.0], [5.0; 3], [0.0; 3]);
        fx.initial_integrate(7, 1e-3, &mut x, &mut v, &mut o);
        assert_eq!(x, [1.0, 2.0, 3.0]);
        assert_eq!(v, [0.0; 3]);
        assert_relative_eq!(o[0], 60.0, max_relative = 1e-14);
        assert_relative_eq!(o[1], 80.0, max_relative = 1e-14);
    }

    #[test]
    fn linear_moves_from_origin_step() {
        let fx = FixMove::Linear {
            xoriginal: [0.0; 3],
            velocity: [2.0, 0.0, 0.0],
            time_origin: 10,
        };
        let (mut x, mut v, mut o) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        fx.initial_integrate(15, 0.5, &mut x, &mut v, &mut o);
        assert_eq!(x[0], 5.0);
        assert_eq!(v[0], 2.0);
    }
}
