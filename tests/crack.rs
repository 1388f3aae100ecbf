//! `crackle crack`: cracked, valid output with the crack network as lines, a
//! run report with the documented keys, determinism across thread counts.

mod common;

use std::process::Command;

fn crack(
    input: &std::path::Path,
    out: &std::path::Path,
    report: &std::path::Path,
    threads: &str,
    extra: &[&str],
) {
    let o = Command::new(common::crackle_bin())
        .args([
            "crack".as_ref(),
            input.as_os_str(),
            out.as_os_str(),
            "--report".as_ref(),
            report.as_os_str(),
        ])
        .args(extra)
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "crack failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn plate_cracks_validly_and_deterministically() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("plate_jittered.obj");
    let mut bytes = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.path().join(format!("plate{threads}.glb"));
        let rep = dir.path().join(format!("plate{threads}.json"));
        crack(&input, &out, &rep, threads, &[]);
        bytes.push(std::fs::read(&out).unwrap());
        let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&rep).unwrap()).unwrap();
        for key in [
            "cracks",
            "crack_length",
            "triangles",
            "nodes",
            "relaxation_steps",
            "stages",
            "energy",
        ] {
            assert!(r.get(key).is_some(), "report lacks '{key}': {r}");
        }
        assert!(r["cracks"].as_u64().unwrap() > 10, "{r}");
        assert!(r["crack_length"].as_f64().unwrap() > 1.0);
        assert!(r["triangles"]["after"].as_u64() > r["triangles"]["before"].as_u64());
        let stages: Vec<&str> = r["stages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["name"].as_str().unwrap())
            .collect();
        assert_eq!(stages, ["read", "weld", "simulate", "write"]);
        if let Some(v) = common::validator() {
            v.assert_clean(&out);
        }
        let back = crackle::io::read(&out).unwrap();
        let modes: Vec<u32> = back.meshes[0]
            .primitives
            .iter()
            .map(|p| match &p.geometry {
                crackle::scene::Geometry::Raw(r) => r.mode,
                crackle::scene::Geometry::Triangles(_) => 4,
            })
            .collect();
        assert!(
            modes.contains(&1),
            "the crack network is written as LINES: {modes:?}"
        );
        assert!(back
            .materials
            .iter()
            .any(|m| m.name() == Some("crack_lines")));
        // Nothing opens a gap: the output is the input's own mesh, the
        // cracks drawn over it.
        assert_eq!(
            back.triangle_count(),
            crackle::io::read(&input).unwrap().triangle_count(),
            "the input's triangles"
        );
    }
    // The simulation surface, asked for, is split along the cracks: welding
    // it leaves them open.
    let out = dir.path().join("plate-sim.glb");
    let rep = dir.path().join("plate-sim.json");
    crack(
        &input,
        &out,
        &rep,
        "2",
        &["--set", "post.output=\"simulation\""],
    );
    let back = crackle::io::read(&out).unwrap();
    let (entries, _) = crackle::bridge::build_sim_meshes(&back, &Default::default());
    assert!(
        entries[0].report.boundary_edges > 96,
        "cracks add boundary edges"
    );
    assert!(
        bytes[0] == bytes[1],
        "1 and 2 threads give byte-identical output"
    );
}

#[test]
fn icosphere_and_bad_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ico.gltf");
    let rep = dir.path().join("ico.json");
    crack(
        &common::fixture("icosphere.obj"),
        &out,
        &rep,
        "2",
        &["--max-rounds", "60"],
    );
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&rep).unwrap()).unwrap();
    assert!(
        r["cracks"].as_u64().unwrap() > 0,
        "a closed sphere under shrinkage cracks: {r}"
    );
    if let Some(v) = common::validator() {
        v.assert_clean(&out);
    }
    let o = common::run([
        "crack".as_ref(),
        common::fixture("icosphere.obj").as_os_str(),
        out.as_os_str(),
        "--alpha".as_ref(),
        "1.5".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("alpha"));
    let o = common::run([
        "crack".as_ref(),
        common::fixture("icosphere.obj").as_os_str(),
        out.as_os_str(),
        "--toughness=-1".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("toughness"));
}

/// Edges used by exactly one triangle, by vertex index within each
/// triangle primitive (how a renderer sees the mesh: crack edges are open).
fn open_edges(scene: &crackle::scene::Scene) -> usize {
    let mut n = 0;
    for m in &scene.meshes {
        for p in &m.primitives {
            if let crackle::scene::Geometry::Triangles(t) = &p.geometry {
                let mut count: std::collections::HashMap<(u32, u32), u32> = Default::default();
                for tri in &t.triangles {
                    for k in 0..3 {
                        let (a, b) = (tri[k], tri[(k + 1) % 3]);
                        *count.entry((a.min(b), a.max(b))).or_default() += 1;
                    }
                }
                n += count.values().filter(|&&c| c == 1).count();
            }
        }
    }
    n
}

/// Crack an eval-data mesh with the defaults: it must finish with cracks, a
/// valid file, the input's own triangles (the cracks drawn over them), and
/// the input's materials and UVs kept; its simulation surface, asked for,
/// has the crack edges open.
fn eval_mesh_cracks(rel: &str) {
    let Some(input) = common::eval_data(rel) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.glb");
    let rep = dir.path().join("out.json");
    crack(&input, &out, &rep, "2", &[]);
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&rep).unwrap()).unwrap();
    assert!(r["cracks"].as_u64().unwrap() > 20, "{rel}: {r}");
    for m in r["meshes"].as_array().unwrap() {
        assert_eq!(
            m["report"]["stopped"], "nothing fails any more",
            "{rel}: the run ends by itself with the default budget: {m}"
        );
    }
    if let Some(v) = common::validator() {
        v.assert_clean(&out);
    }
    let before = crackle::io::read(&input).unwrap();
    let after = crackle::io::read(&out).unwrap();
    assert_eq!(
        after.triangle_count(),
        before.triangle_count(),
        "{rel}: the input's own triangles"
    );
    let sim_out = dir.path().join("sim.glb");
    crack(
        &input,
        &sim_out,
        &dir.path().join("sim.json"),
        "2",
        &["--set", "post.output=\"simulation\""],
    );
    let sim = crackle::io::read(&sim_out).unwrap();
    assert!(
        open_edges(&sim) > open_edges(&before) + 20,
        "{rel}: the simulation surface is split along the cracks ({} -> {} open edges)",
        open_edges(&before),
        open_edges(&sim)
    );
    let names = |s: &crackle::scene::Scene| {
        s.materials
            .iter()
            .filter_map(|m| m.name().map(str::to_owned))
            .collect::<Vec<_>>()
    };
    for name in names(&before) {
        assert!(names(&after).contains(&name), "{rel}: material {name} kept");
    }
    let semantics = |s: &crackle::scene::Scene| {
        let mut v: Vec<String> = Vec::new();
        for m in &s.meshes {
            for p in &m.primitives {
                if let crackle::scene::Geometry::Triangles(t) = &p.geometry {
                    v.extend(t.attributes.iter().map(|a| a.semantic.clone()));
                }
            }
        }
        v.sort();
        v.dedup();
        v
    };
    for s in semantics(&before) {
        assert!(semantics(&after).contains(&s), "{rel}: attribute {s} kept");
    }
}

#[test]
fn spot_cracks() {
    eval_mesh_cracks("obj/spot/spot_triangulated.obj");
}

#[test]
fn stanford_bunny_with_holes_cracks() {
    eval_mesh_cracks("obj/stanford-bunny/stanford-bunny.obj");
}

#[test]
fn fandisk_cracks() {
    eval_mesh_cracks("obj/fandisk/fandisk.obj");
}

#[test]
fn fix_by_material_or_group_name() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("cube.obj");
    let out = dir.path().join("cube.glb");
    let rep = dir.path().join("cube.json");
    crack(
        &input,
        &out,
        &rep,
        "2",
        &["--fix", "red", "--fix", "textured_faces"],
    );
    let o = common::run([
        "crack".as_ref(),
        input.as_os_str(),
        out.as_os_str(),
        "--fix".as_ref(),
        "no_such_part".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("no_such_part") && err.contains("red") && err.contains("textured_faces"),
        "the error names the unknown name and the names there are: {err}"
    );
}

#[test]
fn crack_lines_carry_formation_time() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("torus.glb");
    let rep = dir.path().join("torus.json");
    crack(&common::fixture("torus.obj"), &out, &rep, "2", &[]);
    let back = crackle::io::read(&out).unwrap();
    let lines = back.meshes[0]
        .primitives
        .iter()
        .find_map(|p| match &p.geometry {
            crackle::scene::Geometry::Raw(r) if r.mode == 1 => Some(r.clone()),
            _ => None,
        })
        .expect("a LINES primitive");
    let t = lines.attributes.get("_CRACK_TIME").expect("_CRACK_TIME");
    let acc = &back.accessors[*t];
    let times: Vec<f32> = acc
        .data
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    assert_eq!(times.len(), acc.count);
    assert!(
        times.windows(2).all(|w| w[0] <= w[1]),
        "segments in formation order"
    );
    assert!(times[0] > 0.0 && times[times.len() - 1] > times[0]);
}
