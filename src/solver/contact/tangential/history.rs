//! `tangential history` (tangential_model_history.h,
//! `TangentialModel<TANGENTIAL_HISTORY>::surfacesIntersect`).

use super::super::data::{ContactData, ForceData};
use super::super::lanes::{select3, Lanes, Mask};
use super::super::normal::NormalForce;
use crate::solver::material::PairParams;
use crate::solver::vec3::dot;

/// Incremental tangential spring with Coulomb limit. LIGGGHTS' algorithm, in its order:
/// 1. if updating: `shear += vtr dt`, then project onto the tangent plane:
///    `shear -= (shear . en) en` (no rotation of the history, only this projection);
/// 2. `Ft = -kt shear`; `Ft_shear = kt |shear|`, `Ft_friction = mu_p |Fn|`;
/// 3. sliding (`Ft_shear > Ft_friction`): `Ft *= Ft_friction / Ft_shear` and, if updating,
///    `shear = -Ft / kt` (the history is capped); a zero `|shear|` gives `Ft = 0`;
///    sticking: `Ft -= gammat vtr` (the dashpot acts only while sticking, and is never stored);
/// 4. torques `t_i = -cri (en x Ft)`, `t_j = -crj (en x Ft)`.
///
/// Adds `Ft` / `t_i` to i and `-Ft` / `t_j` to j, returns `Ft`. Each side of the Coulomb
/// branch is computed only if some lane takes it (a side no lane takes would be discarded by
/// every select, so skipping it changes no bit).
#[inline(always)]
pub fn force<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    p: &PairParams,
    shear: &mut [L; 3],
    update_history: bool,
    fi: &mut ForceData<L>,
    fj: &mut ForceData<L>,
) -> [L; 3] {
    let zero = cd.splat(0.0);
    let en = cd.en;
    if update_history {
        let dt = cd.splat(p.dt);
        for k in 0..3 {
            shear[k] = shear[k] + cd.vtr[k] * dt;
        }
        let rsht = dot(*shear, en);
        for k in 0..3 {
            shear[k] = shear[k] - rsht * en[k];
        }
    }
    let shrmag = dot(*shear, *shear).sqrt();
    let kt = nf.kt;
    let ft0 = [-(kt * shear[0]), -(kt * shear[1]), -(kt * shear[2])];
    let ft_shear = kt * shrmag;
    let ft_friction = cd.splat(p.coeff_frict) * nf.fn_.abs();
    let slide = ft_shear.gt(ft_friction);
    let nonzero = shrmag.ne(zero);
    let ft_slide = if slide.any() {
        let ratio = ft_friction / ft_shear;
        let ft_slide = select3(
            nonzero,
            [ft0[0] * ratio, ft0[1] * ratio, ft0[2] * ratio],
            [zero; 3],
        );
        let capped = slide.and(nonzero);
        if update_history && capped.any() {
            let stored = [-ft_slide[0] / kt, -ft_slide[1] / kt, -ft_slide[2] / kt];
            *shear = select3(capped, stored, *shear);
        }
        ft_slide
    } else {
        [zero; 3]
    };
    let ft = if slide.not().any() {
        let g = nf.gammat;
        let ft_stick = [
            ft0[0] - g * cd.vtr[0],
            ft0[1] - g * cd.vtr[1],
            ft0[2] - g * cd.vtr[2],
        ];
        select3(slide, ft_slide, ft_stick)
    } else {
        ft_slide
    };
    let tor = [
        en[1] * ft[2] - en[2] * ft[1],
        en[2] * ft[0] - en[0] * ft[2],
        en[0] * ft[1] - en[1] * ft[0],
    ];
    for k in 0..3 {
        fi.delta_f[k] = fi.delta_f[k] + ft[k];
        fi.delta_torque[k] = fi.delta_torque[k] + -cd.cri * tor[k];
    }
    if !cd.is_wall {
        for k in 0..3 {
            fj.delta_f[k] = fj.delta_f[k] + -ft[k];
            fj.delta_torque[k] = fj.delta_torque[k] + -cd.crj * tor[k];
        }
    }
    ft
}

/// The shear loop's sliding label of a contact (`PairAux::sliding`, not a LIGGGHTS value):
/// `|Ft|^2 >= (mu_p |Fn|)^2 (1 - 1e-9)`, at the Coulomb limit to round-off.
#[inline(always)]
pub fn sliding<L: Lanes>(ft: [L; 3], fn_: L, p: &PairParams) -> L::M {
    let cap = fn_.splat(p.coeff_frict) * fn_.abs();
    dot(ft, ft).ge(cap * cap * fn_.splat(1.0 - 1e-9))
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
    fn sticking_spring_then_coulomb_cap() {
        let p = params(RollingModel::Off);
        let mut cd = pair([0.0; 3]);
        cd.v_i = [1e-3, 0.0, 0.0]; // i slides +x on j
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
        let mut shear = [0.0; 3];
        let (mut fi, mut fj) = (ForceData::default(), ForceData::default());
        // one step: shear = v dt, Ft = -kt v dt - gammat v (stick)
        let ft = force(&cd, &nf, &p, &mut shear, true, &mut fi, &mut fj);
        assert_relative_eq!(shear[0], 1e-3 * 1e-8, max_relative = 1e-15);
        assert_relative_eq!(
            ft[0],
            -nf.kt * 1e-11 - nf.gammat * 1e-3,
            max_relative = 1e-12
        );
        assert_eq!(fj.delta_f[0], -fi.delta_f[0]);
        // a shear far beyond the limit is capped at mu_p Fn and stored capped
        shear = [1.0, 0.0, 0.0];
        let ft = force(&cd, &nf, &p, &mut shear, true, &mut fi, &mut fj);
        assert_relative_eq!(ft[0].abs(), 0.5 * nf.fn_, max_relative = 1e-14);
        assert_relative_eq!(shear[0], 0.5 * nf.fn_ / nf.kt, max_relative = 1e-14);
    }

    /// The sliding label: at the Coulomb limit to round-off, not below it (a cargo-mutants
    /// survivor: the label's tolerance `1 - 1e-9` could become `1 / 1e-9` unseen). The cap
    /// is not 1 N, so that `cap / cap` for `cap * cap` (run 8's survivor, when mu_p Fn was
    /// exactly 1) is seen too.
    #[test]
    fn sliding_is_the_coulomb_limit_to_round_off() {
        let p = params(RollingModel::Off);
        let fn_ = 3.0;
        let cap = p.coeff_frict * fn_;
        assert!(sliding::<f64>([cap, 0.0, 0.0], fn_, &p));
        assert!(sliding::<f64>([0.0, 0.0, -cap * (1.0 - 1e-12)], -fn_, &p));
        assert!(!sliding::<f64>([cap * (1.0 - 1e-6), 0.0, 0.0], fn_, &p));
        assert!(!sliding::<f64>([0.5 * cap, 0.0, 0.0], fn_, &p));
    }

    #[test]
    fn history_is_untouched_without_update() {
        let p = params(RollingModel::Off);
        let mut cd = pair([0.0; 3]);
        cd.v_i = [1e-3, 0.0, 0.0];
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
        let mut shear = [1.0, 0.0, 0.0];
        let (mut fi, mut fj) = (ForceData::default(), ForceData::default());
        force(&cd, &nf, &p, &mut shear, false, &mut fi, &mut fj);
        assert_eq!(shear, [1.0, 0.0, 0.0]);
    }

    #[test]
    fn torque_is_minus_lever_cross_force() {
        // Ft along +x on the upper sphere i, en = +z: t_i = -cri (ez x Ft) = -cri Ft ey.
        let p = params(RollingModel::Off);
        let mut cd = pair([0.0; 3]);
        surface(&mut cd);
        let nf = hertz::force(&cd, &p);
        let mut shear = [-1e-9, 0.0, 0.0];
        let (mut fi, mut fj) = (ForceData::default(), ForceData::default());
        let ft = force(&cd, &nf, &p, &mut shear, false, &mut fi, &mut fj);
        assert!(ft[0] > 0.0);
        assert_relative_eq!(fi.delta_torque[1], -cd.cri * ft[0], max_relative = 1e-14);
    }
}
