//! The top plate's servo: mesh_module_stress_servo.cpp in PID mode (`ctrlPV force`).
//! It keeps no time step of its own: the simulation passes its one dt to every call.
//!
//! Set point `sp = -target_val`; process value `pv = f_total . axis` (force of the particles
//! on the plate). With `axis = (0, -1, 0)` and a positive target the plate moves down until
//! the particles push it up with the target force.
//! - initial_integrate: `xcm += dt vcm`; the mesh is placed at `orig + (xcm - xcm_orig)`;
//! - final_integrate: `err = sp - pv`, `sum += err dt`, `dfdt = -(pv - pv_old)/dt`,
//!   `v = -vel_max (err kp + sum ki + dfdt kd) / |sp|`, `vcm = axis v`, `pv_old = pv`;
//!   `|vcm|` is limited to vel_max, with the anti-windup reset
//!   `sum = (-sgn(vcm . axis) sp - err kp) / ki` when ki > 0.

/// The servo's gains (`vel_max`, `kp`, `ki`, `kd` of `fix mesh/surface/stress/servo`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ServoGains {
    /// Maximum plate speed [m/s].
    pub vel_max: f64,
    /// Proportional gain (speed = kp vel_max at 100 % force error).
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
}

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Servo {
    pub axis: [f64; 3],
    pub sp: f64,
    pub sp_inv: f64,
    pub vel_max: f64,
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
    pub xcm: [f64; 3],
    pub xcm_orig: [f64; 3],
    pub vcm: [f64; 3],
    pub sum_err: f64,
    pub old_pv: f64,
}

impl Servo {
    pub fn new(spec: ServoGains, target_force: f64, com: [f64; 3]) -> Self {
        let sp = -target_force;
        Servo {
            axis: [0.0, -1.0, 0.0],
            sp,
            sp_inv: 1.0 / sp.abs(),
            vel_max: spec.vel_max,
            kp: spec.kp,
            ki: spec.ki,
            kd: spec.kd,
            xcm: com,
            xcm_orig: com,
            vcm: [0.0; 3],
            sum_err: 0.0,
            old_pv: 0.0,
        }
    }

    /// `setup_pre_force`: the reference position of every run is the current one.
    pub fn setup(&mut self) {
        self.xcm_orig = self.xcm;
    }

    /// Moves the plate; returns the displacement since the servo was created (y component
    /// is what the top plate's base moved).
    pub fn initial_integrate(&mut self, dt: f64) -> [f64; 3] {
        for k in 0..3 {
            let dx = dt * self.vcm[k];
            self.xcm[k] += dx;
        }
        [
            self.xcm[0] - self.xcm_orig[0],
            self.xcm[1] - self.xcm_orig[1],
            self.xcm[2] - self.xcm_orig[2],
        ]
    }

    /// PID update from the total force of the particles on the plate.
    pub fn final_integrate(&mut self, f_total: [f64; 3], dt: f64) {
        let a = self.axis;
        let pv = f_total[0] * a[0] + f_total[1] * a[1] + f_total[2] * a[2];
        let err = self.sp - pv;
        self.sum_err += err * dt;
        let dfdt = -(pv - self.old_pv) / dt;
        let mag =
            -self.vel_max * (err * self.kp + self.sum_err * self.ki + dfdt * self.kd) * self.sp_inv;
        self.vcm = [a[0] * mag, a[1] * mag, a[2] * mag];
        self.old_pv = pv;
        let v = self.vcm;
        let vmag = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if vmag > self.vel_max && vmag != 0.0 {
            let factor = self.vel_max / vmag;
            self.vcm = [v[0] * factor, v[1] * factor, v[2] * factor];
            if self.ki > 0.0 {
                let out = self.vcm[0] * a[0] + self.vcm[1] * a[1] + self.vcm[2] * a[2];
                let sgn = if out > 0.0 {
                    1.0
                } else if out < 0.0 {
                    -1.0
                } else {
                    0.0
                };
                self.sum_err = (-sgn * self.sp - err * self.kp) / self.ki;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plate_moves_down_when_underloaded_and_up_when_overloaded() {
        let spec = ServoGains {
            vel_max: 1.0,
            kp: 0.5,
            ki: 0.0,
            kd: 0.0,
        };
        let mut s = Servo::new(spec, 100.0, [0.0, 1.0, 0.0]);
        let dt = 1e-3;
        s.final_integrate([0.0, 0.0, 0.0], dt); // no force: full error
        assert!((s.vcm[1] + 0.5).abs() < 1e-15, "{:?}", s.vcm);
        s.final_integrate([0.0, 300.0, 0.0], dt); // 3x the target: move up, limited
        assert!(s.vcm[1] > 0.0 && s.vcm[1] <= 1.0);
        s.final_integrate([0.0, 100.0, 0.0], dt);
        assert_eq!(s.vcm[1], 0.0);
        s.vcm = [0.0, -0.5, 0.0];
        let d = s.initial_integrate(dt);
        assert!((d[1] + 0.5e-3).abs() < 1e-15);
    }
}
