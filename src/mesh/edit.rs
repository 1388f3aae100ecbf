//! Local edits used by the crack engine: edge and face splits, and opening
//! an edge into a crack.
//!
//! Every edit keeps all invariants checked by
//! [`SimMesh::validate`](super::SimMesh::validate), grows every per-vertex,
//! per-face, per-halfedge and wedge array, and bumps the
//! [generation](super::SimMesh::generation). New vertices and faces are
//! appended (ids `n_vertices()` / `n_faces()` before the edit, in order);
//! existing ids stay valid, although a split face keeps its id while losing
//! part of its area, and the halfedges of a split face may change their
//! endpoints.

use crate::math::GrowGently;

use super::error::{EditFault, FlipRefusal, MeshError};
use super::halfedge::SimMesh;
use super::ids::{FaceId, HalfedgeId, VertexId, WedgeId, INVALID};

/// What [`SimMesh::split_edge`] created.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SplitEdgeResult {
    /// The new vertex on the edge.
    pub vertex: VertexId,
    /// `(parent, child)`: each face adjacent to the edge and the new face
    /// split off it (one pair on a boundary edge, two otherwise).
    pub new_faces: Vec<(FaceId, FaceId)>,
    /// The new halfedges from the origin of the split halfedge to the new
    /// vertex and from the new vertex to its old destination.
    pub halves: [HalfedgeId; 2],
}

/// What [`SimMesh::split_face`] created.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SplitFaceResult {
    /// The new vertex inside the face.
    pub vertex: VertexId,
    /// `(parent, child)` for the two new faces; the parent keeps a third of
    /// the split.
    pub new_faces: Vec<(FaceId, FaceId)>,
}

/// What [`SimMesh::open_edge`] changed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OpenEdgeResult {
    /// The two halfedges of the opened edge, now both boundary halfedges.
    pub halfedges: [HalfedgeId; 2],
    /// `(new, source)`: vertices created by duplicating an endpoint whose
    /// fan the opening cut in two, with the vertex they were copied from
    /// (same position). Per-vertex arrays of the caller should copy the
    /// source's entry.
    pub new_vertices: Vec<(VertexId, VertexId)>,
}

impl SimMesh {
    fn check_halfedge(&self, h: HalfedgeId) -> Result<(), MeshError> {
        if h.idx() < self.n_halfedges() {
            Ok(())
        } else {
            Err(EditFault::HalfedgeRange {
                halfedge: h,
                count: self.n_halfedges(),
            }
            .into())
        }
    }

    /// Give the face corners `corners` a new wedge holding the weighted
    /// combination of `sources` (weights summing to 1, as
    /// [`WedgeAttributes::push_interpolated`](super::attributes::WedgeAttributes::push_interpolated));
    /// the wedges they used keep their values for any other corner. The
    /// surface and its connectivity are unchanged. Returns the new wedge.
    pub fn rewedge_corners(
        &mut self,
        corners: &[HalfedgeId],
        sources: &[(WedgeId, f64)],
    ) -> WedgeId {
        let w = self.wedges.push_interpolated(sources);
        for h in corners {
            self.he_wedge[h.idx()] = w.0;
        }
        self.bump();
        w
    }

    fn push_vertex(&mut self, p: [f64; 3], source: u32, parent: Option<u32>) -> u32 {
        let v = self.positions.len() as u32;
        let n = v as usize + 1;
        self.positions.reserve_gently(n);
        self.vertex_halfedge.reserve_gently(n);
        self.vertex_source.reserve_gently(n);
        self.vertex_parent.reserve_gently(n);
        self.positions.push(p);
        self.vertex_halfedge.push(INVALID);
        self.vertex_source.push(source);
        self.vertex_parent.push(parent.unwrap_or(v));
        v
    }

    /// Appends a face with the given corner vertices, wedges, group and
    /// source; twins are unset. Returns its first halfedge index.
    fn push_face(&mut self, v: [u32; 3], w: [u32; 3], group: u32, source: u32) -> usize {
        let b = self.he_origin.len();
        self.he_origin.reserve_gently(b + 3);
        self.he_wedge.reserve_gently(b + 3);
        self.he_twin.reserve_gently(b + 3);
        self.he_crack.reserve_gently(b + 3);
        let f = self.face_groups.len() + 1;
        self.face_groups.reserve_gently(f);
        self.face_source.reserve_gently(f);
        self.he_origin.extend_from_slice(&v);
        self.he_wedge.extend_from_slice(&w);
        self.he_twin.extend_from_slice(&[INVALID; 3]);
        self.he_crack.extend_from_slice(&[false; 3]);
        self.face_groups.push(group);
        self.face_source.push(source);
        b
    }

    #[inline]
    fn link(&mut self, a: usize, b: usize) {
        self.he_twin[a] = b as u32;
        self.he_twin[b] = a as u32;
    }

    /// Halfedge `a` takes over the edge halfedge `from` stood for: its twin
    /// (which may be `INVALID`) and its crack flag. `from` is relinked by the
    /// caller.
    #[inline]
    fn take_edge(&mut self, a: usize, from: usize) {
        let t = self.he_twin[from];
        self.he_twin[a] = t;
        if t != INVALID {
            self.he_twin[t as usize] = a as u32;
        }
        self.he_crack[a] = self.he_crack[from];
        self.he_crack[from] = false;
    }

    /// Splits the edge of `h` at `(1 - t) * origin + t * dest`, splitting
    /// each adjacent face in two.
    ///
    /// On each side the new corner gets a wedge interpolated at `t` between
    /// the wedges of the edge's corners in that face; if both sides use the
    /// same two wedges (no seam), one new wedge is shared. Halfedge `h`
    /// becomes the first half (origin to new vertex).
    ///
    /// # Errors
    /// `h` out of range or `t` not strictly inside `(0, 1)`.
    pub fn split_edge(&mut self, h: HalfedgeId, t: f64) -> Result<SplitEdgeResult, MeshError> {
        self.check_halfedge(h)?;
        if !(t > 0.0 && t < 1.0) {
            return Err(EditFault::SplitParameter(t).into());
        }
        let h0 = h.idx();
        let h1 = self.next(h).idx();
        let h2 = self.prev(h).idx();
        let f0 = h0 / 3;
        let (a, b, c) = (self.he_origin[h0], self.he_origin[h1], self.he_origin[h2]);
        let (wa, wb) = (self.he_wedge[h0], self.he_wedge[h1]);
        let pa = self.positions[a as usize];
        let pb = self.positions[b as usize];
        let p = std::array::from_fn(|k| (1.0 - t) * pa[k] + t * pb[k]);
        let m = self.push_vertex(p, INVALID, None);
        let wm1 = self
            .wedges
            .push_interpolated(&[(WedgeId(wa), 1.0 - t), (WedgeId(wb), t)])
            .0;
        let opp = self.he_twin[h0];

        // Side of h: (a, b, c) -> (a, m, c) + (m, b, c).
        let g = self.push_face(
            [m, b, c],
            [wm1, wb, self.he_wedge[h2]],
            self.face_groups[f0],
            self.face_source[f0],
        );
        let (g0, g1, g2) = (g, g + 1, g + 2);
        self.take_edge(g1, h1);
        self.he_origin[h1] = m;
        self.he_wedge[h1] = wm1;
        self.link(h1, g2);
        if self.vertex_halfedge[b as usize] == h1 as u32 {
            self.vertex_halfedge[b as usize] = g1 as u32;
        }
        let mut new_faces = vec![(FaceId(f0 as u32), FaceId((g / 3) as u32))];

        if opp == INVALID {
            // g0 (m -> b) is the boundary halfedge of the new vertex; it is
            // a crack side when h was.
            self.he_twin[h0] = INVALID;
            self.he_twin[g0] = INVALID;
            self.he_crack[g0] = self.he_crack[h0];
            self.vertex_halfedge[m as usize] = g0 as u32;
        } else {
            // Side of o = (b -> a): (b, a, d) -> (b, m, d) + (m, a, d).
            let o0 = opp as usize;
            let o1 = self.next(HalfedgeId(opp)).idx();
            let o2 = self.prev(HalfedgeId(opp)).idx();
            let f1 = o0 / 3;
            let d = self.he_origin[o2];
            let (wb2, wa2) = (self.he_wedge[o0], self.he_wedge[o1]);
            let wm2 = if wa2 == wa && wb2 == wb {
                wm1
            } else {
                self.wedges
                    .push_interpolated(&[(WedgeId(wa2), 1.0 - t), (WedgeId(wb2), t)])
                    .0
            };
            let k = self.push_face(
                [m, a, d],
                [wm2, wa2, self.he_wedge[o2]],
                self.face_groups[f1],
                self.face_source[f1],
            );
            let (k0, k1, k2) = (k, k + 1, k + 2);
            self.take_edge(k1, o1);
            self.he_origin[o1] = m;
            self.he_wedge[o1] = wm2;
            self.link(o1, k2);
            self.link(h0, k0);
            self.link(o0, g0);
            if self.vertex_halfedge[a as usize] == o1 as u32 {
                self.vertex_halfedge[a as usize] = k1 as u32;
            }
            self.vertex_halfedge[m as usize] = h1 as u32;
            new_faces.push((FaceId(f1 as u32), FaceId((k / 3) as u32)));
        }
        self.bump();
        Ok(SplitEdgeResult {
            vertex: VertexId(m),
            new_faces,
            halves: [h, HalfedgeId(g0 as u32)],
        })
    }

    /// Splits face `f` in three at the point with barycentric coordinates
    /// `bary` (relative to [`face_vertices`](SimMesh::face_vertices);
    /// normalized to sum 1). The new corner wedge is interpolated
    /// barycentrically from the face's three wedges.
    ///
    /// # Errors
    /// `f` out of range, or a coordinate not finite and strictly positive.
    pub fn split_face(&mut self, f: FaceId, bary: [f64; 3]) -> Result<SplitFaceResult, MeshError> {
        if f.idx() >= self.n_faces() {
            return Err(EditFault::FaceRange {
                face: f,
                count: self.n_faces(),
            }
            .into());
        }
        if !bary.iter().all(|&x| x.is_finite() && x > 0.0) {
            return Err(EditFault::Barycentric(bary).into());
        }
        let sum: f64 = bary.iter().sum();
        let bary = bary.map(|x| x / sum);
        let [h0, h1, h2] = self.face_halfedges(f).map(|h| h.idx());
        let [a, b, c] = [h0, h1, h2].map(|h| self.he_origin[h]);
        let [wa, wb, wc] = [h0, h1, h2].map(|h| self.he_wedge[h]);
        let [pa, pb, pc] = [a, b, c].map(|v| self.positions[v as usize]);
        let p = std::array::from_fn(|k| bary[0] * pa[k] + bary[1] * pb[k] + bary[2] * pc[k]);
        let m = self.push_vertex(p, INVALID, None);
        let wm = self
            .wedges
            .push_interpolated(&[
                (WedgeId(wa), bary[0]),
                (WedgeId(wb), bary[1]),
                (WedgeId(wc), bary[2]),
            ])
            .0;
        let (group, source) = (self.face_groups[f.idx()], self.face_source[f.idx()]);
        // f: (a, b, c) -> (a, b, m); new (b, c, m) and (c, a, m).
        let p0 = self.push_face([b, c, m], [wb, wc, wm], group, source);
        let q0 = self.push_face([c, a, m], [wc, wa, wm], group, source);
        self.take_edge(p0, h1);
        self.take_edge(q0, h2);
        self.he_origin[h2] = m;
        self.he_wedge[h2] = wm;
        self.link(h1, p0 + 2);
        self.link(h2, q0 + 1);
        self.link(p0 + 1, q0 + 2);
        if self.vertex_halfedge[b as usize] == h1 as u32 {
            self.vertex_halfedge[b as usize] = p0 as u32;
        }
        if self.vertex_halfedge[c as usize] == h2 as u32 {
            self.vertex_halfedge[c as usize] = q0 as u32;
        }
        self.vertex_halfedge[m as usize] = h2 as u32;
        self.bump();
        Ok(SplitFaceResult {
            vertex: VertexId(m),
            new_faces: vec![(f, FaceId((p0 / 3) as u32)), (f, FaceId((q0 / 3) as u32))],
        })
    }

    /// Flips the interior edge of `h` (from `a` to `b` in face `(a, b, c)`,
    /// its twin in face `(b, a, d)`) into the edge from `c` to `d`: the faces
    /// become `(a, d, c)` and `(d, b, c)`, each keeping its id, group and
    /// source. Corners keep their wedges, so the edge must not be a seam
    /// (both faces use one wedge at `a` and one at `b`). Positions are not
    /// checked: the caller decides whether the flip keeps the surface.
    ///
    /// # Errors
    /// `h` out of range, a boundary edge, a seam, faces of two groups, or
    /// `c` and `d` already joined.
    pub fn flip_edge(&mut self, h: HalfedgeId) -> Result<(), MeshError> {
        self.check_halfedge(h)?;
        let refuse = |why: FlipRefusal| Err(EditFault::Flip { halfedge: h, why }.into());
        let h0 = h.idx();
        let o0 = self.he_twin[h0];
        if o0 == INVALID {
            return refuse(FlipRefusal::Boundary);
        }
        let o0 = o0 as usize;
        let (f, g) = (h0 / 3, o0 / 3);
        let (h1, h2) = (self.next(h).idx(), self.prev(h).idx());
        let (o1, o2) = (
            self.next(HalfedgeId(o0 as u32)).idx(),
            self.prev(HalfedgeId(o0 as u32)).idx(),
        );
        let [a, b, c] = [h0, h1, h2].map(|x| self.he_origin[x]);
        let d = self.he_origin[o2];
        let [wa, wb, wc] = [h0, h1, h2].map(|x| self.he_wedge[x]);
        let wd = self.he_wedge[o2];
        if self.he_wedge[o1] != wa || self.he_wedge[o0] != wb {
            return refuse(FlipRefusal::Seam);
        }
        if self.face_groups[f] != self.face_groups[g] {
            return refuse(FlipRefusal::Groups);
        }
        if c == d
            || self.find_halfedge(VertexId(c), VertexId(d)).is_some()
            || self.find_halfedge(VertexId(d), VertexId(c)).is_some()
        {
            return refuse(FlipRefusal::Joined);
        }
        // The quad's outer edges (twin, crack flag): a->d, d->b, b->c, c->a.
        let outer = [o1, o2, h1, h2].map(|x| (self.he_twin[x], self.he_crack[x]));
        let (fs, gs) = (3 * f, 3 * g);
        for (k, (v, w)) in [(a, wa), (d, wd), (c, wc)].into_iter().enumerate() {
            self.he_origin[fs + k] = v;
            self.he_wedge[fs + k] = w;
        }
        for (k, (v, w)) in [(d, wd), (b, wb), (c, wc)].into_iter().enumerate() {
            self.he_origin[gs + k] = v;
            self.he_wedge[gs + k] = w;
        }
        for (slot, (twin, crack)) in [fs, gs, gs + 1, fs + 2].into_iter().zip(outer) {
            self.he_twin[slot] = twin;
            if twin != INVALID {
                self.he_twin[twin as usize] = slot as u32;
            }
            self.he_crack[slot] = crack;
        }
        self.link(fs + 1, gs + 2);
        self.he_crack[fs + 1] = false;
        self.he_crack[gs + 2] = false;
        // A vertex whose outgoing halfedge was in the two faces takes one of
        // the new ones (the boundary one, if it has one there).
        let slots = [fs, fs + 1, fs + 2, gs, gs + 1, gs + 2];
        for x in [a, b, c, d] {
            let old = self.vertex_halfedge[x as usize] as usize;
            if old / 3 != f && old / 3 != g {
                continue;
            }
            let mine = slots.iter().copied().filter(|&s| self.he_origin[s] == x);
            let pick = mine
                .clone()
                .find(|&s| self.he_twin[s] == INVALID)
                .or_else(|| mine.clone().next());
            if let Some(s) = pick {
                self.vertex_halfedge[x as usize] = s as u32;
            }
        }
        self.bump();
        Ok(())
    }

    /// Opens the interior edge of `h` into a crack: its two faces stop
    /// sharing it, leaving two boundary halfedges.
    ///
    /// An endpoint that was already on a boundary (mesh border or earlier
    /// crack) has its fan cut in two; the fan starting at the opened
    /// halfedge leaving it moves to a new vertex at the same position. An
    /// interior endpoint (a crack tip) keeps a single, now open, fan and is
    /// not duplicated.
    ///
    /// # Errors
    /// `h` out of range or already a boundary halfedge.
    pub fn open_edge(&mut self, h: HalfedgeId) -> Result<OpenEdgeResult, MeshError> {
        self.check_halfedge(h)?;
        let Some(t) = self.twin(h) else {
            return Err(EditFault::AlreadyOpen(h).into());
        };
        let ends = [(self.origin(h), h), (self.origin(t), t)];
        let was_boundary = ends.map(|(v, _)| self.is_boundary_vertex(v));
        self.he_twin[h.idx()] = INVALID;
        self.he_twin[t.idx()] = INVALID;
        self.he_crack[h.idx()] = true;
        self.he_crack[t.idx()] = true;
        let mut new_vertices = Vec::new();
        for ((v, start), boundary) in ends.into_iter().zip(was_boundary) {
            if !boundary {
                // Crack tip: the cycle became one open fan starting here.
                self.vertex_halfedge[v.idx()] = start.0;
                continue;
            }
            // The fan starting at `start` moves to a copy of `v`.
            let source = self.vertex_source[v.idx()];
            let nv = self.push_vertex(self.positions[v.idx()], source, Some(v.0));
            self.vertex_halfedge[nv as usize] = start.0;
            let mut x = start;
            for _ in 0..self.n_halfedges() {
                self.he_origin[x.idx()] = nv;
                match self.twin(self.prev(x)) {
                    Some(y) => x = y,
                    None => break,
                }
            }
            new_vertices.push((VertexId(nv), v));
        }
        self.bump();
        Ok(OpenEdgeResult {
            halfedges: [h, t],
            new_vertices,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{build, grid_input, icosphere_input, Lcg};
    use crate::mesh::{Channel, ChannelKind, MeshInput};

    fn vertex_at(m: &SimMesh, p: [f64; 2]) -> VertexId {
        m.vertices()
            .find(|&v| m.position(v)[0] == p[0] && m.position(v)[1] == p[1])
            .expect("vertex")
    }

    fn uv(m: &SimMesh, w: WedgeId) -> [f64; 2] {
        let c = m.wedges().channel("uv").unwrap().get(w);
        [c[0], c[1]]
    }

    /// Every corner's UV equals its vertex's xy (true for `grid_input`).
    fn assert_uv_is_xy(m: &SimMesh) {
        for h in m.halfedges() {
            let p = m.position(m.origin(h));
            let t = uv(m, m.wedge(h));
            assert!((t[0] - p[0]).abs() < 1e-12 && (t[1] - p[1]).abs() < 1e-12);
        }
    }

    #[test]
    fn split_interior_edge_of_grid() {
        let (mut m, _) = build(&grid_input(2, 2));
        let (nv, nf, nw, g) = (m.n_vertices(), m.n_faces(), m.n_wedges(), m.generation());
        let area = m.total_area();
        let c = vertex_at(&m, [1.0, 1.0]);
        let b = vertex_at(&m, [1.0, 0.0]);
        let h = m.find_halfedge(c, b).unwrap();
        assert!(m.is_interior_edge(h));
        let r = m.split_edge(h, 0.25).unwrap();
        m.validate().unwrap();
        assert_eq!(m.n_vertices(), nv + 1);
        assert_eq!(m.n_faces(), nf + 2);
        assert_eq!(m.n_wedges(), nw + 1, "no seam: one shared wedge");
        assert!(m.generation() > g);
        assert_eq!(r.vertex, VertexId(nv as u32));
        assert_eq!(m.position(r.vertex), [1.0, 0.75, 0.0]);
        assert_eq!(r.new_faces.len(), 2);
        for (parent, child) in &r.new_faces {
            assert_eq!(m.face_source(*parent), m.face_source(*child));
            assert_eq!(m.face_group(*parent), m.face_group(*child));
        }
        assert_eq!(m.origin(r.halves[0]), c);
        assert_eq!(m.dest(r.halves[0]), r.vertex);
        assert_eq!(m.origin(r.halves[1]), r.vertex);
        assert_eq!(m.dest(r.halves[1]), b);
        assert!((m.total_area() - area).abs() < 1e-12);
        assert_uv_is_xy(&m);
        assert_eq!(m.vertex_parent(r.vertex), r.vertex);
        assert_eq!(m.vertex_source(r.vertex), None);
    }

    #[test]
    fn split_boundary_edge_of_grid() {
        let (mut m, r0) = build(&grid_input(2, 2));
        let (nv, nf) = (m.n_vertices(), m.n_faces());
        let a = vertex_at(&m, [0.0, 0.0]);
        let b = vertex_at(&m, [1.0, 0.0]);
        let h = m.find_halfedge(a, b).unwrap();
        assert!(m.is_boundary_halfedge(h));
        let r = m.split_edge(h, 0.5).unwrap();
        m.validate().unwrap();
        assert_eq!(m.n_vertices(), nv + 1);
        assert_eq!(m.n_faces(), nf + 1);
        assert_eq!(r.new_faces.len(), 1);
        assert!(m.is_boundary_vertex(r.vertex));
        assert_eq!(m.n_boundary_halfedges(), r0.boundary_edges + 1);
        assert_eq!(m.boundary_loops(), 1);
        assert_uv_is_xy(&m);
    }

    #[test]
    fn split_face_interpolates_barycentrically() {
        let (mut m, _) = build(&grid_input(2, 2));
        let area = m.total_area();
        let f = FaceId(3);
        let [a, b, c] = m.face_vertices(f).map(|v| m.position(v));
        let bary = [0.2, 0.3, 0.5];
        let r = m.split_face(f, [2.0, 3.0, 5.0]).unwrap();
        m.validate().unwrap();
        let p = m.position(r.vertex);
        for k in 0..3 {
            let e = bary[0] * a[k] + bary[1] * b[k] + bary[2] * c[k];
            assert!((p[k] - e).abs() < 1e-12);
        }
        assert_eq!(r.new_faces.len(), 2);
        assert_eq!(m.n_faces(), 10);
        assert!((m.total_area() - area).abs() < 1e-12);
        assert_uv_is_xy(&m);
        assert!(m.split_face(f, [1.0, 0.0, 1.0]).is_err());
        assert!(m.split_face(FaceId(99), [1.0, 1.0, 1.0]).is_err());
    }

    #[test]
    fn split_edge_on_uv_seam_makes_two_wedges() {
        // Two quads side by side whose shared edge is a UV seam.
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ];
        let uvs_in = vec![
            0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0, //
            5.0, 0.0, 6.0, 0.0, 6.0, 1.0, 5.0, 1.0,
        ];
        let input = MeshInput {
            positions,
            triangles: vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]],
            face_groups: vec![],
            wedge_channels: vec![Channel::new("uv", 2, ChannelKind::Linear, uvs_in)],
        };
        let (mut m, r) = build(&input);
        assert_eq!(r.boundary_edges, 6);
        let a = vertex_at(&m, [1.0, 0.0]);
        let b = vertex_at(&m, [1.0, 1.0]);
        let h = m.find_halfedge(a, b).unwrap();
        let nw = m.n_wedges();
        let s = m.split_edge(h, 0.25).unwrap();
        m.validate().unwrap();
        assert_eq!(m.n_wedges(), nw + 2);
        let mut uvs: Vec<[f64; 2]> = m
            .vertex_outgoing(s.vertex)
            .map(|h| uv(&m, m.wedge(h)))
            .collect();
        uvs.sort_by(|x, y| x.partial_cmp(y).unwrap());
        uvs.dedup();
        assert_eq!(uvs, vec![[1.0, 0.25], [5.0, 0.25]]);
    }

    fn open_between(m: &mut SimMesh, p: [f64; 2], q: [f64; 2]) -> OpenEdgeResult {
        let (a, b) = (vertex_at(m, p), vertex_at(m, q));
        let h = m
            .find_halfedge(a, b)
            .or_else(|| m.find_halfedge(b, a))
            .unwrap();
        let r = m.open_edge(h).unwrap();
        m.validate().unwrap();
        r
    }

    #[test]
    fn open_edges_along_a_line_cuts_grid_in_two() {
        let (mut m, _) = build(&grid_input(4, 4));
        assert_eq!(m.n_vertices(), 25);
        let nb = m.n_boundary_halfedges();
        let area = m.total_area();

        // Interior edge between two interior vertices: a crack with two tips.
        let r = open_between(&mut m, [1.0, 2.0], [2.0, 2.0]);
        assert!(r.new_vertices.is_empty());
        assert_eq!(m.n_vertices(), 25);
        assert_eq!(m.n_boundary_halfedges(), nb + 2);
        assert_eq!(m.boundary_loops(), 2);
        assert!(m.is_boundary_vertex(vertex_at(&m, [1.0, 2.0])));

        // Extend: (2,2) was on the crack -> duplicated; (3,2) is a new tip.
        let r = open_between(&mut m, [2.0, 2.0], [3.0, 2.0]);
        assert_eq!(r.new_vertices.len(), 1);
        let (new, src) = r.new_vertices[0];
        assert_eq!(m.position(new), [2.0, 2.0, 0.0]);
        assert_eq!(m.vertex_parent(new), src);
        assert_eq!(m.n_vertices(), 26);
        assert_eq!(m.n_boundary_halfedges(), nb + 4);

        // Reach the border: both endpoints duplicated, still one piece.
        let r = open_between(&mut m, [3.0, 2.0], [4.0, 2.0]);
        assert_eq!(r.new_vertices.len(), 2);
        assert_eq!(m.n_vertices(), 28);
        assert_eq!(m.connected_components().0, 1);
        assert_eq!(m.boundary_loops(), 1);

        // Close the line on the other side: the grid falls in two.
        let r = open_between(&mut m, [0.0, 2.0], [1.0, 2.0]);
        assert_eq!(r.new_vertices.len(), 2);
        assert_eq!(m.n_vertices(), 30);
        let (n, comp) = m.connected_components();
        assert_eq!(n, 2);
        for f in m.faces() {
            let above = m.face_vertices(f).iter().any(|&v| m.position(v)[1] > 2.0);
            assert_eq!(
                comp[f.idx()],
                if above {
                    comp[m.n_faces() - 1]
                } else {
                    comp[0]
                }
            );
        }
        assert_eq!(m.boundary_loops(), 2);
        assert_eq!(m.n_boundary_halfedges(), nb + 8);
        assert!((m.total_area() - area).abs() < 1e-12);
        assert_uv_is_xy(&m);

        // Opening a boundary edge is refused.
        let h = m.halfedges().find(|&h| m.is_boundary_halfedge(h)).unwrap();
        assert!(m.open_edge(h).is_err());
        assert!(m.split_edge(h, 1.0).is_err());
        assert!(m.split_edge(HalfedgeId(10_000), 0.5).is_err());
    }

    #[test]
    fn random_edits_on_icosphere_keep_invariants() {
        let (mut m, _) = build(&icosphere_input(2));
        let area = m.total_area();
        let mut rng = Lcg(0xC0FFEE);
        let mut generation = m.generation();
        let (mut splits, mut faces, mut opens) = (0, 0, 0);
        for step in 0..600 {
            let (nv, nf, nh) = (m.n_vertices(), m.n_faces(), m.n_halfedges());
            match rng.below(10) {
                0..=4 => {
                    let h = HalfedgeId(rng.below(nh) as u32);
                    let t = 0.05 + 0.9 * rng.next_f64();
                    let (pa, pb) = (m.position(m.origin(h)), m.position(m.dest(h)));
                    let boundary = m.is_boundary_halfedge(h);
                    let r = m.split_edge(h, t).unwrap();
                    let p = m.position(r.vertex);
                    for k in 0..3 {
                        assert!((p[k] - ((1.0 - t) * pa[k] + t * pb[k])).abs() < 1e-12);
                    }
                    assert_eq!(m.n_faces(), nf + if boundary { 1 } else { 2 });
                    splits += 1;
                }
                5..=7 => {
                    let f = FaceId(rng.below(nf) as u32);
                    let bary = [
                        0.1 + rng.next_f64(),
                        0.1 + rng.next_f64(),
                        0.1 + rng.next_f64(),
                    ];
                    m.split_face(f, bary).unwrap();
                    assert_eq!(m.n_faces(), nf + 2);
                    faces += 1;
                }
                _ => {
                    let h = HalfedgeId(rng.below(nh) as u32);
                    if m.is_boundary_halfedge(h) {
                        continue;
                    }
                    let r = m.open_edge(h).unwrap();
                    assert_eq!(m.n_vertices(), nv + r.new_vertices.len());
                    for (new, src) in r.new_vertices {
                        assert_eq!(m.position(new), m.position(src));
                        assert_eq!(m.vertex_source(new), m.vertex_source(src));
                    }
                    opens += 1;
                }
            }
            m.validate().unwrap_or_else(|e| panic!("step {step}: {e}"));
            assert!(m.generation() > generation);
            generation = m.generation();
            let a = m.total_area();
            assert!(
                (a - area).abs() <= 1e-9 * area,
                "step {step}: area {a} vs {area}"
            );
        }
        assert!(splits > 100 && faces > 100 && opens > 50);
        // Interpolated normals stay unit length.
        let n = m.wedges().channel("n").unwrap();
        for w in 0..m.n_wedges() {
            let v = n.get(WedgeId(w as u32));
            assert!(((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt() - 1.0).abs() < 1e-12);
        }
        // Each face's corners point at wedges in range, and the mesh still
        // covers the same surface pieces.
        assert!(m.connected_components().0 >= 1);
    }

    #[test]
    fn crack_flags_follow_opened_edges_through_splits() {
        let (mut m, _) = build(&grid_input(4, 4));
        let count = |m: &SimMesh| m.halfedges().filter(|&h| m.is_crack_halfedge(h)).count();
        assert_eq!(count(&m), 0, "the input border is not a crack");
        // Open the interior edge (1,2)-(2,2).
        let a = vertex_at(&m, [1.0, 2.0]);
        let b = vertex_at(&m, [2.0, 2.0]);
        let h = m.find_halfedge(a, b).unwrap();
        m.open_edge(h).unwrap();
        assert_eq!(count(&m), 2);
        // Split one side of the crack: both halves stay crack sides.
        let side = m.halfedges().find(|&h| m.is_crack_halfedge(h)).unwrap();
        m.split_edge(side, 0.5).unwrap();
        m.validate().unwrap();
        assert_eq!(count(&m), 3);
        // Splitting the faces next to the crack moves the flag with the edge.
        let faces: Vec<FaceId> = m.faces().collect();
        for f in faces {
            m.split_face(f, [1.0, 1.0, 1.0]).unwrap();
        }
        m.validate().unwrap();
        assert_eq!(count(&m), 3);
        for h in m.halfedges().filter(|&h| m.is_crack_halfedge(h)) {
            let (p, q) = (m.position(m.origin(h)), m.position(m.dest(h)));
            assert!(p[1] == 2.0 && q[1] == 2.0 && p[0] >= 1.0 && q[0] <= 2.0 && q[0] >= 1.0);
        }
        // Splitting an interior edge whose neighbour edges are crack sides keeps the count.
        let inner: Vec<HalfedgeId> = m
            .halfedges()
            .filter(|&h| m.twin(h).is_some())
            .take(20)
            .collect();
        for h in inner {
            if m.twin(h).is_some() {
                m.split_edge(h, 0.3).unwrap();
            }
        }
        m.validate().unwrap();
        assert_eq!(count(&m), 3);
        assert_eq!(
            m.halfedges().filter(|&h| m.is_boundary_halfedge(h)).count(),
            3 + 16,
            "crack sides plus the 16 border edges"
        );
    }

    /// Flipping every interior edge of a grid once (where allowed) keeps
    /// the mesh valid, its area and its UVs at every corner (each corner's
    /// wedge still holds its vertex's own value); a flip refuses a border
    /// edge and an edge whose far corners are joined already.
    #[test]
    fn edges_flip_and_the_mesh_stays_valid() {
        let (mut m, _) = build(&grid_input(4, 4));
        let area = m.total_area();
        let inner: Vec<HalfedgeId> = m
            .halfedges()
            .filter(|&h| m.twin(h).is_some_and(|t| t.0 > h.0))
            .collect();
        // Only where the quad is convex (both new triangles face up), so
        // the flip keeps the surface.
        let up = |m: &SimMesh, t: [VertexId; 3]| {
            let [a, b, c] = t.map(|v| m.position(v));
            (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) > 1e-12
        };
        let mut flipped = 0;
        for h in inner {
            let Some(t) = m.twin(h) else { continue };
            let (a, b) = (m.origin(h), m.dest(h));
            let (c, d) = (m.origin(m.prev(h)), m.origin(m.prev(t)));
            if up(&m, [a, d, c]) && up(&m, [d, b, c]) && m.flip_edge(h).is_ok() {
                flipped += 1;
                m.validate().unwrap();
            }
        }
        assert!(flipped > 10, "{flipped}");
        assert!((m.total_area() - area).abs() < 1e-12);
        for f in m.faces() {
            for (v, w) in m.face_vertices(f).into_iter().zip(m.face_wedges(f)) {
                let p = m.position(v);
                assert_eq!(uv(&m, w), [p[0], p[1]], "face {f}");
            }
        }
        let border = m.halfedges().find(|&h| m.twin(h).is_none()).unwrap();
        assert!(m.flip_edge(border).is_err());
        // Flipping back and forth returns the first triangulation.
        let h = m.halfedges().find(|&h| m.twin(h).is_some()).unwrap();
        let before: Vec<[VertexId; 3]> = m.faces().map(|f| m.face_vertices(f)).collect();
        m.flip_edge(h).unwrap();
        let f = m.face(h);
        let back = m.face_halfedges(f)[1];
        m.flip_edge(back).unwrap();
        m.validate().unwrap();
        let mut after: Vec<Vec<u32>> = m
            .faces()
            .map(|f| {
                let mut v: Vec<u32> = m.face_vertices(f).iter().map(|x| x.0).collect();
                v.sort_unstable();
                v
            })
            .collect();
        let mut want: Vec<Vec<u32>> = before
            .iter()
            .map(|t| {
                let mut v: Vec<u32> = t.iter().map(|x| x.0).collect();
                v.sort_unstable();
                v
            })
            .collect();
        after.sort();
        want.sort();
        assert_eq!(after, want);
    }
}
