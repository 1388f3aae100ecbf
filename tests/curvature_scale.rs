//! The `curvature` preset judges bending at the pattern's scale, in world
//! units against the cell size: a flat ground with a fine grain (the noise of
//! a scan or a sculpted ground) does not crack, a bump on it cracks into
//! closed cells on the bump alone, the same at any scale, and the cracks run
//! across the input's triangles, not along them. Measured with the
//! independent measure (`common/measure.rs`, which shares no code with the
//! crate) on grids a DCC tool makes and on the teapot.

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

use std::path::Path;

/// A regular `n` x `n` grid 10 units wide in the xz plane (each quad split
/// along one diagonal, as a DCC tool's subdivided plane), its heights a
/// seeded grain of `grain` units plus a Gaussian bump of height `bump`
/// (spread 0.8) at the middle, all times `scale`.
fn ground(n: usize, grain: f64, bump: f64, scale: f64) -> String {
    let mut seed = 3u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    shapes::height_plate(n, 10.0 * scale, |x, z| {
        let (x, z) = (x / scale, z / scale);
        scale * (grain * next() + bump * (-(x * x + z * z) / (2.0 * 0.8 * 0.8)).exp())
    })
}

/// The crack lines of `input` cracked with the `curvature` preset.
fn curvature_lines(input: &Path, out: &Path) -> Vec<measure::Seg> {
    common::crack_lines(input, out, "curvature", &[]);
    measure::read_model(out).rest_lines("crack_lines")
}

fn seg_length(s: &measure::Seg) -> f64 {
    let d = [0, 1, 2].map(|k| s[1][k] - s[0][k]);
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

fn length(lines: &[measure::Seg]) -> f64 {
    lines.iter().map(seg_length).sum()
}

#[test]
fn a_grainy_ground_does_not_crack_and_a_bump_on_it_cracks_into_cells() {
    let dir = tempfile::tempdir().unwrap();
    // The grain: 0.02 units (a fifth of a percent of the ground) at every
    // vertex of a 200 x 200 grid. Measured against the mesh's own mean
    // curvature, it cracked the whole ground (363 units of crack).
    let flat = dir.path().join("flat.obj");
    std::fs::write(&flat, ground(200, 0.02, 0.0, 1.0)).unwrap();
    let lines = curvature_lines(&flat, &dir.path().join("flat.glb"));
    assert!(
        length(&lines) < 1e-9,
        "{} of crack on a flat ground",
        length(&lines)
    );

    let bump_text = ground(200, 0.02, 1.5, 1.0);
    let bump = dir.path().join("bump.obj");
    std::fs::write(&bump, &bump_text).unwrap();
    let lines = curvature_lines(&bump, &dir.path().join("bump.glb"));
    let total = length(&lines);
    assert!(total > 20.0, "{total} of crack on the bump");
    // On the bump (its height falls to 1% at 2.4 units): none on the plain.
    let near: f64 = lines
        .iter()
        .filter(|s| {
            let m = [0.5 * (s[0][0] + s[1][0]), 0.5 * (s[0][2] + s[1][2])];
            m[0].hypot(m[1]) < 2.6
        })
        .map(seg_length)
        .sum();
    assert!(near >= 0.95 * total, "{near} of {total} on the bump");
    // Closed cells, seen from above; across the grid's triangles.
    let tris = measure::parse_obj(&bump_text);
    let border = measure::flatten(
        &measure::boundary_edges(&tris, measure::DEFAULT_WELD_REL),
        1,
        0.0,
    );
    let graph = measure::crack_graph(&measure::flatten(&lines, 1, 0.0), measure::DEFAULT_WELD_REL);
    let cells = measure::planar_cells(&graph, &border, 1e-4);
    assert!(cells.len() >= 10, "{} cells", cells.len());
    let on_edges = measure::edge_share(&lines, &tris, measure::DEFAULT_TOL_REL);
    assert!(
        on_edges < 0.05,
        "{on_edges} of the length on the grid's edges"
    );

    // A thousand times larger or smaller: the same pattern, a thousand
    // times longer or shorter.
    for (k, scale) in [1000.0, 0.001].into_iter().enumerate() {
        let other = dir.path().join(format!("scaled-{k}.obj"));
        std::fs::write(&other, ground(200, 0.02, 1.5, scale)).unwrap();
        let out = dir.path().join(format!("scaled-{k}.glb"));
        let scaled = length(&curvature_lines(&other, &out)) / scale;
        assert!(
            (scaled - total).abs() <= 0.05 * total,
            "{scaled} at x{scale} against {total}"
        );
    }
}

/// On the teapot the cracks run across the input's triangles (none along
/// its rows) and close into cells: no ladders of four-way junctions.
#[test]
fn the_teapot_cracks_across_its_rows_into_cells() {
    let Some(input) = common::eval_data("obj/teapot/teapot.obj") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let lines = curvature_lines(&input, &dir.path().join("teapot.glb"));
    assert!(length(&lines) > 50.0, "{}", length(&lines));
    let tris = measure::read_model(&input).triangles(|_| true);
    let on_edges = measure::edge_share(&lines, &tris, measure::DEFAULT_TOL_REL);
    assert!(
        on_edges < 0.05,
        "{on_edges} of the length on the teapot's edges"
    );
    let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let joins = graph.degree.iter().filter(|&&d| d >= 3).count();
    let fours = graph.degree.iter().filter(|&&d| d >= 4).count();
    let tips = graph.degree.iter().filter(|&&d| d == 1).count();
    assert!(joins >= 200, "{joins} junctions");
    assert!(fours * 50 <= joins, "{fours} four-way of {joins} junctions");
    // Most ends join: cells, not dashes.
    assert!(
        tips * 2 <= joins,
        "{tips} open ends against {joins} junctions"
    );
}
