//! The scalar pair path: one contact at a time through the kernels that mirror LIGGGHTS'
//! headers ([`surfaces_intersect`]), the path the SIMD passes are held equal to.

use super::super::neighbor::Pair;
use super::super::records::{pair_contact, PairContact, PairDamp, PairState};
use super::data::Particles;
use crate::solver::contact::{surfaces_intersect, tangential, ContactHistory, ForceData};
use crate::solver::material::PairParams;

/// One pair by the scalar kernels: its history (updated in place); returns i's and j's
/// increments (zero when apart), its state and its dashpot.
pub(super) fn scalar_one(
    p: &Pair,
    hist: &mut ContactHistory,
    s: Particles,
    params: &PairParams,
    update_history: bool,
) -> (ForceData, ForceData, PairState, PairDamp) {
    let (i, j) = (p.i as usize, p.j as usize);
    let Some(mut cd) = pair_contact(
        p,
        (s.x[i], s.x[j]),
        (s.radius[i], s.radius[j]),
        (s.mass[i], s.mass[j]),
        (s.v[i], s.v[j]),
        (s.omega[i], s.omega[j]),
    ) else {
        return Default::default();
    };
    let (fi, fj, o) = surfaces_intersect(&mut cd, params, hist, update_history);
    let state = PairState {
        contact: if o.rolling_mobilised {
            PairContact::RollingMobilised
        } else {
            PairContact::Touching
        },
        sliding: tangential::history::sliding(o.ft, o.normal.fn_, params),
    };
    let damp = PairDamp {
        damping: o.implicit_damping,
        en: cd.en,
    };
    (fi, fj, state, damp)
}
