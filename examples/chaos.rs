//! Control experiment for the lockstep horizon: how fast do two native runs from the same
//! compacted state separate when one coordinate differs by one ulp?
use dem_verify::packing::loose_packing;
use dem_verify::solver::shear::ShearSim;
use dem_verify::spec::{shear::ShearCase, RollingModel};

fn main() {
    let c = ShearCase::preset(
        dem_verify::spec::shear::Preset::Ci,
        RollingModel::Epsd,
        0.5,
        0.5,
        1,
    )
    .unwrap();
    let p = loose_packing(&c);
    let mut s = ShearSim::new(&c.setup(), &p);
    s.setup(0.0).unwrap();
    while s.step < c.compression_steps {
        s.step().unwrap();
    }
    let state = s.state(&p);
    let mut nudged = state.clone();
    nudged.position[0][0] = f64::from_bits(nudged.position[0][0].to_bits() + 1);
    let mut a = ShearSim::new(&c.setup(), &state);
    let mut b = ShearSim::new(&c.setup(), &nudged);
    for sim in [&mut a, &mut b] {
        sim.setup(0.0).unwrap();
        sim.step().unwrap();
        sim.setup(c.stages[0].speed).unwrap();
    }
    for k in 1..=200 {
        a.step().unwrap();
        b.step().unwrap();
        if k % 10 == 0 {
            let (fa, fb) = (a.record().bottom_force, b.record().bottom_force);
            println!(
                "step {k}: bottom_f_x rel diff {:.1e}",
                ((fa[0] - fb[0]) / fa[0]).abs()
            );
        }
    }
}
