//! Pipelines and presets from the command line: listing, running every
//! preset on its fixture and on an eval-data mesh, stage gating, and errors
//! that name the key before any work.

mod common;

use std::process::Command;

fn crack(input: &std::path::Path, out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let rep = out.with_extension("json");
    Command::new(common::crackle_bin())
        .args(["crack".as_ref(), input.as_os_str(), out.as_os_str()])
        .args(["--report".as_ref(), rep.as_os_str()])
        .args(extra)
        .output()
        .unwrap()
}

fn report(out: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(out.with_extension("json")).unwrap()).unwrap()
}

fn stages(r: &serde_json::Value) -> Vec<String> {
    r["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap().to_string())
        .collect()
}

const PRESETS: [(&str, &str); 6] = [
    ("glaze", "icosphere.obj"),
    ("mud", "plate_jittered.obj"),
    ("mud-jagged", "plate_jittered.obj"),
    ("glass-impact", "plate_jittered.obj"),
    ("wood-grain", "plate_jittered.obj"),
    ("tree-rings", "plate_jittered.obj"),
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
            let has_terms = !matches!(name, "glaze" | "mud" | "mud-jagged");
            assert_eq!(
                stages(&r).contains(&"stress".to_string()),
                has_terms,
                "{name}: the stress stage runs only when the pipeline has stress terms: {:?}",
                stages(&r)
            );
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
