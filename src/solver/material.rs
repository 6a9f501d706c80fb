//! Per-type-pair material parameters, derived exactly as LIGGGHTS' global_properties.cpp does.

use crate::solver::contact::models::RollingModel;

/// The constants one contact needs, for a single material (type 1 with itself).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PairParams {
    /// `Yeff = 1 / ((1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j)` [Pa] (`createYeff`).
    pub y_eff: f64,
    /// `Geff = 1 / (2 (2 - nu_i)(1 + nu_i)/E_i + 2 (2 - nu_j)(1 + nu_j)/E_j)` [Pa] (`createGeff`).
    pub g_eff: f64,
    /// `betaeff = ln(e) / sqrt(ln(e)^2 + pi^2)` [-] (`createBetaEff` via `createCoeffRestLog`).
    pub beta_eff: f64,
    /// Sliding friction mu_p (`coeffFrict`).
    pub coeff_frict: f64,
    /// Rolling friction mu_r (`coeffRollFrict`).
    pub coeff_roll_frict: f64,
    /// Rolling viscous damping eta_r (`coeffRollVisc`).
    pub coeff_roll_visc: f64,
    /// epsd3 stiffness factor (`coeffRollStiffness`, read from the global scalar
    /// `rollingStiffness`).
    pub coeff_roll_stiffness: f64,
    /// Time step [s], used by the history models.
    pub dt: f64,
    /// Rolling model.
    pub rolling: RollingModel,
    /// `torsionTorque` of the rolling models.
    pub torsion_torque: bool,
    /// `tangential_damping` of the hertz model (LIGGGHTS default: on).
    pub tangential_damping: bool,
}

/// A body's elastic constants (LIGGGHTS' per-type `youngsModulus`, `poissonsRatio`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Elastic {
    /// Young's modulus E [Pa].
    pub youngs_modulus: f64,
    /// Poisson's ratio nu [-].
    pub poisson_ratio: f64,
}

/// The coefficients LIGGGHTS reads per type pair (`fix property/global ... peratomtypepair`),
/// the same for every pair of a case as the decks write them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients {
    /// `coefficientRestitution` e [-], 0.05 < e <= 1.
    pub restitution: f64,
    /// `coefficientFriction` mu_p [-].
    pub friction: f64,
    /// `coefficientRollingFriction` mu_r [-].
    pub rolling_friction: f64,
    /// `coefficientRollingViscousDamping` eta_r [-].
    pub rolling_damping: f64,
    /// epsd3's `rollingStiffness` factor [-].
    pub rolling_stiffness: f64,
}

impl PairParams {
    /// Builds the parameters of a body of elastic constants `i` against one of `j` (the same
    /// material: `j = i`; a wall of its own modulus: the wall's), with the pair coefficients
    /// `c`, the rolling model and its `torsionTorque`, and the one time step `dt`. The two
    /// compliances are summed in type order (i = the particle's type 1, j = the wall's type
    /// 2), as `createYeff` and `createGeff` loop; the sum of two doubles is commutative, so
    /// the order changes no bit. `pow(x, 2.)` in LIGGGHTS is computed here as `x * x`; both
    /// are the correctly rounded square.
    pub fn between(
        i: Elastic,
        j: Elastic,
        c: Coefficients,
        rolling: RollingModel,
        torsion_torque: bool,
        dt: f64,
    ) -> Self {
        let (ei, nui) = (i.youngs_modulus, i.poisson_ratio);
        let (ej, nuj) = (j.youngs_modulus, j.poisson_ratio);
        let y_eff = 1.0 / ((1.0 - nui * nui) / ei + (1.0 - nuj * nuj) / ej);
        let g_eff =
            1.0 / (2.0 * (2.0 - nui) * (1.0 + nui) / ei + 2.0 * (2.0 - nuj) * (1.0 + nuj) / ej);
        let log_e = c.restitution.ln();
        let pi = std::f64::consts::PI;
        let beta_eff = log_e / (log_e * log_e + pi * pi).sqrt();
        PairParams {
            y_eff,
            g_eff,
            beta_eff,
            coeff_frict: c.friction,
            coeff_roll_frict: c.rolling_friction,
            coeff_roll_visc: c.rolling_damping,
            coeff_roll_stiffness: c.rolling_stiffness,
            dt,
            rolling,
            torsion_torque,
            tangential_damping: true,
        }
    }
}

/// Sphere mass as atom_vec_sphere.cpp `data_atom` computes it:
/// `4.0*MY_PI/3.0 * r*r*r * rho`, evaluated left to right.
pub fn sphere_mass(radius: f64, density: f64) -> f64 {
    4.0 * std::f64::consts::PI / 3.0 * radius * radius * radius * density
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn effective_moduli_match_hand_values() {
        let glass = Elastic {
            youngs_modulus: 7.0e10,
            poisson_ratio: 0.3,
        };
        let c = Coefficients {
            restitution: 0.5,
            friction: 0.5,
            rolling_friction: 0.5,
            rolling_damping: 0.0,
            rolling_stiffness: 2.25,
        };
        let p = PairParams::between(glass, glass, c, RollingModel::Epsd, false, 1e-8);
        // E / (2 (1 - nu^2)) and E / (4 (2 - nu)(1 + nu)).
        assert_relative_eq!(p.y_eff, 7.0e10 / 1.82, max_relative = 1e-15);
        assert_relative_eq!(p.g_eff, 7.0e10 / 8.84, max_relative = 1e-15);
        // ln 0.5 / sqrt(ln^2 0.5 + pi^2) = -0.2154537...
        assert_relative_eq!(p.beta_eff, -0.215_453_761_966_246_8, max_relative = 1e-9);
        let elastic = Coefficients {
            restitution: 1.0,
            ..c
        };
        let e1 = PairParams::between(glass, glass, elastic, RollingModel::Epsd, false, 1e-8);
        assert_eq!(e1.beta_eff, 0.0);
    }
}
