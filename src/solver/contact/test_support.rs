//! What the contact tests share: the test material's pair parameters and the two-sphere and
//! sphere-wall geometries they evaluate.

use super::data::ContactData;
use super::models::RollingModel;
use crate::solver::material::{Coefficients, Elastic, PairParams};
use crate::solver::vec3::V3;

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
