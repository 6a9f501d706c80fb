//! Bricks of the shear box for a domain decomposition (issue #39, docs/mpi.md): the periodic
//! x and z split into `nx` x `nz` equal bricks (the plates bound y). A brick owns the particles
//! whose wrapped position lies in it and holds as ghosts every other particle within the cutoff
//! of it, periodic images included, all in increasing id: the order that makes a brick's pair
//! sums one process's bits (`bricks_with_ghosts_give_each_owned_particle_the_bits_of_one_process`).
//! Sums over particles (the plate forces) are made in id order over every brick's share
//! ([`sum_in_id_order`]), as one process makes them.

use crate::solver::vec3::V3;

/// The split of the periodic box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bricks {
    pub nx: usize,
    pub nz: usize,
    pub lx: f64,
    pub lz: f64,
}

impl Bricks {
    pub fn count(&self) -> usize {
        self.nx * self.nz
    }

    /// Brick `b`'s extent along x and z: `[x0, x1)`, `[z0, z1)`.
    fn extent(&self, b: usize) -> ([f64; 2], [f64; 2]) {
        let (i, k) = (b / self.nz, b % self.nz);
        let along =
            |n: usize, l: f64, r: usize| [l * r as f64 / n as f64, l * (r + 1) as f64 / n as f64];
        (along(self.nx, self.lx, i), along(self.nz, self.lz, k))
    }

    /// The brick that owns a particle at `x` (between rebuilds a particle may have drifted past
    /// a periodic side: it is owned where it wraps to).
    pub fn owner(&self, x: V3) -> usize {
        let (wx, wz) = (x[0].rem_euclid(self.lx), x[2].rem_euclid(self.lz));
        (0..self.count())
            .find(|&b| {
                let ([x0, x1], [z0, z1]) = self.extent(b);
                (x0..x1).contains(&wx) && (z0..z1).contains(&wz)
            })
            // rem_euclid may round up to the box length itself: the last brick's
            .unwrap_or(self.count() - 1)
    }

    /// Whether a particle at `p` (wrapped) is brick `b`'s: its own, or within `cut` of it
    /// along both periodic axes (a ghost it holds).
    pub fn holds(&self, b: usize, p: V3, cut: f64) -> bool {
        let ([x0, x1], [z0, z1]) = self.extent(b);
        // distance along a periodic axis of length l from v to [a, c)
        let gap = |v: f64, a: f64, c: f64, l: f64| {
            let v = v.rem_euclid(l);
            if (a..c).contains(&v) {
                0.0
            } else {
                (a - v).rem_euclid(l).min((v - c).rem_euclid(l))
            }
        };
        self.owner(p) == b
            || (gap(p[0], x0, x1, self.lx) <= cut && gap(p[2], z0, z1, self.lz) <= cut)
    }

    /// Brick `b`'s particles in increasing id, and whether each is its own: those it owns and
    /// those within `cut` of it along both periodic axes (its ghosts).
    pub fn members(&self, b: usize, x: &[V3], cut: f64) -> (Vec<usize>, Vec<bool>) {
        let mut ids = Vec::new();
        let mut own = Vec::new();
        for (q, p) in x.iter().enumerate() {
            if self.holds(b, *p, cut) {
                ids.push(q);
                own.push(self.owner(*p) == b);
            }
        }
        (ids, own)
    }
}

/// The sums (bottom, top) of per-particle plate forces held by several bricks, each share
/// `(id, bottom, top)` of its own particles: made over all shares in increasing id, as one
/// process sums its particles in order (`ShearSim::plate_forces_over`), so the bits do not
/// depend on the split. A particle in two shares is a bug of the caller (panics).
pub fn sum_in_id_order(shares: &[Vec<(u32, V3, V3)>]) -> (V3, V3) {
    let mut all: Vec<&(u32, V3, V3)> = shares.iter().flatten().collect();
    all.sort_by_key(|e| e.0);
    assert!(
        all.windows(2).all(|w| w[0].0 < w[1].0),
        "a particle in two bricks' shares"
    );
    sum_in_order(all.into_iter().map(|(_, b, t)| (*b, *t)))
}

/// The sums (bottom, top) of per-particle plate forces in the order given (one process's:
/// increasing id), component by component as `ShearSim::plate_forces_over` adds them.
pub fn sum_in_order(terms: impl Iterator<Item = (V3, V3)>) -> (V3, V3) {
    let (mut tb, mut tt) = ([0.0; 3], [0.0; 3]);
    for (b, t) in terms {
        for c in 0..3 {
            tb[c] += b[c];
            tt[c] += t[c];
        }
    }
    (tb, tt)
}
