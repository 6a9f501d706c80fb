//! Time-step stability figures of a shear case, computed before every run.
//!
//! For every pair of size classes and every size class against a wall:
//! - `dt / T_Rayleigh` (smaller sphere) and `dt / t_Hertz`, with the Hertz contact time
//!   `t_c = pi sqrt(m* / (1.5 k_n))` of the linearised contact at the estimated load;
//! - the rotational spring `omega_r dt = sqrt(k_r / I_eff) dt` and the rolling dashpot
//!   `lambda dt = C_r dt / I_eff`, with LIGGGHTS' k_r of the model (epsd `2.25 k_n mu_r^2 R*^2`,
//!   epsd3 `k k_n mu_r^2 R*^2`, epsd2 `k_t R*^2`), its `C_r = eta_r 2 sqrt(I_r k_r)` with
//!   `I_r = 1.4 (m_i R_i^2)(m_j R_j^2)/(m_i R_i^2 + m_j R_j^2)` (walls `1.4 m R^2`), and the
//!   inertia the relative rotation actually has, `I_eff = I_i I_j / (I_i + I_j)`,
//!   `I = 0.4 m R^2` (walls: `I_eff = I`).
//!
//! k_n is estimated from the mean contact force at the target stress,
//! `F = 4 pi R_mean^2 sigma / (phi Z)` (phi = 0.6, Z = 5), through Hertz `F = k_n delta`,
//! `k_n = 4/3 E* sqrt(R* delta)`.
//!
//! Criterion (derived here). LIGGGHTS integrates the rotation with velocity Verlet and
//! evaluates the rolling torque with the half-kicked angular velocity, so per contact the
//! relative rotation follows the explicit leapfrog
//! `w_{k+1} = w_k - dt (omega_r^2 theta_k + lambda w_k)`, `theta_{k+1} = theta_k + dt w_{k+1}`.
//! Its characteristic polynomial `z^2 - (2 - lambda dt - omega_r^2 dt^2) z + (1 - lambda dt)`
//! has both roots inside the unit circle (Jury) iff `lambda dt < 2` and
//! `omega_r^2 dt^2 + 2 lambda dt < 4`. A grain with `n` rolling contacts sees roughly n times
//! the stiffness and damping on its own rotation, so the explicit dashpot is expected to be
//! unstable when `S = n (omega_r^2 dt^2 + 2 lambda dt) >= 4`; we take n = 4 (a dense packing
//! has Z of about 4 to 6 contacts per grain). Unstable relative rotations grow until the contacts reach
//! full mobilisation, where epsd switches the dashpot off: the run does not crash, it shows
//! high rotational kinetic energy and low friction.

use super::shear::ShearCase;
use super::{rayleigh_time, RollingModel};
use serde::{Deserialize, Serialize};

/// Rolling contacts per grain assumed by the criterion.
pub const ROLLING_CONTACTS: f64 = 4.0;
const PHI: f64 = 0.6;
const Z: f64 = 5.0;

/// Figures of one contact kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StabilityEntry {
    /// e.g. `0.1mm-0.2mm` or `0.1mm-wall`.
    pub contact: String,
    pub k_n: f64,
    pub dt_over_rayleigh: f64,
    pub dt_over_hertz: f64,
    pub omega_r_dt: f64,
    pub lambda_dt: f64,
    /// `S = n (omega_r^2 dt^2 + 2 lambda dt)`; unstable at >= 4.
    pub criterion: f64,
    pub dashpot_stable: bool,
}

/// All figures of a case, worst first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StabilityReport {
    pub dt: f64,
    pub rolling: String,
    pub entries: Vec<StabilityEntry>,
    pub stable: bool,
}

/// The rolling stiffness of `model`, from the kernels' own formulas.
fn rolling_stiffness(model: RollingModel, kn: f64, kt: f64, mu_r: f64, k3: f64, reff: f64) -> f64 {
    use crate::solver::contact::rolling::{epsd, epsd2, epsd3};
    match model {
        RollingModel::Epsd | RollingModel::EpsdImplicit => epsd::stiffness(kn, mu_r, reff),
        RollingModel::Epsd3 => epsd3::stiffness(k3, kn, mu_r, reff),
        RollingModel::Epsd2 => epsd2::stiffness(kt, reff),
        RollingModel::Cdt | RollingModel::Off => 0.0,
    }
}

pub fn stability(case: &ShearCase) -> StabilityReport {
    use crate::solver::contact::rolling::{pair_reff, pair_rolling_inertia, wall_rolling_inertia};
    let m = &case.material;
    // E* = Yeff and G* = Geff of the material with itself, as the kernels use them
    let pp = m.pair_params(&case.models, case.dt);
    let (e_star, g_star) = (pp.y_eff, pp.g_eff);
    let dt = case.dt;
    let mass = |r: f64| crate::solver::material::sphere_mass(r, m.density);
    let mut radii = case.radii.clone();
    radii.sort_by(f64::total_cmp);
    let mut entries = Vec::new();
    let mut add = |label: String, ri: f64, rj: Option<f64>| {
        let (reff, mstar, r_mean, i_eff, i_r, rmin) = match rj {
            Some(rj) => {
                let (mi, mj) = (mass(ri), mass(rj));
                let (ai, aj) = (mi * ri * ri, mj * rj * rj);
                (
                    pair_reff(ri, rj),
                    mi * mj / (mi + mj),
                    0.5 * (ri + rj),
                    0.4 * ai * aj / (ai + aj),
                    pair_rolling_inertia(mi, ri, mj, rj),
                    ri.min(rj),
                )
            }
            None => {
                let mi = mass(ri);
                (
                    ri,
                    mi,
                    ri,
                    0.4 * mi * ri * ri,
                    wall_rolling_inertia(mi, ri),
                    ri,
                )
            }
        };
        let force = 4.0 * std::f64::consts::PI * r_mean * r_mean * case.normal_stress / (PHI * Z);
        let delta = (3.0 * force / (4.0 * e_star * reff.sqrt())).powf(2.0 / 3.0);
        let kn = 4.0 / 3.0 * e_star * (reff * delta).sqrt();
        let kt = 8.0 * g_star * (reff * delta).sqrt();
        let kr = rolling_stiffness(
            case.models.rolling,
            kn,
            kt,
            m.rolling_friction,
            m.rolling_stiffness,
            reff,
        );
        let c_r = if case.models.rolling.has_damping() {
            m.rolling_damping * 2.0 * (i_r * kr).sqrt()
        } else {
            0.0
        };
        let omega_r_dt = (kr / i_eff).sqrt() * dt;
        let lambda_dt = c_r * dt / i_eff;
        // epsd_implicit integrates the dashpot implicitly: only the spring limits dt
        let explicit_lambda = if case.models.rolling == RollingModel::EpsdImplicit {
            0.0
        } else {
            lambda_dt
        };
        let criterion = ROLLING_CONTACTS * (omega_r_dt * omega_r_dt + 2.0 * explicit_lambda);
        entries.push(StabilityEntry {
            contact: label,
            k_n: kn,
            dt_over_rayleigh: dt / rayleigh_time(m, rmin),
            dt_over_hertz: dt / (std::f64::consts::PI * (mstar / (1.5 * kn)).sqrt()),
            omega_r_dt,
            lambda_dt,
            criterion,
            dashpot_stable: criterion < 4.0,
        });
    };
    let mm = |r: f64| format!("{}mm", r * 1e3);
    for (a, &ri) in radii.iter().enumerate() {
        for &rj in &radii[a..] {
            add(format!("{}-{}", mm(ri), mm(rj)), ri, Some(rj));
        }
        add(format!("{}-wall", mm(ri)), ri, None);
    }
    entries.sort_by(|a, b| b.criterion.total_cmp(&a.criterion));
    let stable = entries.iter().all(|e| e.dashpot_stable);
    StabilityReport {
        dt,
        rolling: case.models.rolling.keyword().into(),
        entries,
        stable,
    }
}

impl StabilityReport {
    /// The worst entries as text lines.
    pub fn lines(&self, n: usize) -> Vec<String> {
        self.entries
            .iter()
            .take(n)
            .map(|e| {
                format!(
                    "{:<14} k_n {:.2e} N/m  dt/T_R {:.2}  dt/t_c {:.3}  omega_r dt {:.3}  lambda dt {:.3}  S = {:.2} {}",
                    e.contact,
                    e.k_n,
                    e.dt_over_rayleigh,
                    e.dt_over_hertz,
                    e.omega_r_dt,
                    e.lambda_dt,
                    e.criterion,
                    if e.dashpot_stable { "(stable)" } else { "(UNSTABLE: S >= 4)" }
                )
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leapfrog_criterion_matches_the_iteration() {
        // iterate the per-contact leapfrog and check growth against the derived bound
        let grows = |w2dt2: f64, ldt: f64| {
            let (mut th, mut w) = (1.0f64, 0.0f64);
            for _ in 0..2000 {
                w -= w2dt2 * th + ldt * w;
                th += w;
                if th.abs() + w.abs() > 1e6 {
                    return true;
                }
            }
            th.abs() + w.abs() > 1.0
        };
        for (w, l) in [
            (0.5, 0.1),
            (0.2, 0.9),
            (1.0, 0.4),
            (0.1, 1.2),
            (2.1, 0.0),
            (1.0, 1.6),
            (0.5, 1.95),
            (0.1, 2.1),
        ] {
            let inside = l < 2.0 && w * w + 2.0 * l < 4.0;
            assert_eq!(!grows(w * w, l), inside, "omega dt {w}, lambda dt {l}");
        }
    }

    #[test]
    fn paper_parameters_with_viscous_rolling_are_flagged() {
        let c = ShearCase::preset(
            crate::spec::shear::Preset::Paper,
            RollingModel::Epsd,
            1.0,
            0.5,
            1,
        )
        .unwrap();
        let r = stability(&c);
        assert!(!r.stable, "{:?}", r.lines(3));
        let undamped = stability(
            &ShearCase::preset(
                crate::spec::shear::Preset::Paper,
                RollingModel::Epsd,
                0.25,
                0.0,
                1,
            )
            .unwrap(),
        );
        assert!(undamped.stable, "{:?}", undamped.lines(3));
        assert_eq!(r.entries.len(), 9);
    }
}
