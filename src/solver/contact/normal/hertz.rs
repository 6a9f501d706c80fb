//! `model hertz` (normal_model_hertz.h, `NormalModel<HERTZ>::surfacesIntersect`).

use super::super::{ContactData, ForceData};
use crate::solver::material::PairParams;

/// sqrt(5/6) as the literal in normal_model_hertz.h.
#[allow(clippy::excessive_precision)]
pub(crate) const SQRT_FIVE_OVER_SIX: f64 =
    0.912_870_929_175_276_855_761_616_304_668_003_556_587_907_824_996_638_75;

/// What the normal model hands to the later stages (LIGGGHTS writes these into sidata).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NormalForce {
    /// Normal force magnitude `Fn = -gamman vn + kn deltan` [N] (may be negative: LIGGGHTS'
    /// `limitForce` is off by default).
    pub fn_: f64,
    /// `kn = 4/3 Yeff sqrt(R* deltan)` [N/m].
    pub kn: f64,
    /// `kt = 8 Geff sqrt(R* deltan)` [N/m].
    pub kt: f64,
    /// `gamman = -2 sqrt(5/6) betaeff sqrt(Sn meff)`, `Sn = 2 Yeff sqrt(R* deltan)` [kg/s].
    pub gamman: f64,
    /// `gammat = -2 sqrt(5/6) betaeff sqrt(St meff)`, `St = kt` (0 without tangential damping).
    pub gammat: f64,
}

/// Hertz normal force with restitution damping. `R* = radi` for walls, else
/// `radi radj / (radi + radj)`. Evaluation order exactly as in the header (left to right).
pub fn hertz(cd: &ContactData, p: &PairParams) -> NormalForce {
    let reff = if cd.is_wall {
        cd.radi
    } else {
        cd.radi * cd.radj / (cd.radi + cd.radj)
    };
    let sqrtval = (reff * cd.deltan).sqrt();
    let sn = 2.0 * p.y_eff * sqrtval;
    let st = 8.0 * p.g_eff * sqrtval;
    let kn = 4.0 / 3.0 * p.y_eff * sqrtval;
    let kt = st;
    let gamman = -2.0 * SQRT_FIVE_OVER_SIX * p.beta_eff * (sn * cd.meff).sqrt();
    let gammat = if p.tangential_damping {
        -2.0 * SQRT_FIVE_OVER_SIX * p.beta_eff * (st * cd.meff).sqrt()
    } else {
        0.0
    };
    // kn /= nktv2p, kt /= nktv2p: nktv2p = 1 in SI units.
    let fn_damping = -gamman * cd.vn;
    let fn_contact = kn * cd.deltan;
    NormalForce {
        fn_: fn_damping + fn_contact,
        kn,
        kt,
        gamman,
        gammat,
    }
}

/// Adds `Fn en` to i and its negation to j (walls: `Fn * area_ratio` with area_ratio = 1).
pub fn apply(cd: &ContactData, nf: &NormalForce, fi: &mut ForceData, fj: &mut ForceData) {
    for k in 0..3 {
        fi.delta_f[k] += nf.fn_ * cd.en[k];
    }
    if !cd.is_wall {
        for k in 0..3 {
            fj.delta_f[k] += -fi.delta_f[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::surface::default_surface;
    use super::super::super::test_support::{pair, params};
    use super::*;
    use crate::spec::RollingModel;
    use approx::assert_relative_eq;

    #[test]
    fn static_hertz_force_matches_formula() {
        let mut cd = pair([0.0; 3]);
        default_surface(&mut cd);
        let p = params(RollingModel::Off);
        let nf = hertz(&cd, &p);
        // Fn = 4/3 E* sqrt(R*) delta^1.5 with E* = E/(2(1-nu^2)), R* = 0.5 mm, delta = 1 um.
        let e_star = 7.0e10 / 1.82;
        let expect = 4.0 / 3.0 * e_star * (0.5e-3_f64).sqrt() * (1e-6_f64).powf(1.5);
        assert_relative_eq!(nf.fn_, expect, max_relative = 1e-8);
        assert_relative_eq!(nf.kt / nf.kn, 6.0 * p.g_eff / p.y_eff, max_relative = 1e-14);
    }

    #[test]
    fn damping_opposes_approach() {
        let mut cd = pair([0.0; 3]);
        cd.v_i = [0.0, 0.0, -0.1]; // i (on top) moves down: approaching
        default_surface(&mut cd);
        let p = params(RollingModel::Off);
        let nf = hertz(&cd, &p);
        let elastic = nf.kn * cd.deltan;
        assert!(
            nf.fn_ > elastic,
            "damping must add repulsion while approaching"
        );
        // gamman = -2 sqrt(5/6) beta sqrt(2 Y* sqrt(R* d) m*), beta < 0 -> gamman > 0.
        let sn = 2.0 * p.y_eff * (0.5e-3 * cd.deltan).sqrt();
        assert_relative_eq!(
            nf.gamman,
            -2.0 * (5.0f64 / 6.0).sqrt() * p.beta_eff * (sn * cd.meff).sqrt(),
            max_relative = 1e-14
        );
    }
}
