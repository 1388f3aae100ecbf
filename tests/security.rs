//! Nothing outside the folders the user gave is read: references are
//! followed through symbolic links to their real place, which must lie in
//! the asset's real folder; only regular files are read, with their size
//! checked first. Every case runs the CLI under a time bound (a FIFO read
//! would block forever) and checks that the outside content never reaches
//! the output.
#![cfg(unix)]

mod common;

use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Run the CLI; fails the test if it takes more than 60 s (a blocked read).
fn run_bounded(args: &[&Path]) -> (Option<i32>, String) {
    let mut child = Command::new(common::crackle_bin())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
            assert!(!err.contains("panicked"), "panic: {err}");
            return (status.code(), err);
        }
        if start.elapsed() > Duration::from_secs(60) {
            child.kill().ok();
            panic!("crackle {args:?} ran for more than 60 s (a blocking read?)");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn convert(input: &Path, out: &Path) -> (Option<i32>, String) {
    run_bounded(&[Path::new("convert"), input, out])
}

/// `files` (fixtures) copied into `dir/asset`, and an empty `dir/outside`.
fn asset(dir: &Path, files: &[&str]) -> (PathBuf, PathBuf) {
    let asset = dir.join("asset");
    let outside = dir.join("outside");
    std::fs::create_dir_all(&asset).unwrap();
    std::fs::create_dir_all(&outside).unwrap();
    for f in files {
        std::fs::copy(common::fixture(f), asset.join(f)).unwrap();
    }
    (asset, outside)
}

/// The textured quad (glTF, external .bin and PNG) in `dir/asset`.
fn quad_asset(dir: &Path) -> (PathBuf, PathBuf) {
    asset(
        dir,
        &["textured_quad.gltf", "textured_quad.bin", "checker.png"],
    )
}

/// Refused with exit 1, the message naming `what`; no output written.
fn assert_refused(code: Option<i32>, err: &str, out: &Path, what: &[&str]) {
    assert_eq!(code, Some(1), "{err}");
    for w in what {
        assert!(err.contains(w), "the error should say '{w}': {err}");
    }
    assert!(!out.exists(), "no output may be written");
}

#[test]
fn a_linked_buffer_outside_the_folder_is_refused() {
    let t = tempfile::tempdir().unwrap();
    let (asset, outside) = quad_asset(t.path());
    // The real buffer moves outside; a link inside points to it.
    std::fs::rename(
        asset.join("textured_quad.bin"),
        outside.join("textured_quad.bin"),
    )
    .unwrap();
    symlink(
        outside.join("textured_quad.bin"),
        asset.join("textured_quad.bin"),
    )
    .unwrap();
    let out = t.path().join("out.glb");
    let (code, err) = convert(&asset.join("textured_quad.gltf"), &out);
    assert_refused(
        code,
        &err,
        &out,
        &[
            "buffer 0",
            "textured_quad.bin",
            "outside the asset's folder",
        ],
    );
    // A link to a file inside the folder is followed.
    std::fs::remove_file(asset.join("textured_quad.bin")).unwrap();
    std::fs::rename(outside.join("textured_quad.bin"), asset.join("real.bin")).unwrap();
    symlink("real.bin", asset.join("textured_quad.bin")).unwrap();
    let (code, err) = convert(&asset.join("textured_quad.gltf"), &out);
    assert_eq!(code, Some(0), "{err}");
}

#[test]
fn a_linked_folder_on_the_way_is_refused() {
    let t = tempfile::tempdir().unwrap();
    let (asset, outside) = quad_asset(t.path());
    std::fs::copy(asset.join("checker.png"), outside.join("secret.png")).unwrap();
    symlink(&outside, asset.join("tex")).unwrap();
    let gltf = std::fs::read_to_string(asset.join("textured_quad.gltf")).unwrap();
    assert!(gltf.contains("\"checker.png\""));
    std::fs::write(
        asset.join("textured_quad.gltf"),
        gltf.replace("\"checker.png\"", "\"tex/secret.png\""),
    )
    .unwrap();
    let out = t.path().join("out.glb");
    let (code, err) = convert(&asset.join("textured_quad.gltf"), &out);
    assert_refused(
        code,
        &err,
        &out,
        &["image 0", "tex/secret.png", "outside the asset's folder"],
    );
}

#[test]
fn fifos_folders_and_devices_are_not_read() {
    let t = tempfile::tempdir().unwrap();
    let (asset, _) = quad_asset(t.path());
    let out = t.path().join("out.glb");
    // The buffer is a FIFO (nobody writes to it: a read would block).
    std::fs::remove_file(asset.join("textured_quad.bin")).unwrap();
    let status = Command::new("mkfifo")
        .arg(asset.join("textured_quad.bin"))
        .status()
        .expect("mkfifo");
    assert!(status.success());
    let (code, err) = convert(&asset.join("textured_quad.gltf"), &out);
    assert_refused(
        code,
        &err,
        &out,
        &["buffer 0", "a FIFO, not a regular file"],
    );
    // A folder.
    std::fs::remove_file(asset.join("textured_quad.bin")).unwrap();
    std::fs::create_dir(asset.join("textured_quad.bin")).unwrap();
    let (code, err) = convert(&asset.join("textured_quad.gltf"), &out);
    assert_refused(
        code,
        &err,
        &out,
        &["buffer 0", "a folder, not a regular file"],
    );
    // The main input itself a FIFO.
    let fifo = t.path().join("model.obj");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let (code, err) = convert(&fifo, &out);
    assert_refused(
        code,
        &err,
        &out,
        &["model.obj", "a FIFO, not a regular file"],
    );
    // A device behind a link in the folder: outside it, and not a file.
    std::fs::remove_dir(asset.join("textured_quad.bin")).unwrap();
    symlink("/dev/zero", asset.join("textured_quad.bin")).unwrap();
    let (code, err) = convert(&asset.join("textured_quad.gltf"), &out);
    assert_refused(
        code,
        &err,
        &out,
        &["buffer 0", "outside the asset's folder"],
    );
}

/// The cube (OBJ, MTL, PNG) in `dir/asset`.
fn cube_asset(dir: &Path) -> (PathBuf, PathBuf) {
    asset(dir, &["cube.obj", "cube.mtl", "cube texture.png"])
}

fn output_json(out: &Path) -> serde_json::Value {
    let bytes = std::fs::read(out).unwrap();
    // GLB: the JSON chunk follows the 12-byte header and 8-byte chunk header.
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

#[test]
fn obj_material_libraries_and_maps_do_not_leave_the_folder() {
    let t = tempfile::tempdir().unwrap();
    let (asset, outside) = cube_asset(t.path());
    let out = t.path().join("out.glb");
    // The MTL is a link to a library outside, naming other materials.
    std::fs::write(
        outside.join("evil.mtl"),
        "newmtl red\nKd 0 0.5 0.25\nnewmtl textured\nKd 0.25 0.5 0\n",
    )
    .unwrap();
    std::fs::remove_file(asset.join("cube.mtl")).unwrap();
    symlink(outside.join("evil.mtl"), asset.join("cube.mtl")).unwrap();
    let (code, err) = convert(&asset.join("cube.obj"), &out);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("cube.mtl") && err.contains("outside the asset's folder"),
        "a warning names the library: {err}"
    );
    let doc = output_json(&out).to_string();
    assert!(!doc.contains("0.25"), "the outside library was read: {doc}");

    // The MTL is inside, its texture a link to an image outside.
    std::fs::remove_file(asset.join("cube.mtl")).unwrap();
    std::fs::copy(common::fixture("cube.mtl"), asset.join("cube.mtl")).unwrap();
    std::fs::rename(asset.join("cube texture.png"), outside.join("secret.png")).unwrap();
    symlink(outside.join("secret.png"), asset.join("cube texture.png")).unwrap();
    let (code, err) = convert(&asset.join("cube.obj"), &out);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("cube texture.png") && err.contains("outside the asset's folder"),
        "a warning names the texture: {err}"
    );
    let doc = output_json(&out);
    assert!(
        doc.get("images").is_none(),
        "the outside image reached the output: {doc}"
    );

    // An MTL far larger than any material library (sparse: no disk used):
    // refused by its size, before reading.
    std::fs::remove_file(asset.join("cube.mtl")).unwrap();
    let big = std::fs::File::create(asset.join("cube.mtl")).unwrap();
    big.set_len(crackle::io::paths::MAX_MTL_BYTES + 1).unwrap();
    let (code, err) = convert(&asset.join("cube.obj"), &out);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("cube.mtl") && err.contains("more than the"),
        "a warning gives the size: {err}"
    );
}

#[test]
fn batch_does_not_follow_a_folder_link_out_of_the_input_tree() {
    let t = tempfile::tempdir().unwrap();
    let lib = t.path().join("lib");
    let elsewhere = t.path().join("elsewhere");
    std::fs::create_dir_all(lib.join("inside")).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::fs::copy(common::fixture("cube.obj"), lib.join("inside/a.obj")).unwrap();
    std::fs::copy(common::fixture("cube.obj"), elsewhere.join("b.obj")).unwrap();
    symlink(&elsewhere, lib.join("linked")).unwrap();
    symlink(elsewhere.join("b.obj"), lib.join("c.obj")).unwrap();
    // A link to a folder inside the tree is followed.
    symlink(lib.join("inside"), lib.join("again")).unwrap();
    let out = t.path().join("out");
    let (code, err) = run_bounded(&[
        Path::new("batch"),
        &lib,
        Path::new("-r"),
        Path::new("--out"),
        &out,
        Path::new("--preset"),
        Path::new("glaze"),
        Path::new("--dry-run"),
    ]);
    assert_eq!(code, Some(0), "{err}");
    for name in ["linked", "c.obj"] {
        assert!(
            err.contains(name) && err.contains("outside the input folder"),
            "batch says it skips '{name}': {err}"
        );
    }
    let listed = |o: &Path| {
        Command::new(common::crackle_bin())
            .args([
                "batch".as_ref(),
                lib.as_os_str(),
                "-r".as_ref(),
                "--out".as_ref(),
            ])
            .arg(o)
            .args(["--preset", "glaze", "--dry-run"])
            .output()
            .unwrap()
    };
    let o = listed(&out);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("a.obj"), "{text}");
    assert!(
        !text.contains("b.obj"),
        "an asset outside the tree is listed: {text}"
    );
}

/// The peak resident memory of this process, from /proc (Linux).
fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A 9 KB glTF whose 40 primitives each name a sparse-only accessor (no
/// bufferView: zeros with one substituted element) of 8 million positions:
/// 96 MB each, under the per-accessor cap, 3.8 GB together. The file's
/// decoded total is capped (64 times its real bytes, at least 1 GiB):
/// refused with a message, before allocating it.
#[test]
fn sparse_only_accessors_cannot_add_up_without_bound() {
    let t = tempfile::tempdir().unwrap();
    let n = 40;
    let accessors: Vec<String> = (0..n)
        .map(|_| {
            "{\"componentType\":5126,\"count\":8000000,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,1],\
             \"sparse\":{\"count\":1,\"indices\":{\"bufferView\":0,\"componentType\":5125},\"values\":{\"bufferView\":1}}}"
                .to_string()
        })
        .collect();
    let prims: Vec<String> = (0..n)
        .map(|i| format!("{{\"attributes\":{{\"POSITION\":{i}}}}}"))
        .collect();
    // 4 bytes of index 0, then 12 bytes of the value (1, 1, 1).
    let doc = format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\"scene\":0,\"scenes\":[{{\"nodes\":[0]}}],\"nodes\":[{{\"mesh\":0}}],\
         \"meshes\":[{{\"primitives\":[{}]}}],\
         \"buffers\":[{{\"byteLength\":16,\"uri\":\"data:application/octet-stream;base64,AAAAAAAAgD8AAIA/AACAPw==\"}}],\
         \"bufferViews\":[{{\"buffer\":0,\"byteLength\":4}},{{\"buffer\":0,\"byteOffset\":4,\"byteLength\":12}}],\
         \"accessors\":[{}]}}",
        prims.join(","),
        accessors.join(",")
    );
    assert!(doc.len() < 10_000, "{}", doc.len());
    let input = t.path().join("bomb.gltf");
    std::fs::write(&input, &doc).unwrap();
    let before = peak_rss_bytes();
    let e = crackle::io::read(&input).unwrap_err().to_string();
    assert!(
        e.contains("bomb.gltf") && e.contains("decoded data past"),
        "{e}"
    );
    if let (Some(b), Some(a)) = (before, peak_rss_bytes()) {
        eprintln!("peak resident memory {} MB -> {} MB", b >> 20, a >> 20);
        assert!(
            a < b + (1536 << 20),
            "the reader allocated {} MB",
            (a - b) >> 20
        );
    }
    // --max-memory lowers the limit: two of those accessors (192 MB) are
    // refused under 100M.
    let out = t.path().join("out.glb");
    let o = common::run([
        "convert".as_ref(),
        input.as_os_str(),
        out.as_os_str(),
        "--max-memory".as_ref(),
        "100M".as_ref(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("104857600 bytes"), "{err}");
    assert!(!out.exists());
}

/// The memory limit is an option of each read, not a process-wide setting:
/// in one process a read with a tiny limit is refused while the same file
/// read with the default limit, before and after, succeeds.
#[test]
fn the_memory_limit_belongs_to_each_read() {
    let path = common::fixture("textured_quad.gltf");
    let tiny = crackle::io::ReadOptions { max_memory: 16 };
    let default = crackle::io::ReadOptions::default();
    assert_eq!(default.max_memory, crackle::io::DEFAULT_MAX_MEMORY);
    assert!(crackle::io::read_with(&path, &default).is_ok());
    let e = crackle::io::read_with(&path, &tiny).expect_err("a 16-byte budget refuses the quad");
    // Refused on the budget: the external buffer's declared length (or,
    // for embedded data, the decoded accessors).
    let e = e.to_string();
    assert!(
        e.contains("memory budget") || e.contains("decoded data"),
        "{e}"
    );
    assert!(crackle::io::read_with(&path, &default).is_ok());
    assert!(crackle::io::read(&path).is_ok());
}
