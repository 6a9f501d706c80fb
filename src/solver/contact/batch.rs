//! The particle-pair contact (surface default x hertz x tangential history x rolling) as one
//! generic kernel over lanes ([`super::lanes::Lanes`]): the operation sequence of
//! [`super::surfaces_intersect`] for a pair, with its branches turned into per-lane selects, so
//! that 8 contacts go through AVX-512 at once with the bits of the scalar kernel.
//!
//! The order of operations, written out once (every line is the scalar kernel's, each a
//! single IEEE operation per lane; `0 +` marks where the scalar code adds into a zeroed
//! `ForceData`, kept because `0 + (-0) = +0`):
//! 1. pair_gran_base.h: `xj' = xj + shift`, `delta = xi - xj'`,
//!    `rsq = (d0 d0 + d1 d1) + d2 d2`, touching iff `!(rsq >= radsum^2)`;
//!    `r = sqrt(rsq)`, `rinv = 1 / r`, `en = delta rinv`, `meff = (mi mj) / (mi + mj)`.
//! 2. surface_model_default.h: `vr = vi - vj`, `vn = vr . en`, `vt = vr - vn en`,
//!    `deltan = radsum - r`, `cri = radi - 0.5 deltan`, `crj = radj - 0.5 deltan`,
//!    `wr = (cri wi + crj wj) rinv`, `vtr = vt - (delta x wr)` component-wise.
//! 3. normal_model_hertz.h: `reff = (radi radj) / (radi + radj)`, `s = sqrt(reff deltan)`,
//!    `Sn = (2 Y*) s`, `kt = St = (8 G*) s`, `kn = ((4/3) Y*) s`,
//!    `gamman = ((-2 sqrt(5/6)) beta) sqrt(Sn meff)`, `gammat` likewise with `St`,
//!    `Fn = (-gamman) vn + kn deltan`; `fi = 0 + Fn en`, `fj = 0 + (-fi)`.
//! 4. tangential_model_history.h: (update) `shear += vtr dt`, `shear -= (shear . en) en`;
//!    `Ft = -(kt shear)`; sliding iff `kt |shear| > mu |Fn|`: `Ft *= (mu |Fn|) / (kt |shear|)`
//!    (0 if `|shear| == 0`), (update) `shear = (-Ft) / kt`; sticking: `Ft -= gammat vtr`;
//!    `tor = en x Ft`; `fi += Ft`, `ti = 0 + (-cri) tor`, `fj += -Ft`, `tj = 0 + (-crj) tor`.
//! 5. rolling_model_<kw>.h (see `super::rolling`): epsd/epsd2/epsd3 spring
//!    `M = M_old + wr_tot (dt k_r)`, capped at `(|Fn| reff) mu_r`, dashpot (epsd, epsd3) below
//!    the cap; cdt `M = w ((((mu_r kn) deltan) reff) / |w|)`; `ti -= M`, `tj += M`.

use super::lanes::{select3, Lanes, Mask};
use super::normal::SQRT_FIVE_OVER_SIX;
use crate::solver::material::PairParams;
use crate::spec::RollingModel;

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

#[inline(always)]
fn dot<L: Lanes>(a: [L; 3], b: [L; 3]) -> L {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Step 1's contact test alone, on the same operations: `!(rsq >= radsum^2)`.
#[inline(always)]
pub fn touching<L: Lanes>(xi: [L; 3], xj: [L; 3], shift: [L; 3], radi: L, radj: L) -> L::M {
    let xj = [xj[0] + shift[0], xj[1] + shift[1], xj[2] + shift[2]];
    let delta = [xi[0] - xj[0], xi[1] - xj[1], xi[2] - xj[2]];
    let rsq = dot(delta, delta);
    let radsum = radi + radj;
    rsq.ge(radsum * radsum).not()
}

/// One pair per lane (see the module doc for the order of operations). `update_history` is
/// LIGGGHTS' `shearupdate`.
#[inline(always)]
pub fn pair<L: Lanes>(a: &PairIn<L>, p: &PairParams, update_history: bool) -> PairOut<L> {
    let zero = L::splat(0.0);
    // 1. geometry
    let xj = [
        a.xj[0] + a.shift[0],
        a.xj[1] + a.shift[1],
        a.xj[2] + a.shift[2],
    ];
    let delta = [a.xi[0] - xj[0], a.xi[1] - xj[1], a.xi[2] - xj[2]];
    let rsq = dot(delta, delta);
    let radsum = a.radi + a.radj;
    let touch = rsq.ge(radsum * radsum).not();
    let r = rsq.sqrt();
    let rinv = L::splat(1.0) / r;
    let en = [delta[0] * rinv, delta[1] * rinv, delta[2] * rinv];
    let meff = a.mi * a.mj / (a.mi + a.mj);
    // 2. surface model
    let vr = [a.vi[0] - a.vj[0], a.vi[1] - a.vj[1], a.vi[2] - a.vj[2]];
    let vn = dot(vr, en);
    let vt = [vr[0] - vn * en[0], vr[1] - vn * en[1], vr[2] - vn * en[2]];
    let deltan = radsum - r;
    let half = L::splat(0.5);
    let cri = a.radi - half * deltan;
    let crj = a.radj - half * deltan;
    let wr = [
        (cri * a.wi[0] + crj * a.wj[0]) * rinv,
        (cri * a.wi[1] + crj * a.wj[1]) * rinv,
        (cri * a.wi[2] + crj * a.wj[2]) * rinv,
    ];
    let [dx, dy, dz] = delta;
    let vtr = [
        vt[0] - (dz * wr[1] - dy * wr[2]),
        vt[1] - (dx * wr[2] - dz * wr[0]),
        vt[2] - (dy * wr[0] - dx * wr[1]),
    ];
    // 3. hertz
    let reff = a.radi * a.radj / (a.radi + a.radj);
    let sqrtval = (reff * deltan).sqrt();
    let sn = L::splat(2.0 * p.y_eff) * sqrtval;
    let st = L::splat(8.0 * p.g_eff) * sqrtval;
    let kn = L::splat(4.0 / 3.0 * p.y_eff) * sqrtval;
    let kt = st;
    let gamma_c = L::splat(-2.0 * SQRT_FIVE_OVER_SIX * p.beta_eff);
    // With e = 1 (the paper's), beta = +0 and gamma_c = -0: `-0 * sqrt(x)` is -0 for every
    // finite x >= 0 (Sn meff and St meff of a touching pair), so the square roots are skipped
    // and the products written as the -0 they are.
    let undamped = p.beta_eff == 0.0;
    let gamman = if undamped {
        gamma_c
    } else {
        gamma_c * (sn * meff).sqrt()
    };
    let gammat = if !p.tangential_damping {
        zero
    } else if undamped {
        gamma_c
    } else {
        gamma_c * (st * meff).sqrt()
    };
    let fn_ = -gamman * vn + kn * deltan;
    let mut fi = [zero + fn_ * en[0], zero + fn_ * en[1], zero + fn_ * en[2]];
    let mut fj = [zero + -fi[0], zero + -fi[1], zero + -fi[2]];
    // 4. tangential history
    let mut shear = a.shear;
    if update_history {
        let dt = L::splat(p.dt);
        for k in 0..3 {
            shear[k] = shear[k] + vtr[k] * dt;
        }
        let rsht = dot(shear, en);
        for k in 0..3 {
            shear[k] = shear[k] - rsht * en[k];
        }
    }
    let shrmag = dot(shear, shear).sqrt();
    let ft0 = [-(kt * shear[0]), -(kt * shear[1]), -(kt * shear[2])];
    let ft_shear = kt * shrmag;
    let ft_friction = L::splat(p.coeff_frict) * fn_.abs();
    let slide = ft_shear.gt(ft_friction);
    let nonzero = shrmag.ne(zero);
    // Each side of the Coulomb branch is computed only if some lane takes it: a side no lane
    // takes is discarded by every select below, so skipping it changes no bit.
    let ft_slide = if slide.any() {
        let ratio = ft_friction / ft_shear;
        let ft_slide = select3(
            nonzero,
            [ft0[0] * ratio, ft0[1] * ratio, ft0[2] * ratio],
            [zero; 3],
        );
        if update_history && slide.and(nonzero).any() {
            let capped = [-ft_slide[0] / kt, -ft_slide[1] / kt, -ft_slide[2] / kt];
            shear = select3(slide.and(nonzero), capped, shear);
        }
        ft_slide
    } else {
        [zero; 3]
    };
    let ft = if slide.not().any() {
        let ft_stick = [
            ft0[0] - gammat * vtr[0],
            ft0[1] - gammat * vtr[1],
            ft0[2] - gammat * vtr[2],
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
    let mut ti = [zero; 3];
    let mut tj = [zero; 3];
    for k in 0..3 {
        fi[k] = fi[k] + ft[k];
        ti[k] = zero + -cri * tor[k];
        fj[k] = fj[k] + -ft[k];
        tj[k] = zero + -crj * tor[k];
    }
    // 5. rolling
    let w = [a.wi[0] - a.wj[0], a.wi[1] - a.wj[1], a.wi[2] - a.wj[2]];
    let mut r_torque = a.r_torque;
    let mut damping = zero;
    let (m, mobilised) = match p.rolling {
        RollingModel::Off => ([zero; 3], zero.ne(zero)),
        RollingModel::Cdt => {
            let wmag = dot(w, w).sqrt();
            let still = wmag.le(zero);
            let s = L::splat(p.coeff_roll_frict) * kn * deltan * reff / wmag;
            let mut m = [w[0] * s, w[1] * s, w[2] * s];
            if !p.torsion_torque {
                let d = dot(m, en);
                m = [m[0] - en[0] * d, m[1] - en[1] * d, m[2] - en[2] * d];
            }
            let rolling = m[0].ne(zero).or(m[1].ne(zero)).or(m[2].ne(zero));
            (select3(still, [zero; 3], m), still.not().and(rolling))
        }
        model => {
            let wr_tot = if p.torsion_torque {
                w
            } else {
                let d = dot(w, en);
                [w[0] - en[0] * d, w[1] - en[1] * d, w[2] - en[2] * d]
            };
            let rmu = L::splat(p.coeff_roll_frict);
            let kr = match model {
                RollingModel::Epsd2 => kt * reff * reff,
                RollingModel::Epsd3 => {
                    L::splat(p.coeff_roll_stiffness) * kn * rmu * rmu * reff * reff
                }
                _ => L::splat(2.25) * kn * rmu * rmu * reff * reff,
            };
            let m_max = fn_.abs() * reff * rmu;
            let s = L::splat(p.dt) * kr;
            let mut m = [
                a.r_torque[0] + wr_tot[0] * s,
                a.r_torque[1] + wr_tot[1] * s,
                a.r_torque[2] + wr_tot[2] * s,
            ];
            let mag = dot(m, m).sqrt();
            let capped = mag.gt(m_max);
            if capped.any() {
                let factor = m_max / mag;
                m = select3(capped, [m[0] * factor, m[1] * factor, m[2] * factor], m);
            }
            if update_history {
                r_torque = m;
            }
            if matches!(
                model,
                RollingModel::Epsd | RollingModel::Epsd3 | RollingModel::EpsdImplicit
            ) && capped.not().any()
            {
                // eta_r = 0: `(0 * 2) * sqrt(I_r k_r)` is +0 for the finite I_r k_r >= 0 of a
                // touching pair, so the square root is skipped
                let r_coef = if p.coeff_roll_visc == 0.0 {
                    zero
                } else {
                    let ai = a.mi * a.radi * a.radi;
                    let bj = a.mj * a.radj * a.radj;
                    let r_inertia = L::splat(1.4) * ai * bj / (ai + bj);
                    L::splat(p.coeff_roll_visc * 2.0) * (r_inertia * kr).sqrt()
                };
                if model == RollingModel::EpsdImplicit {
                    damping = L::select(capped, zero, r_coef);
                } else {
                    let md = [
                        m[0] + r_coef * wr_tot[0],
                        m[1] + r_coef * wr_tot[1],
                        m[2] + r_coef * wr_tot[2],
                    ];
                    m = select3(capped, m, md);
                }
            }
            (m, capped)
        }
    };
    if p.rolling != RollingModel::Off {
        for k in 0..3 {
            ti[k] = ti[k] - m[k];
            tj[k] = tj[k] + m[k];
        }
    }
    let cap = L::splat(p.coeff_frict) * fn_.abs();
    let sliding = dot(ft, ft).ge(cap * cap * L::splat(1.0 - 1e-9));
    PairOut {
        touch,
        fi: select3(touch, fi, [zero; 3]),
        ti: select3(touch, ti, [zero; 3]),
        fj: select3(touch, fj, [zero; 3]),
        tj: select3(touch, tj, [zero; 3]),
        shear: select3(touch, shear, a.shear),
        r_torque: select3(touch, r_torque, a.r_torque),
        damping: L::select(touch, damping, zero),
        en: select3(touch, en, [zero; 3]),
        mobilised: touch.and(mobilised),
        sliding: touch.and(sliding),
    }
}
