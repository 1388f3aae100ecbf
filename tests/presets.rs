//! Pipelines and presets from the command line: listing, running every
//! preset on its fixture and on an eval-data mesh, stage gating, and errors
//! that name the key before any work.

mod common;

use common::{crack, report, stages};

const PRESETS: [(&str, &str); 10] = [
    ("glaze", "icosphere.obj"),
    ("mud", "plate_jittered.obj"),
    ("mud-jagged", "plate_jittered.obj"),
    ("mud-aged", "plate_jittered.obj"),
    ("glass-impact", "plate_jittered.obj"),
    ("glass-tempered", "plate_jittered.obj"),
    ("wood-grain", "plate_jittered.obj"),
    ("tree-rings", "plate_jittered.obj"),
    ("curvature", "bumps.obj"),
    ("texture-mask", "plate_jittered.obj"),
];

#[test]
fn presets_are_listed() {
    let o = common::run_ok(["presets"]);
    let text = String::from_utf8_lossy(&o.stdout);
    for (name, _) in PRESETS {
        assert!(
            text.lines()
                .any(|l| l.starts_with(name) && l.len() > name.len() + 10),
            "{name} listed with a description: {text}"
        );
    }
    let o = common::run_ok(["presets", "glass-impact"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("kind = \"impact\""));
}

#[test]
fn every_preset_cracks_its_fixture_and_an_eval_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let spot = common::eval_data("obj/spot/spot_triangulated.obj");
    for (name, fixture) in PRESETS {
        let mut inputs = vec![common::fixture(fixture)];
        inputs.extend(spot.clone());
        for (i, input) in inputs.iter().enumerate() {
            let out = dir.path().join(format!("{name}-{i}.glb"));
            let o = crack(input, &out, &["--preset", name]);
            assert!(
                o.status.success(),
                "{name} on {}: {}",
                input.display(),
                String::from_utf8_lossy(&o.stderr)
            );
            let r = report(&out);
            assert!(
                r["cracks"].as_u64().unwrap() > 5,
                "{name} on {}: {r}",
                input.display()
            );
            // Only the stages a pipeline uses run.
            let has_terms = !matches!(name, "glaze" | "mud" | "mud-jagged" | "mud-aged");
            for (stage, expected) in [
                ("stress", has_terms),
                ("curvature", name == "curvature"),
                ("texture", name == "texture-mask"),
            ] {
                assert_eq!(
                    stages(&r).contains(&stage.to_string()),
                    expected,
                    "{name}: the {stage} stage runs only when the pipeline uses it: {:?}",
                    stages(&r)
                );
            }
            if let Some(v) = common::validator() {
                v.assert_clean(&out);
            }
        }
    }
}

#[test]
fn bad_pipelines_are_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("plate_jittered.obj");
    let out = dir.path().join("out.glb");
    let pipe = dir.path().join("bad.toml");
    std::fs::write(&pipe, "[simulation]\ntoughness = 2\nshrink = 3\n").unwrap();
    let junk = dir.path().join("junk.png");
    std::fs::write(&junk, b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["--pipeline".into(), pipe.display().to_string()],
            "shrink",
        ),
        (vec!["--set".into(), "simulation.alpha=1.5".into()], "alpha"),
        (vec!["--toughness=-1".into()], "toughness"),
        (
            vec![
                "--preset".into(),
                "glass-impact".into(),
                "--set".into(),
                "stress.0.radius_relative=0".into(),
            ],
            "radius_relative",
        ),
        (vec!["--preset".into(), "lava".into()], "glaze"),
        // Masks: an image that does not decode, a missing file, an unknown
        // slot, a relative path in a preset, an unknown built-in image.
        (
            vec![
                "--preset".into(),
                "texture-mask".into(),
                "--set".into(),
                format!("stress.0.mask.image={}", junk.display()),
            ],
            "mask.image",
        ),
        (
            vec![
                "--preset".into(),
                "texture-mask".into(),
                "--set".into(),
                format!(
                    "stress.0.mask.image={}",
                    dir.path().join("nope.png").display()
                ),
            ],
            "nope.png",
        ),
        (
            vec![
                "--preset".into(),
                "texture-mask".into(),
                "--set".into(),
                "stress.0.mask={ material = \"m\", slot = \"sparkleTexture\" }".into(),
            ],
            "sparkleTexture",
        ),
        (
            vec![
                "--preset".into(),
                "texture-mask".into(),
                "--set".into(),
                "stress.0.mask.image=stains.png".into(),
            ],
            "preset has no folder",
        ),
        (
            vec![
                "--preset".into(),
                "texture-mask".into(),
                "--set".into(),
                "stress.0.mask.image=builtin:nothing".into(),
            ],
            "builtin:blotches",
        ),
        // A material mask naming a material the input does not have.
        (
            vec![
                "--preset".into(),
                "texture-mask".into(),
                "--set".into(),
                "stress.0.mask={ material = \"lacquer\" }".into(),
            ],
            "lacquer",
        ),
        // Curvature keys: a bad measure, a negative strength.
        (
            vec![
                "--preset".into(),
                "curvature".into(),
                "--set".into(),
                "stress.0.separation=wobbly".into(),
            ],
            "wobbly",
        ),
        (
            vec![
                "--preset".into(),
                "curvature".into(),
                "--set".into(),
                "stress.0.strength=-1".into(),
            ],
            "strength",
        ),
    ];
    for (args, key) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = crack(&input, &out, &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(key),
            "{args:?}: the error names '{key}': {err}"
        );
        assert!(!out.exists(), "{args:?}: no output file");
    }
    // The file's name is in the message.
    let o = crack(&input, &out, &["--pipeline", pipe.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("bad.toml"));
}

#[test]
fn pipeline_file_with_overrides_runs() {
    let dir = tempfile::tempdir().unwrap();
    let pipe = dir.path().join("impact.toml");
    std::fs::write(
        &pipe,
        "description = \"test\"\n[select]\nfixed_boundary = true\n[simulation]\nshrink_rate = 0.0\n\
         [[stress]]\nkind = \"impact\"\ninit = 6.0\npoints_relative = [[0.5, 0.5, 0.5]]\nradius = 0.3\n",
    )
    .unwrap();
    let out = dir.path().join("out.glb");
    let input = common::fixture("plate_jittered.obj");
    let o = crack(
        &input,
        &out,
        &[
            "--pipeline",
            pipe.to_str().unwrap(),
            "--set",
            "simulation.seed=5",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let a = std::fs::read(&out).unwrap();
    let out2 = dir.path().join("out2.glb");
    let o = crack(
        &input,
        &out2,
        &["--pipeline", pipe.to_str().unwrap(), "--seed", "5"],
    );
    assert!(o.status.success());
    assert_eq!(
        a,
        std::fs::read(&out2).unwrap(),
        "--seed is --set simulation.seed"
    );
    assert!(report(&out)["cracks"].as_u64().unwrap() > 5);
}

#[test]
fn masks_from_a_pipeline_file_and_from_a_material() {
    let dir = tempfile::tempdir().unwrap();
    // An image relative to the pipeline file's folder.
    std::fs::copy(
        common::fixture("crack_mask.png"),
        dir.path().join("stains.png"),
    )
    .unwrap();
    let pipe = dir.path().join("stains.toml");
    std::fs::write(
        &pipe,
        "[simulation]\ncell_size_relative = 0.05\nshrink_rate = 0.0\n[[stress]]\nkind = \"uniform\"\nevolve = 0.05\n\
         mask = { image = \"stains.png\", confine = true }\n[post]\nbake = true\n",
    )
    .unwrap();
    let out = dir.path().join("file.glb");
    let o = crack(
        &common::fixture("plate_jittered.obj"),
        &out,
        &["--pipeline", pipe.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The same image built in gives the same output.
    let out2 = dir.path().join("builtin.glb");
    let o = crack(
        &common::fixture("plate_jittered.obj"),
        &out2,
        &["--preset", "texture-mask"],
    );
    assert!(o.status.success());
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&out2).unwrap());
    assert!(stages(&report(&out)).contains(&"texture".to_string()));

    // A material's texture as the mask: the cube's "textured" material
    // (map_Kd "cube texture.png", a red/cream checker).
    let out = dir.path().join("material.glb");
    let o = crack(
        &common::fixture("cube.obj"),
        &out,
        &[
            "--preset",
            "texture-mask",
            "--set",
            "stress.0.mask={ material = \"textured\" }",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stages(&report(&out)).contains(&"texture".to_string()));
    // ... and a material without a texture in that slot is named.
    let o = crack(
        &common::fixture("cube.obj"),
        &dir.path().join("red.glb"),
        &[
            "--preset",
            "texture-mask",
            "--set",
            "stress.0.mask={ material = \"red\" }",
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("'red'") && err.contains("baseColorTexture"),
        "{err}"
    );
    assert!(!dir.path().join("red.glb").exists());
}

#[test]
fn select_meshes_cracks_only_the_named_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("hierarchy.glb");
    let out = dir.path().join("out.glb");
    let o = crack(
        &input,
        &out,
        &["--preset", "glaze", "--set", "select.meshes=[\"box\"]"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&out);
    let meshes = r["meshes"].as_array().unwrap();
    assert_eq!(meshes.len(), 1, "{r}");
    // The other mesh is written as it was: same primitive count, no crack lines.
    let doc = |p: &std::path::Path| {
        let (d, _, _) = gltf::import(p).unwrap();
        d.meshes()
            .map(|m| {
                (
                    m.name().unwrap_or_default().to_string(),
                    m.primitives().len(),
                )
            })
            .collect::<Vec<_>>()
    };
    let (a, b) = (doc(&input), doc(&out));
    let other = |v: &Vec<(String, usize)>| v.iter().find(|(n, _)| n == "tetra_and_plate").cloned();
    assert_eq!(other(&a), other(&b));
    // An unknown name is refused and the names there are listed.
    let o = crack(
        &input,
        &dir.path().join("x.glb"),
        &["--set", "select.meshes=[\"wheel\"]"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("wheel") && err.contains("box"), "{err}");
}
