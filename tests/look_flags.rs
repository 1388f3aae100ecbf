//! The artist's flags of `crack` (`Look` in `--help`): each one writes the
//! same bytes as the `--set` keys it stands for, a `--set` of a table key
//! replaces the table's alternative (a mask's image by a material), the
//! flags that need a pipeline entry say which preset has one, and `--help`
//! lists the look before the advanced simulation options.

mod common;

use std::path::Path;

/// Crack `input` with `preset` coarse and small maps, plus `extra`; the
/// output's bytes.
fn bytes(dir: &Path, name: &str, input: &str, preset: &str, extra: &[&str]) -> Vec<u8> {
    let out = dir.join(format!("{name}.glb"));
    let mut args = vec![
        "-q",
        "--preset",
        preset,
        "--cell-size-relative",
        "0.3",
        "--set",
        "post.bake_size=256",
    ];
    args.extend_from_slice(extra);
    let o = common::crack(&common::fixture(input), &out, &args);
    assert!(
        o.status.success(),
        "{preset} {extra:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::read(&out).unwrap()
}

#[test]
fn each_flag_writes_what_its_set_keys_write() {
    let dir = tempfile::tempdir().unwrap();
    let mask = common::fixture("checker.png").display().to_string();
    let mask_set = format!("stress.0.mask.image=\"{}\"", mask.replace('\\', "\\\\"));
    let cases: Vec<(&str, &str, Vec<&str>, Vec<&str>)> = vec![
        (
            "icosphere.obj",
            "glaze",
            vec!["--width", "0.02"],
            vec!["--set", "post.bake_width=0.02"],
        ),
        (
            "icosphere.obj",
            "glaze",
            vec!["--gaps", "0.01"],
            vec!["--set", "post.width=0.01", "--set", "post.walls=true"],
        ),
        (
            "icosphere.obj",
            "glaze",
            vec!["--groove", "0.02"],
            vec!["--set", "post.groove=0.02"],
        ),
        (
            "icosphere.obj",
            "glaze",
            vec!["--no-bake"],
            vec!["--set", "post.bake=false"],
        ),
        (
            "icosphere.obj",
            "mud",
            vec!["--bake"],
            vec!["--set", "post.bake=true"],
        ),
        (
            "icosphere.obj",
            "glaze",
            vec!["--color", "0.5,0.1,0.1"],
            vec!["--set", "post.crack_color=[0.5,0.1,0.1]"],
        ),
        (
            "icosphere.obj",
            "glass-impact",
            vec!["--impact", "0,0,1", "--radius", "0.5"],
            vec![
                "--set",
                "stress.0.points=[[0,0,1]]",
                "--set",
                "stress.0.radius=0.5",
            ],
        ),
        (
            "plate_jittered.obj",
            "texture-mask",
            vec!["--mask", &mask],
            vec!["--set", &mask_set],
        ),
        (
            "cube.obj",
            "texture-mask",
            vec!["--mask", "material:textured"],
            vec!["--set", "stress.0.mask.material=textured"],
        ),
    ];
    for (k, (input, preset, flag, set)) in cases.iter().enumerate() {
        let by_flag = bytes(dir.path(), &format!("flag{k}"), input, preset, flag);
        let by_set = bytes(dir.path(), &format!("set{k}"), input, preset, set);
        assert!(by_flag == by_set, "{preset} {flag:?} differs from {set:?}");
        let plain = bytes(dir.path(), &format!("plain{k}"), input, preset, &[]);
        assert!(by_flag != plain, "{preset} {flag:?} changed nothing");
    }
    // A later --set of the same key wins over the flag.
    let both = bytes(
        dir.path(),
        "both",
        "icosphere.obj",
        "glaze",
        &["--width", "0.05", "--set", "post.bake_width=0.02"],
    );
    assert!(
        both == bytes(
            dir.path(),
            "set0b",
            "icosphere.obj",
            "glaze",
            &["--set", "post.bake_width=0.02"]
        )
    );
}

#[test]
fn flags_without_an_entry_to_set_say_which_preset_has_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.glb");
    let input = common::fixture("icosphere.obj");
    for (args, says) in [
        (
            vec!["--preset", "glaze", "--impact", "0,0,1"],
            "glass-impact",
        ),
        (vec!["--mask", "m.png"], "texture-mask"),
        (vec!["--preset", "glass-impact", "--impact", "0,1"], "three"),
        (vec!["--preset", "glaze", "--color", "red"], "three"),
    ] {
        let o = common::crack(&input, &out, &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} wrote an output");
    }
}

#[test]
fn help_lists_the_look_before_the_advanced_simulation() {
    let o = common::run(["crack", "--help"]);
    let help = String::from_utf8_lossy(&o.stdout);
    let at = |s: &str| help.find(s).unwrap_or_else(|| panic!("no {s} in {help}"));
    assert!(at("Look:") < at("Advanced simulation:"), "{help}");
    for flag in [
        "--width",
        "--gaps",
        "--groove",
        "--bake",
        "--no-bake",
        "--impact",
        "--radius",
        "--mask",
        "--color",
        "--cell-size",
    ] {
        let f = at(&format!("      {flag} "));
        assert!(at("Look:") < f && f < at("Advanced simulation:"), "{flag}");
    }
    assert!(at("Advanced simulation:") < at("--toughness"));
}

/// `crackle presets NAME` ends with where the preset has each look flag.
#[test]
fn presets_name_where_each_look_flag_stands() {
    let show = |name: &str| {
        let o = common::run(["presets", name]);
        assert!(o.status.success());
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    let glaze = show("glaze");
    for (flag, at) in [
        (
            "--cell-size[-relative]",
            "0.05 of the bounding-box diagonal",
        ),
        ("--bake / --no-bake", "baked maps"),
        ("--gaps G", "closed"),
        ("--color R,G,B", "0.02,0.015,0.01"),
    ] {
        let line = glaze
            .lines()
            .find(|l| l.contains(flag))
            .unwrap_or_else(|| panic!("no {flag} in {glaze}"));
        assert!(line.starts_with('#') && line.contains(at), "{line}");
    }
    assert!(show("mud")
        .lines()
        .any(|l| l.contains("--gaps G") && l.contains("0.01 (walls on)")));
    assert!(show("glass-impact")
        .lines()
        .any(|l| l.contains("--impact") && l.contains("where the asset faces the viewer")));
    assert!(show("texture-mask")
        .lines()
        .any(|l| l.contains("--mask") && l.contains("builtin:blotches")));
    // Still a pipeline file: the summary is comments.
    let text = show("mud");
    assert!(text.parse::<toml::Table>().is_ok());
}
