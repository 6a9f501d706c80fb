//! Debug aid: forces of every particle after one step from a LIGGGHTS shear data file
//! (as written by the shear deck), for comparison with a LIGGGHTS dump.
use dem_verify::packing::Packing;
use dem_verify::solver::shear::ShearSim;
use dem_verify::spec::{shear::ShearCase, RollingModel};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let seed: u64 = a[1].parse().unwrap();
    let top_y: f64 = a[3].parse().unwrap();
    let c = ShearCase::preset("ci", RollingModel::Epsd, 0.5, 0.5, seed).unwrap();
    let text = std::fs::read_to_string(&a[2]).unwrap();
    let mut p = Packing {
        radius: vec![],
        position: vec![],
        velocity: vec![],
        omega: vec![],
        top_y,
        box_y_hi: 0.0,
        box_y_lo: 0.0,
    };
    let mut section = "";
    for l in text.lines() {
        let f: Vec<&str> = l.split_whitespace().collect();
        if l.ends_with("ylo yhi") {
            p.box_y_lo = f[0].parse().unwrap();
            p.box_y_hi = f[1].parse().unwrap();
        }
        if l == "Atoms" || l == "Velocities" {
            section = if l == "Atoms" { "a" } else { "v" };
            continue;
        }
        if f.len() == 7 && section == "a" {
            p.radius.push(0.5 * f[2].parse::<f64>().unwrap());
            p.position.push([
                f[4].parse().unwrap(),
                f[5].parse().unwrap(),
                f[6].parse().unwrap(),
            ]);
        }
        if f.len() == 7 && section == "v" {
            p.velocity.push([
                f[1].parse().unwrap(),
                f[2].parse().unwrap(),
                f[3].parse().unwrap(),
            ]);
            p.omega.push([
                f[4].parse().unwrap(),
                f[5].parse().unwrap(),
                f[6].parse().unwrap(),
            ]);
        }
    }
    let mut s = ShearSim::new(&c, &p);
    s.setup(0.0).unwrap();
    s.step().unwrap();
    for pr in s.pairs() {
        eprintln!("pair {} {} shift {:?}", pr.i + 1, pr.j + 1, pr.shift);
    }
    for (i, f) in s.forces().iter().enumerate() {
        println!("{} {:e} {:e} {:e}", i + 1, f[0], f[1], f[2]);
    }
}
