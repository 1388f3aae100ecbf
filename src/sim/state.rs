//! The run's state that grows with the mesh: per-node and per-face arrays
//! ([`PerNode`], [`PerFace`]: each declared in [`State::new`] with the rule
//! that gives new elements their values), the caches of a round, and
//! [`apply_event`], which applies one crack's mutation events to every
//! array ([`State::arrays`] lists them once).

use crate::math::GrowGently;
use crate::geometry::element::Element;
use crate::math::{hash_unit, v3, Sym3};
use crate::mesh::{FaceId, SimMesh, VertexId};
use crate::sim::energy;
use crate::sim::forces::{face_points, Elements, Fans};
use crate::sim::per_element::{Born, Grows, PerFace, PerNode};
use crate::sim::Observer;
use crate::sim::SimParams;
use crate::sim::SimReport;
use crate::sim::Snapshot;
use rayon::prelude::*;
use std::sync::Arc;

/// Simulation state that grows with the mesh.
pub(in crate::sim) struct State {
    pub(in crate::sim) els: Elements,
    pub(in crate::sim) stress: PerFace<Sym3>,
    pub(in crate::sim) residual: PerNode<Sym3>,
    pub(in crate::sim) fixed: PerNode<bool>,
    /// Load multiplier per face (seeded noise).
    pub(in crate::sim) shrink_scale: PerFace<f64>,
    /// Evolution of the stress field per unit time, per face (children copy
    /// their parent's).
    pub(in crate::sim) evolve: PerFace<Sym3>,
    /// Factor on each face's contribution to node separation (empty: 1;
    /// children copy their parent's).
    pub(in crate::sim) sep_scale: PerFace<f64>,
    /// Accumulated virtual displacement per node (for crack width later).
    pub(in crate::sim) displacement: PerNode<[f64; 3]>,
    /// Time each node first lay on a crack (NaN: never).
    pub(in crate::sim) crack_time: PerNode<f64>,
    /// Cracks meeting at each node, indexed by the node's root (all copies
    /// of a crack node share it): 2 along a crack, 3 at a T.
    pub(in crate::sim) crack_degree: PerNode<u8>,
    pub(in crate::sim) unit: f64,
    /// Scratch: per-corner element forces of the current step.
    pub(in crate::sim) corner: Vec<[f64; 3]>,
    /// The last implicit solve's solution: the next solve starts from it.
    pub(in crate::sim) warm: Vec<[f64; 3]>,
    /// Node visits of eigen-diffusion (passes times nodes), for the report.
    pub(in crate::sim) diffusion_work: usize,
    /// What relaxation rounds reuse while the mesh does not change.
    pub(in crate::sim) cache: RoundCache,
    /// Working memory of the implicit rounds, kept so that fresh memory is
    /// not paged in every round.
    pub(in crate::sim) implicit: ImplicitScratch,
    /// With eigen-diffusion: every node's separation tensor, taken from
    /// the stress once after the first round and then changed only by
    /// cracking and diffusion (`None`: computed from the stress).
    pub(in crate::sim) frozen: Option<PerNode<Sym3>>,
    /// A bonded film's state, when the run has a cell size.
    pub(in crate::sim) film: Option<crate::sim::film::Film>,
    /// Where each recorded crack segment is in the report's `segments`,
    /// by its ends' positions (see [`segment_key`]), and the piece that
    /// follows it along the segment it was split from.
    pub(in crate::sim) segment_at: SegmentIndex,
}

/// Recorded crack segments by their ends' positions, and per record the
/// next piece of the segment it was split from (`usize::MAX`: none).
#[derive(Default)]
pub(in crate::sim) struct SegmentIndex {
    at: std::collections::HashMap<[[u64; 3]; 2], usize>,
    next: Vec<usize>,
}

impl SegmentIndex {
    /// Record a new segment of the report (at index `i`).
    fn add(&mut self, a: [f64; 3], b: [f64; 3], i: usize) {
        self.at.insert(segment_key(a, b), i);
        self.next.resize_gently(i + 1, usize::MAX);
    }

    /// The report's segments (and times) in the order they were recorded,
    /// each split one's pieces in place of it, one after the other along
    /// it: chronological, and a crack's segments still follow each other.
    pub(in crate::sim) fn in_record_order(&self, report: &mut SimReport) {
        let n = report.segments.len();
        if self.next.len() != n || self.next.iter().all(|&x| x == usize::MAX) {
            return;
        }
        let mut piece = vec![false; n];
        for &x in &self.next {
            if x != usize::MAX {
                piece[x] = true;
            }
        }
        let mut order = Vec::with_capacity(n);
        for head in (0..n).filter(|&i| !piece[i]) {
            let mut i = head;
            while i != usize::MAX {
                order.push(i);
                i = self.next[i];
            }
        }
        report.segments = order.iter().map(|&i| report.segments[i]).collect();
        report.segment_times = order.iter().map(|&i| report.segment_times[i]).collect();
    }
}

/// A segment's key: its ends' position bits, in order.
fn segment_key(a: [f64; 3], b: [f64; 3]) -> [[u64; 3]; 2] {
    let (ka, kb) = (
        a.map(|x| (x + 0.0).to_bits()),
        b.map(|x| (x + 0.0).to_bits()),
    );
    if ka <= kb {
        [ka, kb]
    } else {
        [kb, ka]
    }
}

/// A later crack ran into the recorded segment `a`-`b` and split its edge
/// at `q`: the record is split there too, so every junction is an end of
/// the segments that meet at it (a stem ends where the crack it meets has
/// a vertex, not in the middle of its segment).
fn split_segment(
    index: &mut SegmentIndex,
    report: &mut SimReport,
    a: [f64; 3],
    b: [f64; 3],
    q: [f64; 3],
) {
    let Some(i) = index.at.remove(&segment_key(a, b)) else {
        return;
    };
    let [p0, p1] = report.segments[i];
    let time = report.segment_times[i];
    let j = report.segments.len();
    report.segments[i] = [p0, q];
    index.at.insert(segment_key(p0, q), i);
    index.add(q, p1, j);
    index.next[j] = index.next[i];
    index.next[i] = j;
    report.segments.push([q, p1]);
    report.segment_times.push(time);
}

/// Working memory of the implicit rounds.
#[derive(Default)]
pub(in crate::sim) struct ImplicitScratch {
    pub(in crate::sim) cg: crate::sim::implicit::CgScratch,
    pub(in crate::sim) tangent: crate::sim::tangent::TangentSystem,
    pub(in crate::sim) rhs: Vec<[f64; 3]>,
    pub(in crate::sim) r: Vec<[f64; 3]>,
    pub(in crate::sim) ax: Vec<[f64; 3]>,
}

/// Earlier implicit solutions kept for the next solve's start.
pub(in crate::sim) const HISTORY: usize = 3;

/// What relaxation rounds reuse while the mesh does not change: built from
/// the mesh and the elements, and rebuilt when
/// [`SimMesh::generation`] moves on (a crack changes the mesh, its
/// elements and its fixed nodes together).
#[derive(Default)]
pub(in crate::sim) struct RoundCache {
    /// The mesh generation the cache was built for.
    pub(in crate::sim) generation: Option<u64>,
    pub(in crate::sim) fans: Option<Arc<Fans>>,
    /// Node normals when bonded (empty otherwise).
    pub(in crate::sim) normals: Vec<[f64; 3]>,
    /// Per-node stiffness bounds (explicit integrators).
    pub(in crate::sim) bounds: Option<Vec<f64>>,
    /// Implicit: the preconditioner for the step it was built for.
    pub(in crate::sim) pre: Option<(f64, Vec<Sym3>)>,
    /// Implicit: the projected node force of one unit of load time.
    pub(in crate::sim) load_force: Option<Vec<[f64; 3]>>,
    /// Implicit: earlier solutions of the system with the given step, and
    /// their products.
    pub(in crate::sim) history: Option<(f64, crate::sim::implicit::History)>,
    /// The projected node force at the current stress, when a
    /// backward-Euler round left it (gathered from the corner forces its
    /// last stress update wrote).
    pub(in crate::sim) force: Option<Vec<[f64; 3]>>,
}

impl RoundCache {
    /// Make the cache that of `mesh` as it is now.
    pub(in crate::sim) fn refresh(&mut self, mesh: &SimMesh, els: &Elements, bonded: bool) {
        let generation = mesh.generation();
        if self.generation == Some(generation)
            && self
                .fans
                .as_ref()
                .is_some_and(|f| f.n_vertices() == mesh.n_vertices())
        {
            return;
        }
        // The old cache goes first (it is as large as the new one).
        *self = RoundCache::default();
        let fans = Fans::new(mesh);
        let normals = if bonded {
            node_normals(&fans, els)
        } else {
            Vec::new()
        };
        *self = RoundCache {
            generation: Some(generation),
            fans: Some(Arc::new(fans)),
            normals,
            ..RoundCache::default()
        };
    }

    pub(in crate::sim) fn fans(&self) -> Arc<Fans> {
        Arc::clone(self.fans.as_ref().expect("refreshed"))
    }
}

impl State {
    pub(in crate::sim) fn element(&self, mesh: &SimMesh, f: FaceId) -> Option<Element> {
        let p = face_points(mesh, f).map(|q| v3::scale(q, 1.0 / self.unit));
        Element::new(p, self.els.clamp)
    }

    pub(in crate::sim) fn in_fixed_group(mesh: &SimMesh, params: &SimParams, v: VertexId) -> bool {
        in_groups(mesh, &params.fixed_groups, v)
    }

    /// The per-node and per-face arrays of a run on `mesh`, each with the
    /// rule that gives new nodes and faces their values: `stress`, `evolve`
    /// and `sep_scale` as given (the last two may be empty: none), the
    /// others filled by the first [`State::grow`].
    pub(in crate::sim) fn new(
        mesh: &SimMesh,
        params: &SimParams,
        faces: [Vec<Sym3>; 2],
        sep_scale: Vec<f64>,
        film: Option<crate::sim::film::Film>,
        els: Elements,
        unit: f64,
    ) -> State {
        let [stress, evolve] = faces;
        // A world-space field: the same wherever the triangles are.
        let noise_at = film
            .as_ref()
            .map(|film| crate::sim::film::NOISE_SPACING * film.cell);
        let (seed, noise) = (params.seed, params.noise);
        let shrink_scale = Born::With(Box::new(move |mesh: &SimMesh, f, _: Option<&f64>| {
            let f = FaceId(f);
            let u = match noise_at {
                Some(spacing) => {
                    let c = face_points(mesh, f)
                        .iter()
                        .fold([0.0; 3], |a, p| v3::add(a, *p));
                    crate::math::value_noise(seed, v3::scale(c, 1.0 / (3.0 * spacing)))
                }
                None => hash_unit(seed, u64::from(mesh.face_source(f))),
            };
            1.0 + noise * u
        }));
        // A copy is fixed with its original, any new node in a fixed
        // group; a node inserted on a fixed border edge is fixed.
        let groups = params.fixed_groups.clone();
        let fixed_boundary = params.fixed_boundary;
        let initially = mesh
            .vertices()
            .map(|v| {
                (fixed_boundary && mesh.is_boundary_vertex(v))
                    || State::in_fixed_group(mesh, params, v)
            })
            .collect();
        let fixed = PerNode::new(
            initially,
            Born::With(Box::new(move |mesh: &SimMesh, v, parent: Option<&bool>| {
                parent.copied().unwrap_or(false) || in_groups(mesh, &groups, VertexId(v))
            })),
        )
        .on_edges(move |e| (e.border && *e.a && *e.b && fixed_boundary) || *e.current);
        State {
            els,
            stress: PerFace::new(stress, Born::Value(Sym3::ZERO)).copied_on_split(),
            residual: PerNode::new(Vec::new(), Born::Value(Sym3::ZERO)),
            frozen: None,
            fixed,
            shrink_scale: PerFace::new(Vec::new(), shrink_scale),
            evolve: PerFace::optional(evolve, Born::Value(Sym3::ZERO)).copied_on_split(),
            sep_scale: PerFace::optional(sep_scale, Born::Value(1.0)).copied_on_split(),
            displacement: PerNode::new(Vec::new(), Born::Parent([0.0; 3])).lerp_on_edges(),
            crack_time: PerNode::new(Vec::new(), Born::Parent(f64::NAN)),
            crack_degree: PerNode::new(Vec::new(), Born::Value(0)),
            unit,
            corner: Vec::new(),
            warm: Vec::new(),
            diffusion_work: 0,
            cache: RoundCache::default(),
            implicit: ImplicitScratch::default(),
            film,
            segment_at: Default::default(),
        }
    }

    /// Every per-node and per-face array that follows the mesh: the one
    /// list [`State::grow`] and [`apply_event`] walk.
    fn arrays(&mut self) -> [&mut dyn Grows; 10] {
        [
            &mut self.stress,
            &mut self.residual,
            &mut self.frozen,
            &mut self.fixed,
            &mut self.shrink_scale,
            &mut self.evolve,
            &mut self.sep_scale,
            &mut self.displacement,
            &mut self.crack_time,
            &mut self.crack_degree,
        ]
    }

    /// Take the separation tensors of every node for eigen-diffusion
    /// (see `frozen`); a copy takes its original's, a node inserted on an
    /// edge is interpolated.
    pub(in crate::sim) fn freeze(&mut self, tensors: Vec<Sym3>) {
        self.frozen = Some(PerNode::new(tensors, Born::Parent(Sym3::ZERO)).lerp_on_edges());
    }

    /// Give the nodes and faces the mesh gained their values, each array
    /// by its rule; the elements of new faces are left to the caller.
    pub(in crate::sim) fn grow(&mut self, mesh: &SimMesh) {
        for a in self.arrays() {
            a.grow(mesh);
        }
        self.els.elements.resize_gently(mesh.n_faces(), None);
        if let Some(film) = &mut self.film {
            film.grow(mesh.n_vertices());
        }
    }
}

/// Whether `v` lies on a face of one of the fixed `groups`.
fn in_groups(mesh: &SimMesh, groups: &[u32], v: VertexId) -> bool {
    !groups.is_empty()
        && mesh
            .vertex_faces(v)
            .any(|f| groups.contains(&mesh.face_group(f)))
}

/// Book-keeping after `crack_node`: grow the state, fix vertices on fixed
/// borders, record segments and crack times, give split faces their
/// parent's stress and new elements, and settle inserted vertices'
/// displacement. Returns whether the event made a crack.
pub(in crate::sim) fn apply_event(
    mesh: &SimMesh,
    st: &mut State,
    report: &mut SimReport,
    ev: &crate::sim::crack::CrackEvent,
) -> bool {
    st.grow(mesh);
    for a in st.arrays() {
        a.settle_inserted(mesh, ev);
    }
    for (&q, &(a, b, border)) in ev.inserted.iter().zip(&ev.inserted_on) {
        if border {
            let (pa, pb, pq) = (mesh.position(a), mesh.position(b), mesh.position(q));
            split_segment(&mut st.segment_at, report, pa, pb, pq);
        }
    }
    if ev.segments.is_empty() {
        return false;
    }
    for (&q, &(a, b, border)) in ev.inserted.iter().zip(&ev.inserted_on) {
        // A vertex inserted on a crack lies on two of its segments.
        let on_crack = border
            && !st.crack_time[a.idx()].is_nan()
            && !st.crack_time[b.idx()].is_nan()
            && ev.segments.iter().any(|&(a, b)| a == q || b == q);
        if on_crack {
            let r = vertex_root(mesh, q).idx();
            st.crack_degree[r] = st.crack_degree[r].saturating_add(2);
        }
    }
    for &(a, b) in &ev.segments {
        for v in [a, b] {
            let r = vertex_root(mesh, v).idx();
            st.crack_degree[r] = st.crack_degree[r].saturating_add(1);
        }
    }
    report.cracks += 1;
    report.crack_length += ev.length;
    report.first_crack_time.get_or_insert(report.time);
    for &(a, b) in &ev.segments {
        let (pa, pb) = (mesh.position(a), mesh.position(b));
        st.segment_at.add(pa, pb, report.segments.len());
        report.segments.push([pa, pb]);
    }
    report
        .segment_times
        .extend(ev.segments.iter().map(|_| report.time));
    // Crack times: the segment ends, then the copies opening made of them.
    for &(a, b) in &ev.segments {
        for x in [a, b] {
            if st.crack_time[x.idx()].is_nan() {
                st.crack_time[x.idx()] = report.time;
            }
        }
    }
    for &(new, orig) in &ev.duplicated {
        if st.crack_time[new.idx()].is_nan() {
            st.crack_time[new.idx()] = st.crack_time[orig.idx()];
        }
    }
    // Children inherit their parent's stress; touched faces get new elements.
    let mut touched: Vec<FaceId> = Vec::new();
    for a in st.arrays() {
        a.settle_split(ev);
    }
    for &(parent, child) in &ev.split_faces {
        touched.push(parent);
        touched.push(child);
    }
    for f in &touched {
        st.els.elements[f.idx()] = st.element(mesh, *f);
    }
    true
}

/// The nodes whose separation a crack event changes: the fans around its
/// segments, its duplicates and inserted vertices (sorted, unique).
pub(in crate::sim) fn touched_nodes(
    mesh: &SimMesh,
    ev: &crate::sim::crack::CrackEvent,
) -> Vec<VertexId> {
    let mut nodes: Vec<VertexId> = Vec::new();
    for &(a, b) in &ev.segments {
        for x in [a, b] {
            nodes.extend(mesh.vertex_faces(x).flat_map(|f| mesh.face_vertices(f)));
        }
    }
    nodes.extend(ev.duplicated.iter().map(|&(n, _)| n));
    nodes.extend(ev.inserted.iter().copied());
    nodes.sort();
    nodes.dedup();
    nodes
}

/// The vertex `v`'s copies were all duplicated from (see
/// [`SimMesh::vertex_parent`]).
pub(in crate::sim) fn vertex_root(mesh: &SimMesh, v: VertexId) -> VertexId {
    let mut r = v;
    for _ in 0..64 {
        let p = mesh.vertex_parent(r);
        if p == r {
            break;
        }
        r = p;
    }
    r
}

/// Unit area-weighted normal of every node (zero where undefined).
pub(in crate::sim) fn node_normals(fans: &Fans, els: &Elements) -> Vec<[f64; 3]> {
    (0..fans.n_vertices())
        .into_par_iter()
        .map(|v| {
            let mut n = [0.0; 3];
            for &(f, _) in fans.fan(v) {
                if let Some(Some(el)) = els.elements.get(f as usize) {
                    n = v3::add(n, v3::scale(el.normal, el.area));
                }
            }
            let l = v3::norm(n);
            if l > 0.0 {
                v3::scale(n, 1.0 / l)
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// Tell `observer` the state, when it wants it.
pub(in crate::sim) fn observe(
    observer: &mut dyn Observer,
    mesh: &SimMesh,
    st: &State,
    report: &SimReport,
) {
    if observer.wants_state() {
        // In the order the finished report gives them (each split record's
        // pieces in its place), so the last frame is the output.
        let mut ordered = SimReport {
            segments: report.segments.clone(),
            segment_times: report.segment_times.clone(),
            ..Default::default()
        };
        st.segment_at.in_record_order(&mut ordered);
        observer.state(&Snapshot {
            mesh,
            time: report.time,
            displacement: &st.displacement,
            crack_time: &st.crack_time,
            segments: &ordered.segments,
            segment_times: &ordered.segment_times,
            energy: energy(&st.els, &st.stress),
        });
    }
}

#[cfg(test)]
#[path = "state_tests.rs"]
mod tests;
