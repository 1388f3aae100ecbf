//! The spring model's cracks join into networks: after a break the load
//! is held while the springs settle (quasistatic drying), the breaking
//! strains spread narrowly so the springs beside a break fail next, and
//! the presets bond the film to its body so cracks form all over. Counted
//! with the independent measure (`common/measure.rs`: it reads the
//! output's crack lines itself and shares no code with the crate): open
//! ends against junctions, where each broken spring drawn on its own made
//! dashes (14 open ends per junction for springs-glaze on the teapot).
//! And they no longer zig-zag along the simulation surface's edges: the
//! crack lines' turning at sharp corners per unit length, measured the same
//! way, against the same run with `post.smooth_paths = 0`.

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
    // springs-mud: its spurs and one-triangle loops (which made most of
    // its junctions) leave with `post.smooth_paths`; the open ends per unit
    // of crack length must not grow.
    let (ends, joins) = ends_and_junctions(&plate, &dir.path().join("m.glb"), "springs-mud");
    let length = measure::crack_length(
        &measure::read_model(&dir.path().join("m.glb")).rest_lines("crack_lines"),
    );
    let raw = dir.path().join("m0.glb");
    common::crack_lines(
        &plate,
        &raw,
        "springs-mud",
        &["--set", "post.smooth_paths=0"],
    );
    let raw_lines = measure::read_model(&raw).rest_lines("crack_lines");
    let raw_ends = measure::crack_graph(&raw_lines, measure::DEFAULT_WELD_REL)
        .degree
        .iter()
        .filter(|&&d| d == 1)
        .count();
    let (per, raw_per) = (
        ends as f64 / length,
        raw_ends as f64 / measure::crack_length(&raw_lines),
    );
    eprintln!("springs-mud: {per:.2} open ends per unit length, {raw_per:.2} on the edges");
    assert!(
        joins >= 20 && per <= 1.1 * raw_per,
        "{ends} ends, {joins} junctions; {per} ends per length against {raw_per}"
    );
}

/// Turning (radians) of `out`'s crack lines at corners sharper than 60
/// degrees (between two segments), per unit of crack length: a crack
/// zig-zagging along triangle edges turns by 60-150 degrees at every edge;
/// a smooth crack drawn through the same points turns by a few tens.
fn zig_zag_per_length(out: &Path) -> f64 {
    let lines = measure::read_model(out).rest_lines("crack_lines");
    let g = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); g.nodes.len()];
    for &[a, b] in &g.edges {
        at[a].push(b);
        at[b].push(a);
    }
    let mut turning = 0.0;
    for (i, n) in at.iter().enumerate() {
        if let [a, b] = n[..] {
            let p = g.nodes[i];
            let u: Vec<f64> = (0..3).map(|k| g.nodes[a][k] - p[k]).collect();
            let v: Vec<f64> = (0..3).map(|k| g.nodes[b][k] - p[k]).collect();
            let dot: f64 = (0..3).map(|k| u[k] * v[k]).sum();
            let nu = u.iter().map(|x| x * x).sum::<f64>().sqrt();
            let nv = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            if nu > 0.0 && nv > 0.0 {
                let turn = std::f64::consts::PI - (dot / (nu * nv)).clamp(-1.0, 1.0).acos();
                if turn > std::f64::consts::FRAC_PI_3 {
                    turning += turn;
                }
            }
        }
    }
    turning / measure::crack_length(&g.segments())
}

#[test]
fn spring_cracks_leave_the_edges_zig_zag() {
    let dir = tempfile::tempdir().unwrap();
    let plate = dir.path().join("plate.obj");
    shapes::write_obj(&plate, &shapes::jittered_plate(160, 10.0, 0.3, 1));
    let ico = common::fixture("icosphere.obj");
    for (input, preset) in [(&plate, "springs-mud"), (&ico, "springs-glaze")] {
        let on = dir.path().join(format!("{preset}.glb"));
        let off = dir.path().join(format!("{preset}-edges.glb"));
        common::crack_lines(input, &on, preset, &[]);
        common::crack_lines(input, &off, preset, &["--set", "post.smooth_paths=0"]);
        let (t_on, t_off) = (zig_zag_per_length(&on), zig_zag_per_length(&off));
        eprintln!("{preset}: turning at sharp corners per unit length {t_off:.2} on the edges, {t_on:.2} smoothed");
        assert!(t_on < 0.5 * t_off, "{preset}: {t_on} against {t_off}");
    }
}
