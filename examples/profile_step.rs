//! Profiling aid: compacts the fast sample briefly and runs N shear steps on one thread.
use dem_verify::packing::loose_packing;
use dem_verify::solver::shear::ShearSim;
use dem_verify::spec::{shear::ShearCase, RollingModel};

fn main() {
    let n: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(2000);
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .unwrap();
    let c = ShearCase::preset(
        dem_verify::spec::shear::Preset::Fast,
        RollingModel::Epsd,
        0.5,
        0.5,
        1,
    )
    .unwrap();
    let p = loose_packing(&c);
    let mut s = ShearSim::new(&c.setup(), &p);
    s.setup(0.0).unwrap();
    for _ in 0..20_000 {
        s.step().unwrap();
    }
    s.setup(c.stages[0].speed).unwrap();
    let t = std::time::Instant::now();
    for _ in 0..n {
        s.step().unwrap();
    }
    eprintln!(
        "{:.3e} particle-steps/s",
        n as f64 * 2500.0 / t.elapsed().as_secs_f64()
    );
}
