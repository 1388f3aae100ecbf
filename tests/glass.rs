//! Glass presets beside `glass-impact` (tested in `impact_star.rs`):
//! `glass-tempered` dices a whole pane into small near-equal cells, and a
//! laminated pane (a windscreen: `glass-impact` on a curved pane) cracks but
//! stays in one piece. Measured with the independent measure
//! (`common/measure.rs`, which reads the output itself and shares no code
//! with the crate) on meshes a DCC tool could make.

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

#[test]
fn tempered_glass_dices_the_whole_pane_into_near_equal_cells() {
    // A jittered pane and a regular grid (whose rows must not show).
    tempered_pane(&shapes::jittered_plate(80, 10.0, 0.3, 3));
    tempered_pane(&shapes::regular_plate(80, 10.0));
}

fn tempered_pane(text: &str) {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("pane.obj");
    shapes::write_obj(&input, text);
    let out = dir.path().join("out.glb");
    let o = common::crack(&input, &out, &["-q", "--preset", "glass-tempered"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lines = measure::flatten(&measure::read_model(&out).rest_lines("crack_lines"), 1, 0.0);
    let border = measure::flatten(
        &measure::boundary_edges(&measure::parse_obj(text), measure::DEFAULT_WELD_REL),
        1,
        0.0,
    );
    let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let cells = measure::planar_cells(&graph, &border, 1e-4);
    // Small cells all over: hundreds on the pane (its 100 square units),
    // the enclosed area nearly all of it.
    assert!(cells.len() >= 300, "{} cells", cells.len());
    let total: f64 = cells.iter().sum();
    assert!(total >= 0.95 * 100.0, "cells cover {total} of 100");
    // Near-equal: the areas' coefficient of variation under 0.5 and no
    // cell over five times the mean (glaze's and mud's first cracks leave
    // long strips and large cells).
    let n = cells.len() as f64;
    let mean = total / n;
    let cv = (cells.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / n).sqrt() / mean;
    let largest = cells.iter().fold(0.0f64, |m, &a| m.max(a));
    assert!(cv < 0.5, "cell areas' CV {cv}");
    assert!(largest < 5.0 * mean, "largest cell {largest}, mean {mean}");
    assert_eq!(measure::open_tips(&graph, &border), 0, "open crack tips");
}

#[test]
fn a_laminated_windscreen_cracks_but_stays_in_one_piece() {
    // The jittered plate bent about the z axis like a windscreen (a sag
    // of a tenth of its width).
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("windscreen.obj");
    let flat = shapes::jittered_plate(80, 10.0, 0.3, 4);
    let bent: String = flat
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(v) => {
                let p: Vec<f64> = v.split_whitespace().map(|x| x.parse().unwrap()).collect();
                format!("v {} {} {}\n", p[0], p[1] - 0.04 * p[0] * p[0], p[2])
            }
            None => format!("{l}\n"),
        })
        .collect();
    shapes::write_obj(&input, &bent);
    let out = dir.path().join("out.glb");
    let o = common::crack(
        &input,
        &out,
        &["-q", "--preset", "glass-impact", "--set", "post.lines=true"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let model = measure::read_model(&out);
    let lines = model.rest_lines("crack_lines");
    assert!(
        measure::crack_length(&lines) > 10.0,
        "the windscreen is hardly cracked: {}",
        measure::crack_length(&lines)
    );
    let input_tris = measure::parse_obj(&bent);
    let tris = model.triangles(|m| m != "crack_lines");
    assert_eq!(
        tris.len(),
        input_tris.len(),
        "the input's triangles come back"
    );
    let pieces = measure::crack_graph(&measure::triangle_edges(&tris), measure::DEFAULT_WELD_REL)
        .pieces()
        .len();
    assert_eq!(pieces, 1, "the laminated pane came apart");
}
