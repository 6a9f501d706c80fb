//! `rolling_friction epsd2` (rolling_model_epsd2.h): elastic-plastic spring, no dashpot.

use super::super::normal::NormalForce;
use super::super::ContactData;
use super::{reff, relative_rotation, spring, tangential_part};
use crate::solver::material::PairParams;
use crate::solver::vec3::V3;

/// `k_r = kt reff^2` (from the *tangential* stiffness); `M = M_old + k_r dt wr_tot`, capped
/// at `|Fn| reff mu_r`; the history stores `M`. No damping (eta_r is not read).
pub fn torque(
    cd: &ContactData,
    nf: &NormalForce,
    p: &PairParams,
    hist: &mut V3,
    update_history: bool,
) -> (V3, bool) {
    let reff = reff(cd);
    let wr_tot = tangential_part(relative_rotation(cd), cd.en, p.torsion_torque);
    let kr = stiffness(nf.kt, reff);
    let m_max = nf.fn_.abs() * reff * p.coeff_roll_frict;
    let (m, capped) = spring(*hist, wr_tot, kr, p.dt, m_max);
    if update_history {
        *hist = m;
    }
    (m, capped)
}

/// epsd2's rolling stiffness `k_r = kt reff^2` (`kt*reff*reff`). Also used by the stability
/// estimate.
pub fn stiffness(kt: f64, reff: f64) -> f64 {
    kt * reff * reff
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
    fn stiffness_from_kt_and_no_dashpot() {
        let p = params(RollingModel::Epsd2);
        let mut cd = pair([100.0, 0.0, 0.0]);
        default_surface(&mut cd);
        let nf = hertz(&cd, &p);
        let mut hist = [0.0; 3];
        let (m, mobilised) = torque(&cd, &nf, &p, &mut hist, true);
        assert!(!mobilised);
        assert_relative_eq!(m[0], nf.kt * 0.25e-6 * 1e-8 * 100.0, max_relative = 1e-14);
        assert_eq!(m, hist);
    }
}
