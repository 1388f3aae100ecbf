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
        // Glaze cells close: open tips under 2% of the junctions.
        for s in [&coarse, &fine] {
            let junctions: f64 = s["degree"]
                .as_array()
                .unwrap()
                .iter()
                .skip(2)
                .map(|x| x.as_f64().unwrap())
                .sum();
            assert!(
                num(s, "dangling_tips") <= 0.02 * junctions,
                "{rel}: open tips\n{s}"
            );
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
    assert!(num(&s, "paired") < 0.05, "paired: {s}");
    let orientation: Vec<f64> = s["orientation"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    // One pattern's bins stray by up to about 40% (on the sphere, eight
    // seeds: 0.106..0.239); the mesh's own direction is checked pooled, in
    // `a_regular_grid_gives_no_direction`. This catches a pattern that
    // follows the teapot's rows.
    for o in &orientation {
        assert!(
            (o - 1.0 / 6.0).abs() < 0.45 / 6.0,
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

/// A latitude-longitude sphere (rows along its meridians and parallels,
/// fans at its poles: the only directions the mesh has, on a surface that
/// has none): after remeshing its cracks run in every direction about
/// alike relative to those rows (every 30-degree bin within 20% of
/// uniform), and no pole gathers a fan.
#[test]
fn a_regular_grid_gives_no_direction() {
    let (nu, nv) = (48usize, 24usize);
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("uv_sphere.obj");
    let mut text = String::from("v 0 0 1\nv 0 0 -1\n");
    for j in 1..nv {
        let theta = std::f64::consts::PI * j as f64 / nv as f64;
        for i in 0..nu {
            let phi = std::f64::consts::TAU * i as f64 / nu as f64;
            text += &format!(
                "v {} {} {}\n",
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos()
            );
        }
    }
    let id = |i: usize, j: usize| 3 + (j - 1) * nu + (i % nu);
    for i in 0..nu {
        text += &format!("f 1 {} {}\n", id(i, 1), id(i + 1, 1));
        text += &format!("f 2 {} {}\n", id(i + 1, nv - 1), id(i, nv - 1));
    }
    for j in 1..nv - 1 {
        for i in 0..nu {
            text += &format!(
                "f {} {} {} {}\n",
                id(i, j),
                id(i, j + 1),
                id(i + 1, j + 1),
                id(i + 1, j)
            );
        }
    }
    std::fs::write(&obj, text).unwrap();
    // Cracks meet at right angles and first cracks run long, so one
    // pattern's angles are strongly correlated (one seed alone strays by up
    // to 50% in a bin, the same on a rotated sphere): eight seeds are
    // pooled, two runs at a time.
    let seeds: Vec<String> = (1..=8).map(|s| s.to_string()).collect();
    for pair in seeds.chunks(2) {
        std::thread::scope(|scope| {
            for seed in pair {
                let out = dir.path().join(format!("uv_sphere_{seed}.glb"));
                let obj = &obj;
                scope.spawn(move || {
                    run_ok([
                        "-q",
                        "crack",
                        obj.to_str().unwrap(),
                        out.to_str().unwrap(),
                        "--preset",
                        "glaze",
                        "--seed",
                        seed,
                    ])
                });
            }
        });
    }
    let mut bins = [0.0f64; 6];
    let mut most = 0;
    for seed in &seeds {
        let out = dir.path().join(format!("uv_sphere_{seed}.glb"));
        let scene = crackle::io::read(&out).unwrap();
        let p = crackle::stats::PatternInput::from_scene(&scene);
        let stats = crackle::stats::pattern_stats(&p, None);
        eprintln!(
            "seed {seed}: {} cells, max degree {}, orientation {:?}",
            stats.cells, stats.max_degree, stats.orientation
        );
        assert!(stats.cells >= 100, "{stats:?}");
        assert!(stats.paired < 0.05, "seed {seed}: paired {}", stats.paired);
        most = most.max(stats.max_degree);
        // Angle of each crack segment to the parallel through it, folded into
        // [0, 180), length-weighted, 6 bins (the polar caps left out).
        for c in &p.cracks {
            let (a, b) = (p.positions[c[0] as usize], p.positions[c[1] as usize]);
            let m = [
                (a[0] + b[0]) / 2.0,
                (a[1] + b[1]) / 2.0,
                (a[2] + b[2]) / 2.0,
            ];
            let rho = (m[0] * m[0] + m[1] * m[1]).sqrt();
            if rho < 0.3 {
                continue;
            }
            let east = [-m[1] / rho, m[0] / rho, 0.0];
            // North: the normal (the position) crossed with east.
            let north = [
                m[1] * east[2] - m[2] * east[1],
                m[2] * east[0] - m[0] * east[2],
                m[0] * east[1] - m[1] * east[0],
            ];
            let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
            let l = dot(d, d).sqrt();
            let angle = dot(d, north)
                .atan2(dot(d, east))
                .to_degrees()
                .rem_euclid(180.0);
            bins[((angle / 30.0) as usize).min(5)] += l;
        }
    }
    let total: f64 = bins.iter().sum();
    assert!(total > 0.0);
    for (k, b) in bins.iter().enumerate() {
        let share = b / total;
        assert!(
            (share * 6.0 - 1.0).abs() < 0.2,
            "bin {k} ({}-{} degrees to the rows) holds {share:.3} of the length (uniform: 0.167): {:?}",
            30 * k,
            30 * (k + 1),
            bins.map(|b| (b / total * 1000.0).round() / 1000.0)
        );
    }
    // A pole of 48 edges would gather a fan of many cracks.
    assert!(most <= 4, "{most} cracks meet at one vertex");
}
