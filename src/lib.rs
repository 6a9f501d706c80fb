//! Native DEM solver and cross-validation harness against LIGGGHTS 3.8.0.
//!
//! Data flows one way:
//! `case.toml -> Case -> {deck -> liggghts -> Series, solver -> Series} -> compare -> report`.
//! The comparator never knows which code produced a series.
#![warn(clippy::undocumented_unsafe_blocks, clippy::missing_safety_doc)]
// Kernels index x/y/z components explicitly, as the LIGGGHTS code they mirror does.
#![allow(clippy::needless_range_loop)]

pub mod calibration;
pub mod chung_ooi;
pub mod cli;
pub mod compare;
pub mod deck;
pub mod error;
pub mod fsutil;
pub mod liggghts;
pub mod packing;
pub mod profile;
pub mod ranks;
pub mod report;
pub mod rotation_map;
pub mod run;
pub mod series;
pub mod shear;
pub mod solver;
pub mod spec;
pub mod vtk;

pub use error::{Error, Result};
