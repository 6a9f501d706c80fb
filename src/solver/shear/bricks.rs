//! Bricks of the shear box for a domain decomposition (issue #39, docs/mpi.md): `nx` x `ny` x
//! `nz` bricks, along the periodic x and z and across the gap between the plates (y), equal at
//! the start and moved at neighbour rebuilds to even out the measured time of the bricks
//! ([`Bricks::balanced`], as LAMMPS' `fix balance ... shift` with `weight time`). A brick owns
//! the particles whose wrapped position lies in it and holds as ghosts every other particle
//! within the cutoff of it, periodic images included, all in increasing id: the order that
//! makes a brick's pair sums one process's bits
//! (`bricks_with_ghosts_give_each_owned_particle_the_bits_of_one_process`). Sums over
//! particles (the plate forces) are exact ([`super::exact`]): any split gives one process's
//! bits, so where the cuts lie never changes a bit.
//!
//! y is not periodic: the lowest slab along it reaches down without end and the highest up
//! (the plates bound the particles), so the cuts across the gap are `ny - 1` planes where the
//! periodic axes have `nx` and `nz` (none with one slab). Which of the splits of a rank count
//! has the least boundary is [`super::decompose::split_for`]'s choice, as LAMMPS' processor
//! grid is the factorisation with the least surface over all three dimensions
//! (`ProcMap::onelevel_grid`): at the paper's 2,500 grains (4 x 4.7 x 2.4 mm between the
//! plates) two bricks share one 4 x 2.4 mm plane across the gap against two 4.7 x 2.4 mm
//! planes along x.

use crate::solver::vec3::V3;

/// The split of the box: `nx` slabs along x, `ny` across the gap (y), `nz` along z; brick
/// `(i ny + j) nz + k` the `i`-th along x, `j`-th along y and `k`-th along z.
#[derive(Clone, Debug, PartialEq)]
pub struct Bricks {
    pub nx: usize,
    pub ny: usize,
    pub nz: usize,
    pub lx: f64,
    pub lz: f64,
    /// Where the slabs along x begin and end: `nx + 1` increasing edges, `0` and `lx` the
    /// first and last.
    xs: Vec<f64>,
    /// The same across the gap (`ny + 1` edges): the first and last are the span the bricks
    /// were made over (the plates' bases then), which the balance spreads the slabs' costs
    /// over; a particle below the second edge is the lowest slab's and one at or above the
    /// last but one the highest's, wherever it is.
    ys: Vec<f64>,
    /// The same along z (`nz + 1` edges).
    zs: Vec<f64>,
}

/// The edges of `n` equal slabs from `a` to `b`.
fn equal_edges(n: usize, a: f64, b: f64) -> Vec<f64> {
    (0..=n).map(|r| a + (b - a) * r as f64 / n as f64).collect()
}

/// The slab of `edges` that holds `w`: the last whose start is not beyond it (the first
/// and last edges are not read: a coordinate that rounds up to a periodic length is the last
/// slab's, and across the gap the end slabs reach without end).
fn slab(edges: &[f64], w: f64) -> usize {
    edges[1..edges.len() - 1].partition_point(|&e| e <= w)
}

/// Slab `i` of `edges` as `[start, end)`, the end slabs reaching without end when `open`.
fn extent_of(edges: &[f64], i: usize, open: bool) -> [f64; 2] {
    let n = edges.len() - 1;
    let lo = if open && i == 0 {
        f64::NEG_INFINITY
    } else {
        edges[i]
    };
    let hi = if open && i == n - 1 {
        f64::INFINITY
    } else {
        edges[i + 1]
    };
    [lo, hi]
}

/// Distance along a periodic axis of length `l` from `v` to `[a, c)`.
fn gap_periodic(v: f64, [a, c]: [f64; 2], l: f64) -> f64 {
    let v = v.rem_euclid(l);
    if (a..c).contains(&v) {
        0.0
    } else {
        (a - v).rem_euclid(l).min((v - c).rem_euclid(l))
    }
}

/// Distance along the gap (not periodic) from `v` to `[a, c)`.
fn gap_open(v: f64, [a, c]: [f64; 2]) -> f64 {
    if v < a {
        a - v
    } else if v >= c {
        v - c
    } else {
        0.0
    }
}

/// Distance along a periodic axis of length `l` between `[a0, a1)` and `[c0, c1)`.
fn apart_periodic(a: [f64; 2], c: [f64; 2], l: f64) -> f64 {
    if a[0] < c[1] && c[0] < a[1] {
        0.0
    } else {
        (c[0] - a[1]).rem_euclid(l).min((a[0] - c[1]).rem_euclid(l))
    }
}

/// Distance along the gap between `[a0, a1)` and `[c0, c1)`.
fn apart_open(a: [f64; 2], c: [f64; 2]) -> f64 {
    if a[0] < c[1] && c[0] < a[1] {
        0.0
    } else {
        (c[0] - a[1]).max(a[0] - c[1])
    }
}

impl Bricks {
    /// `nx` x `ny` x `nz` equal bricks of a box `lx` x `lz`, the gap's slabs equal over
    /// `ys` (the plates' bases).
    pub fn equal([nx, ny, nz]: [usize; 3], lx: f64, ys: [f64; 2], lz: f64) -> Bricks {
        Bricks {
            nx,
            ny,
            nz,
            lx,
            lz,
            xs: equal_edges(nx, 0.0, lx),
            ys: equal_edges(ny, ys[0], ys[1]),
            zs: equal_edges(nz, 0.0, lz),
        }
    }

    pub fn count(&self) -> usize {
        self.nx * self.ny * self.nz
    }

    /// Brick `b`'s slab along each axis.
    fn index(&self, b: usize) -> [usize; 3] {
        [
            b / (self.ny * self.nz),
            (b / self.nz) % self.ny,
            b % self.nz,
        ]
    }

    /// Brick `b`'s extent along x, y and z: `[x0, x1)`, `[y0, y1)`, `[z0, z1)` (the end slabs
    /// across the gap without end).
    fn extent(&self, b: usize) -> [[f64; 2]; 3] {
        let [i, j, k] = self.index(b);
        [
            extent_of(&self.xs, i, false),
            extent_of(&self.ys, j, true),
            extent_of(&self.zs, k, false),
        ]
    }

    /// Brick `b`'s share of the box's volume, across the gap over the span the bricks were
    /// made over.
    pub fn volume_share(&self, b: usize) -> f64 {
        let [i, j, k] = self.index(b);
        let share = |e: &[f64], s: usize| (e[s + 1] - e[s]) / (e[e.len() - 1] - e[0]);
        share(&self.xs, i) * share(&self.ys, j) * share(&self.zs, k)
    }

    /// The narrowest slab's width over the three axes (across the gap over the span the
    /// bricks were made over): a split whose slabs are not wider than the ghost cut is too
    /// thin to be measured by the scaling model.
    pub fn narrowest(&self) -> f64 {
        [&self.xs, &self.ys, &self.zs]
            .iter()
            .flat_map(|e| e.windows(2).map(|w| w[1] - w[0]))
            .fold(f64::INFINITY, f64::min)
    }

    /// The brick that owns a particle at `x` (between rebuilds a particle may have drifted past
    /// a periodic side: it is owned where it wraps to): the one whose extent holds it along
    /// each axis (a coordinate that rounds up to the box length is the last brick's along
    /// that axis).
    pub fn owner(&self, x: V3) -> usize {
        let (wx, wz) = (x[0].rem_euclid(self.lx), x[2].rem_euclid(self.lz));
        (slab(&self.xs, wx) * self.ny + slab(&self.ys, x[1])) * self.nz + slab(&self.zs, wz)
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
        let (mut cx, mut cy, mut cz) = (vec![0.0; self.nx], vec![0.0; self.ny], vec![0.0; self.nz]);
        for (b, &c) in cost.iter().enumerate() {
            let [i, j, k] = self.index(b);
            cx[i] += c;
            cy[j] += c;
            cz[k] += c;
        }
        Bricks {
            xs: shifted(&self.xs, &cx),
            ys: shifted(&self.ys, &cy),
            zs: shifted(&self.zs, &cz),
            ..self.clone()
        }
    }

    /// Whether a particle at `p` (wrapped) is brick `b`'s: its own, or within `cut` of it
    /// along every axis (a ghost it holds).
    pub fn holds(&self, b: usize, p: V3, cut: f64) -> bool {
        let [ex, ey, ez] = self.extent(b);
        self.owner(p) == b
            || (gap_periodic(p[0], ex, self.lx) <= cut
                && gap_open(p[1], ey) <= cut
                && gap_periodic(p[2], ez, self.lz) <= cut)
    }

    /// The bricks near brick `b`, itself excluded, in increasing index: those within `cut`
    /// of it along every axis, the only ones that can hold its particles as ghosts or
    /// receive them at a rebuild (a particle within `cut` of a brick has its owner within
    /// `cut` of that brick). Symmetric: `a` is near `b` when `b` is near `a`. Measured from
    /// the extents with a margin of 1e-9 of the box, so that round-off in a particle's gap
    /// ([`Bricks::holds`]) never makes a brick hold a ghost of one not near it.
    pub fn near(&self, b: usize, cut: f64) -> Vec<usize> {
        let [bx, by, bz] = self.extent(b);
        let ly = self.ys[self.ny] - self.ys[0];
        (0..self.count())
            .filter(|&o| {
                let [ox, oy, oz] = self.extent(o);
                o != b
                    && apart_periodic(bx, ox, self.lx) <= cut + 1e-9 * self.lx
                    && apart_open(by, oy) <= cut + 1e-9 * ly.abs()
                    && apart_periodic(bz, oz, self.lz) <= cut + 1e-9 * self.lz
            })
            .collect()
    }

    /// Brick `b`'s particles in increasing id, and whether each is its own: those it owns and
    /// those within `cut` of it along every axis (its ghosts).
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
    let floor = 0.5 * (edges[n] - edges[0]) / n as f64;
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

    /// The fast preset's box: 4 x 2.4 mm, the plates' bases 4.7 mm apart.
    const LX: f64 = 4.0e-3;
    const LZ: f64 = 2.4e-3;
    const YS: [f64; 2] = [0.6e-3, 5.3e-3];

    /// `n` points over three boxes' lengths along x and z and beyond the plates' bases by a
    /// fifth of the gap (particles between the teeth, and drifted past a periodic side).
    fn points(seed: u64, n: usize, spread: f64) -> Vec<V3> {
        let mut next = uniform(seed);
        let ly = YS[1] - YS[0];
        (0..n)
            .map(|_| {
                let along = |l: f64, u: f64| (u * spread - 0.5 * (spread - 1.0)) * l;
                [
                    along(LX, next()),
                    YS[0] - 0.2 * ly + next() * 1.4 * ly,
                    along(LZ, next()),
                ]
            })
            .collect()
    }

    /// `near` is symmetric, never holds the brick itself, and contains every brick that
    /// holds a ghost of a particle the brick owns (random points, every split up to 4 x 3 x 4,
    /// cuts from a tenth of a brick to beyond a whole one); with a cut under a brick's width
    /// a 4 x 1 x 4 split's brick has its 8 surrounding bricks near, not the other 7, and across
    /// the gap (not periodic) the lowest and highest slabs are not near each other.
    #[test]
    fn near_bricks_are_all_that_can_hold_ghosts() {
        let pts = points(11, 300, 1.0);
        for nx in 1..=4 {
            for ny in 1..=3 {
                for nz in 1..=4 {
                    let b = Bricks::equal([nx, ny, nz], LX, YS, LZ);
                    for cut in [0.1e-3, 0.3e-3, 0.9e-3, 2.5e-3] {
                        for a in 0..b.count() {
                            let near = b.near(a, cut);
                            assert!(!near.contains(&a));
                            for &o in &near {
                                assert!(
                                    b.near(o, cut).contains(&a),
                                    "{nx}x{ny}x{nz} cut {cut}: {a} {o}"
                                );
                            }
                            for p in pts.iter().filter(|&&p| b.owner(p) == a) {
                                for o in (0..b.count()).filter(|&o| o != a) {
                                    if b.holds(o, *p, cut) {
                                        assert!(
                                            near.contains(&o),
                                            "{nx}x{ny}x{nz} {p:?} in {a}, held by {o}"
                                        );
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        let b = Bricks::equal([4, 1, 4], LX, YS, LZ);
        assert_eq!(b.near(0, 0.3e-3), vec![1, 3, 4, 5, 7, 12, 13, 15]);
        assert_eq!(b.near(5, 0.3e-3), vec![0, 1, 2, 4, 6, 8, 9, 10]);
        let b = Bricks::equal([1, 3, 1], LX, YS, LZ);
        assert_eq!(b.near(0, 0.3e-3), vec![1]);
        assert_eq!(b.near(1, 0.3e-3), vec![0, 2]);
        assert_eq!(b.near(2, 0.3e-3), vec![1]);
        // a particle just above the lowest cut is held by the lowest slab, not the highest
        let cut_y = YS[0] + (YS[1] - YS[0]) / 3.0;
        let p = [1e-3, cut_y + 0.1e-3, 1e-3];
        assert_eq!(b.owner(p), 1);
        assert!(b.holds(0, p, 0.3e-3) && !b.holds(2, p, 0.3e-3));
        let b = Bricks::equal([2, 2, 1], LX, YS, LZ);
        assert_eq!(b.near(0, 0.3e-3), vec![1, 2, 3]);
    }

    /// The owner is the brick whose extent holds the wrapped position, at the extents' own
    /// edges too (each edge is the start of the next brick's extent), for every split; a
    /// particle beyond the span across the gap is the end slab's.
    #[test]
    fn the_owner_is_the_brick_whose_extent_holds_the_point() {
        for nx in 1..=4 {
            for ny in 1..=3 {
                for nz in 1..=4 {
                    let b = Bricks::equal([nx, ny, nz], LX, YS, LZ);
                    let mut pts = points(7, 200, 3.0);
                    for i in 0..=nx {
                        for j in 0..=ny {
                            for k in 0..=nz {
                                pts.push([
                                    LX * i as f64 / nx as f64,
                                    YS[0] + (YS[1] - YS[0]) * j as f64 / ny as f64,
                                    LZ * k as f64 / nz as f64,
                                ]);
                            }
                        }
                    }
                    for p in pts {
                        let (wx, wz) = (p[0].rem_euclid(LX), p[2].rem_euclid(LZ));
                        let o = b.owner(p);
                        let [ex, ey, ez] = b.extent(o);
                        let [i, _, k] = b.index(o);
                        let inside = |w: f64, [a, c]: [f64; 2], l: f64, last: bool| {
                            (a..c).contains(&w) || (last && w == l)
                        };
                        assert!(
                            inside(wx, ex, LX, i == nx - 1)
                                && (ey[0]..ey[1]).contains(&p[1])
                                && inside(wz, ez, LZ, k == nz - 1),
                            "{nx} x {ny} x {nz}: {p:?} owned by {o}, extent {:?}",
                            b.extent(o)
                        );
                    }
                }
            }
        }
    }

    /// The balance on a model of measured time (each brick's cost its volume times a factor,
    /// brick 0 30 % slower per particle): repeated rebuilds move the edges until every
    /// slab's cost along each axis is within [`IMBALANCE`] of the mean, and leave equal
    /// costs' bricks as they are. At every rebuild: the end edges stay, the edges increase,
    /// no slab is narrower than half an equal one, no edge moves more than a quarter of a
    /// slab next to it, and a point changes brick only to a near one.
    #[test]
    fn balancing_evens_the_slabs_costs_in_small_moves() {
        let pts = points(5, 300, 1.0);
        for n in [
            [2, 1, 1],
            [3, 1, 1],
            [1, 1, 2],
            [2, 1, 2],
            [4, 1, 3],
            [1, 2, 1],
            [2, 3, 2],
        ] {
            let equal = Bricks::equal(n, LX, YS, LZ);
            let cost = |b: &Bricks, slow: f64| -> Vec<f64> {
                (0..b.count())
                    .map(|r| b.volume_share(r) * if r == 0 { slow } else { 1.0 })
                    .collect()
            };
            assert_eq!(equal.balanced(&cost(&equal, 1.0)), equal);
            let mut b = equal.clone();
            for round in 0..40 {
                let moved = b.balanced(&cost(&b, 1.3));
                for (new, old, n) in [
                    (&moved.xs, &b.xs, n[0]),
                    (&moved.ys, &b.ys, n[1]),
                    (&moved.zs, &b.zs, n[2]),
                ] {
                    assert_eq!((new[0], new[n]), (old[0], old[n]));
                    let l = old[n] - old[0];
                    for k in 0..n {
                        let w = new[k + 1] - new[k];
                        assert!(
                            w >= 0.5 * l / n as f64 * (1.0 - 1e-12),
                            "{n:?} {round}: {new:?}"
                        );
                    }
                    for k in 1..n {
                        let room = 0.25 * (old[k] - old[k - 1]).min(old[k + 1] - old[k]);
                        assert!((new[k] - old[k]).abs() <= room * (1.0 + 1e-12));
                    }
                }
                let cut = 0.3e-3;
                for p in &pts {
                    let (a, o) = (b.owner(*p), moved.owner(*p));
                    assert!(
                        a == o || moved.near(a, cut).contains(&o),
                        "{n:?}: {a} -> {o}"
                    );
                }
                b = moved;
            }
            assert_ne!(b, equal, "{n:?}: the edges moved");
            let c = cost(&b, 1.3);
            for axis in 0..3 {
                let mut s = vec![0.0; n[axis]];
                for (r, &c) in c.iter().enumerate() {
                    s[b.index(r)[axis]] += c;
                }
                let mean = s.iter().sum::<f64>() / s.len() as f64;
                assert!(s.iter().all(|&v| v <= IMBALANCE * mean), "{n:?}: {s:?}");
            }
        }
    }
}
