//! Case descriptions: the only serde boundary for inputs.
//!
//! A case file (TOML, `version = 1`) is parsed into [`CaseFile`] and validated into a [`Case`].
//! Both the LIGGGHTS deck ([`crate::deck`]) and the native run ([`crate::solver`]) are made
//! from the same validated `Case`, so they cannot drift apart. Validation refuses anything a
//! deck could not represent faithfully or that would let a case file inject deck commands:
//! names are identifiers, every number is finite and in range.

pub mod builtin;
pub mod paper_table;
pub mod shear;
pub mod stability_shear;
pub mod windows;

pub use crate::solver::stability::{hertz_collision, HertzCollision};
// the contact models a case names are the solver's (one per LIGGGHTS keyword)
pub use crate::solver::contact::models::{NormalModel, RollingModel, TangentialModel};

use crate::error::{Error, Result};
use crate::solver::material::{Coefficients, Elastic, PairParams};
use crate::solver::two_body::{contact_skin, BodyMotion, BodySetup, TwoBody};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Current case-file format version.
pub const CASE_VERSION: u32 = 1;

/// Material constants (one material for particles and walls), SI units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Young's modulus E [Pa] (`youngsModulus`).
    pub youngs_modulus: f64,
    /// Poisson's ratio nu [-] (`poissonsRatio`).
    pub poisson_ratio: f64,
    /// Particle density rho [kg/m^3].
    pub density: f64,
    /// Coefficient of restitution e [-] (`coefficientRestitution`), 0.05 < e <= 1.
    pub restitution: f64,
    /// Sliding friction mu_p [-] (`coefficientFriction`).
    pub friction: f64,
    /// Rolling friction mu_r [-] (`coefficientRollingFriction`).
    #[serde(default)]
    pub rolling_friction: f64,
    /// Rolling viscous damping eta_r [-] (`coefficientRollingViscousDamping`, epsd/epsd3).
    #[serde(default)]
    pub rolling_damping: f64,
    /// epsd3 rolling stiffness factor [-] (`fix property/global rollingStiffness scalar`, the
    /// name global_properties.cpp registers), >= 1 in SI.
    #[serde(default = "default_rolling_stiffness")]
    pub rolling_stiffness: f64,
}

/// Rayleigh time of a sphere of radius `r` of material `m` [s]
/// ([`crate::solver::stability::rayleigh_time`]).
pub fn rayleigh_time(m: &Material, r: f64) -> f64 {
    crate::solver::stability::rayleigh_time(m.elastic(), m.density, r)
}

fn default_rolling_stiffness() -> f64 {
    2.25
}

impl Material {
    /// Validates every constant as LIGGGHTS requires it (the one material check of the crate,
    /// used by contact and shear cases). `cli_names` adds the command-line option to the names
    /// of mu_r and eta_r (`--mu-r`, `--eta-r`), where a shear case takes them from.
    pub fn validate(&self, cli_names: bool) -> Result<()> {
        let m = self;
        let (rf, rd) = if cli_names {
            (
                "material.rolling_friction (--mu-r)",
                "material.rolling_damping (--eta-r)",
            )
        } else {
            ("material.rolling_friction", "material.rolling_damping")
        };
        let (rf, rd) = (rf.to_string(), rd.to_string());
        check_elastic("material", m.youngs_modulus, m.poisson_ratio)?;
        positive("material.density", m.density)?;
        finite("material.restitution", m.restitution)?;
        if !(m.restitution > 0.05 && m.restitution <= 1.0) {
            return Err(Error::invalid(
                "material.restitution",
                m.restitution,
                "0.05 < e <= 1 (LIGGGHTS' range)",
            ));
        }
        check_coefficient("material.friction", m.friction)?;
        check_coefficient(&rf, m.rolling_friction)?;
        check_coefficient(&rd, m.rolling_damping)?;
        finite("material.rolling_stiffness", m.rolling_stiffness)?;
        if m.rolling_stiffness < 1.0 {
            return Err(Error::invalid(
                "material.rolling_stiffness",
                m.rolling_stiffness,
                ">= 1 (LIGGGHTS epsd3 in SI units)",
            ));
        }
        Ok(())
    }
}

impl Material {
    /// The elastic constants the solver reads.
    pub fn elastic(&self) -> Elastic {
        Elastic {
            youngs_modulus: self.youngs_modulus,
            poisson_ratio: self.poisson_ratio,
        }
    }

    /// The pair constants of this material with itself, at the time step `dt`.
    pub fn pair_params(&self, models: &Models, dt: f64) -> PairParams {
        self.pair_params_against(self.elastic(), models, dt)
    }

    /// The pair constants of a particle of this material against a body of elastic constants
    /// `other` (a wall's own modulus): the pair coefficients are the material's for every
    /// type pair, as the decks write them.
    pub fn pair_params_against(&self, other: Elastic, models: &Models, dt: f64) -> PairParams {
        let c = Coefficients {
            restitution: self.restitution,
            friction: self.friction,
            rolling_friction: self.rolling_friction,
            rolling_damping: self.rolling_damping,
            rolling_stiffness: self.rolling_stiffness,
        };
        PairParams::between(
            self.elastic(),
            other,
            c,
            models.rolling,
            models.torsion_torque,
            dt,
        )
    }
}

/// Contact model composition, as in `pair_style gran model hertz tangential history ...`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Models {
    #[serde(default = "default_normal")]
    pub normal: NormalModel,
    #[serde(default = "default_tangential")]
    pub tangential: TangentialModel,
    pub rolling: RollingModel,
    /// LIGGGHTS `torsionTorque on|off` of the rolling models (default off).
    #[serde(default)]
    pub torsion_torque: bool,
}

fn default_normal() -> NormalModel {
    NormalModel::Hertz
}
fn default_tangential() -> TangentialModel {
    TangentialModel::History
}

/// Imposed kinematics of a particle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Motion {
    /// Integrated by nve/sphere.
    Free,
    /// Not integrated: position, velocity and angular velocity stay as given.
    Fixed,
    /// Spins about its own centre at `omega` [rad/s] (LIGGGHTS `fix move rotate`).
    Rotate {
        #[serde(deserialize_with = "exactly3")]
        omega: [f64; 3],
    },
    /// Moves at constant `velocity` [m/s] (LIGGGHTS `fix move linear`).
    Linear {
        #[serde(deserialize_with = "exactly3")]
        velocity: [f64; 3],
    },
}

/// One sphere of a contact case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleSpec {
    /// Radius [m].
    pub radius: f64,
    /// Initial position [m].
    #[serde(deserialize_with = "exactly3")]
    pub position: [f64; 3],
    /// Initial velocity [m/s].
    #[serde(default, deserialize_with = "exactly3")]
    pub velocity: [f64; 3],
    /// Initial angular velocity [rad/s].
    #[serde(default, deserialize_with = "exactly3")]
    pub omega: [f64; 3],
    #[serde(default = "default_motion")]
    pub motion: Motion,
}

/// A vector of exactly three numbers: serde's fixed-size array reads the first three of a
/// longer list and drops the rest silently (`position = [0, 0, 1.6e-3, 5, "junk"]` was read as
/// its first three), so the list is read whole and its length checked.
fn exactly3<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<[f64; 3], D::Error> {
    let v = Vec::<f64>::deserialize(d)?;
    <[f64; 3]>::try_from(v.as_slice())
        .map_err(|_| serde::de::Error::invalid_length(v.len(), &"three numbers [x, y, z]"))
}

fn default_motion() -> Motion {
    Motion::Free
}

/// A flat triangle-mesh wall: the square |x|,|y| <= half_size at height z, normal +z, made of
/// two triangles (LIGGGHTS `fix mesh/surface` + `fix wall/gran ... mesh`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// Height of the plane [m].
    pub z: f64,
    /// Half the side of the square [m].
    pub half_size: f64,
    /// The wall's own elastic constants (a second atom type in LIGGGHTS, the mesh's `type 2`);
    /// absent: the wall is made of `material` like the particles. Restitution and friction
    /// stay those of `material` for every type pair.
    #[serde(default)]
    pub material: Option<WallMaterial>,
}

/// Elastic constants of a wall with its own material, e.g. a near-rigid plane (Chung & Ooi's
/// benchmark tests 2-4 use a wall 1000 times stiffer than the sphere).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallMaterial {
    /// Young's modulus of the wall [Pa].
    pub youngs_modulus: f64,
    /// Poisson's ratio of the wall [-].
    pub poisson_ratio: f64,
}

impl WallMaterial {
    /// The elastic constants the solver reads.
    pub fn elastic(&self) -> Elastic {
        Elastic {
            youngs_modulus: self.youngs_modulus,
            poisson_ratio: self.poisson_ratio,
        }
    }
}

/// Checks Young's modulus and Poisson's ratio as LIGGGHTS requires them (E >= 5e6 Pa in SI,
/// 0 <= nu < 0.5): the one rule for the particles' and a wall's elastic constants.
pub fn check_elastic(prefix: &str, youngs_modulus: f64, poisson_ratio: f64) -> Result<()> {
    let e_field = format!("{prefix}.youngs_modulus");
    let nu_field = format!("{prefix}.poisson_ratio");
    positive(&e_field, youngs_modulus)?;
    range_ge(
        &e_field,
        youngs_modulus,
        5e6,
        "LIGGGHTS requires >= 5e6 Pa in SI",
    )?;
    finite(&nu_field, poisson_ratio)?;
    if !(0.0..0.5).contains(&poisson_ratio) {
        return Err(Error::invalid(nu_field, poisson_ratio, "0 <= nu < 0.5"));
    }
    Ok(())
}

/// A case file as written by a user (before validation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseFile {
    /// Format version; must be 1.
    pub version: u32,
    /// Identifier: letters, digits, `_` and `-`, at most 64 characters.
    pub name: String,
    /// One line shown by `verify contact --list`. Never written into a deck.
    #[serde(default)]
    pub description: String,
    /// Time step [s].
    pub dt: f64,
    /// Number of time steps.
    pub steps: u64,
    /// Output interval [steps].
    pub output_every: u64,
    /// Step at which prescribed rotations and velocities are reversed (a second LIGGGHTS run).
    #[serde(default)]
    pub reverse_at_step: Option<u64>,
    /// Rolling models this case is run with by `--rolling all` (default: `models.rolling`).
    #[serde(default)]
    pub rolling_models: Vec<RollingModel>,
    pub material: Material,
    pub models: Models,
    pub particles: Vec<ParticleSpec>,
    #[serde(default)]
    pub wall: Option<WallSpec>,
}

/// A validated case: every field checked, ready for both codes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Case {
    pub file: CaseFile,
    /// Warnings found during validation (e.g. dt above 20 % of the Rayleigh time).
    pub warnings: Vec<String>,
}

impl std::ops::Deref for Case {
    type Target = CaseFile;
    fn deref(&self) -> &CaseFile {
        &self.file
    }
}

impl Case {
    /// The case as the two-body solver reads it (its own types: the pair constants at the
    /// case's dt, the bodies and their motions, the wall).
    pub fn two_body(&self) -> TwoBody {
        let m = &self.material;
        let wall = self.wall.as_ref();
        let other = wall
            .and_then(|w| w.material)
            .map_or(m.elastic(), |w| w.elastic());
        TwoBody {
            dt: self.dt,
            params: m.pair_params(&self.models, self.dt),
            wall_params: m.pair_params_against(other, &self.models, self.dt),
            density: m.density,
            bodies: self
                .particles
                .iter()
                .map(|p| BodySetup {
                    x: p.position,
                    v: p.velocity,
                    omega: p.omega,
                    radius: p.radius,
                    motion: match p.motion {
                        Motion::Free => BodyMotion::Free,
                        Motion::Fixed => BodyMotion::Fixed,
                        Motion::Rotate { omega } => BodyMotion::Rotate(omega),
                        Motion::Linear { velocity } => BodyMotion::Linear(velocity),
                    },
                })
                .collect(),
            wall: wall.map(|w| (w.z, w.half_size)),
            steps: self.steps,
            output_every: self.output_every,
            reverse_at_step: self.reverse_at_step,
        }
    }

    /// The neighbour skin of the case (a quarter of the smallest radius), as the solver and
    /// the deck use it.
    pub fn skin(&self) -> f64 {
        contact_skin(self.particles.iter().map(|p| p.radius))
    }
}

impl CaseFile {
    /// Parses TOML text; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &Path) -> Result<Self> {
        toml::from_str(text).map_err(|source| Error::CaseFile {
            path: origin.to_path_buf(),
            source,
        })
    }

    /// Reads and parses a case file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Self::from_toml(&text, path)
    }

    /// The rolling models `--rolling all` runs this case with.
    pub fn applicable_rolling(&self) -> Vec<RollingModel> {
        if self.rolling_models.is_empty() {
            vec![self.models.rolling]
        } else {
            self.rolling_models.clone()
        }
    }

    /// A copy of this case with another rolling model.
    pub fn with_rolling(&self, model: RollingModel) -> CaseFile {
        let mut c = self.clone();
        c.models.rolling = model;
        c
    }

    /// Validates every field; see the module doc.
    pub fn validate(self) -> Result<Case> {
        if self.version != CASE_VERSION {
            return Err(Error::invalid("version", self.version, "1"));
        }
        check_identifier("name", &self.name)?;
        if self.description.contains(['\n', '\r']) {
            return Err(Error::invalid(
                "description",
                "(multi-line text)",
                "a single line",
            ));
        }
        let m = &self.material;
        m.validate(false)?;
        self.check_models()?;
        self.check_run()?;
        self.check_particles()?;
        let rmin = self
            .particles
            .iter()
            .map(|p| p.radius)
            .fold(f64::INFINITY, f64::min);
        match &self.wall {
            Some(w) => self.check_wall(w)?,
            None => self.check_pair(rmin)?,
        }
        let warnings = check_dt(self.dt, m, rmin)?.into_iter().collect();
        for r in self.applicable_rolling() {
            check_damping_model(
                &format!("material.rolling_damping (with rolling_models `{r}`)"),
                m.rolling_damping,
                r,
            )?;
        }
        Ok(Case {
            file: self,
            warnings,
        })
    }

    /// The models: one LIGGGHTS has (a contact case is compared with it), damped if eta_r > 0.
    fn check_models(&self) -> Result<()> {
        let m = &self.material;
        if self.models.rolling.native_only() {
            return Err(Error::invalid(
                "models.rolling",
                self.models.rolling,
                "a LIGGGHTS model (contact cases compare with LIGGGHTS): off, cdt, epsd, epsd2, epsd3",
            ));
        }
        check_damping_model(
            "material.rolling_damping",
            m.rolling_damping,
            self.models.rolling,
        )?;
        Ok(())
    }

    /// The run: dt, steps, output interval, the step of the reversal.
    fn check_run(&self) -> Result<()> {
        positive("dt", self.dt)?;
        if self.steps == 0 || self.steps > 100_000_000 {
            return Err(Error::invalid("steps", self.steps, "1 ..= 100000000"));
        }
        if self.output_every == 0 || self.output_every > self.steps {
            return Err(Error::invalid(
                "output_every",
                self.output_every,
                format!("1 ..= steps ({})", self.steps),
            ));
        }
        if let Some(r) = self.reverse_at_step {
            if r == 0 || r >= self.steps {
                return Err(Error::invalid(
                    "reverse_at_step",
                    r,
                    format!("1 ..= {} (strictly inside the run)", self.steps - 1),
                ));
            }
        }
        Ok(())
    }

    /// The spheres: how many, their sizes, states and motions within bounds, inside the box.
    fn check_particles(&self) -> Result<()> {
        let expected = if self.wall.is_some() { 1 } else { 2 };
        if self.particles.len() != expected {
            return Err(Error::invalid(
                "particles",
                format!("{} entries", self.particles.len()),
                format!(
                    "{expected} ({})",
                    if expected == 1 {
                        "one sphere against the wall"
                    } else {
                        "two spheres"
                    }
                ),
            ));
        }
        for (k, p) in self.particles.iter().enumerate() {
            let f = |s: &str| format!("particles[{k}].{s}");
            positive(&f("radius"), p.radius)?;
            within(&f("radius"), p.radius, MAX_LENGTH_M, "m")?;
            bounded3(&f("position"), p.position, MAX_LENGTH_M, "m")?;
            bounded3(&f("velocity"), p.velocity, MAX_SPEED_M_S, "m/s")?;
            bounded3(&f("omega"), p.omega, MAX_OMEGA_RAD_S, "rad/s")?;
            match &p.motion {
                Motion::Rotate { omega } => {
                    bounded3(&f("motion.omega"), *omega, MAX_OMEGA_RAD_S, "rad/s")?;
                    // LIGGGHTS' `fix move rotate` takes the period 2 pi / |omega|: it must
                    // be a finite number (subnormal components square to zero)
                    let norm =
                        (omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2]).sqrt();
                    if norm < MIN_SPIN_RAD_S {
                        return Err(Error::invalid(
                            f("motion.omega"),
                            format!("{omega:?}"),
                            format!(
                                "an angular velocity of magnitude {MIN_SPIN_RAD_S:e} ..= \
                                 {MAX_OMEGA_RAD_S:e} rad/s (use kind = \"fixed\" for none)"
                            ),
                        ));
                    }
                }
                Motion::Linear { velocity } => {
                    bounded3(&f("motion.velocity"), *velocity, MAX_SPEED_M_S, "m/s")?
                }
                Motion::Free | Motion::Fixed => {}
            }
        }
        let bounds = domain_half_size(self);
        for (k, p) in self.particles.iter().enumerate() {
            for d in 0..3 {
                if p.position[d].abs() + p.radius > 0.5 * bounds {
                    return Err(Error::invalid(
                        format!("particles[{k}].position"),
                        format!("{:?}", p.position),
                        "within the simulation box",
                    ));
                }
            }
        }
        Ok(())
    }

    /// The wall and the sphere against it: the wall's size and material, the sphere above it
    /// with a small overlap, on the face of one triangle.
    fn check_wall(&self, w: &WallSpec) -> Result<()> {
        let m = &self.material;
        bounded3("wall.z", [w.z, 0.0, 0.0], MAX_LENGTH_M, "m")?;
        positive("wall.half_size", w.half_size)?;
        if let Some(wm) = &w.material {
            check_elastic("wall.material", wm.youngs_modulus, wm.poisson_ratio)?;
            // E <= 1e6 x the particles' keeps Yeff's sum of compliances from losing the
            // particle's term entirely to round-off (a near-rigid wall is 1e3 stiffer)
            let max = 1e6 * m.youngs_modulus;
            if wm.youngs_modulus > max {
                return Err(Error::invalid(
                    "wall.material.youngs_modulus",
                    wm.youngs_modulus,
                    format!("<= 1e6 x material.youngs_modulus ({max:e} Pa)"),
                ));
            }
        }
        within("wall.half_size", w.half_size, MAX_LENGTH_M, "m")?;
        let p = &self.particles[0];
        let overlap = p.radius - (p.position[2] - w.z);
        if p.position[2] <= w.z || overlap >= p.radius {
            return Err(Error::invalid(
                "particles[0].position",
                format!("{:?}", p.position),
                "above the wall with an initial overlap smaller than the radius",
            ));
        }
        if w.half_size < 4.0 * p.radius
            || p.position[0].abs() + p.radius > 0.5 * w.half_size
            || p.position[1].abs() + p.radius > 0.5 * w.half_size
        {
            return Err(Error::invalid(
                "wall.half_size",
                w.half_size,
                ">= 4 radii and the sphere within the inner half of the wall",
            ));
        }
        // The sphere must touch the face of one triangle only, away from the diagonal.
        let (x, y) = (p.position[0], p.position[1]);
        if (x - y).abs() / std::f64::consts::SQRT_2 <= p.radius * 1.5 {
            return Err(Error::invalid(
                "particles[0].position",
                format!("{:?}", p.position),
                "at least 1.5 radii away from the wall's diagonal x = y",
            ));
        }
        Ok(())
    }

    /// Two spheres: apart or overlapping by less than the smaller radius `rmin`.
    fn check_pair(&self, rmin: f64) -> Result<()> {
        let (a, b) = (&self.particles[0], &self.particles[1]);
        let d = dist(a.position, b.position);
        if d == 0.0 {
            return Err(Error::invalid(
                "particles[1].position",
                format!("{:?}", b.position),
                "different from particles[0].position",
            ));
        }
        let overlap = a.radius + b.radius - d;
        if overlap >= rmin {
            return Err(Error::invalid(
                "particles",
                format!("initial overlap {overlap:e} m"),
                format!("an initial overlap smaller than the smaller radius ({rmin:e} m)"),
            ));
        }
        Ok(())
    }
}

/// The time-step rule of every case (contact and shear): dt is refused above the Rayleigh
/// time of the smallest particle and warned about above 20 % of it. Returns the warning.
pub fn check_dt(dt: f64, m: &Material, rmin: f64) -> Result<Option<String>> {
    positive("dt", dt)?;
    let t_r = rayleigh_time(m, rmin);
    if dt > t_r {
        return Err(Error::invalid(
            "dt",
            dt,
            format!("<= the Rayleigh time {t_r:.4e} s of the smallest particle"),
        ));
    }
    Ok((dt > 0.2 * t_r).then(|| {
        format!(
            "dt = {dt:e} s is {:.0} % of the Rayleigh time {t_r:.4e} s of the smallest \
             particle (above 20 %)",
            100.0 * dt / t_r
        )
    }))
}

/// Half-width of the cubic simulation box both codes use for a contact case [m]: large enough
/// for the particles (and the wall) with a margin.
pub fn domain_half_size(c: &CaseFile) -> f64 {
    let mut ext: f64 = 0.0;
    for p in &c.particles {
        for d in 0..3 {
            ext = ext.max(p.position[d].abs() + 4.0 * p.radius);
        }
    }
    if let Some(w) = &c.wall {
        ext = ext.max(w.half_size).max(w.z.abs() + 1e-3 * w.half_size);
    }
    // Round up to a power of two so the box bounds print exactly.
    2f64.powi(ext.log2().ceil() as i32 + 1)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Identifiers that reach a deck: `[A-Za-z][A-Za-z0-9_-]{0,63}`.
pub fn check_identifier(field: &str, s: &str) -> Result<()> {
    let ok = !s.is_empty()
        && s.len() <= 64
        && s.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if ok {
        Ok(())
    } else {
        Err(Error::invalid(
            field,
            format!("{s:?}"),
            "an identifier: a letter, then letters, digits, '_' or '-' (at most 64)",
        ))
    }
}

/// Largest friction coefficient (sliding or rolling) a case may set.
pub const MAX_FRICTION: f64 = 10.0;

/// Largest length of a contact case (positions, radii, wall) [m]: a two-body test lives in
/// a box LIGGGHTS can print and the deck's derived sizes (a power-of-two box) stay finite.
pub const MAX_LENGTH_M: f64 = 1e3;
/// Largest speed of a contact case [m/s].
pub const MAX_SPEED_M_S: f64 = 1e4;
/// Largest angular velocity component of a contact case [rad/s].
pub const MAX_OMEGA_RAD_S: f64 = 1e9;
/// Smallest imposed spin [rad/s]: its period (2 pi / |omega|) goes into the deck.
pub const MIN_SPIN_RAD_S: f64 = 1e-9;

/// A finite `v` with `v <= max`.
fn within(field: &str, v: f64, max: f64, unit: &str) -> Result<()> {
    if v.is_finite() && v <= max {
        Ok(())
    } else {
        Err(Error::invalid(field, v, format!("<= {max:e} {unit}")))
    }
}

/// Three finite components of magnitude at most `max`.
fn bounded3(field: &str, v: [f64; 3], max: f64, unit: &str) -> Result<()> {
    if v.iter().all(|x| x.is_finite() && x.abs() <= max) {
        Ok(())
    } else {
        Err(Error::invalid(
            field,
            format!("{v:?}"),
            format!("finite numbers within +-{max:e} {unit}"),
        ))
    }
}

fn finite(field: &str, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::invalid(field, v, "a finite number"))
    }
}
pub(crate) fn positive(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(field, v, "a finite number > 0"))
    }
}
/// The one rule for eta_r against the rolling model: the rolling damping acts only in the
/// models with a dashpot ([`RollingModel::has_damping`]); elsewhere it must be 0.
pub fn check_damping_model(field: &str, eta_r: f64, rolling: RollingModel) -> Result<()> {
    if eta_r > 0.0 && !rolling.has_damping() {
        Err(Error::invalid(
            field,
            eta_r,
            format!(
                "0 with rolling model `{rolling}` (eta_r acts only in epsd, epsd3 and \
                 epsd_implicit)"
            ),
        ))
    } else {
        Ok(())
    }
}

/// The one rule for the rolling coefficients of a requested point (`--mu-r`, `--eta-r` of
/// shear, convergence, replay and sweep runs): each a coefficient ([`check_coefficient`]),
/// mu_r 0 without a rolling model, eta_r only with a dashpot ([`check_damping_model`]).
pub fn check_rolling_point(rolling: RollingModel, mu_r: f64, eta_r: f64) -> Result<()> {
    check_coefficient("--mu-r", mu_r)?;
    check_coefficient("--eta-r", eta_r)?;
    if rolling == RollingModel::Off && mu_r > 0.0 {
        return Err(Error::invalid("--mu-r", mu_r, "0 with --rolling off"));
    }
    check_damping_model("--eta-r", eta_r, rolling)
}

/// The one rule for a friction, rolling friction or rolling damping coefficient: finite, in
/// 0 ..= [`MAX_FRICTION`] (far beyond any granular material: the rolling stiffness grows as
/// mu_r^2, and mu_r = 1e9 blows a run up within steps; eta_r is a fraction of critical
/// damping).
pub fn check_coefficient(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && (0.0..=MAX_FRICTION).contains(&v) {
        Ok(())
    } else {
        Err(Error::invalid(field, v, format!("0 ..= {MAX_FRICTION}")))
    }
}

pub(crate) fn non_negative(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(field, v, "a finite number >= 0"))
    }
}
fn range_ge(field: &str, v: f64, min: f64, why: &str) -> Result<()> {
    if v >= min {
        Ok(())
    } else {
        Err(Error::invalid(field, v, format!(">= {min:e} ({why})")))
    }
}

#[cfg(test)]
mod tests {
    use super::builtin::{builtin_case, builtin_names};
    use super::*;

    fn base() -> CaseFile {
        builtin_case("rolling_plastic").unwrap()
    }

    fn err_of(c: CaseFile) -> String {
        c.validate().unwrap_err().to_string()
    }

    #[test]
    fn builtin_cases_validate() {
        for name in builtin_names() {
            let c = builtin_case(name).unwrap();
            for r in c.applicable_rolling() {
                c.with_rolling(r).validate().unwrap();
            }
        }
    }

    #[test]
    fn nan_and_negative_values_name_the_field() {
        let mut c = base();
        c.material.youngs_modulus = f64::NAN;
        assert!(err_of(c).contains("material.youngs_modulus"));
        let mut c = base();
        c.particles[0].radius = -1e-3;
        let e = err_of(c);
        assert!(
            e.contains("particles[0].radius") && e.contains("> 0"),
            "{e}"
        );
        let mut c = base();
        c.dt = 0.0;
        assert!(err_of(c).contains("`dt`"));
    }

    #[test]
    fn restitution_outside_liggghts_range_is_refused() {
        for e in [0.05, 0.0, 1.01] {
            let mut c = base();
            c.material.restitution = e;
            let msg = err_of(c);
            assert!(
                msg.contains("material.restitution") && msg.contains("0.05 < e <= 1"),
                "{msg}"
            );
        }
        let mut c = base();
        c.material.restitution = f64::INFINITY;
        assert!(err_of(c).contains("material.restitution"));
    }

    #[test]
    fn dt_above_rayleigh_is_refused_and_above_20_percent_warned() {
        let c = base();
        let rmin = c
            .particles
            .iter()
            .map(|p| p.radius)
            .fold(f64::INFINITY, f64::min);
        let t_r = rayleigh_time(&c.material, rmin);
        let mut big = c.clone();
        big.dt = 1.01 * t_r;
        assert!(err_of(big).contains("Rayleigh"));
        let mut warn = c.clone();
        warn.dt = 0.5 * t_r;
        let v = warn.validate().unwrap();
        assert_eq!(v.warnings.len(), 1, "{:?}", v.warnings);
        assert!(v.warnings[0].contains("Rayleigh"));
    }

    #[test]
    fn large_initial_overlap_is_refused() {
        let mut c = base();
        c.particles[1].position[2] = c.particles[0].position[2] + 0.5 * c.particles[0].radius;
        assert!(err_of(c).contains("initial overlap"));
    }

    #[test]
    fn names_cannot_inject_commands() {
        let mut c = base();
        c.name = "x\nshell rm -rf /".into();
        assert!(err_of(c).contains("identifier"));
        let mut c = base();
        c.name = "a b".into();
        assert!(err_of(c).contains("identifier"));
        let mut c = base();
        c.description = "ok\nshell touch /tmp/pwned".into();
        assert!(err_of(c).contains("single line"));
    }

    #[test]
    fn unknown_fields_and_models_are_reported() {
        let text = include_str!("../../cases/rolling_plastic.toml")
            .replace("rolling = \"epsd\"", "rolling = \"epsd9\"");
        let e = CaseFile::from_toml(&text, Path::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("epsd9") && e.contains("epsd2"), "{e}");
        let text = format!(
            "{}\nshell = \"rm\"\n",
            include_str!("../../cases/rolling_plastic.toml")
        );
        let e = CaseFile::from_toml(&text, Path::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("shell"), "{e}");
        let e = RollingModel::parse("foo").unwrap_err().to_string();
        assert!(e.contains("cdt, epsd, epsd2, epsd3"), "{e}");
    }

    #[test]
    fn damping_with_undamped_model_is_refused() {
        let mut c = base().with_rolling(RollingModel::Epsd2);
        c.rolling_models.clear();
        c.material.rolling_damping = 0.3;
        let e = err_of(c);
        assert!(
            e.contains("eta_r acts only in epsd, epsd3 and epsd_implicit"),
            "{e}"
        );
    }

    #[test]
    fn a_wall_material_is_checked_like_the_particles() {
        let base = builtin_case("wall_rolling_plastic").unwrap();
        for (e, nu, field) in [
            (1e6, 0.3, "wall.material.youngs_modulus"),
            (7e10, 0.5, "wall.material.poisson_ratio"),
            (f64::NAN, 0.3, "wall.material.youngs_modulus"),
            (1e18, 0.3, "wall.material.youngs_modulus"),
        ] {
            let mut f = base.clone();
            f.wall.as_mut().unwrap().material = Some(WallMaterial {
                youngs_modulus: e,
                poisson_ratio: nu,
            });
            let err = f.validate().unwrap_err().to_string();
            assert!(err.contains(field), "{e} {nu}: {err}");
        }
        let text =
            "[wall]\nz = 0.0\nhalf_size = 1.0\nmaterial = { youngs_modulus = 1e11, poisson = 0.3 }";
        assert!(toml::from_str::<super::CaseFile>(text).is_err());
    }
}
