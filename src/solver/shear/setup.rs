//! What the shear solver reads of a case, in its own types: built from a case description
//! by `spec::shear::ShearCase::setup`, so the solver never holds the description itself
//! (its presets, stages and protocol are the run layer's business, not the time loop's).

use super::plate::PlateShape;
use super::servo::ServoGains;
use crate::solver::material::PairParams;

/// The shear box's constants for [`super::ShearSim::new`] and [`super::compact`].
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShearSetup {
    /// The one time step [s]: nve/sphere's `dtv` ([`super::ShearSim::new`] sets the kernels'
    /// copy, `params.dt`, from it).
    pub dt: f64,
    /// Periodic lengths along x and z [m].
    pub box_x: f64,
    pub box_z: f64,
    /// Neighbour skin [m].
    pub skin: f64,
    /// `neigh_modify every N check yes|no` (delay 0): a rebuild is considered every `every`
    /// steps since the last, and with `check` made only if some atom moved more than skin/2.
    pub rebuild_every: u64,
    pub rebuild_check: bool,
    /// Both plates' shape.
    pub plate: PlateShape,
    /// The top plate's servo and its target force [N] (normal stress times the plate area).
    pub servo: ServoGains,
    pub target_force: f64,
    /// Particle density [kg/m^3].
    pub density: f64,
    /// The pair constants of the material with itself (and with the plates).
    pub params: PairParams,
}
