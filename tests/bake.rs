//! Baked crack maps (`[post] bake`): the output carries a material variant
//! with base-colour, normal and occlusion maps drawn from the cracks, in the
//! mesh's UVs or an automatic atlas; the stage is in the report only when
//! it runs; the bytes do not depend on the thread count.

mod common;

use crackle::io::image_decode::{decode_channels, Channels};
use crackle::scene::{Geometry, ImageSource, Scene};
use std::path::Path;
use std::process::Command;

fn read(path: &Path) -> Scene {
    crackle::io::read(path).unwrap()
}

/// The decoded RGBA of the texture `slot` of material `m`.
fn texture(scene: &Scene, m: usize, slot: &str) -> (u32, u32, Vec<f32>) {
    let t = crackle::stress::texture::texture_of_material(scene, m, slot).unwrap();
    let bytes = match &scene.images[t.image].source {
        ImageSource::Bytes(b) => b.clone(),
        ImageSource::File(p) => std::fs::read(p).unwrap(),
    };
    decode_channels(&bytes, &t.name, Channels::Rgba).unwrap()
}

fn bake_detail(report: &serde_json::Value) -> serde_json::Value {
    report["meshes"][0]["post"]["bake"].clone()
}

#[test]
fn glaze_bakes_visible_maps_into_an_atlas() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ico.glb");
    let o = common::crack(
        &common::fixture("icosphere.obj"),
        &out,
        &["--preset", "glaze", "--set", "post.bake_size=512", "-q"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = common::report(&out);
    assert!(
        common::stages(&r).contains(&"bake".to_string()),
        "{:?}",
        common::stages(&r)
    );
    let d = bake_detail(&r);
    let m = &d["materials"][0];
    assert_eq!(m["size"], 512, "{d}");
    assert!(
        m["atlas"]["reason"]
            .as_str()
            .unwrap()
            .contains("no TEXCOORD_0"),
        "the icosphere has no UVs: the report says an atlas was made: {d}"
    );
    assert!(m["crack_texels"].as_u64().unwrap() > 1000, "{d}");
    let scene = read(&out);
    // One variant material with the three maps, used by the surface.
    let (mi, _) = scene
        .materials
        .iter()
        .enumerate()
        .find(|(_, m)| m.name().is_some_and(|n| n.ends_with("_cracked")))
        .expect("a _cracked material");
    let prim = scene.meshes[0]
        .primitives
        .iter()
        .find(|p| matches!(p.geometry, Geometry::Triangles(_)))
        .unwrap();
    assert_eq!(prim.material, Some(mi));
    let Geometry::Triangles(t) = &prim.geometry else {
        unreachable!()
    };
    assert!(t.attribute("TEXCOORD_0").is_some() && t.attribute("TANGENT").is_some());
    let (w, h, base) = texture(&scene, mi, "baseColorTexture");
    assert_eq!((w, h), (512, 512));
    let (_, _, normal) = texture(&scene, mi, "normalTexture");
    let (_, _, occl) = texture(&scene, mi, "occlusionTexture");
    // Dark crack texels, tilted normals and occluded texels, but most of
    // the surface as it was.
    // (Background texels outside the islands are black.)
    let dark = base.chunks(4).filter(|p| p[0] > 0.0 && p[0] < 0.75).count();
    let light = base.chunks(4).filter(|p| p[3] > 0.5 && p[0] > 0.9).count();
    let tilted = normal
        .chunks(4)
        .filter(|p| (p[0] - 0.5).abs() > 0.1)
        .count();
    let shaded = occl.chunks(4).filter(|p| p[0] < 0.7).count();
    assert!(dark > 500 && light > 3 * dark, "dark {dark}, light {light}");
    assert!(
        tilted > 200 && shaded > 500,
        "tilted {tilted}, shaded {shaded}"
    );
    if let Some(v) = common::validator() {
        v.assert_clean(&out);
    }
}

#[test]
fn the_bake_stage_is_reported_only_when_it_runs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mud.glb");
    let o = common::crack(
        &common::fixture("plate_jittered.obj"),
        &out,
        &["--preset", "mud", "--cell-size-relative", "0.15", "-q"],
    );
    assert!(o.status.success());
    let r = common::report(&out);
    assert!(!common::stages(&r).contains(&"bake".to_string()));
    assert!(bake_detail(&r).is_null());
    assert!(read(&out).images.is_empty());
}

#[test]
fn a_mesh_without_uvs_is_refused_when_no_atlas_is_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ico.glb");
    let o = common::crack(
        &common::fixture("icosphere.obj"),
        &out,
        &[
            "--preset",
            "glaze",
            "--cell-size-relative",
            "0.15",
            "--set",
            "post.bake_atlas=\"never\"",
            "-q",
        ],
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("icosphere") && err.contains("TEXCOORD_0") && err.contains("bake_atlas"),
        "{err}"
    );
    assert!(!out.exists(), "no partial output");
}

#[test]
fn baked_outputs_do_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let run = |threads: &str| {
        let out = dir.path().join(format!("t{threads}.glb"));
        let o = Command::new(common::crackle_bin())
            .env("RAYON_NUM_THREADS", threads)
            .args([
                "crack",
                "-q",
                "--preset",
                "glass-impact",
                "--cell-size-relative",
                "0.1",
            ])
            .args(["--set", "post.bake_size=512"])
            .arg(common::fixture("plate_jittered.obj"))
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(&out).unwrap()
    };
    let one = run("1");
    assert!(one == run("3"), "1 and 3 threads give different bytes");
}

/// Nearest texel of an RGBA image at `uv`.
fn at(img: &(u32, u32, Vec<f32>), uv: &[f32]) -> [f32; 4] {
    let (w, h, data) = img;
    let x = ((uv[0].rem_euclid(1.0) * *w as f32) as usize).min(*w as usize - 1);
    let y = ((uv[1].rem_euclid(1.0) * *h as f32) as usize).min(*h as usize - 1);
    let k = 4 * (y * *w as usize + x);
    [data[k], data[k + 1], data[k + 2], data[k + 3]]
}

/// The output's cracked material variant and the first mesh's triangles
/// drawn with it.
fn cracked(scene: &Scene) -> (usize, &crackle::scene::TriGeometry) {
    let mi = scene
        .materials
        .iter()
        .position(|m| m.name().is_some_and(|n| n.ends_with("_cracked")))
        .unwrap();
    let prim = scene.meshes[0]
        .primitives
        .iter()
        .find(|p| p.material == Some(mi))
        .unwrap();
    let Geometry::Triangles(t) = &prim.geometry else {
        unreachable!()
    };
    (mi, t)
}

/// The colour differences' median and 95th percentile are below the
/// bounds given.
fn assert_close(mut diffs: Vec<f32>, median_below: f32, p95_below: f32) {
    diffs.sort_by(f32::total_cmp);
    let median = diffs[diffs.len() / 2];
    let p95 = diffs[diffs.len() * 95 / 100];
    assert!(
        median < median_below && p95 < p95_below,
        "median {median}, 95th percentile {p95}"
    );
}

#[test]
fn the_ducks_own_texture_is_kept_under_the_cracks() {
    let Some(duck) = common::eval_data("gltf/Duck/Duck.glb") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("duck.glb");
    let o = common::crack(&duck, &out, &["--preset", "glaze", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The Duck's UVs mirror its two halves onto one texture: cracks baked
    // there would show on both sides, so it gets an atlas, in a UV set of
    // its own (the Duck's TEXCOORD_0 stays, as the artist made it).
    let d = bake_detail(&common::report(&out));
    let reason = d["materials"][0]["atlas"]["reason"].as_str().unwrap_or("");
    assert!(reason.contains("overlaps itself"), "{d}");
    assert_eq!(d["materials"][0]["texcoord"], 1, "{d}");
    let input = read(&duck);
    let scene = read(&out);
    let (mi, t) = cracked(&scene);
    let baked = texture(&scene, mi, "baseColorTexture");
    let occl = texture(&scene, mi, "occlusionTexture");
    let own = texture(&input, 0, "baseColorTexture");
    let atlas = t.attribute("TEXCOORD_1").expect("the atlas");
    let own_uv = t.attribute("TEXCOORD_0").expect("the Duck's own UVs");
    let Geometry::Triangles(inp) = &input.meshes[0].primitives[0].geometry else {
        unreachable!()
    };
    // Every corner keeps its position and its own UVs.
    let input_uv = inp.attribute("TEXCOORD_0").unwrap();
    assert_eq!(t.triangles.len(), inp.triangles.len());
    for (a, b) in t.triangles.iter().zip(&inp.triangles) {
        for k in 0..3 {
            assert_eq!(t.positions[a[k] as usize], inp.positions[b[k] as usize]);
            assert_eq!(own_uv.get(a[k] as usize), input_uv.get(b[k] as usize));
        }
    }
    // At every vertex away from the cracks, the baked map (through the
    // atlas) shows what the Duck's texture shows there (through its own
    // UVs).
    let diffs: Vec<f32> = (0..atlas.len())
        .filter(|&v| at(&occl, atlas.get(v))[0] > 0.999)
        .map(|v| {
            let a = at(&baked, atlas.get(v));
            let b = at(&own, own_uv.get(v));
            (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max)
        })
        .collect();
    assert!(
        diffs.len() > atlas.len() / 20,
        "{} of {}",
        diffs.len(),
        atlas.len()
    );
    assert_close(diffs, 4.0 / 255.0, 24.0 / 255.0);
    if let Some(v) = common::validator() {
        v.assert_clean(&out);
    }
}

#[test]
fn kept_geometry_bakes_the_ducks_own_islands_repacked() {
    let Some(duck) = common::eval_data("gltf/Duck/Duck.glb") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("duck.glb");
    let o = common::crack(&duck, &out, &["--preset", "wood-grain", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let d = bake_detail(&common::report(&out));
    let atlas_report = &d["materials"][0]["atlas"];
    assert_eq!(atlas_report["layout"], "islands", "{d}");
    let input = read(&duck);
    let scene = read(&out);
    let Geometry::Triangles(inp) = &input.meshes[0].primitives[0].geometry else {
        unreachable!()
    };
    let (mi, t) = cracked(&scene);
    // The Duck's own triangles, in their order, at their own positions.
    assert_eq!(t.triangles.len(), inp.triangles.len());
    for (a, b) in t.triangles.iter().zip(&inp.triangles) {
        for k in 0..3 {
            assert_eq!(t.positions[a[k] as usize], inp.positions[b[k] as usize]);
        }
    }
    // Each triangle's atlas UVs are its own UVs scaled and moved: no
    // island is turned, mirrored or sheared, so texture edges stay on the
    // island seams and a normal map keeps its frame.
    // The repacked islands are a UV set of their own.
    let set = format!("TEXCOORD_{}", d["materials"][0]["texcoord"]);
    assert_eq!(set, "TEXCOORD_1", "{d}");
    let atlas = t.attribute(&set).unwrap();
    let own_uv = inp.attribute("TEXCOORD_0").unwrap();
    let mut worst = 0.0f64;
    for (a, b) in t.triangles.iter().zip(&inp.triangles) {
        let e = |uv: &crackle::scene::VertexAttribute, tri: &[u32; 3], j: usize| {
            let (p, q) = (uv.get(tri[0] as usize), uv.get(tri[j] as usize));
            [f64::from(q[0] - p[0]), f64::from(q[1] - p[1])]
        };
        let (x1, y1) = (e(atlas, a, 1), e(own_uv, b, 1));
        let l = y1[0] * y1[0] + y1[1] * y1[1];
        if l < 1e-12 {
            continue;
        }
        // The scale along the first edge: positive, and it fits the
        // second edge too.
        let k = (x1[0] * y1[0] + x1[1] * y1[1]) / l;
        assert!(k > 0.0, "a flipped island");
        for j in [1, 2] {
            let (x, y) = (e(atlas, a, j), e(own_uv, b, j));
            let off = (x[0] - k * y[0]).hypot(x[1] - k * y[1]);
            worst = worst.max(off * 2048.0);
        }
    }
    assert!(
        worst < 0.05,
        "an atlas edge is {worst} texels off its own edge scaled"
    );
    // Away from the cracks the baked map shows the Duck's own texture at
    // each triangle's centre.
    let baked = texture(&scene, mi, "baseColorTexture");
    let occl = texture(&scene, mi, "occlusionTexture");
    let own = texture(&input, 0, "baseColorTexture");
    let centre = |uv: &crackle::scene::VertexAttribute, tri: &[u32; 3]| {
        let c = tri.map(|i| uv.get(i as usize));
        [0, 1].map(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0)
    };
    let diffs: Vec<f32> = t
        .triangles
        .iter()
        .zip(&inp.triangles)
        .filter(|(a, _)| at(&occl, &centre(atlas, a))[0] > 0.999)
        .map(|(a, b)| {
            let x = at(&baked, &centre(atlas, a));
            let y = at(&own, &centre(own_uv, b));
            (0..3).map(|c| (x[c] - y[c]).abs()).fold(0.0, f32::max)
        })
        .collect();
    assert!(diffs.len() > t.triangles.len() / 2, "{}", diffs.len());
    assert_close(diffs, 2.0 / 255.0, 12.0 / 255.0);
    if let Some(v) = common::validator() {
        v.assert_clean(&out);
    }
}

#[test]
fn kept_geometry_carries_lines_and_attributes_onto_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ico.glb");
    let input = common::fixture("icosphere.obj");
    let o = common::crack(
        &input,
        &out,
        &[
            "--preset",
            "springs-glaze",
            "--set",
            "post.bake_size=256",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let source = read(&input);
    let scene = read(&out);
    let tris = |s: &Scene| -> usize {
        s.meshes[0]
            .primitives
            .iter()
            .filter_map(|p| match &p.geometry {
                Geometry::Triangles(t) => Some(t.triangles.len()),
                Geometry::Raw(_) => None,
            })
            .sum()
    };
    assert_eq!(tris(&scene), tris(&source), "the input's own triangles");
    let Geometry::Triangles(t) = &scene.meshes[0].primitives[0].geometry else {
        unreachable!()
    };
    // The crack attributes, from the simulated surface: some vertices lie
    // near a crack, some far from every crack.
    let dist = t.attribute("_CRACK_DISTANCE").expect("_CRACK_DISTANCE");
    let time = t.attribute("_CRACK_TIME").expect("_CRACK_TIME");
    assert_eq!(dist.len(), t.positions.len());
    assert!(time.data.iter().all(|x| (0.0..=1.0).contains(x)));
    let (lo, hi) = dist
        .data
        .iter()
        .fold((f32::INFINITY, 0.0f32), |(a, b), &x| (a.min(x), b.max(x)));
    assert!(lo >= 0.0 && hi > 4.0 * lo.max(1e-3), "{lo} .. {hi}");
    let lines = scene.meshes[0]
        .primitives
        .iter()
        .find_map(|p| match &p.geometry {
            Geometry::Raw(r) => Some(r),
            Geometry::Triangles(_) => None,
        });
    assert!(lines.is_some(), "a crack-lines primitive");
    if let Some(v) = common::validator() {
        v.assert_clean(&out);
    }
}

#[test]
fn the_output_is_the_input_or_the_simulation_surface() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plate.glb");
    let o = common::crack(
        &common::fixture("plate_jittered.obj"),
        &out,
        &[
            "--preset",
            "wood-grain",
            "--set",
            "post.output=remeshed",
            "-q",
        ],
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("post.output"), "{err}");
    assert!(!out.exists(), "no output");
}

#[test]
fn shallow_cracks_fade_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let texels = |fade: &str| -> u64 {
        let out = dir.path().join(format!("mud-{fade}.glb"));
        let o = common::crack(
            &common::fixture("plate_jittered.obj"),
            &out,
            &[
                "--preset",
                "mud-jagged",
                "--set",
                "post.bake=true",
                "--set",
                "post.bake_size=512",
                "--set",
                &format!("post.bake_fade_depth={fade}"),
                "-q",
            ],
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        bake_detail(&common::report(&out))["materials"][0]["crack_texels"]
            .as_u64()
            .unwrap()
    };
    // The mud's cracks open by different amounts: with the depth fade the
    // shallow ones thin (fewer texels show a crack), the deepest stay.
    let (full, faded) = (texels("0"), texels("1"));
    assert!(faded > 0 && faded * 2 < full, "{faded} of {full}");
}
