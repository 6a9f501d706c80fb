//! What the shear box reports: output records (plate forces, top plate position, kinetic
//! energies, rolling mobilisation), particle snapshots, the state handed to a new run, and the
//! checks made at output steps.

use super::state::Packing;
use super::{neighbor, PairContact, ShearSim};
use crate::error::{Error, Result};
use rayon::prelude::*;

/// One output record (SI units).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlateRecord {
    pub step: u64,
    /// Force of the particles on the top plate [N].
    pub top_force: [f64; 3],
    /// Force of the particles on the bottom plate [N].
    pub bottom_force: [f64; 3],
    /// y of the top plate's base [m].
    pub top_y: f64,
    /// Displacement of the bottom plate along x since shearing began [m].
    pub shear_displacement: f64,
    /// Translational and rotational kinetic energy [J].
    pub ke: f64,
    pub erot: f64,
    /// Fraction of touching particle-particle contacts whose rolling resistance is at full
    /// mobilisation (NaN without touching pairs; 0 without a rolling model).
    pub mobilised: f64,
}

/// Particle state for snapshots.
#[derive(Clone, Debug)]
pub struct Snapshot {
    pub step: u64,
    pub x: Vec<[f64; 3]>,
    pub v: Vec<[f64; 3]>,
    pub omega: Vec<[f64; 3]>,
    pub radius: Vec<f64>,
    /// Accumulated rotation vector, integral of omega dt [rad].
    pub rotation: Vec<[f64; 3]>,
    /// The bottom and top plates' triangles where the meshes are now.
    pub plates: [Vec<[[f64; 3]; 3]>; 2],
}

impl ShearSim {
    /// Current sample height: distance between the plates' mean surfaces [m].
    pub fn height(&self) -> f64 {
        self.top.base_y - self.bottom.base_y - self.bottom.tooth_height
    }

    pub fn record(&self) -> PlateRecord {
        let ke = (0..self.x.len())
            .map(|i| {
                let v = self.v[i];
                0.5 * self.mass[i] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
            })
            .sum();
        let erot = (0..self.x.len())
            .map(|i| {
                let w = self.omega[i];
                0.5 * 0.4
                    * self.mass[i]
                    * self.radius[i]
                    * self.radius[i]
                    * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
            })
            .sum();
        let (touching, mobilised) = self.pair_state.iter().fold((0usize, 0usize), |(t, m), a| {
            (
                t + usize::from(a.contact != PairContact::Apart),
                m + usize::from(a.contact == PairContact::RollingMobilised),
            )
        });
        PlateRecord {
            mobilised: mobilised as f64 / touching as f64,
            step: self.step,
            top_force: self.top_force,
            bottom_force: self.bottom_force,
            top_y: self.top.base_y,
            shear_displacement: self.shear_displacement,
            ke,
            erot,
        }
    }

    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            step: self.step,
            x: self.x.clone(),
            v: self.v.clone(),
            omega: self.omega.clone(),
            radius: self.radius.clone(),
            rotation: self.rotation.clone(),
            plates: [0, 1].map(|k| self.meshes[k].tris.iter().map(|t| t.nodes).collect()),
        }
    }

    /// The current state as an initial state for a new run of both codes (positions wrapped
    /// into the box, velocities, angular velocities, top plate position). Contact histories
    /// and the servo's state start afresh, in LIGGGHTS as here.
    pub fn state(&self, like: &Packing) -> Packing {
        let (lx, lz) = (self.box_.lx, self.box_.lz);
        Packing {
            radius: like.radius.clone(),
            position: self
                .x
                .iter()
                .map(|p| [p[0].rem_euclid(lx), p[1], p[2].rem_euclid(lz)])
                .collect(),
            velocity: self.v.clone(),
            omega: self.omega.clone(),
            top_y: self.top.base_y,
            box_y_hi: like.box_y_hi,
            box_y_lo: like.box_y_lo,
        }
    }

    /// The listed pairs.
    pub fn pairs(&self) -> &[neighbor::Pair] {
        &self.nl.pairs
    }

    /// Current force on every particle [N].
    pub fn forces(&self) -> &[[f64; 3]] {
        &self.f
    }

    /// Particles held (a brick's own and ghosts).
    pub fn particle_count(&self) -> usize {
        self.x.len()
    }

    /// Pairs in the neighbour list.
    pub fn listed_pairs(&self) -> usize {
        self.nl.pairs.len()
    }

    /// (listed pairs, touching pairs, particle-plate contacts) at the last force evaluation.
    pub fn contact_counts(&self) -> (usize, usize, usize) {
        let touching = self
            .pair_state
            .iter()
            .filter(|a| a.contact != PairContact::Apart)
            .count();
        let walls = self.wall.iter().map(|w| w.rec.len()).sum();
        (self.nl.pairs.len(), touching, walls)
    }

    /// (particles with plate candidates, candidate triangle images in all) of the last
    /// neighbour build: the particles whose plate contacts are tested each step.
    pub fn plate_candidates(&self) -> (usize, usize) {
        let with = self.wall_start.windows(2).filter(|w| w[1] > w[0]).count();
        (with, self.wall_cand.len())
    }

    /// The heap memory the solver holds, by item [bytes] (allocated capacities; the meshes
    /// and the case are left out: they do not grow with the particles).
    pub fn memory(&self) -> Vec<(&'static str, usize)> {
        fn b<T>(v: &Vec<T>) -> usize {
            v.capacity() * std::mem::size_of::<T>()
        }
        let walls: usize = self
            .wall
            .iter()
            .map(|w| {
                w.rec.capacity() * std::mem::size_of::<crate::solver::trimesh::TriContactRecord>()
            })
            .sum();
        let ftv = self
            .force_time_velocities
            .as_ref()
            .map_or(0, |(v, w)| b(v) + b(w));
        vec![
            (
                "particle arrays",
                b(&self.x)
                    + b(&self.v)
                    + b(&self.omega)
                    + b(&self.f)
                    + b(&self.torque)
                    + b(&self.radius)
                    + b(&self.mass)
                    + b(&self.kick)
                    + b(&self.rotation)
                    + b(&self.xhold)
                    + b(&self.acc)
                    + ftv,
            ),
            ("packed particle records", b(&self.packed)),
            ("pair list", b(&self.nl.pairs)),
            ("pair histories", b(&self.nl.hist)),
            ("pair states", b(&self.pair_state)),
            ("implicit pair dashpots", b(&self.pair_damp)),
            ("pair forces", b(&self.pair_force)),
            (
                "per-particle pair index",
                b(&self.nl.start) + b(&self.nl.entries),
            ),
            ("implicit dashpot sums", b(&self.imp)),
            ("plate records", b(&self.wall) + walls),
            (
                "plate candidates and forces",
                b(&self.wall_start) + b(&self.wall_cand) + b(&self.wall_force),
            ),
        ]
    }

    /// Neighbour rebuilds so far.
    pub fn neighbor_builds(&self) -> u64 {
        self.nl.builds
    }

    /// Checks the particle state for NaN (called at output steps).
    pub fn check_finite(&self) -> Result<()> {
        let bad = self
            .x
            .par_iter()
            .zip(self.v.par_iter())
            .position_any(|(x, v)| !(x.iter().chain(v.iter()).all(|c| c.is_finite())));
        match bad {
            Some(i) => Err(Error::Solver {
                step: self.step,
                msg: format!("particle {} has a non-finite position or velocity", i + 1),
            }),
            None => Ok(()),
        }
    }

    /// Particles outside the box in y (lost in LIGGGHTS terms).
    pub fn lost_particles(&self, y_lo: f64, y_hi: f64) -> usize {
        self.x.iter().filter(|x| x[1] < y_lo || x[1] > y_hi).count()
    }
}
