//! The particles and plates of a shear box state, as the solver starts from it and gives it
//! back: a generated loose packing (`crate::packing::loose_packing`), a compacted state, a
//! snapshot ([`super::ShearSim::state`]).

/// Particles and plate positions of the initial state. y is the plate-normal direction:
/// the bottom plate's base is at y = 0 (teeth up to `tooth_height`), the top plate's base at
/// `top_y` (teeth down to `top_y - tooth_height`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Packing {
    pub radius: Vec<f64>,
    pub position: Vec<[f64; 3]>,
    /// Velocities [m/s] (zero for a generated packing; set for a compacted state).
    pub velocity: Vec<[f64; 3]>,
    /// Angular velocities [rad/s].
    pub omega: Vec<[f64; 3]>,
    pub top_y: f64,
    /// Upper bound of the simulation box in y.
    pub box_y_hi: f64,
    /// Lower bound of the simulation box in y.
    pub box_y_lo: f64,
}
