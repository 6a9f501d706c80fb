//! Rolling resistance. Keyword = LIGGGHTS `rolling_friction <kw>` (rolling_model_<kw>.h).
//! The variants do not share a formula: cdt uses `kn deltan`, epsd/epsd3 build `k_r` from
//! `kn`, epsd2 from `kt`; only epsd and epsd3 have the viscous dashpot.

pub mod cdt;
pub mod epsd;
pub mod epsd2;
pub mod epsd3;

use super::normal::NormalForce;
use super::{ContactData, ForceData};
use crate::solver::material::PairParams;
use crate::solver::vec3::V3;

/// Adds the rolling torque as every rolling header does: `i -= r_torque`, `j += r_torque`
/// (the j part is discarded for walls).
pub fn apply(r_torque: V3, fi: &mut ForceData, fj: &mut ForceData) {
    for k in 0..3 {
        fi.delta_torque[k] -= r_torque[k];
        fj.delta_torque[k] += r_torque[k];
    }
}

/// Relative angular velocity the rolling models see: `omega_i - omega_j` for pairs,
/// the surface model's `wr = cr omega_i / r` for walls.
pub fn relative_rotation(cd: &ContactData) -> V3 {
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

/// `reff`: `radi` for walls, else [`pair_reff`].
pub fn reff(cd: &ContactData) -> f64 {
    if cd.is_wall {
        cd.radi
    } else {
        pair_reff(cd.radi, cd.radj)
    }
}

/// `reff` of a pair: `radi radj / (radi + radj)`.
pub fn pair_reff(radi: f64, radj: f64) -> f64 {
    radi * radj / (radi + radj)
}

/// Rolling inertia of epsd/epsd3 (3D): wall [`wall_rolling_inertia`], pair
/// [`pair_rolling_inertia`].
pub fn rolling_inertia(cd: &ContactData, reff: f64) -> f64 {
    if cd.is_wall {
        wall_rolling_inertia(cd.mi, reff)
    } else {
        pair_rolling_inertia(cd.mi, cd.radi, cd.mj, cd.radj)
    }
}

/// Rolling inertia at a wall: `1.4 mi reff^2`, evaluated left to right.
pub fn wall_rolling_inertia(mi: f64, reff: f64) -> f64 {
    1.4 * mi * reff * reff
}

/// Rolling inertia of a pair: `1.4 (mi radi^2)(mj radj^2) / (mi radi^2 + mj radj^2)`,
/// evaluated left to right.
pub fn pair_rolling_inertia(mi: f64, radi: f64, mj: f64, radj: f64) -> f64 {
    let a = mi * radi * radi;
    let b = mj * radj * radj;
    1.4 * a * b / (a + b)
}

/// The part of `wr` the spring sees: all of it with `torsionTorque on`, else the part
/// perpendicular to the normal, `wr - (wr . en) en`.
pub fn tangential_part(wr: V3, en: V3, torsion_torque: bool) -> V3 {
    if torsion_torque {
        wr
    } else {
        let d = wr[0] * en[0] + wr[1] * en[1] + wr[2] * en[2];
        [wr[0] - en[0] * d, wr[1] - en[1] * d, wr[2] - en[2] * d]
    }
}

/// The elastic-plastic spring shared by epsd, epsd2 and epsd3 (`calcRollTorque`):
/// `M = M_old + k_r dt wr_tot`; if `|M| > |Fn| reff mu_r`, scale it onto that limit.
/// Returns (`M`, whether it was capped). The caller decides what is stored and whether the
/// dashpot is added, since the three headers differ there.
pub fn spring(old: V3, wr_tot: V3, kr: f64, dt: f64, m_max: f64) -> (V3, bool) {
    let s = dt * kr;
    let mut m = [
        old[0] + wr_tot[0] * s,
        old[1] + wr_tot[1] * s,
        old[2] + wr_tot[2] * s,
    ];
    let mag = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
    if mag > m_max {
        let factor = m_max / mag;
        m = [m[0] * factor, m[1] * factor, m[2] * factor];
        (m, true)
    } else {
        (m, false)
    }
}

/// The body shared by epsd and epsd3 (`calcRollTorque`), given the model's `k_r(kn, reff)`:
/// `M = M_old + k_r dt wr_tot`, capped at `|Fn| reff mu_r`; the history stores `M`; below the
/// cap the dashpot `C_r wr_tot`, `C_r = eta_r 2 sqrt(I_r k_r)`, is added but never stored.
pub fn spring_dashpot(
    cd: &ContactData,
    nf: &NormalForce,
    p: &PairParams,
    hist: &mut V3,
    update_history: bool,
    kr: impl Fn(f64, f64) -> f64,
) -> (V3, bool) {
    let reff = reff(cd);
    let r_inertia = rolling_inertia(cd, reff);
    let wr_tot = tangential_part(relative_rotation(cd), cd.en, p.torsion_torque);
    let kr = kr(nf.kn, reff);
    let m_max = nf.fn_.abs() * reff * p.coeff_roll_frict;
    let (mut m, capped) = spring(*hist, wr_tot, kr, p.dt, m_max);
    if update_history {
        *hist = m;
    }
    if !capped {
        let r_coef = p.coeff_roll_visc * 2.0 * (r_inertia * kr).sqrt();
        for k in 0..3 {
            m[k] += r_coef * wr_tot[k];
        }
    }
    (m, capped)
}
