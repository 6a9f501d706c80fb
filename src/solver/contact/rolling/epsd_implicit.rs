//! `rolling_friction epsd_implicit` (ours, not a LIGGGHTS keyword; the deck runs epsd):
//! epsd's spring, its dashpot left to the integrator (`solver::shear::implicit`), which
//! applies it implicitly so that it is stable at any eta_r.

use super::super::data::ContactData;
use super::super::lanes::{Lanes, Mask};
use super::super::normal::NormalForce;
use super::{dashpot_coefficient, epsd, spring};
use crate::solver::material::PairParams;

/// epsd's spring (history, limit, `k_r` [`epsd::stiffness`]) without the dashpot. Returns
/// the spring torque, the dashpot coefficient `C_r = eta_r 2 sqrt(I_r k_r)` for the
/// integrator (0 at the limit) and the lanes at the limit.
#[inline(always)]
pub fn torque<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    p: &PairParams,
    hist: &mut [L; 3],
    update_history: bool,
) -> ([L; 3], L, L::M) {
    let kr = epsd::stiffness(nf.kn, cd.splat(p.coeff_roll_frict), cd.reff());
    let (m, _, capped) = spring(cd, nf, p, kr, hist, update_history);
    let c = if capped.not().any() {
        L::select(capped, cd.splat(0.0), dashpot_coefficient(cd, p, kr))
    } else {
        cd.splat(0.0)
    };
    (m, c, capped)
}

#[cfg(test)]
mod tests {
    use super::super::super::normal::hertz;
    use super::super::super::surface::default::surface;
    use super::super::super::test_support::{pair, params};
    use super::*;
    use crate::solver::contact::models::RollingModel;
    use approx::assert_relative_eq;

    /// epsd's spring alone in the torque; `C_r = eta_r 2 sqrt(I_r k_r)` handed to the
    /// integrator below the limit, 0 at it (a cargo-mutants survivor: C_r was not held).
    #[test]
    fn spring_in_the_torque_dashpot_to_the_integrator() {
        let p = params(RollingModel::EpsdImplicit);
        let mut cd = pair([0.0, 100.0, 0.0]);
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
        let reff = 0.5e-3;
        let kr = 2.25 * nf.kn * 0.25 * reff * reff;
        let i_r = 1.4 * (cd.mi * 1e-6) * (cd.mj * 1e-6) / (cd.mi * 1e-6 + cd.mj * 1e-6);
        let mut hist = [0.0; 3];
        let (m, c, mobilised) = torque(&cd, &nf, &p, &mut hist, true);
        assert!(!mobilised);
        assert_relative_eq!(m[1], kr * 1e-8 * 100.0, max_relative = 1e-14);
        assert_eq!(m, hist);
        assert_relative_eq!(c, 0.3 * 2.0 * (i_r * kr).sqrt(), max_relative = 1e-14);
        let mut hist = [0.0, 1.0, 0.0];
        let (m, c, mobilised) = torque(&cd, &nf, &p, &mut hist, true);
        assert!(mobilised);
        assert_relative_eq!(m[1], nf.fn_ * reff * 0.5, max_relative = 1e-14);
        assert_eq!(c, 0.0);
    }
}
