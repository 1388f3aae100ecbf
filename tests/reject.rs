//! Inputs that must be refused: each gives a clear error (exit code 1, a
//! message naming the file and what is wrong), no panic and no output file.

mod common;

fn refused(rel: &str, expect: &[&str]) {
    let Some(input) = common::eval_data(rel) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.glb");
    let o = common::run(["convert".as_ref(), input.as_os_str(), out.as_os_str()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{rel}: expected exit 1, got {:?}; stderr: {stderr}",
        o.status
    );
    assert!(!stderr.contains("panicked"), "{rel}: panic: {stderr}");
    let name = input.file_name().unwrap().to_string_lossy().to_string();
    assert!(
        stderr.contains(&name),
        "{rel}: the error must name the file: {stderr}"
    );
    for e in expect {
        assert!(
            stderr.contains(e),
            "{rel}: the error should mention '{e}': {stderr}"
        );
    }
    assert!(!out.exists(), "{rel}: no output may be written");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "{rel}: no temporary file may remain"
    );
}

#[test]
fn draco_required_is_refused_by_name() {
    refused(
        "reject/draco_2CylinderEngine/2CylinderEngine.gltf",
        &["KHR_draco_mesh_compression"],
    );
    refused(
        "reject/compressed/Duck_draco.glb",
        &["KHR_draco_mesh_compression"],
    );
}

#[test]
fn meshopt_required_is_refused_by_name() {
    refused(
        "reject/compressed/Duck_meshopt.glb",
        &["EXT_meshopt_compression"],
    );
}

#[test]
fn skinned_only_assets_have_nothing_to_crack() {
    refused(
        "reject/skinned/quad_skin.glb",
        &["nothing to crack", "skinned"],
    );
    refused(
        "reject/skinned/simple_skin.gltf",
        &["nothing to crack", "skinned"],
    );
}

#[test]
fn index_out_of_range_is_refused() {
    refused(
        "reject/IndexOutOfRange/IndexOutOfRange.gltf",
        &["index 255 out of range"],
    );
}

#[test]
fn missing_bin_is_refused() {
    refused(
        "reject/MissingBin/BoxTextured.gltf",
        &["buffer 0", "BoxTextured0.bin"],
    );
}

#[test]
fn every_reject_file_is_refused() {
    let Some(root) = common::eval_data("reject") else {
        return;
    };
    let mut n = 0;
    for entry in common::files_under(&root, &["gltf", "glb", "obj"]) {
        let rel = entry
            .strip_prefix(root.parent().unwrap())
            .unwrap()
            .to_string_lossy()
            .to_string();
        refused(&rel, &[]);
        n += 1;
    }
    assert!(n >= 7, "expected at least 7 reject files, found {n}");
}
