//! Triangle-mesh walls: element geometry as LIGGGHTS' SurfaceMesh computes it
//! (surface_mesh_I.h) and the sphere-triangle contact of tri_mesh_I.h.

use super::vec3::{dot, point_distance, sub, V3};

/// One triangle with the derived quantities LIGGGHTS stores per element.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Triangle {
    pub nodes: [V3; 3],
    /// `edgeVec[i] = (node[i+1] - node[i]) / |...|` (`calcEdgeVecLen`, divided via `1/len`).
    pub edge_vec: [V3; 3],
    pub edge_len: [f64; 3],
    /// `edgeVec[0] x edgeVec[1]`, normalised by `vectorScalarDiv3D` (`calcSurfaceNorm`).
    pub normal: V3,
}

/// Result of the sphere-triangle test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TriContact {
    /// Face contact (LIGGGHTS barySign 7): `d` = centre-to-plane distance, `delta` = vector
    /// from the sphere centre to its projection on the plane (`calcDist`).
    Face { d: f64, delta: V3 },
    /// The closest feature is an edge or a corner, at distance `d` from the centre.
    EdgeOrCorner { d: f64 },
}

fn scalar_div(v: V3, s: f64) -> V3 {
    let sinv = 1.0 / s;
    [sinv * v[0], sinv * v[1], sinv * v[2]]
}

impl Triangle {
    pub fn new(nodes: [V3; 3]) -> Self {
        let mut edge_vec = [[0.0; 3]; 3];
        let mut edge_len = [0.0; 3];
        for i in 0..3 {
            let v = sub(nodes[(i + 1) % 3], nodes[i]);
            edge_len[i] = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            edge_vec[i] = scalar_div(v, edge_len[i]);
        }
        let c = super::vec3::cross(edge_vec[0], edge_vec[1]);
        let normal = scalar_div(c, (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt());
        Triangle {
            nodes,
            edge_vec,
            edge_len,
            normal,
        }
    }

    /// Barycentric coordinates of `p` relative to node 0 (`calcBaryTriCoords`).
    pub fn bary(&self, node0_to_p: V3) -> V3 {
        let a = dot(node0_to_p, self.edge_vec[0]);
        let b = dot(node0_to_p, self.edge_vec[2]);
        let c = dot(self.edge_vec[0], self.edge_vec[2]);
        let one_min_csqr = 1.0 - c * c;
        let b1 = (a - b * c) / (self.edge_len[0] * one_min_csqr);
        let b2 = (a * c - b) / (self.edge_len[2] * one_min_csqr);
        [1.0 - b1 - b2, b1, b2]
    }

    /// Sphere centre `c` against this triangle. Face contacts follow
    /// `resolveFaceContactBary` exactly: `dNorm = n . (c - node0)`, `csPlane = c - n dNorm`,
    /// `delta = csPlane - c`, `d = |c - csPlane|`. For edge/corner features the distance to
    /// the closest point of the triangle is returned (used to detect such contacts).
    pub fn resolve(&self, c: V3) -> TriContact {
        let node0_to_c = sub(c, self.nodes[0]);
        let bary = self.bary(node0_to_c);
        // LIGGGHTS: barySign bit set when bary > -precision/(2 rBound); a strictly positive
        // test is equivalent away from the edges, which is all the contact cases need.
        if bary.iter().all(|b| *b > 0.0) {
            let dnorm = dot(self.normal, node0_to_c);
            let tmp = [
                self.normal[0] * dnorm,
                self.normal[1] * dnorm,
                self.normal[2] * dnorm,
            ];
            let cs_plane = sub(c, tmp);
            let delta = sub(cs_plane, c);
            TriContact::Face {
                d: point_distance(c, cs_plane),
                delta,
            }
        } else {
            let mut d = f64::INFINITY;
            for i in 0..3 {
                let a = self.nodes[i];
                let t = dot(sub(c, a), self.edge_vec[i]).clamp(0.0, self.edge_len[i]);
                let q = [
                    a[0] + t * self.edge_vec[i][0],
                    a[1] + t * self.edge_vec[i][1],
                    a[2] + t * self.edge_vec[i][2],
                ];
                d = d.min(point_distance(c, q));
            }
            TriContact::EdgeOrCorner { d }
        }
    }
}

/// The two triangles of a flat square wall |x|, |y| <= h at height z, normal +z, split along
/// the diagonal x = y; the same triangles the deck writes into the STL file.
pub fn square_wall(z: f64, h: f64) -> [Triangle; 2] {
    [
        Triangle::new([[-h, -h, z], [h, -h, z], [h, h, z]]),
        Triangle::new([[-h, -h, z], [h, h, z], [-h, h, z]]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_wall_normals_point_up() {
        for t in square_wall(0.0, 1.0) {
            assert_eq!(t.normal, [0.0, 0.0, 1.0]);
        }
    }

    #[test]
    fn face_and_edge_classification() {
        let [t1, t2] = square_wall(0.0, 1.0);
        match t1.resolve([0.5, -0.5, 0.1]) {
            TriContact::Face { d, delta } => {
                assert!((d - 0.1).abs() < 1e-15);
                assert!((delta[2] + 0.1).abs() < 1e-15);
            }
            other => panic!("expected face contact, got {other:?}"),
        }
        match t2.resolve([0.5, -0.5, 0.1]) {
            TriContact::EdgeOrCorner { d } => {
                // distance to the diagonal: sqrt(0.1^2 + (1/sqrt 2)^2)
                assert!((d - (0.01f64 + 0.5).sqrt()).abs() < 1e-12, "{d}");
            }
            other => panic!("expected edge contact, got {other:?}"),
        }
    }
}
