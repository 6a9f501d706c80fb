//! The initial loose packing of a shear case, generated once (seeded) so that both codes
//! start from the identical state (LIGGGHTS reads it with `read_data`).

pub use crate::solver::shear::state::Packing;
use crate::spec::shear::ShearCase;

/// Packing fraction of the loose initial packing.
pub const LOOSE_PACKING_FRACTION: f64 = 0.3;

/// SplitMix64: a small, fully specified generator, so a seed gives the same packing on every
/// machine and every version of this crate.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// The particle a chaos baseline moves by one ulp (native against native, the measure of how
/// fast round-off grows that the lockstep and replay comparisons are judged by): the middle
/// one of `n`. Particles are numbered by height ([`loose_packing`]), so it sits in the middle
/// of the gouge, where a difference spreads through the most contacts; particle 0 touches
/// the bottom plate, and nudging it measured a horizon 3x longer in one case (3,002 steps
/// against 930 in `tests/shear_offline.rs`), a baseline too lenient for one code and too
/// strict for the other.
pub fn chaos_probe(n: usize) -> usize {
    n / 2
}

/// Random sequential placement without overlap (periodic in x and z) in a layer above the
/// bottom plate's teeth, largest particles first; the particles then numbered by height. The layer height is the solid height over
/// [`LOOSE_PACKING_FRACTION`]; it grows by 10 % whenever a particle cannot be placed.
pub fn loose_packing(case: &ShearCase) -> Packing {
    let t = case.plates.tooth_height();
    let (lx, lz) = (case.box_x, case.box_z);
    let mut classes: Vec<(f64, usize)> = case
        .radii
        .iter()
        .cloned()
        .zip(case.class_counts())
        .collect();
    classes.sort_by(|a, b| b.0.total_cmp(&a.0));
    let rmax = classes[0].0;
    let mut height = case.solid_volume() / (lx * lz * LOOSE_PACKING_FRACTION);
    'attempt: loop {
        let mut rng = SplitMix64::new(case.seed);
        let mut radius = Vec::with_capacity(case.particles);
        let mut position: Vec<[f64; 3]> = Vec::with_capacity(case.particles);
        let y0 = t + 0.1 * rmax;
        let cell = 2.0 * rmax;
        let (nx, nz) = (
            (lx / cell).floor().max(1.0) as usize,
            (lz / cell).floor().max(1.0) as usize,
        );
        let ny = ((height / cell).ceil() as usize).max(1);
        let mut grid: Vec<Vec<usize>> = vec![Vec::new(); nx * ny * nz];
        let cell_of = |p: [f64; 3]| {
            let cx = ((p[0] / lx * nx as f64) as usize).min(nx - 1);
            let cz = ((p[2] / lz * nz as f64) as usize).min(nz - 1);
            let cy = (((p[1] - y0) / height * ny as f64).max(0.0) as usize).min(ny - 1);
            (cx, cy, cz)
        };
        for &(r, n) in &classes {
            for _ in 0..n {
                let mut placed = false;
                for _ in 0..20_000 {
                    let p = [
                        rng.uniform() * lx,
                        y0 + r + rng.uniform() * (height - 2.0 * r),
                        rng.uniform() * lz,
                    ];
                    let (cx, cy, cz) = cell_of(p);
                    let mut ok = true;
                    'check: for dx in [nx - 1, 0, 1] {
                        for dy in [-1i64, 0, 1] {
                            for dz in [nz - 1, 0, 1] {
                                let gy = cy as i64 + dy;
                                if gy < 0 || gy >= ny as i64 {
                                    continue;
                                }
                                let gx = (cx + dx) % nx;
                                let gz = (cz + dz) % nz;
                                for &k in &grid[(gx * ny + gy as usize) * nz + gz] {
                                    let q = position[k];
                                    let mut d = [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
                                    d[0] -= lx * (d[0] / lx).round();
                                    d[2] -= lz * (d[2] / lz).round();
                                    let s = r + radius[k];
                                    if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < s * s {
                                        ok = false;
                                        break 'check;
                                    }
                                }
                            }
                        }
                    }
                    if ok {
                        grid[(cx * ny + cy) * nz + cz].push(position.len());
                        position.push(p);
                        radius.push(r);
                        placed = true;
                        break;
                    }
                }
                if !placed {
                    height *= 1.1;
                    continue 'attempt;
                }
            }
        }
        let top_y = y0 + height + t + 0.1 * rmax;
        let n = radius.len();
        // numbered bottom to top (ties: placement order): particles near in space are near
        // in number, and stay so under shear (it moves them along x), so most particles'
        // pairs lie in one thread's block of the pair list and the parallel pass sums them
        // there (`pairs::pass`)
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| position[a][1].total_cmp(&position[b][1]));
        let radius = order.iter().map(|&k| radius[k]).collect();
        let position = order.iter().map(|&k| position[k]).collect();
        return Packing {
            radius,
            position,
            velocity: vec![[0.0; 3]; n],
            omega: vec![[0.0; 3]; n],
            top_y,
            box_y_hi: top_y + 2.0 * rmax,
            box_y_lo: -2.0 * rmax,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{shear::ShearCase, RollingModel};

    #[test]
    fn packing_is_seeded_and_overlap_free() {
        let c = ShearCase::preset(
            crate::spec::shear::Preset::Ci,
            RollingModel::Epsd,
            0.5,
            0.0,
            7,
        )
        .unwrap();
        let a = loose_packing(&c);
        let b = loose_packing(&c);
        assert_eq!(a, b);
        assert_eq!(a.radius.len(), 300);
        for i in 0..a.radius.len() {
            for j in 0..i {
                let (p, q) = (a.position[i], a.position[j]);
                let mut d = [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
                d[0] -= c.box_x * (d[0] / c.box_x).round();
                d[2] -= c.box_z * (d[2] / c.box_z).round();
                let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                assert!(dist >= a.radius[i] + a.radius[j], "{i} {j}");
            }
            assert!(a.position[i][1] - a.radius[i] > c.plates.tooth_height());
            assert!(a.position[i][1] + a.radius[i] < a.top_y - c.plates.tooth_height());
        }
        let c2 = ShearCase::preset(
            crate::spec::shear::Preset::Ci,
            RollingModel::Epsd,
            0.5,
            0.0,
            8,
        )
        .unwrap();
        assert_ne!(loose_packing(&c2).position, a.position);
    }
}
