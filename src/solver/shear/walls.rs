//! Particle-plate contacts of one particle per step, as fix_wall_gran.cpp `post_force_mesh`
//! with fix_contact_history_mesh does them: per mesh (bottom, then top) mark the particle's
//! contact records, test its candidate triangles (plane, then the barycentric
//! `resolveTriSphereContactBary`), keep or create a record (`handleContact`: a face contact
//! coplanar with a kept one is skipped, a new face record inherits a coplanar neighbour's
//! history), evaluate the contact, and drop the unmarked records (`cleanUpContacts`).
//! `RUST_LOG=trace` prints every particle-triangle contact.

use super::implicit::add_dashpot;
use super::records::{image_shift, WallSlots, MAX_WALL_CONTACTS};
use crate::solver::contact::{surfaces_intersect, ContactData};
use crate::solver::material::PairParams;
use crate::solver::trimesh::{TriContactRecord, TriMesh};
use crate::solver::vec3::V3;

/// What the plate contacts of every particle share in one force evaluation.
pub(super) struct WallContext<'a> {
    pub params: &'a PairParams,
    pub meshes: &'a [TriMesh; 2],
    /// Candidate (mesh, triangle, image) per particle, CSR.
    pub cand: &'a [(u8, u32, u8)],
    pub cstart: &'a [u32],
    pub lx: f64,
    pub lz: f64,
    /// Node velocity of each mesh.
    pub vnode: [V3; 2],
    pub x: &'a [V3],
    pub v: &'a [V3],
    pub omega: &'a [V3],
    pub radius: &'a [f64],
    pub mass: &'a [f64],
    pub implicit: bool,
    pub torsion: bool,
    pub update_history: bool,
    /// Log every contact (`RUST_LOG=trace`; read once per evaluation, not per contact).
    pub trace: bool,
}

impl WallContext<'_> {
    /// Adds particle `q`'s plate contacts to its force `f`, torque `t`, its contributions to
    /// the plate forces `wf` (bottom, top) and its implicit dashpot system `imp`. False when
    /// the particle would hold more than [`MAX_WALL_CONTACTS`] records.
    pub fn particle(
        &self,
        q: usize,
        slots: &mut WallSlots,
        f: &mut V3,
        t: &mut V3,
        wf: &mut (V3, V3),
        imp: &mut ([f64; 6], V3),
    ) -> bool {
        *wf = ([0.0; 3], [0.0; 3]);
        self.evaluate(q, slots, imp, |hit| apply(hit, f, t, wf))
    }

    /// Particle `q`'s plate contacts, each handed to `emit` in the order
    /// [`WallContext::particle`] adds them; its records and implicit dashpot system updated.
    /// A contact's force and torque do not depend on the particle's force sum, so they can
    /// be found before the pair sums are complete and added after ([`apply`]). False when
    /// the particle would hold more than [`MAX_WALL_CONTACTS`] records.
    pub fn evaluate(
        &self,
        q: usize,
        slots: &mut WallSlots,
        imp: &mut ([f64; 6], V3),
        mut emit: impl FnMut(&WallHit),
    ) -> bool {
        let WallContext {
            params,
            meshes,
            cand,
            cstart,
            lx,
            lz,
            vnode,
            x,
            v,
            omega,
            radius,
            mass,
            implicit,
            torsion,
            update_history,
            trace,
        } = *self;
        for m in 0..2u8 {
            // markAllContacts of this mesh
            for r in &mut slots.rec {
                if r.mesh == m {
                    r.keep = false;
                }
            }
            let mesh = &meshes[m as usize];
            for &(cm, tri, img) in &cand[cstart[q] as usize..cstart[q + 1] as usize] {
                if cm != m {
                    continue;
                }
                let shift = image_shift(img, lx, lz);
                // two exact pre-tests before the barycentric test (which divides): about
                // 70 % of the candidates lie within r of the triangle's plane, and two
                // thirds of those then end apart or on an inactive edge (on the fast
                // state, 1,165 candidates per step). Measured (fast state, avx512,
                // alternating every 250 steps in one process, 3 runs each): time per step
                // with the edge pre-test 0.952-0.975x on 1 thread, 0.974-0.986x on 2.
                if mesh.beyond_plane(tri as usize, shift, x[q], radius[q])
                    || mesh.beyond_edges(tri as usize, shift, x[q], radius[q])
                {
                    continue;
                }
                let Some(hit) = mesh.resolve(tri as usize, shift, x[q]) else {
                    continue;
                };
                let deltan = hit.d - radius[q];
                if deltan > 0.0 {
                    continue;
                }
                // handleContact
                let n = slots.rec.len();
                let slot = match (0..n).find(|&i| slots.rec[i].mesh == m && slots.rec[i].tri == tri)
                {
                    Some(i) => {
                        slots.rec[i].keep = true;
                        i
                    }
                    None => {
                        let cop = &mesh.coplanar[tri as usize];
                        if hit.face
                            && (0..n).any(|i| {
                                slots.rec[i].mesh == m
                                    && slots.rec[i].keep
                                    && cop.contains(&slots.rec[i].tri)
                            })
                        {
                            continue;
                        }
                        if n == MAX_WALL_CONTACTS {
                            return false;
                        }
                        let mut rec = TriContactRecord {
                            mesh: m,
                            tri,
                            keep: true,
                            ..Default::default()
                        };
                        if hit.face {
                            for i in 0..n {
                                if slots.rec[i].mesh == m && cop.contains(&slots.rec[i].tri) {
                                    rec.hist = slots.rec[i].hist;
                                }
                            }
                        }
                        slots.rec.push(rec);
                        n
                    }
                };
                let vn = vnode[m as usize];
                let b = hit.bary;
                let vw = [
                    b[0] * vn[0] + b[1] * vn[0] + b[2] * vn[0],
                    b[0] * vn[1] + b[1] * vn[1] + b[2] * vn[1],
                    b[0] * vn[2] + b[1] * vn[2] + b[2] * vn[2],
                ];
                let mut cd =
                    ContactData::wall(radius[q], mass[q], hit.delta, deltan, v[q], vw, omega[q]);
                if trace {
                    log::trace!(
                        "wall p {} mesh {m} tri {tri} img {img} face {} d {:e} cp {:e} {:e} {:e}",
                        q + 1,
                        hit.face,
                        hit.d,
                        x[q][0] + hit.delta[0],
                        x[q][1] + hit.delta[1],
                        x[q][2] + hit.delta[2]
                    );
                }
                let mut hist = slots.rec[slot].hist;
                let (fi, _, o) = surfaces_intersect(&mut cd, params, &mut hist, update_history);
                if implicit && o.implicit_damping != 0.0 {
                    // walls do not rotate; the dashpot acts on wr = cr omega_i / r
                    add_dashpot(
                        imp,
                        o.implicit_damping * cd.cri * cd.rinv,
                        cd.en,
                        torsion,
                        [0.0; 3],
                    );
                }
                slots.rec[slot].hist = hist;
                slots.rec[slot].force = fi.delta_f;
                slots.rec[slot].torque = fi.delta_torque;
                slots.rec[slot].face = hit.face;
                emit(&WallHit {
                    q: q as u32,
                    mesh: m,
                    force: fi.delta_f,
                    torque: fi.delta_torque,
                });
            }
            // cleanUpContacts of this mesh
            slots.rec.retain(|r| r.mesh != m || r.keep);
        }
        true
    }
}

/// One plate contact's force and torque on a particle, from [`WallContext::evaluate`].
#[derive(Clone, Copy, Debug)]
pub(super) struct WallHit {
    pub q: u32,
    /// 0 the bottom plate, 1 the top.
    pub mesh: u8,
    pub force: V3,
    pub torque: V3,
}

/// Adds a plate contact to the particle's force `f` and torque `t`, and its reaction to the
/// plate's share `wf` (bottom, top) as fix_wall_gran does: the reaction is the change of
/// the particle's force, `-(f_after - f_before)`, which rounds with `f`.
#[inline]
pub(super) fn apply(hit: &WallHit, f: &mut V3, t: &mut V3, wf: &mut (V3, V3)) {
    let before = *f;
    for c in 0..3 {
        f[c] += hit.force[c];
        t[c] += hit.torque[c];
    }
    let dest = if hit.mesh == 1 { &mut wf.1 } else { &mut wf.0 };
    for c in 0..3 {
        dest[c] += -(f[c] - before[c]);
    }
}
