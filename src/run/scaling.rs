//! The scaling model of a decomposed run (issue #39, docs/mpi.md): what `verify bench`
//! predicts for rank counts this machine cannot run, from what it measured.
//!
//! The time of one step on R ranks is the slowest brick's:
//!
//! ```text
//! T(R) = max_b [ t_pair P_b + t_part (N_b + G_b) ] + alpha M_b + beta_inv B_b
//! ```
//!
//! - `P_b` pairs with an own member (a pair across two bricks is computed by both), `N_b` own
//!   particles, `G_b` ghosts (drifted, listed and sent like own ones): the [`Census`] of the
//!   bench's dense state split as the bricks split it;
//! - `t_pair`, `t_part`: the costs per pair (pair pass, sums and walls) and per particle
//!   (integration, neighbour lists, plates) of the 1-rank run of the same bench, from its
//!   phase times (by construction they give back its time per step);
//! - `M_b` messages per step, `B_b` bytes per step a brick receives: every step the ghosts'
//!   positions from the neighbouring bricks (72 bytes per ghost, one message per neighbour)
//!   and one all-reduce (the skin flag and the last step's plate forces' exact sum, 216
//!   bytes: about log2 R messages; two, of 8 and 208 bytes, until 2026-12-06), and a
//!   rebuild's messages amortised over the measured steps
//!   between rebuilds: two all-reduces (the divergence check, the check that no particle
//!   went beyond the neighbouring bricks) and, to each neighbouring brick, the migrants and
//!   the ghosts (each a message of lengths and one of numbers);
//! - `alpha` (latency per message) and `beta_inv` (time per byte): this machine's, measured
//!   by the bench's link probe under `mpirun` ([`Link`]), or a cluster's, assumed.
//!
//! The model also gives the design before (a rebuild's migrants and ghosts by all-to-alls,
//! R - 1 messages each of sizes and of records, until 2026-12-06): what the neighbour-only
//! rebuild bought, as its predictions said before it was made. Until 2026-12-06 every step
//! also made two all-to-alls (a flag in every message) and every brick received every plate
//! particle's force share to add them in id order (1.3 MB a step at 250,000 particles); the
//! exact sum ([`crate::solver::shear::exact`]) and neighbour-only step messages replaced
//! them.

use crate::solver::shear::bricks::Bricks;
use crate::solver::shear::decompose::{censuses, Census, Link};
use crate::solver::shear::{PhaseTimes, ShearSim};
use serde::{Deserialize, Serialize};

/// A cluster's link, assumed (not measured here): an InfiniBand HDR-class network, 1.5 us
/// per message and 10 GB/s.
pub const CLUSTER: Link = Link {
    ranks: 0,
    latency_s: 1.5e-6,
    seconds_per_byte: 1.0e-10,
};

/// A rebuild's all-reduces (about log2 R messages each): the divergence check and the
/// check that no migrant goes beyond the neighbouring bricks
/// ([`crate::solver::shear::decompose`]).
const REBUILD_REDUCES: f64 = 2.0;
/// A rebuild's messages to each neighbouring brick: the migrants and the ghosts, each a
/// message of lengths and one of numbers.
const REBUILD_NEIGHBOUR_MESSAGES: f64 = 4.0;
/// Before 2026-12-06: the migrants and the ghosts each by an all-to-all of sizes and one of
/// records (R - 1 messages each), after the divergence check's all-reduce.
const REBUILD_ALL_TO_ALL_CALLS: f64 = 4.0;

/// Bytes per ghost sent every step: position, velocity, angular velocity.
const GHOST_BYTES: f64 = 72.0;
/// Bytes of a step's all-reduce: the plate forces' exact sum
/// ([`crate::solver::shear::exact::LIMB_LEN`] words), an error count and the skin flag.
const REDUCE_BYTES: f64 = 8.0 * (crate::solver::shear::exact::LIMB_LEN as f64 + 2.0);
/// A step's all-reduces: one (the plate sum waits for the next step's skin flag,
/// [`crate::solver::shear::decompose`]); the design before had two.
const STEP_REDUCES: f64 = 1.0;
const STEP_REDUCES_BEFORE: f64 = 2.0;

/// The costs a 1-rank run measured.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Costs {
    /// Seconds per listed pair per step (pair pass, sums, walls).
    pub per_pair_s: f64,
    /// Seconds per particle per step (integration, neighbour lists, plates).
    pub per_particle_s: f64,
    /// Steps between neighbour rebuilds.
    pub steps_per_rebuild: f64,
}

impl Costs {
    /// From a 1-rank run's phases over `pairs` listed pairs and `particles` particles.
    pub fn of(p: &PhaseTimes, pairs: usize, particles: usize, rebuilds: u64) -> Option<Costs> {
        if p.steps == 0 || pairs == 0 || particles == 0 {
            return None;
        }
        let per_step = |s: f64| s / p.steps as f64;
        Some(Costs {
            per_pair_s: per_step(p.pairs + p.sum_walls) / pairs as f64,
            per_particle_s: per_step(p.integrate + p.neighbor + p.plates) / particles as f64,
            steps_per_rebuild: p.steps as f64 / rebuilds.max(1) as f64,
        })
    }
}

/// One rank count's prediction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScalePoint {
    pub ranks: usize,
    /// Bricks along x, across the gap (y) and along z.
    pub bricks: [usize; 3],
    /// Own particles of the fullest brick.
    pub particles_per_rank: usize,
    /// Ghosts over own particles, the brick with the most ghosts.
    pub ghost_fraction: f64,
    /// The slowest brick's pairs over the mean share of one process's pairs (1: no overhead).
    pub pair_overhead: f64,
    /// Bytes a brick receives per step (the most of any).
    pub bytes_per_step: f64,
    /// Messages a brick sends per step as built, and with a rebuild's migrants and ghosts by
    /// all-to-alls (the design before 2026-12-06).
    pub messages_built: f64,
    pub messages_all_to_all: f64,
    /// Compute time per step of the slowest brick [s].
    pub compute_s: f64,
    /// Predicted time per step [s]: as built, on this machine's link (None without a probe)
    /// and on [`CLUSTER`]'s; and with all-to-all rebuilds on [`CLUSTER`]'s.
    pub here_built_s: Option<f64>,
    pub cluster_built_s: f64,
    pub cluster_all_to_all_s: f64,
}

/// The model's predictions and its check against what this machine ran.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scaling {
    pub particles: usize,
    pub costs: Costs,
    pub link: Option<Link>,
    pub cluster: Link,
    /// One process's time per step [s] (the model's, equal to the 1-rank run's).
    pub one_rank_s: f64,
    pub points: Vec<ScalePoint>,
    /// Rank counts left out: bricks narrower than the ghost cut.
    pub too_thin: Vec<usize>,
}

/// What the model is fitted to: one process's costs, and its state's census at each rank
/// count (taken where the state is, so that the state need not be kept).
#[derive(Clone, Debug)]
pub struct Fit {
    particles: usize,
    pairs: usize,
    costs: Costs,
    splits: Vec<(Bricks, Census)>,
    too_thin: Vec<usize>,
}

/// The [`Fit`] over `ranks` of the state `s` (one process's, as its last rebuild left it).
pub fn fit(s: &ShearSim, costs: Costs, ranks: &[usize]) -> Fit {
    let (splits, too_thin) = censuses(s, ranks);
    Fit {
        particles: s.particle_count(),
        pairs: s.listed_pairs(),
        costs,
        splits,
        too_thin,
    }
}

/// The model's predictions from a [`Fit`], on `link` (this machine's, if measured) and on
/// [`CLUSTER`]'s.
pub fn model(f: &Fit, link: Option<Link>) -> Scaling {
    let (n, pairs_total, costs) = (f.particles, f.pairs, f.costs);
    let points = f
        .splits
        .iter()
        .map(|(b, c)| point(c, [b.nx, b.ny, b.nz], costs, link, pairs_total))
        .collect();
    Scaling {
        particles: n,
        costs,
        link,
        cluster: CLUSTER,
        one_rank_s: costs.per_pair_s * pairs_total as f64 + costs.per_particle_s * n as f64,
        points,
        too_thin: f.too_thin.clone(),
    }
}

fn point(
    c: &Census,
    bricks: [usize; 3],
    k: Costs,
    link: Option<Link>,
    pairs_total: usize,
) -> ScalePoint {
    let r = c.own.len();
    let others = (r - 1) as f64;
    let neighbours = if r == 1 {
        0.0
    } else {
        // a brick's neighbours in a split of nx x ny x nz (fewer where an axis has one or two
        // slabs; across the gap a middle slab's two, as along a periodic axis of 3 or more)
        let side = |n: usize| (n.min(3) - 1) as f64;
        bricks.iter().map(|&n| side(n) + 1.0).product::<f64>() - 1.0
    };
    let log_r = (r as f64).log2();
    // a lone brick exchanges nothing
    let (messages_built, messages_all_to_all) = if r == 1 {
        (0.0, 0.0)
    } else {
        let rebuild = |m: f64| m / k.steps_per_rebuild;
        (
            neighbours
                + STEP_REDUCES * log_r
                + rebuild(REBUILD_REDUCES * log_r + REBUILD_NEIGHBOUR_MESSAGES * neighbours),
            neighbours
                + STEP_REDUCES_BEFORE * log_r
                + rebuild(log_r + REBUILD_ALL_TO_ALL_CALLS * others),
        )
    };
    // each brick's compute time, and bytes received per step
    let per_brick: Vec<(f64, f64)> = (0..r)
        .map(|b| {
            let compute = k.per_pair_s * c.pairs[b] as f64
                + k.per_particle_s * (c.own[b] + c.ghosts[b]) as f64;
            if r == 1 {
                return (compute, 0.0);
            }
            (
                compute,
                GHOST_BYTES * c.ghosts[b] as f64 + REDUCE_BYTES * log_r,
            )
        })
        .collect();
    let slowest = |l: &Link, messages: f64| {
        per_brick
            .iter()
            .map(|&(t, bytes)| t + l.latency_s * messages + l.seconds_per_byte * bytes)
            .fold(0.0, f64::max)
    };
    let compute_s = per_brick.iter().map(|b| b.0).fold(0.0, f64::max);
    let bytes_per_step = per_brick.iter().map(|b| b.1).fold(0.0, f64::max);
    let most = |v: &[usize]| v.iter().copied().max().unwrap_or(0);
    let ghost_fraction = (0..r)
        .map(|b| c.ghosts[b] as f64 / c.own[b].max(1) as f64)
        .fold(0.0, f64::max);
    ScalePoint {
        ranks: r,
        bricks,
        particles_per_rank: most(&c.own),
        ghost_fraction,
        pair_overhead: most(&c.pairs) as f64 / (pairs_total as f64 / r as f64),
        bytes_per_step,
        messages_built,
        messages_all_to_all,
        compute_s,
        here_built_s: link.map(|l| slowest(&l, messages_built)),
        cluster_built_s: slowest(&CLUSTER, messages_built),
        cluster_all_to_all_s: slowest(&CLUSTER, messages_all_to_all),
    }
}

/// The table `verify bench` prints.
pub fn table(s: &Scaling) -> Vec<String> {
    let mut out = vec![format!(
        "  scaling model ({} particles; {:.1} ns per pair, {:.1} ns per particle, a rebuild every \
         {:.0} steps; link here {}; cluster assumed {:.1} us per message, {:.0} GB/s):",
        s.particles,
        s.costs.per_pair_s * 1e9,
        s.costs.per_particle_s * 1e9,
        s.costs.steps_per_rebuild,
        s.link
            .map(|l| format!(
                "{:.2} us per message, {:.1} GB/s (measured, {} ranks)",
                l.latency_s * 1e6,
                1e-9 / l.seconds_per_byte.max(1e-15),
                l.ranks
            ))
            .unwrap_or_else(|| "not measured (no ranks run)".into()),
        s.cluster.latency_s * 1e6,
        1e-9 / s.cluster.seconds_per_byte
    )];
    out.push(
        "    ranks    bricks  particles/rank  ghosts/own  pair overhead  kB/step  msgs/step  \
         speedup here  cluster as built  cluster, all-to-all rebuilds (before)"
            .into(),
    );
    for p in &s.points {
        let speed = |t: f64| {
            format!(
                "{:.1}x ({:.0} %)",
                s.one_rank_s / t,
                100.0 * s.one_rank_s / t / p.ranks as f64
            )
        };
        out.push(format!(
            "    {:>5}  {:>8}  {:>14}  {:>10.3}  {:>13.3}  {:>7.1}  {:>9.1}  {:>12}  {:>16}  {:>37}",
            p.ranks,
            format!("{}x{}x{}", p.bricks[0], p.bricks[1], p.bricks[2]),
            p.particles_per_rank,
            p.ghost_fraction,
            p.pair_overhead,
            p.bytes_per_step / 1e3,
            p.messages_built,
            p.here_built_s.map(speed).unwrap_or_else(|| "-".into()),
            speed(p.cluster_built_s),
            speed(p.cluster_all_to_all_s),
        ));
    }
    if !s.too_thin.is_empty() {
        out.push(format!(
            "    not modelled (bricks narrower than the ghost cut): {:?} ranks",
            s.too_thin
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::shear::tests::fast_dense;

    /// The costs give back the 1-rank run's time per step; one brick exchanges nothing and
    /// takes that time; two bricks exchange as built (one ghost message and one all-reduce
    /// a step, the rebuild's messages amortised) and receive the ghosts' bytes and the
    /// all-reduces'; the all-to-all rebuilds of before sent more messages beyond a few
    /// bricks.
    #[test]
    fn the_model_gives_back_what_it_was_fitted_to() {
        let (c, dense) = fast_dense();
        let mut s = ShearSim::new(&c.setup(), dense);
        s.setup(c.stages[0].speed).unwrap();
        s.time_phases(true);
        for _ in 0..300 {
            s.step().unwrap();
        }
        let p = s.phase_times().unwrap();
        let (n, pairs) = (s.particle_count(), s.listed_pairs());
        let k = Costs::of(&p, pairs, n, 3).unwrap();
        assert_eq!(k.steps_per_rebuild, 100.0);
        let per_step = (p.pairs + p.sum_walls + p.integrate + p.neighbor + p.plates) / 300.0;
        let link = Link {
            ranks: 2,
            latency_s: 1e-6,
            seconds_per_byte: 1e-9,
        };
        let m = model(&fit(&s, k, &[1, 2]), Some(link));
        assert!((m.one_rank_s / per_step - 1.0).abs() < 1e-9);
        let (one, two) = (&m.points[0], &m.points[1]);
        assert_eq!((one.messages_built, one.bytes_per_step), (0.0, 0.0));
        assert!((one.here_built_s.unwrap() / m.one_rank_s - 1.0).abs() < 1e-9);
        // 2 x 1 bricks: one neighbour, one all-reduce of one message; a rebuild every 100
        // steps: two all-reduces and 4 messages to the neighbour (before: two all-reduces a
        // step, and at a rebuild one all-reduce and 4 all-to-alls of one message each)
        assert_eq!(two.messages_built, 1.0 + 1.0 + (2.0 + 4.0) / 100.0);
        assert_eq!(two.messages_all_to_all, 1.0 + 2.0 + (1.0 + 4.0) / 100.0);
        let (splits, _) = censuses(&s, &[2]);
        let cen = &splits[0].1;
        let bytes = (0..2)
            .map(|b| GHOST_BYTES * cen.ghosts[b] as f64 + REDUCE_BYTES)
            .fold(0.0, f64::max);
        assert_eq!(two.bytes_per_step, bytes);
        assert!(two.compute_s < m.one_rank_s && two.compute_s > 0.5 * m.one_rank_s);
        let m = model(&fit(&s, k, &[2, 16]), Some(link));
        let (two, sixteen) = (&m.points[0], &m.points[1]);
        // 16 bricks: 8 neighbours each, against 15 other bricks for an all-to-all
        assert!(sixteen.messages_built < sixteen.messages_all_to_all);
        assert!(sixteen.cluster_built_s < sixteen.cluster_all_to_all_s);
        assert!(two.cluster_built_s > 0.0);
    }
}
