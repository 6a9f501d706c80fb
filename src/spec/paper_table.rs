//! How a shear case differs from the paper (Sac-Morane, Rattez, Veveakis 2022): its Table 2
//! (dt 1.5e-6 s; shear rates v/h = 2, 6, 20 %/s, i.e. 100, 300, 1000 um/s at h = 5 mm, each
//! to 100 % strain; density 2e6 kg/m3; Y = 70 GPa; nu = 0.3; e = 1; mu_p = 0.5; mu_r in
//! {0, 0.25, 0.5, 0.75, 1}; eta_r in {0, 0.25, 0.5, 0.75}) and its Table 1 (2500 grains; radii
//! 0.2 / 0.15 / 0.1 mm at 14 / 29 / 57 %; box 4 x 2.4 mm in x and z; 10 MPa), the rolling
//! model it ran (LIGGGHTS `epsd`) and its toothed plates. The `paper` preset is that set-up;
//! every run prints this list and records it in its summary.

use super::shear::{Fractions, Plates, Preset, ShearCase};
use super::RollingModel;
use serde::{Deserialize, Serialize};

/// The paper's mu_r and eta_r values.
pub const PAPER_MU_R: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];
pub const PAPER_ETA_R: [f64; 4] = [0.0, 0.25, 0.5, 0.75];

/// One parameter of a case that is not the paper's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Deviation {
    pub parameter: String,
    pub paper: String,
    pub case: String,
    /// Why the project chose it, where it is a deliberate reading of the paper.
    pub note: Option<String>,
}

impl std::fmt::Display for Deviation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: paper {}, this run {}",
            self.parameter, self.paper, self.case
        )?;
        if let Some(n) = &self.note {
            write!(f, " ({n})")?;
        }
        Ok(())
    }
}

fn list(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The parameters of `case` that differ from the paper's, in the order of the tables. The
/// reference is the `paper` preset (same seed), so the comparison and the preset cannot
/// drift apart; mu_r and eta_r are compared with the paper's sets.
pub fn deviations(case: &ShearCase) -> Vec<Deviation> {
    let paper = ShearCase::preset(Preset::Paper, RollingModel::Epsd, 0.0, 0.0, case.seed)
        .expect("the paper preset is valid");
    let mut out = Vec::new();
    let mut differ = |parameter: &str, paper: String, case: String| {
        if paper != case {
            out.push(Deviation {
                parameter: parameter.into(),
                paper,
                case,
                note: None,
            });
        }
    };
    let (m, pm) = (&case.material, &paper.material);
    differ("dt [s]", format!("{}", paper.dt), format!("{}", case.dt));
    let stages = |c: &ShearCase| {
        c.stages
            .iter()
            .map(|s| format!("{} m/s to strain {}", s.speed, s.strain))
            .collect::<Vec<_>>()
            .join("; ")
    };
    differ("shear stages", stages(&paper), stages(case));
    for (parameter, paper, this) in [
        ("density [kg/m3]", pm.density, m.density),
        ("Young's modulus [Pa]", pm.youngs_modulus, m.youngs_modulus),
        ("Poisson ratio", pm.poisson_ratio, m.poisson_ratio),
        ("restitution e", pm.restitution, m.restitution),
        ("sliding friction mu_p", pm.friction, m.friction),
    ] {
        differ(parameter, format!("{paper}"), format!("{this}"));
    }
    if !PAPER_MU_R.contains(&m.rolling_friction) {
        differ(
            "rolling friction mu_r",
            format!("one of {}", list(&PAPER_MU_R)),
            format!("{}", m.rolling_friction),
        );
    }
    if !PAPER_ETA_R.contains(&m.rolling_damping) {
        differ(
            "rolling damping eta_r",
            format!("one of {}", list(&PAPER_ETA_R)),
            format!("{}", m.rolling_damping),
        );
    }
    differ(
        "rolling model",
        paper.models.rolling.keyword().into(),
        case.models.rolling.keyword().into(),
    );
    differ(
        "particles",
        format!("{}", paper.particles),
        format!("{}", case.particles),
    );
    differ("radii [m]", list(&paper.radii), list(&case.radii));
    differ(
        "size-class percentages",
        list(&paper.percentages),
        list(&case.percentages),
    );
    differ(
        "box x, z [m]",
        format!("{}, {}", paper.box_x, paper.box_z),
        format!("{}, {}", case.box_x, case.box_z),
    );
    differ(
        "normal stress [Pa]",
        format!("{}", paper.normal_stress),
        format!("{}", case.normal_stress),
    );
    let plates = |p: &Plates| match p {
        Plates::Flat => "flat".to_string(),
        Plates::Teeth { .. } => "toothed".to_string(),
    };
    differ("plates", plates(&paper.plates), plates(&case.plates));
    if case.fractions == Fractions::Number {
        out.push(Deviation {
            parameter: "size-class percentages of".into(),
            paper: "the mass (Table 1)".into(),
            case: "the number of grains".into(),
            note: Some(
                "only number fractions give the paper's h = 5 mm with 2500 grains at 10 MPa; \
                 mass fractions give about 2.6 mm"
                    .into(),
            ),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn case(p: Preset, rolling: RollingModel, mu_r: f64, eta_r: f64) -> ShearCase {
        ShearCase::preset(p, rolling, mu_r, eta_r, 1).unwrap()
    }

    fn names(d: &[Deviation]) -> Vec<&str> {
        d.iter().map(|d| d.parameter.as_str()).collect()
    }

    #[test]
    fn the_paper_preset_is_table_2() {
        let d = deviations(&case(Preset::Paper, RollingModel::Epsd, 0.5, 0.25));
        // only the project's stated reading of Table 1 remains
        assert_eq!(names(&d), vec!["size-class percentages of"], "{d:?}");
        assert!(d[0].note.is_some());
    }

    #[test]
    fn presets_and_changes_are_named() {
        let fast = deviations(&case(Preset::Fast, RollingModel::Epsd, 0.5, 0.0));
        assert!(names(&fast).contains(&"shear stages"), "{fast:?}");
        assert!(!names(&fast).contains(&"restitution e"), "{fast:?}");
        let ci = deviations(&case(Preset::Ci, RollingModel::Epsd2, 0.3, 0.5));
        for p in [
            "shear stages",
            "particles",
            "box x, z [m]",
            "rolling model",
            "rolling friction mu_r",
        ] {
            assert!(names(&ci).contains(&p), "{p}: {ci:?}");
        }
        assert!(!names(&ci).contains(&"rolling damping eta_r"), "{ci:?}");
        let e = case(Preset::Fast, RollingModel::Epsd, 0.0, 0.0)
            .with_restitution("--restitution", 0.5)
            .unwrap();
        let d = deviations(&e);
        let r = d.iter().find(|d| d.parameter == "restitution e").unwrap();
        assert_eq!((r.paper.as_str(), r.case.as_str()), ("1", "0.5"));
        assert_eq!(
            r.to_string(),
            "restitution e: paper 1, this run 0.5",
            "printed as a user reads it"
        );
    }
}
