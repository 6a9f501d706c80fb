//! Per-type-pair material parameters, derived exactly as LIGGGHTS' global_properties.cpp does.

use crate::solver::contact::models::RollingModel;
use crate::spec::{Material, Models};

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

impl PairParams {
    /// Builds the parameters of a material with itself. `pow(x, 2.)` in LIGGGHTS is computed
    /// here as `x * x`; both are the correctly rounded square.
    pub fn new(m: &Material, models: &Models, dt: f64) -> Self {
        Self::between(m, None, models, dt)
    }

    /// Builds the parameters of a particle of material `m` against a body whose elastic
    /// constants are `other` (a wall's own `(E, nu)`; `None`: the same material). The pair
    /// coefficients (restitution, friction, rolling) are `m`'s for every type pair, as the
    /// decks write them. The two compliances are summed in type order (i = the particle's
    /// type 1, j = the wall's type 2), as `createYeff` and `createGeff` loop; the sum of two
    /// doubles is commutative, so the order changes no bit.
    pub fn between(m: &Material, other: Option<(f64, f64)>, models: &Models, dt: f64) -> Self {
        let (ei, nui) = (m.youngs_modulus, m.poisson_ratio);
        let (ej, nuj) = other.unwrap_or((ei, nui));
        let y_eff = 1.0 / ((1.0 - nui * nui) / ei + (1.0 - nuj * nuj) / ej);
        let g_eff =
            1.0 / (2.0 * (2.0 - nui) * (1.0 + nui) / ei + 2.0 * (2.0 - nuj) * (1.0 + nuj) / ej);
        let log_e = m.restitution.ln();
        let pi = std::f64::consts::PI;
        let beta_eff = log_e / (log_e * log_e + pi * pi).sqrt();
        PairParams {
            y_eff,
            g_eff,
            beta_eff,
            coeff_frict: m.friction,
            coeff_roll_frict: m.rolling_friction,
            coeff_roll_visc: m.rolling_damping,
            coeff_roll_stiffness: m.rolling_stiffness,
            dt,
            rolling: models.rolling,
            torsion_torque: models.torsion_torque,
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
        let m = Material {
            youngs_modulus: 7.0e10,
            poisson_ratio: 0.3,
            density: 2500.0,
            restitution: 0.5,
            friction: 0.5,
            rolling_friction: 0.5,
            rolling_damping: 0.0,
            rolling_stiffness: 2.25,
        };
        let models = Models {
            normal: crate::solver::contact::models::NormalModel::Hertz,
            tangential: crate::solver::contact::models::TangentialModel::History,
            rolling: RollingModel::Epsd,
            torsion_torque: false,
        };
        let p = PairParams::new(&m, &models, 1e-8);
        // E / (2 (1 - nu^2)) and E / (4 (2 - nu)(1 + nu)).
        assert_relative_eq!(p.y_eff, 7.0e10 / 1.82, max_relative = 1e-15);
        assert_relative_eq!(p.g_eff, 7.0e10 / 8.84, max_relative = 1e-15);
        // ln 0.5 / sqrt(ln^2 0.5 + pi^2) = -0.2154537...
        assert_relative_eq!(p.beta_eff, -0.215_453_761_966_246_8, max_relative = 1e-9);
        let e1 = PairParams::new(
            &Material {
                restitution: 1.0,
                ..m
            },
            &models,
            1e-8,
        );
        assert_eq!(e1.beta_eff, 0.0);
    }
}
