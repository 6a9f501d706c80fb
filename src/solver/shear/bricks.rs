//! Bricks of the shear box for a domain decomposition (issue #39, docs/mpi.md): the periodic
//! x and z split into `nx` x `nz` bricks (the plates bound y), equal at the start and moved at
//! neighbour rebuilds to even out the measured time of the bricks ([`Bricks::balanced`], as
//! LAMMPS' `fix balance ... shift` with `weight time`). A brick owns the particles
//! whose wrapped position lies in it and holds as ghosts every other particle within the cutoff
//! of it, periodic images included, all in increasing id: the order that makes a brick's pair
//! sums one process's bits (`bricks_with_ghosts_give_each_owned_particle_the_bits_of_one_process`).
//! Sums over particles (the plate forces) are exact ([`super::exact`]): any split gives
//! one process's bits, so where the cuts lie never changes a bit.

use crate::solver::vec3::V3;

/// The split of the periodic box: `nx` slabs along x, `nz` along z, brick `i nz + k` the
/// `i`-th along x and `k`-th along z.
#[derive(Clone, Debug, PartialEq)]
pub struct Bricks {
    pub nx: usize,
    pub nz: usize,
    pub lx: f64,
    pub lz: f64,
    /// Where the slabs along x begin and end: `nx + 1` increasing edges, `0` and `lx` the
    /// first and last.
    xs: Vec<f64>,
    /// The same along z (`nz + 1` edges).
    zs: Vec<f64>,
}

/// The edges of `n` equal slabs of a length `l`.
fn equal_edges(n: usize, l: f64) -> Vec<f64> {
    (0..=n).map(|r| l * r as f64 / n as f64).collect()
}

/// The slab of `edges` that holds `w` (in `[0, l]`): the last whose start is not beyond it
/// (a coordinate that rounds up to the length is the last slab's).
fn slab(edges: &[f64], w: f64) -> usize {
    edges[1..edges.len() - 1].partition_point(|&e| e <= w)
}

impl Bricks {
    /// `nx` x `nz` equal bricks of a box `lx` x `lz`.
    pub fn equal(nx: usize, nz: usize, lx: f64, lz: f64) -> Bricks {
        Bricks {
            nx,
            nz,
            lx,
            lz,
            xs: equal_edges(nx, lx),
            zs: equal_edges(nz, lz),
        }
    }

    pub fn count(&self) -> usize {
        self.nx * self.nz
    }

    /// Brick `b`'s extent along x and z: `[x0, x1)`, `[z0, z1)`.
    fn extent(&self, b: usize) -> ([f64; 2], [f64; 2]) {
        let (i, k) = (b / self.nz, b % self.nz);
        ([self.xs[i], self.xs[i + 1]], [self.zs[k], self.zs[k + 1]])
    }

    /// Brick `b`'s share of the box's x-z area.
    pub fn area_share(&self, b: usize) -> f64 {
        let ([x0, x1], [z0, z1]) = self.extent(b);
        (x1 - x0) * (z1 - z0) / (self.lx * self.lz)
    }

    /// The brick that owns a particle at `x` (between rebuilds a particle may have drifted past
    /// a periodic side: it is owned where it wraps to): the one whose extent holds it along
    /// each axis (a coordinate that rounds up to the box length is the last brick's along
    /// that axis).
    pub fn owner(&self, x: V3) -> usize {
        let (wx, wz) = (x[0].rem_euclid(self.lx), x[2].rem_euclid(self.lz));
        slab(&self.xs, wx) * self.nz + slab(&self.zs, wz)
    }

    /// These bricks moved towards an even share of `cost`, each brick's measured time since
    /// the last rebuild (by brick index): along each axis the slabs' costs (the sums over
    /// their bricks) are spread evenly over each slab and every inner edge moved halfway to
    /// where the cost before it is its share (LAMMPS `fix balance ... shift`, which moves the
    /// cuts of each dimension from the cost along it, `weight time` for measured time). An
    /// axis whose slabs are within [`IMBALANCE`] of their mean is left as it is. An edge moves
    /// at most a quarter of the slab it moves into, and no slab gets narrower than half an
    /// equal one, so a particle changes brick only to a neighbouring one (as a migrant at a
    /// rebuild must) and a slab never vanishes. Every rank computes the same bricks from the
    /// same costs (one all-reduce of them: [`super::decompose`]).
    pub fn balanced(&self, cost: &[f64]) -> Bricks {
        let (mut cx, mut cz) = (vec![0.0; self.nx], vec![0.0; self.nz]);
        for (b, &c) in cost.iter().enumerate() {
            cx[b / self.nz] += c;
            cz[b % self.nz] += c;
        }
        Bricks {
            xs: shifted(&self.xs, &cx),
            zs: shifted(&self.zs, &cz),
            ..self.clone()
        }
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

/// The imbalance that moves the edges of an axis: its costliest slab more than this many
/// times the mean (LAMMPS `fix balance`'s threshold): below it the cuts stay (moving them
/// moves particles for a gain under the noise of measured times).
pub const IMBALANCE: f64 = 1.02;

/// How far an edge goes towards its balanced place at one rebuild (measured times are noisy:
/// halfway, as LAMMPS' `shift` iterations damp their moves).
const DAMPING: f64 = 0.5;

/// `edges` (of `cost.len()` slabs) moved as [`Bricks::balanced`] says.
fn shifted(edges: &[f64], cost: &[f64]) -> Vec<f64> {
    let n = cost.len();
    let total: f64 = cost.iter().sum();
    let mean = total / n as f64;
    if n < 2 || !total.is_finite() || total <= 0.0 || cost.iter().all(|&c| c <= IMBALANCE * mean) {
        return edges.to_vec();
    }
    let floor = 0.5 * edges[n] / n as f64;
    let width = |i: usize| edges[i + 1] - edges[i];
    // what each slab may give up on either side
    let room: Vec<f64> = (0..n)
        .map(|i| (0.25 * width(i)).min(0.5 * (width(i) - floor)).max(0.0))
        .collect();
    let mut out = edges.to_vec();
    let (mut below, mut i) = (0.0, 0);
    for k in 1..n {
        // where the cost before the edge, spread evenly over each slab, is k shares
        let goal = total * k as f64 / n as f64;
        while i + 1 < n && below + cost[i] < goal {
            below += cost[i];
            i += 1;
        }
        let into = if cost[i] > 0.0 {
            ((goal - below) / cost[i]).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let target = edges[i] + into * width(i);
        let want = edges[k] + DAMPING * (target - edges[k]);
        out[k] = want.clamp(edges[k] - room[k - 1], edges[k] + room[k]);
    }
    out
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
                let b = Bricks::equal(nx, nz, lx, lz);
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
        let b = Bricks::equal(4, 4, lx, lz);
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
                let b = Bricks::equal(nx, nz, lx, lz);
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

    /// The balance on a model of measured time (each brick's cost its area times a factor,
    /// brick 0 30 % slower per particle): repeated rebuilds move the edges until every
    /// slab's cost along each axis is within [`IMBALANCE`] of the mean, and leave equal
    /// costs' bricks as they are. At every rebuild: the end edges stay, the edges increase,
    /// no slab is narrower than half an equal one, no edge moves more than a quarter of a
    /// slab next to it, and a point changes brick only to a near one.
    #[test]
    fn balancing_evens_the_slabs_costs_in_small_moves() {
        let (lx, lz) = (4.0e-3, 2.4e-3);
        let mut next = uniform(5);
        let points: Vec<V3> = (0..300).map(|_| [next() * lx, 0.0, next() * lz]).collect();
        for (nx, nz) in [(2, 1), (3, 1), (1, 2), (2, 2), (4, 3)] {
            let equal = Bricks::equal(nx, nz, lx, lz);
            let cost = |b: &Bricks, slow: f64| -> Vec<f64> {
                (0..b.count())
                    .map(|r| {
                        let ([x0, x1], [z0, z1]) = b.extent(r);
                        (x1 - x0) * (z1 - z0) * if r == 0 { slow } else { 1.0 }
                    })
                    .collect()
            };
            assert_eq!(equal.balanced(&cost(&equal, 1.0)), equal);
            let mut b = equal.clone();
            for round in 0..40 {
                let moved = b.balanced(&cost(&b, 1.3));
                for (new, old, l, n) in [(&moved.xs, &b.xs, lx, nx), (&moved.zs, &b.zs, lz, nz)] {
                    assert_eq!((new[0], new[n]), (0.0, l));
                    for k in 0..n {
                        let w = new[k + 1] - new[k];
                        assert!(
                            w >= 0.5 * l / n as f64 * (1.0 - 1e-12),
                            "{nx}x{nz} {round}: {new:?}"
                        );
                    }
                    for k in 1..n {
                        let room = 0.25 * (old[k] - old[k - 1]).min(old[k + 1] - old[k]);
                        assert!((new[k] - old[k]).abs() <= room * (1.0 + 1e-12));
                    }
                }
                let cut = 0.3e-3;
                for p in &points {
                    let (a, o) = (b.owner(*p), moved.owner(*p));
                    assert!(
                        a == o || moved.near(a, cut).contains(&o),
                        "{nx}x{nz}: {a} -> {o}"
                    );
                }
                b = moved;
            }
            assert_ne!(b, equal, "{nx}x{nz}: the edges moved");
            let c = cost(&b, 1.3);
            let slabs = |n: usize, of: &dyn Fn(usize) -> usize| -> Vec<f64> {
                let mut s = vec![0.0; n];
                for (r, &c) in c.iter().enumerate() {
                    s[of(r)] += c;
                }
                s
            };
            for s in [slabs(nx, &|r| r / nz), slabs(nz, &|r| r % nz)] {
                let mean = s.iter().sum::<f64>() / s.len() as f64;
                assert!(s.iter().all(|&v| v <= IMBALANCE * mean), "{nx}x{nz}: {s:?}");
            }
        }
    }
}
