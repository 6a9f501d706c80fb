//! `rolling_friction cdt` (rolling_model_cdt.h): constant directional torque.

use super::super::data::ContactData;
use super::super::lanes::{select3, Lanes, Mask};
use super::super::normal::NormalForce;
use super::relative_rotation;
use crate::solver::material::PairParams;
use crate::solver::vec3::dot;

/// `M = mu_r kn deltan reff w/|w|` opposing the relative rotation `w` (no history, no
/// spring: full mobilisation as soon as `w != 0`). The normal force used is the elastic
/// `kn deltan`, not `Fn`. The header associates differently for pairs,
/// `w * (mu_r kn deltan reff / |w|)`, and walls, `mu_r Fn w_k / |w| reff`; both mirrored.
/// Without `torsionTorque` the normal component of `M` is removed afterwards.
/// The torque, and whether it is at full mobilisation: cdt has no spring, so any rolling
/// contact (nonzero relative rotation) is at its limit; `|w| <= 0` gives no torque.
#[inline(always)]
pub fn torque<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    p: &PairParams,
) -> ([L; 3], L::M) {
    let zero = cd.splat(0.0);
    let rmu = cd.splat(p.coeff_roll_frict);
    let reff = cd.reff();
    let w = relative_rotation(cd);
    let wmag = dot(w, w).sqrt();
    let still = wmag.le(zero);
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
        let d = dot(r, cd.en);
        let en = cd.en;
        r = [r[0] - en[0] * d, r[1] - en[1] * d, r[2] - en[2] * d];
    }
    let rolling = r[0].ne(zero).or(r[1].ne(zero)).or(r[2].ne(zero));
    (select3(still, [zero; 3], r), still.not().and(rolling))
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
    fn full_moment_at_once_along_relative_rotation() {
        let p = params(RollingModel::Cdt);
        let mut cd = pair([0.0, 100.0, 0.0]);
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
        let (m, mobilised) = torque(&cd, &nf, &p);
        assert!(mobilised, "cdt is always at its limit while rolling");
        assert_relative_eq!(m[1], 0.5 * nf.kn * cd.deltan * 0.5e-3, max_relative = 1e-14);
        assert_eq!(m[0], 0.0);
        // a pure twist about the normal gives nothing without torsionTorque
        let mut cd = pair([0.0, 0.0, 100.0]);
        surface(&mut cd);
        let (m, mobilised) = torque(&cd, &nf, &p);
        assert!(!mobilised);
        assert_eq!(m, [0.0; 3]);
    }

    /// At a wall with torsionTorque on: `M = mu_r (kn deltan) w_k / |w| reff` for every
    /// component of the wall's relative rotation `wr`, the one along the normal included
    /// (a cargo-mutants survivor: the tests above remove that component).
    #[test]
    fn wall_moment_along_every_component_with_torsion() {
        let mut p = params(RollingModel::Cdt);
        p.torsion_torque = true;
        let mut cd = wall([30.0, -40.0, 120.0], 1e-6);
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
        let (m, mobilised) = torque(&cd, &nf, &p);
        assert!(mobilised);
        let w = cd.wr;
        let wmag = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        let full = 0.5 * nf.kn * cd.deltan * cd.radi;
        for k in 0..3 {
            assert_relative_eq!(m[k], full * w[k] / wmag, max_relative = 1e-14);
        }
    }
}
