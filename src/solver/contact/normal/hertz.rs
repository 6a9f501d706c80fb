//! `model hertz` (normal_model_hertz.h, `NormalModel<HERTZ>::surfacesIntersect`).

use super::super::data::{ContactData, ForceData};
use super::super::lanes::Lanes;
use crate::solver::material::PairParams;

/// sqrt(5/6) as the literal in normal_model_hertz.h.
#[allow(clippy::excessive_precision)]
pub(crate) const SQRT_FIVE_OVER_SIX: f64 =
    0.912_870_929_175_276_855_761_616_304_668_003_556_587_907_824_996_638_75;

/// What the normal model hands to the later stages (LIGGGHTS writes these into sidata).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NormalForce<L = f64> {
    /// Normal force magnitude `Fn = -gamman vn + kn deltan` [N] (may be negative: LIGGGHTS'
    /// `limitForce` is off by default).
    pub fn_: L,
    /// `kn = 4/3 Yeff sqrt(R* deltan)` [N/m].
    pub kn: L,
    /// `kt = 8 Geff sqrt(R* deltan)` [N/m].
    pub kt: L,
    /// `gamman = -2 sqrt(5/6) betaeff sqrt(Sn meff)`, `Sn = 2 Yeff sqrt(R* deltan)` [kg/s].
    pub gamman: L,
    /// `gammat = -2 sqrt(5/6) betaeff sqrt(St meff)`, `St = kt` (0 without tangential damping).
    pub gammat: L,
}

/// Hertz normal force with restitution damping, `R*` = [`ContactData::reff`]. Evaluation
/// order exactly as in the header (left to right): `Sn = (2 Y*) s`, `St = kt = (8 G*) s`,
/// `kn = ((4/3) Y*) s` with `s = sqrt(R* deltan)`, `gamman = ((-2 sqrt(5/6)) beta)
/// sqrt(Sn meff)`, `gammat` likewise with `St`, `Fn = (-gamman) vn + kn deltan`.
///
/// With e = 1 (the paper's), beta = +0 and `(-2 sqrt(5/6)) beta` = -0: `-0 * sqrt(x)` is -0
/// for every finite x >= 0 (`Sn meff`, `St meff` of a touching contact), so the square roots
/// are skipped and the products written as the -0 they are.
#[inline(always)]
pub fn force<L: Lanes>(cd: &ContactData<L>, p: &PairParams) -> NormalForce<L> {
    let reff = cd.reff();
    let sqrtval = (reff * cd.deltan).sqrt();
    let sn = cd.splat(2.0 * p.y_eff) * sqrtval;
    let st = cd.splat(8.0 * p.g_eff) * sqrtval;
    let kn = cd.splat(4.0 / 3.0 * p.y_eff) * sqrtval;
    let kt = st;
    let gamma_c = cd.splat(-2.0 * SQRT_FIVE_OVER_SIX * p.beta_eff);
    let undamped = p.beta_eff == 0.0;
    let gamman = if undamped {
        gamma_c
    } else {
        gamma_c * (sn * cd.meff).sqrt()
    };
    let gammat = if !p.tangential_damping {
        cd.splat(0.0)
    } else if undamped {
        gamma_c
    } else {
        gamma_c * (st * cd.meff).sqrt()
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
#[inline(always)]
pub fn apply<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    fi: &mut ForceData<L>,
    fj: &mut ForceData<L>,
) {
    for k in 0..3 {
        fi.delta_f[k] = fi.delta_f[k] + nf.fn_ * cd.en[k];
    }
    if !cd.is_wall {
        for k in 0..3 {
            fj.delta_f[k] = fj.delta_f[k] + -fi.delta_f[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::surface::default::surface;
    use super::super::super::test_support::{pair, params};
    use super::*;
    use crate::solver::contact::models::RollingModel;
    use approx::assert_relative_eq;

    #[test]
    fn static_hertz_force_matches_formula() {
        let mut cd = pair([0.0; 3]);
        surface(&mut cd);
        let p = params(RollingModel::Off);
        let nf = force(&cd, &p);
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
        surface(&mut cd);
        let p = params(RollingModel::Off);
        let nf = force(&cd, &p);
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
