//! `rolling_friction epsd2` (rolling_model_epsd2.h): elastic-plastic spring, no dashpot.

use super::super::data::ContactData;
use super::super::lanes::Lanes;
use super::super::normal::NormalForce;
use super::spring;
use crate::solver::material::PairParams;

/// `k_r = kt reff^2` (from the *tangential* stiffness); `M = M_old + k_r dt wr_tot`, capped
/// at `|Fn| reff mu_r`; the history stores `M`. No damping (eta_r is not read).
#[inline(always)]
pub fn torque<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    p: &PairParams,
    hist: &mut [L; 3],
    update_history: bool,
) -> ([L; 3], L::M) {
    let kr = stiffness(nf.kt, cd.reff());
    let (m, _, capped) = spring(cd, nf, p, kr, hist, update_history);
    (m, capped)
}

/// epsd2's rolling stiffness `k_r = kt reff^2` (`kt*reff*reff`). Also used by the stability
/// estimate.
#[inline(always)]
pub fn stiffness<L: Lanes>(kt: L, reff: L) -> L {
    kt * reff * reff
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
    fn stiffness_from_kt_and_no_dashpot() {
        let p = params(RollingModel::Epsd2);
        let mut cd = pair([100.0, 0.0, 0.0]);
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
        let mut hist = [0.0; 3];
        let (m, mobilised) = torque(&cd, &nf, &p, &mut hist, true);
        assert!(!mobilised);
        assert_relative_eq!(m[0], nf.kt * 0.25e-6 * 1e-8 * 100.0, max_relative = 1e-14);
        assert_eq!(m, hist);
    }
}
