//! The other models through the CLI (mass-spring drying, the snapped
//! impact): their presets give valid
//! glTF on their fixture and on the spot scan, the same bytes whatever the
//! thread count, and cracks that open.

mod common;

use std::path::Path;
use std::process::Command;

fn crack(input: &Path, out: &Path, preset: &str, threads: &str) -> serde_json::Value {
    let report = out.with_extension("json");
    let o = Command::new(common::crackle_bin())
        .env("RAYON_NUM_THREADS", threads)
        .args(["crack".as_ref(), input.as_os_str(), out.as_os_str()])
        .args(["--preset", preset, "-q", "--report"])
        .arg(&report)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{preset}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&std::fs::read(report).unwrap()).unwrap()
}

#[test]
fn spring_presets_give_valid_deterministic_output() {
    let dir = tempfile::tempdir().unwrap();
    let mut inputs = vec![
        ("springs-mud", common::fixture("plate_jittered.obj")),
        ("springs-glaze", common::fixture("icosphere.obj")),
    ];
    if let Some(spot) = common::eval_data("obj/spot/spot_triangulated.obj") {
        inputs.push(("springs-mud", spot.clone()));
        inputs.push(("springs-glaze", spot));
    }
    let validator = common::validator();
    for (k, (preset, input)) in inputs.iter().enumerate() {
        let one = dir.path().join(format!("{k}_1.glb"));
        let two = dir.path().join(format!("{k}_2.glb"));
        let r = crack(input, &one, preset, "1");
        crack(input, &two, preset, "2");
        assert_eq!(
            std::fs::read(&one).unwrap(),
            std::fs::read(&two).unwrap(),
            "{preset} on {input:?}: output depends on the thread count"
        );
        let mesh = &r["meshes"][0]["report"];
        assert_eq!(mesh["integrator"], "springs-semi-implicit-euler");
        let cracks = r["cracks"].as_u64().unwrap();
        assert!(cracks > 10, "{preset} on {input:?}: {cracks} cracks");
        // Springs that broke opened the mesh: more nodes than before.
        assert!(r["nodes"]["after"].as_u64() > r["nodes"]["before"].as_u64());
        eprintln!(
            "{preset} on {}: {cracks} breaks, {} steps, stopped: {}",
            input.display(),
            mesh["relax_steps"],
            mesh["stopped"]
        );
        if let Some(v) = &validator {
            v.assert_clean(&one);
        }
    }
}

#[test]
fn bad_spring_parameters_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.glb");
    for (set, name) in [
        ("simulation.springs.alpha=1.5", "springs.alpha"),
        (
            "simulation.springs.break_strain=[0.1, 0.05]",
            "springs.break_strain",
        ),
        ("simulation.springs.mass=0", "springs.mass"),
    ] {
        let o = Command::new(common::crackle_bin())
            .args([
                "crack".as_ref(),
                common::fixture("plate_jittered.obj").as_os_str(),
                out.as_os_str(),
            ])
            .args(["--preset", "springs-mud", "--set", set])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{set}");
        assert!(
            String::from_utf8_lossy(&o.stderr).contains(name),
            "{set}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!out.exists(), "{set}: no output on error");
    }
}

#[test]
fn the_snapped_impact_preset_is_valid_and_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("plate_jittered.obj");
    let (one, two) = (dir.path().join("1.glb"), dir.path().join("2.glb"));
    let r = crack(&input, &one, "impact-snapped", "1");
    crack(&input, &two, "impact-snapped", "2");
    assert_eq!(std::fs::read(&one).unwrap(), std::fs::read(&two).unwrap());
    // Snapped: no triangle is split; tensor relaxation is off.
    assert_eq!(r["triangles"]["before"], r["triangles"]["after"]);
    assert_eq!(r["relaxation_steps"], 0);
    assert!(r["cracks"].as_u64().unwrap() > 20, "{}", r["cracks"]);
    if let Some(v) = common::validator() {
        let rep = v.validate(&one);
        assert_eq!(rep.errors + rep.warnings, 0, "{}", rep.describe());
    }
}
