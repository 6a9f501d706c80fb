//! `rolling_friction epsd_implicit` (ours, not a LIGGGHTS keyword; the deck runs epsd):
//! epsd's spring, its dashpot left to the integrator (`solver::shear::implicit`), which
//! applies it implicitly so that it is stable at any eta_r.

use super::super::lanes::{Lanes, Mask};
use super::super::normal::NormalForce;
use super::super::ContactData;
use super::{dashpot_coefficient, epsd, spring};
use crate::solver::material::PairParams;

/// epsd's spring (history, limit, `k_r` [`epsd::stiffness`]) without the dashpot. Returns
/// the spring torque, the dashpot coefficient `C_r = eta_r 2 sqrt(I_r k_r)` for the
/// integrator (0 at the limit) and the lanes at the limit.
#[inline(always)]
pub fn torque<L: Lanes>(
    cd: &ContactData<L>,
    nf: &NormalForce<L>,
    p: &PairParams,
    hist: &mut [L; 3],
    update_history: bool,
) -> ([L; 3], L, L::M) {
    let kr = epsd::stiffness(nf.kn, L::splat(p.coeff_roll_frict), cd.reff());
    let (m, _, capped) = spring(cd, nf, p, kr, hist, update_history);
    let c = if capped.not().any() {
        L::select(capped, L::splat(0.0), dashpot_coefficient(cd, p, kr))
    } else {
        L::splat(0.0)
    };
    (m, c, capped)
}
