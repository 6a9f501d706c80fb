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
pub mod lanes;
pub mod models;
pub mod normal;
#[cfg(test)]
mod properties;
pub mod rolling;
pub mod surface;
pub mod tangential;

use super::material::PairParams;
use super::vec3::{dot, V3};
use crate::solver::contact::models::RollingModel;
use lanes::{Lanes, Mask};

/// The mask of `like`'s type with no lane set.
#[inline(always)]
pub(crate) fn no_lanes<L: Lanes>(like: L) -> L::M {
    let zero = like.splat(0.0);
    zero.ne(zero)
}

/// LIGGGHTS' `SurfacesIntersectData` for spheres: geometry and kinematics of one contact
/// per lane. `i` is the first partner; for walls `j` is the wall (walls and pairs are never
/// mixed in one evaluation: `is_wall` holds for every lane).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactData<L = f64> {
    pub is_wall: bool,
    pub radi: L,
    /// Radius of partner j (unused for walls).
    pub radj: L,
    /// `radi + radj` (pair) or `radi` (wall).
    pub radsum: L,
    /// Centre distance (pair) or `radi - overlap` (wall).
    pub r: L,
    pub rinv: L,
    /// `x_i - x_j` (pair) or contact point to centre (wall).
    pub delta: [L; 3],
    /// Unit normal, `delta * rinv`, pointing from j (or the wall) towards i.
    pub en: [L; 3],
    /// Overlap. For walls the mesh code sets it before the surface model runs; the surface
    /// model then overwrites it with `radsum - r` (surface_model_default.h).
    pub deltan: L,
    pub meff: L,
    pub mi: L,
    pub mj: L,
    pub v_i: [L; 3],
    pub v_j: [L; 3],
    pub omega_i: [L; 3],
    pub omega_j: [L; 3],
    // Written by the surface model:
    pub vn: L,
    pub wr: [L; 3],
    pub vtr: [L; 3],
    pub cri: L,
    pub crj: L,
}

/// pair_gran_base.h's contact test of a listed pair: j seen at its image `x_j + shift`,
/// `delta = x_i - x_j'`, `rsq = (d0 d0 + d1 d1) + d2 d2`; the pair touches iff
/// `!(rsq >= radsum^2)`. Returns `delta`, `rsq` and the touching lanes.
#[inline(always)]
pub fn pair_geometry<L: Lanes>(
    xi: [L; 3],
    xj: [L; 3],
    shift: [L; 3],
    radi: L,
    radj: L,
) -> ([L; 3], L, L::M) {
    let xj = [xj[0] + shift[0], xj[1] + shift[1], xj[2] + shift[2]];
    let delta = [xi[0] - xj[0], xi[1] - xj[1], xi[2] - xj[2]];
    let rsq = dot(delta, delta);
    let radsum = radi + radj;
    (delta, rsq, rsq.ge(radsum * radsum).not())
}

impl<L: Lanes> ContactData<L> {
    /// A touching particle pair as pair_gran_base.h sets it up: `delta = x_i - x_j` (j's
    /// image), `r = sqrt(rsq)`, `rinv = 1/r`, `en = delta * rinv`, `meff = mi mj / (mi + mj)`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn pair(
        delta: [L; 3],
        rsq: L,
        radi: L,
        radj: L,
        mi: L,
        mj: L,
        v: ([L; 3], [L; 3]),
        omega: ([L; 3], [L; 3]),
    ) -> Self {
        let zero = rsq.splat(0.0);
        let r = rsq.sqrt();
        let rinv = rsq.splat(1.0) / r;
        ContactData {
            is_wall: false,
            radi,
            radj,
            radsum: radi + radj,
            r,
            rinv,
            delta,
            en: [delta[0] * rinv, delta[1] * rinv, delta[2] * rinv],
            deltan: zero,
            meff: mi * mj / (mi + mj),
            mi,
            mj,
            v_i: v.0,
            v_j: v.1,
            omega_i: omega.0,
            omega_j: omega.1,
            vn: zero,
            wr: [zero; 3],
            vtr: [zero; 3],
            cri: zero,
            crj: zero,
        }
    }

    /// A vector of `L` with `v` in every lane ([`Lanes::splat`], this contact's values the
    /// proof that `L` runs here).
    #[inline(always)]
    pub fn splat(&self, v: f64) -> L {
        self.radi.splat(v)
    }

    /// The effective radius every model reads (normal_model_hertz.h and the rolling
    /// headers each compute it; one formula here): `radi` for walls, else
    /// `radi radj / (radi + radj)`.
    #[inline(always)]
    pub fn reff(&self) -> L {
        if self.is_wall {
            self.radi
        } else {
            pair_reff(self.radi, self.radj)
        }
    }
}

/// `reff` of a pair: `radi radj / (radi + radj)`, left to right.
#[inline(always)]
pub fn pair_reff<L: Lanes>(radi: L, radj: L) -> L {
    radi * radj / (radi + radj)
}

impl ContactData<f64> {
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

impl ContactHistory {
    /// The history of the same contact seen from the other side (j against i): a pair that
    /// started or stopped crossing a periodic seam turns round, and its relative history
    /// changes sign.
    pub fn turned_round(self) -> Self {
        ContactHistory {
            shear: self.shear.map(|c| -c),
            r_torque: self.r_torque.map(|c| -c),
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

/// Force and torque increments of one partner (LIGGGHTS `ForceData`), per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct ForceData<L = f64> {
    pub delta_f: [L; 3],
    pub delta_torque: [L; 3],
}

impl<L: Lanes> ForceData<L> {
    /// Zero increments of `like`'s type: each stage adds to them (`0 + x`, as LIGGGHTS adds
    /// into a zeroed `ForceData`; kept because `0 + (-0) = +0`).
    #[inline(always)]
    pub fn zero(like: L) -> Self {
        let zero = like.splat(0.0);
        ForceData {
            delta_f: [zero; 3],
            delta_torque: [zero; 3],
        }
    }
}

/// The history slots of one contact, in LIGGGHTS' order: tangential `shearx..z` [m], then
/// (epsd, epsd2, epsd3, epsd_implicit) `r_torquex_old..z` [N m].
/// `repr(C)`: the batched pair pass reads the slots at fixed offsets.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct ContactHistory<L = f64> {
    pub shear: [L; 3],
    pub r_torque: [L; 3],
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

#[cfg(test)]
mod history_tests {
    use super::{moved_beyond_half_skin, pair_geometry, ContactData, ContactHistory};

    /// A sphere on a moving wall (fix_wall_gran.cpp's set-up): the contact vector is the
    /// triangle test's negated on every axis, `en = delta / r` with `r = r_i - overlap`, and the
    /// wall's velocity is j's (two cargo-mutants survivors: the walls of the mutants' test set
    /// lay along one axis and stood still).
    #[test]
    fn a_wall_contact_takes_the_negated_vector_and_the_wall_velocity() {
        let to_wall = [0.3e-3, -0.8e-3, 0.45e-3];
        let (radi, deltan) = (1e-3, -2e-6);
        let (v_i, v_wall, omega_i) = ([0.1, 0.2, 0.3], [1e-3, 0.0, -2e-3], [4.0, 5.0, 6.0]);
        let c = ContactData::wall(radi, 3e-6, to_wall, deltan, v_i, v_wall, omega_i);
        let r = radi - 2e-6;
        assert_eq!(c.delta, to_wall.map(|d| -d));
        assert_eq!(c.r, r);
        assert_eq!(c.en, to_wall.map(|d| -d * (1.0 / r)));
        assert_eq!((c.deltan, c.radsum, c.meff, c.mi), (2e-6, radi, 3e-6, 3e-6));
        assert_eq!((c.v_i, c.v_j, c.omega_i), (v_i, v_wall, omega_i));
        assert!(c.is_wall);
    }

    /// A pair across the periodic corner of x and z: j is seen at its image `x_j + shift`
    /// on every axis (y's shift is 0), `delta = x_i - x_j'` and `rsq` summed as pair_gran_base.h
    /// sums it; the pair touches iff `rsq < radsum^2` (two cargo-mutants survivors: the image
    /// was held only by the shear tests, outside the mutants' test set).
    #[test]
    fn a_pair_sees_its_partner_at_its_image() {
        let (xi, xj, shift): ([f64; 3], [f64; 3], [f64; 3]) = (
            [0.1e-3, 2.0e-3, 3.9e-3],
            [3.95e-3, 2.5e-3, 0.05e-3],
            [-4e-3, 0.0, 4e-3],
        );
        let image = [xj[0] + shift[0], xj[1] + shift[1], xj[2] + shift[2]];
        let d = [xi[0] - image[0], xi[1] - image[1], xi[2] - image[2]];
        let rsq = (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2];
        assert!(
            (d[1] + 0.5e-3).abs() < 1e-15 && (d[2] + 0.15e-3).abs() < 1e-12,
            "{d:?}"
        );
        let r = rsq.sqrt();
        for (radi, radj, touching) in [(0.3e-3, 0.3e-3, true), (0.2e-3, 0.2e-3, false)] {
            let (delta, got, touch) = pair_geometry::<f64>(xi, xj, shift, radi, radj);
            assert_eq!(delta.map(f64::to_bits), d.map(f64::to_bits));
            assert_eq!(got.to_bits(), rsq.to_bits());
            assert_eq!(touch, touching, "r {r}, radsum {}", radi + radj);
        }
        // an image along every axis (the shear box is periodic in x and z only, the rule is
        // the same on y; a cargo-mutants survivor: `- shift[1]` passed with a zero y shift)
        let (xj, shift) = ([0.0, 3.9e-3, 0.0], [0.0, -4e-3, 0.0]);
        let (delta, _, touch) = pair_geometry::<f64>([0.0, 0.1e-3, 0.0], xj, shift, 0.2e-3, 0.2e-3);
        assert_eq!(delta, [0.0, 0.1e-3 - (3.9e-3 - 4e-3), 0.0]);
        assert!(touch);
    }

    /// An atom triggers a rebuild once it moved strictly more than skin/2 since the last
    /// build, in any direction (a cargo-mutants survivor: no test held the check).
    #[test]
    fn rebuild_when_an_atom_moved_beyond_half_the_skin() {
        let hold = [1.0, 2.0, 3.0];
        assert!(!moved_beyond_half_skin(hold, hold, 0.1));
        assert!(!moved_beyond_half_skin([1.0499, 2.0, 3.0], hold, 0.1));
        assert!(moved_beyond_half_skin([1.0, 2.0, 3.0 - 0.0501], hold, 0.1));
        assert!(moved_beyond_half_skin([1.03, 2.03, 3.03], hold, 0.1));
        assert!(!moved_beyond_half_skin([1.02, 2.02, 3.02], hold, 0.1));
        // exactly skin/2 is not beyond it (0.05 is 0.5 * 0.1 to the bit; a cargo-mutants
        // survivor: `>=` passed)
        assert_eq!(0.5 * 0.1f64, 0.05);
        assert!(!moved_beyond_half_skin([0.05, 0.0, 0.0], [0.0; 3], 0.1));
    }

    /// Seen from the other side, both histories change sign: the tangential spring (a
    /// displacement of i against j) and the rolling torque history (i's torque from j; j's
    /// from i is its opposite); turned round twice it is the same bits (a cargo-mutants
    /// survivor: the rolling history kept its sign, held only by the shear tests, outside
    /// the mutants' test set).
    #[test]
    fn a_history_turned_round_changes_the_sign_of_both_springs() {
        let h = ContactHistory {
            shear: [1e-7, -2e-7, 0.0],
            r_torque: [3e-9, 0.0, -4e-9],
        };
        let t = h.turned_round();
        assert_eq!(t.shear, [-1e-7, 2e-7, -0.0]);
        assert_eq!(t.r_torque, [-3e-9, -0.0, 4e-9]);
        let back = t.turned_round();
        assert_eq!(back.shear.map(f64::to_bits), h.shear.map(f64::to_bits));
        assert_eq!(
            back.r_torque.map(f64::to_bits),
            h.r_torque.map(f64::to_bits)
        );
    }

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
    use crate::solver::material::{Coefficients, Elastic};

    /// Particle density [kg/m^3] of the test material.
    pub const DENSITY: f64 = 2500.0;

    pub fn params(rolling: RollingModel) -> PairParams {
        let glass = Elastic {
            youngs_modulus: 7.0e10,
            poisson_ratio: 0.3,
        };
        let c = Coefficients {
            restitution: 0.5,
            friction: 0.5,
            rolling_friction: 0.5,
            rolling_damping: 0.3,
            rolling_stiffness: 3.0,
        };
        PairParams::between(glass, glass, c, rolling, false, 1e-8)
    }

    /// The sphere i of [`pair`] touching a wall below it instead, with the overlap
    /// `overlap` the mesh code stores (r = radi - overlap); i spins at `omega_i`.
    pub fn wall(omega_i: V3, overlap: f64) -> ContactData {
        let mut cd = pair(omega_i);
        cd.is_wall = true;
        cd.radsum = cd.radi;
        cd.deltan = overlap;
        cd.r = cd.radi - overlap;
        cd.rinv = 1.0 / cd.r;
        cd
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
