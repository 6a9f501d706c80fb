//! The values the contact chain passes along ([`ContactData`], LIGGGHTS'
//! `SurfacesIntersectData`), its products ([`ForceData`]) and what a contact keeps
//! ([`ContactHistory`]), with the pair geometry that decides a contact: what every model
//! file reads and writes, in a file of its own so that the models import it and not the
//! chain that composes them ([`super::surfaces_intersect`]; issue #38).

use super::lanes::{Lanes, Mask};
use crate::solver::vec3::{dot, V3};

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
