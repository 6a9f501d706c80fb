//! LIGGGHTS input generation: `Case -> deck text + data file + STL`. String building only.
//!
//! Injection safety: nothing from a case file is copied into a deck as text. Numbers go
//! through [`num`] (Rust's shortest round-trip formatting of a finite f64, so LIGGGHTS' `atof`
//! reads back the identical double); names are checked identifiers; everything else is
//! fixed text chosen by enums. A test feeds hostile strings through the case and checks the
//! deck.

pub mod shear;

use crate::solver::kinematics::rotation_period;
use crate::spec::{domain_half_size, Case, Material, Models, Motion, RollingModel, WallMaterial};
use std::fmt::Write;

/// Output files every contact deck writes, read back by [`crate::liggghts`].
pub const ATOM_DUMP: &str = "atoms.dump";
pub const CONTACT_DUMP: &str = "contact.dump";
pub const DECK_NAME: &str = "in.deck";
pub const DATA_NAME: &str = "data.txt";
pub const STL_NAME: &str = "wall.stl";

/// A rendered deck: file name and content, `in.deck` first.
#[derive(Clone, Debug, PartialEq)]
pub struct Deck {
    pub files: Vec<(String, String)>,
}

impl Deck {
    pub fn get(&self, name: &str) -> Option<&str> {
        self.files
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, c)| c.as_str())
    }
}

/// Formats a finite number so that it parses back to the identical double.
pub fn num(x: f64) -> String {
    assert!(x.is_finite(), "deck numbers are validated finite");
    if x == 0.0 || (1e-3..1e7).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

fn vec3(v: [f64; 3]) -> String {
    format!("{} {} {}", num(v[0]), num(v[1]), num(v[2]))
}

/// Directory name of a case run with a rolling model: `<case>__<model>`.
pub fn run_name(case: &Case) -> String {
    format!("{}__{}", case.name, case.models.rolling)
}

/// `pair_style gran ...` / `fix wall/gran ...` model keywords and model settings. Settings
/// (`torsionTorque`) follow the model keywords in `pair_style`, but must come after the mesh
/// arguments in `fix wall/gran` (fix_wall_gran.cpp passes only the trailing arguments on).
pub(crate) fn model_args(models: &Models) -> (String, String) {
    let mut s = String::from("model hertz tangential history");
    let mut settings = String::new();
    if models.rolling != RollingModel::Off {
        let torsion = if models.torsion_torque { "on" } else { "off" };
        write!(s, " rolling_friction {}", models.rolling.keyword()).unwrap();
        write!(settings, " torsionTorque {torsion}").unwrap();
    }
    (s, settings)
}

/// The `fix property/global` material lines a model needs (only those it reads: LIGGGHTS
/// refuses unknown combinations, e.g. `rollingStiffness` without epsd3 is harmless but
/// `coefficientRollingViscousDamping` is only read by epsd and epsd3). With a wall of its own
/// material the wall is atom type 2: its Young's modulus and Poisson's ratio follow the
/// particles' in the `peratomtype` lists, and every `peratomtypepair` matrix (2 x 2) holds
/// the particles' coefficient in each entry.
pub(crate) fn material_fixes(
    w: &mut String,
    m: &Material,
    rolling: RollingModel,
    wall: Option<&WallMaterial>,
) {
    let (youngs, poisson) = match wall {
        None => (num(m.youngs_modulus), num(m.poisson_ratio)),
        Some(wm) => (
            format!("{} {}", num(m.youngs_modulus), num(wm.youngs_modulus)),
            format!("{} {}", num(m.poisson_ratio), num(wm.poisson_ratio)),
        ),
    };
    let types = if wall.is_some() { 2 } else { 1 };
    let matrix = |v: f64| vec![num(v); types * types].join(" ");
    writeln!(
        w,
        "fix m1 all property/global youngsModulus peratomtype {youngs}"
    )
    .unwrap();
    writeln!(
        w,
        "fix m2 all property/global poissonsRatio peratomtype {poisson}"
    )
    .unwrap();
    writeln!(
        w,
        "fix m3 all property/global coefficientRestitution peratomtypepair {types} {}",
        matrix(m.restitution)
    )
    .unwrap();
    writeln!(
        w,
        "fix m4 all property/global coefficientFriction peratomtypepair {types} {}",
        matrix(m.friction)
    )
    .unwrap();
    if rolling != RollingModel::Off {
        writeln!(
            w,
            "fix m5 all property/global coefficientRollingFriction peratomtypepair {types} {}",
            matrix(m.rolling_friction)
        )
        .unwrap();
    }
    if rolling.has_damping() {
        writeln!(
            w,
            "fix m6 all property/global coefficientRollingViscousDamping peratomtypepair {types} {}",
            matrix(m.rolling_damping)
        )
        .unwrap();
    }
    if rolling == RollingModel::Epsd3 {
        writeln!(
            w,
            "fix m7 all property/global rollingStiffness scalar {}",
            num(m.rolling_stiffness)
        )
        .unwrap();
    }
}

/// Renders the contact-case deck, data file and (with a wall) the STL mesh.
pub fn contact_deck(case: &Case) -> Deck {
    let m = &case.material;
    let rolling = case.models.rolling;
    let h = domain_half_size(case);
    let mut d = String::new();
    let w = &mut d;
    writeln!(
        w,
        "# LIGGGHTS 3.8.0 deck generated by dem-verify: contact case `{}`, rolling model `{}`.",
        case.name, rolling
    )
    .unwrap();
    writeln!(
        w,
        "# Do not edit; regenerate with `verify decks`. Run as `liggghts -in {DECK_NAME}`."
    )
    .unwrap();
    writeln!(w, "units si").unwrap();
    writeln!(w, "atom_style granular").unwrap();
    writeln!(w, "atom_modify map array").unwrap();
    writeln!(w, "boundary f f f").unwrap();
    writeln!(w, "newton off").unwrap();
    writeln!(w, "communicate single vel yes").unwrap();
    writeln!(w, "hard_particles yes").unwrap();
    writeln!(w, "read_data {DATA_NAME}").unwrap();
    writeln!(w, "neighbor {} bin", num(case.skin())).unwrap();
    writeln!(w, "neigh_modify delay 0").unwrap();
    let wall_material = case.wall.as_ref().and_then(|w| w.material.as_ref());
    material_fixes(w, m, rolling, wall_material);
    let (args, settings) = model_args(&case.models);
    writeln!(w, "pair_style gran {args}{settings}").unwrap();
    writeln!(w, "pair_coeff * *").unwrap();
    writeln!(w, "timestep {}", num(case.dt)).unwrap();
    if case.wall.is_some() {
        // the wall's own material is atom type 2 (declared in the data file)
        let wall_type = if wall_material.is_some() { 2 } else { 1 };
        writeln!(
            w,
            "fix wall all mesh/surface file {STL_NAME} type {wall_type}"
        )
        .unwrap();
        writeln!(
            w,
            "fix wallgran all wall/gran {args} mesh n_meshes 1 meshes wall{settings}"
        )
        .unwrap();
    }
    let free: Vec<String> = case
        .particles
        .iter()
        .enumerate()
        .filter(|(_, p)| p.motion == Motion::Free)
        .map(|(k, _)| (k + 1).to_string())
        .collect();
    if !free.is_empty() {
        writeln!(w, "group free id {}", free.join(" ")).unwrap();
        writeln!(w, "fix integr free nve/sphere").unwrap();
    }
    let moves = move_fixes(case, false);
    for (k, _) in case.particles.iter().enumerate() {
        if moves.iter().any(|(id, _)| *id == k + 1) {
            writeln!(w, "group p{0} id {0}", k + 1).unwrap();
        }
    }
    for (_, line) in &moves {
        writeln!(w, "{line}").unwrap();
    }
    let every = case.output_every;
    let (compute, nid) = if case.wall.is_some() {
        ("wall/gran/local", 3)
    } else {
        ("pair/gran/local", 3)
    };
    let nhist = 3 + if rolling.has_history() { 3 } else { 0 };
    writeln!(w, "compute cgl all {compute} id history").unwrap();
    writeln!(w, "thermo {}", case.steps).unwrap();
    let f17 = "%.17g";
    writeln!(w, "dump atoms all custom {every} {ATOM_DUMP} id x y z vx vy vz fx fy fz omegax omegay omegaz tqx tqy tqz").unwrap();
    writeln!(
        w,
        "dump_modify atoms sort id format \"%d{}\"",
        format!(" {f17}").repeat(15)
    )
    .unwrap();
    let cols: Vec<String> = (1..=nid + nhist).map(|c| format!("c_cgl[{c}]")).collect();
    writeln!(
        w,
        "dump contact all local {every} {CONTACT_DUMP} {}",
        cols.join(" ")
    )
    .unwrap();
    writeln!(
        w,
        "dump_modify contact format \"{}\"",
        vec![f17; nid + nhist].join(" ")
    )
    .unwrap();
    match case.reverse_at_step {
        None => writeln!(w, "run {}", case.steps).unwrap(),
        Some(r) => {
            writeln!(w, "run {r}").unwrap();
            writeln!(
                w,
                "# reversal: imposed rotations and velocities change sign"
            )
            .unwrap();
            for (id, _) in &moves {
                writeln!(w, "unfix mv{id}").unwrap();
            }
            for (_, line) in move_fixes(case, true) {
                writeln!(w, "{line}").unwrap();
            }
            writeln!(w, "run {}", case.steps - r).unwrap();
        }
    }

    let mut files = vec![
        (DECK_NAME.to_string(), d),
        (DATA_NAME.to_string(), data_file(case, h)),
    ];
    if let Some(wall) = &case.wall {
        files.push((STL_NAME.to_string(), stl(wall.z, wall.half_size)));
    }
    Deck { files }
}

/// `fix move` lines per moved particle id; `reversed` negates axis / velocity.
fn move_fixes(case: &Case, reversed: bool) -> Vec<(usize, String)> {
    let sign = if reversed { -1.0 } else { 1.0 };
    case.particles
        .iter()
        .enumerate()
        .filter_map(|(k, p)| {
            let id = k + 1;
            match &p.motion {
                Motion::Rotate { omega } => Some((
                    id,
                    format!(
                        "fix mv{id} p{id} move rotate {} {} {}",
                        vec3(p.position),
                        vec3([sign * omega[0], sign * omega[1], sign * omega[2]]),
                        num(rotation_period(*omega))
                    ),
                )),
                Motion::Linear { velocity } => Some((
                    id,
                    format!(
                        "fix mv{id} p{id} move linear {}",
                        vec3([sign * velocity[0], sign * velocity[1], sign * velocity[2]])
                    ),
                )),
                Motion::Free | Motion::Fixed => None,
            }
        })
        .collect()
}

fn data_file(case: &Case, h: f64) -> String {
    let mut s = String::new();
    let w = &mut s;
    writeln!(w, "LIGGGHTS data file generated by dem-verify\n").unwrap();
    let types = match case.wall.as_ref().and_then(|w| w.material.as_ref()) {
        Some(_) => 2,
        None => 1,
    };
    writeln!(w, "{} atoms\n{types} atom types\n", case.particles.len()).unwrap();
    for ax in ["x", "y", "z"] {
        writeln!(w, "{} {} {ax}lo {ax}hi", num(-h), num(h)).unwrap();
    }
    writeln!(w, "\nAtoms\n").unwrap();
    for (k, p) in case.particles.iter().enumerate() {
        writeln!(
            w,
            "{} 1 {} {} {}",
            k + 1,
            num(2.0 * p.radius),
            num(case.material.density),
            vec3(p.position)
        )
        .unwrap();
    }
    writeln!(w, "\nVelocities\n").unwrap();
    for (k, p) in case.particles.iter().enumerate() {
        writeln!(w, "{} {} {}", k + 1, vec3(p.velocity), vec3(p.omega)).unwrap();
    }
    s
}

/// ASCII STL of the square wall, the same triangles as [`crate::solver::mesh::square_wall`].
fn stl(z: f64, h: f64) -> String {
    let tris = crate::solver::mesh::square_wall(z, h);
    let mut s = String::from("solid wall\n");
    for t in &tris {
        writeln!(s, "  facet normal {}", vec3(t.normal)).unwrap();
        s.push_str("    outer loop\n");
        for n in &t.nodes {
            writeln!(s, "      vertex {}", vec3(*n)).unwrap();
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    s.push_str("endsolid wall\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::builtin::builtin_case;

    #[test]
    fn numbers_round_trip() {
        for x in [
            1e-8,
            7e10,
            0.3,
            1.999e-3,
            -0.06,
            2.0 * std::f64::consts::PI / 100.0,
            5.0,
            0.0,
        ] {
            assert_eq!(num(x).parse::<f64>().unwrap(), x);
        }
    }

    #[test]
    fn deck_contains_models_and_materials() {
        let c = builtin_case("rolling_damped").unwrap().validate().unwrap();
        let d = contact_deck(&c);
        let deck = d.get(DECK_NAME).unwrap();
        assert!(deck.contains("pair_style gran model hertz tangential history rolling_friction epsd torsionTorque off"));
        assert!(deck.contains("coefficientRollingViscousDamping peratomtypepair 1 0.3"));
        assert!(
            deck.contains("fix mv2 p2 move rotate 0 0 0.001799 60 80 0 "),
            "{deck}"
        );
        assert!(d
            .get(DATA_NAME)
            .unwrap()
            .contains("2 1 0.0016 2500 0 0 0.001799"));
    }

    #[test]
    fn reversal_writes_second_run() {
        let c = builtin_case("rolling_unload").unwrap().validate().unwrap();
        let deck = contact_deck(&c).get(DECK_NAME).unwrap().to_string();
        assert!(deck.contains("run 3000\n"));
        assert!(
            deck.contains("unfix mv2\nfix mv2 p2 move rotate 0 0 0.001999 -60 -80 -0 "),
            "{deck}"
        );
        assert!(deck.contains("run 4000\n"));
    }

    #[test]
    fn no_case_text_reaches_the_deck() {
        // The description is free text and must never appear; the name is an identifier.
        let mut f = builtin_case("rolling_plastic").unwrap();
        f.description = "shell touch /tmp/pwned".into();
        let c = f.validate().unwrap();
        let d = contact_deck(&c);
        for (_, text) in &d.files {
            assert!(!text.contains("shell"), "{text}");
        }
    }

    #[test]
    fn a_wall_of_its_own_material_is_atom_type_2() {
        let mut f = builtin_case("wall_rolling_plastic").unwrap();
        f.wall.as_mut().unwrap().material = Some(WallMaterial {
            youngs_modulus: 7.0e13,
            poisson_ratio: 0.25,
        });
        let c = f.with_rolling(RollingModel::Epsd).validate().unwrap();
        let d = contact_deck(&c);
        let deck = &d.files[0].1;
        let data = &d.files[1].1;
        assert!(
            deck.contains("youngsModulus peratomtype 7e10 7e13"),
            "{deck}"
        );
        assert!(
            deck.contains("poissonsRatio peratomtype 0.3 0.25"),
            "{deck}"
        );
        assert!(
            deck.contains("coefficientFriction peratomtypepair 2 0.5 0.5 0.5 0.5"),
            "{deck}"
        );
        assert!(deck.contains("coefficientRollingFriction peratomtypepair 2 0.5 0.5 0.5 0.5"));
        assert!(deck.contains("mesh/surface file wall.stl type 2"), "{deck}");
        assert!(data.contains("2 atom types"), "{data}");
        // without: one type, as every committed deck
        let plain = contact_deck(
            &builtin_case("wall_rolling_plastic")
                .unwrap()
                .validate()
                .unwrap(),
        );
        assert!(plain.files[0].1.contains("type 1\n") && plain.files[1].1.contains("1 atom types"));
    }
}
