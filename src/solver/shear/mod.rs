//! Native solver of the shear box, in LIGGGHTS' order of operations per step:
//! nve/sphere initial_integrate, plate motion (servo `initial_integrate`, `move/mesh linear`),
//! neighbour check and rebuild, force clear, pair forces, plate forces (fix wall/gran:
//! bottom mesh, then top mesh), nve/sphere final_integrate, servo PID update. Every `run`
//! (compression, each shear stage) starts with LIGGGHTS' setup: rebuild, and forces without
//! history update.
//!
//! Parallel and reproducible: pairs are evaluated in parallel, each writing only its own
//! history and force slot; particles then sum their pair forces in pair order (CSR) and their
//! plate contacts in feature order; plate totals are summed in particle order. Results are
//! bit-identical for any number of threads (tested).

pub mod neighbor;
pub mod plate;
pub mod replay;
pub mod servo;

use super::contact::{surfaces_intersect, ContactData, ForceData};
use super::integrate::NveSphere;
use super::material::{sphere_mass, PairParams};
use super::trimesh::{TriContactRecord, TriMesh};
use super::vec3::V3;
use crate::error::{Error, Result};
use crate::packing::Packing;
use crate::spec::shear::ShearCase;
use neighbor::{NeighborList, Periodic};
use plate::{plate_triangles, Plate, Side};
use rayon::prelude::*;
use servo::Servo;

/// Most mesh contact records one sphere may hold at once.
const MAX_WALL_CONTACTS: usize = 8;

/// Mesh contact records of one particle (fix_contact_history_mesh's partner list).
#[derive(Clone, Copy, Debug, Default)]
struct WallSlots {
    n: u8,
    rec: [TriContactRecord; MAX_WALL_CONTACTS],
}

/// The 9 periodic image shifts (x, z) of a triangle; index 4 is the triangle itself.
/// Smallest piece of a parallel loop over particles with little work per item (integration,
/// the rebuild check): below this, rayon's task overhead outweighs the work.
const LIGHT_CHUNK: usize = 1024;
/// Smallest piece of the force loops (pairs, per-particle sums and plate contacts).
const HEAVY_CHUNK: usize = 256;

fn image_shift(k: u8, lx: f64, lz: f64) -> V3 {
    let (ix, iz) = ((k / 3) as f64 - 1.0, (k % 3) as f64 - 1.0);
    [ix * lx, 0.0, iz * lz]
}

/// Per pair, from the force loop: the implicit dashpot's coefficient and contact normal, and
/// the contact state (0 apart, 1 touching, 2 touching with the rolling resistance at full
/// mobilisation).
#[derive(Clone, Copy, Debug, Default)]
struct PairAux {
    damping: f64,
    en: V3,
    contact: u8,
    /// The tangential force is at the Coulomb limit `mu_p |Fn|` (to 1e-9, a label only).
    sliding: bool,
}

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
}

/// The shear box state and time loop.
#[derive(Clone)]
pub struct ShearSim {
    case: ShearCase,
    params: PairParams,
    nve: NveSphere,
    box_: Periodic,
    pub x: Vec<[f64; 3]>,
    pub v: Vec<[f64; 3]>,
    pub omega: Vec<[f64; 3]>,
    f: Vec<[f64; 3]>,
    torque: Vec<[f64; 3]>,
    pub radius: Vec<f64>,
    mass: Vec<f64>,
    rotation: Vec<[f64; 3]>,
    nl: NeighborList,
    xhold: Vec<[f64; 3]>,
    pair_force: Vec<(ForceData, ForceData)>,
    /// epsd_implicit: per pair the dashpot coefficient and contact normal.
    pair_damp: Vec<PairAux>,
    /// DEM_DEBUG_WALL set: print every particle-triangle contact (read once: an environment
    /// lookup per contact cost several per cent of the step).
    debug_wall: bool,
    /// epsd_implicit: per particle `A = sum C P` (symmetric: xx yy zz xy xz yz) and
    /// `B = sum C P w_j` of its rolling dashpots, for the implicit final half-kick.
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
}

impl ShearSim {
    /// The initial state from a generated packing (both codes read the same data).
    pub fn new(case: &ShearCase, packing: &Packing) -> Self {
        let n = packing.radius.len();
        let rho = case.material.density;
        // radius = 0.5 * diameter as read_data computes it; mass as atom_vec_sphere does.
        let radius: Vec<f64> = packing.radius.iter().map(|r| 0.5 * (2.0 * r)).collect();
        let mass = radius.iter().map(|r| sphere_mass(*r, rho)).collect();
        let bottom = Plate::new(Side::Bottom, 0.0, &case.plates, case.box_x);
        let top = Plate::new(Side::Top, packing.top_y, &case.plates, case.box_x);
        let lo = [0.0, packing.box_y_lo, 0.0];
        let hi = [case.box_x, packing.box_y_hi, case.box_z];
        let meshes = [
            TriMesh::new(&plate_triangles(&bottom, case.box_z), lo, hi),
            TriMesh::new(&plate_triangles(&top, case.box_z), lo, hi),
        ];
        let top_orig = meshes[1].tris.iter().map(|t| t.nodes).collect();
        let com = [0.5 * case.box_x, packing.top_y, 0.5 * case.box_z];
        ShearSim {
            case: case.clone(),
            params: PairParams::new(&case.material, &case.models, case.dt),
            nve: NveSphere::new(case.dt),
            box_: Periodic {
                lx: case.box_x,
                lz: case.box_z,
            },
            x: packing.position.clone(),
            v: packing.velocity.clone(),
            omega: packing.omega.clone(),
            f: vec![[0.0; 3]; n],
            torque: vec![[0.0; 3]; n],
            radius,
            mass,
            rotation: vec![[0.0; 3]; n],
            nl: NeighborList::default(),
            xhold: packing.position.clone(),
            pair_force: Vec::new(),
            pair_damp: Vec::new(),
            debug_wall: std::env::var_os("DEM_DEBUG_WALL").is_some(),
            imp: vec![([0.0; 6], [0.0; 3]); n],
            implicit: case.models.rolling == crate::spec::RollingModel::EpsdImplicit,
            wall: vec![WallSlots::default(); n],
            wall_force: vec![([0.0; 3], [0.0; 3]); n],
            wall_start: vec![0; n + 1],
            wall_cand: Vec::new(),
            meshes,
            top_orig,
            bottom,
            top,
            top_base0: packing.top_y,
            servo: Servo::new(&case.servo, case.target_force(), com, case.dt),
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
        }
    }

    /// Starts a new run (LIGGGHTS `run` after changing fixes): the bottom plate's speed, the
    /// servo's reference, a neighbour rebuild, and forces without history update.
    pub fn setup(&mut self, bottom_speed: f64) -> Result<()> {
        self.setup_plates(bottom_speed);
        self.rebuild();
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

    /// Current sample height: distance between the plates' mean surfaces [m].
    pub fn height(&self) -> f64 {
        self.top.base_y - self.bottom.base_y - self.case.plates.tooth_height()
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
        let (touching, mobilised) = self.pair_damp.iter().fold((0usize, 0usize), |(t, m), a| {
            (
                t + usize::from(a.contact > 0),
                m + usize::from(a.contact == 2),
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

    /// Neighbour rebuilds so far.
    pub fn neighbor_builds(&self) -> u64 {
        self.nl.builds
    }

    /// One time step.
    pub fn step(&mut self) -> Result<()> {
        self.step += 1;
        let nve = self.nve;
        let dt = self.case.dt;
        let (radius, mass) = (&self.radius, &self.mass);
        self.x
            .par_iter_mut()
            .zip(self.v.par_iter_mut())
            .zip(self.omega.par_iter_mut())
            .zip(self.f.par_iter().zip(self.torque.par_iter()))
            .zip(self.rotation.par_iter_mut())
            .with_min_len(LIGHT_CHUNK)
            .enumerate()
            .for_each(|(i, ((((x, v), w), (f, t)), rot))| {
                nve.initial(x, v, w, *f, *t, radius[i], mass[i]);
                for k in 0..3 {
                    rot[k] += w[k] * dt;
                }
            });
        self.move_plates();
        if self.decide_rebuild() {
            self.rebuild();
        } else {
            // FixMesh::pre_force on a step without rebuild: a plate whose nodes moved more
            // than skin/2 since the last build asks for a rebuild at the next step
            self.mesh_rebuild_pending = self.plates_moved();
        }
        self.compute_forces(true)?;
        if let Some((v, w)) = &mut self.force_time_velocities {
            v.clone_from(&self.v);
            w.clone_from(&self.omega);
        }
        let (radius, mass) = (&self.radius, &self.mass);
        self.x
            .par_iter()
            .zip(self.v.par_iter_mut())
            .zip(self.omega.par_iter_mut())
            .zip(self.f.par_iter().zip(self.torque.par_iter()))
            .with_min_len(LIGHT_CHUNK)
            .enumerate()
            .for_each(|(i, (((_, v), w), (f, t)))| nve.finish(v, w, *f, *t, radius[i], mass[i]));
        if self.implicit {
            self.implicit_rotation();
        }
        self.servo.final_integrate(self.top_force);
        Ok(())
    }

    /// The plates' initial_integrate: the servo moves the top plate, `move/mesh linear` the
    /// bottom one.
    fn move_plates(&mut self) {
        let d = self.servo.initial_integrate();
        self.top.base_y = self.top_base0 + d[1];
        self.meshes[1].place(&self.top_orig, d);
        self.bottom_node_v = self.bottom_speed;
        if self.bottom_speed != 0.0 {
            // MeshMoverLinear: nodes += vel * dt every step
            let dx = self.bottom_speed * self.case.dt;
            self.meshes[0].translate([dx, 0.0, 0.0]);
            self.bottom.offset_x += dx;
            self.shear_displacement += dx;
        }
    }

    /// `Neighbor::decide` with `delay 0`: a rebuild a plate asked for at the previous step
    /// (`next_reneighbor`), else every `neighbor.every` steps since the last build, and with
    /// `check` only if an atom moved more than skin/2 (`check_distance`).
    fn decide_rebuild(&mut self) -> bool {
        if self.mesh_rebuild_pending {
            return true;
        }
        self.ago += 1;
        let sched = &self.case.neighbor;
        self.ago.is_multiple_of(sched.every) && (!sched.check || self.particles_moved())
    }

    /// `Neighbor::check_distance`: some atom moved more than skin/2 since the last build.
    fn particles_moved(&self) -> bool {
        let trigger = 0.5 * self.case.skin;
        let t2 = trigger * trigger;
        self.x
            .par_iter()
            .zip(self.xhold.par_iter())
            .with_min_len(LIGHT_CHUNK)
            .any(|(x, h)| {
                let d = [x[0] - h[0], x[1] - h[1], x[2] - h[2]];
                d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > t2
            })
    }

    /// `MultiNodeMesh::decideRebuild` for both plates: a node moved more than skin/2 since the
    /// last build (every node of a plate moves by the same vector).
    fn plates_moved(&self) -> bool {
        let trigger = 0.5 * self.case.skin;
        (self.bottom.offset_x - self.bottom_hold).abs() > trigger
            || (self.top.base_y - self.top_hold).abs() > trigger
    }

    /// Wraps positions into the periodic box (LAMMPS `domain->pbc()`) and rebuilds the list.
    fn rebuild(&mut self) {
        let (lx, lz) = (self.box_.lx, self.box_.lz);
        for x in &mut self.x {
            if x[0] < 0.0 {
                x[0] += lx;
            } else if x[0] >= lx {
                x[0] -= lx;
            }
            if x[2] < 0.0 {
                x[2] += lz;
            } else if x[2] >= lz {
                x[2] -= lz;
            }
        }
        self.nl
            .build(&self.x, &self.radius, self.case.skin, self.box_);
        self.rebuild_plates();
        self.build_wall_candidates();
        self.xhold.clone_from(&self.x);
        self.pair_force
            .resize(self.nl.pairs.len(), Default::default());
        self.pair_damp
            .resize(self.nl.pairs.len(), PairAux::default());
    }

    /// The plates' part of a rebuild: the bottom mesh's elements wrapped into the box
    /// (FixMesh::pre_force, `pbcExchangeBorders`), the surface properties recomputed from the
    /// moved nodes (`refreshOwned`), node positions and build counter kept
    /// for the next decision (`storeNodePosRebuild`, `Neighbor::build` sets `ago = 0`).
    fn rebuild_plates(&mut self) {
        self.meshes[0].wrap_x(self.box_.lx);
        for m in &mut self.meshes {
            m.refresh_surface_properties();
        }
        self.ago = 0;
        self.mesh_rebuild_pending = false;
        self.bottom_hold = self.bottom.offset_x;
        self.top_hold = self.top.base_y;
    }

    /// Per particle, the (mesh, triangle, image) within reach until the next rebuild: the
    /// triangle's plane within `r + skin` and its bounding sphere within `r_bound + r + skin`
    /// (LIGGGHTS' test), ordered as LIGGGHTS loops: bottom mesh then top, the triangle itself
    /// before its images, by triangle id.
    ///
    /// Not in LIGGGHTS: a candidate must also have its bounding box within `r + skin`. The
    /// plates' triangles are strips across the whole box, so the bounding sphere admits faces
    /// two teeth away whose plane happens to pass near the particle; the box test drops them.
    /// It only drops triangles that cannot be touched before the next rebuild (a particle
    /// and a plate each move less than `skin / 2` until then, and the box distance is a lower
    /// bound of the triangle distance), and it keeps the order of the others, so the contacts
    /// found and the order their forces are summed in are unchanged: bitwise the same
    /// results, fewer sphere-triangle tests per step.
    fn build_wall_candidates(&mut self) {
        let (lx, lz, skin) = (self.box_.lx, self.box_.lz, self.case.skin);
        let meshes = &self.meshes;
        let y_range: Vec<(f64, f64)> = meshes
            .iter()
            .map(|m| {
                m.tris
                    .iter()
                    .flat_map(|t| t.nodes.iter().map(|n| n[1]))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), y| {
                        (lo.min(y), hi.max(y))
                    })
            })
            .collect();
        let per: Vec<Vec<(u8, u32, u8)>> = self
            .x
            .par_iter()
            .zip(self.radius.par_iter())
            .map(|(p, r)| {
                let mut c = Vec::new();
                for (m, mesh) in meshes.iter().enumerate() {
                    // a particle farther than r + skin from the mesh's y extent has no
                    // candidate in it (each triangle's box test would fail): skip the mesh
                    let (ylo, yhi) = y_range[m];
                    if p[1] < ylo - (r + skin) * (1.0 + 1e-9)
                        || p[1] > yhi + (r + skin) * (1.0 + 1e-9)
                    {
                        continue;
                    }
                    for img in [4u8, 0, 1, 2, 3, 5, 6, 7, 8] {
                        let s = image_shift(img, lx, lz);
                        for (t, (cen, rb)) in mesh.center.iter().zip(&mesh.r_bound).enumerate() {
                            let d = [p[0] - cen[0] - s[0], p[1] - cen[1], p[2] - cen[2] - s[2]];
                            let reach = rb + r + skin;
                            // resolveTriSphereNeighbuild: plane distance first, then bounds
                            let n = mesh.tris[t].normal;
                            let plane = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]).abs();
                            if plane <= r + skin
                                && d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= reach * reach
                                && box_distance_sq(p, &mesh.tris[t].nodes, s)
                                    <= (r + skin) * (r + skin) * (1.0 + 1e-9)
                            {
                                c.push((m as u8, t as u32, img));
                            }
                        }
                    }
                }
                c
            })
            .collect();
        self.wall_start.clear();
        self.wall_start.push(0);
        self.wall_cand.clear();
        for c in per {
            self.wall_cand.extend(c);
            self.wall_start.push(self.wall_cand.len() as u32);
        }
    }

    fn compute_forces(&mut self, update_history: bool) -> Result<()> {
        let params = &self.params;
        let (x, v, omega, radius, mass) = (&self.x, &self.v, &self.omega, &self.radius, &self.mass);
        // pair forces: each pair writes its own history and force slot
        self.nl
            .pairs
            .par_iter_mut()
            .zip(
                self.pair_force
                    .par_iter_mut()
                    .zip(self.pair_damp.par_iter_mut()),
            )
            .with_min_len(HEAVY_CHUNK)
            .for_each(|(p, (out, damp))| {
                let (i, j) = (p.i as usize, p.j as usize);
                let Some(mut cd) = pair_contact(
                    p,
                    (x[i], x[j]),
                    (radius[i], radius[j]),
                    (mass[i], mass[j]),
                    (v[i], v[j]),
                    (omega[i], omega[j]),
                ) else {
                    *out = Default::default();
                    *damp = PairAux::default();
                    return;
                };
                let (fi, fj, o) = surfaces_intersect(&mut cd, params, &mut p.hist, update_history);
                *out = (fi, fj);
                let ft2 = o.ft[0] * o.ft[0] + o.ft[1] * o.ft[1] + o.ft[2] * o.ft[2];
                let cap = params.coeff_frict * o.normal.fn_.abs();
                *damp = PairAux {
                    damping: o.implicit_damping,
                    en: cd.en,
                    contact: if o.rolling_mobilised { 2 } else { 1 },
                    sliding: ft2 >= cap * cap * (1.0 - 1e-9),
                };
            });
        // per-particle sums in pair order, then plate contacts
        let nl = &self.nl;
        let pf = &self.pair_force;
        let pd = &self.pair_damp;
        let implicit = self.implicit;
        let debug_wall = self.debug_wall;
        let torsion = params.torsion_torque;
        let meshes = &self.meshes;
        let (cand, cstart) = (&self.wall_cand, &self.wall_start);
        let (lx, lz) = (self.box_.lx, self.box_.lz);
        // node velocities: move/mesh linear (bottom), servo vcm (top)
        let vnode = [[self.bottom_node_v, 0.0, 0.0], self.servo.vcm];
        let failed = std::sync::atomic::AtomicBool::new(false);
        self.f
            .par_iter_mut()
            .zip(self.torque.par_iter_mut())
            .zip(self.wall.par_iter_mut())
            .zip(self.wall_force.par_iter_mut().zip(self.imp.par_iter_mut()))
            .with_min_len(HEAVY_CHUNK)
            .enumerate()
            .for_each(|(q, (((f, t), slots), (wf, imp)))| {
                *f = [0.0; 3];
                *t = [0.0; 3];
                *imp = ([0.0; 6], [0.0; 3]);
                if implicit {
                    for &(k, is_i) in &nl.entries[nl.start[q] as usize..nl.start[q + 1] as usize] {
                        let PairAux {
                            damping: c, en: n, ..
                        } = pd[k as usize];
                        if c == 0.0 {
                            continue;
                        }
                        let pr = &nl.pairs[k as usize];
                        let other = if is_i { pr.j } else { pr.i } as usize;
                        add_dashpot(imp, c, n, torsion, omega[other]);
                    }
                }
                for &(k, is_i) in &nl.entries[nl.start[q] as usize..nl.start[q + 1] as usize] {
                    let fd = if is_i {
                        &pf[k as usize].0
                    } else {
                        &pf[k as usize].1
                    };
                    for c in 0..3 {
                        f[c] += fd.delta_f[c];
                        t[c] += fd.delta_torque[c];
                    }
                }
                *wf = ([0.0; 3], [0.0; 3]);
                for m in 0..2u8 {
                    // markAllContacts of this mesh
                    for r in &mut slots.rec[..slots.n as usize] {
                        if r.mesh == m {
                            r.keep = false;
                        }
                    }
                    let mesh = &meshes[m as usize];
                    for &(cm, tri, img) in &cand[cstart[q] as usize..cstart[q + 1] as usize] {
                        if cm != m {
                            continue;
                        }
                        let shift = image_shift(img, lx, lz);
                        if mesh.beyond_plane(tri as usize, shift, x[q], radius[q]) {
                            continue;
                        }
                        let Some(hit) = mesh.resolve(tri as usize, shift, x[q]) else {
                            continue;
                        };
                        let deltan = hit.d - radius[q];
                        if deltan > 0.0 {
                            continue;
                        }
                        // handleContact
                        let n = slots.n as usize;
                        let slot = match (0..n)
                            .find(|&i| slots.rec[i].mesh == m && slots.rec[i].tri == tri)
                        {
                            Some(i) => {
                                slots.rec[i].keep = true;
                                i
                            }
                            None => {
                                let cop = &mesh.coplanar[tri as usize];
                                if hit.face
                                    && (0..n).any(|i| {
                                        slots.rec[i].mesh == m
                                            && slots.rec[i].keep
                                            && cop.contains(&slots.rec[i].tri)
                                    })
                                {
                                    continue;
                                }
                                if n == MAX_WALL_CONTACTS {
                                    failed.store(true, std::sync::atomic::Ordering::Relaxed);
                                    return;
                                }
                                let mut rec = TriContactRecord {
                                    mesh: m,
                                    tri,
                                    keep: true,
                                    ..Default::default()
                                };
                                if hit.face {
                                    for i in 0..n {
                                        if slots.rec[i].mesh == m && cop.contains(&slots.rec[i].tri)
                                        {
                                            rec.hist = slots.rec[i].hist;
                                        }
                                    }
                                }
                                slots.rec[n] = rec;
                                slots.n += 1;
                                n
                            }
                        };
                        let vn = vnode[m as usize];
                        let b = hit.bary;
                        let vw = [
                            b[0] * vn[0] + b[1] * vn[0] + b[2] * vn[0],
                            b[0] * vn[1] + b[1] * vn[1] + b[2] * vn[1],
                            b[0] * vn[2] + b[1] * vn[2] + b[2] * vn[2],
                        ];
                        let overlap = -deltan;
                        let sdelta = [-hit.delta[0], -hit.delta[1], -hit.delta[2]];
                        let r = radius[q] - overlap;
                        let rinv = 1.0 / r;
                        let mut cd = ContactData {
                            is_wall: true,
                            radi: radius[q],
                            radsum: radius[q],
                            r,
                            rinv,
                            delta: sdelta,
                            en: [sdelta[0] * rinv, sdelta[1] * rinv, sdelta[2] * rinv],
                            deltan: overlap,
                            meff: mass[q],
                            mi: mass[q],
                            v_i: v[q],
                            v_j: vw,
                            omega_i: omega[q],
                            ..Default::default()
                        };
                        if debug_wall {
                            eprintln!(
                                "wall p {} mesh {m} tri {tri} img {img} face {} d {:e} cp {:e} {:e} {:e}",
                                q + 1,
                                hit.face,
                                hit.d,
                                x[q][0] + hit.delta[0],
                                x[q][1] + hit.delta[1],
                                x[q][2] + hit.delta[2]
                            );
                        }
                        let mut hist = slots.rec[slot].hist;
                        let (fi, _, o) =
                            surfaces_intersect(&mut cd, params, &mut hist, update_history);
                        if implicit && o.implicit_damping != 0.0 {
                            // walls do not rotate; the dashpot acts on wr = cr omega_i / r
                            add_dashpot(
                                imp,
                                o.implicit_damping * cd.cri * cd.rinv,
                                cd.en,
                                torsion,
                                [0.0; 3],
                            );
                        }
                        slots.rec[slot].hist = hist;
                        slots.rec[slot].force = fi.delta_f;
                        slots.rec[slot].torque = fi.delta_torque;
                        slots.rec[slot].face = hit.face;
                        let before = *f;
                        for c in 0..3 {
                            f[c] += fi.delta_f[c];
                            t[c] += fi.delta_torque[c];
                        }
                        let dest = if m == 1 { &mut wf.1 } else { &mut wf.0 };
                        for c in 0..3 {
                            dest[c] += -(f[c] - before[c]);
                        }
                    }
                    // cleanUpContacts of this mesh
                    let mut k = 0;
                    for i in 0..slots.n as usize {
                        let r = slots.rec[i];
                        if r.mesh != m || r.keep {
                            slots.rec[k] = r;
                            k += 1;
                        }
                    }
                    slots.n = k as u8;
                }
            });
        if failed.into_inner() {
            return Err(Error::Solver {
                step: self.step,
                msg: format!("a particle holds more than {MAX_WALL_CONTACTS} mesh contacts"),
            });
        }
        let mut tb = [0.0; 3];
        let mut tt = [0.0; 3];
        for (b, t) in &self.wall_force {
            for c in 0..3 {
                tb[c] += b[c];
                tt[c] += t[c];
            }
        }
        self.bottom_force = tb;
        self.top_force = tt;
        if !(tt.iter().chain(tb.iter()).all(|v| v.is_finite())) {
            return Err(Error::Solver {
                step: self.step,
                msg: "non-finite plate force".into(),
            });
        }
        Ok(())
    }

    /// epsd_implicit, after the explicit half-kick of the non-dashpot torques: solves the
    /// dashpot implicitly, `(I/h + A) w = (I/h) w* + B` with `w*` the kicked angular velocity
    /// and `h = dt/2`; neighbours' angular velocities enter at their values during the force
    /// computation (Jacobi), so the result does not depend on thread count. The dashpot
    /// torque `B - A w` is added to the stored torque for the next initial half-kick: the
    /// damping is integrated by the trapezoidal rule, A-stable for any `C_r dt / I`.
    fn implicit_rotation(&mut self) {
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

/// The dense state after `steps` compression steps of `case` from `loose` (plates still, the
/// servo pressing the top plate), as the initial state of new runs: what `verify convergence`
/// shares between its dt and codes, and what `verify bench` times from.
pub fn compact(case: &ShearCase, loose: &Packing, steps: u64) -> Result<Packing> {
    let mut sim = ShearSim::new(case, loose);
    sim.setup(0.0)?;
    for _ in 0..steps {
        sim.step()?;
    }
    Ok(sim.state(loose))
}

/// The contact data of a listed pair as pair_gran_base.h sets it up (j seen at its image
/// `x_j + shift`, `delta = x_i - x_j`), or None if the pair does not touch
/// (`rsq >= radsum^2`).
pub(crate) fn pair_contact(
    p: &neighbor::Pair,
    x: (V3, V3),
    radius: (f64, f64),
    mass: (f64, f64),
    v: (V3, V3),
    omega: (V3, V3),
) -> Option<ContactData> {
    let (xi, xj) = x;
    let xj = [xj[0] + p.shift[0], xj[1] + p.shift[1], xj[2] + p.shift[2]];
    let delta = [xi[0] - xj[0], xi[1] - xj[1], xi[2] - xj[2]];
    let rsq = delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2];
    let radsum = radius.0 + radius.1;
    if rsq >= radsum * radsum {
        return None;
    }
    Some(ContactData::pair(
        delta, rsq, radius.0, radius.1, mass.0, mass.1, v, omega,
    ))
}

/// Squared distance from `p` to the axis-aligned bounding box of a triangle shifted by `s`.
fn box_distance_sq(p: &V3, nodes: &[V3; 3], s: V3) -> f64 {
    let mut d2 = 0.0;
    for c in 0..3 {
        let lo = nodes[0][c].min(nodes[1][c]).min(nodes[2][c]) + s[c];
        let hi = nodes[0][c].max(nodes[1][c]).max(nodes[2][c]) + s[c];
        let e = if p[c] < lo {
            lo - p[c]
        } else if p[c] > hi {
            p[c] - hi
        } else {
            0.0
        };
        d2 += e * e;
    }
    d2
}

/// Adds one implicit rolling dashpot `C P` (and `C P w_other`) to a particle's system.
fn add_dashpot(imp: &mut ([f64; 6], V3), c: f64, n: V3, torsion: bool, w_other: V3) {
    let p = if torsion {
        [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
    } else {
        [
            1.0 - n[0] * n[0],
            1.0 - n[1] * n[1],
            1.0 - n[2] * n[2],
            -n[0] * n[1],
            -n[0] * n[2],
            -n[1] * n[2],
        ]
    };
    for k in 0..6 {
        imp.0[k] += c * p[k];
    }
    let pw = sym_mul(p, w_other);
    for k in 0..3 {
        imp.1[k] += c * pw[k];
    }
}

/// Symmetric 3x3 (xx yy zz xy xz yz) times a vector.
fn sym_mul(a: [f64; 6], x: V3) -> V3 {
    [
        a[0] * x[0] + a[3] * x[1] + a[4] * x[2],
        a[3] * x[0] + a[1] * x[1] + a[5] * x[2],
        a[4] * x[0] + a[5] * x[1] + a[2] * x[2],
    ]
}

/// Solves a symmetric positive definite 3x3 system by cofactors.
fn solve_sym3(a: [f64; 6], b: V3) -> V3 {
    let [xx, yy, zz, xy, xz, yz] = a;
    let c00 = yy * zz - yz * yz;
    let c01 = xz * yz - xy * zz;
    let c02 = xy * yz - xz * yy;
    let c11 = xx * zz - xz * xz;
    let c12 = xy * xz - xx * yz;
    let c22 = xx * yy - xy * xy;
    let det = xx * c00 + xy * c01 + xz * c02;
    [
        (c00 * b[0] + c01 * b[1] + c02 * b[2]) / det,
        (c01 * b[0] + c11 * b[1] + c12 * b[2]) / det,
        (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::loose_packing;
    use crate::spec::RollingModel;

    fn run_steps(threads: usize, steps: u64) -> (Vec<[f64; 3]>, PlateRecord) {
        let mut c = ShearCase::preset("ci", RollingModel::Epsd, 0.5, 0.5, 3).unwrap();
        c.particles = 120;
        let p = loose_packing(&c);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut s = ShearSim::new(&c, &p);
            s.setup(0.0).unwrap();
            for _ in 0..steps / 2 {
                s.step().unwrap();
            }
            s.setup(0.01).unwrap();
            for _ in 0..steps / 2 {
                s.step().unwrap();
            }
            (s.x.clone(), s.record())
        })
    }

    #[test]
    fn box_distance_is_zero_inside_and_a_lower_bound_outside() {
        let nodes = [[0.0, 0.0, 0.0], [1.0, 0.5, 0.0], [1.0, 0.5, 2.0]];
        assert_eq!(box_distance_sq(&[0.5, 0.25, 1.0], &nodes, [0.0; 3]), 0.0);
        // 0.5 beyond x = 1 and 1 below y = 0: squared distance 1.25
        let d2 = box_distance_sq(&[1.5, -1.0, 1.0], &nodes, [0.0; 3]);
        assert!((d2 - 1.25).abs() < 1e-15);
        // shifted by one period in z the same point is 1 away from the box in z
        let d2 = box_distance_sq(&[0.5, 0.25, -1.0], &nodes, [0.0, 0.0, -4.0]);
        assert!((d2 - 1.0).abs() < 1e-15);
        // a lower bound of the distance to every node
        let p = [2.0, 2.0, 3.0];
        let dmin = nodes
            .iter()
            .map(|n| (0..3).map(|c| (p[c] - n[c]).powi(2)).sum::<f64>())
            .fold(f64::INFINITY, f64::min);
        assert!(box_distance_sq(&p, &nodes, [0.0; 3]) <= dmin);
    }

    #[test]
    fn symmetric_solve_inverts_sym_mul() {
        let a = [4.0, 3.0, 5.0, 1.0, -0.5, 0.25];
        let x = [0.3, -1.2, 2.0];
        let b = sym_mul(a, x);
        let y = solve_sym3(a, b);
        for k in 0..3 {
            assert!((x[k] - y[k]).abs() < 1e-14);
        }
        // a dashpot projects out the normal component
        let mut imp = ([0.0; 6], [0.0; 3]);
        add_dashpot(&mut imp, 2.0, [0.0, 1.0, 0.0], false, [1.0, 5.0, 0.0]);
        assert_eq!(imp.0, [2.0, 0.0, 2.0, -0.0, -0.0, -0.0]);
        assert_eq!(imp.1, [2.0, 0.0, 0.0]);
    }

    #[test]
    fn implicit_dashpot_is_bit_identical_for_any_thread_count() {
        let mut c = ShearCase::preset("ci", RollingModel::EpsdImplicit, 1.0, 0.5, 3).unwrap();
        c.particles = 120;
        let p = loose_packing(&c);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    let mut s = ShearSim::new(&c, &p);
                    s.setup(0.0).unwrap();
                    for _ in 0..3000 {
                        s.step().unwrap();
                    }
                    s.omega.clone()
                })
        };
        let (a, b) = (run(1), run(3));
        assert!(a.iter().any(|w| w[0] != 0.0));
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.map(f64::to_bits), y.map(f64::to_bits));
        }
    }

    #[test]
    fn bit_identical_for_any_thread_count() {
        let (x1, r1) = run_steps(1, 3000);
        let (x3, r3) = run_steps(3, 3000);
        assert!(r1.top_force[1] != 0.0, "plate must be loaded in this test");
        for (a, b) in x1.iter().zip(&x3) {
            for k in 0..3 {
                assert_eq!(a[k].to_bits(), b[k].to_bits());
            }
        }
        assert_eq!(
            r1.top_force.map(f64::to_bits),
            r3.top_force.map(f64::to_bits)
        );
    }
}
