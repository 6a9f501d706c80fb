//! Contact laws, composed as LIGGGHTS composes them (contact_models.h, `ContactModel::
//! surfacesIntersect`): surface model, then normal, then tangential, then rolling, all passing
//! values through one scratch struct ([`ContactData`], LIGGGHTS' `SurfacesIntersectData`).
//! The normal model produces `Fn`, `kn`, `kt` and the damping coefficients that later stages
//! read. Each stage adds to the force/torque increments of both partners ([`ForceData`]).
//!
//! Every kernel is a pure function that mirrors one LIGGGHTS header, operation by operation,
//! so that two-particle histories agree to round-off. The contact history of a contact is
//! [`ContactHistory`] (LIGGGHTS' `contact_history` slots `shearx..z`, `r_torquex_old..z`).
//!
//! History lifetime (found in the LIGGGHTS sources, mirrored by the time loops):
//! - particle-particle: pair_gran_base.h calls `surfacesClose` (which zeroes the history) only
//!   for pairs within `contactDistanceFactor * radsum`; with the default factor 1 it is never
//!   called, so the history of a pair that separates is *kept* until the next neighbour-list
//!   rebuild, which restores it only for pairs touching at that moment (neigh_gran.cpp:
//!   `rsq < radsum*radsum`, else zero history and contact flag 0).
//! - particle-wall (mesh): fix_wall_gran.cpp marks all contacts, `handleContact` keeps only the
//!   intersecting ones, `cleanUpContacts` deletes the rest: the history ends with the contact.
//! - During `setup` of every `run` (Verlet::setup), forces are computed with `shearupdate = 0`:
//!   the kernels run but do not write the history.

pub mod batch;
pub mod lanes;
pub mod normal;
#[cfg(test)]
mod properties;
pub mod rolling;
pub mod surface;
pub mod tangential;

use super::material::PairParams;
use super::vec3::V3;
use crate::spec::RollingModel;

/// LIGGGHTS' `SurfacesIntersectData` for spheres: geometry and kinematics of one contact.
/// `i` is the first partner; for walls `j` is the wall.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactData {
    pub is_wall: bool,
    pub radi: f64,
    /// Radius of partner j (unused for walls).
    pub radj: f64,
    /// `radi + radj` (pair) or `radi` (wall).
    pub radsum: f64,
    /// Centre distance (pair) or `radi - overlap` (wall).
    pub r: f64,
    pub rinv: f64,
    /// `x_i - x_j` (pair) or contact point to centre (wall).
    pub delta: V3,
    /// Unit normal, `delta * rinv`, pointing from j (or the wall) towards i.
    pub en: V3,
    /// Overlap. For walls the mesh code sets it before the surface model runs; the surface
    /// model then overwrites it with `radsum - r` (surface_model_default.h).
    pub deltan: f64,
    pub meff: f64,
    pub mi: f64,
    pub mj: f64,
    pub v_i: V3,
    pub v_j: V3,
    pub omega_i: V3,
    pub omega_j: V3,
    // Written by the surface model:
    pub vn: f64,
    pub wr: V3,
    pub vtr: V3,
    pub cri: f64,
    pub crj: f64,
}

impl ContactData {
    /// A touching particle pair as pair_gran_base.h sets it up: `delta = x_i - x_j` (j's
    /// image), `r = sqrt(rsq)`, `rinv = 1/r`, `en = delta * rinv`, `meff = mi mj / (mi + mj)`.
    #[allow(clippy::too_many_arguments)]
    pub fn pair(
        delta: V3,
        rsq: f64,
        radi: f64,
        radj: f64,
        mi: f64,
        mj: f64,
        v: (V3, V3),
        omega: (V3, V3),
    ) -> Self {
        let r = rsq.sqrt();
        let rinv = 1.0 / r;
        ContactData {
            is_wall: false,
            radi,
            radj,
            radsum: radi + radj,
            r,
            rinv,
            delta,
            en: [delta[0] * rinv, delta[1] * rinv, delta[2] * rinv],
            meff: mi * mj / (mi + mj),
            mi,
            mj,
            v_i: v.0,
            v_j: v.1,
            omega_i: omega.0,
            omega_j: omega.1,
            ..Default::default()
        }
    }

    /// A sphere touching a wall triangle as fix_wall_gran.cpp `post_force_mesh` sets it up:
    /// `deltan = d - r_i` from the triangle test (`resolveTriSphereContactBary`), the contact
    /// `delta` negated, `r = r_i - overlap`, `rinv = 1/r`, `en = delta rinv`, `meff = m_i`,
    /// the wall's velocity at the contact point `v_wall`.
    pub fn wall(
        radi: f64,
        mi: f64,
        delta_to_wall: V3,
        deltan: f64,
        v_i: V3,
        v_wall: V3,
        omega_i: V3,
    ) -> Self {
        let overlap = -deltan;
        let sdelta = [-delta_to_wall[0], -delta_to_wall[1], -delta_to_wall[2]];
        let r = radi - overlap;
        let rinv = 1.0 / r;
        ContactData {
            is_wall: true,
            radi,
            radsum: radi,
            r,
            rinv,
            delta: sdelta,
            en: [sdelta[0] * rinv, sdelta[1] * rinv, sdelta[2] * rinv],
            deltan: overlap,
            meff: mi,
            mi,
            v_i,
            v_j: v_wall,
            omega_i,
            ..Default::default()
        }
    }
}

/// `Neighbor::check_distance` for one atom: it moved more than skin/2 since the last build
/// (`|x - x_hold|^2 > (skin/2)^2`, evaluated as LIGGGHTS does).
pub fn moved_beyond_half_skin(x: V3, hold: V3, skin: f64) -> bool {
    let trigger = 0.5 * skin;
    let d = [x[0] - hold[0], x[1] - hold[1], x[2] - hold[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > trigger * trigger
}

/// Force and torque increments of one partner (LIGGGHTS `ForceData`).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct ForceData {
    pub delta_f: V3,
    pub delta_torque: V3,
}

/// The history slots of one contact, in LIGGGHTS' order: tangential `shearx..z` [m], then
/// (epsd, epsd2, epsd3) `r_torquex_old..z` [N m].
/// `repr(C)`: the batched pair pass reads the slots at fixed offsets.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct ContactHistory {
    pub shear: V3,
    pub r_torque: V3,
}

impl ContactHistory {
    /// Every bit of every value is zero: the default (`+0.0`), unlike a `-0.0` history,
    /// which compares equal to it.
    pub fn all_bits_zero(&self) -> bool {
        self.shear
            .iter()
            .chain(&self.r_torque)
            .all(|v| v.to_bits() == 0)
    }
}

/// Values of one evaluated contact, for observers and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactOutcome {
    pub normal: normal::NormalForce,
    /// Tangential force on i.
    pub ft: V3,
    /// Rolling torque as LIGGGHTS computes it; i receives `-r_torque`, j `+r_torque`.
    pub r_torque: V3,
    /// epsd_implicit: the dashpot coefficient C_r left to the integrator (0 when the spring
    /// is at its limit); the dashpot torque on i is `-C_r P (w_i - w_j)`, P the projector
    /// onto the tangent plane (identity with torsionTorque).
    pub implicit_damping: f64,
    /// The rolling resistance is at full mobilisation: the spring at its limit
    /// `|M| = mu_r R* |Fn|` (epsd, epsd2, epsd3; the epsd dashpot is then off), or any rolling
    /// contact with cdt (no spring, always at the limit).
    pub rolling_mobilised: bool,
}

/// Evaluates one touching contact: `ContactModel::surfacesIntersect` for
/// surface default x normal hertz x tangential history x rolling `p.rolling`.
/// Updates `hist` only when `update_history` (LIGGGHTS `computeflag && shearupdate`).
pub fn surfaces_intersect(
    cd: &mut ContactData,
    p: &PairParams,
    hist: &mut ContactHistory,
    update_history: bool,
) -> (ForceData, ForceData, ContactOutcome) {
    let mut fi = ForceData::default();
    let mut fj = ForceData::default();
    surface::default_surface(cd);
    let nf = normal::hertz(cd, p);
    normal::apply(cd, &nf, &mut fi, &mut fj);
    let ft = tangential::history(
        cd,
        &nf,
        p,
        &mut hist.shear,
        update_history,
        &mut fi,
        &mut fj,
    );
    let mut implicit_damping = 0.0;
    let (r_torque, rolling_mobilised) = match p.rolling {
        RollingModel::Off => ([0.0; 3], false),
        RollingModel::Cdt => rolling::cdt::torque(cd, &nf, p),
        RollingModel::Epsd => rolling::epsd::torque(cd, &nf, p, &mut hist.r_torque, update_history),
        RollingModel::Epsd2 => {
            rolling::epsd2::torque(cd, &nf, p, &mut hist.r_torque, update_history)
        }
        RollingModel::Epsd3 => {
            rolling::epsd3::torque(cd, &nf, p, &mut hist.r_torque, update_history)
        }
        RollingModel::EpsdImplicit => {
            let (m, c, capped) =
                rolling::epsd::spring_only(cd, &nf, p, &mut hist.r_torque, update_history);
            implicit_damping = c;
            (m, capped)
        }
    };
    if p.rolling != RollingModel::Off {
        rolling::apply(r_torque, &mut fi, &mut fj);
    }
    (
        fi,
        fj,
        ContactOutcome {
            normal: nf,
            ft,
            r_torque,
            implicit_damping,
            rolling_mobilised,
        },
    )
}

#[cfg(test)]
mod history_tests {
    use super::ContactHistory;

    /// Only the all-+0.0 history counts as zero: a -0.0 component is a bit set.
    #[test]
    fn all_bits_zero_tells_signed_zeros_apart() {
        assert!(ContactHistory::default().all_bits_zero());
        let mut h = ContactHistory::default();
        h.r_torque[2] = -0.0;
        assert!(h == ContactHistory::default() && !h.all_bits_zero());
        h.r_torque[2] = 0.0;
        h.shear[0] = 5e-324;
        assert!(!h.all_bits_zero());
    }
}

#[cfg(test)]
pub(crate) mod test_support {
    use super::*;
    use crate::spec::{Material, Models, NormalModel, TangentialModel};

    pub fn material() -> Material {
        Material {
            youngs_modulus: 7.0e10,
            poisson_ratio: 0.3,
            density: 2500.0,
            restitution: 0.5,
            friction: 0.5,
            rolling_friction: 0.5,
            rolling_damping: 0.3,
            rolling_stiffness: 3.0,
        }
    }

    pub fn params(rolling: RollingModel) -> PairParams {
        let models = Models {
            normal: NormalModel::Hertz,
            tangential: TangentialModel::History,
            rolling,
            torsion_torque: false,
        };
        PairParams::new(&material(), &models, 1e-8)
    }

    /// Two spheres of radius 1 mm along z with overlap 1 um, i on top; i spins about y.
    pub fn pair(omega_i: V3) -> ContactData {
        let (ri, rj) = (1e-3, 1e-3);
        let dz = 2e-3 - 1e-6;
        let m = crate::solver::material::sphere_mass(1e-3, 2500.0);
        ContactData {
            is_wall: false,
            radi: ri,
            radj: rj,
            radsum: ri + rj,
            r: dz,
            rinv: 1.0 / dz,
            delta: [0.0, 0.0, dz],
            en: [0.0, 0.0, dz * (1.0 / dz)],
            meff: m * m / (m + m),
            mi: m,
            mj: m,
            omega_i,
            ..Default::default()
        }
    }
}
