//! Micro-benchmarks (criterion) of the hot kernels: one contact evaluation per rolling model,
//! the neighbour-list build of a 2500-particle sample, and the sphere-triangle test.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use dem_verify::packing::{loose_packing, SplitMix64};
use dem_verify::solver::contact::{surfaces_intersect, ContactData, ContactHistory};
use dem_verify::solver::material::sphere_mass;
use dem_verify::solver::shear::neighbor::{NeighborList, Periodic};
use dem_verify::solver::shear::plate::{plate_triangles, Plate, Side};
use dem_verify::solver::shear::{compact, KernelPath, ShearSim};
use dem_verify::solver::team::Team;
use dem_verify::solver::trimesh::TriMesh;
use dem_verify::spec::shear::ShearCase;
use dem_verify::spec::RollingModel;

fn contact(c: &mut Criterion) {
    for model in [
        RollingModel::Off,
        RollingModel::Cdt,
        RollingModel::Epsd,
        RollingModel::Epsd2,
        RollingModel::Epsd3,
    ] {
        let case = ShearCase::preset(
            dem_verify::spec::shear::Preset::Fast,
            model,
            0.5,
            if model.has_damping() { 0.5 } else { 0.0 },
            1,
        )
        .unwrap();
        let p = case.material.pair_params(&case.models, case.dt);
        let m = sphere_mass(1.5e-4, 2e6);
        let dz = 2.999e-4;
        let base = ContactData {
            radi: 1.5e-4,
            radj: 1.5e-4,
            radsum: 3e-4,
            r: dz,
            rinv: 1.0 / dz,
            delta: [0.0, 0.0, dz],
            en: [0.0, 0.0, 1.0],
            meff: 0.5 * m,
            mi: m,
            mj: m,
            v_i: [1e-3, 0.0, -1e-4],
            omega_i: [0.0, 3.0, 0.0],
            ..Default::default()
        };
        c.bench_function(&format!("contact hertz/history/{}", model.keyword()), |b| {
            let mut h = ContactHistory::default();
            b.iter(|| {
                let mut cd = base;
                black_box(surfaces_intersect(black_box(&mut cd), &p, &mut h, true))
            })
        });
    }
}

/// The fast preset's case (epsd, mu_r 0.5, eta_r 0.5, seed 1) the shear benchmarks use.
fn fast_case() -> ShearCase {
    ShearCase::preset(
        dem_verify::spec::shear::Preset::Fast,
        RollingModel::Epsd,
        0.5,
        0.5,
        1,
    )
    .unwrap()
}

fn neighbor(c: &mut Criterion) {
    let case = fast_case();
    let pk = loose_packing(&case);
    let mut nl = NeighborList::default();
    let b = Periodic {
        lx: case.box_x,
        lz: case.box_z,
    };
    let team = Team::new(1);
    c.bench_function("neighbor build 2500", |bch| {
        bch.iter(|| nl.build(&team, black_box(&pk.position), &pk.radius, case.skin, b))
    });
}

fn trimesh(c: &mut Criterion) {
    let case = fast_case();
    let plate = Plate::new(Side::Bottom, 0.0, case.plates.shape(case.box_x), case.box_x);
    let mesh = TriMesh::new(
        &plate_triangles(&plate, case.box_z),
        [0.0, -1e-3, 0.0],
        [case.box_x, 1e-2, case.box_z],
    );
    let mut rng = SplitMix64::new(1);
    let pts: Vec<[f64; 3]> = (0..1000)
        .map(|_| {
            [
                rng.uniform() * case.box_x,
                1e-4 + 2e-4 * rng.uniform(),
                rng.uniform() * case.box_z,
            ]
        })
        .collect();
    c.bench_function("sphere-triangle resolve x1000", |b| {
        b.iter(|| {
            let mut n = 0;
            for (k, p) in pts.iter().enumerate() {
                if mesh.resolve(k % mesh.tris.len(), [0.0; 3], *p).is_some() {
                    n += 1;
                }
            }
            black_box(n)
        })
    });
}

/// The force evaluation (pair pass, per-particle sums, plate contacts) of the dense fast state
/// (2500 particles compacted for 20,000 steps, then sheared for 2,000: every contact kind
/// present, histories built up), once per kernel path this CPU runs.
fn force_pass(c: &mut Criterion) {
    let case = fast_case();
    let loose = loose_packing(&case);
    let dense = compact(&case.setup(), &loose, 20_000).unwrap();
    let mut sim = ShearSim::new(&case.setup(), &dense);
    sim.setup(case.stages[0].speed).unwrap();
    for _ in 0..2_000 {
        sim.step().unwrap();
    }
    for path in KernelPath::available() {
        let mut s = sim.clone();
        s.set_kernel(path).unwrap();
        let (listed, touching, _) = {
            s.evaluate_forces().unwrap();
            s.contact_counts()
        };
        c.bench_function(
            &format!(
                "forces of the dense fast state ({listed} pairs, {touching} touching), {}",
                path.name()
            ),
            |b| b.iter(|| s.evaluate_forces().unwrap()),
        );
    }
}

criterion_group!(benches, contact, neighbor, trimesh, force_pass);
criterion_main!(benches);
