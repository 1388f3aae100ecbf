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

use std::path::{Path, PathBuf};

/// `preset` on `input` in `dir`: the default output and the one with
/// `post.smooth_paths = 0` (cracks left on the simulation surface's edges).
fn smoothed_and_on_edges(dir: &Path, input: &Path, preset: &str) -> (PathBuf, PathBuf) {
    let on = dir.join(format!("{preset}.glb"));
    let off = dir.join(format!("{preset}-edges.glb"));
    common::crack_lines(input, &on, preset, &[]);
    common::crack_lines(input, &off, preset, &["--set", "post.smooth_paths=0"]);
    (on, off)
}

/// (open ends, junctions, crack length) of the crack lines in `out`; with
/// `plate` (the half size of a plate in x and z, centred on the origin),
/// ends on the plate's border are not open.
fn ends_and_junctions(out: &Path, plate: Option<f64>) -> (usize, usize, f64) {
    let lines = measure::read_model(out).rest_lines("crack_lines");
    let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let inside = |p: &[f64; 3]| plate.is_none_or(|h| p[0].abs().max(p[2].abs()) < h * (1.0 - 1e-4));
    let ends = graph
        .degree
        .iter()
        .zip(&graph.nodes)
        .filter(|&(&d, p)| d == 1 && inside(p))
        .count();
    let joins = graph.degree.iter().filter(|&&d| d >= 3).count();
    let length = measure::crack_length(&lines);
    eprintln!(
        "{}: {ends} open ends, {joins} junctions, crack length {length:.2}",
        out.display()
    );
    (ends, joins, length)
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

/// Both claims on the same runs: springs-glaze on the icosphere and
/// springs-mud on a jittered plate, each smoothed and on the edges.
#[test]
fn spring_cracks_join_into_networks_off_the_edges() {
    let dir = tempfile::tempdir().unwrap();
    let plate = dir.path().join("plate.obj");
    shapes::write_obj(&plate, &shapes::jittered_plate(160, 10.0, 0.3, 1));
    let ico = common::fixture("icosphere.obj");
    let glaze = smoothed_and_on_edges(dir.path(), &ico, "springs-glaze");
    let mud = smoothed_and_on_edges(dir.path(), &plate, "springs-mud");
    let (ends, joins, _) = ends_and_junctions(&glaze.0, None);
    assert!(
        joins >= 50 && ends <= 8 * joins,
        "{ends} ends, {joins} junctions"
    );
    // springs-mud: its spurs and one-triangle loops (which made most of
    // its junctions) leave with `post.smooth_paths`; the open ends must not
    // grow in number.
    let (ends, joins, length) = ends_and_junctions(&mud.0, Some(5.0));
    let (raw_ends, _, _) = ends_and_junctions(&mud.1, Some(5.0));
    let per = ends as f64 / length;
    assert!(
        joins >= 20 && ends as f64 <= 1.1 * raw_ends as f64,
        "{ends} ends, {joins} junctions, against {raw_ends} ends on the edges"
    );
    // Finishing (the preset's `post.finish`) runs the open tips on to the
    // crack ahead within a cell: the open ends (off the border) per unit
    // length at most a fifth of those of the same run without it.
    let unfinished = dir.path().join("springs-mud-unfinished.glb");
    common::crack_lines(
        &plate,
        &unfinished,
        "springs-mud",
        &["--set", "post.finish=false"],
    );
    let (open, _, open_length) = ends_and_junctions(&unfinished, Some(5.0));
    let open_per = open as f64 / open_length;
    eprintln!("springs-mud: {per:.2} open ends per unit length, {open_per:.2} unfinished");
    assert!(per <= 0.2 * open_per, "{per} against {open_per} unfinished");
    for (preset, (on, off)) in [("springs-mud", &mud), ("springs-glaze", &glaze)] {
        let (t_on, t_off) = (zig_zag_per_length(on), zig_zag_per_length(off));
        eprintln!("{preset}: turning at sharp corners per unit length {t_off:.2} on the edges, {t_on:.2} smoothed");
        assert!(t_on < 0.5 * t_off, "{preset}: {t_on} against {t_off}");
    }
}
