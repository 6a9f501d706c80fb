//! One shear simulation decomposed into bricks (issue #39, docs/mpi.md): each brick a
//! [`ShearSim`] over the particles it owns and its ghosts, stepping in lockstep with the
//! others through a [`Transport`] (bricks as threads of one process here; MPI ranks behind
//! the same trait), **every bit of the state that of one process** for any number of bricks
//! and threads.
//!
//! Read from LAMMPS (comm_brick.cpp `exchange`, `borders`, `forward_comm`; fix
//! contact/history's `pack_exchange`, which moves a particle's pair histories with it) and
//! written our own way:
//!
//! - **Ownership** is decided at a neighbour rebuild, by the wrapped position
//!   ([`Bricks::owner`]); between rebuilds a particle stays with its brick wherever it drifts
//!   (it moves less than skin/2), as in LAMMPS.
//! - **Ghosts** are every particle another brick owns within `2 r_max + skin` of this one
//!   (every partner a pair of an own particle can have), chosen at the rebuild, kept with
//!   their true coordinates: a pair finds its periodic image as one process does. A brick's
//!   particles are held in increasing global id, ghosts among its own: its pair list is
//!   then one process's list restricted to the pairs with an own member, in the same order,
//!   so each own particle's pair sum adds the same terms in the same order
//!   (`bricks_with_ghosts_give_each_owned_particle_the_bits_of_one_process`). A pair with
//!   members in two bricks is computed in both (LIGGGHTS' newton off) from equal inputs, so
//!   both copies of its history stay equal. Pairs of two ghosts are not listed.
//! - **Every step**: the drift (a ghost's drift is discarded); **one all-reduce** of a few
//!   hundred bytes: the skin/2 test and the last step's plate forces, each brick's exact sum
//!   over its own particles added over the bricks (any order gives one process's bits:
//!   [`super::exact`]), with whether its force evaluation failed; the servo's update from
//!   those sums (identically in every brick); the ghosts' positions and velocities sent by
//!   their owners to the bricks that hold them (`forward`: messages to neighbouring bricks
//!   only); the plates moved (identically in every brick); forces for the own particles and
//!   the final half-kick. The plate sum waits for the next step's all-reduce because nothing
//!   reads it before the next step moves the plates (the drift and the half-kick read the
//!   particles only): a step synchronises the bricks once, not twice, so the per-step
//!   spread of two bricks' times is waited for once. Every call that reads the state
//!   between steps (gathering it, a setup, an agreement) first settles the sum
//!   ([`Brick::settle`]); the servo then holds one process's bits.
//! - **A rebuild** wraps the own particles, sends each one whose owner changed to its new
//!   brick with every per-particle state it carries (velocities, force, torque, rotation,
//!   plate contact records) and the histories of its pairs (`migrate`), then each brick
//!   sends its new own particles near another brick to it as ghosts (`border`) and lists its
//!   pairs, giving each touching pair its history by the pair's ids. Both go as numbers
//!   (every value exactly: [`Numbers`]) to the neighbouring bricks only ([`Bricks::near`]:
//!   a particle moves less than the ghost cut between rebuilds), a message of lengths then
//!   one of numbers, as LAMMPS' `exchange` and `borders` talk to their neighbours only.
//! - **Errors** (a diverged particle, too many plate contacts) are agreed on: every brick
//!   stops at the same step, the one that found it with its message.
//!
//! A brick is made from the whole state ([`Brick::of`]: as it was at the last rebuild,
//! without a new one) and gives it back ([`Brick::gather`]), so a run checkpointed from
//! one decomposition resumes on another to the same bits.

use super::bricks::Bricks;
use super::exact::{PlateSum, LIMB_LEN};
use super::neighbor::{Carried, Members, NeighborList, Pair};
use super::{PairState, ShearSim, WallSlots};
use crate::error::{Error, Result};
use crate::solver::contact::{ContactHistory, ForceData};
use crate::solver::trimesh::TriContactRecord;
use crate::solver::vec3::V3;
use std::any::Any;
use std::sync::{Arc, Barrier, Mutex};
use std::time::Instant;

/// What may travel between bricks: anything an MPI transport can serialise and the
/// in-process one can move.
pub trait Wire: serde::Serialize + serde::de::DeserializeOwned + Send + 'static {}
impl<T: serde::Serialize + serde::de::DeserializeOwned + Send + 'static> Wire for T {}

/// How bricks talk: each of `size` ranks calls every collective in the same order.
pub trait Transport {
    /// This brick's rank, `0..size`.
    fn rank(&self) -> usize;
    fn size(&self) -> usize;
    /// All-to-all: `out[s]` is delivered to rank `s`; returns what each rank sent to this
    /// one, by sender (this rank's own `out[rank]` included).
    fn exchange<T: Wire>(&self, out: Vec<T>) -> Vec<T>;
    /// The per-step messages, numbers sent as they are to the ranks they are for only:
    /// `out[r]` to rank r (nothing when empty); `got[r]` filled from rank r, its length (what
    /// rank r sends, fixed at a rebuild) known in advance. The buffers are the caller's,
    /// reused from step to step. MPI: point-to-point, no encoding.
    fn exchange_f64(&self, out: &[Vec<f64>], got: &mut [Vec<f64>]);
    /// All-reduce: `words` added word by word (wrapping) over every rank, on every rank.
    fn sum_u64(&self, words: &mut [u64]);
    /// What this rank's calls have carried so far, where the transport counts it (MPI);
    /// None where it does not (bricks as threads move values without encoding them).
    fn traffic(&self) -> Option<Traffic> {
        None
    }
}

/// What one rank's exchanges carried: what `verify bench` reports of a decomposed run and
/// the scaling model is fitted to (docs/mpi.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Traffic {
    /// Exchanges (each one collective call, or two for [`Transport::exchange`]).
    pub calls: u64,
    /// Messages this rank sent to other ranks (non-empty ones).
    pub messages: u64,
    /// Bytes this rank sent to other ranks.
    pub bytes: u64,
    /// Wall time inside the exchanges [s]: the transfers, and the waits for the slowest rank.
    pub seconds: f64,
}

impl Traffic {
    /// What was carried since `earlier`.
    pub fn since(&self, earlier: &Traffic) -> Traffic {
        Traffic {
            calls: self.calls - earlier.calls,
            messages: self.messages - earlier.messages,
            bytes: self.bytes - earlier.bytes,
            seconds: self.seconds - earlier.seconds,
        }
    }
}

/// Every rank's `mine`, by rank.
pub fn all_gather<T: Wire + Clone>(t: &impl Transport, mine: T) -> Vec<T> {
    t.exchange(vec![mine; t.size()])
}

/// True on every rank when `b` is true on any.
pub fn any(t: &impl Transport, b: bool) -> bool {
    all_gather(t, b).contains(&true)
}

/// Bricks as threads of one process: what the bit-identity tests run (no MPI needed), and a
/// decomposition of one machine's run.
pub struct InProcess {
    rank: usize,
    size: usize,
    board: Arc<Board>,
}

/// The in-process mailboxes: rank r's outgoing values in `slots[r]` between two barriers.
struct Board {
    slots: Vec<Mutex<Option<Box<dyn Any + Send>>>>,
    barrier: Barrier,
}

impl InProcess {
    /// The `size` ranks of one group, one per thread to run.
    pub fn group(size: usize) -> Vec<InProcess> {
        let board = Arc::new(Board {
            slots: (0..size).map(|_| Mutex::new(None)).collect(),
            barrier: Barrier::new(size),
        });
        (0..size)
            .map(|rank| InProcess {
                rank,
                size,
                board: Arc::clone(&board),
            })
            .collect()
    }
}

impl Transport for InProcess {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn exchange<T: Wire>(&self, out: Vec<T>) -> Vec<T> {
        assert_eq!(out.len(), self.size, "one message per rank");
        let lock = |r: usize| {
            self.board.slots[r]
                .lock()
                .unwrap_or_else(|e| e.into_inner())
        };
        let boxed: Vec<Option<T>> = out.into_iter().map(Some).collect();
        *lock(self.rank) = Some(Box::new(boxed));
        self.board.barrier.wait();
        let got = (0..self.size)
            .map(|r| {
                let mut slot = lock(r);
                let theirs = slot
                    .as_mut()
                    .and_then(|b| b.downcast_mut::<Vec<Option<T>>>())
                    .expect("every rank exchanges the same type");
                theirs[self.rank].take().expect("one message per rank")
            })
            .collect();
        // no rank writes its slot again before every rank has read it
        self.board.barrier.wait();
        got
    }

    fn exchange_f64(&self, out: &[Vec<f64>], got: &mut [Vec<f64>]) {
        for (g, m) in got.iter_mut().zip(self.exchange(out.to_vec())) {
            assert_eq!(g.len(), m.len(), "a message of the length expected");
            g.copy_from_slice(&m);
        }
    }

    fn sum_u64(&self, words: &mut [u64]) {
        let all = self.exchange(vec![words.to_vec(); self.size]);
        for (k, w) in words.iter_mut().enumerate() {
            *w = all.iter().fold(0u64, |a, v| a.wrapping_add(v[k]));
        }
    }
}

/// The link between the ranks as [`Transport::exchange_f64`] sees it (what the scaling
/// model of `verify bench` is given, docs/mpi.md).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Link {
    pub ranks: usize,
    /// Time per message of an exchange of one number with every other rank [s].
    pub latency_s: f64,
    /// Extra time per byte sent to another rank, in an exchange of 32 KiB with each [s].
    pub seconds_per_byte: f64,
}

/// Measures the [`Link`]: 2,000 exchanges of one number with every other rank, then 500 of
/// 32 KiB with every other rank (the size of a step's ghost message at about 10^3 particles
/// per brick; nothing to itself, as in a step), each after one untimed exchange. Every rank
/// calls it; each measures its own. Measured on the 2-core VM of 2026-12-05 (2 ranks): 0.6
/// us for one number, 0.6-1.0 GB/s from 4 to 32 KiB, 0.5 GB/s at 64 KiB and above: the
/// size matters, so the probe uses the size a step sends.
pub fn probe_link(t: &impl Transport) -> Link {
    let others = t.size().saturating_sub(1).max(1) as f64;
    let per_call = |len: usize, calls: usize| {
        let mut out = vec![vec![0.5; len]; t.size()];
        out[t.rank()] = Vec::new();
        let mut got = out.clone();
        let mut go = || t.exchange_f64(&out, &mut got);
        go();
        let t0 = std::time::Instant::now();
        for _ in 0..calls {
            go();
        }
        t0.elapsed().as_secs_f64() / calls as f64
    };
    let small = per_call(1, 2000);
    let big_len = 1 << 12;
    let big = per_call(big_len, 500);
    Link {
        ranks: t.size(),
        latency_s: small / others,
        seconds_per_byte: ((big - small) / (8.0 * big_len as f64 * others)).max(0.0),
    }
}

/// What a split of the state `s` (as its last rebuild left it) gives each brick: own
/// particles, ghosts, pairs with an own member (a pair across two bricks is computed by
/// both) and own particles with plate candidates. What the scaling model predicts from.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Census {
    pub own: Vec<usize>,
    pub ghosts: Vec<usize>,
    pub pairs: Vec<usize>,
    pub plate: Vec<usize>,
}

/// The [`Census`] of `s` split into `bricks`, by the rule the bricks are made by
/// ([`Brick::of`]: ownership and ghosts from `xhold`, the cut `2 r_max + skin`).
pub fn census(s: &ShearSim, bricks: &Bricks) -> Census {
    let cut = s.ghost_cut();
    let n = bricks.count();
    let owner: Vec<usize> = s.xhold.iter().map(|&p| bricks.owner(p)).collect();
    let mut c = Census {
        own: vec![0; n],
        ghosts: vec![0; n],
        pairs: vec![0; n],
        plate: vec![0; n],
    };
    for b in 0..n {
        let (ids, own) = bricks.members(b, &s.xhold, cut);
        c.own[b] = own.iter().filter(|&&o| o).count();
        c.ghosts[b] = ids.len() - c.own[b];
    }
    for p in &s.nl.pairs {
        let (oi, oj) = (owner[p.i as usize], owner[p.j as usize]);
        c.pairs[oi] += 1;
        if oj != oi {
            c.pairs[oj] += 1;
        }
    }
    for (q, &o) in owner.iter().enumerate() {
        if s.has_plate_candidates(q) {
            c.plate[o] += 1;
        }
    }
    c
}

/// The [`Census`] of `s` split as `ranks` ranks split it ([`split_for`]), for each count
/// whose bricks are wider than the ghost cut; the counts left out (narrower bricks).
pub fn censuses(s: &ShearSim, ranks: &[usize]) -> (Vec<(Bricks, Census)>, Vec<usize>) {
    let cut = s.ghost_cut();
    let (mut splits, mut thin) = (Vec::new(), Vec::new());
    for &r in ranks {
        let b = split_for(r, s);
        if b.narrowest() <= cut {
            thin.push(r);
        } else {
            let c = census(s, &b);
            splits.push((b, c));
        }
    }
    (splits, thin)
}

/// A particle moving to another brick: everything it carries from step to step.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
struct Migrant {
    id: u32,
    x: V3,
    v: V3,
    omega: V3,
    f: V3,
    torque: V3,
    rotation: V3,
    radius: f64,
    mass: f64,
    wall: WallSlots,
}

impl Migrant {
    /// Local particle `q` of `s` with its plate contact records `wall`.
    fn of(s: &ShearSim, q: usize, wall: WallSlots) -> Self {
        Migrant {
            id: s.ids[q],
            x: s.x[q],
            v: s.v[q],
            omega: s.omega[q],
            f: s.f[q],
            torque: s.torque[q],
            rotation: s.rotation[q],
            radius: s.radius[q],
            mass: s.mass[q],
            wall,
        }
    }
}

/// A value as the numbers a rebuild's messages carry (f64, as MPI moves them: every bit).
/// Ids, counts and indices (below 2^32) and flags (0 or 1) are f64 exactly; reading them
/// back checks that they are (a message is this code's own, so a wrong one is a bug, never
/// an input).
trait Numbers: Sized {
    fn put(&self, out: &mut Vec<f64>);
    fn take(r: &mut Reader) -> Self;
}

/// Reads a message's numbers in order.
struct Reader<'a> {
    at: usize,
    v: &'a [f64],
}

impl<'a> Reader<'a> {
    fn new(v: &'a [f64]) -> Self {
        Reader { at: 0, v }
    }
    fn done(&self) -> bool {
        self.at == self.v.len()
    }
    fn f(&mut self) -> f64 {
        let x = self.v[self.at];
        self.at += 1;
        x
    }
    fn v3(&mut self) -> V3 {
        [self.f(), self.f(), self.f()]
    }
    /// A whole number below 2^32 sent as f64.
    fn u32(&mut self) -> u32 {
        let x = self.f();
        assert!(
            x >= 0.0 && x <= u32::MAX as f64 && x.fract() == 0.0,
            "a count or id in a rebuild message, got {x}"
        );
        x as u32
    }
}

fn put3(out: &mut Vec<f64>, v: &V3) {
    out.extend_from_slice(v);
}

impl Numbers for ContactHistory {
    fn put(&self, out: &mut Vec<f64>) {
        put3(out, &self.shear);
        put3(out, &self.r_torque);
    }
    fn take(r: &mut Reader) -> Self {
        ContactHistory {
            shear: r.v3(),
            r_torque: r.v3(),
        }
    }
}

impl Numbers for TriContactRecord {
    fn put(&self, out: &mut Vec<f64>) {
        out.extend([
            self.mesh as f64,
            self.tri as f64,
            f64::from(u8::from(self.keep)),
        ]);
        self.hist.put(out);
        put3(out, &self.force);
        put3(out, &self.torque);
        out.push(f64::from(u8::from(self.face)));
    }
    fn take(r: &mut Reader) -> Self {
        let mesh = u8::try_from(r.u32()).expect("a mesh index below 256");
        let tri = r.u32();
        let keep = r.u32() != 0;
        TriContactRecord {
            mesh,
            tri,
            keep,
            hist: ContactHistory::take(r),
            force: r.v3(),
            torque: r.v3(),
            face: r.u32() != 0,
        }
    }
}

impl Numbers for Migrant {
    fn put(&self, out: &mut Vec<f64>) {
        out.push(self.id as f64);
        for v in [
            &self.x,
            &self.v,
            &self.omega,
            &self.f,
            &self.torque,
            &self.rotation,
        ] {
            put3(out, v);
        }
        out.extend([self.radius, self.mass, self.wall.rec.len() as f64]);
        for rec in &self.wall.rec {
            rec.put(out);
        }
    }
    fn take(r: &mut Reader) -> Self {
        let id = r.u32();
        let (x, v, omega, f, torque, rotation) = (r.v3(), r.v3(), r.v3(), r.v3(), r.v3(), r.v3());
        let (radius, mass) = (r.f(), r.f());
        let n = r.u32();
        let rec = (0..n).map(|_| TriContactRecord::take(r)).collect();
        Migrant {
            id,
            x,
            v,
            omega,
            f,
            torque,
            rotation,
            radius,
            mass,
            wall: WallSlots { rec },
        }
    }
}

/// A pair history by its global ids, as a migrant carries it.
impl Numbers for ((u32, u32), ContactHistory) {
    fn put(&self, out: &mut Vec<f64>) {
        out.extend([self.0 .0 as f64, self.0 .1 as f64]);
        self.1.put(out);
    }
    fn take(r: &mut Reader) -> Self {
        ((r.u32(), r.u32()), ContactHistory::take(r))
    }
}

/// Numbers per ghost at a rebuild: id, position, velocity, angular velocity, radius, mass.
const GHOST_NUMBERS: usize = 12;

/// Where a particle of a brick comes from at a rebuild: its own particles after the
/// migration (index in them), or the ghosts a rank sent (rank, index in its message).
#[derive(Clone, Copy, Debug)]
enum Held {
    Own(u32),
    Ghost(u32, u32),
}

/// An own particle as [`Brick::gather`] collects it.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
struct Whole {
    p: Migrant,
    xhold: V3,
    cand: Vec<(u8, u32, u8)>,
}

/// A listed pair as [`Brick::gather`] collects it: global ids, shift, history, and its state
/// at the last force evaluation (what the records count).
type GlobalPair = (Pair, ContactHistory, PairState);

/// One brick of a decomposed shear simulation.
pub struct Brick {
    sim: ShearSim,
    bricks: Bricks,
    me: usize,
    /// The ghost cutoff: `2 r_max + skin` over every particle of the run.
    cut: f64,
    /// The bricks near this one ([`Bricks::near`]): the only ones it talks to at a rebuild.
    near: Vec<usize>,
    /// Per rank, the local indices of own particles it holds as ghosts, in increasing id.
    send: Vec<Vec<u32>>,
    /// Per rank, the local indices of the ghosts it owns, in the order it sends them.
    recv: Vec<Vec<u32>>,
    /// Own particles with plate candidates (local indices, fixed from one rebuild to the
    /// next): the terms of this brick's plate force sum.
    plates: Vec<u32>,
    /// `forward`'s messages, per rank (reused from step to step).
    out: Vec<Vec<f64>>,
    got: Vec<Vec<f64>>,
    /// Particles that arrived from other bricks at rebuilds (a statistic for tests).
    pub arrived: u64,
    /// A rebuild's own particles and the order of all it holds: buffers kept from one
    /// rebuild to the next (cleared, never freed), so that a rebuild does not fault in tens
    /// of megabytes of fresh pages at 250,000 particles.
    mine: Vec<Migrant>,
    order: Vec<(u32, Held)>,
    /// This brick's time in the work that grows with its particles (drift, forces, the
    /// step's finish) since the last rebuild [ns], which the next rebuild balances the
    /// bricks by ([`Bricks::balanced`]).
    busy_ns: u64,
    /// What the busy time counts for in the balance (1: as measured; tests make one brick
    /// count more, as if something else slowed it).
    pub cost_factor: f64,
    /// The last force evaluation's plate sum over this brick's own particles (or its
    /// failure), added over the bricks by the next step's all-reduce or a settle.
    pending: Option<PendingPlates>,
}

/// A brick's share of a step's plate forces, not yet added over the bricks.
struct PendingPlates {
    limbs: [u64; LIMB_LEN],
    /// The evaluation's error on this brick, said to every brick when they add the sums.
    failed: Option<Error>,
    /// The step of the evaluation.
    step: u64,
}

impl Brick {
    /// Brick `me` of `bricks` from the whole state `global` as it is (its own particles and
    /// ghosts as the last rebuild chose them, from the positions then, `xhold`; no rebuild).
    pub fn of(global: &ShearSim, bricks: &Bricks, me: usize) -> Brick {
        let cut = global.ghost_cut();
        let held = global.xhold.clone();
        let (ids, own) = bricks.members(me, &held, cut);
        let ghost: Vec<bool> = own.iter().map(|o| !o).collect();
        let pick = |v: &[V3]| ids.iter().map(|&q| v[q]).collect::<Vec<V3>>();
        let nl = local_pairs(global, &ids, &own);
        let (wall_start, wall_cand) = local_plate_candidates(global, &ids, &own);
        let n = ids.len();
        let mut sim = ShearSim {
            x: pick(&global.x),
            v: pick(&global.v),
            omega: pick(&global.omega),
            f: pick(&global.f),
            torque: pick(&global.torque),
            radius: ids.iter().map(|&q| global.radius[q]).collect(),
            mass: ids.iter().map(|&q| global.mass[q]).collect(),
            kick: ids.iter().map(|&q| global.kick[q]).collect(),
            rotation: pick(&global.rotation),
            xhold: pick(&global.xhold),
            wall: ids
                .iter()
                .zip(&own)
                .map(|(&q, &o)| {
                    if o {
                        global.wall[q].clone()
                    } else {
                        WallSlots::default()
                    }
                })
                .collect(),
            nl,
            wall_start,
            wall_cand,
            ids: ids.iter().map(|&q| q as u32).collect(),
            ghost,
            ..ShearSim::without_particles(global)
        };
        sim.size_particle_buffers(n);
        sim.size_pair_buffers();
        let (send, recv) = ghost_lists(bricks, me, &ids, &own, &held, cut);
        let near = bricks.near(me, cut);
        let plates = own_with_candidates(&sim);
        let mut b = Brick {
            sim,
            bricks: bricks.clone(),
            me,
            cut,
            near,
            send,
            recv,
            plates,
            out: Vec::new(),
            got: Vec::new(),
            arrived: 0,
            mine: Vec::new(),
            order: Vec::new(),
            busy_ns: 0,
            cost_factor: 1.0,
            pending: None,
        };
        b.size_messages();
        b
    }

    /// `forward`'s buffers for the send and receive lists of the last rebuild: 9 numbers
    /// per ghost (position, velocity, angular velocity).
    fn size_messages(&mut self) {
        let sized = |lists: &[Vec<u32>]| lists.iter().map(|l| vec![0.0; 9 * l.len()]).collect();
        self.out = sized(&self.send);
        self.got = sized(&self.recv);
    }

    /// A run's setup ([`ShearSim::setup`]) in every brick: the stage speed, a rebuild, and
    /// forces without history update.
    pub fn setup(&mut self, t: &impl Transport, bottom_speed: f64) -> Result<()> {
        self.settle(t)?;
        self.sim.setup_plates(bottom_speed);
        self.rebuild(t)?;
        let local = self.sim.forces_and_kick(false, false);
        self.plate_forces(t, local).map(|_| ())
    }

    /// One time step ([`ShearSim::step`]) in every brick, its plate sum left for the next
    /// step's all-reduce (module notes; [`Brick::settle`] adds it at once).
    pub fn step(&mut self, t: &impl Transport) -> Result<()> {
        let start = Instant::now();
        // a brick whose last evaluation failed drifts too (its error is said below, before
        // anything reads the drifted state), so every brick is at the same step
        let moved = self.sim.drift();
        self.count_busy(start);
        let moved = self.add_plates(t, moved)?;
        self.forward(t);
        self.sim.lap(|p| &mut p.comm);
        self.sim.move_plates();
        self.sim.lap(|p| &mut p.plates);
        if self.sim.decide_rebuild(moved) {
            self.rebuild(t)?;
        } else {
            self.sim.mesh_rebuild_pending = self.sim.plates_moved();
        }
        self.sim.lap(|p| &mut p.neighbor);
        let start = Instant::now();
        let local = self.sim.forces_of_step();
        self.count_busy(start);
        let start = Instant::now();
        let s = &self.sim;
        let mine = super::exact::sum(self.plates.iter().map(|&q| s.wall_force[q as usize]));
        self.sim.lap(|p| &mut p.sum_walls);
        let failed = match local {
            Ok(kicked) => {
                self.sim.finish_particles(kicked);
                None
            }
            Err(e) => Some(e),
        };
        self.pending = Some(PendingPlates {
            limbs: mine.limbs(),
            failed,
            step: self.sim.step,
        });
        self.count_busy(start);
        Ok(())
    }

    /// A collective call that reads the state between steps, made with a plate sum still
    /// waiting, would read a servo one step behind (and could not say an evaluation's
    /// failure): a fault of the calling code, not of the input.
    fn assert_settled(&self) {
        assert!(
            self.pending.is_none(),
            "a brick's state read before Brick::settle (Stepper::settle)"
        );
    }

    /// Adds the last step's plate sum over the bricks now (an all-reduce, if one waits):
    /// the plates' forces and the servo as one process's. Every brick calls it at the same
    /// point; every call of a run's loop that reads the state between steps does first.
    pub fn settle(&mut self, t: &impl Transport) -> Result<()> {
        if self.pending.is_some() {
            self.add_plates(t, false)?;
        }
        Ok(())
    }

    /// The all-reduce of a step (or of a settle): the waiting plate sum and whether its
    /// evaluation failed on some brick, with `moved` (this brick's skin/2 test); keeps the
    /// plates' forces and makes the servo's update from them ([`ShearSim::finish_servo`]).
    /// Returns whether any brick moved beyond skin/2; an evaluation that failed anywhere
    /// is an error everywhere, with the message of the brick that failed.
    fn add_plates(&mut self, t: &impl Transport, moved: bool) -> Result<bool> {
        let pending = self.pending.take();
        let mut words = [0u64; LIMB_LEN + 2];
        if let Some(p) = &pending {
            words[..LIMB_LEN].copy_from_slice(&p.limbs);
            words[LIMB_LEN] = u64::from(p.failed.is_some());
        }
        words[LIMB_LEN + 1] = u64::from(moved);
        t.sum_u64(&mut words);
        self.sim.lap(|p| &mut p.comm);
        if let Some(p) = pending {
            if words[LIMB_LEN] != 0 {
                // rare: say why, every brick (at the step of the evaluation)
                let said = all_gather(t, p.failed.as_ref().map(|e| e.to_string()));
                let local = p.failed.map_or(Ok(()), Err);
                agree(local, said, p.step)?;
            }
            let mut limbs = [0u64; LIMB_LEN];
            limbs.copy_from_slice(&words[..LIMB_LEN]);
            self.sim.keep_plate_forces(PlateSum::from_limbs(&limbs))?;
            self.sim.finish_servo();
        }
        Ok(words[LIMB_LEN + 1] != 0)
    }

    fn count_busy(&mut self, since: Instant) {
        let ns = since.elapsed().as_nanos() as f64 * self.cost_factor;
        self.busy_ns = self.busy_ns.saturating_add(ns as u64);
    }

    /// The ghosts' positions and velocities from their owners (LAMMPS `forward_comm`), after
    /// the drift: what the pair pass reads of them (messages between neighbouring bricks
    /// only).
    fn forward(&mut self, t: &impl Transport) {
        let s = &self.sim;
        for (buf, list) in self.out.iter_mut().zip(&self.send) {
            for (rec, &l) in buf.chunks_exact_mut(9).zip(list) {
                let l = l as usize;
                rec[..3].copy_from_slice(&s.x[l]);
                rec[3..6].copy_from_slice(&s.v[l]);
                rec[6..].copy_from_slice(&s.omega[l]);
            }
        }
        t.exchange_f64(&self.out, &mut self.got);
        let s = &mut self.sim;
        for (list, buf) in self.recv.iter().zip(&self.got) {
            for (&l, rec) in list.iter().zip(buf.chunks_exact(9)) {
                let l = l as usize;
                s.x[l] = [rec[0], rec[1], rec[2]];
                s.v[l] = [rec[3], rec[4], rec[5]];
                s.omega[l] = [rec[6], rec[7], rec[8]];
                if let Some(p) = s.packed.get_mut(l) {
                    p.moved(s.x[l], s.v[l], s.omega[l]);
                }
            }
        }
    }

    /// The plate forces of this evaluation: this brick's exact sum over its own particles
    /// with plate candidates, added over the bricks by one all-reduce of its limbs (any
    /// order gives one process's bits: [`super::exact`]), kept as the plates' forces;
    /// `local` is this brick's force evaluation (true when it kicked), its failure counted
    /// in the same all-reduce: an error anywhere is an error everywhere.
    fn plate_forces(&mut self, t: &impl Transport, local: Result<bool>) -> Result<bool> {
        let s = &self.sim;
        let mine = super::exact::sum(self.plates.iter().map(|&q| s.wall_force[q as usize]));
        let mut words = [0u64; LIMB_LEN + 1];
        words[..LIMB_LEN].copy_from_slice(&mine.limbs());
        words[LIMB_LEN] = u64::from(local.is_err());
        t.sum_u64(&mut words);
        self.sim.lap(|p| &mut p.comm);
        if words[LIMB_LEN] != 0 {
            // rare: say why, every brick
            let said = all_gather(t, local.as_ref().err().map(|e| e.to_string()));
            return agree(local, said, self.sim.step);
        }
        let mut limbs = [0u64; LIMB_LEN];
        limbs.copy_from_slice(&words[..LIMB_LEN]);
        self.sim.keep_plate_forces(PlateSum::from_limbs(&limbs))?;
        local
    }

    /// A neighbour rebuild of every brick ([`ShearSim::rebuild`]): the divergence check,
    /// the wrap, migration, ghosts, the pair list, the plates' part and the plate candidates.
    fn rebuild(&mut self, t: &impl Transport) -> Result<()> {
        let team = self.sim.team();
        let checked = self.sim.check_diverged(&team);
        // one word summed over the bricks, the messages gathered only when one failed; in
        // the same all-reduce every brick's busy time (its own word, the others zero)
        let size = self.bricks.count();
        let mut words = vec![0u64; 1 + size];
        words[0] = u64::from(checked.is_err());
        words[1 + self.me] = std::mem::take(&mut self.busy_ns);
        t.sum_u64(&mut words);
        if words[0] != 0 {
            let said = all_gather(t, checked.as_ref().err().map(|e| e.to_string()));
            agree(checked, said, self.sim.step)?;
        }
        let cost: Vec<f64> = words[1..].iter().map(|&ns| ns as f64).collect();
        let moved = self.bricks.balanced(&cost);
        if moved != self.bricks {
            self.near = moved.near(self.me, self.cut);
            self.bricks = moved;
        }
        self.sim.wrap();
        let over = Members {
            ids: &self.sim.ids,
            ghost: &self.sim.ghost,
        };
        let carried = self.sim.nl.take_carried(over);
        let (mine, carried) = self.migrate(t, carried)?;
        self.border(t, mine);
        let s = &mut self.sim;
        let over = Members {
            ids: &s.ids,
            ghost: &s.ghost,
        };
        s.nl.build_over(&team, &s.x, &s.radius, s.skin, s.box_, over, carried);
        s.after_list(&team);
        self.plates = own_with_candidates(s);
        self.size_messages();
        Ok(())
    }

    /// Sends every own particle whose owner changed to its new brick with the histories of
    /// its pairs (LAMMPS `exchange`, fix contact/history's `pack_exchange`); returns this
    /// brick's own particles after it, in increasing id (in the buffer kept from the last
    /// rebuild: no fresh pages at every rebuild), and the histories to carry into its new
    /// list (its own and those that came with its new particles).
    fn migrate(
        &mut self,
        t: &impl Transport,
        mut carried: Carried,
    ) -> Result<(Vec<Migrant>, Carried)> {
        let s = &mut self.sim;
        let size = self.bricks.count();
        // per brick: the number of particles moving there, their numbers, then their pairs'
        let mut people: Vec<Vec<f64>> = vec![Vec::new(); size];
        for &r in &self.near {
            people[r].push(0.0);
        }
        let mut mine = std::mem::take(&mut self.mine);
        mine.clear();
        let mut gone = std::collections::HashMap::new();
        let mut far = None;
        for q in 0..s.x.len() {
            if s.ghost[q] {
                continue;
            }
            let wall = std::mem::take(&mut s.wall[q]);
            let m = Migrant::of(s, q, wall);
            let to = self.bricks.owner(m.x);
            if to == self.me {
                mine.push(m);
            } else {
                if !self.near.contains(&to) {
                    // stops every brick below, before any message is sent
                    far.get_or_insert((m.id, to));
                    continue;
                }
                gone.insert(m.id, to);
                people[to][0] += 1.0;
                m.put(&mut people[to]);
            }
        }
        Self::none_beyond_the_neighbours(t, far, self.me, s.step)?;
        for (ij, h) in carried.ij.iter().zip(&carried.hist) {
            let a = gone.get(&ij.0);
            let b = gone.get(&ij.1).filter(|b| Some(*b) != a);
            for &to in a.into_iter().chain(b) {
                (*ij, *h).put(&mut people[to]);
            }
        }
        let got = self.swap_near(t, people);
        let staying = mine.len();
        for msg in got.iter().filter(|m| !m.is_empty()) {
            let mut r = Reader::new(msg);
            let n = r.u32();
            self.arrived += u64::from(n);
            mine.extend((0..n).map(|_| Migrant::take(&mut r)));
            let mut hist = Vec::new();
            while !r.done() {
                hist.push(<((u32, u32), ContactHistory)>::take(&mut r));
            }
            carried.merge(hist);
        }
        // the staying ones are in increasing id already (local order is id order)
        if mine.len() > staying {
            mine.sort_by_key(|m| m.id);
        }
        Ok((mine, carried))
    }

    /// Every brick stops when one of them has a migrant `far` (its id, its new brick) beyond
    /// the neighbouring bricks: it moved more than the ghost cut since the last rebuild,
    /// which the skin/2 rule forbids unless it flew off (one summed word; the message
    /// gathered only then).
    fn none_beyond_the_neighbours(
        t: &impl Transport,
        far: Option<(u32, usize)>,
        me: usize,
        step: u64,
    ) -> Result<()> {
        let mut failed = [u64::from(far.is_some())];
        t.sum_u64(&mut failed);
        if failed[0] == 0 {
            return Ok(());
        }
        let local = match far {
            Some((id, to)) => Err(Error::Solver {
                step,
                msg: format!(
                    "particle {} moved from brick {me} to brick {to}, further than the ghost \
                     cut between two neighbour rebuilds (the run is unstable)",
                    id + 1
                ),
            }),
            None => Ok(()),
        };
        let said = all_gather(t, local.as_ref().err().map(|e| e.to_string()));
        agree(local, said, step)
    }

    /// Sends `out[r]` to each brick r near this one (`out` is empty for every other brick)
    /// and returns what each sent this one (empty from the others): the lengths first, then
    /// the numbers, both by [`Transport::exchange_f64`] between neighbouring bricks only.
    fn swap_near(&self, t: &impl Transport, out: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
        let size = self.bricks.count();
        let (mut lengths, mut got) = (vec![Vec::new(); size], vec![Vec::new(); size]);
        for &r in &self.near {
            lengths[r] = vec![out[r].len() as f64];
            got[r] = vec![0.0];
        }
        t.exchange_f64(&lengths, &mut got);
        let mut theirs = vec![Vec::new(); size];
        for &r in &self.near {
            theirs[r] = vec![0.0; Reader::new(&got[r]).u32() as usize];
        }
        debug_assert!(
            (0..size).all(|r| self.near.contains(&r) || out[r].is_empty()),
            "messages to neighbouring bricks only"
        );
        t.exchange_f64(&out, &mut theirs);
        theirs
    }

    /// Sends each own particle to every other brick it is near as a ghost (LAMMPS
    /// `borders`), and makes this brick's particles its own `mine` and the ghosts it
    /// received, in increasing id, with the send and receive lists of `forward`.
    fn border(&mut self, t: &impl Transport, mut mine: Vec<Migrant>) {
        let size = self.bricks.count();
        let (out, sent) = self.ghost_messages(&mine);
        let got = self.swap_near(t, out);
        let mut order = std::mem::take(&mut self.order);
        held_in_id_order(&mut order, &mine, &got);
        self.recv = vec![Vec::new(); size];
        let s = &mut self.sim;
        s.ids.clear();
        s.ids.extend(order.iter().map(|e| e.0));
        s.ghost.clear();
        s.ghost
            .extend(order.iter().map(|e| matches!(e.1, Held::Ghost(..))));
        for v in [&mut s.x, &mut s.v, &mut s.omega, &mut s.f, &mut s.torque] {
            v.clear();
        }
        s.rotation.clear();
        s.radius.clear();
        s.mass.clear();
        s.wall.clear();
        for (l, &(_, h)) in order.iter().enumerate() {
            match h {
                Held::Own(k) => {
                    let m = &mut mine[k as usize];
                    s.x.push(m.x);
                    s.v.push(m.v);
                    s.omega.push(m.omega);
                    s.f.push(m.f);
                    s.torque.push(m.torque);
                    s.rotation.push(m.rotation);
                    s.radius.push(m.radius);
                    s.mass.push(m.mass);
                    s.wall.push(std::mem::take(&mut m.wall));
                }
                Held::Ghost(from, k) => {
                    self.recv[from as usize].push(l as u32);
                    let at = GHOST_NUMBERS * k as usize;
                    let mut g = Reader::new(&got[from as usize][at + 1..at + GHOST_NUMBERS]);
                    let z = [0.0; 3];
                    s.x.push(g.v3());
                    s.v.push(g.v3());
                    s.omega.push(g.v3());
                    s.f.push(z);
                    s.torque.push(z);
                    s.rotation.push(z);
                    s.radius.push(g.f());
                    s.mass.push(g.f());
                    s.wall.push(WallSlots::default());
                }
            }
        }
        let n = order.len();
        let nve = s.nve;
        s.kick.clear();
        s.kick
            .extend(s.radius.iter().zip(&s.mass).map(|(r, m)| nve.kick(*r, *m)));
        s.size_particle_buffers(n);
        let ids = &s.ids;
        self.send = sent
            .into_iter()
            .map(|l| {
                l.into_iter()
                    .map(|g| ids.binary_search(&g).expect("an own particle") as u32)
                    .collect()
            })
            .collect();
        mine.clear();
        self.mine = mine;
        self.order = order;
    }

    /// The ghost records of `mine` (this brick's own particles after the migration) for
    /// each neighbouring brick that holds them ([`GHOST_NUMBERS`] numbers each), and their
    /// ids per brick, in increasing id.
    fn ghost_messages(&self, mine: &[Migrant]) -> (Vec<Vec<f64>>, Vec<Vec<u32>>) {
        let size = self.bricks.count();
        let mut out: Vec<Vec<f64>> = vec![Vec::new(); size];
        let mut sent: Vec<Vec<u32>> = vec![Vec::new(); size];
        for m in mine {
            for &b in &self.near {
                if self.bricks.holds(b, m.x, self.cut) {
                    out[b].push(m.id as f64);
                    for v in [&m.x, &m.v, &m.omega] {
                        put3(&mut out[b], v);
                    }
                    out[b].extend([m.radius, m.mass]);
                    sent[b].push(m.id);
                }
            }
        }
        (out, sent)
    }

    /// The whole state, on rank 0 (None on the others: no rank but the writing one holds
    /// it) ([`Brick::of`]'s inverse: one process's state, bit for bit, when every brick
    /// stepped as one process does): what checkpoints, outputs and the tests read. What is
    /// not per particle (plates, servo, step, rebuild state) every brick holds alike. Each
    /// pair is sent by the brick that owns its lower id.
    pub fn gather(&self, t: &impl Transport) -> Option<ShearSim> {
        self.assert_settled();
        let s = &self.sim;
        let own: Vec<usize> = (0..s.x.len()).filter(|&q| !s.ghost[q]).collect();
        let wholes: Vec<Whole> = own
            .iter()
            .map(|&q| Whole {
                p: Migrant::of(s, q, s.wall[q].clone()),
                xhold: s.xhold[q],
                cand: s.wall_cand[s.wall_start[q] as usize..s.wall_start[q + 1] as usize].to_vec(),
            })
            .collect();
        let pairs: Vec<GlobalPair> =
            s.nl.pairs
                .iter()
                .zip(&s.nl.hist)
                .zip(&s.pair_state)
                .filter(|((p, _), _)| {
                    // the brick that owns the pair's lower id sends it
                    let lower = if s.ids[p.i as usize] < s.ids[p.j as usize] {
                        p.i
                    } else {
                        p.j
                    };
                    !s.ghost[lower as usize]
                })
                .map(|((p, h), st)| {
                    let g = Pair {
                        i: s.ids[p.i as usize],
                        j: s.ids[p.j as usize],
                        shift: p.shift,
                    };
                    (g, *h, *st)
                })
                .collect();
        let mut out = vec![(Vec::new(), Vec::new()); t.size()];
        out[0] = (wholes, pairs);
        let all: Vec<(Vec<Whole>, Vec<GlobalPair>)> = t.exchange(out);
        if t.rank() != 0 {
            return None;
        }
        let mut wholes: Vec<Whole> = Vec::new();
        let mut pairs: Vec<GlobalPair> = Vec::new();
        for (w, p) in all {
            wholes.extend(w);
            pairs.extend(p);
        }
        wholes.sort_by_key(|w| w.p.id);
        assert!(
            wholes.iter().enumerate().all(|(k, w)| w.p.id as usize == k),
            "every particle owned once"
        );
        pairs.sort_by_key(|(p, ..)| Carried::key((p.i, p.j)));
        assert!(
            pairs
                .windows(2)
                .all(|w| Carried::key((w[0].0.i, w[0].0.j)) < Carried::key((w[1].0.i, w[1].0.j))),
            "every pair sent once"
        );
        let n = wholes.len();
        let mut nl = NeighborList {
            builds: s.nl.builds,
            ..Default::default()
        };
        let mut pair_state = Vec::with_capacity(pairs.len());
        for (p, h, st) in pairs {
            nl.pairs.push(p);
            nl.hist.push(h);
            pair_state.push(st);
        }
        nl.index(n);
        let mut wall_start = vec![0u32];
        let mut wall_cand = Vec::new();
        for w in &wholes {
            wall_cand.extend_from_slice(&w.cand);
            wall_start.push(wall_cand.len() as u32);
        }
        let col = |f: fn(&Whole) -> V3| wholes.iter().map(f).collect::<Vec<V3>>();
        let mut g = ShearSim {
            x: col(|w| w.p.x),
            v: col(|w| w.p.v),
            omega: col(|w| w.p.omega),
            f: col(|w| w.p.f),
            torque: col(|w| w.p.torque),
            rotation: col(|w| w.p.rotation),
            xhold: col(|w| w.xhold),
            radius: wholes.iter().map(|w| w.p.radius).collect(),
            mass: wholes.iter().map(|w| w.p.mass).collect(),
            kick: wholes
                .iter()
                .map(|w| s.nve.kick(w.p.radius, w.p.mass))
                .collect(),
            wall: wholes.iter().map(|w| w.p.wall.clone()).collect(),
            nl,
            wall_start,
            wall_cand,
            ..ShearSim::without_particles(s)
        };
        g.size_particle_buffers(n);
        g.pair_state = pair_state;
        g.size_pair_buffers();
        Some(g)
    }
}

/// How a run steps its state: one process ([`ShearSim`]) or one brick of a decomposition
/// ([`BrickRun`]), so that a run's loop (outputs, samples, snapshots, checkpoints) is written
/// once. Every brick of a decomposition calls the same methods at the same steps.
pub trait Stepper {
    /// A run's setup ([`ShearSim::setup`]).
    fn setup(&mut self, bottom_speed: f64) -> Result<()>;
    /// One time step. A brick may leave the step's plate sum to the next step's
    /// all-reduce ([`Brick::step`]): [`Stepper::settle`] before reading the state.
    fn step(&mut self) -> Result<()>;
    /// Completes the last step (collective for bricks: [`Brick::settle`]; nothing to do in
    /// one process). Every call below that reads the state between steps needs it first.
    fn settle(&mut self) -> Result<()> {
        Ok(())
    }
    /// The steps made so far.
    fn steps(&self) -> u64;
    /// The whole state (collective for bricks: gathered on rank 0; None on the others).
    fn whole(&mut self) -> Option<std::borrow::Cow<'_, ShearSim>>;
    /// Whether every brick's `ok` is true (collective for bricks): what stops all the bricks
    /// of a run when one of them fails outside a step (writing an output).
    fn all_ok(&mut self, ok: bool) -> bool;
    /// The state this stepper steps (a brick's own particles and ghosts).
    fn local(&mut self) -> &mut ShearSim;
    /// What the transport carried so far (None: one process, or not counted).
    fn traffic(&self) -> Option<Traffic>;
    /// Every brick's phase times, by rank (collective for bricks): where the waits of a
    /// decomposed run come from (a brick busier than the others).
    fn phases_by_rank(&mut self) -> Vec<Option<super::PhaseTimes>> {
        vec![self.local().phase_times()]
    }
    /// Every brick's own particles, by rank (collective for bricks): where the balance
    /// ([`Bricks::balanced`]) put the cuts.
    fn own_by_rank(&mut self) -> Vec<u64> {
        vec![self.local().own_particles() as u64]
    }
}

impl Stepper for ShearSim {
    fn setup(&mut self, bottom_speed: f64) -> Result<()> {
        ShearSim::setup(self, bottom_speed)
    }

    fn step(&mut self) -> Result<()> {
        ShearSim::step(self)
    }

    fn steps(&self) -> u64 {
        self.step
    }

    fn whole(&mut self) -> Option<std::borrow::Cow<'_, ShearSim>> {
        Some(std::borrow::Cow::Borrowed(self))
    }

    fn all_ok(&mut self, ok: bool) -> bool {
        ok
    }

    fn local(&mut self) -> &mut ShearSim {
        self
    }

    fn traffic(&self) -> Option<Traffic> {
        None
    }
}

/// One brick stepping with its transport.
pub struct BrickRun<'t, T: Transport> {
    pub brick: Brick,
    pub transport: &'t T,
}

impl<T: Transport> Stepper for BrickRun<'_, T> {
    fn setup(&mut self, bottom_speed: f64) -> Result<()> {
        self.brick.setup(self.transport, bottom_speed)
    }

    fn step(&mut self) -> Result<()> {
        self.brick.step(self.transport)
    }

    fn settle(&mut self) -> Result<()> {
        self.brick.settle(self.transport)
    }

    fn steps(&self) -> u64 {
        self.brick.sim.step
    }

    fn whole(&mut self) -> Option<std::borrow::Cow<'_, ShearSim>> {
        self.brick
            .gather(self.transport)
            .map(std::borrow::Cow::Owned)
    }

    fn all_ok(&mut self, ok: bool) -> bool {
        self.brick.assert_settled();
        !any(self.transport, !ok)
    }

    fn local(&mut self) -> &mut ShearSim {
        &mut self.brick.sim
    }

    fn traffic(&self) -> Option<Traffic> {
        self.transport.traffic()
    }

    fn phases_by_rank(&mut self) -> Vec<Option<super::PhaseTimes>> {
        self.brick.assert_settled();
        all_gather(self.transport, self.brick.sim.phase_times())
    }

    fn own_by_rank(&mut self) -> Vec<u64> {
        self.brick.assert_settled();
        all_gather(self.transport, self.brick.sim.own_particles() as u64)
    }
}

/// The split of `s`'s box into `ranks` bricks ([`split_of`]: the plates' bases bound the gap,
/// the ghost cut `2 r_max + skin`).
pub fn split_for(ranks: usize, s: &ShearSim) -> Bricks {
    split_of(ranks, s.box_.lx, plate_span(s), s.box_.lz, s.ghost_cut())
}

/// `n` equal bricks (along x, across the gap, along z) of `s`'s box, the gap's slabs over
/// the plates' bases: the split every rank makes of a run rank 0 chose `n` for.
pub fn bricks_of(n: [usize; 3], s: &ShearSim) -> Bricks {
    Bricks::equal(n, s.box_.lx, plate_span(s), s.box_.lz)
}

/// The span across the gap the bricks of `s` are made over: the plates' bases.
fn plate_span(s: &ShearSim) -> [f64; 2] {
    [s.bottom.base_y, s.top.base_y]
}

/// A chosen split `n` (the command line's `--bricks`, as LAMMPS' `processors`) of `s`'s box,
/// refused when a slab would not be wider than the ghost cut (it would hold ghosts from
/// beyond its neighbours), the error naming how many slabs each axis takes.
pub fn split_as(n: [usize; 3], s: &ShearSim) -> Result<Bricks> {
    let b = bricks_of(n, s);
    let cut = s.ghost_cut();
    if b.narrowest() > cut {
        return Ok(b);
    }
    let most = |l: f64| ((l / cut).ceil() as usize).saturating_sub(1).max(1);
    Err(Error::invalid(
        "--bricks",
        format!("{}x{}x{}", n[0], n[1], n[2]),
        format!(
            "slabs wider than the ghost cut ({:.3} mm): at most {} x {} x {} for this box \
             ({:.3} x {:.3} x {:.3} mm between the plates)",
            cut * 1e3,
            most(s.box_.lx),
            most(s.top.base_y - s.bottom.base_y),
            most(s.box_.lz),
            s.box_.lx * 1e3,
            (s.top.base_y - s.bottom.base_y) * 1e3,
            s.box_.lz * 1e3
        ),
    ))
}

/// The split of a box `lx` x `lz`, the plates' bases at `ys`, into `ranks` = nx ny nz bricks
/// with the least boundary between them: the area of the cuts, which the ghosts' count
/// follows (nx planes of ly lz along the periodic x when nx > 1, none when 1; ny - 1 planes of
/// lx lz across the gap; nz of lx ly along z when nz > 1), as LAMMPS' processor grid is the
/// factorisation with the least surface (`ProcMap::onelevel_grid`). Among the splits whose
/// slabs are all wider than `cut` when there is one (a thinner slab would hold ghosts from
/// beyond its neighbours); the first of equal ones in (nx, ny) order.
pub fn split_of(ranks: usize, lx: f64, ys: [f64; 2], lz: f64, cut: f64) -> Bricks {
    let ly = ys[1] - ys[0];
    let splits: Vec<[usize; 3]> = (1..=ranks)
        .filter(|nx| ranks.is_multiple_of(*nx))
        .flat_map(|nx| {
            let rest = ranks / nx;
            (1..=rest)
                .filter(move |ny| rest.is_multiple_of(*ny))
                .map(move |ny| [nx, ny, rest / ny])
        })
        .collect();
    let planes = |n: usize| if n > 1 { n as f64 } else { 0.0 };
    let area = |&[nx, ny, nz]: &[usize; 3]| {
        planes(nx) * ly * lz + (ny - 1) as f64 * lx * lz + planes(nz) * lx * ly
    };
    let wide = |[nx, ny, nz]: &&[usize; 3]| {
        lx / *nx as f64 > cut && ly / *ny as f64 > cut && lz / *nz as f64 > cut
    };
    let least = |it: &mut dyn Iterator<Item = &[usize; 3]>| {
        it.min_by(|a, b| area(a).total_cmp(&area(b))).copied()
    };
    let n = least(&mut splits.iter().filter(wide))
        .or_else(|| least(&mut splits.iter()))
        .unwrap_or([1, 1, 1]);
    Bricks::equal(n, lx, ys, lz)
}
/// Brick [`Brick::of`]'s pairs: those of `global`'s list with an own member, in list order
/// (increasing key: local order is id order), their histories with them; `ids` the brick's
/// particles (global indices, increasing), `own` which of them it owns.
fn local_pairs(global: &ShearSim, ids: &[usize], own: &[bool]) -> NeighborList {
    let local_of = |g: usize| ids.binary_search(&g).ok();
    let mut nl = NeighborList {
        builds: global.nl.builds,
        ..Default::default()
    };
    for (p, h) in global.nl.pairs.iter().zip(&global.nl.hist) {
        let (i, j) = (local_of(p.i as usize), local_of(p.j as usize));
        if let (Some(i), Some(j)) = (i, j) {
            if own[i] || own[j] {
                nl.pairs.push(Pair {
                    i: i as u32,
                    j: j as u32,
                    shift: p.shift,
                });
                nl.hist.push(*h);
            }
        }
    }
    nl.index(ids.len());
    nl
}

/// Brick [`Brick::of`]'s plate candidates (start offsets and records): an own particle's
/// from `global`, none for a ghost.
fn local_plate_candidates(
    global: &ShearSim,
    ids: &[usize],
    own: &[bool],
) -> (Vec<u32>, Vec<(u8, u32, u8)>) {
    let mut wall_start = vec![0u32];
    let mut wall_cand = Vec::new();
    for (&q, &o) in ids.iter().zip(own) {
        if o {
            let s = &global.wall_start;
            wall_cand.extend_from_slice(&global.wall_cand[s[q] as usize..s[q + 1] as usize]);
        }
        wall_start.push(wall_cand.len() as u32);
    }
    (wall_start, wall_cand)
}

/// Who sends brick `me` which ghosts and whom it sends its own, by the positions of the
/// last rebuild `held` (the same rule on every brick): per rank, the local indices of own
/// particles it holds as ghosts, and of the ghosts it owns.
fn ghost_lists(
    bricks: &Bricks,
    me: usize,
    ids: &[usize],
    own: &[bool],
    held: &[V3],
    cut: f64,
) -> (Vec<Vec<u32>>, Vec<Vec<u32>>) {
    let mut send = vec![Vec::new(); bricks.count()];
    let mut recv = vec![Vec::new(); bricks.count()];
    for (l, &q) in ids.iter().enumerate() {
        if own[l] {
            for (s, list) in send.iter_mut().enumerate() {
                if s != me && bricks.holds(s, held[q], cut) {
                    list.push(l as u32);
                }
            }
        } else {
            recv[bricks.owner(held[q])].push(l as u32);
        }
    }
    (send, recv)
}

/// Every particle a brick holds once, in increasing id, with where it comes from: its own
/// particles `mine` and the ghost records `got[r]` from each brick r (into `order`, cleared).
fn held_in_id_order(order: &mut Vec<(u32, Held)>, mine: &[Migrant], got: &[Vec<f64>]) {
    order.clear();
    order.extend((0..mine.len()).map(|k| (mine[k].id, Held::Own(k as u32))));
    for (r, l) in got.iter().enumerate() {
        assert_eq!(
            l.len() % GHOST_NUMBERS,
            0,
            "whole ghost records from brick {r}"
        );
        order.extend(l.chunks_exact(GHOST_NUMBERS).enumerate().map(|(k, g)| {
            let id = Reader::new(&g[..1]).u32();
            (id, Held::Ghost(r as u32, k as u32))
        }));
    }
    order.sort_by_key(|e| e.0);
}

/// A brick's own particles with plate candidates (local indices, increasing id): its share
/// of the plate forces until the next rebuild.
fn own_with_candidates(s: &ShearSim) -> Vec<u32> {
    (0..s.x.len())
        .filter(|&l| !s.ghost[l] && s.has_plate_candidates(l))
        .map(|l| l as u32)
        .collect()
}

/// Every brick's word on one collective step: Ok when no brick failed; else this brick's own
/// error, or the first other brick's message.
fn agree<T>(
    local: Result<T>,
    said: impl IntoIterator<Item = Option<String>>,
    step: u64,
) -> Result<T> {
    let first = said.into_iter().flatten().next();
    match (local, first) {
        (Err(e), _) => Err(e),
        (Ok(_), Some(msg)) => Err(Error::Solver {
            step,
            msg: format!("another brick stopped: {msg}"),
        }),
        (Ok(v), None) => Ok(v),
    }
}

impl ShearSim {
    /// How far from a brick its ghosts reach: the pair list's cutoff
    /// ([`super::neighbor::cutoff`]).
    fn ghost_cut(&self) -> f64 {
        super::neighbor::cutoff(&self.radius, self.skin)
    }

    /// The particles this state owns: all of one process's, a brick's own (not its ghosts).
    fn own_particles(&self) -> usize {
        self.x.len() - self.ghost.iter().filter(|g| **g).count()
    }

    /// Whether particle `q` has plate candidates (since the last rebuild).
    fn has_plate_candidates(&self, q: usize) -> bool {
        self.wall_start[q] != self.wall_start[q + 1]
    }

    /// Every field of `like` but the per-particle ones and the pair list (empty here):
    /// what a brick, or a state gathered from bricks, fills in.
    fn without_particles(like: &ShearSim) -> ShearSim {
        ShearSim {
            skin: like.skin,
            rebuild_every: like.rebuild_every,
            rebuild_check: like.rebuild_check,
            params: like.params,
            nve: like.nve,
            box_: like.box_,
            box_y: like.box_y,
            x: Vec::new(),
            v: Vec::new(),
            omega: Vec::new(),
            f: Vec::new(),
            torque: Vec::new(),
            radius: Vec::new(),
            mass: Vec::new(),
            kick: Vec::new(),
            rotation: Vec::new(),
            nl: NeighborList::default(),
            xhold: Vec::new(),
            pair_force: Vec::new(),
            record_pair_forces: false,
            acc: Vec::new(),
            packed: Vec::new(),
            packed_current: false,
            pair_state: Vec::new(),
            pair_damp: Vec::new(),
            imp: Vec::new(),
            implicit: like.implicit,
            wall: Vec::new(),
            wall_force: Vec::new(),
            wall_start: vec![0],
            wall_cand: Vec::new(),
            meshes: like.meshes.clone(),
            top_orig: like.top_orig.clone(),
            bottom: like.bottom,
            top: like.top,
            top_base0: like.top_base0,
            servo: like.servo.clone(),
            bottom_speed: like.bottom_speed,
            bottom_node_v: like.bottom_node_v,
            shear_displacement: like.shear_displacement,
            bottom_hold: like.bottom_hold,
            top_hold: like.top_hold,
            force_time_velocities: None,
            ago: like.ago,
            mesh_rebuild_pending: like.mesh_rebuild_pending,
            step: like.step,
            top_force: like.top_force,
            bottom_force: like.bottom_force,
            kernel: like.kernel,
            phases: None,
            team: None,
            plan: Default::default(),
            ids: Vec::new(),
            ghost: Vec::new(),
        }
    }

    /// Sizes the per-particle scratch of `n` particles: the pair sums (zero), the plate
    /// forces, epsd_implicit's dashpot sums; the SIMD records are made anew by the next pass.
    fn size_particle_buffers(&mut self, n: usize) {
        // cleared and refilled in the capacity they have (a rebuild's brick holds about
        // as many as the last: no fresh pages to fault in at every rebuild)
        fn fill<T: Clone>(v: &mut Vec<T>, n: usize, x: T) {
            v.clear();
            v.resize(n, x);
        }
        fill(&mut self.acc, n, ForceData::default());
        fill(&mut self.wall_force, n, ([0.0; 3], [0.0; 3]));
        if self.implicit {
            fill(&mut self.imp, n, ([0.0; 6], [0.0; 3]));
        }
        self.packed = Vec::new();
        self.packed_current = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::loose_packing;
    use crate::solver::contact::models::RollingModel;
    use crate::solver::shear::tests::{fast_dense, state_bytes};
    use crate::solver::team::on_threads;
    use crate::spec::shear::{Preset, ShearCase};

    /// `global` run as `nx` x `ny` x `nz` bricks (threads of this process, each with `threads`
    /// threads of its own; brick 0's time counting `slow` times in the balance): with
    /// `speed` a run's setup first, then `steps` steps; the whole state gathered, how many
    /// particles changed brick, and the bricks at the end.
    fn in_bricks(
        global: &ShearSim,
        n: [usize; 3],
        threads: usize,
        slow: f64,
        speed: Option<f64>,
        steps: u64,
    ) -> (ShearSim, u64, Bricks) {
        let bricks = &bricks_of(n, global);
        let ends: Vec<(Option<ShearSim>, u64, Bricks)> = std::thread::scope(|scope| {
            let runs: Vec<_> = InProcess::group(bricks.count())
                .into_iter()
                .map(|t| {
                    scope.spawn(move || {
                        on_threads(threads, || {
                            let mut b = Brick::of(global, bricks, t.rank());
                            if t.rank() == 0 {
                                b.cost_factor = slow;
                            }
                            if let Some(v) = speed {
                                b.setup(&t, v).unwrap();
                            }
                            for _ in 0..steps {
                                b.step(&t).unwrap();
                            }
                            b.settle(&t).unwrap();
                            let moved = all_gather(&t, b.arrived).iter().sum();
                            (b.gather(&t), moved, b.bricks.clone())
                        })
                    })
                })
                .collect();
            runs.into_iter().map(|r| r.join().unwrap()).collect()
        });
        // the whole state on rank 0 alone; every brick with the same bricks
        assert!(ends[1..]
            .iter()
            .all(|(w, _, b)| w.is_none() && *b == ends[0].2));
        let (one, moved, end) = ends.into_iter().next().unwrap();
        (one.expect("rank 0 gathers"), moved, end)
    }

    /// 120 particles of the ci preset, loose, after the run's setup.
    fn loose_ci_120() -> ShearSim {
        let mut c = ShearCase::preset(Preset::Ci, RollingModel::Epsd, 0.5, 0.0, 3).unwrap();
        c.particles = 120;
        let mut global = ShearSim::new(&c.setup(), &loose_packing(&c));
        global.setup(0.0).unwrap();
        global
    }

    /// A particle blown up in one brick (held by no other) stops every brick at the same
    /// rebuild: the one that holds it with the particle's message, the other saying another
    /// brick stopped, with that message (the failure flag summed over the bricks, the
    /// messages gathered).
    #[test]
    fn a_blown_up_particle_stops_every_brick_at_the_same_step() {
        let global = loose_ci_120();
        let bricks = split_for(2, &global);
        let mut b = [0, 1].map(|r| Brick::of(&global, &bricks, r));
        // a particle of brick 0 that brick 1 does not hold as a ghost
        let l = (0..b[0].sim.ids.len())
            .find(|&l| !b[0].sim.ghost[l] && !b[1].sim.ids.contains(&b[0].sim.ids[l]))
            .expect("a particle far from the other brick");
        let id = b[0].sim.ids[l];
        b[0].sim.v[l] = [0.0, 1e12, 0.0];
        let ends: Vec<(u64, String)> = std::thread::scope(|scope| {
            let runs: Vec<_> = InProcess::group(2)
                .into_iter()
                .zip(b.iter_mut())
                .map(|(t, b)| {
                    scope.spawn(move || {
                        for _ in 0..200 {
                            if let Err(e) = b.step(&t) {
                                return (b.sim.step, e.to_string());
                            }
                        }
                        (b.sim.step, String::new())
                    })
                })
                .collect();
            runs.into_iter().map(|r| r.join().unwrap()).collect()
        });
        let said = format!("diverged: particle {}", id + 1);
        assert_eq!(ends[0].0, ends[1].0, "{ends:?}");
        assert!(
            ends[0].1.contains(&said) && !ends[0].1.contains("another brick"),
            "{ends:?}"
        );
        assert!(
            ends[1].1.contains("another brick stopped") && ends[1].1.contains(&said),
            "{ends:?}"
        );
    }

    /// A particle that jumps beyond the neighbouring bricks between two rebuilds (which the
    /// skin/2 rule forbids unless it flew off) stops every brick at that rebuild, the one it
    /// left saying where it went, instead of a message no brick waits for: the rebuild's
    /// messages go to the neighbouring bricks only.
    #[test]
    fn a_particle_beyond_the_neighbouring_bricks_stops_every_brick() {
        let global = loose_ci_120();
        let lx = global.box_.lx;
        let bricks = bricks_of([4, 1, 1], &global);
        let cut = global.ghost_cut();
        assert_eq!(
            bricks.near(0, cut),
            vec![1, 3],
            "cut {cut} for bricks {} wide",
            lx / 4.0
        );
        let mut b = [0, 1, 2, 3].map(|r| Brick::of(&global, &bricks, r));
        for b in &mut b {
            // no time counted: the bricks stay equal (one step's times would move them at
            // random, and the particle with them)
            b.cost_factor = 0.0;
        }
        let l = (0..b[0].sim.ids.len())
            .find(|&l| !b[0].sim.ghost[l])
            .expect("an own particle");
        let id = b[0].sim.ids[l];
        // two bricks on: from brick 0 to brick 2
        b[0].sim.x[l][0] += lx / 2.0;
        let ends: Vec<(u64, String)> = std::thread::scope(|scope| {
            let runs: Vec<_> = InProcess::group(4)
                .into_iter()
                .zip(b.iter_mut())
                .map(|(t, b)| {
                    scope.spawn(move || match b.step(&t) {
                        Err(e) => (b.sim.step, e.to_string()),
                        Ok(()) => (b.sim.step, String::new()),
                    })
                })
                .collect();
            runs.into_iter().map(|r| r.join().unwrap()).collect()
        });
        let said = format!("particle {} moved from brick 0 to brick 2", id + 1);
        assert!(ends.iter().all(|e| e.0 == ends[0].0), "{ends:?}");
        assert!(ends[0].1.contains(&said), "{ends:?}");
        for e in &ends[1..] {
            assert!(
                e.1.contains("another brick stopped") && e.1.contains(&said),
                "{ends:?}"
            );
        }
    }

    /// The split with the least area of cuts among those whose slabs are wider than the
    /// ghost cut: at the paper's 2,500 grains (4 x 2.4 mm, the plates' bases 4.7 mm apart)
    /// across the gap first (one 4 x 2.4 mm plane for 2 bricks against two 4.7 x 2.4 mm ones
    /// along x); at 250,000 (40 x 24 mm) along x, the longer periodic side; across a gap
    /// thinner than two cuts never; when no split is wide enough, the least area.
    #[test]
    fn the_split_has_the_least_boundary() {
        let cut = 0.35e-3;
        let split = |r: usize, l: [f64; 2], gap: f64| {
            let b = split_of(r, l[0] * 1e-3, [1e-3, (1.0 + gap) * 1e-3], l[1] * 1e-3, cut);
            [b.nx, b.ny, b.nz]
        };
        let paper = [1, 2, 3, 4, 6, 8, 16].map(|r| split(r, [4.0, 2.4], 4.7));
        assert_eq!(
            paper,
            [
                [1, 1, 1],
                [1, 2, 1],
                [1, 3, 1],
                [1, 4, 1],
                [2, 3, 1],
                [2, 4, 1],
                [4, 4, 1]
            ]
        );
        let wide = [2, 4, 8, 256, 1024].map(|r| split(r, [40.0, 24.0], 4.7));
        assert_eq!(
            wide,
            [[2, 1, 1], [4, 1, 1], [4, 1, 2], [16, 2, 8], [32, 2, 16]]
        );
        let thin = [2, 3, 8].map(|r| split(r, [4.0, 2.4], 0.5));
        assert_eq!(thin, [[2, 1, 1], [3, 1, 1], [4, 1, 2]]);
        assert_eq!(split(4, [2.0, 8.0], 0.5), [1, 1, 4]);
        let b = split_of(4096, 4e-3, [1e-3, 5.7e-3], 2.4e-3, cut);
        assert_eq!(b.count(), 4096);
        assert!(b.narrowest() <= cut);
        // a chosen split (`--bricks`) with a slab thinner than the cut: refused, saying how
        // many slabs each axis takes
        let s = loose_ci_120();
        assert!(split_as([2, 1, 1], &s).is_ok());
        let e = split_as([1, 1, 64], &s).unwrap_err().to_string();
        assert!(
            e.contains("`--bricks`: 1x1x64") && e.contains("at most"),
            "{e}"
        );
    }

    /// The scaling model's census counts what the bricks hold: for each split, each brick's
    /// own particles, ghosts, listed pairs and own particles with plate candidates as
    /// [`Brick::of`] makes it; one brick holds everything, no ghosts.
    #[test]
    fn the_census_counts_what_the_bricks_hold() {
        let (c, dense) = fast_dense();
        let mut s = ShearSim::new(&c.setup(), dense);
        s.setup(c.stages[0].speed).unwrap();
        for _ in 0..200 {
            s.step().unwrap();
        }
        let (splits, thin) = censuses(&s, &[1, 2, 4, 6, 4096]);
        assert_eq!(thin, [4096]);
        assert_eq!(splits.len(), 4);
        for (bricks, census) in &splits {
            let r = bricks.count();
            assert_eq!(census.own.iter().sum::<usize>(), s.particle_count());
            if r == 1 {
                assert_eq!(census.ghosts, [0]);
                assert_eq!(census.pairs, [s.listed_pairs()]);
            }
            for b in 0..r {
                let brick = Brick::of(&s, bricks, b);
                let own = brick.sim.own_particles();
                assert_eq!(census.own[b], own, "{r} bricks, brick {b}");
                assert_eq!(census.ghosts[b], brick.sim.particle_count() - own);
                assert_eq!(census.pairs[b], brick.sim.listed_pairs());
                assert_eq!(census.plate[b], own_with_candidates(&brick.sim).len());
            }
            if r > 1 {
                assert!(census.ghosts.iter().all(|&g| g > 0));
                assert!(census.pairs.iter().sum::<usize>() > s.listed_pairs());
            }
        }
    }

    /// The fast preset's 2,500 particles sheared 1,500 steps from a dense state (rebuilds,
    /// particles changing brick, plate contacts, both rolling dashpots): every bit of the
    /// state (particles, forces, rotations, pair list and histories, plate records and
    /// candidates, plates, servo, rebuild state) that of one process, for 1, 2 and 3 bricks
    /// along x, 2 x 2 along x and z, 2 and 3 across the gap and 2 x 2 along x and across the
    /// gap, on 1 and 2 threads each.
    #[test]
    fn bricks_give_one_process_bits_for_any_split_and_thread_count() {
        let (_, dense) = fast_dense();
        for model in [RollingModel::Epsd, RollingModel::EpsdImplicit] {
            let c = ShearCase::preset(Preset::Fast, model, 0.5, 0.5, 4).unwrap();
            let fresh = ShearSim::new(&c.setup(), dense);
            let speed = c.stages[0].speed;
            let steps = 1500;
            let one = on_threads(1, || {
                let mut s = fresh.clone();
                s.setup(speed).unwrap();
                for _ in 0..steps {
                    s.step().unwrap();
                }
                s
            });
            assert!(one.nl.builds >= 5, "{model}: {} rebuilds", one.nl.builds);
            assert!(one.wall.iter().any(|w| !w.rec.is_empty()));
            let reference = state_bytes(&one);
            // (brick 0's time counting 3 times: the cuts move towards it)
            for (split, threads, slow) in [
                ([1, 1, 1], 2, 1.0),
                ([2, 1, 1], 1, 1.0),
                ([2, 1, 1], 2, 1.0),
                ([3, 1, 1], 1, 1.0),
                ([3, 1, 1], 2, 3.0),
                ([2, 1, 2], 1, 1.0),
                ([2, 1, 2], 1, 3.0),
                ([1, 2, 1], 1, 1.0),
                ([1, 3, 1], 2, 3.0),
                ([2, 2, 1], 1, 3.0),
            ] {
                let (got, moved, bricks) =
                    in_bricks(&fresh, split, threads, slow, Some(speed), steps);
                assert!(
                    state_bytes(&got) == reference,
                    "{model}: {split:?} bricks on {threads} threads differ from one process"
                );
                // and what a run's outputs read of it
                assert_eq!(format!("{:?}", got.record()), format!("{:?}", one.record()));
                if split != [1, 1, 1] {
                    assert!(moved > 0, "{model}: {split:?}: no particle changed brick");
                }
                if slow > 1.0 {
                    let equal = bricks_of(split, &fresh);
                    assert!(
                        bricks.volume_share(0) < 0.8 * equal.volume_share(0),
                        "{model}: {split:?}: brick 0 counting 3 times kept {:?}",
                        bricks
                    );
                }
                eprintln!("{model}: {split:?} bricks x {threads} threads, brick 0 x {slow}: one process's bits ({moved} particles changed brick)");
            }
        }
    }

    /// A run stopped on 2 bricks (along x) and resumed on 3 (across the gap) from its
    /// checkpoint form (the gathered state through the checkpoint's serialisation) ends with
    /// one process's bits.
    #[test]
    fn a_run_stopped_on_two_bricks_resumes_on_three_to_the_same_bits() {
        let (c, dense) = fast_dense();
        let fresh = ShearSim::new(&c.setup(), dense);
        let speed = c.stages[0].speed;
        let one = on_threads(1, || {
            let mut s = fresh.clone();
            s.setup(speed).unwrap();
            for _ in 0..1200 {
                s.step().unwrap();
            }
            s
        });
        let (half, _, _) = in_bricks(&fresh, [2, 1, 1], 1, 1.0, Some(speed), 500);
        let bytes = rmp_serde::to_vec(&half).unwrap();
        let resumed: ShearSim = rmp_serde::from_slice(&bytes).unwrap();
        let (end, _, _) = in_bricks(&resumed, [1, 3, 1], 1, 1.0, None, 700);
        assert!(state_bytes(&end) == state_bytes(&one));
    }
}
