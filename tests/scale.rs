//! Patterns at the artist's scale: the cell size asked for, not the
//! triangles, sets the pattern (measured with `crackle stats`).

mod common;

use common::{eval_data, fixture, run_ok};
use serde_json::Value;
use std::path::Path;

/// Crack `input` with `preset` and extra arguments, and return the
/// output's statistics (with the share along the input's edges).
fn crack_stats(input: &Path, preset: &str, extra: &[&str], dir: &Path, name: &str) -> Value {
    let out = dir.join(format!("{name}.glb"));
    let mut args: Vec<String> = vec![
        "-q".into(),
        "crack".into(),
        input.display().to_string(),
        out.display().to_string(),
        "--preset".into(),
        preset.into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    run_ok(&args);
    let o = run_ok([
        "stats".to_string(),
        out.display().to_string(),
        "--input".into(),
        input.display().to_string(),
        "--json".into(),
    ]);
    serde_json::from_slice(&o.stdout).expect("stats JSON")
}

fn num(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} in {v}"))
}

/// A length of the surface that scales with it (the square root of its
/// area), so densities of one shape in two units compare.
fn size(stats: &Value) -> f64 {
    num(stats, "area").sqrt()
}

/// The npm bunny (3.7k triangles) and the Stanford bunny (69k) at the same
/// relative cell size crack alike.
#[test]
fn two_tessellations_of_the_bunny_crack_alike() {
    let (Some(small), Some(big)) = (
        eval_data("obj/npm-bunny/bunny.obj"),
        eval_data("obj/stanford-bunny/stanford-bunny.obj"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let args = ["--cell-size-relative", "0.06"];
    let a = crack_stats(&small, "glaze", &args, dir.path(), "small");
    let b = crack_stats(&big, "glaze", &args, dir.path(), "big");
    // Crack length per area in units of each mesh's size.
    let da = num(&a, "crack_length_per_area") * size(&a);
    let db = num(&b, "crack_length_per_area") * size(&b);
    let ratio = da / db;
    assert!(
        (0.85..1.15).contains(&ratio),
        "density {da:.3} vs {db:.3} ({ratio:.3})\n{a}\n{b}"
    );
    let (ca, cb) = (num(&a, "cells"), num(&b, "cells"));
    assert!((0.8..1.2).contains(&(ca / cb)), "cells {ca} vs {cb}");
}

/// Halving the cell size about doubles the crack length per area, and the
/// measured mean cell diameter is near the size asked for, on three
/// assets.
#[test]
fn the_cell_size_is_the_artists() {
    let meshes = [
        "obj/spot/spot_triangulated.obj",
        "obj/teapot/teapot.obj",
        "gltf/Duck/Duck.glb",
    ];
    let dir = tempfile::tempdir().unwrap();
    for rel in meshes {
        let Some(path) = eval_data(rel) else { continue };
        let coarse = crack_stats(
            &path,
            "glaze",
            &["--cell-size-relative", "0.08"],
            dir.path(),
            "coarse",
        );
        let fine = crack_stats(
            &path,
            "glaze",
            &["--cell-size-relative", "0.04"],
            dir.path(),
            "fine",
        );
        let ratio = num(&fine, "crack_length_per_area") / num(&coarse, "crack_length_per_area");
        assert!(
            (1.6..2.5).contains(&ratio),
            "{rel}: density ratio {ratio:.3}"
        );
        assert!(
            num(&fine, "cells") > num(&coarse, "cells") * 2.0,
            "{rel}: cells"
        );
        for s in [&coarse, &fine] {
            assert_eq!(num(s, "dangling_tips"), 0.0, "{rel}: open tips\n{s}");
        }
    }
}

/// No direction from the mesh on the teapot: cracks cross its triangles,
/// no pole gathers a fan, parallel cracks do not pair, cells are hundreds
/// and their diameter is the one asked for.
#[test]
fn the_teapot_pattern_is_not_the_meshs() {
    let Some(path) = eval_data("obj/teapot/teapot.obj") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let s = crack_stats(&path, "glaze", &[], dir.path(), "teapot");
    let along = num(&s, "along_reference_edges");
    assert!(
        along < 0.2,
        "{along} of the crack length lies on input edges"
    );
    assert!(num(&s, "max_degree") <= 4.0, "a fan: {s}");
    assert!(num(&s, "cells") >= 200.0, "cells: {s}");
    assert!(num(&s, "paired") < 0.1, "paired: {s}");
    let orientation: Vec<f64> = s["orientation"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    for o in &orientation {
        assert!(
            (o - 1.0 / 6.0).abs() < 0.2 / 6.0 * 1.5,
            "orientation {orientation:?}"
        );
    }
}

/// Mud's first cracks meet in T junctions; glaze cells close.
#[test]
fn mud_junctions_are_t_shaped_and_glaze_cells_close() {
    let dir = tempfile::tempdir().unwrap();
    let plate = fixture("plate_jittered.obj");
    let mud = crack_stats(&plate, "mud", &[], dir.path(), "mud");
    let (t, y) = (num(&mud, "t_junctions"), num(&mud, "y_junctions"));
    assert!(t > 2.0 * y && t >= 5.0, "mud: T {t}, Y {y}\n{mud}");
    let glaze = crack_stats(&plate, "glaze", &[], dir.path(), "glaze");
    let junctions: f64 = glaze["degree"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .sum::<f64>();
    assert!(
        num(&glaze, "dangling_tips") <= 0.02 * junctions,
        "glaze: {glaze}"
    );
    assert!(num(&glaze, "cells") >= 30.0, "glaze: {glaze}");
}
