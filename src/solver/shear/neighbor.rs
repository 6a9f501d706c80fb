//! Half neighbour list with bins and skin, periodic in x and z, with the contact history
//! stored beside each pair and carried over on rebuilds by a merge of two sorted lists (no
//! hashing).
//!
//! LIGGGHTS semantics mirrored: a pair is listed when `|x_i - x_j| <= r_i + r_j + skin`
//! (neigh_gran.cpp, size-dependent cutoff); the list is rebuilt when any particle moved more
//! than skin/2 since the last build (`Neighbor::check_distance`). At a rebuild a pair gets its
//! stored history back only if it is touching at that moment (`rsq < radsum^2`,
//! neigh_gran.cpp); otherwise it starts from zero. Between rebuilds a pair that separated keeps
//! its history (pair_gran_base.h never calls `surfacesClose` with the default contact
//! distance factor), so a quick re-contact resumes it. The partner of a pair across a periodic boundary is seen as
//! LAMMPS sees a ghost atom: at `x_j + shift` with `shift` a multiple of the box length.

use crate::solver::contact::ContactHistory;
use crate::solver::team::{bounds, Team};

/// One listed pair: `i < j`, except across a periodic seam, where `i` is the higher index and
/// `j` the lower one seen at its image. LIGGGHTS (newton off) keeps two copies of such a
/// contact, one per owner, each computed from its own rounded ghost coordinate, and reports the
/// higher id's copy (`compute pair/gran/local` drops the other); this orientation makes the
/// native pair that copy, operation for operation, so its history is the one LIGGGHTS dumps.
/// 32 bytes: what the pair pass reads for every listed pair to decide whether it touches
/// (the history, read only for touching pairs, is kept beside it in [`NeighborList::hist`]).
/// `repr(C)`: the SIMD passes load a pair as 32 bytes `[i j | shift]` ([`super::pairs`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct Pair {
    pub i: u32,
    pub j: u32,
    /// Added to x_j to get the image of j nearest to i.
    pub shift: [f64; 3],
}

/// The list and the per-particle index of its pairs (CSR), for a deterministic reduction.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct NeighborList {
    pub pairs: Vec<Pair>,
    /// The contact history of `pairs[k]` at `hist[k]` (two arrays: the touch test streams
    /// 32 bytes per listed pair instead of 80).
    pub hist: Vec<ContactHistory>,
    /// `start[p]..start[p+1]` indexes `entries` for particle p.
    pub start: Vec<u32>,
    /// (pair index, p is the pair's i) in increasing pair index.
    pub entries: Vec<(u32, bool)>,
    pub builds: u64,
    /// Builds of this list in this process (not restored from a checkpoint, unlike
    /// `builds`): what per-list plans made from it are keyed by.
    #[serde(skip)]
    pub generation: u64,
}

/// The cell offsets to scan along a periodic axis of `cells` cells, each neighbour cell once
/// (with two cells, -1 and +1 are the same cell).
fn cell_offsets(cells: usize) -> &'static [isize] {
    match cells {
        0 | 1 => &[0],
        2 => &[0, 1],
        _ => &[-1, 0, 1],
    }
}

/// Spare capacity kept beside `n` per-pair values: 1/8 and 64 more, enough for the list's
/// growth between builds without doubling what is held.
pub(super) fn spare(n: usize) -> usize {
    n / 8 + 64
}

/// `v.resize(n, T::default())` holding at most about [`spare`] unused capacity (plain
/// `resize` grows by doubling: up to twice the memory used).
pub(super) fn resize_snug<T: Clone + Default>(v: &mut Vec<T>, n: usize) {
    if v.capacity() < n {
        v.reserve_exact(n + spare(n) - v.len());
    }
    v.resize(n, T::default());
    if v.capacity() > n + 2 * spare(n) {
        v.shrink_to(n + spare(n));
    }
}

/// Box geometry the list needs.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct Periodic {
    pub lx: f64,
    pub lz: f64,
}

/// The list's cutoff, `2 r_max + skin`: every pair that may touch before the next rebuild is
/// listed, so it bounds every partner a particle can have: what a brick's ghosts must cover.
pub fn cutoff(radius: &[f64], skin: f64) -> f64 {
    2.0 * radius.iter().cloned().fold(0.0, f64::max) + skin
}

/// The histories a rebuild may carry over: those of listed pairs with a bit set (a touching
/// pair with an all-zero history gets the same bits as a new one), each with its pair's
/// `(i, j)` as global ids, sorted by the pair's key (lower id, higher id).
#[derive(Clone, Debug, Default)]
pub struct Carried {
    pub ij: Vec<(u32, u32)>,
    pub hist: Vec<ContactHistory>,
    /// The length of the list they came from: about the next one's (the list changes little
    /// between builds; a capacity of 8 per particle held 256 bytes per particle for 140 used).
    pub listed: usize,
}

impl Carried {
    /// A pair's key: (lower id, higher id), the order of the list and of `Carried`.
    pub fn key((i, j): (u32, u32)) -> (u32, u32) {
        (i.min(j), i.max(j))
    }

    /// Merges histories carried from elsewhere (a brick's immigrants, `ij` global) into
    /// these: sorted by key, one entry per pair (two copies of a pair's history, one per
    /// owner of its members, are equal bit for bit: the first is kept).
    /// Done in place (the incoming few sorted, then the two sorted runs merged from the
    /// back into the grown arrays, then each key's first entry kept), without a copy of the
    /// whole list: as the stable sort of these followed by the incoming would order them.
    pub fn merge(&mut self, more: impl IntoIterator<Item = ((u32, u32), ContactHistory)>) {
        let mut more: Vec<((u32, u32), ContactHistory)> = more.into_iter().collect();
        if more.is_empty() {
            return;
        }
        more.sort_by_key(|e| Carried::key(e.0));
        let (n, m) = (self.ij.len(), more.len());
        self.ij.resize(n + m, (0, 0));
        self.hist.resize(n + m, ContactHistory::default());
        let (mut i, mut w) = (n, n + m);
        while let Some(&(ij, h)) = more.last() {
            w -= 1;
            // equal keys: these before the incoming (from the back, the incoming first)
            if i > 0 && Carried::key(self.ij[i - 1]) > Carried::key(ij) {
                i -= 1;
                self.ij[w] = self.ij[i];
                self.hist[w] = self.hist[i];
            } else {
                self.ij[w] = ij;
                self.hist[w] = h;
                more.pop();
            }
        }
        // one entry per key, its first
        let mut kept = 0;
        for k in 0..self.ij.len() {
            if kept == 0 || Carried::key(self.ij[k]) != Carried::key(self.ij[kept - 1]) {
                self.ij[kept] = self.ij[k];
                self.hist[kept] = self.hist[k];
                kept += 1;
            }
        }
        self.ij.truncate(kept);
        self.hist.truncate(kept);
    }
}

/// Which particles of a brick (issue #39, [`super::bricks`]) a list is built over: each
/// one's global id (increasing: local order is id order) and whether it is a ghost (held for
/// its pairs with the brick's own particles; pairs of two ghosts are not listed). Empty
/// slices: one process, ids are indices, no ghosts.
#[derive(Clone, Copy, Debug, Default)]
pub struct Members<'a> {
    pub ids: &'a [u32],
    pub ghost: &'a [bool],
}

impl Members<'_> {
    fn id(&self, q: u32) -> u32 {
        if self.ids.is_empty() {
            q
        } else {
            self.ids[q as usize]
        }
    }

    fn ghost(&self, q: usize) -> bool {
        self.ghost.get(q) == Some(&true)
    }
}

impl NeighborList {
    /// Rebuilds the list for positions `x` (already wrapped into [0, lx) x [0, lz)), carrying
    /// the histories of its touching pairs over from the list it replaces.
    pub fn build(
        &mut self,
        team: &Team,
        x: &[[f64; 3]],
        radius: &[f64],
        skin: f64,
        box_: Periodic,
    ) {
        let carried = self.take_carried(Members::default());
        self.build_over(team, x, radius, skin, box_, Members::default(), carried);
    }

    /// The histories to carry over, and nothing else (see [`Carried`]), in list order, which
    /// is key order; the histories compacted in place in the old array, whose tail is then
    /// returned, and the per-particle index freed and the old pairs emptied (their buffer,
    /// the same size, kept for the new list), before a new list is made.
    /// Measured at 250,000 particles (peak RSS growth of the solver for 814 bytes per
    /// particle held): old and new lists side by side about 1,180; a separate copy of the
    /// carried histories beside the old list 1,034; this 890 (`verify bench`).
    pub fn take_carried(&mut self, over: Members) -> Carried {
        let carry = |h: &ContactHistory| !h.all_bits_zero();
        let mut ij: Vec<(u32, u32)> =
            Vec::with_capacity(self.hist.iter().filter(|h| carry(h)).count());
        let mut hist = std::mem::take(&mut self.hist);
        for k in 0..hist.len() {
            if carry(&hist[k]) {
                hist[ij.len()] = hist[k];
                let p = &self.pairs[k];
                ij.push((over.id(p.i), over.id(p.j)));
            }
        }
        hist.truncate(ij.len());
        hist.shrink_to_fit();
        let listed = self.pairs.len();
        // the pairs' buffer is kept for the new list (`build_over`): the same size again,
        // without faulting in fresh pages (tens of megabytes at 250,000 particles)
        self.pairs.clear();
        self.entries = Vec::new();
        Carried { ij, hist, listed }
    }

    /// Builds the list over the particles `over` (see [`Members`]) for positions `x` (already wrapped),
    /// each touching pair given its history from `carried` (by the pair's global ids).
    #[allow(clippy::too_many_arguments)]
    pub fn build_over(
        &mut self,
        team: &Team,
        x: &[[f64; 3]],
        radius: &[f64],
        skin: f64,
        box_: Periodic,
        over: Members,
        carried: Carried,
    ) {
        let n = x.len();
        let cut = cutoff(radius, skin);
        let (ymin, ymax) = x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p[1]), b.max(p[1]))
            });
        let nx = ((box_.lx / cut).floor() as usize).max(1);
        let nz = ((box_.lz / cut).floor() as usize).max(1);
        let ny = (((ymax - ymin) / cut).floor() as usize + 1).max(1);
        let cx = |v: f64| {
            (((v / box_.lx) * nx as f64).floor() as isize).clamp(0, nx as isize - 1) as usize
        };
        let cz = |v: f64| {
            (((v / box_.lz) * nz as f64).floor() as isize).clamp(0, nz as isize - 1) as usize
        };
        let cy = |v: f64| (((v - ymin) / cut).floor() as usize).min(ny - 1);
        // counting sort of particles into cells
        let ncell = nx * ny * nz;
        let cell_of: Vec<u32> = x
            .iter()
            .map(|p| ((cx(p[0]) * ny + cy(p[1])) * nz + cz(p[2])) as u32)
            .collect();
        let mut head = vec![0u32; ncell + 1];
        for &c in &cell_of {
            head[c as usize + 1] += 1;
        }
        for c in 0..ncell {
            head[c + 1] += head[c];
        }
        let mut fill = head.clone();
        let mut members = vec![0u32; n];
        for (p, &c) in cell_of.iter().enumerate() {
            members[fill[c as usize] as usize] = p as u32;
            fill[c as usize] += 1;
        }
        drop(fill);
        // each member's position and radius in member order: a cell's candidates are read
        // from one contiguous run instead of gathered from the particle arrays, and a
        // particle's own cell is decoded from `cell_of` instead of found again (the same
        // values, the same list). Measured: criterion `neighbor build 2500` 1.51 -> 1.31 ms;
        // the whole list build at 250,000 particles (1 thread) 241-273 -> 212 ms.
        let rec: Vec<[f64; 4]> = members
            .iter()
            .map(|&j| {
                let p = x[j as usize];
                [p[0], p[1], p[2], radius[j as usize]]
            })
            .collect();
        let mut new_pairs: Vec<Pair> = std::mem::take(&mut self.pairs);
        new_pairs.clear();
        new_pairs.reserve_exact(carried.listed + spare(carried.listed));
        // the search, each thread over its share of the particles in order ([`bounds`]);
        // the shares' lists joined in thread order are the serial list (the first share
        // fills the list itself: a copy of the whole list would raise the peak)
        let th = team.threads();
        let cap = new_pairs.capacity();
        let mut first = Some(new_pairs);
        let (xs, zs) = (cell_offsets(nx), cell_offsets(nz));
        let mut shares = team.map((0..th).map(|_| first.take()).collect(), |t, list| {
            let range = bounds(n, th, t);
            let mut new_pairs = list.unwrap_or_else(|| Vec::with_capacity(cap * range.len() / n));
            let mut touching: Vec<bool> = Vec::with_capacity(new_pairs.capacity());
            let mut cand: Vec<(u32, [f64; 3], bool)> = Vec::new();
            for i in range {
                let ghost_i = over.ghost(i);
                let c = cell_of[i] as usize;
                let (ix, iy, iz) = (c / (ny * nz), (c / nz) % ny, c % nz);
                // the z columns of i's neighbour cells (periodic)
                let mut gzs = [0usize; 3];
                for (g, &dz) in gzs.iter_mut().zip(zs) {
                    *g = (iz as isize + dz).rem_euclid(nz as isize) as usize;
                }
                let gzs = &gzs[..zs.len()];
                cand.clear();
                for &dx in xs {
                    let gx = (ix as isize + dx).rem_euclid(nx as isize) as usize;
                    for dy in [-1isize, 0, 1] {
                        let gy = iy as isize + dy;
                        if gy < 0 || gy >= ny as isize {
                            continue;
                        }
                        let column = (gx * ny + gy as usize) * nz;
                        for &gz in gzs {
                            let c = column + gz;
                            let span = head[c] as usize..head[c + 1] as usize;
                            let cell = &members[span.clone()];
                            // a cell's members are in increasing index (the counting sort
                            // visits the particles in order): the partners j > i are a
                            // tail, found without a branch per member on `j <= i` (taken
                            // about half the time, in no pattern a predictor follows).
                            // Measured (criterion `neighbor build 2500`, loose packing):
                            // 1.91 -> 1.57 ms per build, with the cells' z columns found
                            // once per particle instead of once per cell.
                            let above = cell.partition_point(|&j| (j as usize) <= i);
                            let recs = &rec[span][above..];
                            for (&j, xj) in cell[above..].iter().zip(recs) {
                                if ghost_i && over.ghost(j as usize) {
                                    continue;
                                }
                                let mut shift = [0.0; 3];
                                let mut d = [x[i][0] - xj[0], x[i][1] - xj[1], x[i][2] - xj[2]];
                                if d[0] > 0.5 * box_.lx {
                                    shift[0] = box_.lx;
                                } else if d[0] < -0.5 * box_.lx {
                                    shift[0] = -box_.lx;
                                }
                                if d[2] > 0.5 * box_.lz {
                                    shift[2] = box_.lz;
                                } else if d[2] < -0.5 * box_.lz {
                                    shift[2] = -box_.lz;
                                }
                                d[0] = x[i][0] - (xj[0] + shift[0]);
                                d[2] = x[i][2] - (xj[2] + shift[2]);
                                let radsum = radius[i] + xj[3];
                                let rc = radsum + skin;
                                let rsq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                                if rsq <= rc * rc {
                                    cand.push((j, shift, rsq < radsum * radsum));
                                }
                            }
                        }
                    }
                }
                cand.sort_by_key(|c| c.0);
                cand.dedup_by_key(|c| c.0);
                for &(j, shift, touch) in &cand {
                    touching.push(touch);
                    let (a, b, s) = if shift == [0.0; 3] {
                        (i as u32, j, shift)
                    } else {
                        (j, i as u32, [-shift[0], -shift[1], -shift[2]])
                    };
                    new_pairs.push(Pair {
                        i: a,
                        j: b,
                        shift: s,
                    });
                }
            }
            (new_pairs, touching)
        });
        drop((cell_of, rec));
        let (mut new_pairs, mut touching) = shares.remove(0);
        for (p, t) in shares {
            new_pairs.extend_from_slice(&p);
            touching.extend_from_slice(&t);
        }
        // carry histories of touching pairs over: both lists are sorted by (lower, higher)
        let mut new_hist = vec![ContactHistory::default(); new_pairs.len()];
        let mut k = 0;
        for ((p, &touch), nh) in new_pairs.iter().zip(&touching).zip(new_hist.iter_mut()) {
            if !touch {
                continue;
            }
            let gi = over.id(p.i);
            let now = Carried::key((gi, over.id(p.j)));
            while k < carried.ij.len() && Carried::key(carried.ij[k]) < now {
                k += 1;
            }
            if k < carried.ij.len() && Carried::key(carried.ij[k]) == now {
                let (old_i, h) = (carried.ij[k].0, carried.hist[k]);
                // a pair that started or stopped crossing the seam turned round: its history
                // is relative (i against j), so it changes sign
                *nh = if old_i == gi { h } else { h.turned_round() };
            }
        }
        drop((touching, carried));
        if new_pairs.capacity() > new_pairs.len() + 2 * spare(new_pairs.len()) {
            new_pairs.shrink_to(new_pairs.len() + spare(new_pairs.len()));
        }
        self.pairs = new_pairs;
        self.hist = new_hist;
        self.index(n);
        self.builds += 1;
    }

    /// Makes the per-particle index (CSR `start`, `entries`) of `pairs` over `n` particles:
    /// each particle's pairs in increasing pair index. A new list for the per-list plans
    /// (`generation`).
    pub fn index(&mut self, n: usize) {
        let mut count = vec![0u32; n + 1];
        for p in &self.pairs {
            count[p.i as usize + 1] += 1;
            count[p.j as usize + 1] += 1;
        }
        for q in 0..n {
            count[q + 1] += count[q];
        }
        let mut fill = count.clone();
        self.entries = vec![(0, false); 2 * self.pairs.len()];
        for (k, p) in self.pairs.iter().enumerate() {
            for (q, is_i) in [(p.i as usize, true), (p.j as usize, false)] {
                self.entries[fill[q] as usize] = (k as u32, is_i);
                fill[q] += 1;
            }
        }
        self.start = count;
        self.generation += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use proptest::prelude::*;

    proptest! {
        /// The in-place merge gives what the stable sort of the carried histories followed
        /// by the incoming ones, then each key's first entry, gives: the order, the kept
        /// copy of a pair carried twice, and every bit of the histories.
        #[test]
        fn merge_in_place_is_sort_then_first_of_each_key(
            mine in proptest::collection::btree_set((0u32..60, 0u32..60), 0..80),
            more in proptest::collection::vec(((0u32..60, 0u32..60), -5.0f64..5.0), 0..30),
        ) {
            let hist = |v: f64| {
                let mut h = ContactHistory::default();
                h.shear[0] = v;
                h
            };
            // carried: one entry per key, in key order, as take_carried leaves them
            let mut keys: Vec<(u32, u32)> = mine.iter().map(|&p| Carried::key(p)).collect();
            keys.sort();
            keys.dedup();
            let mut c = Carried {
                ij: keys.iter().map(|&(a, b)| (b, a)).collect(),
                hist: (0..keys.len()).map(|k| hist(k as f64)).collect(),
                listed: 0,
            };
            let more: Vec<((u32, u32), ContactHistory)> =
                more.iter().map(|&(ij, v)| (ij, hist(v))).collect();
            let mut want: Vec<((u32, u32), ContactHistory)> =
                c.ij.iter().copied().zip(c.hist.iter().copied()).chain(more.clone()).collect();
            want.sort_by_key(|e| Carried::key(e.0));
            want.dedup_by_key(|e| Carried::key(e.0));
            c.merge(more);
            let got: Vec<((u32, u32), u64)> =
                c.ij.iter().zip(&c.hist).map(|(&ij, h)| (ij, h.shear[0].to_bits())).collect();
            let want: Vec<((u32, u32), u64)> =
                want.iter().map(|(ij, h)| (*ij, h.shear[0].to_bits())).collect();
            prop_assert_eq!(got, want);
        }
    }

    /// `resize_snug` keeps the values, the length asked for, and at most about 1/8 spare,
    /// growing or shrinking.
    #[test]
    fn snug_resize_keeps_values_and_little_spare() {
        let mut v: Vec<u64> = (0..1000).collect();
        v.reserve(7000);
        resize_snug(&mut v, 1200);
        assert_eq!(v.len(), 1200);
        assert!(v[..1000].iter().enumerate().all(|(i, &x)| x == i as u64));
        assert!(v[1000..].iter().all(|&x| x == 0));
        assert!(v.capacity() <= 1200 + 2 * spare(1200), "{}", v.capacity());
        resize_snug(&mut v, 100);
        assert_eq!(v.len(), 100);
        assert!(v.capacity() <= 100 + 2 * spare(100), "{}", v.capacity());
        for n in [101, 5000, 5001, 5100] {
            resize_snug(&mut v, n);
            assert_eq!(v.len(), n);
            assert!(v.capacity() >= n && v.capacity() <= n + 2 * spare(n));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 300,
            failure_persistence: None,
            rng_seed: proptest::test_runner::RngSeed::Fixed(20261202),
            ..ProptestConfig::default()
        })]

        /// The cell list finds exactly the pairs a brute-force search over every pair and
        /// the nearest periodic image finds (`|d| <= radsum + skin`), with that image's
        /// shift, over random polydisperse packings in boxes of 1 to many cells.
        #[test]
        fn cell_list_equals_brute_force(
            n in 2usize..160,
            lx in 0.3f64..3.0,
            lz in 0.3f64..3.0,
            ly in 0.1f64..2.0,
            rmax in 0.02f64..0.12,
            skin_frac in 0.0f64..0.5,
            seed in any::<u64>(),
        ) {
            // a small LCG: the packing is a function of the generated seed
            let mut state = seed | 1;
            let mut u = || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            let x: Vec<[f64; 3]> = (0..n).map(|_| [u() * lx, u() * ly, u() * lz]).collect();
            let r: Vec<f64> = (0..n).map(|_| rmax * (0.5 + 0.5 * u())).collect();
            let skin = skin_frac * rmax;
            let b = Periodic { lx, lz };
            let mut nl = NeighborList::default();
            nl.build(&Team::new(1), &x, &r, skin, b);
            // the same list, in the same order, from a team of three
            let mut nl3 = NeighborList::default();
            nl3.build(&Team::new(3), &x, &r, skin, b);
            prop_assert!(
                nl3.pairs.iter().map(|p| (p.i, p.j, p.shift)).eq(nl.pairs.iter().map(|p| (p.i, p.j, p.shift))),
                "3 threads list other pairs"
            );
            prop_assert_eq!(&nl3.start, &nl.start);
            let mut found: Vec<(u32, u32)> =
                nl.pairs.iter().map(|p| (p.i.min(p.j), p.i.max(p.j))).collect();
            found.sort();
            let n_found = found.len();
            found.dedup();
            prop_assert_eq!(found.len(), n_found, "a pair listed twice");
            let mut brute = Vec::new();
            for i in 0..n {
                for j in i + 1..n {
                    let mut d = [x[i][0] - x[j][0], x[i][1] - x[j][1], x[i][2] - x[j][2]];
                    d[0] -= lx * (d[0] / lx).round();
                    d[2] -= lz * (d[2] / lz).round();
                    let rc = r[i] + r[j] + skin;
                    let rsq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                    // pairs at the cutoff to round-off are not decided here
                    if (rsq - rc * rc).abs() > 1e-9 * rc * rc && rsq < rc * rc {
                        brute.push((i as u32, j as u32));
                    }
                }
            }
            for p in &brute {
                prop_assert!(found.binary_search(p).is_ok(), "missing pair {:?}", p);
            }
            // every listed pair is within the cutoff through its shift
            for p in &nl.pairs {
                let (i, j) = (p.i as usize, p.j as usize);
                let d = [
                    x[i][0] - (x[j][0] + p.shift[0]),
                    x[i][1] - (x[j][1] + p.shift[1]),
                    x[i][2] - (x[j][2] + p.shift[2]),
                ];
                let rc = r[i] + r[j] + skin;
                prop_assert!(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= rc * rc * (1.0 + 1e-9));
            }
        }
    }

    #[test]
    fn finds_pairs_across_periodic_boundaries_and_keeps_history_of_touching_pairs() {
        let x = vec![
            [0.05, 0.5, 0.5],
            [0.95, 0.5, 0.5],
            [0.5, 0.5, 0.5],
            [0.5, 0.5, 0.98],
        ];
        let r = vec![0.06; 4];
        let mut nl = NeighborList::default();
        let b = Periodic { lx: 1.0, lz: 1.0 };
        nl.build(&Team::new(1), &x, &r, 0.01, b);
        assert_eq!(nl.pairs.len(), 1, "{:?}", nl.pairs);
        // across the seam the pair is oriented from the higher index (LIGGGHTS' reported copy)
        assert_eq!((nl.pairs[0].i, nl.pairs[0].j), (1, 0));
        assert_eq!(nl.pairs[0].shift, [1.0, 0.0, 0.0]);
        nl.hist[0].shear = [1.0, 2.0, 3.0];
        nl.build(&Team::new(1), &x, &r, 0.01, b);
        assert_eq!(nl.hist[0].shear, [1.0, 2.0, 3.0]);
        // particle 0 wrapped to the other side of the seam: the pair no longer crosses it,
        // turns round to (0, 1), and its relative history changes sign
        let mut wrapped = x.clone();
        wrapped[0][0] = 1.05 - 1e-3;
        nl.build(&Team::new(1), &wrapped, &r, 0.01, b);
        assert_eq!(
            (nl.pairs[0].i, nl.pairs[0].j, nl.pairs[0].shift),
            (0, 1, [0.0; 3])
        );
        assert_eq!(nl.hist[0].shear, [-1.0, -2.0, -3.0]);
        nl.build(&Team::new(1), &x, &r, 0.01, b);
        assert_eq!(nl.hist[0].shear, [1.0, 2.0, 3.0]);
        // listed but not touching at the rebuild: history starts again from zero
        let mut apart = x.clone();
        apart[1] = [0.925, 0.5, 0.5];
        nl.build(&Team::new(1), &apart, &r, 0.01, b);
        assert_eq!(nl.pairs.len(), 1);
        assert_eq!(nl.hist[0].shear, [0.0; 3]);
        // the CSR lists each pair for both particles
        assert_eq!(nl.start, vec![0, 1, 2, 2, 2]);
        let mut far = x.clone();
        far[1] = [0.7, 0.5, 0.5];
        nl.build(&Team::new(1), &far, &r, 0.01, b);
        assert!(nl.pairs.is_empty());
    }

    #[test]
    fn brute_force_agrees_on_random_positions() {
        let mut rng = crate::packing::SplitMix64::new(3);
        let n = 400;
        let x: Vec<[f64; 3]> = (0..n)
            .map(|_| [rng.uniform(), rng.uniform() * 0.5, rng.uniform() * 0.8])
            .collect();
        let r: Vec<f64> = (0..n).map(|_| 0.02 + 0.02 * rng.uniform()).collect();
        let mut nl = NeighborList::default();
        nl.build(&Team::new(1), &x, &r, 0.005, Periodic { lx: 1.0, lz: 0.8 });
        let mut brute = 0;
        for i in 0..n {
            for j in i + 1..n {
                let mut d = [x[i][0] - x[j][0], x[i][1] - x[j][1], x[i][2] - x[j][2]];
                d[0] -= (d[0] / 1.0).round();
                d[2] -= 0.8 * (d[2] / 0.8).round();
                let rc = r[i] + r[j] + 0.005;
                if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= rc * rc {
                    brute += 1;
                }
            }
        }
        assert_eq!(nl.pairs.len(), brute);
    }
}
