//! Bricks of the shear box for a domain decomposition (issue #39, docs/mpi.md): the periodic
//! x and z split into `nx` x `nz` equal bricks (the plates bound y). A brick owns the particles
//! whose wrapped position lies in it and holds as ghosts every other particle within the cutoff
//! of it, periodic images included, all in increasing id: the order that makes a brick's pair
//! sums one process's bits (`bricks_with_ghosts_give_each_owned_particle_the_bits_of_one_process`).
//! Sums over particles (the plate forces) are exact ([`super::exact`]): any split gives
//! one process's bits.

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
    /// a periodic side: it is owned where it wraps to): the one whose extent holds it along
    /// each axis, found from the quotient and checked against the extents' own bounds (a
    /// coordinate that rounds up to the box length is the last brick's along that axis).
    pub fn owner(&self, x: V3) -> usize {
        let (wx, wz) = (x[0].rem_euclid(self.lx), x[2].rem_euclid(self.lz));
        let slab = |w: f64, l: f64, n: usize| {
            let edge = |r: usize| l * r as f64 / n as f64;
            let mut i = ((w / l * n as f64) as usize).min(n - 1);
            while i > 0 && w < edge(i) {
                i -= 1;
            }
            while i + 1 < n && w >= edge(i + 1) {
                i += 1;
            }
            i
        };
        slab(wx, self.lx, self.nx) * self.nz + slab(wz, self.lz, self.nz)
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

    /// The bricks near brick `b`, itself excluded, in increasing index: those within `cut`
    /// of it along both periodic axes, the only ones that can hold its particles as ghosts
    /// or receive them at a rebuild (a particle within `cut` of a brick has its owner within
    /// `cut` of that brick). Symmetric: `a` is near `b` when `b` is near `a`. Measured from
    /// the extents with a margin of 1e-9 of the box, so that round-off in a particle's gap
    /// ([`Bricks::holds`]) never makes a brick hold a ghost of one not near it.
    pub fn near(&self, b: usize, cut: f64) -> Vec<usize> {
        let (bx, bz) = self.extent(b);
        // distance along a periodic axis of length l between [a0, a1) and [c0, c1)
        let gap = |a: [f64; 2], c: [f64; 2], l: f64| {
            if a[0] < c[1] && c[0] < a[1] {
                0.0
            } else {
                (c[0] - a[1]).rem_euclid(l).min((a[0] - c[1]).rem_euclid(l))
            }
        };
        (0..self.count())
            .filter(|&o| {
                let (ox, oz) = self.extent(o);
                o != b
                    && gap(bx, ox, self.lx) <= cut + 1e-9 * self.lx
                    && gap(bz, oz, self.lz) <= cut + 1e-9 * self.lz
            })
            .collect()
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform numbers in [0, 1) from `seed` (a 64-bit LCG: tests only).
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// `near` is symmetric, never holds the brick itself, and contains every brick that
    /// holds a ghost of a particle the brick owns (random points, every split up to 5 x 5,
    /// cuts from a tenth of a brick to beyond a whole one); with a cut under a brick's width
    /// a 4 x 4 split's brick has its 8 surrounding bricks near, not the other 7.
    #[test]
    fn near_bricks_are_all_that_can_hold_ghosts() {
        let (lx, lz) = (4.0e-3, 2.4e-3);
        let mut next = uniform(11);
        let points: Vec<V3> = (0..400).map(|_| [next() * lx, 0.0, next() * lz]).collect();
        for nx in 1..=5 {
            for nz in 1..=5 {
                let b = Bricks { nx, nz, lx, lz };
                for cut in [0.1e-3, 0.3e-3, 0.9e-3, 2.5e-3] {
                    for a in 0..b.count() {
                        let near = b.near(a, cut);
                        assert!(!near.contains(&a));
                        for &o in &near {
                            assert!(b.near(o, cut).contains(&a), "{nx}x{nz} cut {cut}: {a} {o}");
                        }
                        for p in points.iter().filter(|&&p| b.owner(p) == a) {
                            for o in (0..b.count()).filter(|&o| o != a) {
                                if b.holds(o, *p, cut) {
                                    assert!(
                                        near.contains(&o),
                                        "{nx}x{nz} {p:?} in {a}, held by {o}"
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
        let b = Bricks {
            nx: 4,
            nz: 4,
            lx,
            lz,
        };
        assert_eq!(b.near(0, 0.3e-3), vec![1, 3, 4, 5, 7, 12, 13, 15]);
        assert_eq!(b.near(5, 0.3e-3), vec![0, 1, 2, 4, 6, 8, 9, 10]);
    }

    /// The owner is the brick whose extent holds the wrapped position, at the extents' own
    /// edges too (each edge is the start of the next brick's extent), for every split.
    #[test]
    fn the_owner_is_the_brick_whose_extent_holds_the_point() {
        let (lx, lz) = (4.0e-3, 2.4e-3);
        let mut next = uniform(7);
        for nx in 1..=5 {
            for nz in 1..=5 {
                let b = Bricks { nx, nz, lx, lz };
                let mut points: Vec<V3> = (0..200)
                    .map(|_| [(next() * 3.0 - 1.0) * lx, 0.0, (next() * 3.0 - 1.0) * lz])
                    .collect();
                for i in 0..=nx {
                    for k in 0..=nz {
                        points.push([lx * i as f64 / nx as f64, 0.0, lz * k as f64 / nz as f64]);
                    }
                }
                for p in points {
                    let (wx, wz) = (p[0].rem_euclid(lx), p[2].rem_euclid(lz));
                    let o = b.owner(p);
                    let ([x0, x1], [z0, z1]) = b.extent(o);
                    let inside = |w: f64, a: f64, c: f64, l: f64, last: bool| {
                        (a..c).contains(&w) || (last && w == l)
                    };
                    assert!(
                        inside(wx, x0, x1, lx, o / nz == nx - 1)
                            && inside(wz, z0, z1, lz, o % nz == nz - 1),
                        "{nx} x {nz}: {p:?} owned by {o}, extent {:?}",
                        b.extent(o)
                    );
                }
            }
        }
    }
}
