//! `rolling_friction epsd3` (rolling_model_epsd3.h): epsd with a user stiffness factor.

use super::super::data::ContactData;
use super::super::lanes::Lanes;
use super::super::normal::NormalForce;
use super::spring_dashpot;
use crate::solver::material::PairParams;

/// As epsd but `k_r = coeffRollStiffness kn mu_r^2 reff^2` (evaluated
/// `coeffRollStiffness*kn*rmu*rmu*reff*reff`). Walls use `radius = radi` for `reff` and
/// `I_r = 1.4 mi radi^2`, the same values epsd uses.
#[inline(always)]
pub fn torque<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    p: &PairParams,
    hist: &mut [L; 3],
    update_history: bool,
) -> ([L; 3], L::M) {
    let kr = stiffness(
        cd.splat(p.coeff_roll_stiffness),
        nf.kn,
        cd.splat(p.coeff_roll_frict),
        cd.reff(),
    );
    spring_dashpot(cd, nf, p, kr, hist, update_history)
}

/// epsd3's rolling stiffness `k_r = coeffRollStiffness kn mu_r^2 reff^2`, evaluated left to
/// right as LIGGGHTS does. Also used by the stability estimate.
#[inline(always)]
pub fn stiffness<L: Lanes>(coeff_roll_stiffness: L, kn: L, mu_r: L, reff: L) -> L {
    coeff_roll_stiffness * kn * mu_r * mu_r * reff * reff
}

#[cfg(test)]
mod tests {
    use super::super::super::normal::hertz;
    use super::super::super::surface::default::surface;
    use super::super::super::test_support::{pair, params};
    use super::*;
    use crate::solver::contact::models::RollingModel;
    use approx::assert_relative_eq;

    #[test]
    fn stiffness_factor_scales_kr() {
        let mut p = params(RollingModel::Epsd3);
        p.coeff_roll_visc = 0.0;
        let mut cd = pair([0.0, 100.0, 0.0]);
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
        let mut hist = [0.0; 3];
        let (m, mobilised) = torque(&cd, &nf, &p, &mut hist, true);
        assert!(!mobilised);
        let kr = 3.0 * nf.kn * 0.25 * 0.25e-6;
        assert_relative_eq!(m[1], kr * 1e-8 * 100.0, max_relative = 1e-14);
    }
}
