//! Plates of the shear box: flat, or a triangle wave of teeth along x (uniform in z), periodic
//! in x. The LIGGGHTS deck builds the same surfaces from triangles ([`plate_triangles`]).
//!
//! Contact features follow LIGGGHTS' mesh semantics (tri_mesh_I.h, fix_contact_history_mesh):
//! - a face contact with a planar strip; its two triangles are coplanar, so LIGGGHTS counts one
//!   contact and copies the history between them (`coplanarContactAlready`,
//!   `checkCoplanarContactHistory`): here one feature per strip;
//! - a convex ridge (tooth tip): the shared edge is active on one triangle only
//!   (`handleSharedEdge`), so one edge contact: one feature per ridge;
//! - concave valleys are reached through the two faces, never as an edge.
//!
//! For a feature at distance `d` from the sphere centre, with `delta` the vector from the
//! centre to the closest point, the wall contact uses LIGGGHTS' quantities:
//! `deltan = d - r`, `sidata.delta = -delta`, `r_c = r - overlap`, `en = -delta / r_c`.

/// Which plate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Side {
    Bottom,
    Top,
}

/// Geometry of one plate at the current time.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plate {
    pub side: Side,
    /// y of the plate's base (valleys of the teeth).
    pub base_y: f64,
    /// Displacement along x of the teeth (bottom plate motion).
    pub offset_x: f64,
    pub tooth_height: f64,
    /// Tooth period along x (box_x for flat plates: one face).
    pub wavelength: f64,
    pub n_teeth: usize,
    pub box_x: f64,
}

/// One touching plate feature of a sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureContact {
    /// Stable id: `((side * n_teeth) + tooth) * 3 + kind` (kind 0 rising face, 1 falling
    /// face, 2 ridge; flat plates: one face, kind 0).
    pub id: u32,
    /// Distance from the centre to the closest point.
    pub d: f64,
    /// Vector from the centre to the closest point (z component 0).
    pub delta: [f64; 3],
}

/// The shape both plates share: a triangle wave of teeth along x, or flat (no height, one
/// face over the box).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlateShape {
    /// Tooth height [m] (0: flat).
    pub tooth_height: f64,
    /// Tooth period along x [m] (box_x for flat plates).
    pub wavelength: f64,
}

impl PlateShape {
    /// A flat plate over a box of length `box_x`.
    pub fn flat(box_x: f64) -> Self {
        PlateShape {
            tooth_height: 0.0,
            wavelength: box_x,
        }
    }
}

impl Plate {
    pub fn new(side: Side, base_y: f64, shape: PlateShape, box_x: f64) -> Self {
        Plate {
            side,
            base_y,
            offset_x: 0.0,
            tooth_height: shape.tooth_height,
            wavelength: shape.wavelength,
            n_teeth: (box_x / shape.wavelength).round() as usize,
            box_x,
        }
    }

    /// y of the tooth tips.
    pub fn tip_y(&self) -> f64 {
        match self.side {
            Side::Bottom => self.base_y + self.tooth_height,
            Side::Top => self.base_y - self.tooth_height,
        }
    }

    /// The features of this plate touching a sphere (centre `p`, radius `r`); at most 4.
    pub fn contacts(&self, p: [f64; 3], r: f64, out: &mut Vec<FeatureContact>) {
        let side = match self.side {
            Side::Bottom => 0u32,
            Side::Top => 1u32,
        };
        let sign = if self.side == Side::Bottom { 1.0 } else { -1.0 };
        if self.tooth_height == 0.0 {
            let d = sign * (p[1] - self.base_y);
            if d < r {
                out.push(FeatureContact {
                    id: side * 3,
                    d: d.abs(),
                    delta: [0.0, self.base_y - p[1], 0.0],
                });
            }
            return;
        }
        let lx = self.box_x;
        let w = self.wavelength;
        let xi = (p[0] - self.offset_x).rem_euclid(lx);
        let k0 = (xi / w).floor() as i64;
        let n = self.n_teeth as i64;
        for dk in [-1i64, 0, 1] {
            let k = k0 + dk;
            let local = xi - k as f64 * w; // particle x relative to this tooth's start
            let tooth = k.rem_euclid(n) as u32;
            let a = [0.0, self.base_y];
            let b = [0.5 * w, self.base_y + sign * self.tooth_height];
            let c = [w, self.base_y];
            let q = [local, p[1]];
            let (t1, d1, c1) = segment(a, b, q);
            let (t2, d2, c2) = segment(b, c, q);
            let base = (side * self.n_teeth as u32 + tooth) * 3;
            let to3 = |cp: [f64; 2]| [cp[0] - local, cp[1] - p[1], 0.0];
            if t1 > 0.0 && t1 < 1.0 && d1 < r {
                out.push(FeatureContact {
                    id: base,
                    d: d1,
                    delta: to3(c1),
                });
            }
            if t2 > 0.0 && t2 < 1.0 && d2 < r {
                out.push(FeatureContact {
                    id: base + 1,
                    d: d2,
                    delta: to3(c2),
                });
            }
            if t1 >= 1.0 && t2 <= 0.0 {
                let dr = ((q[0] - b[0]).powi(2) + (q[1] - b[1]).powi(2)).sqrt();
                if dr < r {
                    out.push(FeatureContact {
                        id: base + 2,
                        d: dr,
                        delta: to3(b),
                    });
                }
            }
        }
    }
}

/// Projection of q on segment a-b: (parameter t, distance to the closest point of the line,
/// closest point of the line).
fn segment(a: [f64; 2], b: [f64; 2], q: [f64; 2]) -> (f64, f64, [f64; 2]) {
    let e = [b[0] - a[0], b[1] - a[1]];
    let len2 = e[0] * e[0] + e[1] * e[1];
    let t = ((q[0] - a[0]) * e[0] + (q[1] - a[1]) * e[1]) / len2;
    let c = [a[0] + t * e[0], a[1] + t * e[1]];
    let d = ((q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2)).sqrt();
    (t, d, c)
}

/// The triangles of a plate spanning [0, box_x] x [0, box_z] (two per face strip), as written
/// into the STL files.
pub fn plate_triangles(plate: &Plate, box_z: f64) -> Vec<[[f64; 3]; 3]> {
    let mut tris = Vec::new();
    let sign = if plate.side == Side::Bottom {
        1.0
    } else {
        -1.0
    };
    let y0 = plate.base_y;
    let mut strip = |x0: f64, y0s: f64, x1: f64, y1s: f64| {
        tris.push([[x0, y0s, 0.0], [x1, y1s, 0.0], [x1, y1s, box_z]]);
        tris.push([[x0, y0s, 0.0], [x1, y1s, box_z], [x0, y0s, box_z]]);
    };
    if plate.tooth_height == 0.0 {
        strip(0.0, y0, plate.box_x, y0);
    } else {
        let w = plate.wavelength;
        let tip = y0 + sign * plate.tooth_height;
        for k in 0..plate.n_teeth {
            let x = k as f64 * w;
            strip(x, y0, x + 0.5 * w, tip);
            strip(x + 0.5 * w, tip, x + w, y0);
        }
    }
    tris
}

#[cfg(test)]
mod tests {
    use super::*;

    fn teeth() -> PlateShape {
        PlateShape {
            tooth_height: 0.2,
            wavelength: 1.0,
        }
    }

    #[test]
    fn sphere_on_a_face_touches_one_feature() {
        let p = Plate::new(Side::Bottom, 0.0, teeth(), 4.0);
        let mut out = Vec::new();
        // above the middle of the rising face of tooth 1 (x in [1, 1.5]), close to it
        p.contacts([1.25, 0.1 + 0.05, 0.3], 0.06, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(out[0].id, 3);
        assert!(out[0].delta[1] < 0.0);
    }

    #[test]
    fn sphere_above_a_tip_touches_the_ridge_and_in_a_valley_two_faces() {
        let p = Plate::new(Side::Bottom, 0.0, teeth(), 4.0);
        let mut out = Vec::new();
        p.contacts([2.5, 0.25, 0.0], 0.1, &mut out);
        assert_eq!(out.iter().map(|c| c.id % 3).collect::<Vec<_>>(), vec![2]);
        out.clear();
        // in the valley at x = 3 (between tooth 2 and tooth 3), just above
        p.contacts([3.0, 0.1, 0.0], 0.1, &mut out);
        assert_eq!(out.len(), 2, "{out:?}");
        // periodic: x = 4 - 1e-9 is the same valley as x = 0
        out.clear();
        p.contacts([4.0 - 1e-9, 0.1, 0.0], 0.1, &mut out);
        assert_eq!(out.len(), 2, "{out:?}");
    }

    #[test]
    fn offset_moves_the_teeth_and_top_plate_points_down() {
        let mut p = Plate::new(Side::Bottom, 0.0, teeth(), 4.0);
        p.offset_x = 0.5;
        let mut out = Vec::new();
        p.contacts([1.0, 0.25, 0.0], 0.1, &mut out); // tip now at x = 1.0
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].id % 3, 2);
        let t = Plate::new(Side::Top, 1.0, teeth(), 4.0);
        out.clear();
        t.contacts([0.5, 0.75, 0.0], 0.1, &mut out);
        assert_eq!(out.len(), 1);
        assert!(out[0].delta[1] > 0.0);
        assert_eq!(plate_triangles(&t, 1.0).len(), 16);
    }
}
