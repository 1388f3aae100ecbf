//! The snapping variant (`impact-snapped`: cracks follow the simulation
//! surface's edges) on a grid a DCC tool makes and on the teapot: its
//! cracks do not run along the input's own edges (the private isotropic
//! surface), and they end on one another instead of crossing in ladders
//! of four-way junctions. Measured with the independent measure
//! (`common/measure.rs`: it reads the output's crack lines itself and
//! shares no code with the crate).

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

use std::path::Path;

/// (share of the crack length on the input's edges, junctions, four-way
/// junctions, crack edges joining two four-way junctions) of
/// `impact-snapped` on `input`.
fn snapped(input: &Path, out: &Path) -> (f64, usize, usize, usize) {
    common::crack_lines(input, out, "impact-snapped", &[]);
    let lines = measure::read_model(out).rest_lines("crack_lines");
    assert!(measure::crack_length(&lines) > 0.0, "no cracks");
    let tris = measure::read_model(input).triangles(|_| true);
    let on_edges = measure::edge_share(&lines, &tris, measure::DEFAULT_TOL_REL);
    let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let joins = graph.degree.iter().filter(|&&d| d >= 3).count();
    let fours = graph.degree.iter().filter(|&&d| d >= 4).count();
    let ladder = graph
        .edges
        .iter()
        .filter(|e| e.iter().all(|&n| graph.degree[n] >= 4))
        .count();
    (on_edges, joins, fours, ladder)
}

fn check(name: &str, (on_edges, joins, fours, ladder): (f64, usize, usize, usize)) {
    eprintln!("{name}: {on_edges:.4} of the length on input edges, {joins} junctions, {fours} four-way, {ladder} edges between four-way junctions");
    assert!(on_edges < 0.05, "{name}: {on_edges} on the input's edges");
    assert!(joins >= 50, "{name}: {joins} junctions");
    // Crossing snapped cracks made 40% of the junctions four-way, in
    // ladders (85 edges between two of them on the grid, 51 on the teapot).
    assert!(
        fours * 5 <= joins,
        "{name}: {fours} four-way of {joins} junctions"
    );
    assert!(
        ladder * 10 <= joins,
        "{name}: {ladder} edges between four-way junctions, {joins} junctions"
    );
}

#[test]
fn snapped_cracks_leave_the_input_edges_and_end_on_each_other() {
    let dir = tempfile::tempdir().unwrap();
    let grid = dir.path().join("grid.obj");
    shapes::write_obj(&grid, &shapes::regular_plate(200, 10.0));
    check("200x200 grid", snapped(&grid, &dir.path().join("grid.glb")));
    if let Some(teapot) = common::eval_data("obj/teapot/teapot.obj") {
        check("teapot", snapped(&teapot, &dir.path().join("teapot.glb")));
    }
}
