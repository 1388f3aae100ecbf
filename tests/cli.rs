//! The command line: exit codes, stdout/stderr discipline, JSON reports,
//! passthrough of what cannot be cracked, and the security rules for URIs.

mod common;

use std::path::Path;

fn write(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
}

#[test]
fn usage_errors_exit_2() {
    let o = common::run(["convert"]);
    assert_eq!(o.status.code(), Some(2));
    let o = common::run(["frobnicate", "x"]);
    assert_eq!(o.status.code(), Some(2));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.obj");
    let o = common::run([
        "convert".as_ref(),
        common::fixture("cube.obj").as_os_str(),
        out.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2), "OBJ output is a usage error");
    let o = common::run(["info", "--weld-tolerance", "-1", "x.obj"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn processing_errors_exit_1_and_name_the_file() {
    let o = common::run(["info", "does/not/exist.glb"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("does/not/exist.glb"));
    assert!(o.stdout.is_empty(), "errors go to stderr only");
}

#[test]
fn info_json_reports_defects() {
    let o = common::run_ok([
        "info".as_ref(),
        common::fixture("torus.obj").as_os_str(),
        "--json".as_ref(),
    ]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["triangles"], 2304);
    let d = &v["simulation_meshes"][0]["defects"];
    assert_eq!(d["boundary_edges"], 0);
    assert_eq!(d["components"], 1);
    assert_eq!(d["vertices"], 1152);
}

#[test]
fn info_matches_known_defects_of_eval_meshes() {
    // Counts from ../shared/eval-data/SOURCES.md.
    let cases: [(&str, &str, u64); 6] = [
        ("obj/beast/beast.obj", "non_manifold_edges", 2),
        ("obj/beast/beast.obj", "duplicate_triangles", 2),
        ("obj/ogre/ogre.obj", "components", 44),
        ("obj/ogre/ogre.obj", "degenerate_triangles_dropped", 4),
        ("obj/teapot/teapot.obj", "boundary_edges", 160),
        (
            "obj/stanford-bunny/stanford-bunny.obj",
            "boundary_edges",
            223,
        ),
    ];
    for (rel, key, want) in cases {
        let Some(p) = common::eval_data(rel) else {
            return;
        };
        let o = common::run_ok(["info".as_ref(), p.as_os_str(), "--json".as_ref()]);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(
            v["simulation_meshes"][0]["defects"][key], want,
            "{rel}: {key}"
        );
    }
    // OBJ positions no face uses (1,113 in the Stanford bunny) are reported.
    let Some(p) = common::eval_data("obj/stanford-bunny/stanford-bunny.obj") else {
        return;
    };
    let o = common::run_ok(["info".as_ref(), p.as_os_str(), "--json".as_ref()]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let warnings = v["warnings"].to_string();
    assert!(
        warnings.contains("1113 vertices are not used"),
        "{warnings}"
    );
}

#[test]
fn quiet_and_verbose() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.glb");
    let fx = common::fixture("cube.obj");
    let o = common::run_ok([
        "-q".as_ref(),
        "convert".as_ref(),
        fx.as_os_str(),
        out.as_os_str(),
    ]);
    assert!(
        o.stdout.is_empty() && o.stderr.is_empty(),
        "-q prints nothing on success"
    );
    let o = common::run_ok([
        "-v".as_ref(),
        "convert".as_ref(),
        fx.as_os_str(),
        out.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("read") && stderr.contains("write"),
        "-v logs stage times: {stderr}"
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("->") && stdout.contains("12 triangles"),
        "{stdout}"
    );
    let o = common::run(["-q", "-v", "info", "x.obj"]);
    assert_eq!(o.status.code(), Some(2), "-q and -v conflict");
    // A long run shows its progress: a line per round with the cracks and
    // relaxation steps so far, for both engines.
    for preset in ["glaze", "springs-mud"] {
        let fx = common::fixture("plate_jittered.obj");
        let o = common::run_ok([
            "-v".as_ref(),
            "crack".as_ref(),
            fx.as_os_str(),
            out.as_os_str(),
            "--preset".as_ref(),
            preset.as_ref(),
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        let rounds: Vec<&str> = stderr
            .lines()
            .filter(|l| l.contains("mesh 0 'plate': round "))
            .collect();
        assert!(rounds.len() >= 3, "{preset}: {stderr}");
        assert!(
            rounds[0].contains("round 1: ") && rounds[1].contains("round 2: "),
            "{rounds:?}"
        );
        let last = rounds.last().unwrap();
        assert!(
            last.contains(" cracks, ")
                && last.contains(" relaxation steps")
                && !last.contains(": 0 cracks"),
            "{preset}: {last}"
        );
    }
}

/// A glTF with a triangle, a LINES and a POINTS primitive in data URIs.
fn mixed_gltf() -> String {
    use base64::Engine;
    let mut bin: Vec<u8> = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        for x in p {
            bin.extend(x.to_le_bytes());
        }
    }
    let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"name":"mixed","mesh":0}}],
        "meshes":[{{"name":"m","primitives":[
            {{"attributes":{{"POSITION":0}}}},
            {{"attributes":{{"POSITION":0}},"mode":1,"indices":1}},
            {{"attributes":{{"POSITION":0}},"mode":0}}]}}],
        "accessors":[
            {{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
            {{"bufferView":1,"componentType":5121,"count":2,"type":"SCALAR"}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":1,"byteLength":2}}],
        "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{b64}"}},
                   {{"byteLength":2,"uri":"data:application/octet-stream;base64,AAE="}}]}}"#
    )
}

#[test]
fn lines_and_points_pass_through() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("mixed.gltf");
    write(&input, &mixed_gltf());
    let out = dir.path().join("out.gltf");
    let o = common::run_ok(["convert".as_ref(), input.as_os_str(), out.as_os_str()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("passed through"),
        "the user is told: {stderr}"
    );
    if let Some(v) = common::validator() {
        v.assert_clean(&out);
    }
    let back: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let modes: Vec<u64> = back["meshes"][0]["primitives"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.get("mode").and_then(|m| m.as_u64()).unwrap_or(4))
        .collect();
    assert_eq!(modes, vec![4, 1, 0]);
}

#[test]
fn uris_outside_the_asset_folder_are_not_followed() {
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("secret.bin");
    std::fs::write(&secret, [0u8; 64]).unwrap();
    let sub = dir.path().join("asset");
    std::fs::create_dir(&sub).unwrap();
    let base = r#""asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
        "bufferViews":[{"buffer":0,"byteLength":36}]"#;
    let abs = secret.display().to_string();
    for (name, uri) in [
        ("dotdot", "../secret.bin"),
        ("absolute", abs.as_str()),
        ("file", "file:///etc/passwd"),
    ] {
        let input = sub.join(format!("{name}.gltf"));
        write(
            &input,
            &format!(r#"{{{base},"buffers":[{{"byteLength":36,"uri":"{uri}"}}]}}"#),
        );
        let out = dir.path().join(format!("{name}.glb"));
        let o = common::run(["convert".as_ref(), input.as_os_str(), out.as_os_str()]);
        assert_eq!(o.status.code(), Some(1), "{name}");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            stderr.contains("not followed") || stderr.contains("leaves"),
            "{name}: {stderr}"
        );
        assert!(!out.exists());
    }
    // An image URI escaping the folder is refused the same way.
    let input = sub.join("img.gltf");
    write(
        &input,
        r#"{"asset":{"version":"2.0"},"images":[{"uri":"../secret.png"}],"textures":[{"source":0}]}"#,
    );
    let o = common::run(["info".as_ref(), input.as_os_str()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("image 0"));
}

#[test]
fn declared_sizes_larger_than_data_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("small.bin");
    std::fs::write(&bin, [0u8; 36]).unwrap();
    let input = dir.path().join("big.gltf");
    write(
        &input,
        r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
        "bufferViews":[{"buffer":0,"byteLength":36}],
        "buffers":[{"byteLength":4000000000,"uri":"small.bin"}]}"#,
    );
    let o = common::run(["info".as_ref(), input.as_os_str()]);
    assert_eq!(o.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("byteLength declares 4000000000"),
        "{stderr}"
    );
}

#[test]
fn texture_transform_and_material_extensions_are_kept() {
    let Some(input) = common::eval_data("gltf/TextureTransformTest/TextureTransformTest.gltf")
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.gltf");
    common::run_ok(["convert".as_ref(), input.as_os_str(), out.as_os_str()]);
    let src: serde_json::Value = serde_json::from_slice(&std::fs::read(&input).unwrap()).unwrap();
    let back: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert!(back["extensionsUsed"]
        .as_array()
        .unwrap()
        .iter()
        .any(|e| e == "KHR_texture_transform"));
    // Every material keeps its texture-transform blocks, in order.
    let transforms = |v: &serde_json::Value| -> Vec<String> {
        v["materials"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m["pbrMetallicRoughness"]["baseColorTexture"]["extensions"].to_string())
            .collect()
    };
    assert_eq!(transforms(&src), transforms(&back));
}

#[test]
fn assets_without_triangles_are_refused_with_the_reason() {
    for (rel, why) in [
        (
            "gltf/Mesh_PrimitiveMode/Mesh_PrimitiveMode_00.gltf",
            "POINTS",
        ),
        (
            "gltf/Mesh_PrimitiveMode/Mesh_PrimitiveMode_01.gltf",
            "lines",
        ),
    ] {
        let Some(input) = common::eval_data(rel) else {
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.glb");
        let o = common::run(["convert".as_ref(), input.as_os_str(), out.as_os_str()]);
        assert_eq!(o.status.code(), Some(1));
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            stderr.contains("nothing to crack") && stderr.contains(why),
            "{stderr}"
        );
        assert!(!out.exists());
        // `info` still describes it.
        common::run_ok(["info".as_ref(), input.as_os_str()]);
    }
}

#[test]
fn output_is_byte_identical_across_runs_and_thread_counts() {
    let Some(input) = common::eval_data("gltf/CesiumMilkTruck/CesiumMilkTruck.glb") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut outputs = Vec::new();
    for threads in ["1", "2", "1"] {
        let out = dir.path().join(format!("t{}.glb", outputs.len()));
        let o = std::process::Command::new(common::crackle_bin())
            .args(["convert".as_ref(), input.as_os_str(), out.as_os_str()])
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(o.status.success());
        outputs.push(std::fs::read(&out).unwrap());
    }
    assert!(
        outputs.windows(2).all(|w| w[0] == w[1]),
        "outputs differ between runs"
    );
}

#[test]
fn output_folder_is_created() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a/b/cube.gltf");
    common::run_ok([
        "convert".as_ref(),
        common::fixture("cube.obj").as_os_str(),
        out.as_os_str(),
    ]);
    // Side files are named after their content: cube.<tag>.bin.
    let names: Vec<String> = std::fs::read_dir(dir.path().join("a/b"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let tagged = |prefix: &str, ext: &str| {
        names.iter().any(|n| {
            n.strip_prefix(prefix)
                .and_then(|r| r.strip_suffix(ext))
                .is_some_and(|tag| tag.len() == 16 && tag.bytes().all(|b| b.is_ascii_hexdigit()))
        })
    };
    assert!(out.exists() && tagged("cube.", ".bin"), "{names:?}");
    assert!(
        tagged("cube texture.", ".png"),
        "the texture is copied beside the .gltf: {names:?}"
    );
}

/// Temporary files a killed `crack` or `convert` left beside its output
/// (their process is gone) are removed by the next run into that folder;
/// another live process's, and other files, are kept.
#[test]
fn a_run_removes_the_temporary_files_a_killed_run_left() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.glb");
    // Process ids stop far below 999,999,999 (Linux: 4,194,304 at most);
    // process 1 is always alive.
    let stale = dir.path().join(".o.glb.crackle-tmp-999999999-0");
    let stale_bin = dir.path().join(".o.bin.crackle-tmp-999999999-3");
    let live = dir.path().join(".o.glb.crackle-tmp-1-0");
    let other = dir.path().join("notes.crackle-tmp-999999999-0");
    for p in [&stale, &stale_bin, &live, &other] {
        std::fs::write(p, b"x").unwrap();
    }
    let fx = common::fixture("cube.obj");
    for command in ["convert", "crack"] {
        std::fs::write(&stale, b"x").unwrap();
        common::run_ok([
            "-q".as_ref(),
            command.as_ref(),
            fx.as_os_str(),
            out.as_os_str(),
        ]);
        assert!(!stale.exists(), "{command}: the stale temporary is left");
        assert!(!stale_bin.exists() || command == "crack");
        assert!(
            live.exists(),
            "{command}: a live process's temporary was removed"
        );
        assert!(
            other.exists(),
            "{command}: a file not named as a temporary was removed"
        );
        assert!(out.exists());
    }
}

/// The command lines the README and `--help` show, run as written: every
/// backticked span with `--set` (on the jittered plate), the README's
/// `cargo run --release -- crack ...` quick starts (with the binary) and
/// its `crackle batch ... --preset mud` example (on a folder of one mesh).
#[test]
fn documented_examples_work() {
    let readme = std::fs::read_to_string(common::manifest_dir().join("README.md")).unwrap();
    // README spans lie within one line (code fences would upset the
    // pairing of backticks across lines); help text may wrap.
    let mut texts: Vec<String> = readme
        .lines()
        .filter(|l| !l.contains("```"))
        .map(str::to_string)
        .collect();
    for cmd in ["crack", "batch", "study"] {
        let o = common::run_ok([cmd, "--help"]);
        texts.push(String::from_utf8_lossy(&o.stdout).replace('\n', " "));
    }
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("out.glb");
    let ico = common::fixture("icosphere.obj");
    let plate = common::fixture("plate_jittered.obj");
    let mut ran = 0;
    for text in &texts {
        for (i, span) in text.split('`').enumerate() {
            if i % 2 == 0
                || !span.contains("--set")
                || !span.trim_start().starts_with("--")
                || span.contains("KEY")
                || !span.contains('=')
            {
                continue;
            }
            let mut args: Vec<std::ffi::OsString> =
                vec!["crack".into(), plate.clone().into(), out.clone().into()];
            args.extend(span.split_whitespace().map(Into::into));
            let o = common::run(&args);
            assert_eq!(
                o.status.code(),
                Some(0),
                "`{span}`: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            ran += 1;
        }
    }
    assert!(ran >= 4, "only {ran} --set examples found");
    // The quick starts.
    for line in readme.lines() {
        let key = "cargo run --release -- ";
        let Some(at) = line.find(key) else {
            continue;
        };
        let rest = line[at + key.len()..].split('`').next().unwrap_or_default();
        let args: Vec<String> = rest
            .split_whitespace()
            .map(|a| {
                if a.starts_with("fixtures/") {
                    common::manifest_dir()
                        .join(a)
                        .to_string_lossy()
                        .into_owned()
                } else if a.starts_with("out/") {
                    t.path()
                        .join(a.replace('/', "_"))
                        .to_string_lossy()
                        .into_owned()
                } else {
                    a.to_string()
                }
            })
            .collect();
        common::run_ok(&args);
        ran += 1;
    }
    assert!(ran >= 6, "{ran} examples run: the quick starts are missing");
    // The batch example, in a folder with `assets/` of one mesh.
    let line = readme
        .lines()
        .find(|l| l.starts_with("crackle batch assets/ -r --out build/cracked --preset mud"))
        .expect("the README's batch example");
    let cmd = line.split('#').next().unwrap();
    std::fs::create_dir_all(t.path().join("assets/rocks")).unwrap();
    std::fs::copy(&ico, t.path().join("assets/rocks/ico.obj")).unwrap();
    let o = std::process::Command::new(common::crackle_bin())
        .args(cmd.split_whitespace().skip(1))
        .current_dir(t.path())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{cmd}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(t.path().join("build/cracked/rocks/ico.glb").is_file());
}

/// A `.gltf` output and its side files commit as a unit: side files are
/// named after their content, so a new output never overwrites a side file
/// an old one uses (nor an input image of the same name); the old side
/// files go once the new main file is in place; when the main file cannot
/// be placed (a folder in its way), the side files this run placed go
/// again and nothing new is left.
#[test]
fn gltf_outputs_commit_as_a_unit() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    for f in ["textured_quad.gltf", "textured_quad.bin", "checker.png"] {
        std::fs::copy(common::fixture(f), d.join(f)).unwrap();
    }
    let listing = || {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let input = d.join("textured_quad.gltf");
    let checker = std::fs::read(d.join("checker.png")).unwrap();
    // Written beside its input, under the input's name pattern.
    let out = d.join("out.gltf");
    common::run_ok(["convert".as_ref(), input.as_os_str(), out.as_os_str()]);
    let first = listing();
    assert_eq!(first.len(), 6, "{first:?}");
    assert_eq!(std::fs::read(d.join("checker.png")).unwrap(), checker);
    gltf::import(&out).unwrap();
    // Replaced by another asset: its side files replace the old ones.
    let cube = common::fixture("cube.obj");
    common::run_ok(["convert".as_ref(), cube.as_os_str(), out.as_os_str()]);
    let second = listing();
    assert_eq!(second.len(), 6, "old side files remain: {second:?}");
    assert!(second.iter().any(|n| n.starts_with("cube texture.")));
    assert!(!second
        .iter()
        .any(|n| n.starts_with("checker.") && n != "checker.png"));
    gltf::import(&out).unwrap();
    gltf::import(&input).unwrap();
    // A folder where the main file goes: an error, and nothing new stays.
    let blocked = d.join("blocked.gltf");
    std::fs::create_dir(&blocked).unwrap();
    let before = listing();
    let o = common::run(["convert".as_ref(), input.as_os_str(), blocked.as_os_str()]);
    assert_ne!(o.status.code(), Some(0));
    assert_eq!(listing(), before, "{}", String::from_utf8_lossy(&o.stderr));
}

/// Kills between renames: `convert` into a `.gltf` is killed (SIGKILL) at
/// 25 moments across its run, alternating two inputs. After every kill the
/// `.gltf` in place, if any, loads with all its side files; the next
/// completed run leaves only its own files (the dead runs' temporary files
/// removed, the old side files gone).
#[cfg(unix)]
#[test]
fn a_gltf_output_survives_kills_at_any_moment() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // Two inputs that take a while to read and write.
    let mut a = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n");
    for _ in 0..200_000 {
        a.push_str("f 1 2 3\n");
    }
    a.push_str("f 2 4 3\n");
    std::fs::write(d.join("a.obj"), &a).unwrap();
    std::fs::copy(common::fixture("cube.obj"), d.join("b.obj")).unwrap();
    for f in ["cube.mtl", "cube texture.png"] {
        std::fs::copy(common::fixture(f), d.join(f)).unwrap();
    }
    let outdir = d.join("out");
    std::fs::create_dir(&outdir).unwrap();
    let out = outdir.join("scene.gltf");
    // How long a whole run takes.
    let start = std::time::Instant::now();
    common::run_ok([
        "convert".as_ref(),
        d.join("a.obj").as_os_str(),
        out.as_os_str(),
    ]);
    let whole = start.elapsed();
    for k in 0..25u32 {
        let input = d.join(if k % 2 == 0 { "b.obj" } else { "a.obj" });
        let mut child = std::process::Command::new(common::crackle_bin())
            .args(["convert".as_ref(), input.as_os_str(), out.as_os_str()])
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(whole * k / 20);
        let _ = child.kill();
        let _ = child.wait();
        if out.exists() {
            gltf::import(&out).unwrap_or_else(|e| panic!("after a kill at {k}/20: {e}"));
        }
    }
    common::run_ok([
        "convert".as_ref(),
        d.join("b.obj").as_os_str(),
        out.as_os_str(),
    ]);
    gltf::import(&out).unwrap();
    let mut left: Vec<String> = std::fs::read_dir(&outdir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(
        left.len(),
        3,
        "only scene.gltf, its .bin and its texture: {left:?}"
    );
}

/// A `.gltf` written into the current folder by a bare name, twice: its
/// side files stay (the sweep of stray buffers names them as written).
#[test]
fn a_gltf_output_by_bare_name_keeps_its_side_files() {
    let t = tempfile::tempdir().unwrap();
    for f in ["cube.obj", "cube.mtl", "cube texture.png"] {
        std::fs::copy(common::fixture(f), t.path().join(f)).unwrap();
    }
    for _ in 0..2 {
        let o = std::process::Command::new(common::crackle_bin())
            .args(["convert", "cube.obj", "scene.gltf", "-q"])
            .current_dir(t.path())
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        gltf::import(t.path().join("scene.gltf")).unwrap();
    }
    assert_eq!(std::fs::read_dir(t.path()).unwrap().count(), 6);
}

/// The crack command's help shows the library's defaults, not copies typed
/// into the command line: change a default in `SimParams` and the help
/// follows.
#[test]
fn help_shows_the_library_defaults() {
    let out = common::run_ok(["crack", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout).into_owned();
    let d = crackle::sim::SimParams::default();
    for (flag, value) in [
        ("--toughness", d.toughness.to_string()),
        ("--alpha", d.alpha.to_string()),
        ("--shrink-rate", d.shrink_rate.to_string()),
        ("--load-time", d.load_time.to_string()),
        ("--seed", d.seed.to_string()),
        ("--tolerance", d.tolerance.to_string()),
        ("--integrator", d.integrator.name().to_string()),
        ("--max-rounds", d.max_rounds.to_string()),
        ("--max-triangles", d.max_triangles.to_string()),
        ("--finish-rings", d.finish_rings.to_string()),
    ] {
        let at = help
            .find(&format!("{flag} "))
            .unwrap_or_else(|| panic!("{flag} missing from the help:\n{help}"));
        let entry = &help[at..];
        let end = entry[2..].find("\n      -").map_or(entry.len(), |k| k + 2);
        assert!(
            entry[..end].contains(&format!("[default: {value}]")),
            "{flag}: expected [default: {value}] in {:?}",
            &entry[..end]
        );
    }
}

/// `--report` naming the input or the output is refused before any work;
/// both stay as they were (the report overwrote them).
#[test]
fn a_report_never_overwrites_the_input_or_the_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("cube.obj");
    std::fs::copy(common::fixture("cube.obj"), &input).unwrap();
    let before = std::fs::read(&input).unwrap();
    let out = dir.path().join("out.glb");
    for report in [input.clone(), dir.path().join("./out.glb")] {
        let o = common::run([
            "crack".as_ref(),
            input.as_os_str(),
            out.as_os_str(),
            "--preset".as_ref(),
            "glaze".as_ref(),
            "--report".as_ref(),
            report.as_os_str(),
        ]);
        assert_ne!(o.status.code(), Some(0));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("the report would overwrite"), "{err}");
    }
    assert_eq!(std::fs::read(&input).unwrap(), before);
    assert!(!out.exists(), "refused before any work");
}

/// An output that would hold a non-finite number is refused, naming the
/// mesh, and nothing is written (`post.curl=1e300` wrote invalid glTF,
/// exit 0); `--cell-size` with `--cell-size-relative` is a usage error
/// (the relative one silently won).
#[test]
fn no_invalid_number_reaches_an_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.glb");
    let plate = common::fixture("plate_jittered.obj");
    let o = common::run([
        "crack".as_ref(),
        plate.as_os_str(),
        out.as_os_str(),
        "--preset".as_ref(),
        "mud".as_ref(),
        "--set".as_ref(),
        "post.curl=1e300".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("mesh 0 'plate'") && err.contains("not a finite number"),
        "{err}"
    );
    assert!(!out.exists());
    let o = common::run([
        "crack".as_ref(),
        plate.as_os_str(),
        out.as_os_str(),
        "--cell-size".as_ref(),
        "0.1".as_ref(),
        "--cell-size-relative".as_ref(),
        "0.05".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!out.exists());
    // A material no solid has is refused before any work (`young=1e300`
    // wrote no mesh with exit 0, then ran for minutes on steps of 1e-267 s).
    let block = common::fixture("notched_block.obj");
    for (key, named) in [
        ("simulation.ductile.young=1e300", "ductile.young"),
        ("simulation.ductile.density=1e-30", "ductile.density"),
        ("simulation.ductile.tear_speed=1e300", "ductile.tear_speed"),
    ] {
        let started = std::time::Instant::now();
        let o = common::run([
            "crack".as_ref(),
            block.as_os_str(),
            out.as_os_str(),
            "--preset".as_ref(),
            "tear".as_ref(),
            "--set".as_ref(),
            key.as_ref(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{key}: {err}");
        assert!(err.contains(named) && err.contains("must be in"), "{err}");
        assert!(started.elapsed().as_secs() < 30, "{key}: refused late");
        assert!(!out.exists());
    }
}

/// A pipeline or rules file that is a FIFO is refused at once (the run
/// blocked forever reading it): `--pipeline`, `--rules`, and a rules
/// entry's pipeline.
#[cfg(unix)]
#[test]
fn a_fifo_for_a_pipeline_or_rules_is_refused_not_waited_on() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("fifo.toml");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let rules = dir.path().join("rules.toml");
    write(&rules, "[[rule]]\nglob = \"*\"\npipeline = \"fifo.toml\"\n");
    let cube = common::fixture("cube.obj");
    let out = dir.path().join("out");
    let a_glb = out.join("a.glb");
    let crack: Vec<&std::ffi::OsStr> = vec![
        "crack".as_ref(),
        cube.as_os_str(),
        a_glb.as_os_str(),
        "--pipeline".as_ref(),
        fifo.as_os_str(),
    ];
    let batch = |r: &std::path::Path| -> Vec<std::ffi::OsString> {
        [
            "batch".as_ref(),
            cube.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
            "--rules".as_ref(),
            r.as_os_str(),
        ]
        .iter()
        .map(|x| x.to_os_string())
        .collect()
    };
    let runs: Vec<Vec<std::ffi::OsString>> = vec![
        crack.iter().map(|x| x.to_os_string()).collect(),
        batch(&fifo),
        batch(&rules),
    ];
    for args in runs {
        let mut child = std::process::Command::new(common::crackle_bin())
            .args(&args)
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break Some(s);
            }
            if start.elapsed().as_secs() > 30 {
                let _ = child.kill();
                break None;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        let status = status.unwrap_or_else(|| panic!("{args:?} waited on the FIFO"));
        assert_eq!(status.code(), Some(2), "{args:?}");
    }
}

/// An external buffer is held to `--max-memory` (and to the 4 GiB limit of
/// a buffer file) on its declared length before anything is allocated: a
/// 500-byte glTF naming a sparse 3 GiB file took 3.1 GB of memory under
/// `--max-memory 100M`, and 5 GiB aborted on the allocation (exit 134).
#[cfg(unix)]
#[test]
fn a_sparse_buffer_is_refused_before_it_is_allocated() {
    let dir = tempfile::tempdir().unwrap();
    for (gib, budget, expect) in [(3u64, "100M", "--max-memory"), (5, "8G", "4 GiB limit")] {
        let len = gib << 30;
        let bin = dir.path().join(format!("big{gib}.bin"));
        std::fs::File::create(&bin).unwrap().set_len(len).unwrap();
        let gltf = dir.path().join(format!("sparse{gib}.gltf"));
        write(
            &gltf,
            &format!(
                r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"scene":0,
"nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
"min":[0,0,0],"max":[1,1,0]}}],
"bufferViews":[{{"buffer":0,"byteLength":36}}],
"buffers":[{{"uri":"big{gib}.bin","byteLength":{len}}}]}}"#
            ),
        );
        let out = dir.path().join(format!("out{gib}.glb"));
        let o = common::run([
            "convert".as_ref(),
            gltf.as_os_str(),
            out.as_os_str(),
            "--max-memory".as_ref(),
            budget.as_ref(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{gib} GiB: {err}");
        assert!(
            err.contains("buffer 0") && err.contains(expect) && err.contains("sparse"),
            "{gib} GiB: {err}"
        );
        assert!(!out.exists());
    }
}

/// A 16384 x 16384 PNG (about 260 KB of zeros), written row by row.
fn huge_png(path: &Path) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut enc = png::Encoder::new(file, 16384, 16384);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Fast);
    let mut w = enc.write_header().unwrap();
    let mut s = w.stream_writer().unwrap();
    let row = vec![0u8; 16384];
    for _ in 0..16384 {
        std::io::Write::write_all(&mut s, &row).unwrap();
    }
    s.finish().unwrap();
}

/// An image is held to `--max-memory` on its declared size before it is
/// decoded, as a material's base colour in the bake and as a mask: a
/// 16384 x 16384 PNG as `map_Kd` took 4.4 GB and 86 s in `glaze`'s bake
/// under `--max-memory 100M`, as a mask 1.06 GB. Both are refused before
/// the simulation, as every budget is (a usage error, exit 2).
#[test]
fn an_image_over_the_memory_budget_is_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    huge_png(&dir.path().join("big.png"));
    write(
        &dir.path().join("quad.obj"),
        "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl stone\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    );
    write(
        &dir.path().join("quad.mtl"),
        "newmtl stone\nKd 1 1 1\nmap_Kd big.png\n",
    );
    let quad = dir.path().join("quad.obj");
    let out = dir.path().join("out.glb");
    let o = common::run([
        "crack".as_ref(),
        quad.as_os_str(),
        out.as_os_str(),
        "--preset".as_ref(),
        "glaze".as_ref(),
        "--max-memory".as_ref(),
        "100M".as_ref(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("big.png") && err.contains("--max-memory"),
        "{err}"
    );
    assert!(!out.exists());
    // As a mask image of a pipeline.
    write(
        &dir.path().join("masked.toml"),
        "[simulation]\ncell_size_relative = 0.2\n\n[[stress]]\nkind = \"uniform\"\n\
         mask = { image = \"big.png\" }\n",
    );
    let pipeline = dir.path().join("masked.toml");
    let o = common::run([
        "crack".as_ref(),
        quad.as_os_str(),
        out.as_os_str(),
        "--pipeline".as_ref(),
        pipeline.as_os_str(),
        "--max-memory".as_ref(),
        "100M".as_ref(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_ne!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("big.png") && err.contains("--max-memory"),
        "{err}"
    );
    assert!(!out.exists());
}

/// Many objects or primitives are held to `--max-memory` before they are
/// built (100,000 one-triangle OBJ objects, 5.3 MB, took 1.58 GB; 100,000
/// glTF primitives over one buffer 1.17 GB; 1,000 one-triangle objects
/// under `glaze`, each remeshed to its own cell size, asked for 15 million
/// simulated triangles): refused with the numbers at once; a few thousand
/// still convert within the budget.
#[test]
fn many_objects_or_primitives_are_held_to_the_memory_budget() {
    let dir = tempfile::tempdir().unwrap();
    let objs = |n: usize| {
        let mut t = String::new();
        for i in 0..n {
            let (x, y) = ((i % 300) as f64, (i / 300) as f64);
            t += &format!(
                "o t{i}\nv {x} {y} 0\nv {} {y} 0\nv {x} {} 0\nf -3 -2 -1\n",
                x + 0.9,
                y + 0.9
            );
        }
        t
    };
    let prims = |n: usize| {
        // One triangle (positions, then u16 indices) as a data URI, shared
        // by every primitive.
        let mut bin = Vec::new();
        for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
            bin.extend_from_slice(&v.to_le_bytes());
        }
        for i in [0u16, 1, 2, 0] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let b64 = |b: &[u8]| {
            const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
            let mut s = String::new();
            for c in b.chunks(3) {
                let n = (u32::from(c[0]) << 16)
                    | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
                    | u32::from(*c.get(2).unwrap_or(&0));
                for k in 0..4 {
                    if k <= c.len() {
                        s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
                    } else {
                        s.push('=');
                    }
                }
            }
            s
        };
        let p = "{\"attributes\":{\"POSITION\":0},\"indices\":1}";
        format!(
            "{{\"asset\":{{\"version\":\"2.0\"}},\"buffers\":[{{\"byteLength\":44,\"uri\":\"data:application/octet-stream;base64,{}\"}}],\
             \"bufferViews\":[{{\"buffer\":0,\"byteLength\":36}},{{\"buffer\":0,\"byteOffset\":36,\"byteLength\":6}}],\
             \"accessors\":[{{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}},\
             {{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}}],\
             \"meshes\":[{{\"primitives\":[{}]}}],\"nodes\":[{{\"mesh\":0}}],\"scenes\":[{{\"nodes\":[0]}}],\"scene\":0}}",
            b64(&bin),
            vec![p; n].join(",")
        )
    };
    let out = dir.path().join("out.glb");
    let run = |input: &Path, extra: &[&str]| {
        let mut args: Vec<std::ffi::OsString> = vec!["--max-memory".into(), "256M".into()];
        args.extend(extra.iter().map(|a| a.into()));
        args.push(input.into());
        args.push(out.clone().into());
        if extra == ["crack"] {
            args.extend(["--preset".into(), "glaze".into()]);
        }
        let started = std::time::Instant::now();
        let o = common::run(&args);
        (o, started.elapsed())
    };
    for (name, text) in [("objs.obj", objs(100_000)), ("prims.gltf", prims(100_000))] {
        let input = dir.path().join(name);
        write(&input, &text);
        let (o, took) = run(&input, &["convert"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        assert!(
            err.contains(name) && err.contains("100000") && err.contains("--max-memory"),
            "{err}"
        );
        assert!(took.as_secs() < 20, "{name}: refused after {took:?}");
        assert!(!out.exists());
    }
    // Every tiny object remeshed to its own cell size: refused up front.
    let input = dir.path().join("objs300.obj");
    write(&input, &objs(300));
    let (o, took) = run(&input, &["crack"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("simulation surfaces of 300 meshes need about"),
        "{err}"
    );
    assert!(took.as_secs() < 20, "refused after {took:?}");
    assert!(!out.exists());
    // A few thousand convert within the budget.
    for (name, text) in [("objs3k.obj", objs(3000)), ("prims3k.gltf", prims(3000))] {
        let input = dir.path().join(name);
        write(&input, &text);
        let (o, _) = run(&input, &["convert"]);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(crackle::io::read(&out).unwrap().triangle_count(), 3000);
        std::fs::remove_file(&out).unwrap();
    }
}

#[test]
fn a_run_that_forms_no_crack_says_why() {
    // The curvature preset on a flat plate: no crack, as it should, and a
    // warning saying the field keeps the flat surface from cracking.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("flat.glb");
    let o = common::crack(
        &common::fixture("plate_jittered.obj"),
        &out,
        &["--preset", "curvature", "--no-bake"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("no crack formed") && err.contains("curvature term"),
        "{err}"
    );
    // A run that cracks says nothing of the kind.
    let o = common::crack(
        &common::fixture("plate_jittered.obj"),
        &out,
        &["--preset", "glaze", "--no-bake"],
    );
    assert!(o.status.success());
    assert!(!String::from_utf8_lossy(&o.stderr).contains("no crack formed"));
}

/// The memory budget checked before remeshing counts the film's multigrid
/// hierarchy when it is asked for: the same cell size over a small budget
/// is refused at 1,024 bytes a triangle with Jacobi and 1,344 with
/// multigrid, before any work and with no output.
#[test]
fn the_memory_budget_counts_the_film_s_multigrid() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.glb");
    let refusal = |extra: &[&str]| {
        let mut args: Vec<std::ffi::OsString> = vec![
            "crack".into(),
            common::fixture("plate_jittered.obj").into(),
            out.clone().into(),
            "--preset".into(),
            "glaze".into(),
            "--max-memory".into(),
            "1M".into(),
        ];
        args.extend(extra.iter().map(|a| a.into()));
        let o = common::run(&args);
        assert_eq!(o.status.code(), Some(2));
        assert!(!out.exists());
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let jacobi = refusal(&[]);
    let multigrid = refusal(&["--set", "simulation.film_preconditioner=multigrid"]);
    assert!(jacobi.contains("at 1024 bytes each"), "{jacobi}");
    assert!(multigrid.contains("at 1344 bytes each"), "{multigrid}");
}
