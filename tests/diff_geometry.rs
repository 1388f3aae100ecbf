//! `crackle diff --geometry` ("b is a's own mesh"): a converted fixture and a
//! glaze output (maps, lines and attributes added) are a's own mesh; a moved
//! vertex, rotated triangle corners and a removed attribute are not;
//! `--same-indices` makes split vertices a difference.

mod common;

use crackle::scene::{
    Geometry, Material, Primitive, RawAccessor, RawGeometry, Scene, TriGeometry, VertexAttribute,
};
use std::path::Path;
use std::process::Output;

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `crackle diff A B EXTRA...`.
fn diff(a: &Path, b: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["diff".as_ref(), a.as_os_str(), b.as_os_str()];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    common::run(args)
}

/// `diff --geometry EXTRA...` must exit with `code`; its stdout.
fn geometry(a: &Path, b: &Path, extra: &[&str], code: i32, what: &str) -> String {
    let mut args = vec!["--geometry"];
    args.extend(extra);
    let o = diff(a, b, &args);
    let out = stdout(&o);
    assert_eq!(
        o.status.code(),
        Some(code),
        "{what}: diff {args:?} should exit {code}\n--- stdout ---\n{out}\n--- stderr ---\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let verdict = if code == 0 { "equivalent" } else { "differ:" };
    assert!(out.starts_with(verdict), "{what}: {out}");
    out
}

/// `summary.geometry` of `diff --geometry --json`, which must exit with `code`.
fn geometry_json(a: &Path, b: &Path, code: i32) -> serde_json::Value {
    let o = diff(a, b, &["--geometry", "--json"]);
    assert_eq!(o.status.code(), Some(code), "{}", stdout(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["mode"], "geometry");
    assert_eq!(v["equivalent"], code == 0);
    v["summary"]["geometry"].clone()
}

/// The triangles of mesh 0's first primitive of `s`.
fn tri0(s: &mut Scene) -> &mut TriGeometry {
    match &mut s.meshes[0].primitives[0].geometry {
        Geometry::Triangles(t) => t,
        Geometry::Raw(_) => panic!("primitive 0 is not decoded triangles"),
    }
}

/// `fixture` read by the library, edited by `edit`, written as `name` in `dir`.
fn edited(
    dir: &Path,
    fixture: &str,
    name: &str,
    edit: impl FnOnce(&mut Scene),
) -> std::path::PathBuf {
    let mut s = crackle::io::read(&common::fixture(fixture)).unwrap();
    edit(&mut s);
    let out = dir.join(name);
    crackle::io::gltf_write::write_scene(&s, &out).unwrap();
    out
}

#[test]
fn converted_fixtures_are_their_inputs_own_mesh() {
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "icosphere.obj",
        "torus.obj",
        "textured_quad.gltf",
        "hierarchy.glb",
    ] {
        let input = common::fixture(name);
        let out = dir.path().join(format!("{name}.glb"));
        common::run_ok([
            "convert".as_ref(),
            input.as_os_str(),
            out.as_os_str(),
            "-q".as_ref(),
        ]);
        let text = geometry(&input, &out, &[], 0, name);
        assert!(
            text.contains("\ngeometry: vertices "),
            "{name}: no geometry line: {text}"
        );
        let g = geometry_json(&input, &out, 0);
        assert!(g["triangles"].as_u64().unwrap() > 0, "{name}: {g}");
        assert_eq!(
            g["vertices_a"], g["vertices_b"],
            "{name}: convert adds no vertex"
        );
    }
}

#[test]
fn glaze_output_is_the_inputs_own_mesh_but_not_the_same_file() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("icosphere.obj");
    let out = dir.path().join("ico.glb");
    let o = common::crack(&input, &out, &["--preset", "glaze", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    geometry(&input, &out, &[], 0, "glaze output");
    let g = geometry_json(&input, &out, 0);
    assert_eq!(g["triangles"], 1280, "{g}");
    assert!(g["vertices_b"].as_u64() >= g["vertices_a"].as_u64(), "{g}");
    assert_eq!(
        g["split_vertices"].as_i64().unwrap(),
        g["vertices_b"].as_i64().unwrap() - g["vertices_a"].as_i64().unwrap()
    );

    // The whole file is not the same: materials, maps and lines were added.
    let o = diff(&input, &out, &[]);
    let text = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(text.contains("material"), "{text}");

    // Nor is the output a's own mesh the other way round: the input lacks
    // the attributes the output has.
    let back = geometry(&out, &input, &[], 1, "input against the glaze output");
    assert!(back.contains("_CRACK_DISTANCE missing in b"), "{back}");
}

#[test]
fn a_moved_vertex_differs_naming_mesh_primitive_triangle_and_attribute() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("icosphere.obj");
    // Written unchanged by the library, the file is the input's own mesh.
    let same = edited(dir.path(), "icosphere.obj", "same.glb", |_| {});
    geometry(&input, &same, &["--same-indices"], 0, "unchanged");

    let moved = edited(dir.path(), "icosphere.obj", "moved.glb", |s| {
        tri0(s).positions[7][1] += 0.25;
    });
    let text = geometry(&input, &moved, &[], 1, "moved vertex");
    let line = text
        .lines()
        .find(|l| l.contains("POSITION differs"))
        .unwrap_or_else(|| panic!("no POSITION line: {text}"));
    assert!(line.contains("mesh 0 'icosphere' primitive 0"), "{line}");
    assert!(line.contains("first at triangle "), "{line}");
    assert!(line.contains("vertex 7 of a"), "{line}");
    assert!(line.contains("by up to 0.25 "), "{line}");
    // Below the tolerance the same move is no difference.
    geometry(
        &input,
        &moved,
        &["--tolerance", "0.3"],
        0,
        "moved within tolerance",
    );
}

#[test]
fn rotated_corners_differ() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("icosphere.obj");
    let rotated = edited(dir.path(), "icosphere.obj", "rotated.glb", |s| {
        let t = tri0(s);
        for k in [10, 500] {
            let [a, b, c] = t.triangles[k];
            t.triangles[k] = [b, c, a];
        }
    });
    let text = geometry(&input, &rotated, &[], 1, "rotated corners");
    assert!(
        text.contains("POSITION differs at 6 corners of 2 of 1280 triangles"),
        "{text}"
    );
    assert!(text.contains("first at triangle 10 "), "{text}");
    let g = geometry_json(&input, &rotated, 1);
    assert_eq!(g["triangles_same_indices"], 1278, "{g}");
}

#[test]
fn a_removed_attribute_differs_an_added_one_does_not() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("icosphere.obj");
    let removed = edited(dir.path(), "icosphere.obj", "removed.glb", |s| {
        let t = tri0(s);
        let n = t.attributes.len();
        t.attributes.retain(|a| a.semantic != "NORMAL");
        assert_eq!(t.attributes.len(), n - 1, "the fixture has normals");
    });
    let text = geometry(&input, &removed, &[], 1, "NORMAL removed");
    assert!(
        text.contains("mesh 0 'icosphere' primitive 0: NORMAL missing in b primitive 0"),
        "{text}"
    );

    // What crackle adds is ignored: an attribute, and a crack-wall primitive.
    let added = edited(dir.path(), "icosphere.obj", "added.glb", |s| {
        let t = tri0(s);
        let n = t.positions.len();
        t.attributes.push(VertexAttribute {
            semantic: "_CRACK_DISTANCE".into(),
            components: 1,
            data: vec![0.5; n],
        });
        add_primitive(s, "crack_wall");
    });
    geometry(
        &input,
        &added,
        &["--same-indices"],
        0,
        "attribute and wall added",
    );

    // Another added triangle primitive is more triangles.
    let other = edited(dir.path(), "icosphere.obj", "other.glb", |s| {
        add_primitive(s, "extra")
    });
    let text = geometry(&input, &other, &[], 1, "triangles added");
    assert!(text.contains("triangles 1280 vs 1281"), "{text}");
}

#[test]
fn morph_targets_are_compared_per_corner_and_counted() {
    let dir = tempfile::tempdir().unwrap();
    // One POSITION displacement target, vertex 5 displaced by `dy`.
    let target = |dy: f32| {
        move |s: &mut Scene| {
            let t = tri0(s);
            let mut data = vec![0.0; 3 * t.positions.len()];
            data[16] = dy;
            t.targets.push(vec![VertexAttribute {
                semantic: "POSITION".into(),
                components: 3,
                data,
            }]);
        }
    };
    let a = edited(dir.path(), "icosphere.obj", "a.glb", target(0.5));
    let same = edited(dir.path(), "icosphere.obj", "same.glb", target(0.5));
    geometry(&a, &same, &["--same-indices"], 0, "same target");
    let moved = edited(dir.path(), "icosphere.obj", "moved.glb", target(0.25));
    let text = geometry(&a, &moved, &[], 1, "target moved");
    assert!(
        text.contains("primitive 0: morph target 0 POSITION differs at "),
        "{text}"
    );
    assert!(text.contains("vertex 5 of a"), "{text}");
    let none = edited(dir.path(), "icosphere.obj", "none.glb", |_| {});
    let text = geometry(&a, &none, &[], 1, "target removed");
    assert!(text.contains("morph targets 1 vs 0"), "{text}");
}

/// Add to mesh 0 a one-triangle primitive with a new material named `material`.
fn add_primitive(s: &mut Scene, material: &str) {
    let mut m = Material::default();
    m.json.insert("name".into(), material.into());
    s.materials.push(m);
    s.meshes[0].primitives.push(Primitive {
        material: Some(s.materials.len() - 1),
        geometry: Geometry::Triangles(TriGeometry {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
            ..Default::default()
        }),
        rest: Default::default(),
    });
}

/// Add an accessor of `count` elements of `kind` (float, or unsigned
/// int/byte) to `s`; its index.
fn accessor(s: &mut Scene, kind: &str, component_type: u32, count: usize, data: Vec<u8>) -> usize {
    s.accessors.push(RawAccessor {
        component_type,
        kind: kind.into(),
        normalized: false,
        count,
        min: None,
        max: None,
        name: None,
        data,
    });
    s.accessors.len() - 1
}

/// Mesh 0's first primitive as passed-through accessors with joints (as a
/// skinned primitive is kept), `moved` added to vertex 3's x.
fn as_raw(s: &mut Scene, moved: f32) {
    let t = tri0(s).clone();
    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let n = t.positions.len();
    let mut pos = t.positions.as_flattened().to_vec();
    pos[9] += moved;
    let mut attributes = std::collections::BTreeMap::new();
    let p = accessor(s, "VEC3", 5126, n, floats(&pos));
    let bound = |f: fn(f32, f32) -> f32| {
        let b = (0..3).map(|k| pos.iter().skip(k).step_by(3).copied().reduce(f).unwrap());
        Some(serde_json::json!(b.collect::<Vec<_>>()))
    };
    (s.accessors[p].min, s.accessors[p].max) = (bound(f32::min), bound(f32::max));
    attributes.insert("POSITION".into(), p);
    for a in &t.attributes {
        let kind = ["SCALAR", "VEC2", "VEC3", "VEC4"][a.components - 1];
        let i = accessor(s, kind, 5126, n, floats(&a.data));
        attributes.insert(a.semantic.clone(), i);
    }
    attributes.insert(
        "JOINTS_0".into(),
        accessor(s, "VEC4", 5121, n, vec![0; 4 * n]),
    );
    let ix: Vec<u8> = t
        .triangles
        .as_flattened()
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let indices = Some(accessor(s, "SCALAR", 5125, 3 * t.triangles.len(), ix));
    s.meshes[0].primitives[0].geometry = Geometry::Raw(RawGeometry {
        mode: 4,
        attributes,
        indices,
        targets: Vec::new(),
    });
}

#[test]
fn passed_through_triangles_are_compared_too() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("icosphere.obj");
    let raw = edited(dir.path(), "icosphere.obj", "raw.glb", |s| as_raw(s, 0.0));
    let back = crackle::io::read(&raw).unwrap();
    assert!(
        matches!(back.meshes[0].primitives[0].geometry, Geometry::Raw(_)),
        "a primitive with joints is passed through"
    );
    geometry(&input, &raw, &["--same-indices"], 0, "passed through");
    let moved = edited(dir.path(), "icosphere.obj", "raw-moved.glb", |s| {
        as_raw(s, 0.5)
    });
    let text = geometry(&input, &moved, &[], 1, "passed through, moved");
    assert!(text.contains("POSITION differs at "), "{text}");
    assert!(text.contains("vertex 3 of a vs vertex 3 of b"), "{text}");
}

#[test]
fn same_indices_makes_split_vertices_a_difference() {
    let Some(duck) = common::eval_data("gltf/Duck/Duck.glb") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("duck.glb");
    let o = common::crack(&duck, &out, &["--preset", "glaze", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = geometry(&duck, &out, &[], 0, "duck glaze");
    let g = geometry_json(&duck, &out, 0);
    let split = g["split_vertices"].as_i64().unwrap();
    assert!(split > 0, "the baked UV set splits vertices: {g}");
    assert!(
        text.contains(&format!(
            "vertices 2399 -> {} ({split} split;",
            2399 + split
        )),
        "{text}"
    );

    let strict = geometry(&duck, &out, &["--same-indices"], 1, "duck --same-indices");
    assert!(
        strict.contains(&format!(
            "vertices 2399 vs {} ({split} split)",
            2399 + split
        )),
        "{strict}"
    );
}

#[test]
fn usage_and_unreadable_files_exit_2() {
    let cube = common::fixture("cube.obj");
    let o = diff(&cube, &cube, &["--same-indices"]);
    assert_eq!(o.status.code(), Some(2), "--same-indices needs --geometry");
    let missing = Path::new("no/such/file.glb");
    let o = diff(&cube, missing, &["--geometry"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no/such/file.glb"));
    assert!(o.stdout.is_empty());
}
