//! Time loop of a contact case: two spheres, or one sphere and a triangle-mesh wall, in
//! LIGGGHTS' order of operations (Verlet::setup / Verlet::run with fix nve/sphere,
//! fix move, pair gran and fix wall/gran). Owns all state; returns frames, does no I/O.

use super::contact::{
    moved_beyond_half_skin, surfaces_intersect, ContactData, ContactHistory, ForceData,
};
use super::integrate::NveSphere;
use super::kinematics::{rotation_period, FixMove};
use super::material::{sphere_mass, PairParams};
use super::mesh::{square_wall, TriContact, Triangle};
use super::vec3::V3;
use crate::error::{Error, Result};

/// Neighbour skin of the contact cases [m], the same in the deck: a quarter of the smallest
/// radius.
pub fn contact_skin(radii: impl IntoIterator<Item = f64>) -> f64 {
    0.25 * radii.into_iter().fold(f64::INFINITY, f64::min)
}

/// A contact case as the solver reads it, in its own types (built from a case description
/// by `spec::Case::two_body`): the pair constants, the bodies, the wall and the run's length.
#[derive(Clone, Debug)]
pub struct TwoBody {
    /// The one time step [s] (nve/sphere's `dtv`; the kernels' copy in `params` is set from
    /// it).
    pub dt: f64,
    /// Particle against particle.
    pub params: PairParams,
    /// The sphere against the wall (the wall's own elastic constants, or `params`').
    pub wall_params: PairParams,
    /// Particle density [kg/m^3].
    pub density: f64,
    pub bodies: Vec<BodySetup>,
    /// The square wall: its height z [m] and half side [m].
    pub wall: Option<(f64, f64)>,
    /// Steps of the run, output interval, and the step whose imposed motions reverse.
    pub steps: u64,
    pub output_every: u64,
    pub reverse_at_step: Option<u64>,
}

/// One sphere at the start: its state, radius, and how it moves.
#[derive(Clone, Copy, Debug)]
pub struct BodySetup {
    pub x: V3,
    pub v: V3,
    pub omega: V3,
    pub radius: f64,
    pub motion: BodyMotion,
}

/// How a sphere moves: integrated by nve/sphere, held still, or by a `fix move`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BodyMotion {
    Free,
    Fixed,
    /// Spins about its own centre at angular velocity omega [rad/s] (`fix move rotate`).
    Rotate(V3),
    /// Moves at a constant velocity [m/s] (`fix move linear`).
    Linear(V3),
}

/// Per-atom state at an output step, as a LIGGGHTS `dump custom` row.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AtomState {
    pub x: V3,
    pub v: V3,
    pub f: V3,
    pub omega: V3,
    pub torque: V3,
}

/// One output step: all atoms (in id order) and the history of the touching contact, oriented
/// as LIGGGHTS stores it with atom 1 as `i` (zero when nothing touches).
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub step: u64,
    pub atoms: Vec<AtomState>,
    pub touching: bool,
    pub history: ContactHistory,
}

struct Body {
    s: AtomState,
    radius: f64,
    mass: f64,
    motion: Option<FixMove>,
    integrate: bool,
}

struct Sim {
    params: PairParams,
    /// The sphere against the wall (the wall's own elastic constants, or `params`).
    wall_params: PairParams,
    nve: NveSphere,
    bodies: Vec<Body>,
    wall: Option<[Triangle; 2]>,
    /// Pair history while the pair is in the neighbour list.
    pair_hist: Option<ContactHistory>,
    pair_touching: bool,
    /// Wall history per triangle while in contact.
    wall_hist: [Option<ContactHistory>; 2],
    skin: f64,
    xhold: Vec<V3>,
    step: u64,
}

/// Runs a contact case and returns a frame at step 0 and every `output_every`.
pub fn run(case: &TwoBody) -> Result<Vec<Frame>> {
    let mut sim = Sim::new(case);
    let mut frames = Vec::with_capacity((case.steps / case.output_every + 1) as usize);
    let reverse = case.reverse_at_step;
    sim.setup()?;
    frames.push(sim.frame());
    while sim.step < case.steps {
        if Some(sim.step) == reverse {
            sim.reverse_motions();
            sim.setup()?;
        }
        sim.advance()?;
        if sim.step.is_multiple_of(case.output_every) {
            frames.push(sim.frame());
        }
    }
    Ok(frames)
}

impl Sim {
    fn new(case: &TwoBody) -> Self {
        let rho = case.density;
        let bodies: Vec<Body> = case
            .bodies
            .iter()
            .map(|p| {
                // The data file holds the diameter; LIGGGHTS reads radius = 0.5 * diameter.
                let radius = 0.5 * (2.0 * p.radius);
                let motion = match p.motion {
                    BodyMotion::Rotate(omega) => {
                        Some(FixMove::rotate(p.x, omega, rotation_period(omega)))
                    }
                    BodyMotion::Linear(velocity) => Some(FixMove::Linear {
                        xoriginal: p.x,
                        velocity,
                        time_origin: 0,
                    }),
                    BodyMotion::Free | BodyMotion::Fixed => None,
                };
                Body {
                    s: AtomState {
                        x: p.x,
                        v: p.v,
                        omega: p.omega,
                        ..Default::default()
                    },
                    radius,
                    mass: sphere_mass(radius, rho),
                    motion,
                    integrate: p.motion == BodyMotion::Free,
                }
            })
            .collect();
        let xhold = bodies.iter().map(|b| b.s.x).collect();
        // the one time step, as in the shear box: nve's dtv, the kernels' copies set from it
        let nve = NveSphere::new(case.dt);
        let at_dt = |p: PairParams| PairParams { dt: nve.dtv, ..p };
        Sim {
            params: at_dt(case.params),
            wall_params: at_dt(case.wall_params),
            nve,
            bodies,
            wall: case.wall.map(|(z, half)| square_wall(z, half)),
            pair_hist: None,
            pair_touching: false,
            wall_hist: [None, None],
            skin: contact_skin(case.bodies.iter().map(|b| b.radius)),
            xhold,
            step: 0,
        }
    }

    /// Verlet::setup: neighbour build, then forces without history update.
    fn setup(&mut self) -> Result<()> {
        self.build_neighbors();
        self.compute_forces(false)
    }

    /// A new run after `unfix`/`fix`: rotations about the negated axis, linear motions with
    /// negated velocity from the current position, time origin = current step.
    fn reverse_motions(&mut self) {
        let step = self.step;
        for b in &mut self.bodies {
            b.motion = match b.motion {
                Some(FixMove::Rotate {
                    omega_rotate,
                    runit,
                    ..
                }) => Some(FixMove::Rotate {
                    point: b.s.x,
                    omega_rotate,
                    runit: [-runit[0], -runit[1], -runit[2]],
                }),
                Some(FixMove::Linear { velocity, .. }) => Some(FixMove::Linear {
                    xoriginal: b.s.x,
                    velocity: [-velocity[0], -velocity[1], -velocity[2]],
                    time_origin: step,
                }),
                None => None,
            };
        }
    }

    fn advance(&mut self) -> Result<()> {
        self.step += 1;
        let (step, dt) = (self.step, self.nve.dtv);
        for b in &mut self.bodies {
            if b.integrate {
                let s = &mut b.s;
                self.nve.initial(
                    &mut s.x,
                    &mut s.v,
                    &mut s.omega,
                    s.f,
                    s.torque,
                    b.radius,
                    b.mass,
                );
            }
            if let Some(m) = &b.motion {
                m.initial_integrate(step, dt, &mut b.s.x, &mut b.s.v, &mut b.s.omega);
            }
        }
        if self.needs_rebuild() {
            self.build_neighbors();
        }
        self.compute_forces(true)?;
        for b in &mut self.bodies {
            if b.integrate {
                let s = &mut b.s;
                self.nve
                    .finish(&mut s.v, &mut s.omega, s.f, s.torque, b.radius, b.mass);
            }
        }
        for b in &self.bodies {
            let s = &b.s;
            let finite = [s.x, s.v, s.f, s.omega, s.torque]
                .iter()
                .all(|v| v.iter().all(|c| c.is_finite()));
            if !finite {
                return Err(Error::Solver {
                    step,
                    msg: "non-finite particle state".into(),
                });
            }
        }
        Ok(())
    }

    /// `Neighbor::check_distance`: rebuild when any atom moved more than skin/2.
    fn needs_rebuild(&self) -> bool {
        self.bodies
            .iter()
            .zip(&self.xhold)
            .any(|(b, h)| moved_beyond_half_skin(b.s.x, *h, self.skin))
    }

    /// Neighbour build (neigh_gran.cpp): a pair beyond `radsum + skin` leaves the list; a
    /// listed pair keeps its history only if it is touching at the build.
    fn build_neighbors(&mut self) {
        self.xhold = self.bodies.iter().map(|b| b.s.x).collect();
        if self.bodies.len() == 2 {
            let (a, b) = (&self.bodies[0], &self.bodies[1]);
            let d = [
                a.s.x[0] - b.s.x[0],
                a.s.x[1] - b.s.x[1],
                a.s.x[2] - b.s.x[2],
            ];
            let rsq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let cut = a.radius + b.radius + self.skin;
            let radsum = a.radius + b.radius;
            if rsq > cut * cut {
                self.pair_hist = None;
            } else if self.pair_hist.is_none() || rsq >= radsum * radsum {
                self.pair_hist = Some(ContactHistory::default());
            }
        }
    }

    /// force_clear, pair forces (pair_gran_base.h `compute_force`), then wall forces
    /// (fix_wall_gran.cpp `post_force_mesh`).
    fn compute_forces(&mut self, update_history: bool) -> Result<()> {
        for b in &mut self.bodies {
            b.s.f = [0.0; 3];
            b.s.torque = [0.0; 3];
        }
        self.pair_touching = false;
        if self.bodies.len() == 2 {
            self.pair_force(update_history);
        }
        if self.wall.is_some() {
            self.wall_force(update_history)?;
        }
        Ok(())
    }

    fn pair_force(&mut self, update_history: bool) {
        let Some(hist) = self.pair_hist.as_mut() else {
            return;
        };
        let (bi, bj) = (&self.bodies[0], &self.bodies[1]);
        let delta = [
            bi.s.x[0] - bj.s.x[0],
            bi.s.x[1] - bj.s.x[1],
            bi.s.x[2] - bj.s.x[2],
        ];
        let rsq = delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2];
        let radsum = bi.radius + bj.radius;
        if rsq >= radsum * radsum {
            return;
        }
        let mut cd = ContactData::pair(
            delta,
            rsq,
            bi.radius,
            bj.radius,
            bi.mass,
            bj.mass,
            (bi.s.v, bj.s.v),
            (bi.s.omega, bj.s.omega),
        );
        let (fi, fj, _) = surfaces_intersect(&mut cd, &self.params, hist, update_history);
        self.pair_touching = true;
        add_force(&mut self.bodies[0].s, &fi);
        add_force(&mut self.bodies[1].s, &fj);
    }

    fn wall_force(&mut self, update_history: bool) -> Result<()> {
        let tris = self.wall.expect("wall present");
        for (t, tri) in tris.iter().enumerate() {
            let b = &self.bodies[0];
            let radi = b.radius;
            match tri.resolve(b.s.x) {
                TriContact::Face { d, delta } => {
                    let deltan = d - radi; // resolveTriSphereContactBary: d - rSphere
                    if deltan > 0.0 {
                        self.wall_hist[t] = None;
                        continue;
                    }
                    let mut cd =
                        ContactData::wall(radi, b.mass, delta, deltan, b.s.v, [0.0; 3], b.s.omega);
                    let hist = self.wall_hist[t].get_or_insert_with(ContactHistory::default);
                    let (fi, _, _) =
                        surfaces_intersect(&mut cd, &self.wall_params, hist, update_history);
                    add_force(&mut self.bodies[0].s, &fi);
                }
                TriContact::EdgeOrCorner { d } => {
                    if d <= radi {
                        return Err(Error::Solver {
                            step: self.step,
                            msg: "sphere touches a wall edge or corner; the contact cases \
                                  support face contacts only"
                                .into(),
                        });
                    }
                    self.wall_hist[t] = None;
                }
            }
        }
        Ok(())
    }

    fn frame(&self) -> Frame {
        let (touching, history) = if self.wall.is_some() {
            match self.wall_hist.iter().flatten().next() {
                Some(h) => (true, *h),
                None => (false, ContactHistory::default()),
            }
        } else if self.pair_touching {
            (true, self.pair_hist.unwrap_or_default())
        } else {
            (false, ContactHistory::default())
        };
        Frame {
            step: self.step,
            atoms: self.bodies.iter().map(|b| b.s).collect(),
            touching,
            history,
        }
    }
}

/// pair_gran_base.h `force_update`: `f += relax * delta_F` with relax = 1 (exact).
fn add_force(s: &mut AtomState, fd: &ForceData) {
    for k in 0..3 {
        s.f[k] += fd.delta_f[k];
        s.torque[k] += fd.delta_torque[k];
    }
}
