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

/// A short seeded run of the hostile classes on the real binary (see
/// `tests/fuzz_engine/hostile.rs`): 20 cases, each class the main one of
/// two; no panic, hang, memory overrun, escape or unreadable output.
#[cfg(unix)]
#[test]
fn the_binary_survives_hostile_asset_folders() {
    use fuzz_engine::hostile::CLASSES;
    use fuzz_engine::hostile_run::{fuzz_hostile, settings};
    let work = tempfile::tempdir().unwrap();
    let s = settings(
        common::crackle_bin(),
        &common::manifest_dir(),
        std::time::Duration::from_secs(60),
        2_000,
    );
    let start = std::time::Instant::now();
    let sum = fuzz_hostile(&s, 5, 20, f64::INFINITY, work.path());
    eprintln!(
        "hostile: {sum:#?} in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    assert_eq!(sum.cases, 20);
    for c in CLASSES {
        assert!(
            sum.per_class.get(&c).is_some_and(|n| *n > 0),
            "{c:?} never ran"
        );
    }
    if !sum.failures.is_empty() {
        // Keep the failing cases' folders for their reproducers.
        let kept = work.keep();
        panic!(
            "{} failures (case folders kept in {}):\n{}",
            sum.failures.len(),
            kept.display(),
            sum.failures.join("\n")
        );
    }
}

/// The hostile checks catch what they look for: a stand-in binary that
/// copies its environment into the output, writes into the victim folder,
/// overruns its time or exits like a panic is reported each time.
#[cfg(unix)]
#[test]
fn the_hostile_checks_catch_escapes_hangs_and_panics() {
    use fuzz_engine::hostile::build;
    use fuzz_engine::hostile_run::{run_case, settings};
    use std::os::unix::fs::PermissionsExt as _;
    let work = tempfile::tempdir().unwrap();
    let script = |name: &str, body: &str| {
        let p = work.path().join(name);
        std::fs::write(&p, format!("#!/bin/sh\n{body}\n")).unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
        p
    };
    let cases = [
        ("leak", "env > ../out/leak.bin", "holds the secret"),
        (
            "write",
            "echo x > ../victim/new.txt",
            "victim/new.txt created",
        ),
        (
            "touch",
            "echo x >> ../victim/secret.txt",
            "victim/secret.txt changed",
        ),
        ("hang", "sleep 30", "hang"),
        (
            "panic",
            "echo 'thread main panicked' >&2; exit 101",
            "panic",
        ),
    ];
    for (i, (name, body, expect)) in cases.into_iter().enumerate() {
        let s = settings(
            script(name, body),
            &common::manifest_dir(),
            std::time::Duration::from_secs(2),
            100,
        );
        let case = build(&s, i as u64, &work.path().join(format!("case-{i}")));
        let (_, fails) = run_case(&s, &case);
        assert!(
            fails.iter().any(|f| f.contains(expect)),
            "{name}: {fails:?}"
        );
    }
}
