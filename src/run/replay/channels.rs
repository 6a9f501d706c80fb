//! The comparison of one replayed step: both codes' atoms, contacts and plate forces gathered
//! into the same per-item form ([`Side`]) and compared channel by channel ([`compare`]); which
//! channels are judged ([`JUDGED`]) and which check the kernel alone.

use super::dumps::{v3, Dumped};
use super::outcome::ChannelError;
use crate::error::Result;
use crate::solver::contact::ContactHistory;
use crate::solver::shear::replay::{PairObservation, WallObservation};
use crate::solver::shear::ShearSim;
use crate::solver::vec3::V3;
use std::collections::BTreeMap;

pub(super) fn norm(a: V3) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

pub(super) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Accumulates one channel: worst |a - b| and the peak of |a|, |b|.
#[derive(Default)]
pub(super) struct Acc {
    pub(super) err: f64,
    pub(super) peak: f64,
    pub(super) worst: String,
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
pub(super) type ContactValues = (V3, V3, ContactHistory, String);

/// One side of a comparison: particles, contacts keyed as LIGGGHTS keys them, plate forces.
pub(super) struct Side {
    pub(super) x: Vec<V3>,
    pub(super) v: Vec<V3>,
    pub(super) omega: Vec<V3>,
    pub(super) f: Vec<V3>,
    pub(super) torque: Vec<V3>,
    pub(super) pairs: BTreeMap<(u32, u32), ContactValues>,
    pub(super) walls: BTreeMap<(u32, u8, u32), ContactValues>,
    pub(super) top: V3,
    pub(super) bottom: V3,
}

pub(super) fn pair_kind(o: &PairObservation) -> String {
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
pub(super) fn native_side(
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

pub(super) fn liggghts_side(d: &Dumped, thermo: &[f64], kinds: &Side) -> Side {
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
pub(super) fn compare(a: &Side, b: &Side) -> Vec<ChannelError> {
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
pub(super) fn contact_channels<K: Ord>(
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
pub(super) const KERNEL: [&str; 7] = [
    "pair_force",
    "pair_torque",
    "periodic_pair_force",
    "periodic_pair_torque",
    "wall_force",
    "wall_torque",
    "contact_set",
];

/// The judged channel with the largest error.
pub(super) fn worst(ch: &[ChannelError]) -> ChannelError {
    ch.iter()
        .filter(|c| JUDGED.contains(&c.channel.as_str()))
        .max_by(|a, b| a.max_rel_err.total_cmp(&b.max_rel_err))
        .cloned()
        .unwrap_or_default()
}

/// Largest error over the judged channels (the chaos envelope).
pub(super) fn max_judged(ch: &[ChannelError]) -> f64 {
    ch.iter()
        .filter(|c| JUDGED.contains(&c.channel.as_str()))
        .map(|c| c.max_rel_err)
        .fold(0.0, f64::max)
}
