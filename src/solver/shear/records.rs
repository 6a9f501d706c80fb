//! The records the shear solver's passes share: a particle's plate contact slots
//! ([`WallSlots`]), a listed pair's state after the force loop ([`PairState`], [`PairDamp`])
//! and its contact set-up ([`pair_contact`]). In a file of their own so that the passes
//! (pairs, walls, observers) import them and not the time loop that runs the passes
//! (issue #38).

use super::neighbor::Pair;
use crate::solver::contact::{pair_geometry, ContactData};
use crate::solver::trimesh::TriContactRecord;
use crate::solver::vec3::V3;

/// Most mesh contact records one sphere may hold at once.
pub(super) const MAX_WALL_CONTACTS: usize = 8;

/// Mesh contact records of one particle (fix_contact_history_mesh's partner list), in the
/// order they were created, at most [`MAX_WALL_CONTACTS`]. Held on the heap only while the
/// particle has records: most particles are away from the plates, and a fixed array of 8
/// records was 840 bytes per particle, the largest item of the solver's memory. Stored in
/// checkpoints as that fixed array ([`FixedSlots`]), so checkpoints of either layout resume.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
#[serde(from = "FixedSlots", into = "FixedSlots")]
pub(super) struct WallSlots {
    pub(super) rec: Vec<TriContactRecord>,
}

/// The checkpoint form of [`WallSlots`]: a count and 8 records.
#[derive(Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
pub(super) struct FixedSlots {
    n: u8,
    rec: [TriContactRecord; MAX_WALL_CONTACTS],
}

impl From<FixedSlots> for WallSlots {
    fn from(f: FixedSlots) -> Self {
        let n = (f.n as usize).min(MAX_WALL_CONTACTS);
        WallSlots {
            rec: f.rec[..n].to_vec(),
        }
    }
}

impl From<WallSlots> for FixedSlots {
    fn from(w: WallSlots) -> Self {
        let mut f = FixedSlots {
            n: w.rec.len() as u8,
            ..Default::default()
        };
        f.rec[..w.rec.len()].copy_from_slice(&w.rec);
        f
    }
}

/// The 9 periodic image shifts (x, z) of a triangle; index 4 is the triangle itself.
pub(super) fn image_shift(k: u8, lx: f64, lz: f64) -> V3 {
    let (ix, iz) = ((k / 3) as f64 - 1.0, (k % 3) as f64 - 1.0);
    [ix * lx, 0.0, iz * lz]
}

/// The state of a listed pair after the force loop.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub(super) enum PairContact {
    #[default]
    Apart,
    Touching,
    /// Touching, with the rolling resistance at full mobilisation.
    RollingMobilised,
}

/// Per pair, from the force loop: the contact state (2 bytes; what observers count).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub(super) struct PairState {
    pub(super) contact: PairContact,
    /// The tangential force is at the Coulomb limit `mu_p |Fn|` (to 1e-9, a label only).
    pub(super) sliding: bool,
}

/// Per pair, from the force loop, for epsd_implicit only: the rolling dashpot's coefficient
/// and the contact normal, which the implicit half-kick reads.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct PairDamp {
    pub(super) damping: f64,
    pub(super) en: V3,
}

/// The contact data of a listed pair as pair_gran_base.h sets it up (j seen at its image
/// `x_j + shift`, `delta = x_i - x_j`), or None if the pair does not touch
/// (`rsq >= radsum^2`).
pub(crate) fn pair_contact(
    p: &Pair,
    x: (V3, V3),
    radius: (f64, f64),
    mass: (f64, f64),
    v: (V3, V3),
    omega: (V3, V3),
) -> Option<ContactData> {
    let (delta, rsq, touch) = pair_geometry(x.0, x.1, p.shift, radius.0, radius.1);
    if !touch {
        return None;
    }
    Some(ContactData::pair(
        delta, rsq, radius.0, radius.1, mass.0, mass.1, v, omega,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A particle's plate records survive the checkpoint form (a count and 8 fixed slots)
    /// unchanged, in order, and a record count beyond 8 is not read past the slots.
    #[test]
    fn wall_slots_round_trip_through_the_checkpoint_form() {
        let rec = |tri: u32, s: f64| TriContactRecord {
            mesh: (tri % 2) as u8,
            tri,
            keep: tri.is_multiple_of(3),
            hist: crate::solver::contact::ContactHistory {
                shear: [s, -0.0, 1e-300],
                r_torque: [-s, 0.0, f64::MIN_POSITIVE],
            },
            force: [s; 3],
            torque: [-s; 3],
            face: tri.is_multiple_of(2),
        };
        let w = WallSlots {
            rec: vec![rec(7, 1.5), rec(3, -2.25), rec(12, 3.0)],
        };
        let bytes = rmp_serde::to_vec(&w).unwrap();
        let back: WallSlots = rmp_serde::from_slice(&bytes).unwrap();
        assert_eq!(back.rec, w.rec);
        let bits = |w: &WallSlots| rmp_serde::to_vec(w).unwrap();
        assert_eq!(bits(&back), bytes);
        let fixed = FixedSlots {
            n: 200,
            ..FixedSlots::from(w)
        };
        assert_eq!(WallSlots::from(fixed).rec.len(), MAX_WALL_CONTACTS);
        assert!(WallSlots::from(FixedSlots::default()).rec.is_empty());
    }
}
