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
//!
//! Every kernel is generic over [`lanes::Lanes`]: the same code evaluates one contact
//! (`f64`: the two-body cases, the wall contacts, the scalar shear pass) and 4 or 8 at once
//! (AVX2 / AVX-512 lanes, the SIMD shear passes through [`batch::pair`]). A branch of the
//! headers that depends on a contact's values is a per-lane [`lanes::Lanes::select`] (for
//! `f64` an `if`); a branch on the model (pair or wall, the rolling keyword, the parameters)
//! is an `if` for all lanes alike.

pub mod batch;
mod data;
pub mod lanes;
pub mod models;
pub mod normal;
#[cfg(test)]
mod properties;
pub mod rolling;
pub mod surface;
pub mod tangential;
#[cfg(test)]
pub(crate) mod test_support;

use super::material::PairParams;
use crate::solver::contact::models::RollingModel;
use lanes::Lanes;

pub(crate) use data::no_lanes;
pub use data::{
    moved_beyond_half_skin, pair_geometry, pair_reff, ContactData, ContactHistory, ForceData,
};

/// Values of one evaluated contact per lane, for observers and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactOutcome<L: Lanes = f64> {
    pub normal: normal::NormalForce<L>,
    /// Tangential force on i.
    pub ft: [L; 3],
    /// Rolling torque as LIGGGHTS computes it; i receives `-r_torque`, j `+r_torque`.
    pub r_torque: [L; 3],
    /// epsd_implicit: the dashpot coefficient C_r left to the integrator (0 when the spring
    /// is at its limit); the dashpot torque on i is `-C_r P (w_i - w_j)`, P the projector
    /// onto the tangent plane (identity with torsionTorque).
    pub implicit_damping: L,
    /// The rolling resistance is at full mobilisation: the spring at its limit
    /// `|M| = mu_r R* |Fn|` (epsd, epsd2, epsd3, epsd_implicit; the epsd dashpot is then
    /// off), or any rolling contact with cdt (no spring, always at the limit).
    pub rolling_mobilised: L::M,
}

/// Evaluates touching contacts: `ContactModel::surfacesIntersect` (contact_models.h) for
/// surface default -> normal hertz -> tangential history -> rolling `p.rolling`, in that
/// order, the one composition of the contact law. Updates `hist` only when
/// `update_history` (LIGGGHTS `computeflag && shearupdate`).
#[inline(always)]
pub fn surfaces_intersect<L: Lanes>(
    cd: &mut ContactData<L>,
    p: &PairParams,
    hist: &mut ContactHistory<L>,
    update_history: bool,
) -> (ForceData<L>, ForceData<L>, ContactOutcome<L>) {
    let zero = cd.splat(0.0);
    let mut fi = ForceData::zero(zero);
    let mut fj = ForceData::zero(zero);
    surface::default::surface(cd);
    let nf = normal::hertz::force(cd, p);
    normal::hertz::apply(cd, &nf, &mut fi, &mut fj);
    let ft = tangential::history::force(
        cd,
        &nf,
        p,
        &mut hist.shear,
        update_history,
        &mut fi,
        &mut fj,
    );
    let r = &mut hist.r_torque;
    let (r_torque, implicit_damping, rolling_mobilised) = match p.rolling {
        RollingModel::Off => ([zero; 3], zero, no_lanes(zero)),
        RollingModel::Cdt => {
            let (m, mobilised) = rolling::cdt::torque(cd, &nf, p);
            (m, zero, mobilised)
        }
        RollingModel::Epsd => {
            let (m, mobilised) = rolling::epsd::torque(cd, &nf, p, r, update_history);
            (m, zero, mobilised)
        }
        RollingModel::Epsd2 => {
            let (m, mobilised) = rolling::epsd2::torque(cd, &nf, p, r, update_history);
            (m, zero, mobilised)
        }
        RollingModel::Epsd3 => {
            let (m, mobilised) = rolling::epsd3::torque(cd, &nf, p, r, update_history);
            (m, zero, mobilised)
        }
        RollingModel::EpsdImplicit => rolling::epsd_implicit::torque(cd, &nf, p, r, update_history),
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
