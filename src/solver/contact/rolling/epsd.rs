//! `rolling_friction epsd` (rolling_model_epsd.h): elastic-plastic spring-dashpot.

use super::super::data::ContactData;
use super::super::lanes::Lanes;
use super::super::normal::NormalForce;
use super::spring_dashpot;
use crate::solver::material::PairParams;

/// `k_r = 2.25 kn mu_r^2 reff^2` (evaluated `2.25*kn*rmu*rmu*reff*reff`);
/// `M = M_old + k_r dt wr_tot`, capped at `|Fn| reff mu_r`. The history stores `M`
/// (capped or not). Below the cap the dashpot `C_r wr_tot`, `C_r = eta_r 2 sqrt(I_r k_r)`, is
/// added to the applied torque but never stored; at the cap the dashpot is off.
#[inline(always)]
pub fn torque<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    p: &PairParams,
    hist: &mut [L; 3],
    update_history: bool,
) -> ([L; 3], L::M) {
    let kr = stiffness(nf.kn, cd.splat(p.coeff_roll_frict), cd.reff());
    spring_dashpot(cd, nf, p, kr, hist, update_history)
}

/// epsd's rolling stiffness `k_r = 2.25 kn mu_r^2 reff^2`, evaluated as LIGGGHTS does
/// (`2.25*kn*rmu*rmu*reff*reff`, left to right). Also epsd_implicit's, and used by the
/// stability estimate.
#[inline(always)]
pub fn stiffness<L: Lanes>(kn: L, mu_r: L, reff: L) -> L {
    kn.splat(2.25) * kn * mu_r * mu_r * reff * reff
}

#[cfg(test)]
mod tests {
    use super::super::super::normal::hertz;
    use super::super::super::surface::default::surface;
    use super::super::super::test_support::{pair, params, wall};
    use super::*;
    use crate::solver::contact::models::RollingModel;
    use approx::assert_relative_eq;

    #[test]
    fn spring_plus_dashpot_below_cap_then_cap_without_dashpot() {
        let p = params(RollingModel::Epsd);
        let mut cd = pair([0.0, 100.0, 0.0]);
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
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

    /// At a wall the dashpot uses the wall's rolling inertia `I_r = 1.4 m_i R_i^2` and
    /// `reff = R_i` (a cargo-mutants survivor: no test held the wall's inertia).
    #[test]
    fn wall_dashpot_uses_the_wall_rolling_inertia() {
        let p = params(RollingModel::Epsd);
        let mut cd = wall([0.0, 100.0, 0.0], 1e-6);
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
        let reff = cd.radi;
        let kr = 2.25 * nf.kn * 0.25 * reff * reff;
        let c_r = 0.3 * 2.0 * (1.4 * cd.mi * reff * reff * kr).sqrt();
        let mut hist = [0.0; 3];
        let (m, mobilised) = torque(&cd, &nf, &p, &mut hist, true);
        assert!(!mobilised);
        let wr = cd.wr[1];
        assert_relative_eq!(hist[1], kr * 1e-8 * wr, max_relative = 1e-14);
        assert_relative_eq!(m[1], kr * 1e-8 * wr + c_r * wr, max_relative = 1e-14);
    }
}
