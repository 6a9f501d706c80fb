//! Debug aid: runs the native shear solver of a preset and writes per-atom state every N
//! steps, in the format of the LIGGGHTS dump used for comparison.
use dem_verify::packing::loose_packing;
use dem_verify::solver::shear::ShearSim;
use dem_verify::spec::{shear::ShearCase, RollingModel};
use std::io::Write;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let steps: u64 = a[1].parse().unwrap();
    let every: u64 = a[2].parse().unwrap();
    let out = std::path::PathBuf::from(&a[3]);
    let c = ShearCase::preset("ci", RollingModel::Epsd, 0.5, 0.5, 1).unwrap();
    let p = loose_packing(&c);
    let mut s = ShearSim::new(&c, &p);
    s.setup(0.0).unwrap();
    std::fs::create_dir_all(&out).unwrap();
    while s.step < steps {
        s.step().unwrap();
        if s.step.is_multiple_of(every) {
            let mut f = std::fs::File::create(out.join(format!("n.{}.txt", s.step))).unwrap();
            for i in 0..s.x.len() {
                let (x, v, w) = (s.x[i], s.v[i], s.omega[i]);
                writeln!(
                    f,
                    "{} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e}",
                    i + 1,
                    x[0],
                    x[1],
                    x[2],
                    v[0],
                    v[1],
                    v[2],
                    w[0],
                    w[1],
                    w[2]
                )
                .unwrap();
            }
        }
    }
}
