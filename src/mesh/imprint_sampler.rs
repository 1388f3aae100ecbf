//! Values of the cracked mesh sampled at points of the same surface: the
//! closest face's interpolated value, or the face of the crack side facing
//! a direction; and so carried over to each vertex of the cut mesh.

use super::value;
use crate::mesh::halfedge::SimMesh;
use crate::mesh::ids::{FaceId, HalfedgeId, VertexId};
use crate::mesh::spatial::{
    add, bbox, closest_on_segment, closest_on_triangle, dist2, dot, norm, scale, sub, Grid,
};

/// How much farther than the closest crack side (in mean edge lengths of
/// the cracked mesh) [`Sampler::crack_side_along`] still considers a side:
/// the cut's crack lies within the snapping distance of the simulated one.
const SIDE_REACH: f64 = 0.03;

/// How far (in mean edge lengths of the cracked mesh) from a crack vertex
/// [`Sampler::crack_side`] looks for its side's face.
const SIDE_STEP: f64 = 0.01;

/// Values of the cracked mesh at points of the same surface.
pub(super) struct Sampler<'a> {
    mesh: &'a SimMesh,
    faces: Grid,
    /// The crack sides (halfedges without a twin on a crack).
    sides: Vec<HalfedgeId>,
    side_grid: Option<Grid>,
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
        let sides: Vec<HalfedgeId> = mesh
            .halfedges()
            .filter(|&h| mesh.is_crack_halfedge(h) && mesh.twin(h).is_none())
            .collect();
        let side_grid = (!sides.is_empty()).then(|| {
            Grid::new(
                sides
                    .iter()
                    .map(|&h| bbox(&[mesh.position(mesh.origin(h)), mesh.position(mesh.dest(h))])),
                cell,
            )
        });
        Sampler {
            mesh,
            faces,
            sides,
            side_grid,
            cell,
        }
    }

    /// The face closest to `p` (the first by index on a tie) and the
    /// barycentric coordinates of its closest point.
    fn closest(&self, p: [f64; 3]) -> Option<(FaceId, [f64; 3])> {
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
        best.map(|(_, f, bary)| (FaceId(f as u32), bary))
    }

    /// `values` (per vertex) interpolated at the closest point of `p`.
    pub(super) fn face_value(&self, p: [f64; 3], values: &[[f64; 3]]) -> [f64; 3] {
        let Some((f, bary)) = self.closest(p) else {
            return [0.0; 3];
        };
        let vs = self.mesh.face_vertices(f);
        (0..3).fold([0.0; 3], |s, k| {
            add(s, scale(value(values, vs[k].idx()), bary[k]))
        })
    }

    /// The face of the crack side at `p` facing `dir` and the barycentric
    /// coordinates of `p`'s closest point on it: the face closest to a
    /// point a hundredth of an edge from `p` along `dir`. `dir` points into
    /// the sector of the surface a copy of a crack vertex owns (the middle
    /// of its fan), so the face lies on that copy's side of every crack
    /// meeting there, at a junction too, and its corners are that side's
    /// copies of the cracked mesh's vertices.
    pub(super) fn crack_side(
        &self,
        p: [f64; 3],
        dir: [f64; 3],
    ) -> Option<([VertexId; 3], [f64; 3])> {
        let l = norm(dir);
        if l.is_nan() || l <= 0.0 {
            return None;
        }
        let q = add(p, scale(dir, SIDE_STEP * self.cell / l));
        let f = self.closest(q)?.0;
        let vs = self.mesh.face_vertices(f);
        let bary = closest_on_triangle(p, vs.map(|v| self.mesh.position(v))).1;
        Some((vs, bary))
    }

    /// The crack side at `p` running the way of `dir` (the direction of a
    /// crack side of the other mesh leaving `p`: both meshes keep their
    /// faces to the left of their sides, so a side running the same way
    /// has its material on the same side of the crack): among the sides
    /// near the closest one, the one whose direction is closest to `dir`.
    /// Its ends and `p`'s parameter along it.
    pub(super) fn crack_side_along(
        &self,
        p: [f64; 3],
        dir: [f64; 3],
    ) -> Option<([VertexId; 2], f64)> {
        let grid = self.side_grid.as_ref()?;
        let reach = SIDE_REACH * self.cell;
        let mut near: Vec<(f64, usize)> = Vec::new();
        let mut best = f64::INFINITY;
        grid.search(p, |i| {
            let h = self.sides[i];
            let (a, b) = (
                self.mesh.position(self.mesh.origin(h)),
                self.mesh.position(self.mesh.dest(h)),
            );
            let d = dist2(p, closest_on_segment(p, a, b)).sqrt();
            best = best.min(d);
            near.push((d, i));
            Some((best + reach) * (best + reach))
        });
        near.sort_by_key(|x| x.1);
        near.dedup_by_key(|x| x.1);
        let l = norm(dir);
        if l.is_nan() || l <= 0.0 {
            return None;
        }
        let mut pick: Option<(f64, usize)> = None;
        for &(d, i) in &near {
            if d > best + reach {
                continue;
            }
            let h = self.sides[i];
            let e = sub(
                self.mesh.position(self.mesh.dest(h)),
                self.mesh.position(self.mesh.origin(h)),
            );
            let le = norm(e);
            if le <= 0.0 {
                continue;
            }
            let s = dot(e, dir) / (le * l);
            if pick.is_none_or(|(ps, _)| s > ps) {
                pick = Some((s, i));
            }
        }
        let (score, i) = pick?;
        if score <= 0.0 {
            return None;
        }
        let h = self.sides[i];
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

    /// `displacement`, `crack_time` and each array of `carry` (per vertex
    /// of the sampled mesh) at each vertex of the cut `mesh` (`on_crack`
    /// per vertex: on a crack): a crack vertex's from the crack side on its
    /// own side, any other vertex's from the closest face.
    pub(super) fn carry(
        &self,
        mesh: &SimMesh,
        on_crack: &[bool],
        displacement: &[[f64; 3]],
        crack_time: &[f64],
        carry: &[&[[f64; 3]]],
    ) -> Carried {
        let mut disp = Vec::with_capacity(mesh.n_vertices());
        let mut carried: Vec<Vec<[f64; 3]>> = carry
            .iter()
            .map(|_| Vec::with_capacity(mesh.n_vertices()))
            .collect();
        let mut ctime = Vec::with_capacity(mesh.n_vertices());
        for v in mesh.vertices() {
            let p = mesh.position(v);
            // A copy of a crack vertex takes its values from the cracked
            // mesh's crack side running the way of the copy's own side leaving
            // it; failing that, from the face its fan faces.
            let corners: Option<(Vec<VertexId>, Vec<f64>)> = if on_crack[v.idx()] {
                mesh.vertex_outgoing(v)
                    .find(|&h| mesh.twin(h).is_none() && mesh.is_crack_halfedge(h))
                    .and_then(|h| self.crack_side_along(p, sub(mesh.position(mesh.dest(h)), p)))
                    .map(|([a, b], t)| (vec![a, b], vec![1.0 - t, t]))
                    .or_else(|| {
                        let (_, d) = mesh.fan_middle(v)?;
                        let (vs, bary) = self.crack_side(p, d)?;
                        Some((vs.to_vec(), bary.to_vec()))
                    })
            } else {
                None
            };
            match corners {
                Some((vs, w)) => {
                    let at = |values: &[[f64; 3]]| {
                        vs.iter().zip(&w).fold([0.0; 3], |s, (u, &x)| {
                            add(s, scale(value(values, u.idx()), x))
                        })
                    };
                    disp.push(at(displacement));
                    for (out, values) in carried.iter_mut().zip(carry) {
                        out.push(at(values));
                    }
                    ctime.push(side_time(crack_time, &vs, &w));
                }
                None => {
                    disp.push(self.face_value(p, displacement));
                    for (out, values) in carried.iter_mut().zip(carry) {
                        out.push(self.face_value(p, values));
                    }
                    ctime.push(f64::NAN);
                }
            }
        }
        Carried {
            displacement: disp,
            crack_time: ctime,
            carried,
        }
    }
}

/// The cracked mesh's per-vertex values carried over to the cut mesh.
pub(super) struct Carried {
    /// Per vertex: the displacement, on the vertex's side of any crack.
    pub(super) displacement: Vec<[f64; 3]>,
    /// Per vertex: the crack time (NaN off the cracks).
    pub(super) crack_time: Vec<f64>,
    /// Per carried array, per vertex: its value.
    pub(super) carried: Vec<Vec<[f64; 3]>>,
}

/// The crack time between vertices `a` and `b` at `t`; an end without a
/// time gives the other's.
/// The crack time at barycentric `bary` of the cracked mesh's face `vs`:
/// interpolated over the corners that lie on a crack (a time), NaN when
/// none does.
fn side_time(times: &[f64], vs: &[VertexId], bary: &[f64]) -> f64 {
    let (mut sum, mut weight) = (0.0, 0.0);
    for k in 0..vs.len() {
        let t = times.get(vs[k].idx()).copied().unwrap_or(f64::NAN);
        if !t.is_nan() {
            sum += bary[k] * t;
            weight += bary[k];
        }
    }
    if weight > 0.0 {
        sum / weight
    } else {
        // Only a corner's own time counts: the first corner with one.
        vs.iter()
            .map(|u| times.get(u.idx()).copied().unwrap_or(f64::NAN))
            .find(|t| !t.is_nan())
            .unwrap_or(f64::NAN)
    }
}
