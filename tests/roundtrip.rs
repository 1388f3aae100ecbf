//! Round trips: every fixture and the listed eval-data assets go through
//! `crackle convert` to `.glb` and `.gltf`; the outputs pass the Khronos
//! validator with no error, warning or unused object, and keep triangle
//! counts, materials, UVs and the node hierarchy.

mod common;

use crackle::scene::{Geometry, Scene};
use std::collections::BTreeMap;
use std::path::Path;

/// Canonical corner tuples of every crackable triangle of a mesh: position and
/// first UV, rounded; each triangle rotated to start at its smallest corner.
fn corner_signature(scene: &Scene, mesh: usize) -> Vec<[i64; 15]> {
    let mut tris = Vec::new();
    for p in &scene.meshes[mesh].primitives {
        let Geometry::Triangles(t) = &p.geometry else {
            continue;
        };
        let uv = t.attribute("TEXCOORD_0");
        let q = |x: f32, s: f32| (x as f64 * s as f64).round() as i64;
        for tri in &t.triangles {
            let scale = 1e4;
            let c: Vec<[i64; 5]> = tri
                .iter()
                .map(|&v| {
                    let p = t.positions[v as usize];
                    let (u, w) = uv
                        .map(|a| (a.get(v as usize)[0], a.get(v as usize)[1]))
                        .unwrap_or((0.0, 0.0));
                    [
                        q(p[0], scale),
                        q(p[1], scale),
                        q(p[2], scale),
                        q(u, 1e4),
                        q(w, 1e4),
                    ]
                })
                .collect();
            let k = (0..3).min_by_key(|&i| c[i]).unwrap();
            let mut out = [0i64; 15];
            for j in 0..3 {
                out[j * 5..j * 5 + 5].copy_from_slice(&c[(k + j) % 3]);
            }
            tris.push(out);
        }
    }
    tris.sort();
    tris
}

fn used_material_names(scene: &Scene) -> Vec<String> {
    let mut used: Vec<usize> = scene
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .filter(|p| !matches!(&p.geometry, Geometry::Triangles(t) if t.triangles.is_empty()))
        .filter_map(|p| p.material)
        .collect();
    used.sort();
    used.dedup();
    used.iter()
        .map(|&m| scene.materials[m].name().unwrap_or("").to_string())
        .collect()
}

fn textured_primitives(scene: &Scene) -> usize {
    scene
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .filter(|p| matches!(&p.geometry, Geometry::Triangles(t) if t.attribute("TEXCOORD_0").is_some()))
        .count()
}

fn node_names(scene: &Scene) -> Vec<Option<String>> {
    scene.nodes.iter().map(|n| n.name.clone()).collect()
}

/// Convert `input` to .glb and .gltf, as read and welded (`--weld`), and
/// check everything the issue asks for; as read, the output is the input's
/// own primitives (`crackle diff --geometry --same-indices`).
fn round_trip(input: &Path) {
    let v = common::validator();
    let src = crackle::io::read(input).unwrap_or_else(|e| panic!("read {}: {e}", input.display()));
    let dir = tempfile::tempdir().unwrap();
    for (ext, weld) in [
        ("glb", false),
        ("gltf", false),
        ("glb", true),
        ("gltf", true),
    ] {
        let out = dir.path().join(format!("out.{ext}"));
        let mut args = vec![
            "convert".as_ref(),
            input.as_os_str(),
            out.as_os_str(),
            "--json".as_ref(),
        ];
        if weld {
            args.push("--weld".as_ref());
        }
        let o = common::run_ok(args);
        let report: serde_json::Value =
            serde_json::from_slice(&o.stdout).expect("convert --json prints JSON");
        let dropped: u64 = report["meshes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| {
                m["defects"]["degenerate_triangles_dropped"]
                    .as_u64()
                    .unwrap()
            })
            .sum();
        assert_eq!(report["welded"], weld, "{}", input.display());
        if !weld {
            let d = common::run([
                "diff".as_ref(),
                input.as_os_str(),
                out.as_os_str(),
                "--geometry".as_ref(),
                "--same-indices".as_ref(),
            ]);
            assert!(
                d.status.success(),
                "{}: convert without --weld changed the primitives: {}",
                input.display(),
                String::from_utf8_lossy(&d.stdout)
            );
        }
        if let Some(v) = &v {
            // A file crackle writes as it read it has no problem of its
            // own: what the validator finds in the source (the
            // DamagedHelmet's normal map without tangents) it may keep.
            if matches!(
                input.extension().and_then(|e| e.to_str()),
                Some("gltf" | "glb")
            ) {
                v.assert_no_worse(input, &out);
            } else {
                v.assert_clean(&out);
            }
        }
        let back =
            crackle::io::read(&out).unwrap_or_else(|e| panic!("re-read {}: {e}", out.display()));
        assert_eq!(
            back.triangle_count() as u64 + dropped,
            src.triangle_count() as u64,
            "{}: triangle count changed ({} dropped as degenerate)",
            input.display(),
            dropped
        );
        assert_eq!(
            used_material_names(&back),
            used_material_names(&src),
            "{}: materials",
            input.display()
        );
        assert_eq!(
            textured_primitives(&back),
            textured_primitives(&src),
            "{}: UV sets",
            input.display()
        );
        assert_eq!(
            node_names(&back),
            node_names(&src),
            "{}: node hierarchy",
            input.display()
        );
        assert_eq!(
            back.animations.len(),
            src.animations.len(),
            "{}: animations",
            input.display()
        );
        if dropped == 0 {
            // Positions and UVs corner by corner (meshes keep their order when all are used).
            let src_meshes: Vec<usize> = (0..src.meshes.len())
                .filter(|&m| src.meshes[m].has_triangles())
                .collect();
            let back_meshes: Vec<usize> = (0..back.meshes.len())
                .filter(|&m| back.meshes[m].has_triangles())
                .collect();
            assert_eq!(src_meshes.len(), back_meshes.len());
            for (&a, &b) in src_meshes.iter().zip(&back_meshes) {
                assert!(
                    corner_signature(&src, a) == corner_signature(&back, b),
                    "{}: mesh {a} corners (position + UV) differ after the round trip",
                    input.display()
                );
            }
        }
        // Textures keep their images.
        let tex_count = |s: &Scene| s.textures.len();
        assert!(tex_count(&back) <= tex_count(&src) || src.textures.is_empty());
    }
}

macro_rules! eval_round_trip {
    ($name:ident, $rel:expr) => {
        #[test]
        fn $name() {
            if let Some(p) = common::eval_data($rel) {
                round_trip(&p);
            }
        }
    };
}

eval_round_trip!(duck_glb, "gltf/Duck/Duck.glb");
eval_round_trip!(box_textured, "gltf/BoxTextured/BoxTextured.gltf");
eval_round_trip!(
    box_textured_embedded,
    "gltf/BoxTextured-Embedded/BoxTextured.gltf"
);
eval_round_trip!(
    cesium_milk_truck,
    "gltf/CesiumMilkTruck/CesiumMilkTruck.glb"
);
eval_round_trip!(
    animated_morph_cube,
    "gltf/AnimatedMorphCube/AnimatedMorphCube.gltf"
);
eval_round_trip!(
    texture_transform_test,
    "gltf/TextureTransformTest/TextureTransformTest.gltf"
);
eval_round_trip!(
    triangle_fan,
    "gltf/Mesh_PrimitiveMode/Mesh_PrimitiveMode_05.gltf"
);
eval_round_trip!(
    triangles_without_indices,
    "gltf/Mesh_PrimitiveMode/Mesh_PrimitiveMode_06.gltf"
);
eval_round_trip!(box_interleaved, "gltf/BoxInterleaved/BoxInterleaved.glb");
eval_round_trip!(cubevc, "gltf/edge_cases/cubevc.glb");
eval_round_trip!(nested, "gltf/edge_cases/nested.glb");
eval_round_trip!(
    alpha_blend,
    "gltf/AlphaBlendModeTest/AlphaBlendModeTest.glb"
);
eval_round_trip!(damaged_helmet, "gltf/DamagedHelmet/DamagedHelmet.gltf");
eval_round_trip!(duck_quantized, "derived/Duck_quantized.glb");
eval_round_trip!(spot_obj, "obj/spot/spot_triangulated.obj");
eval_round_trip!(spot_quads_obj, "obj/spot/spot_quadrangulated.obj");
eval_round_trip!(spider_obj, "obj/spider/spider.obj");
eval_round_trip!(bunny10k_obj, "obj/bunny10k_textured/bunny10k_textured.obj");
eval_round_trip!(fuze_obj, "obj/fuze/fuze.obj");
eval_round_trip!(wallhole_obj, "obj/edge_cases/wallhole.obj");
eval_round_trip!(nefertiti_blender5, "derived/nefertiti_blender5.glb");
eval_round_trip!(spider_blender5, "derived/spider_blender5.glb");

macro_rules! fixture_round_trip {
    ($name:ident, $rel:expr) => {
        #[test]
        fn $name() {
            round_trip(&common::fixture($rel));
        }
    };
}

fixture_round_trip!(fixture_plate, "plate_jittered.obj");
fixture_round_trip!(fixture_icosphere, "icosphere.obj");
fixture_round_trip!(fixture_torus, "torus.obj");
fixture_round_trip!(fixture_cube, "cube.obj");
fixture_round_trip!(fixture_textured_quad, "textured_quad.gltf");
fixture_round_trip!(fixture_hierarchy, "hierarchy.glb");

/// Welding joins UV seams: the torus is one closed component after welding.
#[test]
fn torus_uv_seam_is_welded() {
    let scene = crackle::io::read(&common::fixture("torus.obj")).unwrap();
    let (entries, skipped) = crackle::bridge::build_sim_meshes(&scene, &Default::default());
    assert!(skipped.is_empty());
    let r = &entries[0].report;
    assert_eq!(r.boundary_edges, 0, "{r:?}");
    assert_eq!(r.components, 1);
    assert_eq!(r.vertices, 48 * 24);
}

/// The hierarchy survives: transforms, instancing, names.
#[test]
fn hierarchy_transforms_and_instances_survive() {
    let src = crackle::io::read(&common::fixture("hierarchy.glb")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("h.gltf");
    common::run_ok([
        "convert".as_ref(),
        common::fixture("hierarchy.glb").as_os_str(),
        out.as_os_str(),
    ]);
    let back = crackle::io::read(&out).unwrap();
    let transforms = |s: &Scene| {
        s.nodes
            .iter()
            .map(|n| n.transform.matrix())
            .collect::<Vec<_>>()
    };
    let children = |s: &Scene| {
        s.nodes
            .iter()
            .map(|n| n.children.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(transforms(&src), transforms(&back));
    assert_eq!(children(&src), children(&back));
    let instances = |s: &Scene| {
        let mut m: BTreeMap<usize, usize> = BTreeMap::new();
        for n in &s.nodes {
            if let Some(x) = n.mesh {
                *m.entry(x).or_default() += 1;
            }
        }
        m.into_values().collect::<Vec<_>>()
    };
    assert_eq!(instances(&src), instances(&back));
    assert!(
        instances(&back).contains(&2),
        "the box mesh stays instanced, not duplicated"
    );
}

/// Inputs that once took quadratic time convert, with every triangle kept
/// or reported: an OBJ of 100,000 copies of one face (31 s before), a
/// glTF whose nodes form a 100,000-deep chain (9 s) and a glTF mesh of
/// 30,000 primitives (3.9 s). The work bounds are unit tests
/// (`many_duplicate_faces_take_linear_work`,
/// `the_hierarchy_check_takes_linear_work`,
/// `large_polygons_take_about_n_log_n_work`); this runs the whole reader
/// and writer on them.
#[test]
fn hostile_sizes_convert() {
    use std::fmt::Write as _;
    let dir = tempfile::tempdir().unwrap();
    let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n");
    for _ in 0..100_000 {
        obj.push_str("f 1 2 3\n");
    }
    obj.push_str("f 2 4 3\n");
    // And one face of 20,000 corners (a circle).
    let base = 5;
    for i in 0..20_000 {
        let a = std::f64::consts::TAU * i as f64 / 20_000.0;
        writeln!(obj, "v {} {} 1", a.cos(), a.sin()).unwrap();
    }
    obj.push('f');
    for i in 0..20_000 {
        write!(obj, " {}", base + i).unwrap();
    }
    obj.push('\n');
    let triangle = "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}],\
        \"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],\
        \"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}]";
    let n = 100_000;
    let nodes: Vec<String> = (0..n)
        .map(|i| {
            if i + 1 < n {
                format!("{{\"children\":[{}]}}", i + 1)
            } else {
                "{\"mesh\":0}".into()
            }
        })
        .collect();
    let chain = format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\"scene\":0,\"scenes\":[{{\"nodes\":[0]}}],\"nodes\":[{}],\
         \"meshes\":[{{\"primitives\":[{{\"attributes\":{{\"POSITION\":0}}}}]}}],{triangle}}}",
        nodes.join(",")
    );
    let prims = vec!["{\"attributes\":{\"POSITION\":0}}"; 30_000].join(",");
    let many = format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\"scene\":0,\"scenes\":[{{\"nodes\":[0]}}],\"nodes\":[{{\"mesh\":0}}],\
         \"meshes\":[{{\"primitives\":[{prims}]}}],{triangle}}}"
    );
    for (name, text, triangles) in [
        ("dup.obj", obj, 100_001 + 19_998),
        ("chain.gltf", chain, 1),
        ("prims.gltf", many, 30_000),
    ] {
        let input = dir.path().join(name);
        std::fs::write(&input, text).unwrap();
        let out = dir.path().join(format!("{name}.glb"));
        let o = common::run_ok([
            "convert".as_ref(),
            input.as_os_str(),
            out.as_os_str(),
            "--weld".as_ref(),
        ]);
        // Triangles too thin for f32 (the fine circle's ears) are dropped
        // with a warning that counts them.
        let stderr = String::from_utf8_lossy(&o.stderr);
        let dropped: usize = stderr
            .split("dropped ")
            .skip(1)
            .filter_map(|t| t.split(' ').next()?.parse::<usize>().ok())
            .sum();
        let (doc, _, _) = gltf::import(&out).unwrap();
        let count: usize = doc
            .meshes()
            .flat_map(|m| m.primitives().collect::<Vec<_>>())
            .map(|p| {
                p.indices()
                    .map_or(p.get(&gltf::Semantic::Positions).unwrap().count(), |a| {
                        a.count()
                    })
                    / 3
            })
            .sum();
        assert_eq!(count + dropped, triangles, "{name}: {stderr}");
        assert!(dropped * 10 < triangles, "{name}: {stderr}");
    }
}

/// Two writers of one `.gltf` at once (two jobs with one target): after
/// every round, the main file in place names side files that exist (each
/// writer's sweep removed the buffer the other's main file named, in 4 of
/// 40 rounds, before writers of `.gltf` outputs in one folder took turns).
#[test]
fn two_writers_of_one_gltf_leave_a_whole_output() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("shared.gltf");
    let a = crackle::io::read(&common::fixture("cube.obj")).unwrap();
    let b = crackle::io::read(&common::fixture("icosphere.obj")).unwrap();
    for round in 0..40 {
        std::thread::scope(|s| {
            for scene in [&a, &b] {
                let target = &target;
                s.spawn(move || {
                    crackle::io::gltf_write::write_scene(scene, target).unwrap();
                });
            }
        });
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&target).unwrap()).unwrap();
        for b in json["buffers"].as_array().unwrap() {
            let uri = b["uri"].as_str().unwrap();
            assert!(
                dir.path().join(uri).is_file(),
                "round {round}: the output names {uri}, which is gone"
            );
        }
        let back = crackle::io::read(&target);
        assert!(back.is_ok(), "round {round}: {:?}", back.err());
        // Only the side file the output in place names is left.
        let bins = std::fs::read_dir(dir.path())
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().ends_with(".bin"))
            .count();
        assert_eq!(bins, 1, "round {round}");
    }
}
