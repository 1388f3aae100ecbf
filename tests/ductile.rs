//! `model = "ductile"` from the command line: the `tear` preset on its
//! notched block, an open mesh refused, and the same bytes on any number of
//! threads.

mod common;

use common::{crack, report};
use std::process::Command;

/// A coarse grid keeps the runs short; the benchmark runs the preset's 40.
const COARSE: [&str; 4] = ["--preset", "tear", "--set", "simulation.ductile.grid=12"];

#[test]
fn the_tear_preset_tears_the_notched_block_into_pieces() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("torn.glb");
    let o = crack(&common::fixture("notched_block.obj"), &out, &COARSE);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&out);
    let d = &r["meshes"][0]["post"];
    assert_eq!(d["ductile"]["cg_unconverged"], 0, "{d}");
    assert!(d["ductile"]["cg_iterations"].as_u64().unwrap() > 0, "{d}");
    assert!(d["ductile"]["separated_pull"].as_f64().is_some(), "{d}");
    assert!(d["pieces"].as_u64().unwrap() >= 2, "{d}");
    assert!(r["stages"]
        .as_array()
        .unwrap()
        .iter()
        .any(|s| s["name"] == "tear"));
    // Pieces are nodes of their own; the torn faces have their material.
    let doc = gltf::Gltf::open(&out).unwrap();
    let meshes: Vec<_> = doc.meshes().collect();
    assert!(meshes.len() >= 2, "{} meshes", meshes.len());
    let with_mesh = doc.nodes().filter(|n| n.mesh().is_some()).count();
    assert_eq!(with_mesh, meshes.len());
    let torn = meshes
        .iter()
        .flat_map(|m| m.primitives())
        .filter(|p| p.material().name() == Some("tear_interior"))
        .count();
    assert!(torn >= 2, "each piece has torn faces: {torn}");
    if let Some(v) = common::validator() {
        v.assert_clean(&out);
    }
}

#[test]
fn an_open_mesh_is_refused_with_its_boundary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("open.glb");
    let o = crack(&common::fixture("plate_jittered.obj"), &out, &COARSE);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("mesh 0") && err.contains("boundary loop"),
        "{err}"
    );
    assert!(!out.exists(), "no output for a refused mesh");
}

#[test]
fn the_tear_is_the_same_on_any_number_of_threads() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = Vec::new();
    for threads in ["1", "3"] {
        let out = dir.path().join(format!("t{threads}.glb"));
        let o = Command::new(common::crackle_bin())
            .args([
                "crack".as_ref(),
                common::fixture("notched_block.obj").as_os_str(),
                out.as_os_str(),
            ])
            .args(COARSE)
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        bytes.push(std::fs::read(&out).unwrap());
    }
    assert!(
        bytes[0] == bytes[1],
        "1 and 3 threads wrote different files"
    );
}
