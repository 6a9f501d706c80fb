//! Time-step limits and the closed-form Hertz collision, from elastic constants and radii
//! (the physics they estimate; a case applies them to its material: `spec::rayleigh_time`).

use super::material::Elastic;

/// Rayleigh time of a sphere of radius `r` [s] of elastic constants `e` and density
/// `density`: `T_R = pi r sqrt(rho / G) / (0.1631 nu + 0.8766)`, `G = E / (2 (1 + nu))`.
pub fn rayleigh_time(e: Elastic, density: f64, r: f64) -> f64 {
    let g = e.youngs_modulus / (2.0 * (1.0 + e.poisson_ratio));
    std::f64::consts::PI * r * (density / g).sqrt() / (0.1631 * e.poisson_ratio + 0.8766)
}

/// Hertz theory of an elastic head-on collision (no damping, no friction).
#[derive(Clone, Copy, Debug)]
pub struct HertzCollision {
    /// Maximum overlap [m].
    pub max_overlap: f64,
    /// Contact duration [s].
    pub duration: f64,
}

/// Elastic Hertz collision of two spheres approaching at relative speed `v` [m/s], with
/// effective radius `r_eff`, effective mass `m_eff` and effective modulus
/// `y_eff = 1 / ((1 - nu1^2)/E1 + (1 - nu2^2)/E2)`:
/// `delta_max = (15 m v^2 / (16 Y sqrt(R)))^(2/5)`, `t_c = 2.9432 delta_max / v`
/// (Johnson, Contact Mechanics, sec. 11.4; 2.9432 = 2 * integral factor 1.4716).
pub fn hertz_collision(y_eff: f64, r_eff: f64, m_eff: f64, v: f64) -> HertzCollision {
    let max_overlap = (15.0 * m_eff * v * v / (16.0 * y_eff * r_eff.sqrt())).powf(0.4);
    HertzCollision {
        max_overlap,
        duration: 2.943_2 * max_overlap / v,
    }
}
