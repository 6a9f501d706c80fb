//! The particle-pair contact over lanes ([`super::lanes::Lanes`]): pair_gran_base.h's
//! geometry and [`super::surfaces_intersect`] on 4 or 8 pairs at once, the results of the
//! lanes that do not touch replaced by zeros and their history kept. The contact law itself
//! is not written here: it is the one chain of `super::{surface, normal, tangential,
//! rolling}`, the same code the scalar pass runs with `L = f64`, so the SIMD passes give the
//! scalar bits by construction (each operation one IEEE operation per lane, branches on
//! values as per-lane selects, see `super::lanes`).

use super::data::{pair_geometry, ContactData, ContactHistory};
use super::lanes::{select3, Lanes, Mask};
use super::{surfaces_intersect, tangential};
use crate::solver::material::PairParams;

/// Inputs of a lane's pair: both particles' state, the image shift of j and the history.
#[derive(Clone, Copy)]
pub struct PairIn<L> {
    pub xi: [L; 3],
    pub xj: [L; 3],
    pub shift: [L; 3],
    pub radi: L,
    pub radj: L,
    pub mi: L,
    pub mj: L,
    pub vi: [L; 3],
    pub vj: [L; 3],
    pub wi: [L; 3],
    pub wj: [L; 3],
    pub shear: [L; 3],
    pub r_torque: [L; 3],
}

/// Outputs of a lane's pair. For a lane that does not touch: forces, damping and flags are
/// zero and the history is the input's.
#[derive(Clone, Copy)]
pub struct PairOut<L: Lanes> {
    pub touch: L::M,
    pub fi: [L; 3],
    pub ti: [L; 3],
    pub fj: [L; 3],
    pub tj: [L; 3],
    pub shear: [L; 3],
    pub r_torque: [L; 3],
    /// epsd_implicit's dashpot coefficient C_r (0 elsewhere and at the rolling limit).
    pub damping: L,
    pub en: [L; 3],
    /// The rolling resistance is at full mobilisation (`ContactOutcome::rolling_mobilised`).
    pub mobilised: L::M,
    /// `|Ft|^2 >= (mu |Fn|)^2 (1 - 1e-9)`: the label of the shear loop's `PairAux::sliding`.
    pub sliding: L::M,
}

/// pair_gran_base.h's contact test alone ([`pair_geometry`]): `!(rsq >= radsum^2)`.
#[inline(always)]
pub fn touching<L: Lanes>(xi: [L; 3], xj: [L; 3], shift: [L; 3], radi: L, radj: L) -> L::M {
    pair_geometry(xi, xj, shift, radi, radj).2
}

/// One pair per lane: [`pair_geometry`], [`ContactData::pair`], [`surfaces_intersect`] and
/// the sliding label ([`tangential::history::sliding`]). `update_history` is LIGGGHTS'
/// `shearupdate`.
#[inline(always)]
pub fn pair<L: Lanes>(a: &PairIn<L>, p: &PairParams, update_history: bool) -> PairOut<L> {
    let zero = a.radi.splat(0.0);
    let (delta, rsq, touch) = pair_geometry(a.xi, a.xj, a.shift, a.radi, a.radj);
    let mut cd = ContactData::pair(
        delta,
        rsq,
        a.radi,
        a.radj,
        a.mi,
        a.mj,
        (a.vi, a.vj),
        (a.wi, a.wj),
    );
    let mut hist = ContactHistory {
        shear: a.shear,
        r_torque: a.r_torque,
    };
    let (fi, fj, o) = surfaces_intersect(&mut cd, p, &mut hist, update_history);
    let sliding = tangential::history::sliding(o.ft, o.normal.fn_, p);
    PairOut {
        touch,
        fi: select3(touch, fi.delta_f, [zero; 3]),
        ti: select3(touch, fi.delta_torque, [zero; 3]),
        fj: select3(touch, fj.delta_f, [zero; 3]),
        tj: select3(touch, fj.delta_torque, [zero; 3]),
        shear: select3(touch, hist.shear, a.shear),
        r_torque: select3(touch, hist.r_torque, a.r_torque),
        damping: L::select(touch, o.implicit_damping, zero),
        en: select3(touch, cd.en, [zero; 3]),
        mobilised: touch.and(o.rolling_mobilised),
        sliding: touch.and(sliding),
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{params, DENSITY};
    use super::*;
    use crate::solver::contact::models::RollingModel;
    use crate::solver::material::sphere_mass;

    fn input(gap: f64) -> PairIn<f64> {
        let m = sphere_mass(1e-4, DENSITY);
        PairIn {
            xi: [0.0, 0.0, 2e-4 + gap],
            xj: [0.3, 0.0, 0.0],
            shift: [-0.3, 0.0, 0.0],
            radi: 1e-4,
            radj: 1e-4,
            mi: m,
            mj: m,
            vi: [0.01, -0.02, -0.05],
            vj: [0.0, 0.01, 0.02],
            wi: [10.0, 50.0, -3.0],
            wj: [-4.0, 0.0, 7.0],
            shear: [3e-8, -1e-8, 2e-9],
            r_torque: [1e-9, 2e-9, -5e-10],
        }
    }

    /// One lane of `f64`: a touching pair gives the scalar chain's bits (the pass on a CPU
    /// without AVX2 runs the scalar chain, this is the batch's own `L = f64`); a pair apart
    /// gives zeros and keeps its history, bit for bit.
    #[test]
    fn one_lane_is_the_scalar_chain_and_apart_is_zero() {
        for model in RollingModel::ALL {
            let p = params(model);
            for update in [false, true] {
                let a = input(-1e-6);
                let o = pair(&a, &p, update);
                assert!(o.touch, "{model:?}");
                let (delta, rsq, _) = pair_geometry(a.xi, a.xj, a.shift, a.radi, a.radj);
                let mut cd = ContactData::pair(
                    delta,
                    rsq,
                    a.radi,
                    a.radj,
                    a.mi,
                    a.mj,
                    (a.vi, a.vj),
                    (a.wi, a.wj),
                );
                let mut h = ContactHistory {
                    shear: a.shear,
                    r_torque: a.r_torque,
                };
                let (fi, fj, s) = surfaces_intersect(&mut cd, &p, &mut h, update);
                let bits = |v: [f64; 3]| v.map(f64::to_bits);
                assert_eq!(bits(o.fi), bits(fi.delta_f), "{model:?}");
                assert_eq!(bits(o.ti), bits(fi.delta_torque), "{model:?}");
                assert_eq!(bits(o.fj), bits(fj.delta_f), "{model:?}");
                assert_eq!(bits(o.tj), bits(fj.delta_torque), "{model:?}");
                assert_eq!(bits(o.shear), bits(h.shear), "{model:?}");
                assert_eq!(bits(o.r_torque), bits(h.r_torque), "{model:?}");
                assert_eq!(o.damping.to_bits(), s.implicit_damping.to_bits());
                assert_eq!(o.mobilised, s.rolling_mobilised);
                assert!(o.fi != [0.0; 3] && (update || o.shear == a.shear));
                let apart = input(1e-6);
                let o = pair(&apart, &p, update);
                assert!(!o.touch && !o.mobilised && !o.sliding);
                assert_eq!(bits(o.fi), [0; 3]);
                assert_eq!(bits(o.tj), [0; 3]);
                assert_eq!(o.damping.to_bits(), 0);
                assert_eq!(bits(o.shear), bits(apart.shear));
                assert_eq!(bits(o.r_torque), bits(apart.r_torque));
            }
        }
    }
}
