//! `crackle batch`: folders in, mirrored folders out, exit codes, the
//! report, the incremental state, determinism across `--jobs`, a killed run,
//! rules, shards and the emitted build files.

mod common;

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn batch(args: &[&str]) -> Output {
    Command::new(common::crackle_bin())
        .arg("batch")
        .args(args)
        .output()
        .unwrap()
}

fn p(x: &Path) -> &str {
    x.to_str().unwrap()
}

fn copy(from: &Path, to: &Path) {
    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
    std::fs::copy(from, to).unwrap();
}

/// A small asset library: an OBJ plate, an OBJ cube with its MTL and a
/// texture, a glTF with its .bin, a GLB with a hierarchy, a text file that
/// is not an asset, and (when `bad`) a glTF whose .bin is missing.
fn library(root: &Path, bad: bool) {
    copy(
        &common::fixture("plate_jittered.obj"),
        &root.join("good/plate.obj"),
    );
    for f in ["cube.obj", "cube.mtl", "cube texture.png"] {
        copy(&common::fixture(f), &root.join("good/cube").join(f));
    }
    for f in ["textured_quad.gltf", "textured_quad.bin", "checker.png"] {
        copy(&common::fixture(f), &root.join("good/quad").join(f));
    }
    copy(
        &common::fixture("hierarchy.glb"),
        &root.join("props/hierarchy.glb"),
    );
    std::fs::write(root.join("props/readme.txt"), "not an asset").unwrap();
    if bad {
        let reject = common::eval_data("reject/MissingBin/BoxTextured.gltf")
            .expect("eval-data reject/MissingBin (see SOURCES.md)");
        copy(&reject, &root.join("bad/BoxTextured.gltf"));
    }
}

fn report(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// status per input file name.
fn statuses(r: &Value) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = r["assets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| {
            let name = Path::new(a["input"].as_str().unwrap())
                .file_name()
                .unwrap()
                .to_string_lossy()
                .into_owned();
            (name, a["status"].as_str().unwrap().to_string())
        })
        .collect();
    v.sort();
    v
}

/// Every regular file under `dir` (relative, sorted), hidden ones included.
fn files(dir: &Path) -> Vec<PathBuf> {
    fn walk(root: &Path, d: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.push(p.strip_prefix(root).unwrap().to_path_buf());
            }
        }
    }
    let mut out = Vec::new();
    if dir.exists() {
        walk(dir, dir, &mut out);
    }
    out.sort();
    out
}

fn glb_is_complete(path: &Path) -> bool {
    let b = std::fs::read(path).unwrap();
    b.len() >= 12
        && &b[0..4] == b"glTF"
        && u32::from_le_bytes(b[8..12].try_into().unwrap()) as usize == b.len()
}

#[test]
fn a_mixed_folder_reports_the_bad_asset_then_redoes_only_what_changed() {
    let t = tempfile::tempdir().unwrap();
    let (lib, out) = (t.path().join("lib"), t.path().join("out"));
    library(&lib, true);
    let rep = t.path().join("r.json");
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--preset",
        "mud",
        "-j",
        "2",
        "--report",
        p(&rep),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("BoxTextured.gltf"), "{stderr}");
    let r = report(&rep);
    assert_eq!(
        statuses(&r),
        [
            ("BoxTextured.gltf", "failed"),
            ("cube.obj", "cracked"),
            ("hierarchy.glb", "cracked"),
            ("plate.obj", "cracked"),
            ("textured_quad.gltf", "cracked"),
        ]
        .map(|(a, b)| (a.to_string(), b.to_string()))
    );
    let bad = r["assets"]
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["status"] == "failed")
        .unwrap();
    assert!(
        bad["error"].as_str().unwrap().contains("BoxTextured"),
        "{bad}"
    );
    assert_eq!(r["totals"]["failed"], 1);
    assert_eq!(r["totals"]["cracked"], 4);
    for a in r["assets"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["status"] == "cracked")
    {
        assert!(
            a["cracks"].as_u64().is_some() && a["output_bytes"].as_u64().unwrap() > 0,
            "{a}"
        );
        assert!(
            a["stages"]
                .as_array()
                .unwrap()
                .iter()
                .any(|s| s["name"] == "simulate"),
            "{a}"
        );
    }
    // The tree is mirrored; nothing is written for the bad asset.
    let written: Vec<PathBuf> = files(&out)
        .into_iter()
        .filter(|f| !f.to_string_lossy().starts_with('.'))
        .collect();
    assert_eq!(
        written,
        [
            "good/cube/cube.glb",
            "good/plate.glb",
            "good/quad/textured_quad.glb",
            "props/hierarchy.glb"
        ]
        .map(PathBuf::from)
    );
    for f in &written {
        assert!(glb_is_complete(&out.join(f)), "{f:?}");
    }
    let before: Vec<Vec<u8>> = written
        .iter()
        .map(|f| std::fs::read(out.join(f)).unwrap())
        .collect();
    let mtimes = |w: &[PathBuf]| -> Vec<std::time::SystemTime> {
        w.iter()
            .map(|f| std::fs::metadata(out.join(f)).unwrap().modified().unwrap())
            .collect()
    };
    let m0 = mtimes(&written);

    // Second run: every good asset is up to date and untouched; the bad one
    // fails again.
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--preset",
        "mud",
        "--report",
        p(&rep),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let r = report(&rep);
    let s = statuses(&r);
    assert_eq!(
        s.iter().filter(|(_, st)| st == "up-to-date").count(),
        4,
        "{s:?}"
    );
    assert_eq!(mtimes(&written), m0);

    // A texture's bytes change: only its asset runs again.
    let tex = lib.join("good/cube/cube texture.png");
    let mut bytes = std::fs::read(&tex).unwrap();
    bytes.extend_from_slice(b"\0\0\0\0");
    std::fs::write(&tex, bytes).unwrap();
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--preset",
        "mud",
        "--report",
        p(&rep),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let s = statuses(&report(&rep));
    assert_eq!(
        s.iter()
            .filter(|(_, st)| st == "cracked")
            .map(|(n, _)| n.as_str())
            .collect::<Vec<_>>(),
        ["cube.obj"],
        "{s:?}"
    );
    // Another pipeline, or --force, reruns everything.
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--preset",
        "glaze",
        "--report",
        p(&rep),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(report(&rep)["totals"]["cracked"], 4);
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--preset",
        "mud",
        "--force",
        "--report",
        p(&rep),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(report(&rep)["totals"]["cracked"], 4);
    // Same inputs and pipeline again: the same bytes as the first run.
    for (f, b) in written.iter().zip(&before) {
        if !f.starts_with("good/cube") {
            assert_eq!(&std::fs::read(out.join(f)).unwrap(), b, "{f:?}");
        }
    }
    // --fail-fast stops at the failure (one job: nothing after it starts).
    let out2 = t.path().join("out2");
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out2),
        "--preset",
        "mud",
        "-j",
        "1",
        "--fail-fast",
        "--report",
        p(&rep),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let r = report(&rep);
    assert_eq!(r["assets"][0]["status"], "failed", "{r}"); // bad/ sorts first
    assert_eq!(r["totals"]["not_run"], 4, "{r}");
}

#[test]
fn outputs_are_the_same_whatever_the_jobs() {
    let t = tempfile::tempdir().unwrap();
    let lib = t.path().join("lib");
    library(&lib, false);
    // Also glTF output (JSON, .bin and images beside it).
    for fmt in ["glb", "gltf"] {
        let (a, b) = (
            t.path().join(format!("j1{fmt}")),
            t.path().join(format!("j2{fmt}")),
        );
        for (dir, j) in [(&a, "1"), (&b, "2")] {
            let o = batch(&[
                p(&lib),
                "-r",
                "--out",
                p(dir),
                "--preset",
                "glaze",
                "-j",
                j,
                "--format",
                fmt,
                "-q",
            ]);
            assert_eq!(
                o.status.code(),
                Some(0),
                "{}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        let (fa, fb) = (files(&a), files(&b));
        assert_eq!(fa, fb);
        assert!(
            fa.iter().any(|f| f.extension().is_some_and(|e| e == fmt)),
            "{fa:?}"
        );
        for f in fa
            .iter()
            .filter(|f| !f.to_string_lossy().starts_with(".crackle"))
        {
            assert_eq!(
                std::fs::read(a.join(f)).unwrap(),
                std::fs::read(b.join(f)).unwrap(),
                "{f:?}"
            );
        }
    }
    // The outputs pass the Khronos validator.
    if let Some(v) = common::validator() {
        let out = t.path().join("j2glb");
        for f in files(&out)
            .iter()
            .filter(|f| f.extension().is_some_and(|e| e == "glb"))
        {
            let r = v.validate(out.join(f));
            assert_eq!(r.errors, 0, "{f:?}: {}", r.describe());
        }
    }
}

#[test]
fn nothing_to_do_usage_errors_and_dry_runs() {
    let t = tempfile::tempdir().unwrap();
    let empty = t.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    std::fs::write(empty.join("notes.txt"), "x").unwrap();
    let out = t.path().join("out");
    let o = batch(&[p(&empty), "-r", "--out", p(&out)]);
    assert_eq!(
        o.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("nothing to do"));
    // A missing input, a bad shard, an output on top of its input: usage errors.
    let o = batch(&[p(&t.path().join("nope")), "--out", p(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nope"));
    let lib = t.path().join("lib");
    library(&lib, false);
    for s in ["0/2", "3/2", "x"] {
        let o = batch(&[p(&lib), "-r", "--out", p(&out), "--shard", s]);
        assert_eq!(o.status.code(), Some(2), "{s}");
    }
    let props = lib.join("props");
    let o = batch(&[p(&props), "--out", p(&props)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("is the input folder"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let glb = props.join("hierarchy.glb");
    let o = batch(&[p(&glb), "--out", p(&props)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("is an input"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // Two inputs writing one output.
    let clash = t.path().join("clash");
    copy(&common::fixture("plate_jittered.obj"), &clash.join("a.obj"));
    copy(&common::fixture("hierarchy.glb"), &clash.join("a.glb"));
    let o = batch(&[p(&clash), "--out", p(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("would both write"));
    // A dry run lists every asset and writes nothing.
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--preset",
        "mud",
        "--dry-run",
    ]);
    assert_eq!(o.status.code(), Some(0));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(stdout.matches("crack (preset mud)").count(), 4, "{stdout}");
    assert!(!out.exists());
    // A quoted glob picks assets by pattern, relative to its folder.
    let glob = format!("{}/**/*.obj", p(&lib));
    let o = batch(&[&glob, "--out", p(&out), "--dry-run"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("good/plate.glb") && stdout.contains("good/cube/cube.glb"),
        "{stdout}"
    );
    assert!(!stdout.contains("hierarchy"), "{stdout}");
}

#[test]
fn rules_choose_pipelines_copy_and_skip() {
    let t = tempfile::tempdir().unwrap();
    let (lib, out) = (t.path().join("lib"), t.path().join("out"));
    library(&lib, false);
    let rules = t.path().join("rules.toml");
    std::fs::write(
        &rules,
        r#"
unmatched = "skip"

[[rule]]
glob = "plate.obj"        # no '/': the file name at any depth
preset = "mud"
set = ["simulation.seed=7"]

[[rule]]
glob = "good/cube/*"
action = "copy"

[[rule]]
glob = "props/**"
preset = "glaze"
"#,
    )
    .unwrap();
    let rep = t.path().join("r.json");
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--rules",
        p(&rules),
        "--report",
        p(&rep),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let r = report(&rep);
    let by_name = |n: &str| {
        r["assets"]
            .as_array()
            .unwrap()
            .iter()
            .find(|a| a["input"].as_str().unwrap().ends_with(n))
            .unwrap()
            .clone()
    };
    assert_eq!(by_name("plate.obj")["pipeline"], "preset mud");
    assert_eq!(by_name("plate.obj")["rule"], 1);
    assert_eq!(by_name("hierarchy.glb")["pipeline"], "preset glaze");
    assert_eq!(by_name("cube.obj")["status"], "copied");
    assert_eq!(by_name("textured_quad.gltf")["status"], "skipped");
    // A copy brings the files the asset references, unchanged.
    for f in ["cube.obj", "cube.mtl", "cube texture.png"] {
        assert_eq!(
            std::fs::read(out.join("good/cube").join(f)).unwrap(),
            std::fs::read(lib.join("good/cube").join(f)).unwrap(),
            "{f}"
        );
    }
    assert!(!out.join("good/quad").exists());
    // The rule's own set applies: seed 7 differs from the default seed.
    let plain = t.path().join("plain.glb");
    let o = Command::new(common::crackle_bin())
        .args([
            "crack",
            p(&lib.join("good/plate.obj")),
            p(&plain),
            "--preset",
            "mud",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_ne!(
        std::fs::read(&plain).unwrap(),
        std::fs::read(out.join("good/plate.glb")).unwrap()
    );
    // Rules and --preset together, or a bad rule, are usage errors.
    let o = batch(&[
        p(&lib),
        "--out",
        p(&out),
        "--rules",
        p(&rules),
        "--preset",
        "mud",
    ]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::write(&rules, "[[rule]]\nglob = \"*\"\naction = \"melt\"\n").unwrap();
    let o = batch(&[p(&lib), "--out", p(&out), "--rules", p(&rules)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("melt"));
}

#[test]
fn shards_split_the_assets_between_them() {
    let t = tempfile::tempdir().unwrap();
    let lib = t.path().join("lib");
    for i in 0..12 {
        copy(
            &common::fixture("cube.obj"),
            &lib.join(format!("a{i:02}.obj")),
        );
    }
    let mut seen: Vec<String> = Vec::new();
    for k in 1..=3 {
        let o = batch(&[
            p(&lib),
            "--out",
            p(&t.path().join("o")),
            "--shard",
            &format!("{k}/3"),
            "--dry-run",
        ]);
        assert!(matches!(o.status.code(), Some(0 | 3)));
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        let mine: Vec<String> = stdout
            .lines()
            .filter(|l| l.starts_with("crack"))
            .map(|l| l.split_whitespace().last().unwrap().to_string())
            .collect();
        assert!(mine.len() < 12, "shard {k}/3 has every asset");
        seen.extend(mine);
    }
    seen.sort();
    let before = seen.len();
    seen.dedup();
    assert_eq!(before, seen.len(), "an asset is in two shards");
    assert_eq!(seen.len(), 12, "every asset is in a shard: {seen:?}");
    // Two shards running at once into one folder keep each other's state.
    let out = t.path().join("shared");
    let spawn = |k: &str| {
        Command::new(common::crackle_bin())
            .args(["batch", p(&lib), "--out", p(&out), "--shard", k, "-q"])
            .spawn()
            .unwrap()
    };
    let (mut a, mut b) = (spawn("1/2"), spawn("2/2"));
    assert!(a.wait().unwrap().success() && b.wait().unwrap().success());
    let o = batch(&[p(&lib), "--out", p(&out), "--dry-run"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("12 assets: 0 to do, 12 up to date"),
        "{stdout}"
    );
}

#[test]
fn a_killed_batch_leaves_no_partial_output_and_a_rerun_completes() {
    let t = tempfile::tempdir().unwrap();
    let (lib, out) = (t.path().join("lib"), t.path().join("out"));
    for i in 0..10 {
        copy(
            &common::fixture("bumps.obj"),
            &lib.join(format!("b{i}.obj")),
        );
    }
    let mut child = Command::new(common::crackle_bin())
        .args([
            "batch",
            p(&lib),
            "--out",
            p(&out),
            "--preset",
            "mud",
            "-j",
            "2",
            "-q",
        ])
        .spawn()
        .unwrap();
    // Kill it (SIGKILL) once the first output and the state are there.
    let start = std::time::Instant::now();
    loop {
        let done = files(&out)
            .iter()
            .filter(|f| f.extension().is_some_and(|e| e == "glb"))
            .count();
        let saved = out.join(".crackle-batch.json").exists();
        if (done >= 1 && saved) || start.elapsed().as_secs() > 60 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let left: Vec<PathBuf> = files(&out)
        .into_iter()
        .filter(|f| !f.to_string_lossy().starts_with('.'))
        .collect();
    assert!(
        !left.is_empty() && left.len() < 10,
        "killed mid-way: {left:?}"
    );
    for f in &left {
        assert!(glb_is_complete(&out.join(f)), "{f:?} is partial");
    }
    // The rerun does the rest and leaves no temporary file behind.
    let rep = t.path().join("r.json");
    let o = batch(&[
        p(&lib),
        "--out",
        p(&out),
        "--preset",
        "mud",
        "-j",
        "2",
        "-q",
        "--report",
        p(&rep),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let r = report(&rep);
    let up = r["totals"]["up_to_date"].as_u64().unwrap();
    assert!(up >= 1 && up as usize <= left.len(), "{}", r["totals"]);
    assert_eq!(up + r["totals"]["cracked"].as_u64().unwrap(), 10);
    let all = files(&out);
    assert!(
        all.iter()
            .all(|f| !f.to_string_lossy().contains("crackle-tmp")),
        "{all:?}"
    );
    let glbs: Vec<&PathBuf> = all
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "glb"))
        .collect();
    assert_eq!(glbs.len(), 10);
    // Every output is the same asset cracked the same way.
    let first = std::fs::read(out.join(glbs[0])).unwrap();
    for f in glbs {
        assert_eq!(std::fs::read(out.join(f)).unwrap(), first, "{f:?}");
    }
}

fn ninja() -> Option<PathBuf> {
    let local = common::manifest_dir().join("tools/ninja/bin/ninja");
    if local.exists() {
        return Some(local);
    }
    if Command::new("ninja")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return Some(PathBuf::from("ninja"));
    }
    assert!(
        !common::in_ci(),
        "ninja is missing: run scripts/install-ninja.sh"
    );
    eprintln!("SKIP: ninja is not installed (scripts/install-ninja.sh)");
    None
}

#[test]
fn emitted_build_files_build_what_the_batch_builds() {
    let t = tempfile::tempdir().unwrap();
    let lib = t.path().join("lib");
    library(&lib, false);
    let reference = t.path().join("ref");
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&reference),
        "--preset",
        "mud",
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0));
    let outputs: Vec<PathBuf> = files(&reference)
        .into_iter()
        .filter(|f| !f.to_string_lossy().starts_with('.'))
        .collect();
    assert_eq!(outputs.len(), 4);
    let check = |out: &Path| {
        for f in &outputs {
            assert_eq!(
                std::fs::read(out.join(f)).unwrap(),
                std::fs::read(reference.join(f)).unwrap(),
                "{f:?}"
            );
        }
    };
    // make
    let out = t.path().join("make out");
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--preset",
        "mud",
        "--emit",
        "make",
    ]);
    assert_eq!(o.status.code(), Some(0));
    let makefile = t.path().join("Makefile");
    std::fs::write(&makefile, &o.stdout).unwrap();
    let m = Command::new("make")
        .args(["-j2", "-s", "-f", p(&makefile)])
        .output()
        .unwrap();
    assert!(m.status.success(), "{}", String::from_utf8_lossy(&m.stderr));
    check(&out);
    let m = Command::new("make")
        .args(["-f", p(&makefile)])
        .output()
        .unwrap();
    assert!(
        String::from_utf8_lossy(&m.stdout).contains("Nothing to be done"),
        "{}",
        String::from_utf8_lossy(&m.stdout)
    );
    // ninja
    if let Some(ninja) = ninja() {
        let out = t.path().join("ninja out");
        let o = batch(&[
            p(&lib),
            "-r",
            "--out",
            p(&out),
            "--preset",
            "mud",
            "--emit",
            "ninja",
        ]);
        assert_eq!(o.status.code(), Some(0));
        let file = t.path().join("build.ninja");
        std::fs::write(&file, &o.stdout).unwrap();
        let n = Command::new(&ninja)
            .current_dir(t.path())
            .args(["-f", p(&file), "-j", "2"])
            .output()
            .unwrap();
        assert!(
            n.status.success(),
            "{}{}",
            String::from_utf8_lossy(&n.stdout),
            String::from_utf8_lossy(&n.stderr)
        );
        check(&out);
        let n = Command::new(&ninja)
            .current_dir(t.path())
            .args(["-f", p(&file)])
            .output()
            .unwrap();
        assert!(
            String::from_utf8_lossy(&n.stdout).contains("no work to do"),
            "{}",
            String::from_utf8_lossy(&n.stdout)
        );
        // A changed texture rebuilds its asset only.
        let tex = lib.join("good/cube/cube texture.png");
        let mut bytes = std::fs::read(&tex).unwrap();
        bytes.push(0);
        std::thread::sleep(std::time::Duration::from_millis(1100));
        std::fs::write(&tex, bytes).unwrap();
        let n = Command::new(&ninja)
            .current_dir(t.path())
            .args(["-f", p(&file), "-d", "explain", "-n"])
            .output()
            .unwrap();
        let so = String::from_utf8_lossy(&n.stdout);
        assert!(
            so.contains("[1/1]"),
            "{so}{}",
            String::from_utf8_lossy(&n.stderr)
        );
    }
}

#[test]
fn assets_sharing_files_and_names_never_collide() {
    // Sibling OBJs sharing one MTL and texture, written as glTF by many
    // jobs at once: each output's image is its own file, none fails.
    let t = tempfile::tempdir().unwrap();
    let (lib, out) = (t.path().join("lib"), t.path().join("out"));
    for f in ["cube.mtl", "cube texture.png"] {
        copy(&common::fixture(f), &lib.join(f));
    }
    for i in 0..12 {
        copy(
            &common::fixture("cube.obj"),
            &lib.join(format!("c{i:02}.obj")),
        );
    }
    // Two folders whose textures share a name but not their bytes.
    for (d, fill) in [("ta", 1u8), ("tb", 2u8)] {
        copy(&common::fixture("cube.obj"), &lib.join(d).join("cube.obj"));
        copy(&common::fixture("cube.mtl"), &lib.join(d).join("cube.mtl"));
        let mut png = std::fs::read(common::fixture("cube texture.png")).unwrap();
        png.extend(std::iter::repeat_n(fill, 8));
        std::fs::write(lib.join(d).join("cube texture.png"), png).unwrap();
    }
    let rep = t.path().join("r.json");
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--format",
        "gltf",
        "-j",
        "8",
        "-q",
        "--report",
        p(&rep),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(report(&rep)["totals"]["cracked"], 14);
    // Side files carry a tag of their content: `<name>.<16 hex>.<ext>`.
    let untagged = |f: &Path| -> String {
        let name = f.to_string_lossy();
        let parts: Vec<&str> = name.split('.').collect();
        parts
            .iter()
            .filter(|x| !(x.len() == 16 && x.bytes().all(|b| b.is_ascii_hexdigit())))
            .copied()
            .collect::<Vec<_>>()
            .join(".")
    };
    let names = files(&out);
    assert!(
        names.iter().any(|f| untagged(f) == "c00_cube texture.png"),
        "{names:?}"
    );
    // Each output's texture is its own asset's.
    for d in ["ta", "tb"] {
        let texture = names
            .iter()
            .find(|f| untagged(f) == format!("{d}/cube_cube texture.png"))
            .unwrap_or_else(|| panic!("{d}: {names:?}"));
        assert_eq!(
            std::fs::read(out.join(texture)).unwrap(),
            std::fs::read(lib.join(d).join("cube texture.png")).unwrap()
        );
    }
    // The output folder may not be an input folder.
    let o = batch(&[p(&lib), "-r", "--out", p(&lib)]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn a_reference_that_appears_later_rebuilds_and_copies_need_no_decoding() {
    let t = tempfile::tempdir().unwrap();
    let (lib, out) = (t.path().join("lib"), t.path().join("out"));
    // An OBJ whose MTL is missing at first.
    copy(&common::fixture("cube.obj"), &lib.join("cube.obj"));
    let rep = t.path().join("r.json");
    let run = || {
        batch(&[
            p(&lib),
            "--out",
            p(&out),
            "--preset",
            "mud",
            "-q",
            "--report",
            p(&rep),
        ])
    };
    assert_eq!(run().status.code(), Some(0));
    assert_eq!(report(&rep)["totals"]["cracked"], 1);
    assert_eq!(run().status.code(), Some(0));
    assert_eq!(report(&rep)["totals"]["up_to_date"], 1);
    for f in ["cube.mtl", "cube texture.png"] {
        copy(&common::fixture(f), &lib.join(f));
    }
    assert_eq!(run().status.code(), Some(0));
    assert_eq!(
        report(&rep)["totals"]["cracked"],
        1,
        "the new MTL rebuilds the asset"
    );
    // A folder link that loops does not hang the walk.
    #[cfg(unix)]
    std::os::unix::fs::symlink(&lib, lib.join("loop")).unwrap();
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--preset",
        "mud",
        "--dry-run",
    ]);
    assert_eq!(o.status.code(), Some(0));
    // A compressed glTF crackle cannot decode is still copied by a copy rule.
    if let Some(draco) = common::eval_data("reject/compressed/Duck_draco.glb") {
        let lib2 = t.path().join("lib2");
        copy(&draco, &lib2.join("duck.glb"));
        let rules = t.path().join("rules.toml");
        std::fs::write(&rules, "unmatched = \"copy\"\n").unwrap();
        let out2 = t.path().join("out2");
        let o = batch(&[p(&lib2), "--out", p(&out2), "--rules", p(&rules), "-q"]);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(
            std::fs::read(out2.join("duck.glb")).unwrap(),
            std::fs::read(&draco).unwrap()
        );
    }
}

/// The library runs a batch on its own: plan, triage, execute with an
/// observer, the report; a second triage finds everything up to date.
#[test]
fn the_library_runs_a_batch_without_the_command_line() {
    use crackle::batch::{self, BatchObserver, Choice, Options, PipeSpec, Status};
    use std::sync::atomic::{AtomicUsize, Ordering};
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    copy(&common::fixture("icosphere.obj"), &input.join("a/ball.obj"));
    copy(&common::fixture("torus.obj"), &input.join("ring.obj"));
    std::fs::write(input.join("notes.txt"), "not an asset").unwrap();
    let out = dir.path().join("out");
    let options = Options {
        inputs: vec![p(&input).to_string()],
        out: out.clone(),
        recursive: true,
        format: batch::OutFormat::Glb,
        jobs: 2,
        fail_fast: false,
        force: false,
        shard: None,
        weld: crackle::mesh::WeldOptions::default(),
        read: crackle::io::ReadOptions::default(),
    };
    let choice = || {
        let pipeline = crackle::pipeline::Pipeline::preset("glaze", &[]).unwrap();
        let spec = PipeSpec::new(None, Some("glaze".into()), vec![], pipeline);
        Choice::One(Box::new(spec.unwrap()))
    };
    let plan = batch::plan(&options, choice()).unwrap();
    let rels: Vec<&str> = plan.assets.iter().map(|a| a.rel.as_str()).collect();
    assert_eq!(rels, ["a/ball.obj", "ring.obj"]);
    assert_eq!(plan.assets[0].output, out.join("a/ball.glb"));

    #[derive(Default)]
    struct Count {
        started: AtomicUsize,
        stages: AtomicUsize,
        done: AtomicUsize,
    }
    impl BatchObserver for Count {
        fn start(&self, _: usize, _: &batch::Asset) {
            self.started.fetch_add(1, Ordering::SeqCst);
        }
        fn stage(&self, _: usize, _: &batch::Asset, _: &str) {
            self.stages.fetch_add(1, Ordering::SeqCst);
        }
        fn done(&self, _: usize, _: &batch::Asset, _: &batch::Outcome) {
            self.done.fetch_add(1, Ordering::SeqCst);
        }
    }
    let count = Count::default();
    let triage = batch::triage(&plan, &options, true);
    assert_eq!(triage.todo, [0, 1]);
    let (outcomes, seconds) = batch::execute(&plan, &options, triage, &count).unwrap();
    assert!(seconds > 0.0);
    assert_eq!(count.started.load(Ordering::SeqCst), 2);
    assert_eq!(count.done.load(Ordering::SeqCst), 2);
    assert!(
        count.stages.load(Ordering::SeqCst) >= 2 * 4,
        "read, weld, simulate, write..."
    );
    assert!(
        outcomes.iter().all(|o| o.status == Status::Cracked),
        "{outcomes:?}"
    );
    for a in &plan.assets {
        assert!(a.output.is_file(), "{}", a.output.display());
    }
    let report = batch::BatchReport::new(&plan, &out, None, &outcomes, seconds);
    assert_eq!(report.totals.cracked, 2);
    let cracks: usize = report.assets.iter().map(|r| r.cracks.unwrap()).sum();
    assert!(cracks > 0 && cracks == report.totals.cracks);

    // The state file makes the next triage find both up to date; a forced
    // one redoes both.
    let plan = batch::plan(&options, choice()).unwrap();
    let again = batch::triage(&plan, &options, true);
    assert!(again.todo.is_empty());
    assert!(again.outcomes.iter().all(|o| o.status == Status::UpToDate));
    let forced = Options {
        force: true,
        ..options.clone()
    };
    assert_eq!(batch::triage(&plan, &forced, false).todo, [0, 1]);
}

/// Nothing from outside the asset folder lands in the output: a copy rule
/// refuses a buffer linked to a file outside the folder and an image
/// linked to `/proc/self/environ` (the asset fails, named; the others go
/// on). They were copied, exit 0.
#[cfg(unix)]
#[test]
fn copies_take_nothing_from_outside_the_asset_folder() {
    use std::os::unix::fs::symlink;
    let t = tempfile::tempdir().unwrap();
    let secret = t.path().join("secret.txt");
    std::fs::write(&secret, "TOKEN=hunter2").unwrap();
    // Row 1: copy rules and links out of the asset folder.
    let lib = t.path().join("lib");
    for f in ["textured_quad.gltf", "checker.png"] {
        copy(&common::fixture(f), &lib.join("quad").join(f));
    }
    symlink(&secret, lib.join("quad/textured_quad.bin")).unwrap();
    copy(
        &common::fixture("textured_quad.gltf"),
        &lib.join("env/quad.gltf"),
    );
    copy(
        &common::fixture("textured_quad.bin"),
        &lib.join("env/textured_quad.bin"),
    );
    symlink("/proc/self/environ", lib.join("env/checker.png")).unwrap();
    copy(
        &common::fixture("hierarchy.glb"),
        &lib.join("fine/hierarchy.glb"),
    );
    let rules = t.path().join("rules.toml");
    std::fs::write(&rules, "unmatched = \"copy\"\n").unwrap();
    let out = t.path().join("out");
    let rep = t.path().join("r.json");
    let o = batch(&[
        p(&lib),
        "-r",
        "--out",
        p(&out),
        "--rules",
        p(&rules),
        "--report",
        p(&rep),
    ]);
    assert_ne!(o.status.code(), Some(0), "two assets refused");
    let r = report(&rep);
    assert_eq!(r["totals"]["failed"], 2, "{r}");
    assert_eq!(r["totals"]["copied"], 1, "{r}");
    assert!(out.join("fine/hierarchy.glb").is_file());
    for f in files(&out) {
        let bytes = std::fs::read(out.join(&f)).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(!text.contains("hunter2"), "{f:?} holds the outside file");
        assert!(!text.contains("PATH="), "{f:?} holds the environment");
    }
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("outside the asset's folder"), "{stderr}");
}

/// Links planted under temporary names in an asset tree that holds
/// `--out` are never written through, and the output is a file, not a
/// link (the temporary was `.NAME.crackle-tmp-PID-N`, written through a
/// link of that name).
#[cfg(unix)]
#[test]
fn planted_temporaries_are_never_written_through() {
    use std::os::unix::fs::symlink;
    let t = tempfile::tempdir().unwrap();
    let tree = t.path().join("tree");
    copy(&common::fixture("cube.obj"), &tree.join("a.obj"));
    let out = tree.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let victim = t.path().join("victim.txt");
    std::fs::write(&victim, "precious").unwrap();
    // Process ids are handed out in turn: the batch's is most likely
    // among the next few thousand (the names the old writer used).
    let me = std::process::id();
    for pid in me + 1..me + 3000 {
        for n in 0..2 {
            let name = format!(".a.glb.crackle-tmp-{pid}-{n}");
            symlink(&victim, out.join(name)).unwrap();
        }
    }
    let o = batch(&[
        p(&tree.join("a.obj")),
        "--out",
        p(&out),
        "--preset",
        "glaze",
        "-q",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious");
    let written = std::fs::symlink_metadata(out.join("a.glb")).unwrap();
    assert!(
        written.file_type().is_file(),
        "the output is a file, not a link"
    );
}

/// A folder link inside `--out` is not written through: the asset fails,
/// named (a copy replaced a file wherever the link pointed).
#[cfg(unix)]
#[test]
fn folder_links_inside_the_output_are_not_written_through() {
    use std::os::unix::fs::symlink;
    let t = tempfile::tempdir().unwrap();
    let lib3 = t.path().join("lib3");
    copy(&common::fixture("cube.obj"), &lib3.join("sub/a.obj"));
    let out3 = t.path().join("out3");
    let elsewhere = t.path().join("elsewhere");
    std::fs::create_dir_all(&out3).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();
    symlink(&elsewhere, out3.join("sub")).unwrap();
    let o = batch(&[p(&lib3), "-r", "--out", p(&out3), "--preset", "glaze"]);
    assert_ne!(o.status.code(), Some(0));
    assert!(
        std::fs::read_dir(&elsewhere).unwrap().next().is_none(),
        "nothing written through the folder link"
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("symbolic link inside the output folder"),
        "{stderr}"
    );
}

/// An asset saved while the batch cracks it is reported and left out of
/// date: its output is from the bytes read before the save. The batch
/// hashed the asset after cracking it, recorded the new bytes' hash beside
/// the old bytes' output, and every later run said "up to date".
#[test]
fn an_asset_saved_during_its_run_stays_out_of_date() {
    let t = tempfile::tempdir().unwrap();
    let (lib, out) = (t.path().join("lib"), t.path().join("out"));
    let plate = lib.join("plate.obj");
    copy(&common::fixture("plate_jittered.obj"), &plate);
    // Slow enough (several seconds) for the save to land mid-run.
    let pipeline = t.path().join("slow.toml");
    std::fs::write(
        &pipeline,
        "[simulation]\ncell_size_relative = 0.03\n\n[[stress]]\nkind = \"uniform\"\n",
    )
    .unwrap();
    let rep = t.path().join("r.json");
    let args = [
        p(&lib),
        "--out",
        p(&out),
        "--pipeline",
        p(&pipeline),
        "--report",
        p(&rep),
    ];
    // The save lands once the batch says it has hashed the asset's files
    // (its info log), however slowly the machine starts it.
    let mut child = Command::new(common::crackle_bin())
        .arg("batch")
        .args(args)
        .arg("-v")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(child.stderr.take().unwrap()));
    let mut stderr = String::new();
    for line in lines.by_ref() {
        let line = line.unwrap();
        stderr += &line;
        stderr.push('\n');
        if line.contains("plate.obj: started") {
            break;
        }
    }
    let mut text = std::fs::read_to_string(&plate).unwrap();
    text.push_str("# saved again\n");
    std::fs::write(&plate, text).unwrap();
    for line in lines {
        stderr += &line.unwrap();
        stderr.push('\n');
    }
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(0), "{stderr}");
    let r = report(&rep);
    let row = &r["assets"][0];
    assert_eq!(row["status"], "cracked", "{r}");
    assert!(
        row["warning"]
            .as_str()
            .is_some_and(|w| w.contains("changed while it was processed")),
        "the save landed after the run, or was not noticed: {r}"
    );
    assert!(
        stderr.contains("changed while it was processed"),
        "{stderr}"
    );
    // The next run cracks it again (from the saved bytes), then it is up
    // to date.
    for expect in ["cracked", "up-to-date"] {
        let o = batch(&args);
        assert_eq!(o.status.code(), Some(0));
        assert_eq!(
            statuses(&report(&rep)),
            [("plate.obj".to_string(), expect.to_string())]
        );
    }
}

#[test]
fn a_copy_of_a_gltf_whose_buffer_is_missing_fails_and_writes_nothing_of_it() {
    // The copy would name a buffer the output does not have (a file
    // removed, or swapped for a link, while the batch runs reads as missing
    // at one moment): that asset fails, the others are copied.
    let t = tempfile::tempdir().unwrap();
    let lib = t.path().join("lib");
    let out = t.path().join("out");
    for f in ["textured_quad.gltf", "checker.png"] {
        copy(&common::fixture(f), &lib.join("quad").join(f));
    }
    for f in ["cube.obj", "cube.mtl", "cube texture.png"] {
        copy(&common::fixture(f), &lib.join("cube").join(f));
    }
    let rules = t.path().join("rules.toml");
    std::fs::write(&rules, "unmatched = \"copy\"\n").unwrap();
    let o = batch(&[p(&lib), "-r", "--out", p(&out), "--rules", p(&rules)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("textured_quad.gltf") && err.contains("textured_quad.bin"),
        "{err}"
    );
    assert!(!out.join("quad").join("textured_quad.gltf").exists());
    assert!(!out.join("quad").join("checker.png").exists());
    for f in ["cube.obj", "cube.mtl", "cube texture.png"] {
        assert!(out.join("cube").join(f).is_file(), "{f}");
    }
}
