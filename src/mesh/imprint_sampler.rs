//! Values of the cracked mesh sampled at points of the same surface: the
//! closest face's interpolated value, or the crack side facing a
//! direction.

use super::value;
use crate::mesh::halfedge::SimMesh;
use crate::mesh::ids::{FaceId, HalfedgeId, VertexId};
use crate::mesh::spatial::{
    add, bbox, closest_on_segment, closest_on_triangle, dist2, dot, norm, scale, sub, Grid,
};

/// Values of the cracked mesh at points of the same surface.
pub(super) struct Sampler<'a> {
    mesh: &'a SimMesh,
    faces: Grid,
    /// The crack halfedges (both sides of every crack edge).
    cracks: Vec<HalfedgeId>,
    crack_grid: Option<Grid>,
    cell: f64,
}

impl<'a> Sampler<'a> {
    pub(super) fn new(mesh: &'a SimMesh) -> Sampler<'a> {
        let cell = mesh.mean_edge_length().max(1e-12);
        let faces = Grid::new(
            mesh.faces()
                .map(|f| bbox(&mesh.face_vertices(f).map(|v| mesh.position(v)))),
            cell,
        );
        let cracks: Vec<HalfedgeId> = mesh
            .halfedges()
            .filter(|&h| mesh.is_crack_halfedge(h) && mesh.twin(h).is_none())
            .collect();
        let crack_grid = (!cracks.is_empty()).then(|| {
            Grid::new(
                cracks
                    .iter()
                    .map(|&h| bbox(&[mesh.position(mesh.origin(h)), mesh.position(mesh.dest(h))])),
                cell,
            )
        });
        Sampler {
            mesh,
            faces,
            cracks,
            crack_grid,
            cell,
        }
    }

    /// `values` (per vertex) interpolated at the closest point of `p`.
    pub(super) fn face_value(&self, p: [f64; 3], values: &[[f64; 3]]) -> [f64; 3] {
        let mut best: Option<(f64, usize, [f64; 3])> = None;
        self.faces.search(p, |f| {
            let t = self
                .mesh
                .face_vertices(FaceId(f as u32))
                .map(|v| self.mesh.position(v));
            let (q, bary) = closest_on_triangle(p, t);
            let d = dist2(p, q);
            if best.is_none_or(|b| d < b.0 || (d == b.0 && f < b.1)) {
                best = Some((d, f, bary));
            }
            best.map(|b| b.0)
        });
        let Some((_, f, bary)) = best else {
            return [0.0; 3];
        };
        let vs = self.mesh.face_vertices(FaceId(f as u32));
        (0..3).fold([0.0; 3], |s, k| {
            add(s, scale(value(values, vs[k].idx()), bary[k]))
        })
    }

    /// The crack side at `p` facing `dir`: the ends of the closest crack
    /// halfedge whose face lies most towards `dir`, and `p`'s parameter
    /// along it.
    pub(super) fn crack_side(&self, p: [f64; 3], dir: [f64; 3]) -> Option<([VertexId; 2], f64)> {
        let grid = self.crack_grid.as_ref()?;
        let mut near: Vec<(f64, usize)> = Vec::new();
        let mut best = f64::INFINITY;
        grid.search(p, |i| {
            let h = self.cracks[i];
            let (a, b) = (
                self.mesh.position(self.mesh.origin(h)),
                self.mesh.position(self.mesh.dest(h)),
            );
            let d = dist2(p, closest_on_segment(p, a, b));
            best = best.min(d);
            near.push((d, i));
            Some(best)
        });
        // Every halfedge within a hair of the closest distance: the sides
        // of the closest crack edge (and, at a junction, of its
        // neighbours).
        let tol = best * (1.0 + 1e-6) + 1e-12 * self.cell * self.cell;
        near.sort_by_key(|x| x.1);
        near.dedup_by_key(|x| x.1);
        let mut pick: Option<(f64, usize)> = None;
        for &(d, i) in &near {
            if d > tol {
                continue;
            }
            let h = self.cracks[i];
            let a = self.mesh.position(self.mesh.origin(h));
            let b = self.mesh.position(self.mesh.dest(h));
            let c = self.mesh.position(self.mesh.dest(self.mesh.next(h)));
            // Into the face, perpendicular to the edge.
            let e = sub(b, a);
            let ee = dot(e, e);
            if ee <= 0.0 {
                continue;
            }
            let ac = sub(c, a);
            let inward = sub(ac, scale(e, dot(ac, e) / ee));
            let li = norm(inward);
            if li <= 0.0 {
                continue;
            }
            let s = dot(inward, dir) / li;
            if pick.is_none_or(|(ps, _)| s > ps) {
                pick = Some((s, i));
            }
        }
        let (_, i) = pick?;
        let h = self.cracks[i];
        let (va, vb) = (self.mesh.origin(h), self.mesh.dest(h));
        let (a, b) = (self.mesh.position(va), self.mesh.position(vb));
        let e = sub(b, a);
        let ee = dot(e, e);
        let t = if ee > 0.0 {
            (dot(sub(p, a), e) / ee).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Some(([va, vb], t))
    }
}
