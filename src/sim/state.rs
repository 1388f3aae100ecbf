//! The run's state that grows with the mesh: per-node and per-face arrays,
//! the caches of a round, and [`apply_event`], which applies one crack's
//! mutation events to every array (the transfer rules in one place).

use crate::geometry::element::Element;
use crate::math::{hash_unit, v3, Sym3};
use crate::mesh::{FaceId, SimMesh, VertexId};
use crate::sim::energy;
use crate::sim::forces::{face_points, Elements, Fans};
use crate::sim::Observer;
use crate::sim::SimParams;
use crate::sim::SimReport;
use crate::sim::Snapshot;
use rayon::prelude::*;
use std::sync::Arc;

/// Simulation state that grows with the mesh.
pub(in crate::sim) struct State {
    pub(in crate::sim) els: Elements,
    pub(in crate::sim) stress: Vec<Sym3>,
    pub(in crate::sim) residual: Vec<Sym3>,
    pub(in crate::sim) fixed: Vec<bool>,
    /// Load multiplier per face (seeded noise).
    pub(in crate::sim) shrink_scale: Vec<f64>,
    /// Evolution of the stress field per unit time, per face (children copy
    /// their parent's).
    pub(in crate::sim) evolve: Vec<Sym3>,
    /// Factor on each face's contribution to node separation (empty: 1;
    /// children copy their parent's).
    pub(in crate::sim) sep_scale: Vec<f64>,
    /// Accumulated virtual displacement per node (for crack width later).
    pub(in crate::sim) displacement: Vec<[f64; 3]>,
    /// Time each node first lay on a crack (NaN: never).
    pub(in crate::sim) crack_time: Vec<f64>,
    /// Cracks meeting at each node, indexed by the node's root (all copies
    /// of a crack node share it): 2 along a crack, 3 at a T.
    pub(in crate::sim) crack_degree: Vec<u8>,
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
    pub(in crate::sim) frozen: Option<Vec<Sym3>>,
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
        self.next.resize(i + 1, usize::MAX);
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
        !params.fixed_groups.is_empty()
            && mesh
                .vertex_faces(v)
                .any(|f| params.fixed_groups.contains(&mesh.face_group(f)))
    }

    /// Extend per-node and per-face state to new nodes and faces.
    /// Duplicates inherit their parent's displacement and crack time;
    /// inserted vertices are settled by the caller.
    pub(in crate::sim) fn grow(&mut self, mesh: &SimMesh, params: &SimParams) {
        self.residual.resize(mesh.n_vertices(), Sym3::ZERO);
        self.crack_degree.resize(mesh.n_vertices(), 0);
        if let Some(fz) = &mut self.frozen {
            while fz.len() < mesh.n_vertices() {
                let v = VertexId(fz.len() as u32);
                let parent = mesh.vertex_parent(v);
                let s = if parent != v {
                    fz.get(parent.idx()).copied()
                } else {
                    None
                };
                fz.push(s.unwrap_or(Sym3::ZERO));
            }
        }
        while self.displacement.len() < mesh.n_vertices() {
            let v = VertexId(self.displacement.len() as u32);
            let parent = mesh.vertex_parent(v);
            let (d, t) = if parent != v && parent.idx() < self.displacement.len() {
                (
                    self.displacement[parent.idx()],
                    self.crack_time[parent.idx()],
                )
            } else {
                ([0.0; 3], f64::NAN)
            };
            self.displacement.push(d);
            self.crack_time.push(t);
        }
        while self.fixed.len() < mesh.n_vertices() {
            let v = VertexId(self.fixed.len() as u32);
            // Duplicates inherit fixedness from their parent; inserted
            // vertices are settled by the caller (it knows the split edge).
            let parent = mesh.vertex_parent(v);
            let f = (parent != v && self.fixed.get(parent.idx()).copied().unwrap_or(false))
                || Self::in_fixed_group(mesh, params, v);
            self.fixed.push(f);
        }
        self.els.elements.resize(mesh.n_faces(), None);
        self.stress.resize(mesh.n_faces(), Sym3::ZERO);
        if !self.evolve.is_empty() {
            self.evolve.resize(mesh.n_faces(), Sym3::ZERO);
        }
        if !self.sep_scale.is_empty() {
            self.sep_scale.resize(mesh.n_faces(), 1.0);
        }
        while self.shrink_scale.len() < mesh.n_faces() {
            let f = FaceId(self.shrink_scale.len() as u32);
            let u = match &self.film {
                // A world-space field: the same wherever the triangles are.
                Some(film) => {
                    let c = face_points(mesh, f)
                        .iter()
                        .fold([0.0; 3], |a, p| v3::add(a, *p));
                    let spacing = crate::sim::film::NOISE_SPACING * film.cell;
                    crate::math::value_noise(params.seed, v3::scale(c, 1.0 / (3.0 * spacing)))
                }
                None => hash_unit(params.seed, u64::from(mesh.face_source(f))),
            };
            self.shrink_scale.push(1.0 + params.noise * u);
        }
        if let Some(film) = &mut self.film {
            film.grow(mesh.n_vertices());
        }
    }
}

/// Book-keeping after `crack_node`: grow the state, fix vertices on fixed
/// borders, record segments and crack times, give split faces their
/// parent's stress and new elements, and settle inserted vertices'
/// displacement. Returns whether the event made a crack.
pub(in crate::sim) fn apply_event(
    mesh: &SimMesh,
    st: &mut State,
    params: &SimParams,
    report: &mut SimReport,
    ev: &crate::sim::crack::CrackEvent,
) -> bool {
    st.grow(mesh, params);
    for (&q, &(a, b, border)) in ev.inserted.iter().zip(&ev.inserted_on) {
        // A vertex on a fixed border edge is fixed.
        if border && st.fixed[a.idx()] && st.fixed[b.idx()] && params.fixed_boundary {
            st.fixed[q.idx()] = true;
        }
        // Its displacement is interpolated along the edge it split.
        let (pa, pb, pq) = (mesh.position(a), mesh.position(b), mesh.position(q));
        let l = v3::norm(v3::sub(pb, pa));
        let t = if l > 0.0 {
            (v3::norm(v3::sub(pq, pa)) / l).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let (da, db) = (st.displacement[a.idx()], st.displacement[b.idx()]);
        st.displacement[q.idx()] = v3::add(v3::scale(da, 1.0 - t), v3::scale(db, t));
        if let Some(fz) = &mut st.frozen {
            fz[q.idx()] = fz[a.idx()] * (1.0 - t) + fz[b.idx()] * t;
        }
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
    for &(parent, child) in &ev.split_faces {
        st.stress[child.idx()] = st.stress[parent.idx()];
        if !st.evolve.is_empty() {
            st.evolve[child.idx()] = st.evolve[parent.idx()];
        }
        if !st.sep_scale.is_empty() {
            st.sep_scale[child.idx()] = st.sep_scale[parent.idx()];
        }
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
