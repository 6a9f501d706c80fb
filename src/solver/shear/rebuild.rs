//! The rebuild policy and the broad phase: when the neighbour list is rebuilt
//! (`Neighbor::decide`, `check_distance`, the meshes' `decideRebuild`), what a rebuild does
//! (periodic wrap, pair list, plates' elements wrapped and refreshed), and the per-particle
//! plate-triangle candidates built with it.

use super::{image_shift, ShearSim};
use crate::error::{Error, Result};
use crate::solver::team::{bounds, Team};
use crate::solver::trimesh::TriMesh;
use crate::solver::vec3::V3;

/// A plate-triangle candidate of a particle: (mesh, triangle, image).
type WallCand = (u8, u32, u8);

impl ShearSim {
    /// `Neighbor::decide` with `delay 0`: a rebuild a plate asked for at the previous step
    /// (`next_reneighbor`), else every `neighbor.every` steps since the last build, and with
    /// `check` only if an atom moved more than skin/2 (`check_distance`): `particles_moved`,
    /// found by the drift of the same step ([`ShearSim::step`]; the positions do not change
    /// between the drift and this decision).
    pub(super) fn decide_rebuild(&mut self, particles_moved: bool) -> bool {
        if self.mesh_rebuild_pending {
            return true;
        }
        self.ago += 1;
        self.ago.is_multiple_of(self.rebuild_every) && (!self.rebuild_check || particles_moved)
    }

    /// `MultiNodeMesh::decideRebuild` for both plates: a node moved more than skin/2 since the
    /// last build (every node of a plate moves by the same vector).
    pub(super) fn plates_moved(&self) -> bool {
        let trigger = 0.5 * self.skin;
        (self.bottom.offset_x - self.bottom_hold).abs() > trigger
            || (self.top.base_y - self.top_hold).abs() > trigger
    }

    /// Wraps positions into the periodic box (LAMMPS `domain->pbc()`) and rebuilds the list.
    /// First the divergence check ([`ShearSim::check_diverged`]): a blown-up state is an
    /// error naming the step and the particle, never a neighbour grid over a huge extent.
    pub(super) fn rebuild(&mut self) -> Result<()> {
        let team = self.team();
        self.check_diverged(&team)?;
        self.wrap();
        self.nl
            .build(&team, &self.x, &self.radius, self.skin, self.box_);
        self.after_list(&team);
        Ok(())
    }

    /// The periodic wrap of every position into [0, lx) x [0, lz) (LAMMPS `domain->pbc()`).
    pub(super) fn wrap(&mut self) {
        let (lx, lz) = (self.box_.lx, self.box_.lz);
        // the wrap changes positions the drift packed
        self.packed_current = false;
        for x in &mut self.x {
            if x[0] < 0.0 {
                x[0] += lx;
            } else if x[0] >= lx {
                x[0] -= lx;
            }
            if x[2] < 0.0 {
                x[2] += lz;
            } else if x[2] >= lz {
                x[2] -= lz;
            }
        }
    }

    /// What a rebuild does after the new pair list: the plates' part, the plate candidates,
    /// the positions kept for the next `check_distance`, the per-pair buffers sized.
    pub(super) fn after_list(&mut self, team: &Team) {
        self.rebuild_plates();
        self.build_wall_candidates(team);
        self.xhold.clone_from(&self.x);
        self.size_pair_buffers();
    }

    /// The cheap divergence check of every neighbour rebuild: every particle finite, inside
    /// LIGGGHTS' fixed y bounds, and no more than one box length outside the periodic x and z
    /// range (a sane run moves a particle less than skin/2 between checks, far less than
    /// that). Costs one pass over the particles per rebuild.
    pub(super) fn check_diverged(&self, team: &Team) -> Result<()> {
        let (lx, lz) = (self.box_.lx, self.box_.lz);
        let (ylo, yhi) = self.box_y;
        let (x, v) = (&self.x, &self.v);
        let (th, n) = (team.threads(), x.len());
        // the first bad particle of each share; the first of those
        let bad = team
            .map((0..th).collect(), |_, t| {
                bounds(n, th, t).find(|&i| {
                    !(x[i].iter().chain(v[i].iter()).all(|c| c.is_finite())
                        && (-lx..2.0 * lx).contains(&x[i][0])
                        && (ylo..=yhi).contains(&x[i][1])
                        && (-lz..2.0 * lz).contains(&x[i][2]))
                })
            })
            .into_iter()
            .flatten()
            .next();
        match bad {
            None => Ok(()),
            Some(i) => Err(Error::Solver {
                step: self.step,
                msg: format!(
                    "the run diverged: particle {} is at {:?} m with velocity {:?} m/s \
                     (box x 0..{lx:e}, y {ylo:e}..{yhi:e}, z 0..{lz:e}); a time step or a \
                     rolling stiffness too large for the contacts is the usual cause",
                    self.id_of(i) + 1,
                    self.x[i],
                    self.v[i]
                ),
            }),
        }
    }

    /// The plates' part of a rebuild: the bottom mesh's elements wrapped into the box
    /// (FixMesh::pre_force, `pbcExchangeBorders`), the surface properties recomputed from the
    /// moved nodes (`refreshOwned`), node positions and build counter kept
    /// for the next decision (`storeNodePosRebuild`, `Neighbor::build` sets `ago = 0`).
    pub(super) fn rebuild_plates(&mut self) {
        self.meshes[0].wrap_x(self.box_.lx);
        for m in &mut self.meshes {
            m.refresh_surface_properties();
        }
        self.ago = 0;
        self.mesh_rebuild_pending = false;
        self.bottom_hold = self.bottom.offset_x;
        self.top_hold = self.top.base_y;
    }

    /// Per particle, the (mesh, triangle, image) within reach until the next rebuild: the
    /// triangle's plane within `r + skin` and its bounding sphere within `r_bound + r + skin`
    /// (LIGGGHTS' test), ordered as LIGGGHTS loops: bottom mesh then top, the triangle itself
    /// before its images, by triangle id.
    ///
    /// Not in LIGGGHTS: a candidate must also have its bounding box within `r + skin`. The
    /// plates' triangles are strips across the whole box, so the bounding sphere admits faces
    /// two teeth away whose plane happens to pass near the particle; the box test drops them.
    /// It only drops triangles that cannot be touched before the next rebuild (a particle
    /// and a plate each move less than `skin / 2` until then, and the box distance is a lower
    /// bound of the triangle distance), and it keeps the order of the others, so the contacts
    /// found and the order their forces are summed in are unchanged: bitwise the same
    /// results, fewer sphere-triangle tests per step.
    pub(super) fn build_wall_candidates(&mut self, team: &Team) {
        let (lx, lz, skin) = (self.box_.lx, self.box_.lz, self.skin);
        let meshes = &self.meshes;
        let y_range: Vec<(f64, f64)> = meshes
            .iter()
            .map(|m| {
                m.tris
                    .iter()
                    .flat_map(|t| t.nodes.iter().map(|n| n[1]))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), y| {
                        (lo.min(y), hi.max(y))
                    })
            })
            .collect();
        // per mesh its triangles by the x of their centres, and the largest x distance from
        // a triangle's centre to one of its nodes (`hx`): a triangle whose centre is farther
        // in x than hx + r + skin from the particle's image has its bounding box farther
        // than r + skin in x alone and fails the box test of `is_candidate`, so only a
        // window of triangles is tested (in increasing index, the order of testing them
        // all: the same candidates in the same order; the 1e-9 margin, ~1e-13 m, covers the
        // rounding of the box's corners, ~1e-17 m). The plates are strips across z, their
        // triangles spread along x: at 250,000 particles (160 triangles per plate) every
        // particle near a plate tested all 160 at 9 images (47.6 ns per particle-step for
        // the neighbour phase, 1 thread, 1,000 steps, 20 rebuilds). A window by the
        // largest bounding radius (44.0 ns) still held 60 % of them: the strips' bounding
        // radius is half the box's z length. By hx, measured per rebuild at 250,000 (1
        // thread, each part of the rebuild timed): the candidates 178-189 -> 16 ms (the
        // pair search 195-205 ms).
        let by_x: Vec<(Vec<(f64, u32)>, f64)> = meshes
            .iter()
            .map(|m| {
                let mut v: Vec<(f64, u32)> = m
                    .center
                    .iter()
                    .enumerate()
                    .map(|(t, c)| (c[0], t as u32))
                    .collect();
                v.sort_by(|a, b| a.0.total_cmp(&b.0));
                let hx = m
                    .tris
                    .iter()
                    .zip(&m.center)
                    .flat_map(|(t, c)| t.nodes.iter().map(move |n| (n[0] - c[0]).abs()))
                    .fold(0.0, f64::max);
                (v, hx)
            })
            .collect();
        // each share's candidates in particle order, with its particles' counts; joined in
        // share order
        let (x, radius, ghost) = (&self.x, &self.radius, &self.ghost);
        let (th, n) = (team.threads(), x.len());
        let per: Vec<(Vec<WallCand>, Vec<u32>)> = team.map((0..th).collect(), |_, share| {
            let (mut c, mut counts) = (Vec::new(), Vec::with_capacity(bounds(n, th, share).len()));
            let mut window: Vec<u32> = Vec::new();
            for q in bounds(n, th, share) {
                // a brick's ghost: its plate contacts are its owner's
                if ghost.get(q) == Some(&true) {
                    counts.push(0);
                    continue;
                }
                let (p, r) = (&x[q], radius[q]);
                let before = c.len();
                for (m, mesh) in meshes.iter().enumerate() {
                    // a particle farther than r + skin from the mesh's y extent has no
                    // candidate in it (each triangle's box test would fail): skip the mesh
                    let (ylo, yhi) = y_range[m];
                    if p[1] < ylo - (r + skin) * (1.0 + 1e-9)
                        || p[1] > yhi + (r + skin) * (1.0 + 1e-9)
                    {
                        continue;
                    }
                    let (sorted, hx) = &by_x[m];
                    let half = (hx + r + skin) * (1.0 + 1e-9);
                    for img in [4u8, 0, 1, 2, 3, 5, 6, 7, 8] {
                        let s = image_shift(img, lx, lz);
                        let x0 = p[0] - s[0];
                        let lo = sorted.partition_point(|e| e.0 < x0 - half);
                        let hi = sorted.partition_point(|e| e.0 <= x0 + half);
                        window.clear();
                        window.extend(sorted[lo..hi.max(lo)].iter().map(|e| e.1));
                        window.sort_unstable();
                        for &t in &window {
                            if is_candidate(mesh, t as usize, p, r, skin, s) {
                                c.push((m as u8, t, img));
                            }
                        }
                    }
                }
                counts.push((c.len() - before) as u32);
            }
            (c, counts)
        });
        self.wall_start.clear();
        self.wall_start.push(0);
        self.wall_cand.clear();
        for (c, counts) in per {
            for k in counts {
                let last = *self.wall_start.last().unwrap_or(&0);
                self.wall_start.push(last + k);
            }
            self.wall_cand.extend(c);
        }
        self.drop_records_without_candidates();
    }

    /// Clears the plate contact records of every particle without candidates: what its next
    /// evaluation would do (mark every record, test no triangle, clean up the unmarked), done
    /// once here so that the force loop can skip such particles without reading their
    /// records.
    pub(super) fn drop_records_without_candidates(&mut self) {
        for (q, slots) in self.wall.iter_mut().enumerate() {
            if self.wall_start[q] == self.wall_start[q + 1] {
                // frees the records' memory too
                slots.rec = Vec::new();
            }
        }
    }
}

/// Whether triangle `t` of `mesh`, shifted by `s`, is a plate candidate of a particle at `p`
/// of radius `r` (`resolveTriSphereNeighbuild`: plane distance first, then the bounding
/// sphere, then the triangle's bounding box, each within r + skin).
fn is_candidate(mesh: &TriMesh, t: usize, p: &V3, r: f64, skin: f64, s: V3) -> bool {
    let (cen, rb) = (&mesh.center[t], mesh.r_bound[t]);
    let d = [p[0] - cen[0] - s[0], p[1] - cen[1], p[2] - cen[2] - s[2]];
    let reach = rb + r + skin;
    let n = mesh.tris[t].normal;
    let plane = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]).abs();
    plane <= r + skin
        && d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= reach * reach
        && box_distance_sq(p, &mesh.tris[t].nodes, s) <= (r + skin) * (r + skin) * (1.0 + 1e-9)
}

/// Squared distance from `p` to the axis-aligned bounding box of a triangle shifted by `s`.
fn box_distance_sq(p: &V3, nodes: &[V3; 3], s: V3) -> f64 {
    let mut d2 = 0.0;
    for c in 0..3 {
        let lo = nodes[0][c].min(nodes[1][c]).min(nodes[2][c]) + s[c];
        let hi = nodes[0][c].max(nodes[1][c]).max(nodes[2][c]) + s[c];
        let e = if p[c] < lo {
            lo - p[c]
        } else if p[c] > hi {
            p[c] - hi
        } else {
            0.0
        };
        d2 += e * e;
    }
    d2
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::loose_packing;
    use crate::solver::contact::models::RollingModel;
    use crate::spec::shear::{Preset, ShearCase};

    /// The candidates found through the window of triangles by x are those of testing every
    /// triangle of every mesh at every image, in the same order, with the bottom plate
    /// moved so that its triangles wrapped across the seam; in the preset's box and in one
    /// 4 times longer in z (strips whose bounding radius is 4 times their x window).
    #[test]
    fn windowed_plate_candidates_are_every_triangles_in_order() {
        for long_z in [1.0, 4.0] {
            let mut case =
                ShearCase::preset(Preset::Fast, RollingModel::Epsd, 0.5, 0.5, 1).unwrap();
            case.box_z *= long_z;
            case.particles = (case.particles as f64 * long_z) as usize;
            windowed_candidates_in(&case);
        }
    }

    fn windowed_candidates_in(case: &ShearCase) {
        let pk = loose_packing(case);
        let mut sim = ShearSim::new(&case.setup(), &pk);
        let team = Team::new(2);
        let (lx, lz, skin) = (case.box_x, case.box_z, case.skin);
        for dx in [0.0, 0.37 * lx, 0.91 * lx] {
            sim.meshes[0].translate([dx, 0.0, 0.0]);
            sim.meshes[0].wrap_x(lx);
            sim.build_wall_candidates(&team);
            let (mut want, mut start) = (Vec::new(), vec![0u32]);
            for (p, &r) in sim.x.iter().zip(&sim.radius) {
                for (m, mesh) in sim.meshes.iter().enumerate() {
                    for img in [4u8, 0, 1, 2, 3, 5, 6, 7, 8] {
                        for t in 0..mesh.tris.len() {
                            if is_candidate(mesh, t, p, r, skin, image_shift(img, lx, lz)) {
                                want.push((m as u8, t as u32, img));
                            }
                        }
                    }
                }
                start.push(want.len() as u32);
            }
            assert!(want.len() > 20, "{}", want.len());
            assert_eq!(sim.wall_cand, want);
            assert_eq!(sim.wall_start, start);
        }
    }

    #[test]
    fn box_distance_is_zero_inside_and_a_lower_bound_outside() {
        let nodes = [[0.0, 0.0, 0.0], [1.0, 0.5, 0.0], [1.0, 0.5, 2.0]];
        assert_eq!(box_distance_sq(&[0.5, 0.25, 1.0], &nodes, [0.0; 3]), 0.0);
        // 0.5 beyond x = 1 and 1 below y = 0: squared distance 1.25
        let d2 = box_distance_sq(&[1.5, -1.0, 1.0], &nodes, [0.0; 3]);
        assert!((d2 - 1.25).abs() < 1e-15);
        // shifted by one period in z the same point is 1 away from the box in z
        let d2 = box_distance_sq(&[0.5, 0.25, -1.0], &nodes, [0.0, 0.0, -4.0]);
        assert!((d2 - 1.0).abs() < 1e-15);
        // a lower bound of the distance to every node
        let p = [2.0, 2.0, 3.0];
        let dmin = nodes
            .iter()
            .map(|n| (0..3).map(|c| (p[c] - n[c]).powi(2)).sum::<f64>())
            .fold(f64::INFINITY, f64::min);
        assert!(box_distance_sq(&p, &nodes, [0.0; 3]) <= dmin);
    }
}
