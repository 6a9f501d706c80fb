//! The shear-box deck: the generated packing as a data file, both plates as STL meshes
//! (the triangles of [`crate::solver::shear::plate::plate_triangles`]), the top plate as a
//! `mesh/surface/stress/servo`, the bottom plate moved by `move/mesh linear` in one run per
//! stage, and plate forces printed by thermo at 17 significant digits.

use super::{num, Deck};
use crate::packing::Packing;
use crate::solver::shear::plate::{plate_triangles, Plate, Side};
use crate::spec::shear::ShearCase;
use std::fmt::Write;

pub const BOTTOM_STL: &str = "bottom.stl";
pub const TOP_STL: &str = "top.stl";
pub const SNAPSHOT_PREFIX: &str = "snap_";
/// Velocity-profile samples ([`profile_dumps`]).
pub const PROFILE_PREFIX: &str = "prof_";

/// Thermo columns after `Step`, in this order, parsed by [`crate::liggghts::read_thermo`].
pub const THERMO_COLUMNS: [&str; 10] = [
    "f_top[1]",
    "f_top[2]",
    "f_top[3]",
    "f_bottom[1]",
    "f_bottom[2]",
    "f_bottom[3]",
    "f_top[8]",
    "ke",
    "c_rke",
    "atoms",
];

fn stl(name: &str, tris: &[[[f64; 3]; 3]]) -> String {
    let mut s = format!("solid {name}\n");
    for t in tris {
        // LIGGGHTS computes normals from the vertices; the facet normal is informative.
        s.push_str("  facet normal 0 0 0\n    outer loop\n");
        for v in t {
            writeln!(s, "      vertex {} {} {}", num(v[0]), num(v[1]), num(v[2])).unwrap();
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    writeln!(s, "endsolid {name}").unwrap();
    s
}

/// Renders the deck for a validated shear case and its initial packing.
pub fn shear_deck(case: &ShearCase, packing: &Packing) -> Deck {
    shear_deck_with(case, packing, &DeckExtras::default())
}

/// What a study adds to the production deck: denser thermo, an earlier end, and commands
/// (dumps, computes) issued before the first run. Generated text only, never case text.
#[derive(Clone, Debug, Default)]
pub struct DeckExtras {
    /// Thermo interval (default: the case's `output_every`).
    pub thermo_every: Option<u64>,
    /// Stop after this step (the runs after it are dropped, the one holding it shortened).
    pub end_step: Option<u64>,
    /// Commands before the compression run.
    pub before_runs: String,
    /// Write LIGGGHTS restart files `restart.<step>` every this many steps (a multiple of the
    /// output interval, so a thermo line at that step proves the file complete: LIGGGHTS'
    /// `Output::write` writes dumps, then the restart file, then thermo).
    pub restart_every: Option<u64>,
    /// Continue from the restart file `restart.<step>` of this step instead of the data file
    /// ([`resume_preamble`]): the runs ending at or before it are dropped, the others run
    /// `upto` their end step.
    pub resume_from: Option<u64>,
}

/// Restart files' name: `restart.<step>` (LIGGGHTS replaces `*` with the step).
pub const RESTART_PREFIX: &str = "restart.";

/// What replaces `units` .. `read_data` when a deck continues from a restart file. The file
/// holds units, atom style, box, boundaries, atoms with their per-atom fix data (contact
/// histories, mesh neighbour lists) and the global state of every fix that has one (meshes,
/// servo, `move/mesh`), restored when a fix of the same ID and style is defined again. It
/// does not hold `communicate single vel yes` or `newton off` (LIGGGHTS refuses the
/// granular pair style without them), so those come again. Measured on the ci preset
/// (2026-12-02): the resumed run's plate forces differ from the uninterrupted run's by 6 %
/// 100 steps after the restart step and then follow their own trajectory (steady mu 0.470
/// against 0.513, within one seed's scatter); writing a restart file itself changes the
/// bottom plate's force sum in the 12th digit at that step.
fn resume_preamble(step: u64) -> String {
    format!(
        "hard_particles yes\nread_restart {RESTART_PREFIX}{step}\ncommunicate single vel yes\nnewton off\n"
    )
}

/// The replay's dumps: at every step of each window `[s, s + k]`, the atoms (id, position,
/// image flags, velocity, angular velocity, force, torque), every touching pair and every
/// particle-triangle contact (ids, force and torque on the first partner, the history) at 17
/// significant digits. The schedule is an equal-style variable giving the next dump step
/// (`dump_modify every v_name`), `max(a, b)` written as `(a + b + |a - b|) / 2`.
pub fn replay_dumps(windows: &[(u64, u64)], n_hist: usize) -> String {
    let max2 = |a: &str, b: &str| format!("(({a})+({b})+abs(({a})-({b})))/2");
    let mut terms = Vec::new();
    let mut prev_end: Option<u64> = None;
    for &(s, e) in windows {
        let lo = prev_end
            .map(|p| format!("(step>={p})*"))
            .unwrap_or_default();
        terms.push(format!("{lo}(step<{e})*{}", max2("step+1", &s.to_string())));
        prev_end = Some(e);
    }
    if let Some(p) = prev_end {
        terms.push(format!("(step>={p})*1e15"));
    }
    let ncol = 9 + n_hist;
    let g17 = |n: usize| vec!["%.17g"; n].join(" ");
    let cols = |c: &str| {
        (1..=ncol)
            .map(|k| format!("c_{c}[{k}]"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let mut d = String::new();
    let w = &mut d;
    writeln!(w, "# replay dumps").unwrap();
    writeln!(w, "variable rnext equal \"{}\"", terms.join("+")).unwrap();
    writeln!(w, "dump ratoms all custom 1 {REPLAY_ATOMS}*.dump id x y z ix iy iz vx vy vz omegax omegay omegaz fx fy fz tqx tqy tqz").unwrap();
    writeln!(
        w,
        "dump_modify ratoms every v_rnext sort id format \"%d {} %d %d %d {}\"",
        g17(3),
        g17(12)
    )
    .unwrap();
    for (c, style, file) in [
        ("rpair", "pair/gran/local", REPLAY_PAIRS),
        ("rwall", "wall/gran/local", REPLAY_WALLS),
    ] {
        writeln!(w, "compute {c} all {style} id force torque history").unwrap();
        writeln!(w, "dump d{c} all local 1 {file}*.dump {}", cols(c)).unwrap();
        writeln!(w, "dump_modify d{c} every v_rnext format \"{}\"", g17(ncol)).unwrap();
    }
    d
}

pub const REPLAY_ATOMS: &str = "ratoms_";
pub const REPLAY_PAIRS: &str = "rpairs_";
pub const REPLAY_WALLS: &str = "rwalls_";

/// Renders the deck with study additions (see [`DeckExtras`]).
pub fn shear_deck_with(case: &ShearCase, packing: &Packing, extras: &DeckExtras) -> Deck {
    let m = &case.material;
    let rolling = case.models.rolling;
    let mut d = String::new();
    let w = &mut d;
    writeln!(
        w,
        "# LIGGGHTS 3.8.0 deck generated by dem-verify: shear case `{}`.",
        case.name
    )
    .unwrap();
    writeln!(
        w,
        "# x and z periodic; bottom plate sheared along x, top plate servo-controlled along y."
    )
    .unwrap();
    for line in [
        "units si",
        "atom_style granular",
        "atom_modify map array",
        "boundary p f p",
        "newton off",
        "communicate single vel yes",
        "hard_particles yes",
    ] {
        writeln!(w, "{line}").unwrap();
    }
    writeln!(w, "read_data {}", super::DATA_NAME).unwrap();
    if let Some(step) = extras.resume_from {
        // everything before the neighbour settings comes from the restart file
        let at = w.find("units si").expect("the deck starts with units");
        w.truncate(at);
        w.push_str(&resume_preamble(step));
    }
    writeln!(w, "neighbor {} bin", num(case.skin)).unwrap();
    if case.neighbor == crate::spec::shear::NeighborSchedule::default() {
        writeln!(w, "neigh_modify delay 0").unwrap();
    } else {
        writeln!(
            w,
            "neigh_modify delay 0 every {} check {}",
            case.neighbor.every,
            if case.neighbor.check { "yes" } else { "no" }
        )
        .unwrap();
    }
    super::material_fixes(w, m, rolling, None);
    let (models, settings) = super::model_args(&case.models);
    writeln!(w, "pair_style gran {models}{settings}").unwrap();
    writeln!(w, "pair_coeff * *").unwrap();
    writeln!(w, "timestep {}", num(case.dt)).unwrap();
    let com = [0.5 * case.box_x, packing.top_y, 0.5 * case.box_z];
    let s = &case.servo;
    writeln!(
        w,
        "fix bottom all mesh/surface/stress file {BOTTOM_STL} type 1"
    )
    .unwrap();
    writeln!(
        w,
        "fix top all mesh/surface/stress/servo file {TOP_STL} type 1 com {} {} {} ctrlPV force axis 0 -1 0 target_val {} vel_max {} kp {} ki {} kd {}",
        num(com[0]),
        num(com[1]),
        num(com[2]),
        num(case.target_force()),
        num(s.vel_max),
        num(s.kp),
        num(s.ki),
        num(s.kd)
    )
    .unwrap();
    writeln!(
        w,
        "fix walls all wall/gran {models} mesh n_meshes 2 meshes bottom top{settings}"
    )
    .unwrap();
    writeln!(w, "fix integr all nve/sphere").unwrap();
    writeln!(w, "compute rke all erotate/sphere").unwrap();
    writeln!(w, "thermo_style custom step {}", THERMO_COLUMNS.join(" ")).unwrap();
    writeln!(w, "thermo_modify format float %.17g").unwrap();
    writeln!(
        w,
        "thermo {}",
        extras.thermo_every.unwrap_or(case.output_every)
    )
    .unwrap();
    if case.snapshot_every > 0 {
        writeln!(
            w,
            "dump snap all custom {} {SNAPSHOT_PREFIX}*.dump id radius x y z vx vy vz omegax omegay omegaz",
            case.snapshot_every
        )
        .unwrap();
        writeln!(w, "dump_modify snap sort id").unwrap();
    }
    w.push_str(&profile_dumps(
        &crate::spec::windows::schedule(case),
        PROFILE_PREFIX,
    ));
    w.push_str(&extras.before_runs);
    if let Some(n) = extras.restart_every {
        writeln!(w, "restart {n} {RESTART_PREFIX}*").unwrap();
    }
    let end = extras.end_step.unwrap_or(u64::MAX);
    let from = extras.resume_from.unwrap_or(0);
    // a resumed deck runs `upto` each run's end step from wherever the restart left it
    let run = |w: &mut String, steps: u64, run_end: u64| {
        if extras.resume_from.is_some() {
            writeln!(w, "run {run_end} upto").unwrap();
        } else {
            writeln!(w, "run {steps}").unwrap();
        }
    };
    let compression = case.compression_steps.min(end);
    if from < compression {
        writeln!(w, "# compression by the servo").unwrap();
        run(w, compression, compression);
    }
    let mut start = case.compression_steps;
    for (k, (stage, steps)) in case.stages.iter().zip(case.stage_steps()).enumerate() {
        if start >= end {
            break;
        }
        let steps = steps.min(end - start);
        start += steps;
        if start <= from {
            continue;
        }
        writeln!(w, "# shear stage {}: {} m/s", k + 1, num(stage.speed)).unwrap();
        writeln!(
            w,
            "fix shear{k} all move/mesh mesh bottom linear {} 0 0",
            num(stage.speed)
        )
        .unwrap();
        run(w, steps, start);
        writeln!(w, "unfix shear{k}").unwrap();
    }

    let mut data = String::new();
    let dw = &mut data;
    writeln!(
        dw,
        "LIGGGHTS data file generated by dem-verify: shear case {}\n",
        case.name
    )
    .unwrap();
    writeln!(dw, "{} atoms\n1 atom types\n", packing.radius.len()).unwrap();
    writeln!(dw, "0 {} xlo xhi", num(case.box_x)).unwrap();
    writeln!(
        dw,
        "{} {} ylo yhi",
        num(packing.box_y_lo),
        num(packing.box_y_hi)
    )
    .unwrap();
    writeln!(dw, "0 {} zlo zhi", num(case.box_z)).unwrap();
    writeln!(dw, "\nAtoms\n").unwrap();
    for (k, (r, p)) in packing.radius.iter().zip(&packing.position).enumerate() {
        writeln!(
            dw,
            "{} 1 {} {} {} {} {}",
            k + 1,
            num(2.0 * r),
            num(m.density),
            num(p[0]),
            num(p[1]),
            num(p[2])
        )
        .unwrap();
    }
    if packing
        .velocity
        .iter()
        .chain(&packing.omega)
        .any(|v| v.iter().any(|c| *c != 0.0))
    {
        writeln!(dw, "\nVelocities\n").unwrap();
        for (k, (v, w)) in packing.velocity.iter().zip(&packing.omega).enumerate() {
            writeln!(
                dw,
                "{} {} {} {} {} {} {}",
                k + 1,
                num(v[0]),
                num(v[1]),
                num(v[2]),
                num(w[0]),
                num(w[1]),
                num(w[2])
            )
            .unwrap();
        }
    }
    let bottom = Plate::new(Side::Bottom, 0.0, case.plates.shape(case.box_x), case.box_x);
    let top = Plate::new(
        Side::Top,
        packing.top_y,
        case.plates.shape(case.box_x),
        case.box_x,
    );
    Deck {
        files: vec![
            (super::DECK_NAME.to_string(), d),
            (super::DATA_NAME.to_string(), data),
            (
                BOTTOM_STL.to_string(),
                stl("bottom", &plate_triangles(&bottom, case.box_z)),
            ),
            (
                TOP_STL.to_string(),
                stl("top", &plate_triangles(&top, case.box_z)),
            ),
        ],
    }
}

/// The deck commands that dump `id y vx` at the schedule's steps: an equal-style variable
/// gives the next sample step (`dump_modify every v_pnext`), per window
/// `max(first, first + every (floor((step - first) / every) + 1))`, `max(a, b)` written as
/// `(a + b + |a - b|) / 2` as in the replay's dumps.
fn profile_dumps(windows: &[crate::spec::windows::SampleWindow], prefix: &str) -> String {
    let max2 = |a: &str, b: &str| format!("(({a})+({b})+abs(({a})-({b})))/2");
    let mut terms = Vec::new();
    let mut prev_end: Option<u64> = None;
    for w in windows {
        let lo = prev_end
            .map(|p| format!("(step>={p})*"))
            .unwrap_or_default();
        let next = format!(
            "{}+{}*(floor((step-{})/{})+1)",
            w.first, w.every, w.first, w.every
        );
        terms.push(format!(
            "{lo}(step<{})*{}",
            w.last(),
            max2(&w.first.to_string(), &next)
        ));
        prev_end = Some(w.last());
    }
    if let Some(p) = prev_end {
        terms.push(format!("(step>={p})*1e15"));
    }
    let mut d = String::new();
    writeln!(d, "# velocity-profile samples").unwrap();
    writeln!(d, "variable pnext equal \"{}\"", terms.join("+")).unwrap();
    writeln!(d, "dump prof all custom 1 {prefix}*.dump id y vx").unwrap();
    writeln!(
        d,
        "dump_modify prof every v_pnext sort id format \"%d %.17g %.17g\""
    )
    .unwrap();
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::windows::SampleWindow;

    #[test]
    fn deck_schedule_names_the_next_sample() {
        let w = [SampleWindow {
            stage: 0,
            first: 100,
            every: 10,
            samples: 3,
        }];
        let d = profile_dumps(&w, "prof_");
        assert!(d.contains("(step<120)*"), "{d}");
        assert!(d.contains("(step>=120)*1e15"), "{d}");
        // evaluate the variable's formula here the way LIGGGHTS would
        let next = |step: f64| {
            let a = 100.0;
            let b = 100.0 + 10.0 * (((step - 100.0) / 10.0).floor() + 1.0);
            if step < 120.0 {
                (a + b + (a - b).abs()) / 2.0
            } else {
                1e15
            }
        };
        assert_eq!(
            [next(0.0), next(100.0), next(105.0), next(110.0)],
            [100.0, 110.0, 110.0, 120.0]
        );
    }
}
