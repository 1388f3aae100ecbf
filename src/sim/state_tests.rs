//! One test per transfer rule of [`apply_event`] and [`State::grow`]: what
//! each per-node and per-face array of a new or split element holds after
//! a crack.

use super::*;
use crate::mesh::shapes::jittered_plate;
use crate::sim::crack::{crack_node, CrackEvent, CrackRules};
use crate::sim::driver::start;

/// A jittered plate (border fixed), its state and report at the start of
/// a run.
fn setup() -> (SimMesh, State, SimReport) {
    let mesh = jittered_plate(8, 0.3, 11);
    let params = SimParams {
        fixed_boundary: true,
        ..SimParams::default()
    };
    let (st, report) = start(&mesh, &params, None).expect("a plate starts");
    (mesh, st, report)
}

/// Rules that split edges rather than snap to them.
fn splitting() -> CrackRules {
    CrackRules {
        theta1: 1f64.to_radians(),
        min_split: 0.01,
        min_quality: 0.0,
        ..CrackRules::default()
    }
}

/// Crack the plate's most central interior node along a direction no
/// edge of the grid has; the event.
fn crack_centre(mesh: &mut SimMesh) -> CrackEvent {
    let centre = mesh
        .vertices()
        .filter(|&v| !mesh.is_boundary_vertex(v))
        .min_by(|&a, &b| {
            let d = |v: VertexId| v3::dist2(mesh.position(v), [4.0, 4.0, 0.0]);
            d(a).total_cmp(&d(b))
        })
        .expect("an interior node");
    let a = 23f64.to_radians();
    crack_node(mesh, centre, [a.cos(), a.sin(), 0.0], &splitting()).expect("it cracks")
}

/// Every per-node and per-face array has the mesh's length.
fn assert_sized(mesh: &SimMesh, st: &State) {
    let (n, f) = (mesh.n_vertices(), mesh.n_faces());
    assert_eq!(st.displacement.len(), n);
    assert_eq!(st.crack_time.len(), n);
    assert_eq!(st.fixed.len(), n);
    assert_eq!(st.residual.len(), n);
    assert_eq!(st.crack_degree.len(), n);
    assert_eq!(st.stress.len(), f);
    assert_eq!(st.shrink_scale.len(), f);
    assert_eq!(st.els.elements.len(), f);
}

#[test]
fn every_array_grows_with_the_mesh() {
    let (mut mesh, mut st, mut report) = setup();
    let before = (mesh.n_vertices(), mesh.n_faces());
    let ev = crack_centre(&mut mesh);
    assert!(mesh.n_vertices() > before.0 && mesh.n_faces() > before.1);
    assert!(apply_event(&mesh, &mut st, &mut report, &ev));
    assert_sized(&mesh, &st);
}

#[test]
fn split_faces_inherit_their_parents_stress() {
    let (mut mesh, mut st, mut report) = setup();
    for (k, s) in st.stress.iter_mut().enumerate() {
        *s = Sym3::IDENTITY * (1.0 + k as f64);
    }
    let ev = crack_centre(&mut mesh);
    assert!(!ev.split_faces.is_empty());
    apply_event(&mesh, &mut st, &mut report, &ev);
    for &(parent, child) in &ev.split_faces {
        assert_eq!(st.stress[child.idx()], st.stress[parent.idx()]);
        // and a new element for the changed shape
        assert!(st.els.elements[child.idx()].is_some());
    }
}

#[test]
fn inserted_nodes_interpolate_the_displacement_of_the_edge_they_split() {
    let (mut mesh, mut st, mut report) = setup();
    // A displacement linear in position is reproduced exactly.
    let field = |p: [f64; 3]| [0.1 * p[0] + 0.02 * p[1], -0.03 * p[0], 0.05 * p[1]];
    for v in mesh.vertices() {
        st.displacement[v.idx()] = field(mesh.position(v));
    }
    let ev = crack_centre(&mut mesh);
    assert!(!ev.inserted.is_empty(), "the crack crossed no edge");
    apply_event(&mesh, &mut st, &mut report, &ev);
    for &q in &ev.inserted {
        let want = field(mesh.position(q));
        let got = st.displacement[q.idx()];
        assert!(
            v3::norm(v3::sub(got, want)) < 1e-12,
            "{q:?}: {got:?} vs {want:?}"
        );
    }
}

#[test]
fn copies_made_by_opening_inherit_displacement_fixedness_and_crack_time() {
    let (mut mesh, mut st, mut report) = setup();
    for v in mesh.vertices() {
        st.displacement[v.idx()] = [0.01 * v.0 as f64, 0.0, 0.0];
    }
    report.time = 7.0;
    let ev = crack_centre(&mut mesh);
    assert!(!ev.duplicated.is_empty(), "the crack opened nothing");
    apply_event(&mesh, &mut st, &mut report, &ev);
    for &(new, orig) in &ev.duplicated {
        assert_eq!(st.displacement[new.idx()], st.displacement[orig.idx()]);
        assert_eq!(st.fixed[new.idx()], st.fixed[orig.idx()]);
        assert_eq!(st.crack_time[new.idx()], st.crack_time[orig.idx()]);
    }
}

#[test]
fn crack_ends_get_the_time_and_their_degree() {
    let (mut mesh, mut st, mut report) = setup();
    report.time = 3.5;
    let ev = crack_centre(&mut mesh);
    apply_event(&mesh, &mut st, &mut report, &ev);
    assert_eq!(report.cracks, 1);
    assert_eq!(report.segments.len(), ev.segments.len());
    assert!(report.segment_times.iter().all(|&t| t == 3.5));
    for &(a, b) in &ev.segments {
        for v in [a, b] {
            assert_eq!(st.crack_time[v.idx()], 3.5);
            assert!(st.crack_degree[crate::sim::state::vertex_root(&mesh, v).idx()] >= 1);
        }
    }
    // Nodes away from the crack keep no crack time.
    let untouched = st.crack_time.iter().filter(|t| t.is_nan()).count();
    assert!(untouched > mesh.n_vertices() / 2);
}

#[test]
fn nodes_inserted_on_a_fixed_border_are_fixed() {
    // Cracks from a node next to the border, in many directions: those
    // that split a border edge insert a node there.
    let mut on_border = 0;
    for k in 0..26 {
        let (mut mesh, mut st, mut report) = setup();
        let near = mesh
            .vertices()
            .filter(|&v| !mesh.is_boundary_vertex(v))
            .min_by(|&a, &b| {
                let d = |v: VertexId| v3::dist2(mesh.position(v), [1.0, 4.0, 0.0]);
                d(a).total_cmp(&d(b))
            })
            .expect("an interior node");
        let a = (7.0 * k as f64).to_radians();
        let ev =
            crack_node(&mut mesh, near, [a.cos(), a.sin(), 0.0], &splitting()).expect("it cracks");
        apply_event(&mesh, &mut st, &mut report, &ev);
        for (&q, &(a, b, border)) in ev.inserted.iter().zip(&ev.inserted_on) {
            let expect = border && st.fixed[a.idx()] && st.fixed[b.idx()];
            assert_eq!(st.fixed[q.idx()], expect, "{q:?} on ({a:?}, {b:?})");
            on_border += usize::from(expect);
        }
    }
    assert!(on_border > 0, "no crack split a border edge");
}

#[test]
fn an_event_without_segments_grows_the_state_but_counts_no_crack() {
    let (mesh, mut st, mut report) = setup();
    let ev = CrackEvent::default();
    assert!(!apply_event(&mesh, &mut st, &mut report, &ev));
    assert_eq!(report.cracks, 0);
    assert_sized(&mesh, &st);
}
