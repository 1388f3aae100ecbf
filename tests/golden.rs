//! Golden files: every built-in preset run on the fixture its description
//! names (at a coarse cell size, [`GOLDEN_CELL`]) must give what
//! `fixtures/golden/<preset>.glb` holds, up to
//! `crackle diff --tolerance 1e-5`. `CRACKLE_UPDATE_GOLDEN=1 cargo test
//! --release --test golden` rewrites the golden files instead.
//!
//! Also `crackle diff` itself: a file against itself, different presets,
//! vertex order, moved positions, renamed nodes, `--json`, missing files.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

/// Tolerance of the golden comparison.
const GOLDEN_TOLERANCE: &str = "1e-5";

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `crackle diff A B EXTRA...`.
fn diff(a: &Path, b: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["diff".as_ref(), a.as_os_str(), b.as_os_str()];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    common::run(args)
}

/// Panics unless `diff` said "equivalent" with exit 0.
fn assert_equivalent(o: &Output, what: &str) {
    assert!(
        o.status.code() == Some(0) && stdout(o).starts_with("equivalent"),
        "{what}: expected equivalent, got {}\n--- stdout ---\n{}\n--- stderr ---\n{}",
        o.status,
        stdout(o),
        stderr(o)
    );
}

/// Panics unless `diff` said "differ" with exit 1; its stdout.
fn assert_differ(o: &Output, what: &str) -> String {
    let out = stdout(o);
    assert!(
        o.status.code() == Some(1) && out.starts_with("differ:"),
        "{what}: expected a difference (exit 1), got {}\n--- stdout ---\n{out}\n--- stderr ---\n{}",
        o.status,
        stderr(o)
    );
    out
}

/// `crackle crack FIXTURE OUT --preset PRESET -q`, which must succeed.
fn crack_preset(preset: &str, fixture: &Path, out: &Path) {
    crack_preset_with(preset, fixture, out, &[]);
}

/// [`crack_preset`] with extra arguments.
fn crack_preset_with(preset: &str, fixture: &Path, out: &Path, extra: &[&str]) {
    let mut args: Vec<&std::ffi::OsStr> = vec![
        "crack".as_ref(),
        fixture.as_os_str(),
        out.as_os_str(),
        "--preset".as_ref(),
        preset.as_ref(),
        "-q".as_ref(),
    ];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    common::run_ok(args);
}

/// The golden runs ask for a coarse cell size (15% of the diagonal), so
/// that the remeshed fixtures, and the golden files, stay small.
const GOLDEN_CELL: [&str; 4] = [
    "--cell-size-relative",
    "0.15",
    "--set",
    "post.bake_size=256",
];

/// Every built-in preset with the fixture its description names ("try it
/// on fixtures/NAME").
fn presets() -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    for (name, _) in crackle::pipeline::PRESETS {
        let p = crackle::pipeline::Pipeline::preset(name, &[]).unwrap();
        let d = &p.description;
        let start = d
            .find("fixtures/")
            .unwrap_or_else(|| panic!("preset {name}: its description names no fixture: {d}"))
            + "fixtures/".len();
        let file: String = d[start..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || "._-".contains(*c))
            .collect();
        out.push((name.to_string(), common::fixture(&file)));
    }
    assert!(out.len() >= 8, "expected the 8 built-in presets: {out:?}");
    out
}

fn updating() -> bool {
    std::env::var("CRACKLE_UPDATE_GOLDEN").is_ok_and(|v| v == "1")
}

#[test]
fn presets_match_golden_files() {
    let golden_dir = common::manifest_dir().join("fixtures").join("golden");
    let dir = tempfile::tempdir().unwrap();
    let update = updating();
    let mut failures = Vec::new();
    for (preset, fixture) in presets() {
        let golden = golden_dir.join(format!("{preset}.glb"));
        let out = dir.path().join(format!("{preset}.glb"));
        // The ductile model's grid, coarse as the cell size.
        let mut args = GOLDEN_CELL.to_vec();
        if preset == "tear" {
            args.extend(["--set", "simulation.ductile.grid=10"]);
        }
        crack_preset_with(&preset, &fixture, &out, &args);
        if update {
            std::fs::create_dir_all(&golden_dir).unwrap();
            std::fs::copy(&out, &golden).unwrap();
            eprintln!(
                "CRACKLE_UPDATE_GOLDEN=1: rewrote {} (preset {preset} on {})",
                golden.display(),
                fixture.display()
            );
            continue;
        }
        if !golden.exists() {
            failures.push(format!(
                "{preset}: golden file {} is missing; create it with \
                 `CRACKLE_UPDATE_GOLDEN=1 cargo test --release --test golden`",
                golden.display()
            ));
            continue;
        }
        let o = diff(&golden, &out, &["--tolerance", GOLDEN_TOLERANCE]);
        if !o.status.success() {
            failures.push(format!(
                "{preset} on {} differs from {} ({}); if the change is intended, \
                 rewrite the golden files with `CRACKLE_UPDATE_GOLDEN=1 cargo test --release \
                 --test golden`\n{}{}",
                fixture.display(),
                golden.display(),
                o.status,
                stdout(&o),
                stderr(&o)
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn diff_of_a_file_with_itself_is_equivalent() {
    for f in ["hierarchy.glb", "textured_quad.gltf", "cube.obj"] {
        let path = common::fixture(f);
        let o = diff(&path, &path, &[]);
        assert_equivalent(&o, f);
        assert!(stdout(&o).contains("triangles"), "totals: {}", stdout(&o));
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("glaze.glb");
    crack_preset("glaze", &common::fixture("icosphere.obj"), &out);
    let o = diff(&out, &out, &[]);
    assert_equivalent(&o, "glaze output");
    assert!(stdout(&o).contains("crack segments"), "{}", stdout(&o));
}

#[test]
fn diff_of_two_presets_names_what_differs() {
    let dir = tempfile::tempdir().unwrap();
    let plate = common::fixture("plate_jittered.obj");
    let (mud, jagged) = (dir.path().join("mud.glb"), dir.path().join("jagged.glb"));
    crack_preset("mud", &plate, &mud);
    crack_preset("mud-jagged", &plate, &jagged);
    let out = assert_differ(&diff(&mud, &jagged, &[]), "mud vs mud-jagged");
    for needle in [
        "mesh 0 'plate' primitive 0: vertices ",
        "triangles ",
        "segments ",
        "crack length ",
    ] {
        assert!(out.contains(needle), "names {needle:?}:\n{out}");
    }
    // The totals of both files.
    assert!(out.contains("\na: ") && out.contains("\nb: "), "{out}");
}

/// A glTF scene with one mesh of two triangles (a quad) with NORMAL and
/// TEXCOORD_0, written by hand as `<name>.gltf` + `<name>.bin`.
struct Quad {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    indices: Vec<u16>,
    node: &'static str,
}

impl Quad {
    fn new() -> Quad {
        Quad {
            positions: vec![
                [0.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [2.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            normals: vec![[0.0, 0.0, 1.0]; 4],
            uvs: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            indices: vec![0, 1, 2, 0, 2, 3],
            node: "quad",
        }
    }

    /// The same quad with its vertices in the order `order` (new vertex k
    /// is old vertex order[k]), triangles remapped, each rotated once and
    /// listed in reverse.
    fn reordered(&self, order: &[usize]) -> Quad {
        let mut inverse = vec![0u16; order.len()];
        for (k, &old) in order.iter().enumerate() {
            inverse[old] = k as u16;
        }
        let mut indices = Vec::new();
        for t in self.indices.chunks(3).rev() {
            let t: Vec<u16> = t.iter().map(|&i| inverse[i as usize]).collect();
            indices.extend([t[1], t[2], t[0]]);
        }
        Quad {
            positions: order.iter().map(|&i| self.positions[i]).collect(),
            normals: order.iter().map(|&i| self.normals[i]).collect(),
            uvs: order.iter().map(|&i| self.uvs[i]).collect(),
            indices,
            node: self.node,
        }
    }

    fn write(&self, dir: &Path, name: &str) -> PathBuf {
        let mut bin: Vec<u8> = Vec::new();
        let mut views = Vec::new();
        let mut push = |bytes: Vec<u8>| {
            let offset = bin.len();
            views.push(
                serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}),
            );
            bin.extend(bytes);
            while bin.len() % 4 != 0 {
                bin.push(0);
            }
        };
        let f32s = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        push(f32s(self.positions.as_flattened()));
        push(f32s(self.normals.as_flattened()));
        push(f32s(self.uvs.as_flattened()));
        push(self.indices.iter().flat_map(|x| x.to_le_bytes()).collect());
        let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in &self.positions {
            for k in 0..3 {
                min[k] = min[k].min(p[k]);
                max[k] = max[k].max(p[k]);
            }
        }
        let n = self.positions.len();
        let gltf = serde_json::json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"name": self.node, "mesh": 0}],
            "meshes": [{"name": "quad", "primitives": [{
                "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                "indices": 3,
            }]}],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3", "min": min, "max": max},
                {"bufferView": 1, "componentType": 5126, "count": n, "type": "VEC3"},
                {"bufferView": 2, "componentType": 5126, "count": n, "type": "VEC2"},
                {"bufferView": 3, "componentType": 5123, "count": self.indices.len(), "type": "SCALAR"},
            ],
            "bufferViews": views,
            "buffers": [{"uri": format!("{name}.bin"), "byteLength": bin.len()}],
        });
        std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_string_pretty(&gltf).unwrap()).unwrap();
        path
    }
}

#[test]
fn diff_ignores_vertex_and_triangle_order() {
    let dir = tempfile::tempdir().unwrap();
    let quad = Quad::new();
    let a = quad.write(dir.path(), "a");
    let b = quad.reordered(&[2, 0, 3, 1]).write(dir.path(), "b");
    assert_equivalent(&diff(&a, &b, &[]), "quad with reordered vertices");
    // With tolerance 0 too (exact values).
    assert_equivalent(
        &diff(&a, &b, &["--tolerance", "0"]),
        "reordered, tolerance 0",
    );
    // Same vertices, other triangles (the other diagonal): not equivalent.
    let mut flipped = Quad::new();
    flipped.indices = vec![0, 1, 3, 1, 2, 3];
    let c = flipped.write(dir.path(), "c");
    let out = assert_differ(&diff(&a, &c, &[]), "other diagonal");
    assert!(out.contains("2 of 2 triangles differ"), "{out}");
}

/// A cracked output (crack splits make vertices identical in every
/// attribute, told apart only by their triangles), its vertices permuted,
/// triangles rotated and reversed, written by the library: equivalent.
#[test]
fn diff_ignores_vertex_order_of_a_cracked_mesh() {
    use crackle::scene::Geometry;
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("glaze.glb");
    crack_preset("glaze", &common::fixture("icosphere.obj"), &a);
    let mut scene = crackle::io::read(&a).unwrap();
    let mut permuted = 0;
    for mesh in &mut scene.meshes {
        for p in &mut mesh.primitives {
            let Geometry::Triangles(t) = &mut p.geometry else {
                continue;
            };
            let n = t.positions.len();
            // A fixed pseudo-random permutation: new vertex k is old order[k].
            let mut order: Vec<usize> = (0..n).collect();
            let mut state = 0x2545_f491_4f6c_dd1d_u64;
            for k in (1..n).rev() {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                order.swap(k, (state >> 33) as usize % (k + 1));
            }
            let mut inverse = vec![0u32; n];
            for (k, &old) in order.iter().enumerate() {
                inverse[old] = k as u32;
            }
            t.positions = order.iter().map(|&i| t.positions[i]).collect();
            for attr in t
                .attributes
                .iter_mut()
                .chain(t.targets.iter_mut().flatten())
            {
                let c = attr.components;
                attr.data = order
                    .iter()
                    .flat_map(|&i| attr.data[i * c..(i + 1) * c].to_vec())
                    .collect();
            }
            t.triangles = t
                .triangles
                .iter()
                .rev()
                .enumerate()
                .map(|(k, tri)| {
                    let r = tri.map(|i| inverse[i as usize]);
                    match k % 3 {
                        0 => r,
                        1 => [r[1], r[2], r[0]],
                        _ => [r[2], r[0], r[1]],
                    }
                })
                .collect();
            permuted += n;
        }
    }
    assert!(permuted > 0);
    let b = dir.path().join("permuted.glb");
    crackle::io::gltf_write::write_scene(&scene, &b).unwrap();
    assert_ne!(
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        "the permuted file must differ in bytes"
    );
    assert_equivalent(&diff(&a, &b, &[]), "cracked mesh with permuted vertices");
}

#[test]
fn diff_reports_a_moved_position() {
    let dir = tempfile::tempdir().unwrap();
    let quad = Quad::new();
    let a = quad.write(dir.path(), "a");
    // Moved by 1e-3 (over the tolerance): one vertex differs in POSITION.
    let mut moved = Quad::new();
    moved.positions[2][1] += 1e-3;
    let b = moved.write(dir.path(), "b");
    let out = assert_differ(&diff(&a, &b, &["--tolerance", "1e-5"]), "moved 1e-3");
    assert!(
        out.contains("mesh 0 'quad' primitive 0: 1 of 4 vertices differ in POSITION by up to"),
        "{out}"
    );
    assert!(out.contains("tolerance 1e-5 scaled by 2"), "{out}");
    // Also when the vertices are reordered.
    let c = moved.reordered(&[3, 2, 1, 0]).write(dir.path(), "c");
    let out = assert_differ(&diff(&a, &c, &["--tolerance", "1e-5"]), "moved, reordered");
    assert!(out.contains("1 of 4 vertices differ in POSITION"), "{out}");
    assert!(out.contains("vertices matched up to order"), "{out}");
    // A move within the tolerance is equivalent: 1e-3 against 1e-3 x 2.
    assert_equivalent(
        &diff(&a, &b, &["--tolerance", "1e-3"]),
        "moved 1e-3, tolerance 1e-3 scaled by 2",
    );
    // Another attribute.
    let mut uv = Quad::new();
    uv.uvs[1][0] = 0.5;
    let d = uv.write(dir.path(), "d");
    let out = assert_differ(&diff(&a, &d, &[]), "uv moved");
    assert!(
        out.contains("1 of 4 vertices differ in TEXCOORD_0 by up to 0.5"),
        "{out}"
    );
}

#[test]
fn diff_reports_structure() {
    let dir = tempfile::tempdir().unwrap();
    let a = Quad::new().write(dir.path(), "a");
    let mut renamed = Quad::new();
    renamed.node = "other";
    let b = renamed.write(dir.path(), "b");
    let out = assert_differ(&diff(&a, &b, &[]), "renamed node");
    assert!(
        out.contains("node 0 'quad': name 'quad' vs 'other'"),
        "{out}"
    );
    // A file with another hierarchy and materials.
    let out = assert_differ(
        &diff(&a, &common::fixture("hierarchy.glb"), &[]),
        "quad vs hierarchy",
    );
    assert!(out.contains("nodes: count 1 vs 4"), "{out}");
    assert!(out.contains("materials: count 0 vs 3"), "{out}");
}

#[test]
fn diff_json_is_parseable() {
    let dir = tempfile::tempdir().unwrap();
    let a = Quad::new().write(dir.path(), "a");
    let mut moved = Quad::new();
    moved.positions[0][2] = 0.25;
    let b = moved.write(dir.path(), "b");

    let o = diff(&a, &b, &["--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o))
        .unwrap_or_else(|e| panic!("not JSON ({e}): {}", stdout(&o)));
    assert_eq!(v["equivalent"], false);
    let diffs = v["differences"].as_array().unwrap();
    assert!(!diffs.is_empty());
    assert!(diffs.iter().any(|d| d["kind"] == "attribute_values"
        && d["where"] == "mesh 0 'quad' primitive 0"
        && d["detail"].as_str().unwrap().contains("POSITION")));
    for side in ["a", "b"] {
        assert_eq!(v["summary"][side]["triangles"], 2, "{v}");
        assert_eq!(v["summary"][side]["vertices"], 4, "{v}");
        assert_eq!(v["summary"][side]["crack_segments"], 0, "{v}");
    }

    let o = diff(&a, &a, &["--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["equivalent"], true);
    assert_eq!(v["differences"].as_array().map(Vec::len), Some(0));
}

#[test]
fn diff_of_a_missing_file_names_it() {
    let dir = tempfile::tempdir().unwrap();
    let present = common::fixture("cube.obj");
    let missing = dir.path().join("no_such_file.glb");
    for (a, b) in [(&missing, &present), (&present, &missing)] {
        let o = diff(a, b, &[]);
        assert!(!o.status.success(), "missing file must fail");
        assert!(
            stderr(&o).contains("no_such_file.glb"),
            "the error names the file: {}",
            stderr(&o)
        );
    }
}
