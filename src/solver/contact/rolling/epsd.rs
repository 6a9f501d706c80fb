//! `rolling_friction epsd` (rolling_model_epsd.h): elastic-plastic spring-dashpot.

use super::super::normal::NormalForce;
use super::super::ContactData;
use super::spring_dashpot;
use crate::solver::material::PairParams;
use crate::solver::vec3::V3;

/// `k_r = 2.25 kn mu_r^2 reff^2` (evaluated `2.25*kn*rmu*rmu*reff*reff`);
/// `M = M_old + k_r dt wr_tot`, capped at `|Fn| reff mu_r`. The history stores `M`
/// (capped or not). Below the cap the dashpot `C_r wr_tot`, `C_r = eta_r 2 sqrt(I_r k_r)`, is
/// added to the applied torque but never stored; at the cap the dashpot is off.
pub fn torque(
    cd: &ContactData,
    nf: &NormalForce,
    p: &PairParams,
    hist: &mut V3,
    update_history: bool,
) -> (V3, bool) {
    let rmu = p.coeff_roll_frict;
    spring_dashpot(cd, nf, p, hist, update_history, |kn, reff| {
        stiffness(kn, rmu, reff)
    })
}

/// epsd's rolling stiffness `k_r = 2.25 kn mu_r^2 reff^2`, evaluated as LIGGGHTS does
/// (`2.25*kn*rmu*rmu*reff*reff`, left to right). Also used by the stability estimate.
pub fn stiffness(kn: f64, mu_r: f64, reff: f64) -> f64 {
    2.25 * kn * mu_r * mu_r * reff * reff
}

/// epsd_implicit: epsd's spring (history, limit) without the dashpot, the dashpot
/// coefficient `C_r = eta_r 2 sqrt(I_r k_r)` (0 at the limit) for the implicit integrator, and
/// whether the spring is at its limit.
pub fn spring_only(
    cd: &ContactData,
    nf: &NormalForce,
    p: &PairParams,
    hist: &mut V3,
    update_history: bool,
) -> (V3, f64, bool) {
    let reff = super::reff(cd);
    let r_inertia = super::rolling_inertia(cd, reff);
    let wr_tot = super::tangential_part(super::relative_rotation(cd), cd.en, p.torsion_torque);
    let rmu = p.coeff_roll_frict;
    let kr = stiffness(nf.kn, rmu, reff);
    let m_max = nf.fn_.abs() * reff * rmu;
    let (m, capped) = super::spring(*hist, wr_tot, kr, p.dt, m_max);
    if update_history {
        *hist = m;
    }
    let c = if capped {
        0.0
    } else {
        p.coeff_roll_visc * 2.0 * (r_inertia * kr).sqrt()
    };
    (m, c, capped)
}

#[cfg(test)]
mod tests {
    use super::super::super::normal::hertz;
    use super::super::super::surface::default_surface;
    use super::super::super::test_support::{pair, params};
    use super::*;
    use crate::spec::RollingModel;
    use approx::assert_relative_eq;

    #[test]
    fn spring_plus_dashpot_below_cap_then_cap_without_dashpot() {
        let p = params(RollingModel::Epsd);
        let mut cd = pair([0.0, 100.0, 0.0]);
        default_surface(&mut cd);
        let nf = hertz(&cd, &p);
        let reff = 0.5e-3;
        let kr = 2.25 * nf.kn * 0.25 * reff * reff;
        let i_r = 1.4 * (cd.mi * 1e-6) * (cd.mj * 1e-6) / (cd.mi * 1e-6 + cd.mj * 1e-6);
        let c_r = 0.3 * 2.0 * (i_r * kr).sqrt();
        let mut hist = [0.0; 3];
        let (m, mobilised) = torque(&cd, &nf, &p, &mut hist, true);
        assert!(!mobilised);
        assert_relative_eq!(hist[1], kr * 1e-8 * 100.0, max_relative = 1e-14);
        assert_relative_eq!(m[1], kr * 1e-8 * 100.0 + c_r * 100.0, max_relative = 1e-14);
        let mut hist = [0.0, 1.0, 0.0];
        let (m, mobilised) = torque(&cd, &nf, &p, &mut hist, true);
        assert!(mobilised);
        let cap = nf.fn_ * reff * 0.5;
        assert_relative_eq!(m[1], cap, max_relative = 1e-14);
        assert_relative_eq!(hist[1], cap, max_relative = 1e-14);
    }
}
