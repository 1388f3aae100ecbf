//! The half-edge data structure [`SimMesh`] and its read-only queries.
//!
//! # Layout
//!
//! Struct of arrays with `u32` indices. Halfedges are stored implicitly per
//! face: halfedge `3f + k` is the `k`-th edge of face `f`, going from the
//! face's corner `k` to corner `k + 1 (mod 3)`, so `next`, `prev` and `face`
//! are arithmetic. There are no explicit faceless boundary halfedges: a
//! **boundary halfedge** is a face halfedge without a twin
//! ([`SimMesh::twin`] returns `None`). Every halfedge is also a face corner:
//! the corner at its origin, whose attributes are [`SimMesh::wedge`].
//!
//! Every vertex has at least one incident face and its incident faces form a
//! single fan. Its outgoing halfedge ([`SimMesh::vertex_halfedge`]) is the
//! boundary one if the vertex is on a boundary. Rotating from it with
//! `h -> twin(prev(h))` visits the whole fan counter-clockwise (for
//! counter-clockwise faces), ending at a missing twin for boundary vertices.

use super::attributes::WedgeAttributes;
use super::error::{EditFault, MeshError};
use super::ids::{FaceId, HalfedgeId, VertexId, WedgeId, INVALID};
use crate::math::v3;
pub(super) use crate::math::v3::{cross, norm, sub};

/// A simulation mesh: an oriented 2-manifold triangle mesh with boundary,
/// with per-corner attribute wedges. See the [module docs](self) for the
/// layout.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimMesh {
    /// Rest position of each vertex.
    pub(super) positions: Vec<[f64; 3]>,
    /// One outgoing halfedge per vertex (the boundary one on a boundary).
    pub(super) vertex_halfedge: Vec<u32>,
    /// Input vertex each vertex was welded from, or `INVALID`.
    pub(super) vertex_source: Vec<u32>,
    /// The vertex each vertex was duplicated from (itself if none).
    pub(super) vertex_parent: Vec<u32>,
    /// Origin vertex of each halfedge.
    pub(super) he_origin: Vec<u32>,
    /// Twin of each halfedge, or `INVALID` on a boundary.
    pub(super) he_twin: Vec<u32>,
    /// Wedge of the corner at each halfedge's origin.
    pub(super) he_wedge: Vec<u32>,
    /// Whether each halfedge is a side of a crack (opened by
    /// [`open_edge`](SimMesh::open_edge), or a piece of one after a split).
    pub(super) he_crack: Vec<bool>,
    /// Input group (primitive / material) of each face.
    pub(super) face_groups: Vec<u32>,
    /// Input triangle each face comes from.
    pub(super) face_source: Vec<u32>,
    /// Attribute values of the wedges.
    pub(super) wedges: WedgeAttributes,
    /// Bumped on every mutation.
    pub(super) generation: u64,
}

/// Twice the area of triangle `(a, b, c)`.
#[inline]
pub(super) fn double_area(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    norm(cross(sub(b, a), sub(c, a)))
}

impl SimMesh {
    /// The angle `v`'s fan of faces spans at `v`, and the unit direction
    /// through the middle of that angle (the fan walked counter-clockwise from
    /// [`SimMesh::vertex_halfedge`]). On a copy of a crack node the fan lies
    /// between two crack edges, so the middle points away from the crack:
    /// perpendicular to a straight crack, the bisector at a corner. `None` when
    /// the fan has no non-degenerate corner or the middle direction vanishes.
    pub fn fan_middle(&self, v: VertexId) -> Option<(f64, [f64; 3])> {
        let pv = self.position(v);
        let mut corners: Vec<([f64; 3], [f64; 3], f64)> = Vec::new();
        for h in self.vertex_outgoing(v) {
            let a = v3::unit(v3::sub(self.position(self.dest(h)), pv));
            let b = v3::unit(v3::sub(self.position(self.origin(self.prev(h))), pv));
            if let (Some(ua), Some(ub)) = (a, b) {
                corners.push((ua, ub, v3::dot(ua, ub).clamp(-1.0, 1.0).acos()));
            }
        }
        let total: f64 = corners.iter().map(|c| c.2).sum();
        let half = 0.5 * total;
        let mut acc = 0.0;
        for (u1, u2, a) in corners {
            if acc + a >= half {
                // Turn u1 towards u2 by (half - acc) within this corner.
                let s = if a > 0.0 { (half - acc) / a } else { 0.0 };
                let d = v3::add(
                    v3::scale(u1, ((1.0 - s) * a).sin()),
                    v3::scale(u2, (s * a).sin()),
                );
                return v3::unit(d).map(|d| (total, d));
            }
            acc += a;
        }
        None
    }

    // ----- sizes -------------------------------------------------------

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.face_groups.len()
    }

    /// Number of halfedges (always `3 * n_faces()`).
    pub fn n_halfedges(&self) -> usize {
        self.he_origin.len()
    }

    /// Number of wedges.
    pub fn n_wedges(&self) -> usize {
        self.wedges.len()
    }

    /// Counter bumped by every mutation; per-element caches keyed on it can
    /// detect a stale mesh.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// All vertex ids.
    pub fn vertices(&self) -> impl ExactSizeIterator<Item = VertexId> + '_ {
        (0..self.n_vertices() as u32).map(VertexId)
    }

    /// All face ids.
    pub fn faces(&self) -> impl ExactSizeIterator<Item = FaceId> + '_ {
        (0..self.n_faces() as u32).map(FaceId)
    }

    /// All halfedge ids.
    pub fn halfedges(&self) -> impl ExactSizeIterator<Item = HalfedgeId> + '_ {
        (0..self.n_halfedges() as u32).map(HalfedgeId)
    }

    // ----- per-element data --------------------------------------------

    /// Rest positions of all vertices, indexed by [`VertexId::idx`].
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.positions
    }

    /// Rest position of `v`.
    pub fn position(&self, v: VertexId) -> [f64; 3] {
        self.positions[v.idx()]
    }

    /// Move every vertex to `positions` (indexed by vertex id), for
    /// post-processing after the simulation (crack width, curling).
    ///
    /// # Errors
    /// A length that is not the vertex count, or a non-finite coordinate.
    pub fn set_positions(&mut self, positions: &[[f64; 3]]) -> Result<(), MeshError> {
        if positions.len() != self.positions.len() {
            return Err(EditFault::PositionCount {
                positions: positions.len(),
                vertices: self.positions.len(),
            }
            .into());
        }
        if let Some(i) = positions
            .iter()
            .position(|p| p.iter().any(|x| !x.is_finite()))
        {
            return Err(EditFault::NotFinite(i).into());
        }
        self.positions.copy_from_slice(positions);
        self.bump();
        Ok(())
    }

    /// The wedge attribute values, for post-processing (normals after the
    /// surface moved). The channel layout cannot change.
    pub fn wedge_values_mut(&mut self, name: &str) -> Option<&mut [f64]> {
        self.wedges.channel_values_mut(name)
    }

    /// The input vertex `v` was welded from (its representative), or `None`
    /// for a vertex created by a split. Duplicates inherit it.
    pub fn vertex_source(&self, v: VertexId) -> Option<u32> {
        let s = self.vertex_source[v.idx()];
        (s != INVALID).then_some(s)
    }

    /// The vertex `v` was duplicated from (by manifold repair or
    /// [`open_edge`](SimMesh::open_edge)), or `v` itself.
    pub fn vertex_parent(&self, v: VertexId) -> VertexId {
        VertexId(self.vertex_parent[v.idx()])
    }

    /// The root of every vertex, indexed by vertex id: [`vertex_parent`](SimMesh::vertex_parent)
    /// followed to the vertex nothing was duplicated from (all copies of a
    /// crack vertex share it). Bounded, in case of a corrupted parent cycle.
    pub fn vertex_roots(&self) -> Vec<u32> {
        let n = self.n_vertices();
        let mut root = vec![0u32; n];
        for v in 0..n {
            let mut r = v;
            for _ in 0..n {
                if r < v {
                    // Already resolved (copies are appended after their parent).
                    r = root[r] as usize;
                    break;
                }
                let p = self.vertex_parent[r] as usize;
                if p == r {
                    break;
                }
                r = p;
            }
            root[v] = r as u32;
        }
        root
    }

    /// Input group of every face, indexed by [`FaceId::idx`].
    pub fn face_groups(&self) -> &[u32] {
        &self.face_groups
    }

    /// Input group of face `f`.
    pub fn face_group(&self, f: FaceId) -> u32 {
        self.face_groups[f.idx()]
    }

    /// Input triangle index of every face, indexed by [`FaceId::idx`]
    /// (split children inherit their parent's).
    pub fn face_sources(&self) -> &[u32] {
        &self.face_source
    }

    /// Input triangle index of face `f`.
    pub fn face_source(&self, f: FaceId) -> u32 {
        self.face_source[f.idx()]
    }

    /// The wedge table. Wedges `0..input vertices` are the input's vertices;
    /// later ones were interpolated by edits.
    pub fn wedges(&self) -> &WedgeAttributes {
        &self.wedges
    }

    // ----- halfedge navigation -----------------------------------------

    /// Next halfedge in the same face.
    #[inline]
    pub fn next(&self, h: HalfedgeId) -> HalfedgeId {
        HalfedgeId(if h.0 % 3 == 2 { h.0 - 2 } else { h.0 + 1 })
    }

    /// Previous halfedge in the same face.
    #[inline]
    pub fn prev(&self, h: HalfedgeId) -> HalfedgeId {
        HalfedgeId(if h.0 % 3 == 0 { h.0 + 2 } else { h.0 - 1 })
    }

    /// The opposite halfedge in the neighbouring face, `None` on a boundary.
    #[inline]
    pub fn twin(&self, h: HalfedgeId) -> Option<HalfedgeId> {
        let t = self.he_twin[h.idx()];
        (t != INVALID).then_some(HalfedgeId(t))
    }

    /// The face of `h`.
    #[inline]
    pub fn face(&self, h: HalfedgeId) -> FaceId {
        FaceId(h.0 / 3)
    }

    /// The vertex `h` leaves.
    #[inline]
    pub fn origin(&self, h: HalfedgeId) -> VertexId {
        VertexId(self.he_origin[h.idx()])
    }

    /// The vertex `h` points to.
    #[inline]
    pub fn dest(&self, h: HalfedgeId) -> VertexId {
        self.origin(self.next(h))
    }

    /// Wedge of the face corner at `origin(h)` in `face(h)`.
    #[inline]
    pub fn wedge(&self, h: HalfedgeId) -> WedgeId {
        WedgeId(self.he_wedge[h.idx()])
    }

    /// Whether `h` has no twin (mesh boundary or crack).
    #[inline]
    pub fn is_boundary_halfedge(&self, h: HalfedgeId) -> bool {
        self.he_twin[h.idx()] == INVALID
    }

    /// Whether `h` is one side of a crack (a boundary halfedge made by
    /// opening an edge, not the input's own border).
    #[inline]
    pub fn is_crack_halfedge(&self, h: HalfedgeId) -> bool {
        self.he_crack[h.idx()]
    }

    /// The outgoing halfedge of `v` (the boundary one if `v` is on a
    /// boundary).
    #[inline]
    pub fn vertex_halfedge(&self, v: VertexId) -> HalfedgeId {
        HalfedgeId(self.vertex_halfedge[v.idx()])
    }

    /// Whether `v` lies on a boundary (mesh border or crack).
    pub fn is_boundary_vertex(&self, v: VertexId) -> bool {
        self.is_boundary_halfedge(self.vertex_halfedge(v))
    }

    /// The three halfedges of `f`.
    #[inline]
    pub fn face_halfedges(&self, f: FaceId) -> [HalfedgeId; 3] {
        let b = f.0 * 3;
        [HalfedgeId(b), HalfedgeId(b + 1), HalfedgeId(b + 2)]
    }

    /// The three vertices of `f`, counter-clockwise.
    #[inline]
    pub fn face_vertices(&self, f: FaceId) -> [VertexId; 3] {
        let b = f.idx() * 3;
        [
            VertexId(self.he_origin[b]),
            VertexId(self.he_origin[b + 1]),
            VertexId(self.he_origin[b + 2]),
        ]
    }

    /// The wedges of the three corners of `f`, in the order of
    /// [`face_vertices`](SimMesh::face_vertices).
    #[inline]
    pub fn face_wedges(&self, f: FaceId) -> [WedgeId; 3] {
        let b = f.idx() * 3;
        [
            WedgeId(self.he_wedge[b]),
            WedgeId(self.he_wedge[b + 1]),
            WedgeId(self.he_wedge[b + 2]),
        ]
    }

    /// Outgoing halfedges of `v`, counter-clockwise, starting at
    /// [`vertex_halfedge`](SimMesh::vertex_halfedge).
    pub fn vertex_outgoing(&self, v: VertexId) -> VertexOutgoing<'_> {
        let start = self.vertex_halfedge(v);
        VertexOutgoing {
            mesh: self,
            start,
            cur: Some(start),
            steps: 0,
        }
    }

    /// Faces around `v`, counter-clockwise.
    pub fn vertex_faces(&self, v: VertexId) -> impl Iterator<Item = FaceId> + '_ {
        self.vertex_outgoing(v).map(|h| self.face(h))
    }

    /// The halfedge from `a` to `b`, if the edge exists.
    pub fn find_halfedge(&self, a: VertexId, b: VertexId) -> Option<HalfedgeId> {
        self.vertex_outgoing(a).find(|&h| self.dest(h) == b)
    }

    // ----- geometry -----------------------------------------------------

    /// Area of face `f`.
    pub fn face_area(&self, f: FaceId) -> f64 {
        let [a, b, c] = self.face_vertices(f).map(|v| self.position(v));
        0.5 * double_area(a, b, c)
    }

    /// Unit normal of face `f` (right-handed with the corner order), or zero
    /// for a degenerate face.
    pub fn face_normal(&self, f: FaceId) -> [f64; 3] {
        let [a, b, c] = self.face_vertices(f).map(|v| self.position(v));
        let n = cross(sub(b, a), sub(c, a));
        let l = norm(n);
        if l > 0.0 {
            [n[0] / l, n[1] / l, n[2] / l]
        } else {
            [0.0; 3]
        }
    }

    /// Total surface area.
    pub fn total_area(&self) -> f64 {
        self.faces().map(|f| self.face_area(f)).sum()
    }

    /// Length of the edge of `h`.
    pub fn edge_length(&self, h: HalfedgeId) -> f64 {
        norm(sub(
            self.position(self.dest(h)),
            self.position(self.origin(h)),
        ))
    }

    /// Axis-aligned bounding box `(min, max)` of the vertices (both zero
    /// for an empty mesh).
    pub fn bounding_box(&self) -> ([f64; 3], [f64; 3]) {
        if self.positions.is_empty() {
            return ([0.0; 3], [0.0; 3]);
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }

    /// Mean length of the edges, each edge counted once (0 for an empty
    /// mesh).
    pub fn mean_edge_length(&self) -> f64 {
        let mut sum = 0.0;
        let mut n = 0usize;
        for h in self.halfedges() {
            // Count an interior edge from its lower halfedge only.
            if self.twin(h).is_none_or(|t| t > h) {
                sum += self.edge_length(h);
                n += 1;
            }
        }
        if n == 0 {
            0.0
        } else {
            sum / n as f64
        }
    }

    // ----- topology summaries --------------------------------------------

    /// Number of boundary halfedges (each boundary or crack edge side).
    pub fn n_boundary_halfedges(&self) -> usize {
        self.he_twin.iter().filter(|&&t| t == INVALID).count()
    }

    /// Number of closed boundary loops.
    pub fn boundary_loops(&self) -> usize {
        let mut seen = vec![false; self.n_halfedges()];
        let mut loops = 0;
        for h in self.halfedges() {
            if seen[h.idx()] || !self.is_boundary_halfedge(h) {
                continue;
            }
            loops += 1;
            let mut x = h;
            // The next boundary halfedge is the boundary outgoing halfedge of
            // the destination; bounded in case the mesh is invalid.
            for _ in 0..self.n_halfedges() {
                if seen[x.idx()] {
                    break;
                }
                seen[x.idx()] = true;
                x = self.vertex_halfedge(self.dest(x));
                if !self.is_boundary_halfedge(x) {
                    break;
                }
            }
        }
        loops
    }

    /// Connected components through shared edges: the number of components
    /// and the component of every face (numbered by lowest face).
    pub fn connected_components(&self) -> (usize, Vec<u32>) {
        let mut comp = vec![INVALID; self.n_faces()];
        let mut n = 0u32;
        let mut stack = Vec::new();
        for f in 0..self.n_faces() {
            if comp[f] != INVALID {
                continue;
            }
            comp[f] = n;
            stack.push(f as u32);
            while let Some(g) = stack.pop() {
                for k in 0..3 {
                    let t = self.he_twin[g as usize * 3 + k];
                    if t != INVALID {
                        let o = (t / 3) as usize;
                        if comp[o] == INVALID {
                            comp[o] = n;
                            stack.push(o as u32);
                        }
                    }
                }
            }
            n += 1;
        }
        (n as usize, comp)
    }

    /// Whether the edge of `h` is interior (has faces on both sides).
    pub fn is_interior_edge(&self, h: HalfedgeId) -> bool {
        !self.is_boundary_halfedge(h)
    }

    /// Marks the mesh as modified.
    #[inline]
    pub(super) fn bump(&mut self) {
        self.generation += 1;
    }
}

/// Iterator over a vertex's outgoing halfedges, see
/// [`SimMesh::vertex_outgoing`].
#[derive(Clone, Debug)]
pub struct VertexOutgoing<'a> {
    mesh: &'a SimMesh,
    start: HalfedgeId,
    cur: Option<HalfedgeId>,
    steps: usize,
}

impl Iterator for VertexOutgoing<'_> {
    type Item = HalfedgeId;

    fn next(&mut self) -> Option<HalfedgeId> {
        let h = self.cur?;
        self.steps += 1;
        // Guard against a corrupted mesh looping forever.
        self.cur = if self.steps > self.mesh.n_halfedges() {
            None
        } else {
            self.mesh
                .twin(self.mesh.prev(h))
                .filter(|&n| n != self.start)
        };
        Some(h)
    }
}
