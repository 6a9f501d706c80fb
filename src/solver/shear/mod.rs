//! Native solver of the shear box, in LIGGGHTS' order of operations per step:
//! nve/sphere initial_integrate, plate motion (servo `initial_integrate`, `move/mesh linear`),
//! neighbour check and rebuild, force clear, pair forces, plate forces (fix wall/gran:
//! bottom mesh, then top mesh), nve/sphere final_integrate, servo PID update. Every `run`
//! (compression, each shear stage) starts with LIGGGHTS' setup: rebuild, and forces without
//! history update.
//!
//! Parallel and reproducible: pairs are evaluated in parallel, each writing only its own
//! history and force slot; particles then sum their pair forces in pair order (CSR) and their
//! plate contacts in feature order; plate totals are summed exactly ([`exact`]: any order,
//! any split over threads or ranks gives the same bits). Results are bit-identical for any
//! number of threads (tested).

pub mod bricks;
pub mod decompose;
pub mod exact;
mod implicit;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod neighbor;
pub mod observe;
pub mod pairs;
pub mod plate;
mod rebuild;
mod records;
pub mod replay;
pub mod servo;
mod setup;
pub mod state;
mod walls;

pub use pairs::KernelPath;
pub use setup::ShearSetup;
pub use state::Packing;

use super::contact::{moved_beyond_half_skin, ForceData};
use super::integrate::{Kick, NveSphere};
use super::material::{sphere_mass, PairParams};
use super::team::{bounds, split_mut, Team};
use super::trimesh::TriMesh;
use super::vec3::V3;
use crate::error::{Error, Result};
use implicit::{add_dashpot, solve_sym3, sym_mul};
use neighbor::{NeighborList, Pair, Periodic};
use plate::{plate_triangles, Plate, Side};
use records::{
    image_shift, pair_contact, PairContact, PairDamp, PairState, WallSlots, MAX_WALL_CONTACTS,
};
use servo::Servo;
use std::sync::{Arc, Mutex};

/// The shear box state and time loop, built from its own constants ([`ShearSetup`], made
/// from a case by `spec::shear::ShearCase::setup`). The time step is read from `setup.dt`
/// once, in [`ShearSim::new`], into `nve` (fix nve/sphere's `dtv`, `dtf`, `dtfrotate`), the
/// one time step it holds; every later use reads `nve.dtv`: the drift, the rotation, the
/// bottom plate, the servo (which keeps none), and the contact kernels through `params.dt`,
/// set from it (LIGGGHTS' models read `update->dt`).
///
/// Serialisable whole (every field but the phase clock and the kernel choice, which the
/// reading machine makes again): a checkpoint is this struct, so a resumed run continues from
/// exactly the state, scratch buffers included, that the uninterrupted run would have.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct ShearSim {
    /// Neighbour skin [m] and the rebuild schedule ([`ShearSetup`]'s).
    skin: f64,
    rebuild_every: u64,
    rebuild_check: bool,
    params: PairParams,
    nve: NveSphere,
    box_: Periodic,
    /// The fixed y bounds of LIGGGHTS' box [m] (`box_y_lo`, `box_y_hi` of the packing): a
    /// particle beyond them is lost there, and a blown-up run here.
    box_y: (f64, f64),
    pub x: Vec<[f64; 3]>,
    pub v: Vec<[f64; 3]>,
    pub omega: Vec<[f64; 3]>,
    f: Vec<[f64; 3]>,
    torque: Vec<[f64; 3]>,
    pub radius: Vec<f64>,
    mass: Vec<f64>,
    /// Per particle, nve/sphere's half-kick factors (made once: radius, mass and dt are
    /// fixed for the life of the run).
    kick: Vec<Kick>,
    rotation: Vec<[f64; 3]>,
    nl: NeighborList,
    xhold: Vec<[f64; 3]>,
    /// Per pair, i's and j's force increments (zero when apart): written by the parallel
    /// and the scalar pass, or when `record_pair_forces` (observers, tests); else stale or
    /// empty (never allocated by a serial AVX-512 run).
    pair_force: Vec<(ForceData, ForceData)>,
    /// Keep `pair_force` current at every force evaluation.
    #[serde(skip)]
    record_pair_forces: bool,
    /// Per particle, the sum of its pair increments in pair order ([`pairs::pass`]).
    acc: Vec<ForceData>,
    /// The SIMD passes' packed particle records ([`pairs::Packed`]) of `x`, `v`, `omega`,
    /// `radius`, `mass` (empty on the scalar path): written by the drift of [`Self::step`]
    /// (`packed_current`), else by [`Self::pack_particles`] before the pass.
    #[serde(skip)]
    packed: Vec<pairs::Packed>,
    /// `packed` holds the particles as the drift left them, and nothing changed them since:
    /// set by the drift, cleared by a rebuild (which wraps positions) and by the pass that
    /// read it, so that a pass entered any other way (setup, tests, replays) packs anew.
    #[serde(skip)]
    packed_current: bool,
    /// Per pair, its contact state at the last force evaluation.
    pair_state: Vec<PairState>,
    /// epsd_implicit: per pair the dashpot coefficient and contact normal (empty otherwise:
    /// 40 bytes per pair not held nor written by the other models).
    pair_damp: Vec<PairDamp>,
    /// epsd_implicit: per particle `A = sum C P` (symmetric: xx yy zz xy xz yz) and
    /// `B = sum C P w_j` of its rolling dashpots, for the implicit final half-kick (empty
    /// for the other models).
    imp: Vec<([f64; 6], V3)>,
    implicit: bool,
    wall: Vec<WallSlots>,
    /// Per particle: its plate-force contributions (bottom, top).
    wall_force: Vec<([f64; 3], [f64; 3])>,
    /// Candidate (mesh, triangle, image) per particle, CSR, built with the neighbour list.
    wall_start: Vec<u32>,
    wall_cand: Vec<(u8, u32, u8)>,
    /// Bottom (0) and top (1) plate meshes: the triangles of the STL files.
    meshes: [TriMesh; 2],
    /// Top mesh nodes at the start of the run (servo `node_orig`).
    top_orig: Vec<[V3; 3]>,
    pub bottom: Plate,
    pub top: Plate,
    top_base0: f64,
    pub servo: Servo,
    bottom_speed: f64,
    /// Node velocity of the bottom mesh: zero in setup (FixMoveMesh::setup zeroes it), the
    /// stage speed from the first step on (MeshMoverLinear).
    bottom_node_v: f64,
    pub shear_displacement: f64,
    bottom_hold: f64,
    top_hold: f64,
    /// Observers only (the replay): velocities and angular velocities at force time.
    force_time_velocities: Option<(Vec<V3>, Vec<V3>)>,
    /// Steps since the last neighbour build (`Neighbor::ago`).
    ago: u64,
    /// A plate moved more than skin/2 at the previous step: rebuild now (`next_reneighbor`).
    mesh_rebuild_pending: bool,
    pub step: u64,
    top_force: [f64; 3],
    bottom_force: [f64; 3],
    /// The pair pass's kernel path (the fastest this CPU runs, unless set).
    #[serde(skip, default = "KernelPath::detect")]
    kernel: KernelPath,
    /// Wall time per phase of `step` (off unless [`ShearSim::time_phases`]).
    #[serde(skip)]
    phases: Option<PhaseClock>,
    /// The threads of the per-step parallel regions, as many as the rayon pool the
    /// simulation steps in ([`ShearSim::team`]).
    #[serde(skip)]
    team: Option<Arc<Team>>,
    /// The parallel pair pass's per-list plan.
    #[serde(skip)]
    plan: pairs::BlockPlan,
    /// A brick of a decomposed run ([`decompose`]): each local particle's global id, in
    /// increasing order (empty in one process: ids are indices).
    #[serde(skip)]
    ids: Vec<u32>,
    /// A brick's ghosts: particles another brick owns, held for their pairs with this one's
    /// (empty in one process). A ghost's position and velocities are its owner's, sent every
    /// step; its force, kick and plate contacts are not made here.
    #[serde(skip)]
    ghost: Vec<bool>,
}

/// Wall time spent in each phase of [`ShearSim::step`] [s], summed over `steps` steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PhaseTimes {
    pub steps: u64,
    /// nve/sphere's two half-steps, the rotation sum and the implicit dashpot.
    pub integrate: f64,
    /// Plate motion (servo, move/mesh) and the servo's update.
    pub plates: f64,
    /// The rebuild decision and the rebuilds (pair list, plate candidates).
    pub neighbor: f64,
    /// The pair pass ([`pairs::pass`]).
    pub pairs: f64,
    /// Per-particle sums of pair forces and the particle-plate contacts.
    pub sum_walls: f64,
    /// A decomposed run's exchanges of every step (the ghosts' positions, the plate force
    /// shares), with the waits for the slowest brick; a rebuild's migration and ghosts are
    /// in `neighbor`. Zero in one process.
    #[serde(default)]
    pub comm: f64,
}

impl PhaseTimes {
    /// The phases with their names.
    pub fn named(&self) -> [(&'static str, f64); 6] {
        [
            ("pair pass", self.pairs),
            ("sums + walls", self.sum_walls),
            ("integration", self.integrate),
            ("neighbour", self.neighbor),
            ("plates", self.plates),
            ("communication", self.comm),
        ]
    }
}

/// Adds the time since the last lap to one phase (a free function: the force loop holds
/// borrows of other fields).
fn lap(clock: &mut Option<PhaseClock>, phase: fn(&mut PhaseTimes) -> &mut f64) {
    if let Some(p) = clock {
        let now = std::time::Instant::now();
        *phase(&mut p.times) += (now - p.last).as_secs_f64();
        p.last = now;
    }
}

#[derive(Clone, Copy, Debug)]
struct PhaseClock {
    last: std::time::Instant,
    times: PhaseTimes,
}

impl ShearSim {
    /// The initial state from a generated packing (both codes read the same data).
    pub fn new(case: &ShearSetup, packing: &Packing) -> Self {
        let n = packing.radius.len();
        let rho = case.density;
        // radius = 0.5 * diameter as read_data computes it; mass as atom_vec_sphere does.
        let radius: Vec<f64> = packing.radius.iter().map(|r| 0.5 * (2.0 * r)).collect();
        let mass: Vec<f64> = radius.iter().map(|r| sphere_mass(*r, rho)).collect();
        let bottom = Plate::new(Side::Bottom, 0.0, case.plate, case.box_x);
        let top = Plate::new(Side::Top, packing.top_y, case.plate, case.box_x);
        let lo = [0.0, packing.box_y_lo, 0.0];
        let hi = [case.box_x, packing.box_y_hi, case.box_z];
        let meshes = [
            TriMesh::new(&plate_triangles(&bottom, case.box_z), lo, hi),
            TriMesh::new(&plate_triangles(&top, case.box_z), lo, hi),
        ];
        let top_orig = meshes[1].tris.iter().map(|t| t.nodes).collect();
        let com = [0.5 * case.box_x, packing.top_y, 0.5 * case.box_z];
        let nve = NveSphere::new(case.dt);
        let kick = radius
            .iter()
            .zip(&mass)
            .map(|(r, m)| nve.kick(*r, *m))
            .collect();
        ShearSim {
            skin: case.skin,
            rebuild_every: case.rebuild_every,
            rebuild_check: case.rebuild_check,
            // the one time step: nve/sphere's dtv; the kernels' copy is set from it here
            params: PairParams {
                dt: nve.dtv,
                ..case.params
            },
            nve,
            box_: Periodic {
                lx: case.box_x,
                lz: case.box_z,
            },
            box_y: (packing.box_y_lo, packing.box_y_hi),
            x: packing.position.clone(),
            v: packing.velocity.clone(),
            omega: packing.omega.clone(),
            f: vec![[0.0; 3]; n],
            torque: vec![[0.0; 3]; n],
            radius,
            mass,
            kick,
            rotation: vec![[0.0; 3]; n],
            nl: NeighborList::default(),
            xhold: packing.position.clone(),
            pair_force: Vec::new(),
            record_pair_forces: false,
            acc: vec![ForceData::default(); n],
            packed: Vec::new(),
            packed_current: false,
            pair_state: Vec::new(),
            pair_damp: Vec::new(),
            imp: if case.params.rolling
                == crate::solver::contact::models::RollingModel::EpsdImplicit
            {
                vec![([0.0; 6], [0.0; 3]); n]
            } else {
                Vec::new()
            },
            implicit: case.params.rolling
                == crate::solver::contact::models::RollingModel::EpsdImplicit,
            wall: vec![WallSlots::default(); n],
            wall_force: vec![([0.0; 3], [0.0; 3]); n],
            wall_start: vec![0; n + 1],
            wall_cand: Vec::new(),
            meshes,
            top_orig,
            bottom,
            top,
            top_base0: packing.top_y,
            servo: Servo::new(case.servo, case.target_force, com),
            bottom_speed: 0.0,
            bottom_node_v: 0.0,
            shear_displacement: 0.0,
            bottom_hold: 0.0,
            top_hold: packing.top_y,
            force_time_velocities: None,
            ago: 0,
            mesh_rebuild_pending: false,
            step: 0,
            top_force: [0.0; 3],
            bottom_force: [0.0; 3],
            kernel: KernelPath::detect(),
            phases: None,
            team: None,
            plan: Default::default(),
            ids: Vec::new(),
            ghost: Vec::new(),
        }
    }

    /// Starts (or stops) timing the phases of every step from zero.
    pub fn time_phases(&mut self, on: bool) {
        self.phases = on.then(|| PhaseClock {
            last: std::time::Instant::now(),
            times: PhaseTimes::default(),
        });
    }

    /// The phase times so far, if timed.
    pub fn phase_times(&self) -> Option<PhaseTimes> {
        self.phases.map(|p| p.times)
    }

    /// Adds the time since the last lap to one phase.
    fn lap(&mut self, phase: fn(&mut PhaseTimes) -> &mut f64) {
        lap(&mut self.phases, phase)
    }

    /// Chooses the pair pass's kernel path (both give the same bits); an error if this CPU
    /// cannot run it.
    pub fn set_kernel(&mut self, path: KernelPath) -> Result<()> {
        self.kernel = path.checked("kernel")?;
        Ok(())
    }

    /// Evaluates every force of the current state without updating any history (what a
    /// run's setup does): for benchmarks of the force loops on a fixed state.
    pub fn evaluate_forces(&mut self) -> Result<()> {
        self.compute_forces(false)
    }

    /// The pair pass's kernel path.
    pub fn kernel(&self) -> KernelPath {
        self.kernel
    }

    /// The global index of local particle `i` (a brick's ids; in one process `i` itself).
    fn id_of(&self, i: usize) -> usize {
        self.ids.get(i).map_or(i, |&g| g as usize)
    }

    /// Sizes the per-pair buffers for the current pair list (after a build).
    fn size_pair_buffers(&mut self) {
        let np = self.nl.pairs.len();
        neighbor::resize_snug(&mut self.pair_state, np);
        if self.implicit {
            neighbor::resize_snug(&mut self.pair_damp, np);
        }
    }

    /// Starts a new run (LIGGGHTS `run` after changing fixes): the bottom plate's speed, the
    /// servo's reference, a neighbour rebuild, and forces without history update.
    pub fn setup(&mut self, bottom_speed: f64) -> Result<()> {
        self.setup_plates(bottom_speed);
        self.rebuild()?;
        self.compute_forces(false)
    }

    /// The plates' part of a run's setup: stage speed, servo reference, mesh origins.
    fn setup_plates(&mut self, bottom_speed: f64) {
        self.bottom_speed = bottom_speed;
        self.bottom_node_v = 0.0;
        self.servo.setup();
        self.top_base0 = self.top.base_y;
        self.top_orig = self.meshes[1].tris.iter().map(|t| t.nodes).collect();
    }

    /// One time step.
    pub fn step(&mut self) -> Result<()> {
        let moved = self.drift();
        self.move_plates();
        self.lap(|p| &mut p.plates);
        if self.decide_rebuild(moved) {
            self.rebuild()?;
        } else {
            // FixMesh::pre_force on a step without rebuild: a plate whose nodes moved more
            // than skin/2 since the last build asks for a rebuild at the next step
            self.mesh_rebuild_pending = self.plates_moved();
        }
        self.lap(|p| &mut p.neighbor);
        let kicked = self.forces_of_step()?;
        self.finish_step(kicked);
        Ok(())
    }

    /// The first part of a step: nve/sphere's initial_integrate (the half-kick and the
    /// drift, and the rotation sum) of every particle, and in the same pass
    /// `Neighbor::check_distance`: true when a particle (a brick's own, not a ghost) moved
    /// more than skin/2 since the last build.
    fn drift(&mut self) -> bool {
        self.step += 1;
        if let Some(p) = &mut self.phases {
            p.last = std::time::Instant::now();
            p.times.steps += 1;
        }
        let nve = self.nve;
        let dt = self.nve.dtv;
        let team = self.team();
        let th = team.threads();
        let n = self.x.len();
        // the SIMD passes' packed records written as the particles drift (their radius and
        // mass, which do not change, once when made). Measured on the fast state (1 thread,
        // avx512, alternating every 250 steps in one process): writing the whole record in
        // the drift cost 2-4 % more per step than writing the moving values only.
        let pack = self.kernel != KernelPath::Scalar;
        if !pack {
            self.packed = Vec::new();
        } else if self.packed.len() != n {
            self.pack_all(&team);
        }
        let (kick, f, torque) = (&self.kick[..], &self.f[..], &self.torque[..]);
        let (xhold, skin, ghost) = (&self.xhold[..], self.skin, &self.ghost[..]);
        // the drift, and in the same pass `Neighbor::check_distance` on the drifted positions
        // (some atom moved more than skin/2 since the last build); each share's inputs as
        // slices of its own (no bounds check or reload of an array's address per particle)
        let parts: Vec<_> = split_mut(&mut self.x, th)
            .into_iter()
            .zip(split_mut(&mut self.v, th))
            .zip(split_mut(&mut self.omega, th))
            .zip(split_mut(&mut self.rotation, th))
            .zip(split_mut(&mut self.packed, th))
            .collect();
        let moved = team
            .map(parts, |t, ((((x, v), w), rot), packed)| {
                let r = bounds(n, th, t);
                let ghost = ghost.get(r.clone()).unwrap_or(&[]);
                let (f, torque, kick, xhold) = (
                    &f[r.clone()],
                    &torque[r.clone()],
                    &kick[r.clone()],
                    &xhold[r],
                );
                let mut moved = false;
                let inputs = f.iter().zip(torque).zip(kick).zip(xhold);
                let states = x
                    .iter_mut()
                    .zip(v.iter_mut())
                    .zip(w.iter_mut())
                    .zip(rot.iter_mut());
                for (k, ((((f, tq), kick), hold), (((x, v), w), rot))) in
                    inputs.zip(states).enumerate()
                {
                    // a brick's ghosts are not drifted: `forward` overwrites their x, v and
                    // omega with their owners' drifted values before anything reads them
                    // (their rotation is never read), and their skin test is their owner's
                    if ghost.get(k) == Some(&true) {
                        continue;
                    }
                    nve.initial_kicked(x, v, w, *f, *tq, *kick);
                    for c in 0..3 {
                        rot[c] += w[c] * dt;
                    }
                    moved |= moved_beyond_half_skin(*x, *hold, skin);
                    if let Some(p) = packed.get_mut(k) {
                        p.moved(*x, *v, *w);
                    }
                }
                moved
            })
            .contains(&true);
        self.packed_current = pack;
        self.lap(|p| &mut p.integrate);
        moved
    }

    /// The step's force evaluation (with history update); true when it made the final
    /// half-kick too: in the force evaluation's last region (see `forces_and_kick`), unless
    /// the velocities at force time are kept or the implicit dashpots need every particle's
    /// sums first.
    fn forces_of_step(&mut self) -> Result<bool> {
        let fuse_kick = self.force_time_velocities.is_none() && !self.implicit;
        self.forces_and_kick(true, fuse_kick)
    }

    /// The last part of a step, after its force evaluation (which made the final half-kick
    /// when `kicked`): nve/sphere's final_integrate, the implicit dashpots, the servo's
    /// update from the top plate's force.
    fn finish_step(&mut self, kicked: bool) {
        self.finish_particles(kicked);
        self.finish_servo();
    }

    /// [`Self::finish_step`]'s particles: nve/sphere's final_integrate (unless the force
    /// evaluation made it) and the implicit dashpots. Reads nothing of the plates.
    fn finish_particles(&mut self, kicked: bool) {
        let nve = self.nve;
        let team = self.team();
        let (th, n) = (team.threads(), self.x.len());
        if let Some((v, w)) = &mut self.force_time_velocities {
            v.clone_from(&self.v);
            w.clone_from(&self.omega);
        }
        if !kicked {
            let (kick, f, torque) = (&self.kick, &self.f, &self.torque);
            let parts: Vec<_> = split_mut(&mut self.v, th)
                .into_iter()
                .zip(split_mut(&mut self.omega, th))
                .collect();
            team.each(parts, |t, (v, w)| {
                let r = bounds(n, th, t);
                let inputs = f[r.clone()].iter().zip(&torque[r.clone()]).zip(&kick[r]);
                for (((f, tq), kick), (v, w)) in inputs.zip(v.iter_mut().zip(w.iter_mut())) {
                    nve.finish_kicked(v, w, *f, *tq, *kick);
                }
            });
        }
        if self.implicit {
            self.implicit_rotation();
        }
        self.lap(|p| &mut p.integrate);
    }

    /// [`Self::finish_step`]'s servo: its update from the top plate's force of the step's
    /// evaluation (`top_force`). Nothing reads the servo before the next step moves the
    /// plates, so a brick makes it when the plate sums are added over the bricks (at the
    /// next step's all-reduce, `decompose`).
    fn finish_servo(&mut self) {
        self.servo.final_integrate(self.top_force, self.nve.dtv);
        self.lap(|p| &mut p.plates);
    }

    /// The team of the per-step regions: as many threads as the rayon pool this is called
    /// in (made again when that changes, e.g. a checkpoint resumed with another count).
    pub(super) fn team(&mut self) -> Arc<Team> {
        let n = rayon::current_num_threads();
        match &self.team {
            Some(t) if t.threads() == n => Arc::clone(t),
            _ => Arc::clone(self.team.insert(Arc::new(Team::new(n)))),
        }
    }

    /// Makes `packed` the SIMD passes' records of the particles as they are, unless the
    /// drift just wrote them (`packed_current`, consumed here); empty on the scalar path.
    fn pack_particles(&mut self, team: &Team) {
        let current = std::mem::take(&mut self.packed_current);
        if self.kernel == KernelPath::Scalar {
            self.packed = Vec::new();
        } else if !current || self.packed.len() != self.x.len() {
            self.pack_all(team);
        }
    }

    /// Makes `packed` the records of every particle as it is ([`pairs::Packed::new`]).
    fn pack_all(&mut self, team: &Team) {
        let n = self.x.len();
        self.packed.resize(n, Default::default());
        let (x, v, omega, radius, mass) = (&self.x, &self.v, &self.omega, &self.radius, &self.mass);
        let th = team.threads();
        team.each(split_mut(&mut self.packed, th), |t, packed| {
            for (p, i) in packed.iter_mut().zip(bounds(n, th, t)) {
                *p = pairs::Packed::new(x[i], radius[i], v[i], mass[i], omega[i]);
            }
        });
    }

    /// The plates' initial_integrate: the servo moves the top plate, `move/mesh linear` the
    /// bottom one.
    fn move_plates(&mut self) {
        let d = self.servo.initial_integrate(self.nve.dtv);
        self.top.base_y = self.top_base0 + d[1];
        self.meshes[1].place(&self.top_orig, d);
        self.bottom_node_v = self.bottom_speed;
        if self.bottom_speed != 0.0 {
            // MeshMoverLinear: nodes += vel * dt every step
            let dx = self.bottom_speed * self.nve.dtv;
            self.meshes[0].translate([dx, 0.0, 0.0]);
            self.bottom.offset_x += dx;
            self.shear_displacement += dx;
        }
    }

    /// Every particle's force and torque, the plate forces, and the contact histories when
    /// `update_history` (LIGGGHTS' `shearupdate`).
    fn compute_forces(&mut self, update_history: bool) -> Result<()> {
        self.forces_and_kick(update_history, false).map(|_| ())
    }

    /// [`Self::compute_forces`]; with `kick`, on a team of several threads whose plate
    /// contacts are evaluated in the pair pass's region, also the final half-kick of every
    /// particle, made in the region that completes its force (each thread its share, right
    /// after the share's sums): one region fewer per step. True when it kicked. The kick is
    /// `finish_kicked` on the finished force and torque, as the step's own kick loop makes
    /// it: the same bits.
    ///
    /// Kept as one function on purpose: moving its fused-plate closure and its share split
    /// into functions of their own (164 -> 135 lines, 2026-12-06) left `chunk_avx2`'s machine
    /// code byte for byte the same but made the pair pass that this function inlines 10-15 %
    /// slower (fast preset, 1 thread, avx2, alternating binaries: 112-119 -> 127-131 ns per
    /// particle-step; 250,000 particles 141-147 -> 162-164); measure before splitting it.
    fn forces_and_kick(&mut self, update_history: bool, kick: bool) -> Result<bool> {
        let team = self.team();
        let th = team.threads();
        let n = self.x.len();
        self.pack_particles(&team);
        let params = &self.params;
        let (x, v, omega, radius, mass) = (&self.x, &self.v, &self.omega, &self.radius, &self.mass);
        let implicit = self.implicit;
        let torsion = params.torsion_torque;
        let walls = walls::WallContext {
            params,
            meshes: &self.meshes,
            cand: &self.wall_cand,
            cstart: &self.wall_start,
            lx: self.box_.lx,
            lz: self.box_.lz,
            // node velocities: move/mesh linear (bottom), servo vcm (top)
            vnode: [[self.bottom_node_v, 0.0, 0.0], self.servo.vcm],
            x,
            v,
            omega,
            radius,
            mass,
            implicit,
            torsion,
            update_history,
            trace: log::log_enabled!(log::Level::Trace),
        };
        // On several threads without dashpot sums, each thread evaluates the plate contacts
        // of its share of the particles in the pair pass's region, after its block of pairs
        // (a contact's force does not depend on the pair sums; it is added to them, in the
        // same order, in the sums region): the pair blocks and the plate contacts are
        // uneven in opposite directions (more pairs in the lower share, 22 % more plate
        // candidates in the upper one on the fast state), and each region waits for its
        // slower thread.
        let fuse = th > 1 && !implicit;
        type Early<'a> = (&'a mut [WallSlots], Vec<walls::WallHit>, bool);
        let early: Vec<Mutex<Early>> = if fuse {
            split_mut(&mut self.wall, th)
                .into_iter()
                .map(|slots| Mutex::new((slots, Vec::new(), true)))
                .collect()
        } else {
            Vec::new()
        };
        let after_block = |t: usize| {
            let Some(part) = early.get(t) else {
                return;
            };
            let mut part = part.lock().unwrap_or_else(|e| e.into_inner());
            let (slots, hits, ok) = &mut *part;
            let o = bounds(n, th, t).start;
            let mut none = ([0.0; 6], [0.0; 3]);
            for (k, slots) in slots.iter_mut().enumerate() {
                let q = o + k;
                if walls.cstart[q] != walls.cstart[q + 1]
                    && !walls.evaluate(q, slots, &mut none, |h| hits.push(*h))
                {
                    *ok = false;
                }
            }
        };
        // pair forces: each pair writes its own history, force slot and state
        let sums = pairs::pass(
            &team,
            self.kernel,
            &self.nl.pairs,
            pairs::Csr {
                start: &self.nl.start,
                entries: &self.nl.entries,
            },
            &mut self.nl.hist,
            &mut self.pair_force,
            &mut self.pair_state,
            &mut self.pair_damp,
            &mut self.acc,
            pairs::Particles {
                x,
                v,
                omega,
                radius,
                mass,
                packed: &self.packed,
            },
            params,
            update_history,
            self.record_pair_forces,
            &after_block,
            &mut self.plan,
            self.nl.generation,
        );
        lap(&mut self.phases, |p| &mut p.pairs);
        let mut hits: Vec<Vec<walls::WallHit>> = Vec::with_capacity(early.len());
        for part in early {
            let (_, h, ok) = part.into_inner().unwrap_or_else(|e| e.into_inner());
            if !ok {
                return Err(too_many_wall_contacts(self.step));
            }
            hits.push(h);
        }
        if fuse {
            self.sum_and_kick(&team, sums, &hits, kick);
            return self.keep_plate_forces_of(&hits).map(|_| kick);
        }
        // per-particle sums in pair order, then plate contacts
        let nl = &self.nl;
        let csr = pairs::Csr {
            start: &nl.start,
            entries: &nl.entries,
        };
        let pd = &self.pair_damp;
        let sum = pairs::PairSums {
            first: match sums {
                pairs::Sums::Accumulated => &[],
                pairs::Sums::Blocks => &self.plan.first,
            },
            cut: &self.plan.cut,
            csr,
            out: &self.pair_force,
            state: &self.pair_state,
        };
        if sums == pairs::Sums::Accumulated && !implicit {
            let totals = serial_sums(
                &mut self.f,
                &mut self.torque,
                &mut self.wall,
                &mut self.wall_force,
                &self.acc,
                &walls,
            );
            let Some(total) = totals else {
                return Err(too_many_wall_contacts(self.step));
            };
            return self.keep_plate_forces(total).map(|_| false);
        }
        // epsd_implicit on one thread: the dashpot sums made pair by pair in the list's order
        // (`dashpot_sums_in_pair_order`), not gathered per particle in `team_sums`
        let summed = implicit && th == 1;
        if summed {
            dashpot_sums_in_pair_order(&mut self.imp, &nl.pairs, pd, omega, torsion);
        }
        let imps = if implicit {
            split_mut(&mut self.imp, th)
        } else {
            // the dashpot sums are held by epsd_implicit only (72 bytes per particle)
            (0..th).map(|_| Default::default()).collect()
        };
        let parts: Vec<_> = split_mut(&mut self.f, th)
            .into_iter()
            .zip(split_mut(&mut self.torque, th))
            .zip(split_mut(&mut self.wall, th))
            .zip(split_mut(&mut self.wall_force, th))
            .zip(imps)
            .zip(split_mut(&mut self.acc, th))
            .map(|(((((f, torque), wall), wall_force), imp), acc)| Shares {
                f,
                torque,
                wall,
                wall_force,
                imp,
                acc,
            })
            .collect();
        let failed = team_sums(&team, parts, &walls, &sum, nl, pd, summed);
        // every sum was read and zeroed (`PairSums::add`)
        self.plan.acc_zero = sums == pairs::Sums::Blocks;
        if failed {
            return Err(too_many_wall_contacts(self.step));
        }
        self.keep_plate_forces_summed().map(|_| false)
    }

    /// The sums region of the team path with plate contacts found in the pass (several
    /// threads, no implicit dashpots): per particle of each share, its pair sum
    /// (`PairSums::add`), its plate contacts `hits` (each thread's, in particle order)
    /// added as `WallContext::particle` adds them, then with `kick` its final half-kick.
    /// Measured on the fast state (2 threads, avx512, alternating every 250 steps in one
    /// process with the step's own kick region): -3 to +3 %, 1.2 % less time per step on
    /// average over 7 runs.
    fn sum_and_kick(
        &mut self,
        team: &Team,
        sums: pairs::Sums,
        hits: &[Vec<walls::WallHit>],
        kick: bool,
    ) {
        let (th, n) = (team.threads(), self.x.len());
        let nl = &self.nl;
        let sum = pairs::PairSums {
            first: match sums {
                pairs::Sums::Accumulated => &[],
                pairs::Sums::Blocks => &self.plan.first,
            },
            cut: &self.plan.cut,
            csr: pairs::Csr {
                start: &nl.start,
                entries: &nl.entries,
            },
            out: &self.pair_force,
            state: &self.pair_state,
        };
        let (nve, kicks, cstart) = (self.nve, &self.kick, &self.wall_start);
        let parts: Vec<_> = split_mut(&mut self.f, th)
            .into_iter()
            .zip(split_mut(&mut self.torque, th))
            .zip(split_mut(&mut self.wall_force, th))
            .zip(split_mut(&mut self.acc, th))
            .zip(split_mut(&mut self.v, th))
            .zip(split_mut(&mut self.omega, th))
            .collect();
        team.each(parts, |t, (((((f, tq), wf), acc), v), w)| {
            let o = bounds(n, th, t).start;
            let mine: &[walls::WallHit] = hits.get(t).map_or(&[], Vec::as_slice);
            let mut h = 0;
            for k in 0..f.len() {
                let q = o + k;
                let (fq, tqq) = (&mut f[k], &mut tq[k]);
                *fq = [0.0; 3];
                *tqq = [0.0; 3];
                sum.add(q, &mut acc[k], fq, tqq);
                if cstart[q] != cstart[q + 1] {
                    wf[k] = ([0.0; 3], [0.0; 3]);
                    while h < mine.len() && mine[h].q as usize == q {
                        walls::apply(&mine[h], fq, tqq, &mut wf[k]);
                        h += 1;
                    }
                }
                if kick {
                    nve.finish_kicked(&mut v[k], &mut w[k], *fq, *tqq, kicks[q]);
                }
            }
        });
        self.plan.acc_zero = sums == pairs::Sums::Blocks;
    }

    /// Sums the plate forces of every particle with plate candidates (`wall_force`) and
    /// keeps them ([`Self::keep_plate_forces`]); the particles without candidates would add
    /// nothing.
    fn keep_plate_forces_summed(&mut self) -> Result<()> {
        let ws = &self.wall_start;
        let with_candidates = (0..self.wall_force.len()).filter(|&q| ws[q] != ws[q + 1]);
        self.keep_plate_forces(self.plate_forces_over(with_candidates))
    }

    /// [`Self::keep_plate_forces_summed`] over the particles with a plate contact only,
    /// from `hits`: the others add nothing. Measured on the fast state (2
    /// threads): the serial sum over every particle cost 2.3-2.7 us per step, 1.3 %.
    fn keep_plate_forces_of(&mut self, hits: &[Vec<walls::WallHit>]) -> Result<()> {
        let mut last = None;
        let touching = hits.iter().flatten().filter_map(|h| {
            let new = last != Some(h.q);
            last = Some(h.q);
            new.then_some(h.q as usize)
        });
        let total = self.plate_forces_over(touching);
        self.keep_plate_forces(total)
    }

    /// The exact sum ([`exact::PlateSum`]: any order gives its bits) of the bottom and top
    /// plate forces (`wall_force`) of particles `qs`.
    fn plate_forces_over(&self, qs: impl Iterator<Item = usize>) -> exact::PlateSum {
        exact::sum(qs.map(|q| self.wall_force[q]))
    }

    /// Keeps the plate forces (bottom, top) of this evaluation, the exact sum of the
    /// particles' shares rounded once; ends the force phase. A share that is not finite or
    /// beyond [`exact::MAX_SHARE`] is an error.
    fn keep_plate_forces(&mut self, total: exact::PlateSum) -> Result<()> {
        self.lap(|p| &mut p.sum_walls);
        let Some((tb, tt)) = total.totals() else {
            return Err(Error::Solver {
                step: self.step,
                msg: format!(
                    "a plate force that is not finite or beyond {:.1e} N",
                    exact::MAX_SHARE
                ),
            });
        };
        // finite by construction: at most 2^127 grid units, 2^47 N
        self.bottom_force = tb;
        self.top_force = tt;
        Ok(())
    }
}

/// A particle would hold more plate contact records than the slots allow.
fn too_many_wall_contacts(step: u64) -> Error {
    Error::Solver {
        step,
        msg: format!("a particle holds more than {MAX_WALL_CONTACTS} mesh contacts"),
    }
}

/// One thread without dashpot sums: the pair sums are the particles' forces (`0 + a` is `a`
/// bit for bit: a sum started at +0 is never -0), and only the particles with plate
/// candidates (about 11 % on the fast state) are visited, their plate forces added to the
/// exact sum ([`exact::PlateSum`]). Measured on the fast state (1 thread, avx512): sums + walls 30-33 -> 23-24 ns per
/// particle-step. Returns the plate totals (bottom, top), each particle's contributions kept
/// in `wall_force` (a brick's share of the plate forces, [`decompose`]), or None when a
/// particle would hold too many plate contacts.
fn serial_sums(
    f: &mut [V3],
    torque: &mut [V3],
    wall: &mut [WallSlots],
    wall_force: &mut [(V3, V3)],
    acc: &[ForceData],
    walls: &walls::WallContext,
) -> Option<exact::PlateSum> {
    for ((f, t), a) in f.iter_mut().zip(torque.iter_mut()).zip(acc) {
        *f = a.delta_f;
        *t = a.delta_torque;
    }
    let mut total = exact::PlateSum::default();
    let mut none = ([0.0; 6], [0.0; 3]);
    for q in 0..f.len() {
        if walls.cstart[q] == walls.cstart[q + 1] {
            continue;
        }
        let wf = &mut wall_force[q];
        if !walls.particle(q, &mut wall[q], &mut f[q], &mut torque[q], wf, &mut none) {
            return None;
        }
        total.add(wf.0, wf.1);
    }
    Some(total)
}

/// One team member's share of the per-particle outputs of the sums region.
struct Shares<'a> {
    f: &'a mut [V3],
    torque: &'a mut [V3],
    wall: &'a mut [WallSlots],
    wall_force: &'a mut [(V3, V3)],
    /// epsd_implicit's dashpot sums (empty for the other models).
    imp: &'a mut [([f64; 6], V3)],
    acc: &'a mut [ForceData],
}

/// epsd_implicit's dashpot sums of every particle over its pairs (`add_dashpot`, zeroed
/// first), made pair by pair in the list's order: a particle's entries are its pairs in
/// increasing pair index (`NeighborList::entries`), so each particle gets the same additions
/// in the same order as `team_sums`' loop over its entries makes them (the same bits), while
/// each pair's record, both members and their angular velocities are read once, in order,
/// instead of gathered once per member. Measured at 25,000 particles (1 thread, a profile
/// of the study `scaled-25k`): the per-particle gather was about 30 % of the step.
fn dashpot_sums_in_pair_order(
    imp: &mut [([f64; 6], V3)],
    pairs: &[Pair],
    pd: &[PairDamp],
    omega: &[V3],
    torsion: bool,
) {
    imp.fill(([0.0; 6], [0.0; 3]));
    for (pr, &PairDamp { damping: c, en: n }) in pairs.iter().zip(pd) {
        if c == 0.0 {
            continue;
        }
        let (i, j) = (pr.i as usize, pr.j as usize);
        add_dashpot(&mut imp[i], c, n, torsion, omega[j]);
        add_dashpot(&mut imp[j], c, n, torsion, omega[i]);
    }
}

/// The sums region on a team (each member its share of the particles, in particle order):
/// per particle, epsd_implicit's dashpot sums over its pairs (unless `dashpots_summed`:
/// [`dashpot_sums_in_pair_order`] made them), its pair sum ([`pairs::PairSums::add`]), then
/// its plate contacts. True when a particle would hold too many plate contacts.
fn team_sums(
    team: &Team,
    parts: Vec<Shares>,
    walls: &walls::WallContext,
    sum: &pairs::PairSums,
    nl: &NeighborList,
    pd: &[PairDamp],
    dashpots_summed: bool,
) -> bool {
    let (implicit, torsion, omega) = (walls.implicit, walls.torsion, walls.omega);
    let failed = std::sync::atomic::AtomicBool::new(false);
    let body = |q: usize,
                f: &mut V3,
                t: &mut V3,
                slots: &mut WallSlots,
                wf: &mut (V3, V3),
                imp: &mut ([f64; 6], V3),
                acc: &mut ForceData| {
        *f = [0.0; 3];
        *t = [0.0; 3];
        if implicit && !dashpots_summed {
            *imp = ([0.0; 6], [0.0; 3]);
            for &(k, is_i) in &nl.entries[nl.start[q] as usize..nl.start[q + 1] as usize] {
                let PairDamp { damping: c, en: n } = pd[k as usize];
                if c == 0.0 {
                    continue;
                }
                let pr = &nl.pairs[k as usize];
                let other = if is_i { pr.j } else { pr.i } as usize;
                add_dashpot(imp, c, n, torsion, omega[other]);
            }
        }
        // the pair sums (pairs::pass)
        sum.add(q, acc, f, t);
        // a particle without plate candidates holds no records
        // (`drop_records_without_candidates`): nothing to mark, test or clean up, and
        // no plate force (its `wf` is not read)
        if walls.cstart[q] == walls.cstart[q + 1] {
            return;
        }
        if !walls.particle(q, slots, f, t, wf, imp) {
            failed.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    };
    let (n, th) = (walls.x.len(), team.threads());
    team.each(parts, |t, s| {
        let o = bounds(n, th, t).start;
        let mut none = ([0.0; 6], [0.0; 3]);
        for k in 0..s.f.len() {
            let q = o + k;
            let imp = s.imp.get_mut(k).unwrap_or(&mut none);
            body(
                q,
                &mut s.f[k],
                &mut s.torque[k],
                &mut s.wall[k],
                &mut s.wall_force[k],
                imp,
                &mut s.acc[k],
            );
        }
    });
    failed.into_inner()
}

/// The dense state after `steps` compression steps of `case` from `loose` (plates still, the
/// servo pressing the top plate), as the initial state of new runs: what `verify convergence`
/// shares between its dt and codes, and what `verify bench` times from.
pub fn compact(case: &ShearSetup, loose: &Packing, steps: u64) -> Result<Packing> {
    let mut sim = ShearSim::new(case, loose);
    sim.setup(0.0)?;
    for _ in 0..steps {
        sim.step()?;
    }
    Ok(sim.state(loose))
}

impl ShearSim {
    /// epsd_implicit, after the explicit half-kick of the non-dashpot torques: solves the
    /// dashpot implicitly, `(I/h + A) w = (I/h) w* + B` with `w*` the kicked angular velocity
    /// and `h = dt/2`; neighbours' angular velocities enter at their values during the force
    /// computation (Jacobi), so the result does not depend on thread count. The dashpot
    /// torque `B - A w` is added to the stored torque for the next initial half-kick: the
    /// damping is integrated by the trapezoidal rule, A-stable for any `C_r dt / I`.
    pub(super) fn implicit_rotation(&mut self) {
        use rayon::prelude::*;
        let h = self.nve.dtf;
        let (radius, mass) = (&self.radius, &self.mass);
        self.omega
            .par_iter_mut()
            .zip(self.torque.par_iter_mut())
            .zip(self.imp.par_iter())
            .enumerate()
            .for_each(|(i, ((w, t), (a, b)))| {
                if a.iter().all(|x| *x == 0.0) {
                    return;
                }
                let ih = 0.4 * mass[i] * radius[i] * radius[i] / h;
                let m = [a[0] + ih, a[1] + ih, a[2] + ih, a[3], a[4], a[5]];
                let rhs = [ih * w[0] + b[0], ih * w[1] + b[1], ih * w[2] + b[2]];
                let x = solve_sym3(m, rhs);
                let ax = sym_mul(*a, x);
                for k in 0..3 {
                    t[k] += b[k] - ax[k];
                }
                *w = x;
            });
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::packing::loose_packing;
    use crate::solver::contact::models::RollingModel;
    use crate::spec::shear::{Preset, ShearCase};
    use std::sync::OnceLock;

    /// The fast preset's 2,500 particles (epsd, mu_r 0.5, eta_r 0.5, seed 4) after the
    /// preset's whole compression (40,000 steps): the dense state the thread-count, brick,
    /// census, resume and scaling-model tests shear. Made once per test process and shared:
    /// each of those tests made it again before, about 25 s of a core apiece (five of them,
    /// twice in CI: the library's tests run again on the scalar path).
    pub(crate) fn fast_dense() -> &'static (ShearCase, Packing) {
        static DENSE: OnceLock<(ShearCase, Packing)> = OnceLock::new();
        DENSE.get_or_init(|| {
            let c = ShearCase::preset(Preset::Fast, RollingModel::Epsd, 0.5, 0.5, 4).unwrap();
            let dense = compact(&c.setup(), &loose_packing(&c), c.compression_steps).unwrap();
            (c, dense)
        })
    }

    /// Every piece of state a step carries to the next (particles, forces, rotations, pair
    /// list with histories, wall contact slots, plates, servo, rebuild state) as bytes,
    /// f64 as their bits.
    pub(crate) fn state_bytes(s: &ShearSim) -> Vec<u8> {
        rmp_serde::to_vec(&(
            (&s.x, &s.v, &s.omega, &s.f, &s.torque, &s.rotation),
            (&s.nl.pairs, &s.nl.hist, &s.wall, &s.wall_cand),
            (&s.servo, &s.top, &s.bottom, s.top_force, s.bottom_force),
            (s.step, s.ago, s.mesh_rebuild_pending, &s.xhold),
        ))
        .unwrap()
    }

    /// 2500 particles (the paper's count: every per-particle loop is split into several
    /// chunks, the pair pass into many), from a dense state, sheared on 1, 2 and 3 threads:
    /// every bit of the state equal, for the explicit and the implicit rolling dashpot.
    #[test]
    fn bit_identical_for_any_thread_count_at_paper_size() {
        let preset = |model| ShearCase::preset(Preset::Fast, model, 0.5, 0.5, 4).unwrap();
        // one dense packing (the preset's whole compression) for both models
        let (c, dense) = fast_dense();
        assert_eq!(c.particles, 2500);
        for model in [RollingModel::Epsd, RollingModel::EpsdImplicit] {
            let c = preset(model);
            let run = |threads: usize| {
                crate::solver::team::on_threads(threads, || {
                    let mut s = ShearSim::new(&c.setup(), dense);
                    s.setup(c.stages[0].speed).unwrap();
                    for _ in 0..1500 {
                        s.step().unwrap();
                    }
                    s
                })
            };
            let one = run(1);
            let count = |f: fn(&PairState) -> bool| one.pair_state.iter().filter(|a| f(a)).count();
            let touching = count(|a| a.contact != PairContact::Apart);
            let sliding = count(|a| a.sliding);
            let rolling_limit = count(|a| a.contact == PairContact::RollingMobilised);
            assert!(
                touching > 2500 && sliding > 50 && rolling_limit > 50,
                "{model}: a dense sheared state ({touching} touching, {sliding} sliding, \
                 {rolling_limit} at the rolling limit)"
            );
            assert!(
                one.wall.iter().any(|w| !w.rec.is_empty()),
                "{model}: plate contacts"
            );
            assert!(one.omega.iter().any(|w| w[2] != 0.0));
            let reference = state_bytes(&one);
            for threads in [2, 3] {
                assert!(
                    state_bytes(&run(threads)) == reference,
                    "{model}: {threads} threads differ from 1"
                );
            }
        }
    }

    /// At mu_r = 0 eta_r acts on nothing: k_r = 0, so the spring, its cap |Fn| R mu_r and the
    /// dashpot C_r = eta_r 2 sqrt(I_r k_r) are all zero, for the explicit dashpots (epsd,
    /// epsd3) and the implicit one. The paper-protocol report leans on it: the (0, 0) run is
    /// the mu_r = 0 end of the eta_r = 0.5 curve (`report::paper::conclusions`). A sheared
    /// dense state at (0, 0.5) and at (0, 0): every bit the same.
    #[test]
    fn eta_r_acts_on_nothing_at_mu_r_zero() {
        for model in [
            RollingModel::Epsd,
            RollingModel::Epsd3,
            RollingModel::EpsdImplicit,
        ] {
            let run = |eta_r: f64| {
                let c = ShearCase::preset(crate::spec::shear::Preset::Ci, model, 0.0, eta_r, 2)
                    .unwrap();
                let dense = compact(&c.setup(), &loose_packing(&c), c.compression_steps).unwrap();
                let mut s = ShearSim::new(&c.setup(), &dense);
                s.setup(c.stages[0].speed).unwrap();
                for _ in 0..2000 {
                    s.step().unwrap();
                }
                s
            };
            let (damped, undamped) = (run(0.5), run(0.0));
            assert!(
                damped.omega.iter().any(|w| w[2] != 0.0),
                "{model}: grains roll"
            );
            assert!(
                state_bytes(&damped) == state_bytes(&undamped),
                "{model}: eta_r 0.5 changed a state at mu_r 0"
            );
        }
    }

    #[test]
    fn a_blown_up_particle_stops_the_run_at_the_next_rebuild() {
        let mut c = ShearCase::preset(
            crate::spec::shear::Preset::Ci,
            RollingModel::Epsd,
            0.5,
            0.0,
            3,
        )
        .unwrap();
        c.particles = 120;
        let p = loose_packing(&c);
        let mut s = ShearSim::new(&c.setup(), &p);
        s.setup(0.0).unwrap();
        s.v[7] = [0.0, 1e12, 0.0];
        let mut err = None;
        for _ in 0..200 {
            if let Err(e) = s.step() {
                err = Some(e.to_string());
                break;
            }
        }
        let e = err.expect("the run must stop");
        assert!(e.contains("diverged: particle 8"), "{e}");
        assert!(e.starts_with("native solver stopped at step 1:"), "{e}");
    }
}
