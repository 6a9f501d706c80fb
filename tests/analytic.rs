//! Physics checks beside LIGGGHTS: the native solver *and* the stored LIGGGHTS outputs are
//! held against closed-form results, so that two codes agreeing on an artefact would still
//! be caught.
//! - rolling cases: M(t) = min(k_r omega t, mu_r R* Fn) with each model's k_r (cdt: the limit
//!   at once), through reversal, and the epsd/epsd3 dashpot C_r = eta_r 2 sqrt(I_r k_r);
//! - normal_elastic: Hertz maximum overlap and contact duration;
//! - normal_damped: the restitution the damping was built for;
//! - tangential cases: the spring obeys the Coulomb limit, |Ft| = mu_p Fn only when sliding.

#![allow(clippy::needless_range_loop)]

use dem_verify::deck::run_name;
use dem_verify::run::contact::{contact_runs, RollingChoice};
use dem_verify::series::{contact_series, Series};
use dem_verify::solver::material::sphere_mass;
use dem_verify::solver::two_body;
use dem_verify::spec::{hertz_collision, Case, Motion, RollingModel};
use std::path::Path;

/// Both codes' series of a case: (label, series).
fn both(case: &Case) -> Vec<(&'static str, Series)> {
    let stored = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("reference/contact")
        .join(run_name(case))
        .join("liggghts.csv");
    vec![
        (
            "native",
            contact_series(case, &two_body::run(&case.two_body()).unwrap()).unwrap(),
        ),
        ("liggghts", Series::read_csv(&stored).unwrap()),
    ]
}

fn vec_at(s: &Series, row: usize, name: &str) -> [f64; 3] {
    let c = |a: &str| {
        s.col(&format!("{name}_{a}[N m]"))
            .unwrap_or_else(|| panic!("{name}"))
    };
    [
        s.rows[row][c("x")],
        s.rows[row][c("y")],
        s.rows[row][c("z")],
    ]
}

fn rolling_cases(name: &str) -> Vec<Case> {
    contact_runs(name, None, RollingChoice::All).unwrap()
}

/// Closed-form rolling moment on particle 1 at step n, along the prescribed spin of
/// particle 2 (both particles held in place, constant overlap, so Fn is constant).
struct RollingTheory {
    kr: f64,
    m_max: f64,
    c_r: f64,
    omega: f64,
    dt: f64,
    cdt: bool,
    reverse_at: Option<u64>,
}

impl RollingTheory {
    fn new(case: &Case) -> Self {
        let p = case.material.pair_params(&case.models, case.dt);
        let (a, b) = (&case.particles[0], &case.particles[1]);
        let (r1, r2) = (a.radius, b.radius);
        let dist = ((b.position[0] - a.position[0]).powi(2)
            + (b.position[1] - a.position[1]).powi(2)
            + (b.position[2] - a.position[2]).powi(2))
        .sqrt();
        let delta = r1 + r2 - dist;
        let reff = r1 * r2 / (r1 + r2);
        let kn = 4.0 / 3.0 * p.y_eff * (reff * delta).sqrt();
        let kt = 8.0 * p.g_eff * (reff * delta).sqrt();
        let mu_r = case.material.rolling_friction;
        let kr = match case.models.rolling {
            RollingModel::Epsd => 2.25 * kn * mu_r * mu_r * reff * reff,
            RollingModel::Epsd2 => kt * reff * reff,
            RollingModel::Epsd3 => case.material.rolling_stiffness * kn * mu_r * mu_r * reff * reff,
            RollingModel::Cdt => 0.0,
            RollingModel::Off | RollingModel::EpsdImplicit => {
                unreachable!("not a contact-case model")
            }
        };
        let rho = case.material.density;
        let (ia, ib) = (
            sphere_mass(r1, rho) * r1 * r1,
            sphere_mass(r2, rho) * r2 * r2,
        );
        let i_r = 1.4 * ia * ib / (ia + ib);
        let c_r = if case.models.rolling.has_damping() {
            case.material.rolling_damping * 2.0 * (i_r * kr).sqrt()
        } else {
            0.0
        };
        let Motion::Rotate { omega } = b.motion else {
            panic!("rolling cases spin particle 2")
        };
        RollingTheory {
            kr,
            m_max: mu_r * reff * kn * delta,
            c_r,
            omega: (omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2]).sqrt(),
            dt: case.dt,
            cdt: case.models.rolling == RollingModel::Cdt,
            reverse_at: case.reverse_at_step,
        }
    }

    /// Signed moment along the initial spin direction at step n (without dashpot), and
    /// whether the spring is below the limit there.
    fn spring(&self, n: u64) -> (f64, bool) {
        if n == 0 {
            return (0.0, true);
        }
        let sign_after = |n: u64| match self.reverse_at {
            Some(r) if n > r => -1.0,
            _ => 1.0,
        };
        if self.cdt {
            return (sign_after(n) * self.m_max, false);
        }
        let step = self.kr * self.omega * self.dt;
        let mut m: f64 = 0.0;
        let mut below = true;
        for k in 1..=n {
            m += sign_after(k) * step;
            below = m.abs() <= self.m_max;
            m = m.clamp(-self.m_max, self.m_max);
        }
        (m, below)
    }

    /// Applied moment (with the dashpot below the limit).
    fn applied(&self, n: u64) -> f64 {
        let (m, below) = self.spring(n);
        let sign = match self.reverse_at {
            Some(r) if n > r => -1.0,
            _ => 1.0,
        };
        if below && n > 0 {
            m + sign * self.c_r * self.omega
        } else {
            m
        }
    }
}

fn check_rolling(case_name: &str) {
    for case in rolling_cases(case_name) {
        let th = RollingTheory::new(&case);
        let Motion::Rotate { omega } = case.particles[1].motion else {
            unreachable!()
        };
        let w = (omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2]).sqrt();
        let dir = [omega[0] / w, omega[1] / w, omega[2] / w];
        for (code, s) in both(&case) {
            let mut saturated = false;
            for (row, &n) in s.steps.iter().enumerate() {
                let m = vec_at(&s, row, "m_roll");
                let expect = th.applied(n);
                for k in 0..3 {
                    let err = (m[k] - expect * dir[k]).abs() / th.m_max;
                    assert!(
                        err < 1e-9,
                        "{case_name}/{}/{code} step {n}: m_roll {m:?} vs theory {expect:e} along {dir:?} (rel err {err:e})",
                        case.models.rolling
                    );
                }
                saturated |= th.spring(n).0.abs() >= th.m_max * (1.0 - 1e-12);
            }
            let expect_saturation = case_name != "rolling_elastic" && case_name != "rolling_damped";
            assert_eq!(
                saturated, expect_saturation,
                "{case_name}/{}/{code}: saturation",
                case.models.rolling
            );
        }
    }
}

#[test]
fn rolling_elastic_moment_grows_as_kr_omega_t() {
    check_rolling("rolling_elastic");
}

#[test]
fn rolling_plastic_moment_saturates_at_mu_r_rstar_fn() {
    check_rolling("rolling_plastic");
}

#[test]
fn rolling_unload_reverses_elastically_then_saturates_opposite() {
    check_rolling("rolling_unload");
}

#[test]
fn rolling_damped_adds_the_viscous_dashpot_below_the_limit() {
    check_rolling("rolling_damped");
}

#[test]
fn normal_elastic_matches_hertz_overlap_and_duration() {
    let case = &contact_runs("normal_elastic", None, RollingChoice::All).unwrap()[0];
    let p = case.material.pair_params(&case.models, case.dt);
    let (a, b) = (&case.particles[0], &case.particles[1]);
    let m = sphere_mass(a.radius, case.material.density);
    let v = 2.0 * (a.velocity[0].powi(2) + a.velocity[2].powi(2)).sqrt();
    let theory = hertz_collision(
        p.y_eff,
        a.radius * b.radius / (a.radius + b.radius),
        m / 2.0,
        v,
    );
    for (code, s) in both(case) {
        let fn_ = s.column("fn[N]").unwrap();
        let x1: Vec<[f64; 3]> = (0..s.rows.len()).map(|r| pos(&s, r, 1)).collect();
        let x2: Vec<[f64; 3]> = (0..s.rows.len()).map(|r| pos(&s, r, 2)).collect();
        let max_overlap = x1
            .iter()
            .zip(&x2)
            .map(|(p, q)| a.radius + b.radius - dist(*p, *q))
            .fold(f64::MIN, f64::max);
        let stride = (s.steps[1] - s.steps[0]) as f64;
        let duration = fn_.iter().filter(|f| **f > 0.0).count() as f64 * stride * case.dt;
        let e1 = (max_overlap / theory.max_overlap - 1.0).abs();
        let e2 = (duration / theory.duration - 1.0).abs();
        assert!(
            e1 < 2e-3,
            "{code}: max overlap {max_overlap:e} vs Hertz {:e}",
            theory.max_overlap
        );
        assert!(
            e2 < 0.02,
            "{code}: contact duration {duration:e} vs Hertz {:e}",
            theory.duration
        );
        // e = 1: the rebound speed equals the approach speed.
        let last = s.rows.len() - 1;
        let vx = |k: usize| s.rows[last][s.col(&format!("v_{k}_x[m/s]")).unwrap()];
        let vz = |k: usize| s.rows[last][s.col(&format!("v_{k}_z[m/s]")).unwrap()];
        let rebound = ((vx(1) - vx(2)).powi(2) + (vz(1) - vz(2)).powi(2)).sqrt();
        assert!(
            (rebound / v - 1.0).abs() < 1e-6,
            "{code}: rebound {rebound} vs {v}"
        );
    }
}

#[test]
fn normal_damped_restitution_is_close_to_e() {
    let case = &contact_runs("normal_damped", None, RollingChoice::All).unwrap()[0];
    let a = &case.particles[0];
    let v = 2.0 * (a.velocity[0].powi(2) + a.velocity[2].powi(2)).sqrt();
    for (code, s) in both(case) {
        let last = s.rows.len() - 1;
        let get = |h: &str| s.rows[last][s.col(h).unwrap()];
        let rebound = ((get("v_1_x[m/s]") - get("v_2_x[m/s]")).powi(2)
            + (get("v_1_z[m/s]") - get("v_2_z[m/s]")).powi(2))
        .sqrt();
        let e = rebound / v;
        // The hertz damping (2 sqrt(5/6) beta sqrt(Sn m*)) is built to give e; it does so
        // within a few per cent for Hertz contacts.
        assert!((e - 0.5).abs() < 0.03, "{code}: effective restitution {e}");
    }
}

/// LIGGGHTS' history model caps the *spring*: `kt |shear| <= mu_p |Fn|` always, and while
/// sliding `|Ft| = mu_p |Fn|` exactly. While sticking the dashpot `-gammat vtr` is added on
/// top of the spring, so |Ft| may exceed mu_p Fn briefly (e.g. just after a reversal).
#[test]
fn tangential_spring_obeys_the_coulomb_limit() {
    for (name, must_slide) in [("tangential_stick", false), ("tangential_slip", true)] {
        for case in contact_runs(name, None, RollingChoice::All).unwrap() {
            let mu = case.material.friction;
            let p = case.material.pair_params(&case.models, case.dt);
            let (a, b) = (&case.particles[0], &case.particles[1]);
            let reff = a.radius * b.radius / (a.radius + b.radius);
            for (code, s) in both(&case) {
                let fn_ = s.column("fn[N]").unwrap();
                let mut slid = false;
                for r in 0..s.rows.len() {
                    let c = |h: &str| s.rows[r][s.col(h).unwrap()];
                    let ft =
                        (c("ft_x[N]").powi(2) + c("ft_y[N]").powi(2) + c("ft_z[N]").powi(2)).sqrt();
                    let shear = (c("shear_x[m]").powi(2)
                        + c("shear_y[m]").powi(2)
                        + c("shear_z[m]").powi(2))
                    .sqrt();
                    let overlap = a.radius + b.radius - dist(pos(&s, r, 1), pos(&s, r, 2));
                    let kt = 8.0 * p.g_eff * (reff * overlap).sqrt();
                    let limit = mu * fn_[r];
                    assert!(
                        kt * shear <= limit * (1.0 + 1e-9),
                        "{name}/{code}: spring {} > mu Fn {limit}",
                        kt * shear
                    );
                    slid |= limit > 0.0 && (ft / limit - 1.0).abs() < 1e-9;
                    if !must_slide {
                        assert!(
                            ft < limit,
                            "{name}/{code}: |Ft| {ft} reached mu Fn {limit} while sticking"
                        );
                    }
                }
                assert_eq!(
                    slid, must_slide,
                    "{name}/{}/{code}: sliding",
                    case.models.rolling
                );
            }
        }
    }
}

fn pos(s: &Series, row: usize, k: usize) -> [f64; 3] {
    let c = |a: &str| s.rows[row][s.col(&format!("x_{k}_{a}[m]")).unwrap()];
    [c("x"), c("y"), c("z")]
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Sphere on the mesh wall, held at a fixed overlap while it spins: the normal force is
/// Hertz's static one, Fn = 4/3 Y* sqrt(R delta) delta with Y* = E / (2 (1 - nu^2)) (the wall
/// has the sphere's material) and R* = R (a plane), in both codes at every step.
#[test]
fn wall_normal_force_is_hertz_for_a_sphere_on_a_plane() {
    for case in contact_runs("wall_rolling_plastic", None, RollingChoice::All).unwrap() {
        let m = &case.material;
        let p = &case.particles[0];
        let w = case.wall.as_ref().unwrap();
        let delta = p.radius - (p.position[2] - w.z);
        let y_star = m.youngs_modulus / (2.0 * (1.0 - m.poisson_ratio * m.poisson_ratio));
        let hertz = 4.0 / 3.0 * y_star * (p.radius * delta).sqrt() * delta;
        for (code, s) in both(&case) {
            let fn_ = s.column("fn[N]").unwrap();
            assert!(fn_.len() > 100, "{code}: {} rows", fn_.len());
            for (k, f) in fn_.iter().enumerate() {
                assert!(
                    (f / hertz - 1.0).abs() < 1e-12,
                    "{code}/{}: step {}: Fn {f:e} vs Hertz {hertz:e}",
                    case.models.rolling,
                    s.steps[k]
                );
            }
        }
    }
}
