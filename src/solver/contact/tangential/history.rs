//! `tangential history` (tangential_model_history.h,
//! `TangentialModel<TANGENTIAL_HISTORY>::surfacesIntersect`).

use super::super::normal::NormalForce;
use super::super::{ContactData, ForceData};
use crate::solver::material::PairParams;
use crate::solver::vec3::V3;

/// Incremental tangential spring with Coulomb limit. LIGGGHTS' algorithm, in its order:
/// 1. if updating: `shear += vtr dt`, then project onto the tangent plane:
///    `shear -= (shear . en) en` (no rotation of the history, only this projection);
/// 2. `Ft = -kt shear`; `Ft_shear = kt |shear|`, `Ft_friction = mu_p |Fn|`;
/// 3. sliding (`Ft_shear > Ft_friction`): `Ft *= Ft_friction / Ft_shear` and, if updating,
///    `shear = -Ft / kt` (the history is capped); a zero `|shear|` gives `Ft = 0`;
///    sticking: `Ft -= gammat vtr` (the dashpot acts only while sticking, and is never stored);
/// 4. torques `t_i = -cri (en x Ft)`, `t_j = -crj (en x Ft)`.
///
/// Adds `Ft` / `t_i` to i and `-Ft` / `t_j` to j, returns `Ft`.
pub fn history(
    cd: &ContactData,
    nf: &NormalForce,
    p: &PairParams,
    shear: &mut V3,
    update_history: bool,
    fi: &mut ForceData,
    fj: &mut ForceData,
) -> V3 {
    let [enx, eny, enz] = cd.en;
    if update_history {
        let dt = p.dt;
        shear[0] += cd.vtr[0] * dt;
        shear[1] += cd.vtr[1] * dt;
        shear[2] += cd.vtr[2] * dt;
        let rsht = shear[0] * enx + shear[1] * eny + shear[2] * enz;
        shear[0] -= rsht * enx;
        shear[1] -= rsht * eny;
        shear[2] -= rsht * enz;
    }
    let shrmag = (shear[0] * shear[0] + shear[1] * shear[1] + shear[2] * shear[2]).sqrt();
    let kt = nf.kt;
    let xmu = p.coeff_frict;
    let mut ft = [-(kt * shear[0]), -(kt * shear[1]), -(kt * shear[2])];
    let ft_shear = kt * shrmag;
    let ft_friction = xmu * nf.fn_.abs();
    if ft_shear > ft_friction {
        if shrmag != 0.0 {
            let ratio = ft_friction / ft_shear;
            ft = [ft[0] * ratio, ft[1] * ratio, ft[2] * ratio];
            if update_history {
                *shear = [-ft[0] / kt, -ft[1] / kt, -ft[2] / kt];
            }
        } else {
            ft = [0.0; 3];
        }
    } else {
        let g = nf.gammat;
        ft = [
            ft[0] - g * cd.vtr[0],
            ft[1] - g * cd.vtr[1],
            ft[2] - g * cd.vtr[2],
        ];
    }
    let tor = [
        eny * ft[2] - enz * ft[1],
        enz * ft[0] - enx * ft[2],
        enx * ft[1] - eny * ft[0],
    ];
    for k in 0..3 {
        fi.delta_f[k] += ft[k];
        fi.delta_torque[k] += -cd.cri * tor[k];
    }
    if !cd.is_wall {
        for k in 0..3 {
            fj.delta_f[k] += -ft[k];
            fj.delta_torque[k] += -cd.crj * tor[k];
        }
    }
    ft
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
    fn sticking_spring_then_coulomb_cap() {
        let p = params(RollingModel::Off);
        let mut cd = pair([0.0; 3]);
        cd.v_i = [1e-3, 0.0, 0.0]; // i slides +x on j
        default_surface(&mut cd);
        let nf = hertz(&cd, &p);
        let mut shear = [0.0; 3];
        let (mut fi, mut fj) = (ForceData::default(), ForceData::default());
        // one step: shear = v dt, Ft = -kt v dt - gammat v (stick)
        let ft = history(&cd, &nf, &p, &mut shear, true, &mut fi, &mut fj);
        assert_relative_eq!(shear[0], 1e-3 * 1e-8, max_relative = 1e-15);
        assert_relative_eq!(
            ft[0],
            -nf.kt * 1e-11 - nf.gammat * 1e-3,
            max_relative = 1e-12
        );
        assert_eq!(fj.delta_f[0], -fi.delta_f[0]);
        // a shear far beyond the limit is capped at mu_p Fn and stored capped
        shear = [1.0, 0.0, 0.0];
        let ft = history(&cd, &nf, &p, &mut shear, true, &mut fi, &mut fj);
        assert_relative_eq!(ft[0].abs(), 0.5 * nf.fn_, max_relative = 1e-14);
        assert_relative_eq!(shear[0], 0.5 * nf.fn_ / nf.kt, max_relative = 1e-14);
    }

    #[test]
    fn history_is_untouched_without_update() {
        let p = params(RollingModel::Off);
        let mut cd = pair([0.0; 3]);
        cd.v_i = [1e-3, 0.0, 0.0];
        default_surface(&mut cd);
        let nf = hertz(&cd, &p);
        let mut shear = [1.0, 0.0, 0.0];
        let (mut fi, mut fj) = (ForceData::default(), ForceData::default());
        history(&cd, &nf, &p, &mut shear, false, &mut fi, &mut fj);
        assert_eq!(shear, [1.0, 0.0, 0.0]);
    }

    #[test]
    fn torque_is_minus_lever_cross_force() {
        // Ft along +x on the upper sphere i, en = +z: t_i = -cri (ez x Ft) = -cri Ft ey.
        let p = params(RollingModel::Off);
        let mut cd = pair([0.0; 3]);
        default_surface(&mut cd);
        let nf = hertz(&cd, &p);
        let mut shear = [-1e-9, 0.0, 0.0];
        let (mut fi, mut fj) = (ForceData::default(), ForceData::default());
        let ft = history(&cd, &nf, &p, &mut shear, false, &mut fi, &mut fj);
        assert!(ft[0] > 0.0);
        assert_relative_eq!(fi.delta_torque[1], -cd.cri * ft[0], max_relative = 1e-14);
    }
}
