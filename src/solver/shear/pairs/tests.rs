//! The pair pass's paths against each other: every SIMD path gives the scalar bits.

use super::super::ShearSim;
use super::*;
use crate::packing::loose_packing;
use crate::spec::shear::{Preset, ShearCase};
use crate::spec::RollingModel;

/// A dense sheared ci-preset state of `model` (mu_r 0.5, restitution `e`, eta_r `eta`
/// where it applies): compacted, then sheared so that contacts carry built-up, capped and
/// new histories.
fn sheared(model: RollingModel, e: f64, eta: f64) -> ShearSim {
    let eta = if model.has_damping() { eta } else { 0.0 };
    let c = ShearCase::preset(Preset::Ci, model, 0.5, eta, 2)
        .unwrap()
        .with_restitution("e", e)
        .unwrap();
    let mut s = ShearSim::new(&c, &loose_packing(&c));
    s.setup(0.0).unwrap();
    for _ in 0..c.compression_steps {
        s.step().unwrap();
    }
    s.setup(c.stages[0].speed).unwrap();
    for _ in 0..3000 {
        s.step().unwrap();
    }
    s
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

/// Each SIMD path this CPU runs against the scalar one over every listed pair of dense
/// sheared states of every rolling model, with and without history update, then 200
/// whole steps each: equal bits everywhere. Two materials: the paper's (e = 1, eta_r
/// 0.5) and a damped one without rolling dashpot (e = 0.5, eta_r 0), which take
/// different branches of the kernel.
#[test]
fn simd_passes_give_the_scalar_bits_on_dense_sheared_states() {
    let simd: Vec<_> = KernelPath::available()
        .into_iter()
        .filter(|&k| k != KernelPath::Scalar)
        .collect();
    for k in [KernelPath::Avx2, KernelPath::Avx512] {
        assert_eq!(k.checked("kernel").is_ok(), simd.contains(&k));
        if !simd.contains(&k) {
            // said, not passed over: this run does not test that path
            eprintln!(
                "{k:?} is not on this CPU: its pair pass is NOT tested by this run (only on a CPU that has it)"
            );
        }
    }
    if simd.is_empty() {
        // the scalar path is the only one here; the rest of the suite tests it
        eprintln!("neither AVX2 nor AVX-512 on this CPU: only the scalar path exists here");
        return;
    }
    for (model, e, eta, path) in RollingModel::ALL
        .into_iter()
        .flat_map(|m| [(m, 1.0, 0.5), (m, 0.5, 0.0)])
        .flat_map(|(m, e, eta)| simd.iter().map(move |&p| (m, e, eta, p)))
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
