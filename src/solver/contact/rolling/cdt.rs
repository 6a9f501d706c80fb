//! `rolling_friction cdt` (rolling_model_cdt.h): constant directional torque.

use super::super::normal::NormalForce;
use super::super::ContactData;
use super::{reff, relative_rotation};
use crate::solver::material::PairParams;
use crate::solver::vec3::V3;

/// `M = mu_r kn deltan reff w/|w|` opposing the relative rotation `w` (no history, no
/// spring: full mobilisation as soon as `w != 0`). The normal force used is the elastic
/// `kn deltan`, not `Fn`. The header associates differently for pairs,
/// `w * (mu_r kn deltan reff / |w|)`, and walls, `mu_r Fn w_k / |w| reff`; both mirrored.
/// Without `torsionTorque` the normal component of `M` is removed afterwards.
/// The torque, and whether it is at full mobilisation: cdt has no spring, so any rolling
/// contact (nonzero relative rotation) is at its limit.
pub fn torque(cd: &ContactData, nf: &NormalForce, p: &PairParams) -> (V3, bool) {
    let rmu = p.coeff_roll_frict;
    let reff = reff(cd);
    let w = relative_rotation(cd);
    let wmag = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    if wmag <= 0.0 {
        return ([0.0; 3], false);
    }
    let mut r = if cd.is_wall {
        let fn_ = cd.deltan * nf.kn;
        [
            rmu * fn_ * w[0] / wmag * reff,
            rmu * fn_ * w[1] / wmag * reff,
            rmu * fn_ * w[2] / wmag * reff,
        ]
    } else {
        let s = rmu * nf.kn * cd.deltan * reff / wmag;
        [w[0] * s, w[1] * s, w[2] * s]
    };
    if !p.torsion_torque {
        let [enx, eny, enz] = cd.en;
        let d = r[0] * enx + r[1] * eny + r[2] * enz;
        r = [r[0] - enx * d, r[1] - eny * d, r[2] - enz * d];
    }
    let rolling = r != [0.0; 3];
    (r, rolling)
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
    fn full_moment_at_once_along_relative_rotation() {
        let p = params(RollingModel::Cdt);
        let mut cd = pair([0.0, 100.0, 0.0]);
        default_surface(&mut cd);
        let nf = hertz(&cd, &p);
        let (m, mobilised) = torque(&cd, &nf, &p);
        assert!(mobilised, "cdt is always at its limit while rolling");
        assert_relative_eq!(m[1], 0.5 * nf.kn * cd.deltan * 0.5e-3, max_relative = 1e-14);
        assert_eq!(m[0], 0.0);
        // a pure twist about the normal gives nothing without torsionTorque
        let mut cd = pair([0.0, 0.0, 100.0]);
        default_surface(&mut cd);
        let (m, mobilised) = torque(&cd, &nf, &p);
        assert!(!mobilised);
        assert_eq!(m, [0.0; 3]);
    }
}
