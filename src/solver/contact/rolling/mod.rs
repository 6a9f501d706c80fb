//! Rolling resistance. Keyword = LIGGGHTS `rolling_friction <kw>` (rolling_model_<kw>.h);
//! `epsd_implicit` is ours (epsd's spring with the dashpot left to the integrator). The
//! variants do not share a formula: cdt uses `kn deltan`, epsd/epsd3 build `k_r` from
//! `kn`, epsd2 from `kt`; only epsd and epsd3 add the viscous dashpot in the kernel. What
//! they share (the relative rotation, its tangential part, the rolling inertia, the
//! elastic-plastic spring, the dashpot coefficient) is written once here.

pub mod cdt;
pub mod epsd;
pub mod epsd2;
pub mod epsd3;
pub mod epsd_implicit;

use super::data::{ContactData, ForceData};
use super::lanes::{select3, Lanes, Mask};
use super::normal::NormalForce;
use crate::solver::material::PairParams;
use crate::solver::vec3::dot;

pub use super::data::pair_reff;

/// Adds the rolling torque as every rolling header does: `i -= r_torque`, `j += r_torque`
/// (the j part is discarded for walls).
#[inline(always)]
pub fn apply<L: Lanes>(r_torque: [L; 3], fi: &mut ForceData<L>, fj: &mut ForceData<L>) {
    for k in 0..3 {
        fi.delta_torque[k] = fi.delta_torque[k] - r_torque[k];
        fj.delta_torque[k] = fj.delta_torque[k] + r_torque[k];
    }
}

/// Relative angular velocity the rolling models see: `omega_i - omega_j` for pairs,
/// the surface model's `wr = cr omega_i / r` for walls.
#[inline(always)]
pub fn relative_rotation<L: Lanes>(cd: &ContactData<L>) -> [L; 3] {
    if cd.is_wall {
        cd.wr
    } else {
        [
            cd.omega_i[0] - cd.omega_j[0],
            cd.omega_i[1] - cd.omega_j[1],
            cd.omega_i[2] - cd.omega_j[2],
        ]
    }
}

/// Rolling inertia of epsd/epsd3 (3D): wall [`wall_rolling_inertia`], pair
/// [`pair_rolling_inertia`].
#[inline(always)]
pub fn rolling_inertia<L: Lanes>(cd: &ContactData<L>, reff: L) -> L {
    if cd.is_wall {
        wall_rolling_inertia(cd.mi, reff)
    } else {
        pair_rolling_inertia(cd.mi, cd.radi, cd.mj, cd.radj)
    }
}

/// Rolling inertia at a wall: `1.4 mi reff^2`, evaluated left to right.
#[inline(always)]
pub fn wall_rolling_inertia<L: Lanes>(mi: L, reff: L) -> L {
    mi.splat(1.4) * mi * reff * reff
}

/// Rolling inertia of a pair: `1.4 (mi radi^2)(mj radj^2) / (mi radi^2 + mj radj^2)`,
/// evaluated left to right.
#[inline(always)]
pub fn pair_rolling_inertia<L: Lanes>(mi: L, radi: L, mj: L, radj: L) -> L {
    let a = mi * radi * radi;
    let b = mj * radj * radj;
    mi.splat(1.4) * a * b / (a + b)
}

/// The part of `wr` the spring sees: all of it with `torsionTorque on`, else the part
/// perpendicular to the normal, `wr - (wr . en) en`.
#[inline(always)]
pub fn tangential_part<L: Lanes>(wr: [L; 3], en: [L; 3], torsion_torque: bool) -> [L; 3] {
    if torsion_torque {
        wr
    } else {
        let d = dot(wr, en);
        [wr[0] - en[0] * d, wr[1] - en[1] * d, wr[2] - en[2] * d]
    }
}

/// The elastic-plastic spring shared by epsd, epsd2, epsd3 and epsd_implicit
/// (`calcRollTorque`), given the model's `k_r`: `M = M_old + wr_tot (dt k_r)`, with
/// `wr_tot` the [`tangential_part`] of the [`relative_rotation`]; if `|M| > |Fn| reff mu_r`,
/// `M` is scaled onto that limit. The history stores `M` when updating. Returns `M`,
/// `wr_tot` and the lanes at the limit; whether a dashpot is added is the model's.
#[inline(always)]
pub fn spring<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    p: &PairParams,
    kr: L,
    hist: &mut [L; 3],
    update_history: bool,
) -> ([L; 3], [L; 3], L::M) {
    let wr_tot = tangential_part(relative_rotation(cd), cd.en, p.torsion_torque);
    let m_max = nf.fn_.abs() * cd.reff() * cd.splat(p.coeff_roll_frict);
    let s = cd.splat(p.dt) * kr;
    let mut m = [
        hist[0] + wr_tot[0] * s,
        hist[1] + wr_tot[1] * s,
        hist[2] + wr_tot[2] * s,
    ];
    let mag = dot(m, m).sqrt();
    let capped = mag.gt(m_max);
    if capped.any() {
        let factor = m_max / mag;
        m = select3(capped, [m[0] * factor, m[1] * factor, m[2] * factor], m);
    }
    if update_history {
        *hist = m;
    }
    (m, wr_tot, capped)
}

/// The dashpot coefficient of epsd, epsd3 and epsd_implicit below the limit:
/// `C_r = eta_r 2 sqrt(I_r k_r)`, evaluated `(eta_r 2) sqrt(I_r k_r)`. With eta_r = 0 it is
/// `+0 sqrt(x)` = +0 for the finite `I_r k_r >= 0` of a touching contact: the square root is
/// skipped.
#[inline(always)]
pub fn dashpot_coefficient<L: Lanes>(cd: &ContactData<L>, p: &PairParams, kr: L) -> L {
    if p.coeff_roll_visc == 0.0 {
        cd.splat(0.0)
    } else {
        let r_inertia = rolling_inertia(cd, cd.reff());
        cd.splat(p.coeff_roll_visc * 2.0) * (r_inertia * kr).sqrt()
    }
}

/// The body shared by epsd and epsd3 (`calcRollTorque`), given the model's `k_r`: the
/// [`spring`], and below the limit the dashpot `C_r wr_tot` ([`dashpot_coefficient`]) added
/// to the applied torque but never stored; at the limit the dashpot is off.
#[inline(always)]
pub fn spring_dashpot<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    p: &PairParams,
    kr: L,
    hist: &mut [L; 3],
    update_history: bool,
) -> ([L; 3], L::M) {
    let (m, wr_tot, capped) = spring(cd, nf, p, kr, hist, update_history);
    if capped.not().any() {
        let r_coef = dashpot_coefficient(cd, p, kr);
        let damped = [
            m[0] + r_coef * wr_tot[0],
            m[1] + r_coef * wr_tot[1],
            m[2] + r_coef * wr_tot[2],
        ];
        (select3(capped, m, damped), capped)
    } else {
        (m, capped)
    }
}
