//! Starting the shear box from a state that LIGGGHTS recorded, and observing it contact by
//! contact (`verify replay`). Pure numerics: the dumps are parsed in `crate::replay`.
//!
//! What is taken from LIGGGHTS and what is reconstructed:
//! - particles: positions exactly as LIGGGHTS holds them (not re-wrapped: atoms are wrapped
//!   only at rebuilds), velocities, angular velocities, and the forces and torques of the
//!   dumped step (the next half-kick uses them);
//! - contact histories: every touching particle pair (`compute pair/gran/local ... history`,
//!   keyed by atom ids and oriented as LIGGGHTS stores them) and every particle-triangle
//!   contact (`compute wall/gran/local`, keyed by mesh, triangle and atom);
//! - plates and neighbour schedule: reconstructed by [`ShearSim::step_plates_only`] from the
//!   start of the run, with the top plate's servo fed LIGGGHTS' own plate force of every step
//!   (thermo at 17 digits): the servo integral, the plate position and velocity and the bottom
//!   mesh's nodes (including when its elements were wrapped at a rebuild) then carry the same
//!   bits as LIGGGHTS'. This needs a rebuild schedule that does not depend on particle
//!   positions (`neighbor.check = false`); the mesh-triggered rebuilds are reproduced.
//!
//! Not available from LIGGGHTS' dumps: the history of listed pairs that separated since the
//! last rebuild (pair/gran/local lists touching pairs only). Such a pair starts from zero
//! history here; it matters only if it touches again before the next rebuild.

use super::{PairContact, ShearSim, WallSlots, MAX_WALL_CONTACTS};
use crate::error::{Error, Result};
use crate::solver::contact::ContactHistory;
use crate::solver::trimesh::TriContactRecord;
use crate::solver::vec3::V3;
use std::collections::HashMap;

/// A state recorded by LIGGGHTS at the end of `step`. Particle vectors are indexed by atom id - 1.
#[derive(Clone, Debug, Default)]
pub struct RecordedState {
    pub step: u64,
    pub x: Vec<V3>,
    pub v: Vec<V3>,
    pub omega: Vec<V3>,
    pub f: Vec<V3>,
    pub torque: Vec<V3>,
    /// Touching pairs: (i, j) as LIGGGHTS orients them (0-based ids), history as stored.
    pub pairs: HashMap<(u32, u32), ContactHistory>,
    /// Particle-triangle contacts: (particle 0-based, mesh 0 bottom / 1 top, triangle id).
    pub walls: Vec<(u32, u8, u32, ContactHistory)>,
}

/// One touching particle pair, re-evaluated without history update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairObservation {
    pub i: u32,
    pub j: u32,
    pub force_i: V3,
    pub torque_i: V3,
    pub force_j: V3,
    pub torque_j: V3,
    pub hist: ContactHistory,
    /// Across a periodic boundary.
    pub periodic: bool,
    pub sliding: bool,
    pub rolling_limit: bool,
}

/// One particle-triangle contact, re-evaluated without history update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallObservation {
    pub particle: u32,
    pub mesh: u8,
    pub tri: u32,
    pub force: V3,
    pub torque: V3,
    pub hist: ContactHistory,
    pub face: bool,
}

fn neg(h: ContactHistory) -> ContactHistory {
    ContactHistory {
        shear: h.shear.map(|c| -c),
        r_torque: h.r_torque.map(|c| -c),
    }
}

impl ShearSim {
    /// The setup of a run for the plates only (see [`ShearSim::setup`]).
    pub fn setup_plates_only(&mut self, bottom_speed: f64) {
        self.setup_plates(bottom_speed);
        self.rebuild_plates();
    }

    /// One step of the plates and the neighbour schedule only, the top plate's servo fed
    /// `top_force` (the force of the particles on it at this step, as LIGGGHTS printed it).
    pub fn step_plates_only(&mut self, top_force: V3) -> Result<()> {
        if self.rebuild_check {
            return Err(Error::invalid(
                "neighbor.check",
                true,
                "false: a replay reconstructs the rebuild schedule without particle positions",
            ));
        }
        self.step += 1;
        self.move_plates();
        // `neighbor.check` is off here (refused above): no particle test
        if self.decide_rebuild(false) {
            self.rebuild_plates();
        } else {
            self.mesh_rebuild_pending = self.plates_moved();
        }
        self.top_force = top_force;
        self.servo.final_integrate(top_force, self.nve.dtv);
        Ok(())
    }

    /// Sets the force-time velocities from a recorded state one step earlier: the half-kick
    /// `v + dtf f / m`, `omega + dtf/(0.4 m r^2) torque` of nve/sphere's initial_integrate,
    /// what LIGGGHTS' ghost atoms hold at a dump (for [`ShearSim::observe_contacts`]).
    pub fn set_force_time_velocities_from(&mut self, prev: &RecordedState) {
        let nve = self.nve;
        let mut v = prev.v.clone();
        let mut w = prev.omega.clone();
        for i in 0..v.len() {
            let mut x = prev.x[i];
            nve.initial_kicked(
                &mut x,
                &mut v[i],
                &mut w[i],
                prev.f[i],
                prev.torque[i],
                self.kick[i],
            );
        }
        self.force_time_velocities = Some((v, w));
    }

    /// Keep the velocities of every force computation (for [`ShearSim::observe_contacts`]).
    pub fn keep_force_time_velocities(&mut self) {
        self.force_time_velocities = Some((self.v.clone(), self.omega.clone()));
    }

    /// Whether the neighbour list was rebuilt in the last step (or setup).
    pub fn rebuilt_now(&self) -> bool {
        self.ago == 0
    }

    /// Top plate centre `xcm` as the servo holds it (LIGGGHTS `f_top[7..9]`).
    pub fn servo_xcm(&self) -> V3 {
        self.servo.xcm
    }

    /// Puts a recorded particle state and its contact histories into the simulation, whose
    /// plates and schedule must already be at `st.step` ([`ShearSim::step_plates_only`]).
    /// The neighbour list and wall candidates are built for the recorded positions without
    /// wrapping them and without counting as a rebuild (LIGGGHTS' schedule continues).
    pub fn load_recorded(&mut self, st: &RecordedState) -> Result<()> {
        let n = self.x.len();
        if st.step != self.step {
            return Err(Error::Solver {
                step: self.step,
                msg: format!(
                    "recorded state is at step {}, plates at {}",
                    st.step, self.step
                ),
            });
        }
        for (what, len) in [
            ("x", st.x.len()),
            ("v", st.v.len()),
            ("omega", st.omega.len()),
            ("f", st.f.len()),
            ("torque", st.torque.len()),
        ] {
            if len != n {
                return Err(Error::Solver {
                    step: st.step,
                    msg: format!("recorded {what} has {len} atoms, the case {n}"),
                });
            }
        }
        self.x.clone_from(&st.x);
        self.v.clone_from(&st.v);
        self.omega.clone_from(&st.omega);
        self.f.clone_from(&st.f);
        self.torque.clone_from(&st.torque);
        self.xhold.clone_from(&st.x);
        self.nl.pairs.clear();
        let builds = self.nl.builds;
        let team = self.team();
        self.nl
            .build(&team, &self.x, &self.radius, self.skin, self.box_);
        self.nl.builds = builds;
        let mut used = 0usize;
        for (p, ph) in self.nl.pairs.iter().zip(self.nl.hist.iter_mut()) {
            if let Some(h) = st.pairs.get(&(p.i, p.j)) {
                *ph = *h;
                used += 1;
            } else if let Some(h) = st.pairs.get(&(p.j, p.i)) {
                *ph = neg(*h);
                used += 1;
            }
        }
        if used != st.pairs.len() {
            return Err(Error::Solver {
                step: st.step,
                msg: format!(
                    "{} of {} recorded contact pairs are not neighbours here",
                    st.pairs.len() - used,
                    st.pairs.len()
                ),
            });
        }
        self.build_wall_candidates(&team);
        self.wall = vec![WallSlots::default(); n];
        for &(q, mesh, tri, hist) in &st.walls {
            let (q, ntri) = (
                q as usize,
                self.meshes.get(mesh as usize).map(|m| m.tris.len()),
            );
            match ntri {
                Some(nt) if (tri as usize) < nt && q < n => {}
                _ => {
                    return Err(Error::Solver {
                        step: st.step,
                        msg: format!("wall contact of atom {} with mesh {mesh} triangle {tri} does not exist here", q + 1),
                    })
                }
            }
            let slots = &mut self.wall[q];
            if slots.rec.len() == MAX_WALL_CONTACTS {
                return Err(Error::Solver {
                    step: st.step,
                    msg: format!(
                        "atom {} has more than {MAX_WALL_CONTACTS} wall contacts",
                        q + 1
                    ),
                });
            }
            slots.rec.push(TriContactRecord {
                mesh,
                tri,
                keep: true,
                hist,
                ..Default::default()
            });
        }
        self.drop_records_without_candidates();
        self.size_pair_buffers();
        Ok(())
    }

    /// Every touching pair and particle-triangle contact of the current state, evaluated
    /// again without updating any history: what LIGGGHTS' `compute pair/gran/local` and
    /// `wall/gran/local` report at a dump (PairGran::compute_pgl, FixWallGran::
    /// post_force_pgl: `shearupdate = 0`, end-of-step velocities and plate velocities).
    pub fn observe_contacts(&self) -> Result<(Vec<PairObservation>, Vec<WallObservation>)> {
        let mut probe = self.clone();
        probe.record_pair_forces = true;
        probe.compute_forces(false)?;
        // LIGGGHTS reports a pair across a periodic seam from the copy owned by the higher
        // atom id, whose partner is a ghost atom: ghosts got their velocities at the last
        // forward communication, before final_integrate. So the lower id (`p.j` of such a
        // pair, see `neighbor::Pair`) enters with its force-time velocities.
        if let Some((fv, fw)) = &self.force_time_velocities {
            let (x, r, m) = (&probe.x, &probe.radius, &probe.mass);
            let each = probe.nl.pairs.iter().zip(&probe.nl.hist);
            for ((p, hist), out) in each.zip(probe.pair_force.iter_mut()) {
                if p.shift == [0.0; 3] {
                    continue;
                }
                let (i, j) = (p.i as usize, p.j as usize);
                if let Some(mut cd) = super::pair_contact(
                    p,
                    (x[i], x[j]),
                    (r[i], r[j]),
                    (m[i], m[j]),
                    (probe.v[i], fv[j]),
                    (probe.omega[i], fw[j]),
                ) {
                    let mut h = *hist;
                    let (fi, fj, _) = crate::solver::contact::surfaces_intersect(
                        &mut cd,
                        &probe.params,
                        &mut h,
                        false,
                    );
                    *out = (fi, fj);
                }
            }
        }
        let pairs = probe
            .nl
            .pairs
            .iter()
            .zip(&probe.nl.hist)
            .zip(&probe.pair_force)
            .zip(&probe.pair_state)
            .filter(|(_, a)| a.contact != PairContact::Apart)
            .map(|(((p, hist), (fi, fj)), a)| PairObservation {
                i: p.i,
                j: p.j,
                force_i: fi.delta_f,
                torque_i: fi.delta_torque,
                force_j: fj.delta_f,
                torque_j: fj.delta_torque,
                hist: *hist,
                periodic: p.shift != [0.0; 3],
                sliding: a.sliding,
                rolling_limit: a.contact == PairContact::RollingMobilised,
            })
            .collect();
        let mut walls = Vec::new();
        for (q, slots) in probe.wall.iter().enumerate() {
            for r in &slots.rec {
                walls.push(WallObservation {
                    particle: q as u32,
                    mesh: r.mesh,
                    tri: r.tri,
                    force: r.force,
                    torque: r.torque,
                    hist: r.hist,
                    face: r.face,
                });
            }
        }
        Ok((pairs, walls))
    }

    /// Triangles of the (bottom, top) plate meshes.
    pub fn triangle_counts(&self) -> [usize; 2] {
        [self.meshes[0].tris.len(), self.meshes[1].tris.len()]
    }

    /// Force of the particles on the (top, bottom) plate at the last step [N].
    pub fn plate_forces(&self) -> (V3, V3) {
        (self.top_force, self.bottom_force)
    }

    /// Torque on every particle at the last step [N m].
    pub fn torques(&self) -> &[V3] {
        &self.torque
    }
}
