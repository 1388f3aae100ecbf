//! A short seeded fuzzing run of each reader (OBJ, glTF, GLB) on mutants
//! of the fixtures and the eval-data meshes: no panic, no hang, bounded
//! memory. `scripts/fuzz.sh [seconds]` runs the same engine for longer.

mod common;
mod fuzz_engine;

use fuzz_engine::{fuzz, Kind};

fn short_run(kind: Kind, seed: u64) {
    if common::eval_data("obj").is_none() {
        eprintln!("eval-data missing: fuzzing the fixtures only");
    }
    let out = tempfile::tempdir().unwrap();
    let sum = fuzz(
        &common::manifest_dir(),
        kind,
        seed,
        400,
        f64::INFINITY,
        2 << 20,
        6 << 30,
        out.path(),
    );
    eprintln!("{kind:?}: {sum:?}");
    assert_eq!(sum.cases, 400);
    assert!(sum.failures.is_empty(), "{:#?}", sum.failures);
    assert!(sum.refused > 0 && sum.read > 0, "{sum:?}");
}

#[test]
fn obj_reader_survives_mutants() {
    short_run(Kind::Obj, 1);
}

#[test]
fn gltf_reader_survives_mutants() {
    short_run(Kind::Gltf, 2);
}

#[test]
fn glb_reader_survives_mutants() {
    short_run(Kind::Glb, 3);
}
