//! The outcome of a replay (`summary.json`, schema [`super::SCHEMA`]), apart from the study so
//! that the report (src/report/replay.rs) reads it without importing the study.

use serde::{Deserialize, Serialize};

/// Error of one channel at one step: `max |LIGGGHTS - native| / peak`, the peak being the
/// largest magnitude of the channel over all items of that step in either code.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct ChannelError {
    pub channel: String,
    pub max_rel_err: f64,
    pub peak: f64,
    /// The worst item: an atom, a pair or a particle-triangle contact, and its kind.
    pub worst: String,
}

/// One compared step of a window.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct StepResult {
    pub step: u64,
    /// Largest error over all channels, LIGGGHTS against native.
    pub max_rel_err: f64,
    /// The same for native against native with every particle one ulp apart in x.
    pub chaos_rel_err: f64,
    pub worst: ChannelError,
    pub channels: Vec<ChannelError>,
    pub pass: bool,
}

/// What a window holds: contact kinds and events.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Coverage {
    pub pairs: usize,
    pub periodic_pairs: usize,
    pub sliding_pairs: usize,
    pub rolling_limit_pairs: usize,
    pub wall_face: usize,
    pub wall_edge_corner: usize,
    /// Neighbour rebuilds inside the window.
    pub rebuilds: u64,
    /// Atoms wrapped across a periodic seam inside the window.
    pub seam_crossings: usize,
    /// Particle-triangle contacts that began or ended inside the window.
    pub triangle_changes: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct WindowResult {
    pub start: u64,
    /// compaction or shear
    pub phase: String,
    pub coverage: Coverage,
    pub steps: Vec<StepResult>,
    /// Steps agreeing from the start of the window (within rtol at step 1, the chaos envelope
    /// after).
    pub horizon: u64,
    pub pass: bool,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ReplayOutcome {
    pub schema: u32,
    pub pass: bool,
    pub case: String,
    pub rolling: String,
    pub mu_r: f64,
    pub eta_r: f64,
    pub restitution: f64,
    pub rtol: f64,
    pub chaos_factor: f64,
    pub neighbor_every: u64,
    pub liggghts_version: String,
    pub windows: Vec<WindowResult>,
    /// What was imposed or reconstructed instead of read from LIGGGHTS.
    pub notes: Vec<String>,
}
