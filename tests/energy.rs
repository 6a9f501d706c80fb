//! Energy and momentum of the shear box's time loop in a closed elastic system: the ci
//! preset's packing (300 particles, periodic in x and z) between flat plates held still (servo
//! speed 0, bottom plate at rest), Hertz with restitution 1, no sliding friction, no rolling
//! resistance, particles given random velocities. Then
//! - the total energy (kinetic, translational and rotational, plus the Hertz elastic energy
//!   `U = 8/15 Yeff sqrt(R*) delta^(5/2)` of every pair and wall contact) stays constant up to
//!   the integrator's bounded error (velocity Verlet: no drift);
//! - momentum along x and z (no plate force has an x or z component, pair forces are equal
//!   and opposite) stays constant to round-off;
//! - no torque acts (frictionless), so every angular velocity is unchanged bit for bit.
//!
//! Negative control: restitution 0.5 must lose energy (the check sees dissipation).

use dem_verify::packing::loose_packing;
use dem_verify::solver::material::sphere_mass;
use dem_verify::solver::shear::ShearSim;
use dem_verify::spec::shear::{CaseRequest, Overrides, Preset, Protocol, ShearCase};
use dem_verify::spec::RollingModel;

/// Deterministic uniform numbers in [-1, 1) (splitmix64).
fn uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

fn closed_case(restitution: f64) -> ShearCase {
    let (mut case, _) = ShearCase::build(&CaseRequest {
        preset: Preset::Ci,
        rolling: RollingModel::Off,
        mu_r: 0.0,
        eta_r: 0.0,
        seed: 3,
        protocol: Protocol::default(),
        overrides: Overrides {
            flat_plates: true,
            ..Overrides::default()
        },
        allow_inertial: false,
    })
    .unwrap();
    case.material.restitution = restitution;
    case.material.friction = 0.0;
    case.material.rolling_friction = 0.0;
    case
}

struct Budget {
    kinetic: f64,
    rotational: f64,
    elastic: f64,
    contacts: usize,
    momentum: [f64; 3],
    /// Sum of |m v| per component: the scale of the momentum's round-off.
    momentum_scale: [f64; 3],
}

impl Budget {
    fn total(&self) -> f64 {
        self.kinetic + self.rotational + self.elastic
    }
}

fn budget(sim: &ShearSim, case: &ShearCase) -> Budget {
    let m = &case.material;
    let y_eff = 1.0 / (2.0 * (1.0 - m.poisson_ratio * m.poisson_ratio) / m.youngs_modulus);
    let hertz = |delta: f64, r_eff: f64| 8.0 / 15.0 * y_eff * r_eff.sqrt() * delta.powf(2.5);
    let n = sim.x.len();
    let mut b = Budget {
        kinetic: 0.0,
        rotational: 0.0,
        elastic: 0.0,
        contacts: 0,
        momentum: [0.0; 3],
        momentum_scale: [0.0; 3],
    };
    for i in 0..n {
        let r = sim.radius[i];
        let mass = sphere_mass(r, m.density);
        let inertia = 0.4 * mass * r * r;
        for k in 0..3 {
            b.kinetic += 0.5 * mass * sim.v[i][k] * sim.v[i][k];
            b.rotational += 0.5 * inertia * sim.omega[i][k] * sim.omega[i][k];
            b.momentum[k] += mass * sim.v[i][k];
            b.momentum_scale[k] += (mass * sim.v[i][k]).abs();
        }
        // flat plates: surfaces at the plates' base y
        for delta in [
            r - (sim.x[i][1] - sim.bottom.base_y),
            r - (sim.top.base_y - sim.x[i][1]),
        ] {
            if delta > 0.0 {
                b.elastic += hertz(delta, r);
                b.contacts += 1;
            }
        }
        for j in i + 1..n {
            let mut d: [f64; 3] = std::array::from_fn(|k| sim.x[j][k] - sim.x[i][k]);
            // minimum image in the periodic x and z
            for (k, l) in [(0, case.box_x), (2, case.box_z)] {
                d[k] -= l * (d[k] / l).round();
            }
            let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let delta = sim.radius[i] + sim.radius[j] - dist;
            if delta > 0.0 {
                let r_eff = sim.radius[i] * sim.radius[j] / (sim.radius[i] + sim.radius[j]);
                b.elastic += hertz(delta, r_eff);
                b.contacts += 1;
            }
        }
    }
    b
}

/// Runs the closed system for 0.03 s at `dt_factor` times the preset's dt, with 200 budgets;
/// returns them and the angular velocities at the start and the end.
fn run(restitution: f64, dt_factor: f64) -> (Vec<Budget>, Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let mut case = closed_case(restitution);
    case.dt *= dt_factor;
    let steps = (20_000.0 / dt_factor).round() as u64;
    let every = steps / 200;
    let mut packing = loose_packing(&case);
    let mut state = 42u64;
    for (v, w) in packing.velocity.iter_mut().zip(packing.omega.iter_mut()) {
        for k in 0..3 {
            v[k] = 0.2 * uniform(&mut state);
            w[k] = 500.0 * uniform(&mut state);
        }
    }
    let mut sim = ShearSim::new(&case.setup(), &packing);
    sim.setup(0.0).unwrap();
    // the top plate held where it is: the servo's speed limit at zero
    sim.servo.vel_max = 0.0;
    let omega0 = sim.omega.clone();
    let mut out = vec![budget(&sim, &case)];
    for s in 1..=steps {
        sim.step().unwrap();
        if s % every == 0 {
            out.push(budget(&sim, &case));
        }
    }
    (out, omega0, sim.omega.clone())
}

/// The largest |E / E0 - 1| over a run.
fn worst_energy_error(b: &[Budget]) -> f64 {
    let e0 = b[0].total();
    b.iter()
        .map(|x| (x.total() / e0 - 1.0).abs())
        .fold(0.0, f64::max)
}

#[test]
fn a_closed_elastic_frictionless_packing_keeps_its_energy_and_momentum() {
    let (b, omega0, omega1) = run(1.0, 1.0);
    let e0 = b[0].total();
    let touching = b.iter().filter(|x| x.contacts > 0).count();
    let max_elastic = b.iter().map(|x| x.elastic / e0).fold(0.0, f64::max);
    let worst = worst_energy_error(&b);
    // the same 0.03 s at dt / 4
    let (b4, _, _) = run(1.0, 0.25);
    let worst4 = worst_energy_error(&b4);
    eprintln!(
        "E0 {e0:.6e} J; {touching} of {} samples with contacts; largest elastic share \
         {max_elastic:.3e}; worst |E/E0 - 1| {worst:.3e} at dt, {worst4:.3e} at dt / 4",
        b.len()
    );
    // the test means something only when particles collide and contacts store energy
    assert!(
        touching > b.len() / 2 && max_elastic > 1e-3,
        "too few contacts"
    );
    // the translational energy is exchanged, not lost
    let k_min = b.iter().map(|x| x.kinetic).fold(f64::INFINITY, f64::min);
    assert!(k_min > 0.5 * b[0].kinetic);
    // Velocity Verlet's error is bounded and falls with dt (second order; collisions of
    // 0.2 m/s last about 7 steps at the paper's dt): measured 3.1e-3 at dt, 1.6e-3 at dt / 2,
    // 8.7e-5 at dt / 4. A missing or wrong force term would not fall with dt.
    assert!(worst < 5e-3, "energy error {worst:e}");
    assert!(
        worst4 * 4.0 < worst,
        "energy error {worst4:e} at dt / 4, {worst:e} at dt"
    );
    for k in [0, 2] {
        let dp = (b.last().unwrap().momentum[k] - b[0].momentum[k]).abs();
        assert!(
            dp <= 1e-12 * b[0].momentum_scale[k],
            "momentum {k} changed by {dp:e} of {:e}",
            b[0].momentum_scale[k]
        );
    }
    assert_eq!(omega0, omega1, "a frictionless contact exerted a torque");
}

#[test]
fn a_damped_packing_loses_energy() {
    let (b, _, _) = run(0.5, 1.0);
    let lost = 1.0 - b.last().unwrap().total() / b[0].total();
    eprintln!("restitution 0.5: {lost:.3e} of the energy lost");
    assert!(lost > 0.1, "dissipation not seen: {lost:e}");
}
