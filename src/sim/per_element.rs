//! Per-node and per-face values that grow with the mesh, as
//! geometry-central's `VertexData<T>` / `FaceData<T>` do: each array is
//! declared once, with the rule that gives a node or face the mesh gains
//! its value, and the run's state applies every array's rule in one walk
//! ([`Grows`]) when a crack has changed the mesh.
//!
//! A crack changes the mesh in three ways an array has a rule for:
//! - it *copies* a node to open the crack ([`SimMesh::vertex_parent`] is
//!   the original): [`Born::Parent`] takes the original's value;
//! - it *inserts* a node on an edge it crosses: [`PerNode::on_edges`]
//!   settles its value from the edge's ends ([`PerNode::lerp_on_edges`]
//!   interpolates by the node's place along the edge);
//! - it *splits* a face: [`PerFace::copied_on_split`] gives the new face
//!   its parent's value.
//!
//! The values are read and written as a slice (`Deref`); the length is
//! the mesh's, changed only by [`Grows::grow`].

use crate::math::GrowGently;
use crate::math::{v3, Sym3};
use crate::mesh::{SimMesh, VertexId};
use crate::sim::crack::CrackEvent;
use std::ops::{Deref, DerefMut};

/// A value computed for a new element from the mesh, its index and (for a
/// node's copy) the original's value.
type Compute<T> = Box<dyn Fn(&SimMesh, u32, Option<&T>) -> T + Send + Sync>;

/// What a node or face the mesh gains starts with.
pub(in crate::sim) enum Born<T> {
    /// This value.
    Value(T),
    /// A node's copy takes the original's value; any other new node (or a
    /// face) this value.
    Parent(T),
    /// Computed (see [`Compute`]).
    With(Compute<T>),
}

impl<T: Clone> Born<T> {
    fn value(&self, mesh: &SimMesh, i: u32, parent: Option<&T>) -> T {
        match self {
            Born::Value(x) => x.clone(),
            Born::Parent(x) => parent.unwrap_or(x).clone(),
            Born::With(f) => f(mesh, i, parent),
        }
    }
}

/// A node inserted on an edge: the values at the edge's ends, its place
/// along the edge (0 at `a`, 1 at `b`), whether the edge was a boundary
/// edge (the mesh's border or an earlier crack), and its value so far.
pub(in crate::sim) struct OnEdge<'a, T> {
    pub(in crate::sim) a: &'a T,
    pub(in crate::sim) b: &'a T,
    pub(in crate::sim) t: f64,
    pub(in crate::sim) border: bool,
    pub(in crate::sim) current: &'a T,
}

type Settle<T> = Box<dyn Fn(OnEdge<'_, T>) -> T + Send + Sync>;

/// Values interpolated along an edge.
pub(in crate::sim) trait Lerp {
    /// `a` at `t = 0`, `b` at `t = 1`.
    fn lerp(a: &Self, b: &Self, t: f64) -> Self;
}

impl Lerp for [f64; 3] {
    fn lerp(a: &Self, b: &Self, t: f64) -> Self {
        v3::add(v3::scale(*a, 1.0 - t), v3::scale(*b, t))
    }
}

impl Lerp for Sym3 {
    fn lerp(a: &Self, b: &Self, t: f64) -> Self {
        *a * (1.0 - t) + *b * t
    }
}

/// An array that follows the mesh's edits.
pub(in crate::sim) trait Grows {
    /// Give every node or face the mesh has gained a value by the rule.
    fn grow(&mut self, mesh: &SimMesh);
    /// Settle the nodes `ev` inserted on edges (after [`Grows::grow`]).
    fn settle_inserted(&mut self, _mesh: &SimMesh, _ev: &CrackEvent) {}
    /// Settle the faces `ev` split off (after [`Grows::grow`]).
    fn settle_split(&mut self, _ev: &CrackEvent) {}
}

impl<G: Grows> Grows for Option<G> {
    fn grow(&mut self, mesh: &SimMesh) {
        if let Some(g) = self {
            g.grow(mesh);
        }
    }
    fn settle_inserted(&mut self, mesh: &SimMesh, ev: &CrackEvent) {
        if let Some(g) = self {
            g.settle_inserted(mesh, ev);
        }
    }
    fn settle_split(&mut self, ev: &CrackEvent) {
        if let Some(g) = self {
            g.settle_split(ev);
        }
    }
}

/// One value per node of the mesh.
pub(in crate::sim) struct PerNode<T> {
    values: Vec<T>,
    born: Born<T>,
    on_edges: Option<Settle<T>>,
}

impl<T: Clone> PerNode<T> {
    /// `values` for the nodes the mesh has (possibly none yet: the first
    /// [`Grows::grow`] fills them), new nodes by `born`; a node inserted on
    /// an edge keeps what `born` gave it.
    pub(in crate::sim) fn new(values: Vec<T>, born: Born<T>) -> Self {
        PerNode {
            values,
            born,
            on_edges: None,
        }
    }

    /// A node inserted on an edge takes what `settle` makes of the edge.
    pub(in crate::sim) fn on_edges(
        mut self,
        settle: impl Fn(OnEdge<'_, T>) -> T + Send + Sync + 'static,
    ) -> Self {
        self.on_edges = Some(Box::new(settle));
        self
    }
}

impl<T: Clone + Lerp + 'static> PerNode<T> {
    /// A node inserted on an edge is interpolated between the edge's ends.
    pub(in crate::sim) fn lerp_on_edges(self) -> Self {
        self.on_edges(|e| T::lerp(e.a, e.b, e.t))
    }
}

impl<T: Clone> Grows for PerNode<T> {
    fn grow(&mut self, mesh: &SimMesh) {
        let n = mesh.n_vertices();
        self.values.reserve_gently(n);
        while self.values.len() < n {
            let i = self.values.len();
            let v = VertexId(i as u32);
            let parent = mesh.vertex_parent(v);
            let from = (parent != v)
                .then(|| self.values.get(parent.idx()))
                .flatten();
            let x = self.born.value(mesh, i as u32, from);
            self.values.push(x);
        }
    }

    fn settle_inserted(&mut self, mesh: &SimMesh, ev: &CrackEvent) {
        let Some(settle) = &self.on_edges else {
            return;
        };
        for (&q, &(a, b, border)) in ev.inserted.iter().zip(&ev.inserted_on) {
            let (pa, pb, pq) = (mesh.position(a), mesh.position(b), mesh.position(q));
            let l = v3::norm(v3::sub(pb, pa));
            let t = if l > 0.0 {
                (v3::norm(v3::sub(pq, pa)) / l).clamp(0.0, 1.0)
            } else {
                0.5
            };
            let x = settle(OnEdge {
                a: &self.values[a.idx()],
                b: &self.values[b.idx()],
                t,
                border,
                current: &self.values[q.idx()],
            });
            self.values[q.idx()] = x;
        }
    }
}

/// One value per face of the mesh.
pub(in crate::sim) struct PerFace<T> {
    values: Vec<T>,
    born: Born<T>,
    /// A face split off takes its parent's value.
    copied_on_split: bool,
    /// Whether the array follows the mesh: an array made empty means "no
    /// such values" (every reader takes its default) and stays empty.
    follows: bool,
}

impl<T: Clone> PerFace<T> {
    /// `values` for the faces the mesh has (none yet: the first
    /// [`Grows::grow`] fills them), new faces by `born`.
    pub(in crate::sim) fn new(values: Vec<T>, born: Born<T>) -> Self {
        PerFace {
            values,
            born,
            copied_on_split: false,
            follows: true,
        }
    }

    /// `values`, or no values at all (left empty whatever the mesh does)
    /// when `values` is empty.
    pub(in crate::sim) fn optional(values: Vec<T>, born: Born<T>) -> Self {
        let follows = !values.is_empty();
        PerFace {
            follows,
            ..PerFace::new(values, born)
        }
    }

    /// Move the values out, leaving none until [`PerFace::replace`].
    pub(in crate::sim) fn take(&mut self) -> Vec<T> {
        std::mem::take(&mut self.values)
    }

    /// A face a crack splits off takes its parent's value.
    pub(in crate::sim) fn copied_on_split(mut self) -> Self {
        self.copied_on_split = true;
        self
    }
}

impl<T: Clone> Grows for PerFace<T> {
    fn grow(&mut self, mesh: &SimMesh) {
        if !self.follows {
            return;
        }
        let n = mesh.n_faces();
        self.values.reserve_gently(n);
        while self.values.len() < n {
            let i = self.values.len() as u32;
            let x = self.born.value(mesh, i, None);
            self.values.push(x);
        }
    }

    fn settle_split(&mut self, ev: &CrackEvent) {
        if !self.copied_on_split || self.values.is_empty() {
            return;
        }
        for &(parent, child) in &ev.split_faces {
            self.values[child.idx()] = self.values[parent.idx()].clone();
        }
    }
}

macro_rules! as_slice {
    ($t:ident) => {
        impl<T> $t<T> {
            /// Put `values` in place of the values (one per element: they
            /// are moved out and back around a step that needs them apart
            /// from the state) and return the old ones.
            pub(in crate::sim) fn replace(&mut self, values: Vec<T>) -> Vec<T> {
                std::mem::replace(&mut self.values, values)
            }
            /// The values as a vector.
            pub(in crate::sim) fn into_values(self) -> Vec<T> {
                self.values
            }
        }
        impl<'a, T> IntoIterator for &'a $t<T> {
            type Item = &'a T;
            type IntoIter = std::slice::Iter<'a, T>;
            fn into_iter(self) -> Self::IntoIter {
                self.values.iter()
            }
        }
        impl<T> Deref for $t<T> {
            type Target = [T];
            fn deref(&self) -> &[T] {
                &self.values
            }
        }
        impl<T> DerefMut for $t<T> {
            fn deref_mut(&mut self) -> &mut [T] {
                &mut self.values
            }
        }
    };
}
as_slice!(PerNode);
as_slice!(PerFace);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::FaceId;

    #[test]
    fn new_nodes_and_faces_follow_their_rules() {
        let (mesh, _) = crate::mesh::shapes::build(&crate::mesh::shapes::grid_input(3, 3));
        let mut a = PerNode::new(Vec::new(), Born::Value(7u8));
        let mut b: PerNode<f64> = PerNode::new(
            Vec::new(),
            Born::With(Box::new(|m: &SimMesh, i, _| m.position(VertexId(i))[0])),
        );
        let mut f = PerFace::new(vec![1.0, 2.0], Born::Value(0.5)).copied_on_split();
        let mut off: PerFace<f64> = PerFace::optional(Vec::new(), Born::Value(1.0));
        for g in [&mut a as &mut dyn Grows, &mut b, &mut f, &mut off] {
            g.grow(&mesh);
        }
        assert_eq!(a.len(), mesh.n_vertices());
        assert!(a.iter().all(|&x| x == 7));
        assert_eq!(b[5], mesh.position(VertexId(5))[0]);
        assert_eq!(f.len(), mesh.n_faces());
        assert_eq!((f[0], f[1], f[2]), (1.0, 2.0, 0.5));
        assert!(off.is_empty(), "an array without values stays without");
        let ev = CrackEvent {
            split_faces: vec![(FaceId(1), FaceId(3))],
            ..Default::default()
        };
        f.settle_split(&ev);
        assert_eq!(f[3], 2.0);
    }

    #[test]
    fn inserted_nodes_are_interpolated_along_their_edge() {
        let mut mesh = crate::mesh::shapes::build(&crate::mesh::shapes::grid_input(2, 2)).0;
        let mut d = PerNode::new(Vec::new(), Born::Parent([0.0; 3])).lerp_on_edges();
        d.grow(&mesh);
        for (v, x) in d.iter_mut().enumerate() {
            *x = [v as f64, 0.0, 0.0];
        }
        let (a, b) = (VertexId(0), VertexId(1));
        let h = mesh
            .vertex_outgoing(a)
            .find(|&h| mesh.dest(h) == b)
            .expect("edge 0-1");
        let q = mesh.split_edge(h, 0.25).expect("split").vertex;
        d.grow(&mesh);
        let ev = CrackEvent {
            inserted: vec![q],
            inserted_on: vec![(a, b, true)],
            ..Default::default()
        };
        d.settle_inserted(&mesh, &ev);
        assert!((d[q.idx()][0] - 0.25).abs() < 1e-12, "{:?}", d[q.idx()]);
    }
}
