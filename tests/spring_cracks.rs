//! The spring model's cracks join into networks: after a break the load
//! is held while the springs settle (quasistatic drying), the breaking
//! strains spread narrowly so the springs beside a break fail next, and
//! the presets bond the film to its body so cracks form all over. Counted
//! with the independent measure (`common/measure.rs`: it reads the
//! output's crack lines itself and shares no code with the crate): open
//! ends against junctions, where each broken spring drawn on its own made
//! dashes (14 open ends per junction for springs-glaze on the teapot).

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

use std::path::Path;

/// (open ends, junctions) of `preset`'s crack lines on `input`.
fn ends_and_junctions(input: &Path, out: &Path, preset: &str) -> (usize, usize) {
    common::crack_lines(input, out, preset, &[]);
    let lines = measure::read_model(out).rest_lines("crack_lines");
    let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let ends = graph.degree.iter().filter(|&&d| d == 1).count();
    let joins = graph.degree.iter().filter(|&&d| d >= 3).count();
    eprintln!(
        "{preset} on {}: {ends} open ends, {joins} junctions, crack length {:.2}",
        input.display(),
        measure::crack_length(&lines)
    );
    (ends, joins)
}

#[test]
fn spring_cracks_join_into_networks() {
    let dir = tempfile::tempdir().unwrap();
    let plate = dir.path().join("plate.obj");
    shapes::write_obj(&plate, &shapes::jittered_plate(160, 10.0, 0.3, 1));
    let ico = common::fixture("icosphere.obj");
    let (ends, joins) = ends_and_junctions(&ico, &dir.path().join("g.glb"), "springs-glaze");
    assert!(
        joins >= 50 && ends <= 8 * joins,
        "{ends} ends, {joins} junctions"
    );
    let (ends, joins) = ends_and_junctions(&plate, &dir.path().join("m.glb"), "springs-mud");
    assert!(
        joins >= 50 && ends <= 2 * joins,
        "{ends} ends, {joins} junctions"
    );
}
