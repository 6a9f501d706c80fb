//! `verify replay`: the dense sheared gouge compared with LIGGGHTS contact by contact.
//!
//! One LIGGGHTS shear run dumps the complete state (atoms, every touching pair and every
//! particle-triangle contact with its history) at every step of a few windows
//! `[s, s + K]`, and its plate forces at every step. For each window the native solver starts
//! from LIGGGHTS' state at `s` (histories included, nothing reset; plates, servo and
//! neighbour schedule reconstructed bit for bit from the run's start, see
//! `solver::shear::replay`) and advances K steps; after each step its particles, contacts and
//! plate forces are compared with LIGGGHTS' dump of that step. Step 1 must agree to `rtol`
//! (1e-12: only the order in which forces are summed differs). Later steps are judged against
//! a chaos envelope measured in the same run: the native solver against itself with one
//! particle moved by one ulp.
//!
//! Data flow: request -> deck + LIGGGHTS run -> dumps -> native replay -> outcome (typed,
//! serialisable) -> table / summary.json / SVG. This module never reads command-line flags.

use crate::deck::shear::{
    replay_dumps, shear_deck_with, DeckExtras, REPLAY_ATOMS, REPLAY_PAIRS, REPLAY_WALLS,
    THERMO_COLUMNS,
};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::{read_thermo, Liggghts, LOG_NAME};
use crate::packing::loose_packing;
use crate::solver::contact::ContactHistory;
use crate::solver::shear::replay::{PairObservation, RecordedState, WallObservation};
use crate::solver::shear::ShearSim;
use crate::solver::vec3::V3;
use crate::spec::shear::{NeighborSchedule, ShearCase};
use crate::spec::RollingModel;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Schema version of `summary.json`.
pub const SCHEMA: u32 = 1;

/// Rebuild interval of the replay run (`neigh_modify every 10 check no`): a schedule that
/// does not depend on particle positions, so the native side can reproduce it (and the bottom
/// mesh's wrap steps) from the plates alone. Plates still force rebuilds as in production.
pub const REPLAY_NEIGHBOR_EVERY: u64 = 10;

/// Default timeout of the replay's LIGGGHTS run [s] (one recorded shear run).
pub const REPLAY_TIMEOUT_S: u64 = 3600;

/// Step-1 tolerance: only the order of force summation differs.
pub const STEP1_RTOL: f64 = 1e-12;

/// Later steps agree if their error is within this factor of the chaos envelope.
pub const CHAOS_FACTOR: f64 = 100.0;

/// One replay: the case (preset and overrides already applied and validated), the window
/// starts, the window length and where to write.
#[derive(Clone, Debug)]
pub struct ReplayRequest {
    pub case: ShearCase,
    pub states: Vec<u64>,
    pub steps: u64,
    pub rtol: f64,
    pub out: PathBuf,
}

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
    /// The same for native against native with one particle one ulp apart.
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

/// Number of history values LIGGGHTS stores per contact for this rolling model.
pub fn history_len(rolling: RollingModel) -> usize {
    match rolling {
        RollingModel::Epsd | RollingModel::Epsd2 | RollingModel::Epsd3 => 6,
        _ => 3,
    }
}

/// The replay run's case: the production case with the position-independent neighbour
/// schedule, ending after the last window.
pub fn replay_case(case: &ShearCase) -> Result<ShearCase> {
    if case.models.rolling == RollingModel::EpsdImplicit {
        return Err(Error::invalid(
            "--rolling",
            "epsd_implicit",
            "a LIGGGHTS model (off, cdt, epsd, epsd2, epsd3): epsd_implicit is native only",
        ));
    }
    let mut c = case.clone();
    c.neighbor = NeighborSchedule {
        every: REPLAY_NEIGHBOR_EVERY,
        check: false,
    };
    c.validate(false)?;
    Ok(c)
}

/// `n` window starts spread over compaction (its second half) and the first `shear_span`
/// steps of shearing, none at a run boundary.
pub fn default_states(case: &ShearCase, n: usize, k: u64, shear_span: u64) -> Vec<u64> {
    let comp = case.compression_steps;
    let n_comp = n / 2;
    let n_shear = n - n_comp;
    let mut s = Vec::new();
    for i in 0..n_comp {
        s.push(comp / 2 + (i as u64 + 1) * (comp / 2) / (n_comp as u64 + 1));
    }
    let span = shear_span.min(case.stage_steps().first().copied().unwrap_or(0));
    for i in 0..n_shear {
        s.push(
            comp + 3
                + (i as u64 + 1) * span.saturating_sub(k + REPLAY_NEIGHBOR_EVERY + 6)
                    / (n_shear as u64 + 1),
        );
    }
    s.sort_unstable();
    s.dedup();
    s
}

/// Checks the window starts: increasing, disjoint, inside the run, not at a run boundary.
pub fn check_states(case: &ShearCase, states: &[u64], k: u64) -> Result<()> {
    let k = k + REPLAY_NEIGHBOR_EVERY;
    let ends = crate::shear::run_ends(case);
    let total = *ends.last().unwrap_or(&0);
    if states.is_empty() || k == 0 {
        return Err(Error::invalid(
            "--states/--steps",
            format!("{} states, {k} steps", states.len()),
            ">= 1 state and >= 1 step",
        ));
    }
    for w in states.windows(2) {
        if w[1] <= w[0] + k {
            return Err(Error::invalid(
                "--at",
                format!("{} then {}", w[0], w[1]),
                format!("increasing starts more than --steps = {k} apart"),
            ));
        }
    }
    for &s in states {
        let crosses = ends
            .iter()
            .chain(std::iter::once(&0))
            .any(|&e| s <= e && e < s + k + 1);
        if s == 0 || s + k > total || crosses {
            return Err(Error::invalid(
                "--at",
                s,
                format!(
                    "1 ..= {} with no run boundary (steps {ends:?}) in [s, s + {k}]",
                    total.saturating_sub(k)
                ),
            ));
        }
    }
    Ok(())
}

/// One parsed dump step.
struct Dumped {
    state: RecordedState,
    /// (id1 - 1, id2 - 1) -> force, torque on id1, history, periodic flag.
    pairs: BTreeMap<(u32, u32), (V3, V3, ContactHistory, bool)>,
    /// (atom - 1, mesh, triangle) -> force, torque, history.
    walls: BTreeMap<(u32, u8, u32), (V3, V3, ContactHistory)>,
}

fn parse_err(path: &Path, msg: impl Into<String>) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

/// Rows of a LIGGGHTS dump after its `ITEM: ATOMS` / `ITEM: ENTRIES` header, checking the
/// step, the row count and that every row has `ncol` numbers.
fn dump_rows(path: &Path, step: u64, ncol: usize) -> Result<Vec<Vec<f64>>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut lines = text.lines();
    let mut count: Option<usize> = None;
    let mut got_step = None;
    while let Some(l) = lines.next() {
        if l.starts_with("ITEM: TIMESTEP") {
            got_step = lines.next().and_then(|s| s.trim().parse::<u64>().ok());
        } else if l.starts_with("ITEM: NUMBER OF") {
            count = lines.next().and_then(|s| s.trim().parse::<usize>().ok());
        } else if l.starts_with("ITEM: ATOMS") || l.starts_with("ITEM: ENTRIES") {
            let cols = l.split_whitespace().count() - 2;
            if cols != ncol {
                return Err(parse_err(
                    path,
                    format!("{cols} columns, expected {ncol} (a history layout from another rolling model?)"),
                ));
            }
            break;
        }
    }
    if got_step != Some(step) {
        return Err(parse_err(
            path,
            format!("timestep {got_step:?}, expected {step}"),
        ));
    }
    let count = count.ok_or_else(|| parse_err(path, "no NUMBER OF ATOMS/ENTRIES"))?;
    let mut rows = Vec::with_capacity(count);
    for (k, l) in lines.enumerate() {
        let v: Vec<f64> = l
            .split_whitespace()
            .map(|t| t.parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|e| parse_err(path, format!("row {}: {e}", k + 1)))?;
        if v.len() != ncol {
            return Err(parse_err(
                path,
                format!("row {} has {} values, expected {ncol}", k + 1, v.len()),
            ));
        }
        rows.push(v);
    }
    if rows.len() != count {
        return Err(parse_err(
            path,
            format!("{} rows, header says {count}", rows.len()),
        ));
    }
    Ok(rows)
}

fn v3(r: &[f64], at: usize) -> V3 {
    [r[at], r[at + 1], r[at + 2]]
}

fn hist(r: &[f64], at: usize, n: usize) -> ContactHistory {
    ContactHistory {
        shear: v3(r, at),
        r_torque: if n == 6 { v3(r, at + 3) } else { [0.0; 3] },
    }
}

fn read_dumped(
    dir: &Path,
    step: u64,
    atoms: usize,
    n_hist: usize,
    ntri: [usize; 2],
) -> Result<Dumped> {
    let pa = dir.join(format!("{REPLAY_ATOMS}{step}.dump"));
    let rows = dump_rows(&pa, step, 19)?;
    if rows.len() != atoms {
        return Err(parse_err(
            &pa,
            format!("{} atoms, the case has {atoms} (atoms lost?)", rows.len()),
        ));
    }
    let mut st = RecordedState {
        step,
        ..Default::default()
    };
    for (k, r) in rows.iter().enumerate() {
        if r[0] as usize != k + 1 {
            return Err(parse_err(
                &pa,
                format!("row {} holds atom id {}, expected {}", k + 1, r[0], k + 1),
            ));
        }
        st.x.push(v3(r, 1));
        st.v.push(v3(r, 7));
        st.omega.push(v3(r, 10));
        st.f.push(v3(r, 13));
        st.torque.push(v3(r, 16));
    }
    let ncol = 9 + n_hist;
    let pp = dir.join(format!("{REPLAY_PAIRS}{step}.dump"));
    let mut pairs = BTreeMap::new();
    for r in dump_rows(&pp, step, ncol)? {
        let (a, b) = (r[0] as usize, r[1] as usize);
        if a == 0 || b == 0 || a > atoms || b > atoms || a == b {
            return Err(parse_err(
                &pp,
                format!("pair ids {a} {b} outside 1..={atoms}"),
            ));
        }
        let key = ((a - 1) as u32, (b - 1) as u32);
        let h = hist(&r, 9, n_hist);
        st.pairs.insert(key, h);
        pairs.insert(key, (v3(&r, 3), v3(&r, 6), h, r[2] != 0.0));
    }
    let pw = dir.join(format!("{REPLAY_WALLS}{step}.dump"));
    let mut walls = BTreeMap::new();
    for r in dump_rows(&pw, step, ncol)? {
        let (m, t, a) = (r[0] as usize, r[1] as usize, r[2] as usize);
        if m > 1 || t >= ntri[m.min(1)] || a == 0 || a > atoms {
            return Err(parse_err(
                &pw,
                format!("wall contact mesh {m} triangle {t} atom {a} does not exist"),
            ));
        }
        let h = hist(&r, 9, n_hist);
        st.walls.push(((a - 1) as u32, m as u8, t as u32, h));
        walls.insert(
            ((a - 1) as u32, m as u8, t as u32),
            (v3(&r, 3), v3(&r, 6), h),
        );
    }
    Ok(Dumped {
        state: st,
        pairs,
        walls,
    })
}

fn norm(a: V3) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Accumulates one channel: worst |a - b| and the peak of |a|, |b|.
#[derive(Default)]
struct Acc {
    err: f64,
    peak: f64,
    worst: String,
}

impl Acc {
    fn add(&mut self, a: V3, b: V3, item: impl FnOnce() -> String) {
        self.peak = self.peak.max(norm(a)).max(norm(b));
        let e = norm(sub(a, b));
        if e > self.err || (self.worst.is_empty() && e >= self.err) {
            self.err = e;
            self.worst = item();
        }
    }
    fn finish(self, channel: &str) -> ChannelError {
        ChannelError {
            channel: channel.into(),
            max_rel_err: if self.peak > 0.0 {
                self.err / self.peak
            } else if self.err > 0.0 {
                f64::INFINITY
            } else {
                0.0
            },
            peak: self.peak,
            worst: self.worst,
        }
    }
}

/// A contact's force and torque on its first partner, its history and its kind.
type ContactValues = (V3, V3, ContactHistory, String);
/// A curve of the error plot.
type Points = Vec<(f64, f64)>;

/// One side of a comparison: particles, contacts keyed as LIGGGHTS keys them, plate forces.
struct Side {
    x: Vec<V3>,
    v: Vec<V3>,
    omega: Vec<V3>,
    f: Vec<V3>,
    torque: Vec<V3>,
    pairs: BTreeMap<(u32, u32), ContactValues>,
    walls: BTreeMap<(u32, u8, u32), ContactValues>,
    top: V3,
    bottom: V3,
}

fn pair_kind(o: &PairObservation) -> String {
    let mut k = vec!["pair"];
    if o.periodic {
        k.push("periodic");
    }
    if o.sliding {
        k.push("sliding");
    }
    if o.rolling_limit {
        k.push("rolling limit");
    }
    k.join(", ")
}

/// The native side, its pairs oriented like `like` (LIGGGHTS' keys) where a key exists.
fn native_side(
    sim: &ShearSim,
    like: &BTreeMap<(u32, u32), (V3, V3, ContactHistory, bool)>,
) -> Result<Side> {
    let (pairs, walls) = sim.observe_contacts()?;
    let neg = |h: ContactHistory| ContactHistory {
        shear: h.shear.map(|c| -c),
        r_torque: h.r_torque.map(|c| -c),
    };
    let mut p = BTreeMap::new();
    for o in &pairs {
        let kind = pair_kind(o);
        if like.contains_key(&(o.j, o.i)) {
            p.insert((o.j, o.i), (o.force_j, o.torque_j, neg(o.hist), kind));
        } else {
            p.insert((o.i, o.j), (o.force_i, o.torque_i, o.hist, kind));
        }
    }
    let w = walls
        .iter()
        .map(|o: &WallObservation| {
            let kind = format!(
                "{} plate, {}",
                if o.mesh == 0 { "bottom" } else { "top" },
                if o.face { "face" } else { "edge/corner" }
            );
            (
                (o.particle, o.mesh, o.tri),
                (o.force, o.torque, o.hist, kind),
            )
        })
        .collect();
    let (top, bottom) = sim.plate_forces();
    Ok(Side {
        x: sim.x.clone(),
        v: sim.v.clone(),
        omega: sim.omega.clone(),
        f: sim.forces().to_vec(),
        torque: sim.torques().to_vec(),
        pairs: p,
        walls: w,
        top,
        bottom,
    })
}

fn liggghts_side(d: &Dumped, thermo: &[f64], kinds: &Side) -> Side {
    let pk = |k: &(u32, u32)| {
        kinds
            .pairs
            .get(k)
            .map(|e| e.3.clone())
            .unwrap_or_else(|| "pair (LIGGGHTS only)".into())
    };
    let wk = |k: &(u32, u8, u32)| {
        kinds
            .walls
            .get(k)
            .map(|e| e.3.clone())
            .unwrap_or_else(|| "wall (LIGGGHTS only)".into())
    };
    Side {
        x: d.state.x.clone(),
        v: d.state.v.clone(),
        omega: d.state.omega.clone(),
        f: d.state.f.clone(),
        torque: d.state.torque.clone(),
        pairs: d
            .pairs
            .iter()
            .map(|(k, v)| (*k, (v.0, v.1, v.2, pk(k))))
            .collect(),
        walls: d
            .walls
            .iter()
            .map(|(k, v)| (*k, (v.0, v.1, v.2, wk(k))))
            .collect(),
        top: v3(thermo, 0),
        bottom: v3(thermo, 3),
    }
}

/// Every channel of `a` against `b`. A contact present in one side only counts as an error
/// of 1 (relative) in its channel's `missing` entry.
fn compare(a: &Side, b: &Side) -> Vec<ChannelError> {
    let mut out = Vec::new();
    // A particle's force and torque are sums of its contacts' (near-cancelling in a dense
    // packing): their round-off scales with the largest contact term, not with the net value.
    let term = |f: &dyn Fn(&ContactValues) -> V3| {
        a.pairs
            .values()
            .chain(a.walls.values())
            .map(|e| norm(f(e)))
            .fold(0.0, f64::max)
    };
    let (fterm, tterm) = (term(&|e| e.0), term(&|e| e.1));
    for (name, xa, xb, floor) in [
        ("x", &a.x, &b.x, 0.0),
        ("v", &a.v, &b.v, 0.0),
        ("omega", &a.omega, &b.omega, 0.0),
        ("f", &a.f, &b.f, fterm),
        ("torque", &a.torque, &b.torque, tterm),
    ] {
        let mut acc = Acc::default();
        for (i, (p, q)) in xa.iter().zip(xb.iter()).enumerate() {
            acc.add(*p, *q, || format!("atom {}", i + 1));
        }
        acc.peak = acc.peak.max(floor);
        out.push(acc.finish(name));
    }
    let mut missing = (0usize, String::new());
    // pairs across a periodic seam in channels of their own (their geometry is the one place
    // where the two codes' ghost coordinates must be rounded alike: see neighbor::Pair)
    let periodic = |k: &(u32, u32)| {
        a.pairs
            .get(k)
            .or_else(|| b.pairs.get(k))
            .is_some_and(|e| e.3.contains("periodic"))
    };
    let split = |m: &BTreeMap<(u32, u32), ContactValues>,
                 want: bool|
     -> BTreeMap<(u32, u32), ContactValues> {
        m.iter()
            .filter(|(k, _)| periodic(k) == want)
            .map(|(k, v)| (*k, v.clone()))
            .collect()
    };
    for (want, what) in [(false, "pair"), (true, "periodic_pair")] {
        contact_channels(
            &split(&a.pairs, want),
            &split(&b.pairs, want),
            what,
            |k, kind| format!("pair {}-{} ({kind})", k.0 + 1, k.1 + 1),
            &mut missing,
            &mut out,
        );
    }
    contact_channels(
        &a.walls,
        &b.walls,
        "wall",
        |k, kind| format!("atom {} mesh {} tri {} ({kind})", k.0 + 1, k.1, k.2),
        &mut missing,
        &mut out,
    );
    let mut plates = Acc::default();
    plates.add(a.top, b.top, || "top plate".into());
    plates.add(a.bottom, b.bottom, || "bottom plate".into());
    out.push(plates.finish("plate_force"));
    out.push(ChannelError {
        channel: "contact_set".into(),
        max_rel_err: missing.0 as f64,
        peak: 1.0,
        worst: missing.1,
    });
    out
}

/// Force, torque, shear and rolling history of the contacts both sides hold (`<what>_force`,
/// ...); a contact held by one side only is counted in `missing` (count, last item).
fn contact_channels<K: Ord>(
    a: &BTreeMap<K, ContactValues>,
    b: &BTreeMap<K, ContactValues>,
    what: &str,
    name: impl Fn(&K, &str) -> String,
    missing: &mut (usize, String),
    out: &mut Vec<ChannelError>,
) {
    let mut chans: [Acc; 4] = Default::default();
    for (k, ea) in a {
        let Some(eb) = b.get(k) else {
            *missing = (missing.0 + 1, name(k, &ea.3));
            continue;
        };
        let item = || name(k, &ea.3);
        chans[0].add(ea.0, eb.0, item);
        chans[1].add(ea.1, eb.1, item);
        chans[2].add(ea.2.shear, eb.2.shear, item);
        chans[3].add(ea.2.r_torque, eb.2.r_torque, item);
    }
    for (k, eb) in b {
        if !a.contains_key(k) {
            *missing = (missing.0 + 1, name(k, &eb.3));
        }
    }
    for (c, suffix) in chans
        .into_iter()
        .zip(["force", "torque", "shear_hist", "roll_hist"])
    {
        out.push(c.finish(&format!("{what}_{suffix}")));
    }
}

/// Channels that decide: what the force computation produces from the recorded state
/// (particle forces and torques, every contact's force, torque and history, plate forces, the
/// contact set). Positions, velocities and angular velocities are reported, not judged: after
/// a step they carry the force round-off divided by the mass, which for a slow particle is a
/// large fraction of its own small velocity.
///
/// The contacts' own forces and torques (`pair_force`, ...) are what LIGGGHTS' computes report:
/// re-evaluations at the end of the step. Evaluated on the native state they carry its
/// velocity round-off, which cdt's torque direction `wr / |wr|` amplifies without bound near
/// rolling reversal; so they are reported, and judged as `kernel_*`: the native kernels
/// evaluated on LIGGGHTS' own recorded state of the same step (same inputs).
pub const JUDGED: [&str; 17] = [
    "f",
    "torque",
    "pair_shear_hist",
    "pair_roll_hist",
    "periodic_pair_shear_hist",
    "periodic_pair_roll_hist",
    "kernel_periodic_pair_force",
    "kernel_periodic_pair_torque",
    "wall_shear_hist",
    "wall_roll_hist",
    "plate_force",
    "contact_set",
    "kernel_pair_force",
    "kernel_pair_torque",
    "kernel_wall_force",
    "kernel_wall_torque",
    "kernel_contact_set",
];

/// Channels of the kernel check (see [`JUDGED`]).
const KERNEL: [&str; 7] = [
    "pair_force",
    "pair_torque",
    "periodic_pair_force",
    "periodic_pair_torque",
    "wall_force",
    "wall_torque",
    "contact_set",
];

/// The judged channel with the largest error.
fn worst(ch: &[ChannelError]) -> ChannelError {
    ch.iter()
        .filter(|c| JUDGED.contains(&c.channel.as_str()))
        .max_by(|a, b| a.max_rel_err.total_cmp(&b.max_rel_err))
        .cloned()
        .unwrap_or_default()
}

/// Largest error over the judged channels (the chaos envelope).
fn max_judged(ch: &[ChannelError]) -> f64 {
    ch.iter()
        .filter(|c| JUDGED.contains(&c.channel.as_str()))
        .map(|c| c.max_rel_err)
        .fold(0.0, f64::max)
}

/// Runs LIGGGHTS (kept under `out/liggghts/`) and replays every window natively.
pub fn run(req: &ReplayRequest, lig: &Liggghts, progress: impl Fn(&str)) -> Result<ReplayOutcome> {
    let case = replay_case(&req.case)?;
    check_states(&case, &req.states, req.steps)?;
    let k = req.steps;
    let n_hist = history_len(case.models.rolling);
    let packing = loose_packing(&case);
    // each window starts at the first rebuild at or after its requested step (then every
    // pair with a history touches, and LIGGGHTS' dump holds the complete state)
    let windows: Vec<(u64, u64)> = req
        .states
        .iter()
        .map(|&s| (s, s + k + REPLAY_NEIGHBOR_EVERY))
        .collect();
    let end = windows.last().map(|w| w.1 + 1).unwrap_or(0);
    let extras = DeckExtras {
        thermo_every: Some(1),
        end_step: Some(end),
        before_runs: replay_dumps(&windows, n_hist),
    };
    let dir = req.out.join("liggghts");
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let deck = shear_deck_with(&case, &packing, &extras);
    progress(&format!(
        "LIGGGHTS: {} steps with dumps in {}",
        end,
        dir.display()
    ));
    lig.run(&deck, &dir)?;
    let thermo: BTreeMap<u64, Vec<f64>> = read_thermo(&dir.join(LOG_NAME), THERMO_COLUMNS.len())?
        .into_iter()
        .collect();
    let log = dir.join(LOG_NAME);
    let row = |s: u64| -> Result<&Vec<f64>> {
        thermo.get(&s).ok_or_else(|| {
            parse_err(
                &log,
                format!("no thermo row for step {s} (thermo every step expected)"),
            )
        })
    };
    let mut sim = ShearSim::new(&case, &packing);
    let ntri = sim.triangle_counts();
    let ends = crate::shear::run_ends(&case);
    let mut results = Vec::new();
    let mut run_start = 0u64;
    let mut wi = 0usize;
    for (r, &run_end) in ends.iter().enumerate() {
        if wi >= windows.len() {
            break;
        }
        let speed = if r == 0 {
            0.0
        } else {
            case.stages[r - 1].speed
        };
        sim.setup_plates_only(speed);
        let mut step = run_start;
        while step < run_end && wi < windows.len() {
            step += 1;
            let t = row(step)?;
            sim.step_plates_only(v3(t, 0))?;
            if sim.servo_xcm()[1].to_bits() != t[6].to_bits() {
                return Err(Error::Solver {
                    step,
                    msg: format!(
                        "the reconstructed top plate centre y {:e} differs from LIGGGHTS' {:e}",
                        sim.servo_xcm()[1],
                        t[6]
                    ),
                });
            }
            if step > windows[wi].0 + REPLAY_NEIGHBOR_EVERY {
                return Err(Error::Solver {
                    step,
                    msg: format!(
                        "no neighbour rebuild within {REPLAY_NEIGHBOR_EVERY} steps of {}",
                        windows[wi].0
                    ),
                });
            }
            if step >= windows[wi].0 && sim.rebuilt_now() {
                progress(&format!(
                    "window {} / {}: steps {}..={}",
                    wi + 1,
                    windows.len(),
                    step,
                    step + k
                ));
                results.push(replay_window(
                    &sim, &dir, &row, step, k, n_hist, ntri, req.rtol, &case,
                )?);
                wi += 1;
            }
        }
        run_start = run_end;
    }
    let pass = results.len() == windows.len() && results.iter().all(|w| w.pass);
    let outcome = ReplayOutcome {
        schema: SCHEMA,
        pass,
        case: case.name.clone(),
        rolling: case.models.rolling.keyword().into(),
        mu_r: case.material.rolling_friction,
        eta_r: case.material.rolling_damping,
        restitution: case.material.restitution,
        rtol: req.rtol,
        chaos_factor: CHAOS_FACTOR,
        neighbor_every: REPLAY_NEIGHBOR_EVERY,
        liggghts_version: lig.version(),
        windows: results,
        notes: vec![
            format!("neighbour list rebuilt every {REPLAY_NEIGHBOR_EVERY} steps without distance check in both codes (plates still force rebuilds), so that the schedule can be reproduced"),
            "top plate servo state reconstructed from LIGGGHTS' plate force of every step; its centre checked bit for bit at every step".into(),
            "histories of pairs that separated since the last rebuild are not dumped by LIGGGHTS and start from zero natively".into(),
            "contact forces are re-evaluations without history update at the end of the step in both codes (compute pair/gran/local semantics)".into(),
        ],
    };
    let json = serde_json::to_string_pretty(&outcome)?;
    write_atomic(&req.out.join("summary.json"), json.as_bytes())?;
    plot(&req.out, &outcome)?;
    Ok(outcome)
}

#[allow(clippy::too_many_arguments)]
fn replay_window<'a>(
    plates: &ShearSim,
    dir: &Path,
    row: &impl Fn(u64) -> Result<&'a Vec<f64>>,
    s: u64,
    k: u64,
    n_hist: usize,
    ntri: [usize; 2],
    rtol: f64,
    case: &ShearCase,
) -> Result<WindowResult> {
    let atoms = case.particles;
    let d0 = read_dumped(dir, s, atoms, n_hist, ntri)?;
    let mut sim = plates.clone();
    sim.load_recorded(&d0.state)?;
    sim.keep_force_time_velocities();
    // the plates as LIGGGHTS moved them, for the kernel check on LIGGGHTS' own states
    let mut lig_plates = plates.clone();
    let mut prev_state = d0.state.clone();
    let mut twin = sim.clone();
    twin.x[0][0] = next_up(twin.x[0][0]);
    let mut cov = Coverage::default();
    let builds0 = sim.neighbor_builds();
    let mut steps = Vec::new();
    let mut prev_walls: Option<Vec<(u32, u8, u32)>> = None;
    let mut horizon = 0;
    let mut alive = true;
    for _ in 0..k {
        let xb = sim.x.clone();
        sim.step()?;
        twin.step()?;
        let step = sim.step;
        let d = read_dumped(dir, step, atoms, n_hist, ntri)?;
        let nat = native_side(&sim, &d.pairs)?;
        let lig = liggghts_side(&d, row(step)?, &nat);
        let tw = native_side(&twin, &d.pairs)?;
        let mut ch = compare(&lig, &nat);
        // kernel check: the native contact kernels on LIGGGHTS' own state of this step give
        // LIGGGHTS' contact forces and torques (same inputs, same operations)
        lig_plates.step_plates_only(v3(row(step)?, 0))?;
        let mut probe = lig_plates.clone();
        probe.load_recorded(&d.state)?;
        probe.set_force_time_velocities_from(&prev_state);
        let kernel = native_side(&probe, &d.pairs)?;
        for c in compare(&lig, &kernel) {
            if KERNEL.contains(&c.channel.as_str()) {
                ch.push(ChannelError {
                    channel: format!("kernel_{}", c.channel),
                    ..c
                });
            }
        }
        prev_state = d.state;
        let chaos = max_judged(&compare(&tw, &nat));
        let floor = if steps.is_empty() {
            0.0
        } else {
            CHAOS_FACTOR * chaos
        };
        let w = worst(&ch);
        let pass = w.max_rel_err <= rtol.max(floor);
        if alive && pass {
            horizon += 1;
        } else {
            alive = false;
        }
        // coverage
        cov.pairs = cov.pairs.max(nat.pairs.len());
        cov.periodic_pairs = cov.periodic_pairs.max(
            nat.pairs
                .values()
                .filter(|p| p.3.contains("periodic"))
                .count(),
        );
        cov.sliding_pairs = cov.sliding_pairs.max(
            nat.pairs
                .values()
                .filter(|p| p.3.contains("sliding"))
                .count(),
        );
        cov.rolling_limit_pairs = cov.rolling_limit_pairs.max(
            nat.pairs
                .values()
                .filter(|p| p.3.contains("rolling limit"))
                .count(),
        );
        cov.wall_face = cov
            .wall_face
            .max(nat.walls.values().filter(|p| p.3.ends_with("face")).count());
        cov.wall_edge_corner = cov.wall_edge_corner.max(
            nat.walls
                .values()
                .filter(|p| p.3.ends_with("corner"))
                .count(),
        );
        let lx = case.box_x;
        let lz = case.box_z;
        cov.seam_crossings += xb
            .iter()
            .zip(&sim.x)
            .filter(|(a, b)| (a[0] - b[0]).abs() > 0.5 * lx || (a[2] - b[2]).abs() > 0.5 * lz)
            .count();
        let mut wk: Vec<(u32, u8, u32)> = nat.walls.keys().copied().collect();
        wk.sort_unstable();
        if let Some(p) = &prev_walls {
            cov.triangle_changes += p.iter().filter(|x| wk.binary_search(x).is_err()).count()
                + wk.iter().filter(|x| p.binary_search(x).is_err()).count();
        }
        prev_walls = Some(wk);
        steps.push(StepResult {
            step,
            max_rel_err: w.max_rel_err,
            chaos_rel_err: chaos,
            worst: w,
            channels: ch,
            pass,
        });
    }
    cov.rebuilds = sim.neighbor_builds() - builds0;
    let pass = steps.iter().all(|s| s.pass);
    Ok(WindowResult {
        start: s,
        phase: if s < case.compression_steps {
            "compaction"
        } else {
            "shear"
        }
        .into(),
        coverage: cov,
        steps,
        horizon,
        pass,
    })
}

fn next_up(x: f64) -> f64 {
    if x == 0.0 {
        f64::from_bits(1)
    } else if x > 0.0 {
        f64::from_bits(x.to_bits() + 1)
    } else {
        f64::from_bits(x.to_bits() - 1)
    }
}

/// `error.svg`: largest error against the step within each window, LIGGGHTS vs native
/// (solid) and the chaos envelope (faint), log10.
fn plot(out: &Path, o: &ReplayOutcome) -> Result<()> {
    use crate::report::plot::{line_plot, Curve};
    let floor = 1e-20f64;
    let data: Vec<(Points, Points, String)> = o
        .windows
        .iter()
        .map(|w| {
            let curve = |e: fn(&StepResult) -> f64| -> Points {
                w.steps
                    .iter()
                    .enumerate()
                    .map(|(i, s)| ((i + 1) as f64, e(s).max(floor).log10()))
                    .collect()
            };
            let (a, b) = (curve(|s| s.max_rel_err), curve(|s| s.chaos_rel_err));
            (a, b, format!("from step {}", w.start))
        })
        .collect();
    let mut curves = Vec::new();
    for (k, (a, b, label)) in data.iter().enumerate() {
        curves.push(Curve::new(label, a, k));
        curves.push(Curve::new("", b, k).faint());
    }
    line_plot(
        &out.join("error.svg"),
        "replay: LIGGGHTS vs native (solid), native vs 1-ulp twin (faint)",
        "step after the recorded state",
        "log10 max relative error",
        &curves,
    )
}

/// The terminal table.
pub fn table(o: &ReplayOutcome) -> String {
    let mut s = format!(
        "replay {} ({}, mu_r {}, eta_r {}, e {}): step 1 within {:e}, later steps within {}x the 1-ulp chaos envelope\n",
        o.case, o.rolling, o.mu_r, o.eta_r, o.restitution, o.rtol, o.chaos_factor
    );
    s.push_str("  start  phase       pairs per sl rl  wall f/e  rb seam tri  step-1 err  worst step-1 channel (item)                      horizon\n");
    for w in &o.windows {
        let c = &w.coverage;
        let s1 = &w.steps[0];
        s.push_str(&format!(
            "  {:>6} {:<11} {:>5} {:>3} {:>3} {:>3} {:>4}/{:<3} {:>3} {:>4} {:>3}  {:>10.3e}  {:<48} {:>3}/{} {}\n",
            w.start,
            w.phase,
            c.pairs,
            c.periodic_pairs,
            c.sliding_pairs,
            c.rolling_limit_pairs,
            c.wall_face,
            c.wall_edge_corner,
            c.rebuilds,
            c.seam_crossings,
            c.triangle_changes,
            s1.max_rel_err,
            format!("{} ({})", s1.worst.channel, s1.worst.worst),
            w.horizon,
            w.steps.len(),
            if w.pass { "ok" } else { "FAIL" }
        ));
    }
    s.push_str(if o.pass {
        "replay: agree\n"
    } else {
        "replay: DISAGREE\n"
    });
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dumps_with_wrong_columns_rows_or_step_are_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("d.dump");
        let head = "ITEM: TIMESTEP\n7\nITEM: NUMBER OF ENTRIES\n2\nITEM: BOX BOUNDS pp ff pp\n0 1\n0 1\n0 1\n";
        std::fs::write(&p, format!("{head}ITEM: ENTRIES c[1] c[2]\n1 2\n3 4\n")).unwrap();
        assert_eq!(dump_rows(&p, 7, 2).unwrap().len(), 2);
        let e = dump_rows(&p, 7, 3).unwrap_err().to_string();
        assert!(
            e.contains("d.dump") && e.contains("2 columns, expected 3"),
            "{e}"
        );
        let e = dump_rows(&p, 8, 2).unwrap_err().to_string();
        assert!(e.contains("timestep Some(7), expected 8"), "{e}");
        std::fs::write(&p, format!("{head}ITEM: ENTRIES c[1] c[2]\n1 2\n")).unwrap();
        let e = dump_rows(&p, 7, 2).unwrap_err().to_string();
        assert!(e.contains("1 rows, header says 2"), "{e}");
        std::fs::write(&p, format!("{head}ITEM: ENTRIES c[1] c[2]\n1 2\n3 x\n")).unwrap();
        assert!(dump_rows(&p, 7, 2)
            .unwrap_err()
            .to_string()
            .contains("row 2"));
    }

    #[test]
    fn default_states_are_valid_windows() {
        let c = replay_case(
            &ShearCase::preset(
                crate::spec::shear::Preset::Ci,
                RollingModel::Epsd,
                0.5,
                0.0,
                1,
            )
            .unwrap(),
        )
        .unwrap();
        let s = default_states(&c, 6, 12, 20_000);
        assert_eq!(s.len(), 6);
        check_states(&c, &s, 12).unwrap();
        assert!(s[2] < c.compression_steps && s[3] > c.compression_steps);
        // a window across the start of shearing is refused
        assert!(check_states(&c, &[c.compression_steps - 5], 12).is_err());
    }
}
