//! Full invariant check of a [`SimMesh`].

use super::error::{InvariantFault as Fault, MeshError};
use super::halfedge::SimMesh;
use super::ids::INVALID;

macro_rules! ensure {
    ($cond:expr, $fault:expr) => {
        if !$cond {
            return Err(MeshError::Invariant { fault: $fault });
        }
    };
}

impl SimMesh {
    /// Checks every invariant of the mesh: array lengths, ids in range,
    /// finite positions, faces with three distinct vertices, twin symmetry
    /// and opposite direction, no two halfedges with the same (origin,
    /// dest), and for every vertex: its outgoing halfedge leaves it, is a
    /// boundary halfedge if the vertex is on a boundary, and its incident
    /// faces form a single fan reached from that halfedge.
    ///
    /// `next^3 = id` and per-face halfedges hold by construction (halfedge
    /// `3f + k` belongs to face `f`). Costs `O(n log n)`.
    ///
    /// # Errors
    /// [`MeshError::Invariant`] describing the first violation found.
    pub fn validate(&self) -> Result<(), MeshError> {
        self.validate_lengths()?;
        self.validate_ranges()?;
        self.validate_faces_and_twins()?;
        self.validate_directed_edges()?;
        self.validate_fans()
    }

    /// Checks the arrays' lengths against each other, and that no crack
    /// halfedge has a twin.
    fn validate_lengths(&self) -> Result<(), MeshError> {
        let nv = self.n_vertices();
        let nf = self.face_groups.len();
        let nh = self.he_origin.len();
        let nw = self.wedges.len();

        // Lengths.
        ensure!(
            nh == 3 * nf,
            Fault::HalfedgeCount {
                halfedges: nh,
                faces: nf,
            }
        );
        let arrays = [
            ("he_crack", self.he_crack.len(), nh, "halfedges"),
            ("he_twin", self.he_twin.len(), nh, "halfedges"),
            ("he_wedge", self.he_wedge.len(), nh, "halfedges"),
            ("face_source", self.face_source.len(), nf, "faces"),
            ("vertex_halfedge", self.vertex_halfedge.len(), nv, "vertices"),
            ("vertex_source", self.vertex_source.len(), nv, "vertices"),
            ("vertex_parent", self.vertex_parent.len(), nv, "vertices"),
        ];
        for (array, len, count, elements) in arrays {
            ensure!(
                len == count,
                Fault::ArrayLength {
                    array,
                    len,
                    count,
                    elements,
                }
            );
        }
        ensure!(
            (0..nh).all(|h| !self.he_crack[h] || self.he_twin[h] == INVALID),
            Fault::CrackTwin
        );
        ensure!(
            self.wedges.is_consistent(),
            Fault::WedgeChannels { wedges: nw }
        );
        ensure!(nh < INVALID as usize, Fault::TooManyHalfedges);
        Ok(())
    }

    /// Checks that positions are finite and every id a vertex or halfedge
    /// holds is in range.
    fn validate_ranges(&self) -> Result<(), MeshError> {
        let nv = self.n_vertices();
        let nh = self.he_origin.len();
        let nw = self.wedges.len();

        // Per-element ranges.
        for (v, p) in self.positions.iter().enumerate() {
            ensure!(
                p.iter().all(|x| x.is_finite()),
                Fault::NonFinite {
                    vertex: v,
                    position: *p,
                }
            );
            let range = |field, value: u32, count| Fault::OutOfRange {
                element: "vertex",
                index: v,
                field,
                value,
                count,
            };
            let o = self.vertex_halfedge[v];
            ensure!((o as usize) < nh, range("outgoing halfedge", o, nh));
            let parent = self.vertex_parent[v];
            ensure!((parent as usize) < nv, range("parent", parent, nv));
        }
        for h in 0..nh {
            let range = |field, value: u32, count| Fault::OutOfRange {
                element: "halfedge",
                index: h,
                field,
                value,
                count,
            };
            let o = self.he_origin[h];
            ensure!((o as usize) < nv, range("origin", o, nv));
            let w = self.he_wedge[h];
            ensure!((w as usize) < nw, range("wedge", w, nw));
            let t = self.he_twin[h];
            ensure!(t == INVALID || (t as usize) < nh, range("twin", t, nh));
        }
        Ok(())
    }

    /// Checks that faces have three distinct vertices and twins are
    /// symmetric and opposite.
    fn validate_faces_and_twins(&self) -> Result<(), MeshError> {
        // Faces and twins.
        for f in self.faces() {
            let [a, b, c] = self.face_vertices(f);
            ensure!(
                a != b && b != c && a != c,
                Fault::RepeatedVertex {
                    face: f,
                    vertices: [a, b, c],
                }
            );
        }
        for h in self.halfedges() {
            ensure!(
                self.next(self.next(self.next(h))) == h && self.face(self.next(h)) == self.face(h),
                Fault::NextCycle(h)
            );
            if let Some(t) = self.twin(h) {
                ensure!(t != h, Fault::SelfTwin(h));
                ensure!(
                    self.twin(t) == Some(h),
                    Fault::TwinAsymmetric {
                        halfedge: h,
                        twin: t,
                    }
                );
                ensure!(
                    self.origin(t) == self.dest(h) && self.dest(t) == self.origin(h),
                    Fault::TwinNotOpposite {
                        halfedge: h,
                        ends: [self.origin(h), self.dest(h)],
                        twin: t,
                        twin_ends: [self.origin(t), self.dest(t)],
                    }
                );
            }
        }
        Ok(())
    }

    /// Checks that no two halfedges share (origin, dest).
    fn validate_directed_edges(&self) -> Result<(), MeshError> {
        // Unique directed edges.
        let mut keys: Vec<(u32, u32, u32)> = self
            .halfedges()
            .map(|h| (self.origin(h).0, self.dest(h).0, h.0))
            .collect();
        keys.sort_unstable();
        for w in keys.windows(2) {
            ensure!(
                (w[0].0, w[0].1) != (w[1].0, w[1].1),
                Fault::DuplicateEdge {
                    halfedges: [w[0].2, w[1].2],
                    from: w[0].0,
                    to: w[0].1,
                }
            );
        }
        Ok(())
    }

    /// Checks every vertex's fan: its outgoing halfedge leaves it (a
    /// boundary one on a boundary) and the rotation from it visits all its
    /// outgoing halfedges.
    fn validate_fans(&self) -> Result<(), MeshError> {
        let nv = self.n_vertices();
        // Fans: from each vertex's outgoing halfedge, the rotation must
        // visit all its outgoing halfedges.
        let mut degree = vec![0u32; nv];
        let mut boundary_out = vec![0u32; nv];
        for h in self.halfedges() {
            let v = self.origin(h).idx();
            degree[v] += 1;
            if self.is_boundary_halfedge(h) {
                boundary_out[v] += 1;
            }
        }
        for v in self.vertices() {
            let start = self.vertex_halfedge(v);
            ensure!(
                self.origin(start) == v,
                Fault::OutgoingElsewhere {
                    vertex: v,
                    halfedge: start,
                    leaves: self.origin(start),
                }
            );
            let i = v.idx();
            ensure!(
                boundary_out[i] <= 1,
                Fault::SeveralFans {
                    vertex: v,
                    count: boundary_out[i],
                }
            );
            ensure!(
                boundary_out[i] == 0 || self.is_boundary_halfedge(start),
                Fault::BoundaryOutgoing {
                    vertex: v,
                    halfedge: start,
                }
            );
            let mut count = 0u32;
            let mut x = start;
            loop {
                ensure!(
                    self.origin(x) == v,
                    Fault::FanStray {
                        vertex: v,
                        halfedge: x,
                        leaves: self.origin(x),
                    }
                );
                count += 1;
                ensure!(count <= degree[i], Fault::FanOpen(v));
                match self.twin(self.prev(x)) {
                    None => {
                        ensure!(
                            self.is_boundary_halfedge(start),
                            Fault::InteriorFanEnds {
                                vertex: v,
                                halfedge: x,
                            }
                        );
                        break;
                    }
                    Some(y) if y == start => break,
                    Some(y) => x = y,
                }
            }
            ensure!(
                count == degree[i],
                Fault::NonManifoldFan {
                    vertex: v,
                    degree: degree[i],
                    fan: count,
                }
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::mesh::shapes::{build, grid_input};
    use crate::mesh::{MeshError, VertexId};

    fn expect_invariant(m: &crate::mesh::SimMesh, what: &str) {
        match m.validate() {
            Err(MeshError::Invariant { fault }) => {
                let msg = fault.to_string();
                assert!(msg.contains(what), "{msg}");
            }
            other => panic!("expected invariant error containing {what:?}, got {other:?}"),
        }
    }

    #[test]
    fn detects_corruption() {
        let (m, _) = build(&grid_input(2, 2));
        m.validate().unwrap();

        let mut c = m.clone();
        let h = c.he_twin.iter().position(|&t| t != super::INVALID).unwrap();
        c.he_twin[h] = super::INVALID;
        expect_invariant(&c, "twin");

        let mut c = m.clone();
        c.he_origin[0] = c.he_origin[1];
        assert!(c.validate().is_err());

        let mut c = m.clone();
        let v = c.he_origin[0] as usize;
        c.vertex_halfedge[v] = 1;
        expect_invariant(&c, "outgoing halfedge");

        let mut c = m.clone();
        c.positions[0][2] = f64::NAN;
        expect_invariant(&c, "non-finite");

        let mut c = m.clone();
        c.he_wedge[4] = 1000;
        expect_invariant(&c, "wedge");

        let mut c = m.clone();
        c.face_source.pop();
        expect_invariant(&c, "face_source");

        // Interior vertex whose outgoing halfedge is interior but which sits
        // on a boundary: point a boundary vertex at an interior halfedge.
        let mut c = m.clone();
        let v = VertexId(0);
        let interior = c
            .vertex_outgoing(v)
            .find(|&h| !c.is_boundary_halfedge(h))
            .unwrap();
        c.vertex_halfedge[0] = interior.0;
        expect_invariant(&c, "boundary");
    }
}
