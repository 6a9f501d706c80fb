//! Triangle meshes with LIGGGHTS' contact semantics (surface_mesh_I.h, tri_mesh_I.h,
//! fix_contact_history_mesh_I.h), for walls in a box periodic in x and z.
//!
//! - Topology (`handleSharedEdge`, `handleCorner`): triangles sharing an edge are neighbours;
//!   the shared edge of non-coplanar neighbours is active on the one with the higher id only,
//!   of coplanar ones on neither. A corner is inactive if two of the edges meeting there are
//!   colinear (with different end points) or none of them is active; otherwise active on the
//!   triangle with the highest id. Periodic images count as neighbours for edges and corners
//!   alike (LIGGGHTS builds the topology with its ghost elements: a flat periodic plate shows
//!   no extra contact at its seams, and a ridge ending on a seam has no active corner there;
//!   both checked against LIGGGHTS).
//! - Contact (`resolveTriSphereContactBary`): barycentric signs select face (all positive),
//!   edge or corner; an inactive edge/corner gives no contact. Triangles must have no obtuse
//!   angle (the obtuse-corner branch is not mirrored; checked at construction).
//! - Bookkeeping (`handleContact`): a contact with a triangle it touched last step keeps its
//!   history; a new *face* contact is skipped if a coplanar node-neighbour already has a contact
//!   this step, else it starts with the history of a coplanar node-neighbour's contact, if any.

use super::mesh::Triangle;
use super::vec3::{cross, dot, point_distance, sub, V3};

/// `EPSILON_CURVATURE`: normals with |n_a . n_b| > 1 - 1e-5 are coplanar.
pub const CURVATURE: f64 = 1.0 - 0.00001;
/// `EPSILON_PRECISION` of meshes [m].
pub const PRECISION: f64 = 1e-8;
const SMALL_TRIMESH: f64 = 1e-10;

/// What a sphere-triangle test found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit {
    /// Distance from the centre to the closest point of the feature.
    pub d: f64,
    /// Closest point minus centre (`calcDist`).
    pub delta: V3,
    pub bary: V3,
    /// Face contact (LIGGGHTS barySign 7).
    pub face: bool,
}

/// A mesh with its topology flags. Triangle ids are their indices (STL order).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct TriMesh {
    pub tris: Vec<Triangle>,
    pub edge_active: Vec<[bool; 3]>,
    pub corner_active: Vec<[bool; 3]>,
    /// Bounding-sphere radius and centre of each triangle (`rBound`, `center`).
    pub r_bound: Vec<f64>,
    pub center: Vec<V3>,
    /// `coplanar[i]` lists the triangles that share a node with i (periodic images included)
    /// and are coplanar with it (`areCoplanarNodeNeighs`).
    pub coplanar: Vec<Vec<u32>>,
}

fn same_point(a: V3, b: V3, tol: f64) -> bool {
    (a[0] - b[0]).abs() <= tol && (a[1] - b[1]).abs() <= tol && (a[2] - b[2]).abs() <= tol
}

fn shifted(p: V3, s: V3) -> V3 {
    [p[0] + s[0], p[1] + s[1], p[2] + s[2]]
}

impl TriMesh {
    /// Builds the mesh and its topology for a box periodic in x (`lx`) and z (`lz`) whose
    /// lower corner is `lo` and upper corner `hi`.
    pub fn new(nodes: &[[V3; 3]], lo: V3, hi: V3) -> Self {
        let tris: Vec<Triangle> = nodes.iter().map(|n| Triangle::new(*n)).collect();
        for t in &tris {
            for i in 0..3 {
                // the angle at node i is obtuse when the edge arriving there and the edge leaving
                // it point the same way
                assert!(
                    dot(t.edge_vec[i], t.edge_vec[(i + 2) % 3]) <= 1e-12,
                    "obtuse triangles are not supported"
                );
            }
        }
        let n = tris.len();
        let (lx, lz) = (hi[0] - lo[0], hi[2] - lo[2]);
        let shifts: Vec<V3> = [-1.0, 0.0, 1.0]
            .iter()
            .flat_map(|sx| [-1.0, 0.0, 1.0].map(|sz| [sx * lx, 0.0, sz * lz]))
            .collect();
        let tol = PRECISION;
        let mut edge_active = vec![[true; 3]; n];
        let mut neighbors: Vec<Vec<usize>> = vec![Vec::new(); n];
        for i in 0..n {
            for j in (i + 1)..n {
                for s in &shifts {
                    for ie in 0..3 {
                        let (a0, a1) = (tris[i].nodes[ie], tris[i].nodes[(ie + 1) % 3]);
                        for je in 0..3 {
                            let (b0, b1) = (
                                shifted(tris[j].nodes[je], *s),
                                shifted(tris[j].nodes[(je + 1) % 3], *s),
                            );
                            let shared = (same_point(a0, b0, tol) && same_point(a1, b1, tol))
                                || (same_point(a0, b1, tol) && same_point(a1, b0, tol));
                            if !shared {
                                continue;
                            }
                            if !neighbors[i].contains(&j) {
                                neighbors[i].push(j);
                                neighbors[j].push(i);
                            }
                            let coplanar = dot(tris[i].normal, tris[j].normal).abs() >= CURVATURE;
                            let overlap = coplanar && {
                                // third nodes on the same side of the shared edge
                                let en = super::vec3::cross(tris[i].edge_vec[ie], tris[i].normal);
                                let vi = sub(tris[i].nodes[(ie + 2) % 3], a0);
                                let vj = sub(shifted(tris[j].nodes[(je + 2) % 3], *s), a0);
                                dot(vi, en) * dot(vj, en) > 0.0
                            };
                            if !coplanar || overlap {
                                // ids are indices and i < j: the edge stays active on j
                                edge_active[i][ie] = false;
                                edge_active[j][je] = true;
                            } else {
                                edge_active[i][ie] = false;
                                edge_active[j][je] = false;
                            }
                        }
                    }
                }
            }
        }
        let mut corner_active = vec![[true; 3]; n];
        for i in 0..n {
            for k in 0..3 {
                let node = tris[i].nodes[k];
                let mut edges: Vec<(V3, V3)> = Vec::new();
                let mut any_active = false;
                let mut max_id = 0;
                for (j, t) in tris.iter().enumerate() {
                    for s in &shifts {
                        for m in 0..3 {
                            if same_point(shifted(t.nodes[m], *s), node, tol) {
                                max_id = max_id.max(j);
                                edges.push((t.edge_vec[m], shifted(t.nodes[(m + 1) % 3], *s)));
                                edges.push((
                                    t.edge_vec[(m + 2) % 3],
                                    shifted(t.nodes[(m + 2) % 3], *s),
                                ));
                                any_active |= edge_active[j][m] || edge_active[j][(m + 2) % 3];
                            }
                        }
                    }
                }
                let mut colinear = false;
                for a in 0..edges.len() {
                    for b in (a + 1)..edges.len() {
                        if dot(edges[a].0, edges[b].0).abs() > CURVATURE
                            && !same_point(edges[a].1, edges[b].1, tol)
                        {
                            colinear = true;
                        }
                    }
                }
                corner_active[i][k] = !colinear && any_active && i == max_id;
            }
        }
        let center: Vec<V3> = tris
            .iter()
            .map(|t| {
                let mut c = [0.0; 3];
                for nd in &t.nodes {
                    for d in 0..3 {
                        c[d] += nd[d];
                    }
                }
                let inv = 1.0 / 3.0;
                [inv * c[0], inv * c[1], inv * c[2]]
            })
            .collect();
        let r_bound = tris
            .iter()
            .zip(&center)
            .map(|(t, c)| {
                t.nodes
                    .iter()
                    .map(|nd| point_distance(*nd, *c))
                    .fold(0.0, f64::max)
            })
            .collect();
        let mut coplanar = vec![Vec::new(); n];
        for i in 0..n {
            for j in 0..n {
                if i == j || dot(tris[i].normal, tris[j].normal).abs() <= CURVATURE {
                    continue;
                }
                let share = shifts.iter().any(|s| {
                    tris[i].nodes.iter().any(|a| {
                        tris[j]
                            .nodes
                            .iter()
                            .any(|b| same_point(*a, shifted(*b, *s), tol))
                    })
                });
                if share {
                    coplanar[i].push(j as u32);
                }
            }
        }
        TriMesh {
            tris,
            edge_active,
            corner_active,
            r_bound,
            center,
            coplanar,
        }
    }

    /// Recomputes every triangle's edge vectors, edge lengths and normal from its current
    /// nodes, as LIGGGHTS does at every rebuild and setup (`refreshOwned` ->
    /// `recalcLocalSurfProperties`: `calcEdgeVecLen`, `calcSurfaceNorm`). A moving mesh's
    /// nodes carry the rounding of their motion, so these differ in the last bits from the
    /// values computed from the STL nodes; centres and bounding radii are kept (recomputed
    /// only for deforming meshes).
    pub fn refresh_surface_properties(&mut self) {
        for t in &mut self.tris {
            *t = Triangle::new(t.nodes);
        }
    }

    /// Translates every triangle by `d` (LIGGGHTS `move`: nodes and centres incremented).
    pub fn translate(&mut self, d: V3) {
        for (t, c) in self.tris.iter_mut().zip(self.center.iter_mut()) {
            for nd in &mut t.nodes {
                for k in 0..3 {
                    nd[k] += d[k];
                }
            }
            for k in 0..3 {
                c[k] += d[k];
            }
        }
    }

    /// Places every triangle at `orig + d` and recomputes centres as LIGGGHTS' `move(total,
    /// incremental)` does (servo-controlled meshes).
    pub fn place(&mut self, orig: &[[V3; 3]], d: V3) {
        for ((t, c), o) in self.tris.iter_mut().zip(self.center.iter_mut()).zip(orig) {
            *c = [0.0; 3];
            for j in 0..3 {
                for k in 0..3 {
                    t.nodes[j][k] = o[j][k] + d[k];
                    c[k] += t.nodes[j][k];
                }
            }
            let inv = 1.0 / 3.0;
            *c = [inv * c[0], inv * c[1], inv * c[2]];
        }
    }

    /// Moves elements whose centre left [0, lx) back by one period (LIGGGHTS `pbc()` of
    /// meshes: `delta = remap(center) - center`, applied if |delta|^2 > 1e-9).
    pub fn wrap_x(&mut self, lx: f64) {
        for (t, c) in self.tris.iter_mut().zip(self.center.iter_mut()) {
            let mut cn = *c;
            if cn[0] < 0.0 {
                cn[0] += lx;
            } else if cn[0] >= lx {
                cn[0] -= lx;
            }
            let d = [cn[0] - c[0], 0.0, 0.0];
            if d[0] * d[0] > 1e-9 {
                for nd in &mut t.nodes {
                    nd[0] += d[0];
                }
                c[0] += d[0];
            }
        }
    }

    /// Whether a sphere (centre `p`, radius `r`) is certainly out of contact with triangle `t`
    /// at image shift `s` because its distance to the triangle's plane exceeds `r` (with a
    /// relative margin of 1e-9, far above round-off): the distance [`Self::resolve`] finds is
    /// never smaller than the plane distance, so such a sphere would get `d - r > 0` there and
    /// no contact. A cheap exact pre-test (one dot product instead of barycentrics).
    pub fn beyond_plane(&self, t: usize, s: V3, p: V3, r: f64) -> bool {
        let tri = &self.tris[t];
        let node0_to_p = sub(p, shifted(tri.nodes[0], s));
        dot(tri.normal, node0_to_p).abs() > r * (1.0 + 1e-9)
    }

    /// Whether a sphere (centre `p`, radius `r`) is certainly out of contact with triangle `t`
    /// at image shift `s` because its centre lies more than `r` outside one of the
    /// triangle's edges, in the triangle's plane: every point of the triangle is then
    /// farther than `r`. The distance [`Self::resolve`] finds is never smaller than the
    /// distance to the triangle, except that a centre whose projection lies outside an edge
    /// by less than about [`PRECISION`] still counts as a face contact (its barycentric
    /// tolerance): the margin, `2 PRECISION` and 1e-9 relative, covers that and the
    /// rounding of the edge normal. Such a sphere would get `d - r > 0` there (or an
    /// inactive feature) and no contact. No division, unlike `resolve`.
    pub fn beyond_edges(&self, t: usize, s: V3, p: V3, r: f64) -> bool {
        let tri = &self.tris[t];
        let lim = r * (1.0 + 1e-9) + 2.0 * PRECISION;
        (0..3).any(|k| {
            // in-plane outward normal of edge k (from node k to node k+1): e_k x n for the
            // normal e_0 x e_1 (`calcSurfaceNorm`)
            let out = cross(tri.edge_vec[k], tri.normal);
            dot(sub(p, shifted(tri.nodes[k], s)), out) > lim
        })
    }

    /// Sphere (centre `p`, radius `r`) against triangle `t` seen at image shift `s`:
    /// `resolveTriSphereContactBary` for non-obtuse triangles. None when the closest feature
    /// is an inactive edge or corner.
    pub fn resolve(&self, t: usize, s: V3, p: V3) -> Option<TriHit> {
        let tri = &self.tris[t];
        let nodes = [
            shifted(tri.nodes[0], s),
            shifted(tri.nodes[1], s),
            shifted(tri.nodes[2], s),
        ];
        let node0_to_p = sub(p, nodes[0]);
        let bary = tri.bary(node0_to_p);
        let invlen = 1.0 / (2.0 * self.r_bound[t]);
        let lim = -PRECISION * invlen;
        let sign = (bary[0] > lim) as u8 + 2 * (bary[1] > lim) as u8 + 4 * (bary[2] > lim) as u8;
        let corner = |k: usize| -> Option<TriHit> {
            if !self.corner_active[t][k] {
                return None;
            }
            let mut b = [0.0; 3];
            b[k] = 1.0;
            Some(TriHit {
                d: point_distance(p, nodes[k]),
                delta: sub(nodes[k], p),
                bary: b,
                face: false,
            })
        };
        let edge = |ie: usize| -> Option<TriHit> {
            let (ip, ipp) = ((ie + 1) % 3, (ie + 2) % 3);
            let node_to_p = sub(p, nodes[ie]);
            let dist = dot(node_to_p, tri.edge_vec[ie]);
            if dist < -SMALL_TRIMESH {
                corner(ie)
            } else if dist > tri.edge_len[ie] + SMALL_TRIMESH {
                corner(ip)
            } else {
                if !self.edge_active[t][ie] {
                    return None;
                }
                let ev = tri.edge_vec[ie];
                let cp = [
                    nodes[ie][0] + dist * ev[0],
                    nodes[ie][1] + dist * ev[1],
                    nodes[ie][2] + dist * ev[2],
                ];
                let mut b = [0.0; 3];
                b[ipp] = 0.0;
                b[ie] = 1.0 - dist / tri.edge_len[ie];
                b[ip] = 1.0 - b[ie];
                Some(TriHit {
                    d: point_distance(p, cp),
                    delta: sub(cp, p),
                    bary: b,
                    face: false,
                })
            }
        };
        match sign {
            1 => corner(0),
            2 => corner(1),
            3 => edge(0),
            4 => corner(2),
            5 => edge(2),
            6 => edge(1),
            7 => {
                let n = tri.normal;
                let dnorm = dot(n, node0_to_p);
                let tmp = [n[0] * dnorm, n[1] * dnorm, n[2] * dnorm];
                let cs = sub(p, tmp);
                Some(TriHit {
                    d: point_distance(p, cs),
                    delta: sub(cs, p),
                    bary,
                    face: true,
                })
            }
            _ => None,
        }
    }
}

/// One contact record of a particle with a mesh triangle (fix_contact_history_mesh).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TriContactRecord {
    pub mesh: u8,
    pub tri: u32,
    pub keep: bool,
    pub hist: super::contact::ContactHistory,
    /// Force and torque of the last evaluation on the particle, and whether it was a face
    /// contact (observers only: the replay compares them with LIGGGHTS' wall/gran/local).
    pub force: [f64; 3],
    pub torque: [f64; 3],
    pub face: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(lx: f64, lz: f64) -> TriMesh {
        let t = vec![
            [[0.0, 0.0, 0.0], [lx, 0.0, 0.0], [lx, 0.0, lz]],
            [[0.0, 0.0, 0.0], [lx, 0.0, lz], [0.0, 0.0, lz]],
        ];
        TriMesh::new(&t, [0.0, -1.0, 0.0], [lx, 1.0, lz])
    }

    #[test]
    fn flat_periodic_plate_has_no_active_edges_or_corners() {
        let m = flat(2.0, 1.5);
        assert_eq!(m.edge_active, vec![[false; 3]; 2]);
        // every node has colinear edges through the periodic images
        assert_eq!(m.corner_active, vec![[false; 3]; 2]);
        assert_eq!(m.coplanar, vec![vec![1], vec![0]]);
        // a sphere anywhere above finds exactly one face among the triangles and images
        let p = [1.0, 0.05, 1e-6];
        let mut hits = 0;
        for t in 0..2 {
            for s in [[0.0, 0.0, 0.0], [0.0, 0.0, -1.5], [0.0, 0.0, 1.5]] {
                if let Some(h) = m.resolve(t, s, p) {
                    if h.d < 0.1 {
                        hits += 1;
                        assert!(h.face);
                    }
                }
            }
        }
        assert_eq!(hits, 1);
    }

    /// A tent in a 2 x 1 periodic box: two strips of two triangles meeting at a ridge along z
    /// at x = 1, height h = 0.5. Returns the mesh and h.
    fn tent() -> (TriMesh, f64) {
        let (lx, lz, h) = (2.0, 1.0, 0.5);
        let strip = |x0: f64, y0: f64, x1: f64, y1: f64| {
            vec![
                [[x0, y0, 0.0], [x1, y1, 0.0], [x1, y1, lz]],
                [[x0, y0, 0.0], [x1, y1, lz], [x0, y0, lz]],
            ]
        };
        let mut t = strip(0.0, 0.0, 1.0, h);
        t.extend(strip(1.0, h, 2.0, 0.0));
        (TriMesh::new(&t, [0.0, -1.0, 0.0], [lx, 1.0, lz]), h)
    }

    #[test]
    fn ridge_edge_is_active_on_one_triangle() {
        let (m, h) = tent();
        let ridge: usize = m.edge_active.iter().flatten().filter(|a| **a).count();
        // the ridge (once) and the valley at the periodic seam x = 0 = 2 (once)
        assert_eq!(ridge, 2, "{:?}", m.edge_active);
        // above the ridge: one edge contact
        let p = [1.0, h + 0.1, 0.5];
        let hits: Vec<TriHit> = (0..4)
            .filter_map(|k| m.resolve(k, [0.0; 3], p))
            .filter(|h| h.d < 0.2)
            .collect();
        assert_eq!(hits.len(), 1, "{hits:?}");
        assert!(!hits[0].face);
        assert!((hits[0].d - 0.1).abs() < 1e-12);
    }

    /// The plane pre-test never rejects a sphere that `resolve` finds touching: over a grid of
    /// centres around a tent (faces, ridge, valley, images), `beyond_plane` implies no contact.
    #[test]
    fn plane_and_edge_pretests_never_drop_a_contact() {
        let (m, _) = tent();
        let (lx, lz) = (2.0, 1.0);
        let (mut rejected, mut by_edges, mut touching) = (0, 0, 0);
        for ix in 0..41 {
            for iy in 0..21 {
                for iz in 0..5 {
                    let p = [
                        -0.5 + 3.0 * ix as f64 / 40.0,
                        -0.2 + 1.2 * iy as f64 / 20.0,
                        -0.3 + 1.6 * iz as f64 / 4.0,
                    ];
                    for r in [0.05, 0.2] {
                        for tri in 0..4 {
                            for s in [[0.0; 3], [lx, 0.0, 0.0], [0.0, 0.0, -lz]] {
                                let hit = m.resolve(tri, s, p).filter(|h| h.d - r <= 0.0);
                                touching += hit.is_some() as usize;
                                if m.beyond_plane(tri, s, p, r) {
                                    rejected += 1;
                                    assert!(hit.is_none(), "{p:?} r {r} tri {tri} {hit:?}");
                                } else if m.beyond_edges(tri, s, p, r) {
                                    by_edges += 1;
                                    assert!(hit.is_none(), "{p:?} r {r} tri {tri} {hit:?}");
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(
            rejected > 1000 && by_edges > 1000 && touching > 100,
            "{rejected} {by_edges} {touching}"
        );
    }

    #[test]
    fn edge_pretest_keeps_the_face_contacts_of_the_barycentric_tolerance() {
        // centres whose projection lies just outside an edge (within the PRECISION the
        // barycentric signs allow) touch the face; the pre-test must keep them
        let (m, h) = tent();
        let (mut kept, mut faces) = (0, 0);
        for k in 0..=20 {
            let x = 0.05 + 0.9 * k as f64 / 20.0;
            // triangle 0's edge 0 runs along z = 0 from (0, 0) to (1, h): a centre above
            // the face at z slightly below 0
            for dz in [-0.9 * PRECISION, -0.4 * PRECISION, 0.0, 1e-12] {
                let on = [x, x * h, dz];
                let n = m.tris[0].normal;
                let r = 0.01;
                let p = [
                    on[0] + 0.5 * r * n[0],
                    on[1] + 0.5 * r * n[1],
                    on[2] + 0.5 * r * n[2],
                ];
                let hit = m.resolve(0, [0.0; 3], p).filter(|h| h.d - r <= 0.0);
                faces += hit.is_some_and(|h| h.face) as usize;
                if hit.is_some() {
                    assert!(!m.beyond_edges(0, [0.0; 3], p, r), "{p:?} {hit:?}");
                    kept += 1;
                }
            }
        }
        assert!(kept > 40 && faces > 40, "{kept} {faces}");
    }
}
