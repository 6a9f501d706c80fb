//! The pair pass's paths against each other: every SIMD path gives the scalar bits.

use super::super::neighbor::NeighborList;
use super::super::records::PairContact;
use super::super::{compact, Packing, ShearSim};
use super::*;
use crate::packing::loose_packing;
use crate::solver::contact::models::RollingModel;
use crate::solver::vec3::V3;
use crate::spec::shear::{Preset, ShearCase};
use std::sync::OnceLock;

/// A dense sheared ci-preset state of `model` (mu_r 0.5, restitution `e`, eta_r `eta`
/// where it applies): the shared compacted box of restitution `e` ([`compacted`]) sheared
/// 3,000 steps with `model`, so that contacts carry built-up, capped and new histories.
fn sheared(model: RollingModel, e: f64, eta: f64) -> ShearSim {
    let eta = if model.has_damping() { eta } else { 0.0 };
    let c = ShearCase::preset(Preset::Ci, model, 0.5, eta, 2)
        .unwrap()
        .with_restitution("e", e)
        .unwrap();
    let mut s = ShearSim::new(&c.setup(), compacted(e));
    s.setup(c.stages[0].speed).unwrap();
    for _ in 0..3000 {
        s.step().unwrap();
    }
    s
}

/// The ci preset's box after its whole compression (epsd, mu_r 0.5, eta_r 0.5 at e = 1,
/// 0 at e = 0.5), made once per test process for each of the two restitutions the tests use
/// and shared by every model's sheared state: each of the 15 sheared states compacted its
/// own box before, four fifths of their steps and most of this file's time.
fn compacted(e: f64) -> &'static Packing {
    static BOXES: [OnceLock<Packing>; 2] = [OnceLock::new(), OnceLock::new()];
    let (cell, eta) = match e {
        1.0 => (&BOXES[0], 0.5),
        0.5 => (&BOXES[1], 0.0),
        _ => panic!("the shared compacted boxes are of e = 1 and e = 0.5, not {e}"),
    };
    cell.get_or_init(|| {
        let c = ShearCase::preset(Preset::Ci, RollingModel::Epsd, 0.5, eta, 2)
            .unwrap()
            .with_restitution("e", e)
            .unwrap();
        compact(&c.setup(), &loose_packing(&c), c.compression_steps).unwrap()
    })
}

/// sysfs spells cache sizes with a unit letter; anything else is not a size.
#[test]
fn cache_sizes_parse() {
    assert_eq!(parse_cache_size("1024K\n"), Some(1 << 20));
    assert_eq!(parse_cache_size("2M"), Some(2 << 20));
    assert_eq!(parse_cache_size("65536"), Some(65536));
    assert_eq!(parse_cache_size("big"), None);
    assert!(!prefetch_pays(2500) || l2_bytes() < 2500 * 144);
}

/// With many members a particle can have pairs in three blocks or more: the block of its
/// first pair sums the prefix of its pair sum, the later blocks' increments are added
/// from `out` ([`BlockPlan::first`]). One force evaluation of a dense sheared state on 1
/// and on 7 threads: equal bits, with such particles present.
#[test]
fn pair_sums_across_three_blocks_give_the_serial_bits() {
    let base = sheared(RollingModel::Epsd, 1.0, 0.5);
    let on = |threads: usize| {
        crate::solver::team::on_threads(threads, || {
            let mut s = base.clone();
            s.evaluate_forces().unwrap();
            s
        })
    };
    let (one, seven) = (on(1), on(7));
    let (nl, cut) = (&seven.nl, &seven.plan.cut);
    assert_eq!(cut.len(), 8, "one block per member");
    let blocks = |q: usize| {
        let entries = &nl.entries[nl.start[q] as usize..nl.start[q + 1] as usize];
        let mut b: Vec<usize> = entries
            .iter()
            .map(|&(k, _)| block_of(cut, k as usize))
            .collect();
        b.dedup();
        b.len()
    };
    let spread = (0..seven.x.len()).filter(|&q| blocks(q) >= 3).count();
    assert!(spread > 0, "no particle with pairs in three blocks");
    let bits = |s: &ShearSim| {
        let v: Vec<u64> = (s.f.iter().chain(&s.torque))
            .flatten()
            .chain(s.top_force.iter().chain(&s.bottom_force))
            .map(|x| x.to_bits())
            .collect();
        v
    };
    assert!(bits(&one) == bits(&seven), "7 threads differ from 1");
    assert!(one.f.iter().flatten().any(|&x| x != 0.0));
}

/// The AVX2 pass against the scalar one (see [`simd_pass_gives_the_scalar_bits`]).
#[test]
#[cfg_attr(
    not(path_avx2),
    ignore = "the AVX2 path does not run here (no AVX2, or DEM_VERIFY_MAX_KERNEL)"
)]
fn avx2_pass_gives_the_scalar_bits_on_dense_sheared_states() {
    simd_pass_gives_the_scalar_bits(KernelPath::Avx2);
}

/// The AVX-512 pass against the scalar one (see [`simd_pass_gives_the_scalar_bits`]).
#[test]
#[cfg_attr(
    not(path_avx512),
    ignore = "the AVX-512 path does not run here (no AVX-512F/DQ, or DEM_VERIFY_MAX_KERNEL)"
)]
fn avx512_pass_gives_the_scalar_bits_on_dense_sheared_states() {
    simd_pass_gives_the_scalar_bits(KernelPath::Avx512);
}

/// A SIMD path against the scalar one over every listed pair of dense sheared states of
/// every rolling model, with and without history update, then 200 whole steps each: equal
/// bits everywhere. Two materials: the paper's (e = 1, eta_r 0.5) and a damped one without
/// rolling dashpot (e = 0.5, eta_r 0), which take different branches of the kernel. A path
/// that does not run here is the calling test's `ignore` (build.rs), so here it must run.
fn simd_pass_gives_the_scalar_bits(path: KernelPath) {
    assert!(
        path.runs_here(),
        "{path:?} was built to be tested here but does not run here (another CPU, or \
         DEM_VERIFY_MAX_KERNEL changed without a rebuild)"
    );
    for (model, e, eta) in RollingModel::ALL
        .into_iter()
        .flat_map(|m| [(m, 1.0, 0.5), (m, 0.5, 0.0)])
    {
        let mut base = sheared(model, e, eta);
        // contacts that start now (zero history) besides the built-up ones: every 7th pair
        for h in base.nl.hist.iter_mut().step_by(7) {
            *h = Default::default();
        }
        let (mut touching, mut sliding, mut mobilised, mut fresh) = (0, 0, 0, 0);
        for update in [true, false] {
            let mut a = base.clone();
            let mut b = base.clone();
            a.set_kernel(KernelPath::Scalar).unwrap();
            b.set_kernel(path).unwrap();
            // the next piece's records prefetched or not (a few thousand particles
            // are too few for it to pay): the same bits either way
            b.plan.prefetch = Some(update);
            a.record_pair_forces = true;
            b.record_pair_forces = true;
            a.compute_forces(update).unwrap();
            b.compute_forces(update).unwrap();
            assert_eq!(a.nl.pairs.len(), b.nl.pairs.len());
            for k in 0..a.nl.pairs.len() {
                let (pa, pb) = (&a.nl.hist[k], &b.nl.hist[k]);
                let bits = |h: &crate::solver::contact::ContactHistory| {
                    (h.shear.map(f64::to_bits), h.r_torque.map(f64::to_bits))
                };
                assert_eq!(bits(pa), bits(pb), "{model:?} pair {k} history");
                let fb = |f: &(ForceData, ForceData)| {
                    [f.0.delta_f, f.0.delta_torque, f.1.delta_f, f.1.delta_torque]
                        .map(|v| v.map(f64::to_bits))
                };
                assert_eq!(
                    fb(&a.pair_force[k]),
                    fb(&b.pair_force[k]),
                    "{model:?} pair {k} forces"
                );
                let (xa, xb) = (&a.pair_state[k], &b.pair_state[k]);
                assert_eq!(xa, xb, "{model:?} pair {k} state");
                assert_eq!(a.pair_damp.len(), b.pair_damp.len());
                // the dashpot slots are held by epsd_implicit only
                assert_eq!(a.pair_damp.is_empty(), model != RollingModel::EpsdImplicit);
                if let (Some(da), Some(db)) = (a.pair_damp.get(k), b.pair_damp.get(k)) {
                    assert_eq!(da.damping.to_bits(), db.damping.to_bits());
                    assert_eq!(da.en.map(f64::to_bits), db.en.map(f64::to_bits));
                }
                if update && xa.contact != PairContact::Apart {
                    touching += 1;
                    sliding += usize::from(xa.sliding);
                    mobilised += usize::from(xa.contact == PairContact::RollingMobilised);
                    fresh += usize::from(base.nl.hist[k] == Default::default());
                }
            }
            assert_eq!(a.f.len(), b.f.len());
            for (fa, fb) in a.f.iter().zip(&b.f) {
                assert_eq!(fa.map(f64::to_bits), fb.map(f64::to_bits));
            }
        }
        // the states exercise what the kernel branches on
        assert!(touching > 200, "{model:?}: {touching} touching pairs");
        assert!(sliding > 0, "{model:?}: no sliding contact");
        assert!(fresh > 0, "{model:?}: no new contact");
        if model != RollingModel::Off {
            assert!(mobilised > 0, "{model:?}: no contact at the rolling limit");
        }
        let mut a = base.clone();
        let mut b = base;
        a.set_kernel(KernelPath::Scalar).unwrap();
        b.set_kernel(path).unwrap();
        b.plan.prefetch = Some(true);
        for _ in 0..200 {
            a.step().unwrap();
            b.step().unwrap();
        }
        for (xa, xb) in a.x.iter().zip(&b.x).chain(a.omega.iter().zip(&b.omega)) {
            assert_eq!(xa.map(f64::to_bits), xb.map(f64::to_bits), "{model:?}");
        }
        eprintln!(
            "{} {model:?}, e {e}, eta_r {eta}: {touching} touching, {sliding} sliding, {mobilised} at the \
             rolling limit, {fresh} new: equal bits",
            path.name()
        );
    }
}

/// The pair pass on a subset of the particles: `ids` (increasing global indices) gathered
/// into local arrays in that order, the neighbour list built anew from them, each pair's
/// history taken from `s`'s list by the pair's global ids (turned round where the pair did),
/// then one pass (history updated) on one thread. Returns the list and each local particle's
/// pair sum.
fn pass_on(s: &ShearSim, ids: &[usize], path: KernelPath) -> (NeighborList, Vec<ForceData>) {
    let team = crate::solver::team::Team::new(1);
    let g3 = |a: &[[f64; 3]]| -> Vec<[f64; 3]> { ids.iter().map(|&i| a[i]).collect() };
    let g1 = |a: &[f64]| -> Vec<f64> { ids.iter().map(|&i| a[i]).collect() };
    let (x, v, omega, radius, mass) =
        (g3(&s.x), g3(&s.v), g3(&s.omega), g1(&s.radius), g1(&s.mass));
    let mut nl = NeighborList::default();
    nl.build(&team, &x, &radius, s.skin, s.box_);
    let key = |a: usize, b: usize| (a.min(b), a.max(b));
    let before: std::collections::BTreeMap<_, _> =
        s.nl.pairs
            .iter()
            .zip(&s.nl.hist)
            .map(|(p, h)| (key(p.i as usize, p.j as usize), (p.i as usize, *h)))
            .collect();
    for (p, h) in nl.pairs.iter().zip(nl.hist.iter_mut()) {
        let (gi, gj) = (ids[p.i as usize], ids[p.j as usize]);
        if let Some(&(old_i, old)) = before.get(&key(gi, gj)) {
            *h = if old_i == gi { old } else { old.turned_round() };
        }
    }
    let packed: Vec<Packed> = if path == KernelPath::Scalar {
        Vec::new()
    } else {
        (0..x.len())
            .map(|k| Packed::new(x[k], radius[k], v[k], mass[k], omega[k]))
            .collect()
    };
    let np = nl.pairs.len();
    let (mut out, mut state) = (Vec::new(), vec![Default::default(); np]);
    let mut damp = if s.implicit {
        vec![Default::default(); np]
    } else {
        Vec::new()
    };
    let mut acc = vec![ForceData::default(); x.len()];
    let generation = nl.generation;
    let NeighborList {
        pairs,
        hist,
        start,
        entries,
        ..
    } = &mut nl;
    let sums = pass(
        &team,
        path,
        pairs,
        Csr { start, entries },
        hist,
        &mut out,
        &mut state,
        &mut damp,
        &mut acc,
        Particles {
            x: &x,
            v: &v,
            omega: &omega,
            radius: &radius,
            mass: &mass,
            packed: &packed,
        },
        &s.params,
        true,
        false,
        &|_| {},
        &mut BlockPlan::default(),
        generation,
    );
    assert!(sums == Sums::Accumulated);
    (nl, acc)
}

/// Domain decomposition (issue #39) rests on this: a particle's pair sum is the sum of its
/// pairs' increments in the order of its partners' ids, and a pair's increments depend on the
/// two particles and the pair's history only. So a rank that holds its own particles and the
/// others within the cutoff of its brick (ghosts, periodic images included), in increasing
/// id, lists their pairs itself and gets its own particles' sums and their pairs' histories
/// bit for bit as one process does. Checked on a dense sheared state split into bricks of
/// 2 and 3 along x, 2 along z, 2 x 2 along x and z, 2 and 3 across the gap and 2 x 2 along x
/// and across the gap, on every kernel path this CPU runs.
#[test]
fn bricks_with_ghosts_give_each_owned_particle_the_bits_of_one_process() {
    let base = sheared(RollingModel::Epsd, 1.0, 0.5);
    let n = base.x.len();
    let all: Vec<usize> = (0..n).collect();
    let rmax = base.radius.iter().cloned().fold(0.0, f64::max);
    let cut = 2.0 * rmax + base.skin;
    for path in KernelPath::available() {
        let (gnl, gacc) = pass_on(&base, &all, path);
        let gkey = |p: &Pair| (p.i.min(p.j) as usize, p.i.max(p.j) as usize);
        let global: std::collections::BTreeMap<_, _> = gnl
            .pairs
            .iter()
            .zip(&gnl.hist)
            .map(|(p, h)| (gkey(p), (*p, *h)))
            .collect();
        for [nx, ny, nz] in [
            [2usize, 1, 1],
            [3, 1, 1],
            [1, 1, 2],
            [2, 1, 2],
            [1, 2, 1],
            [1, 3, 1],
            [2, 2, 1],
        ] {
            let bricks = super::super::decompose::bricks_of([nx, ny, nz], &base);
            let mut owned_total = 0;
            let mut crossing = 0;
            for b in 0..bricks.count() {
                let (local, _) = bricks.members(b, &base.x, cut);
                let owns = |q: usize| bricks.owner(base.x[q]) == b;
                let (lnl, lacc) = pass_on(&base, &local, path);
                let mut mine = 0;
                for (a, &q) in local.iter().enumerate() {
                    if !owns(q) {
                        continue;
                    }
                    mine += 1;
                    let bits =
                        |f: &ForceData| [f.delta_f, f.delta_torque].map(|v| v.map(f64::to_bits));
                    assert_eq!(
                        bits(&lacc[a]),
                        bits(&gacc[q]),
                        "{path:?}, {nx}x{ny}x{nz} bricks, brick {b}: particle {q}"
                    );
                }
                owned_total += mine;
                // the brick lists every pair of its own particles, as one process does,
                // with the same orientation, image shift and updated history
                let mut listed = 0;
                for (p, h) in lnl.pairs.iter().zip(&lnl.hist) {
                    let (gi, gj) = (local[p.i as usize], local[p.j as usize]);
                    if !owns(gi) && !owns(gj) {
                        continue;
                    }
                    listed += 1;
                    crossing += usize::from(owns(gi) != owns(gj));
                    let (gp, gh) = global[&(gi.min(gj), gi.max(gj))];
                    assert_eq!((gp.i as usize, gp.j as usize), (gi, gj));
                    assert_eq!(gp.shift.map(f64::to_bits), p.shift.map(f64::to_bits));
                    assert_eq!(
                        (gh.shear.map(f64::to_bits), gh.r_torque.map(f64::to_bits)),
                        (h.shear.map(f64::to_bits), h.r_torque.map(f64::to_bits)),
                    );
                }
                let expected = global.keys().filter(|&&(a, b)| owns(a) || owns(b)).count();
                assert_eq!(listed, expected, "{nx}x{ny}x{nz} brick {b}: pairs");
            }
            assert_eq!(owned_total, n, "every particle owned once");
            assert!(
                crossing > 100,
                "{nx}x{ny}x{nz}: {crossing} pairs across bricks"
            );
        }
        assert!(gacc.iter().any(|f| f.delta_f != [0.0; 3]));
        eprintln!(
            "{}: every brick's own particles have one process's bits",
            path.name()
        );
    }
}

/// The plate forces of a decomposed state: each brick's exact sum of its own particles with
/// plate candidates ([`super::super::exact::PlateSum`]), the bricks' sums added through their
/// limbs in any order (an MPI_SUM all-reduce), are one process's plate forces bit for bit,
/// for every split (epsd_implicit, whose force pass keeps each particle's plate force); the
/// same shares added in f64 brick by brick are not (what the exact sum is for).
#[test]
fn plate_forces_summed_exactly_over_bricks_are_one_process_bits() {
    use super::super::exact::{self, PlateSum, LIMB_LEN};
    let mut s = sheared(RollingModel::EpsdImplicit, 1.0, 0.5);
    s.evaluate_forces().unwrap();
    let one = (s.bottom_force, s.top_force);
    assert!(one.0[1] != 0.0 && one.1[1] != 0.0, "{one:?}");
    let bits = |f: (V3, V3)| (f.0.map(f64::to_bits), f.1.map(f64::to_bits));
    let with_candidates = |q: usize| s.wall_start[q] != s.wall_start[q + 1];
    let mut f64_differs = 0;
    for n in [
        [1usize, 1, 1],
        [2, 1, 1],
        [3, 1, 1],
        [2, 1, 2],
        [4, 1, 3],
        [1, 2, 1],
        [2, 2, 1],
    ] {
        let bricks = super::super::decompose::bricks_of(n, &s);
        let shares: Vec<Vec<(V3, V3)>> = (0..bricks.count())
            .map(|b| {
                (0..s.x.len())
                    .filter(|&q| bricks.owner(s.x[q]) == b && with_candidates(q))
                    .map(|q| s.wall_force[q])
                    .collect()
            })
            .collect();
        assert!(shares.iter().filter(|v| !v.is_empty()).count() == bricks.count());
        let mut words = [0u64; LIMB_LEN];
        for v in shares.iter().rev() {
            for (w, l) in words.iter_mut().zip(exact::sum(v.iter().copied()).limbs()) {
                *w += l;
            }
        }
        let total = PlateSum::from_limbs(&words).totals().unwrap();
        assert_eq!(bits(total), bits(one), "{n:?}");
        // the same terms summed in f64 brick by brick, then the bricks' sums
        let by_brick = shares
            .iter()
            .fold(([0.0; 3], [0.0; 3]), |(mut b, mut t), v| {
                let (mut pb, mut pt) = ([0.0; 3], [0.0; 3]);
                for (fb, ft) in v {
                    for c in 0..3 {
                        pb[c] += fb[c];
                        pt[c] += ft[c];
                    }
                }
                for c in 0..3 {
                    b[c] += pb[c];
                    t[c] += pt[c];
                }
                (b, t)
            });
        if bits(by_brick) != bits(one) {
            f64_differs += 1;
        }
    }
    // measured: the f64 sums differ from the exact one in the last bits for most splits
    assert!(f64_differs > 0, "no split showed why the sum is exact");
}
