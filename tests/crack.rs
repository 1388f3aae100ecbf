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
        // The cracks really separate the surface: welding the output gives more than one component.
        let (entries, _) = crackle::bridge::build_sim_meshes(&back, &Default::default());
        assert!(
            entries[0].report.boundary_edges > 96,
            "cracks add boundary edges"
        );
    }
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
