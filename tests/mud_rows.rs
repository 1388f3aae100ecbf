//! `mud` on a flat patch: cells that do not line up in rows along the
//! patch's border. A bonded film on a rectangle is stressed a little more
//! along its long side, so under an even drying its first cracks ran
//! straight across the patch and the next ones met them at right angles:
//! paving slabs in rows. The preset's uneven drying (`noise`) lets the
//! first cracks wander. Measured with the independent measure
//! (`common/measure.rs`: it reads the output's crack lines itself and
//! shares no code with the crate) on plates a DCC tool could make.

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

/// The crack lines at rest of `mud` (with `args`) on the plate `text`.
fn mud_lines(text: &str, args: &[&str]) -> Vec<measure::Seg> {
    preset_lines("mud", text, args, None)
}

/// The crack lines at rest of `preset` (with `args`) on the plate `text`,
/// the output also written to `keep` when given.
fn preset_lines(
    preset: &str,
    text: &str,
    args: &[&str],
    keep: Option<&std::path::Path>,
) -> Vec<measure::Seg> {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plate.obj");
    shapes::write_obj(&input, text);
    let out = keep.map_or_else(|| dir.path().join("out.glb"), |k| k.to_path_buf());
    let mut all = vec!["-q", "--preset", preset, "--set", "post.lines=true"];
    all.extend(args);
    let o = common::crack(&input, &out, &all);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    measure::read_model(&out).rest_lines("crack_lines")
}

/// The share of crack length running within 15 degrees of the plate's
/// axes, in chords a third of a cell long, more than a cell from the
/// border (a random orientation: 1/3), for `mud` on the 10-unit plate
/// `text` (in the xz plane).
fn axis_share(text: &str, args: &[&str]) -> f64 {
    let lines = measure::flatten(&mud_lines(text, args), 1, 0.0);
    let tris = measure::parse_obj(text);
    let border = measure::flatten(
        &measure::boundary_edges(&tris, measure::DEFAULT_WELD_REL),
        1,
        0.0,
    );
    let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let d = measure::cell_diameters(&measure::planar_cells(&graph, &border, 1e-4));
    assert!(d > 0.0, "no cells");
    let (lo, hi) = measure::bounds(lines.iter().flatten());
    measure::chord_axis_share(&graph, d / 3.0, measure::plate_frame(lo, hi, d))
}

#[test]
fn mud_on_a_flat_patch_is_not_laid_in_rows() {
    let regular = axis_share(&shapes::regular_plate(160, 10.0), &[]);
    let jittered = axis_share(&shapes::jittered_plate(160, 10.0, 0.3, 1), &[]);
    eprintln!("along the axes: regular plate {regular:.3}, jittered {jittered:.3}");
    // An even drying (the preset before its noise) lays rows: 0.95 and
    // 0.78 of the length along the axes.
    for share in [regular, jittered] {
        assert!(share < 0.7, "regular {regular:.3}, jittered {jittered:.3}");
    }
    assert!(
        0.5 * (regular + jittered) < 0.55,
        "regular {regular:.3}, jittered {jittered:.3}"
    );
}

/// For `mud` on the 10-unit plate `text` (in the xz plane, x and z in
/// [-5, 5]): of the crack length within half a cell of the border, the
/// share running within 20 degrees of the nearest border's normal; and
/// the same share from half a cell to a cell and a half in (a random
/// orientation: 2/9). Read from the output's crack lines at rest, segment
/// by segment.
fn border_normal_shares(text: &str, args: &[&str]) -> (f64, f64) {
    // The preset's cell: a tenth of the plate's diagonal.
    border_shares_of(&mud_lines(text, args), 0.1 * 200f64.sqrt())
}

/// [`border_normal_shares`] of crack lines at rest on the 10-unit plate
/// (x and z in [-5, 5]) for a cell of `cell`.
fn border_shares_of(lines: &[measure::Seg], cell: f64) -> (f64, f64) {
    let (mut near, mut near_normal, mut inner, mut inner_normal) = (0.0, 0.0, 0.0, 0.0);
    for [a, b] in lines {
        let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[2] + b[2])];
        let d = [b[0] - a[0], b[2] - a[2]];
        let len = d[0].hypot(d[1]);
        if len == 0.0 {
            continue;
        }
        // Distances to the four borders; the nearest one's normal.
        let to = [mid[0] + 5.0, 5.0 - mid[0], mid[1] + 5.0, 5.0 - mid[1]];
        let k = (0..4).min_by(|&i, &j| to[i].total_cmp(&to[j])).unwrap();
        let along_normal = if k < 2 { d[0].abs() } else { d[1].abs() } / len;
        let normal = along_normal > 20f64.to_radians().cos();
        if to[k] < 0.5 * cell {
            near += len;
            near_normal += if normal { len } else { 0.0 };
        } else if to[k] < 1.5 * cell {
            inner += len;
            inner_normal += if normal { len } else { 0.0 };
        }
    }
    assert!(near > 0.0 && inner > 0.0, "no cracks near the border");
    (near_normal / near, inner_normal / inner)
}

#[test]
fn the_border_cuts_through_mud_cells_instead_of_combing_them() {
    // A free border relaxes the stress across it: the first cracks reach
    // it at right angles, evenly spaced, a comb along every edge. The
    // preset grows its pattern 1.5 cells beyond the border (margin) and
    // cuts it off there, so near the border the cracks run as they do
    // further in.
    for (name, text) in [
        ("regular", shapes::regular_plate(160, 10.0)),
        ("jittered", shapes::jittered_plate(160, 10.0, 0.3, 1)),
    ] {
        let (free, free_inner) = border_normal_shares(&text, &["--set", "simulation.margin=0"]);
        let (cut, cut_inner) = border_normal_shares(&text, &[]);
        eprintln!(
            "{name}: near the border along its normal: free {free:.3} (further in {free_inner:.3}), with the margin {cut:.3} (further in {cut_inner:.3})"
        );
        // The measure sees the comb of a free border (0.72-0.86 measured).
        assert!(free > 0.6, "{name}: free border {free:.3}");
        // With the margin, no comb: about what the pattern does further in
        // (0.27-0.36 measured, further in 0.24-0.31).
        assert!(cut < 0.45, "{name}: with the margin {cut:.3}");
        assert!(
            cut < cut_inner + 0.15,
            "{name}: {cut:.3} against {cut_inner:.3} further in"
        );
    }
}

#[test]
fn a_glaze_with_a_margin_is_cut_by_the_border_and_its_attributes_see_only_the_input() {
    // glaze keeps the input unchanged (lines, attributes, baked maps); with
    // `simulation.margin` its pattern grows past the border like mud's,
    // the lines are clipped there, and the crack distance attribute counts
    // only the cracks on the input: no vertex lies nearer a crack by its
    // attribute than half its distance to the nearest crack line drawn
    // (a crack in the strip just outside would make border vertices so).
    let plate = shapes::jittered_plate(160, 10.0, 0.3, 1);
    let cell = 0.05 * 200f64.sqrt(); // glaze: 5% of the diagonal
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("glaze.glb");
    let free = border_shares_of(&preset_lines("glaze", &plate, &[], None), cell);
    let lines = preset_lines(
        "glaze",
        &plate,
        &["--set", "simulation.margin=1.5"],
        Some(&out),
    );
    let cut = border_shares_of(&lines, cell);
    eprintln!(
        "glaze near the border along its normal: free {:.3} (further in {:.3}), with a margin {:.3} (further in {:.3})",
        free.0, free.1, cut.0, cut.1
    );
    assert!(free.0 > 0.6, "without the margin: {free:?}");
    assert!(
        cut.0 < 0.45 && cut.0 < cut.1 + 0.15,
        "with the margin: {cut:?}"
    );
    let scene = crackle::io::read(&out).unwrap();
    let mut checked = 0;
    for prim in &scene.meshes[0].primitives {
        let crackle::scene::Geometry::Triangles(t) = &prim.geometry else {
            continue;
        };
        let Some(dist) = t.attribute("_CRACK_DISTANCE") else {
            continue;
        };
        for (p, d) in t.positions.iter().zip(&dist.data) {
            let q = [f64::from(p[0]), f64::from(p[2])];
            let nearest = lines
                .iter()
                .map(|[a, b]| {
                    let (ab, aq) = ([b[0] - a[0], b[2] - a[2]], [q[0] - a[0], q[1] - a[2]]);
                    let l2 = ab[0] * ab[0] + ab[1] * ab[1];
                    let s = if l2 > 0.0 {
                        ((aq[0] * ab[0] + aq[1] * ab[1]) / l2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    (aq[0] - s * ab[0]).hypot(aq[1] - s * ab[1])
                })
                .fold(f64::INFINITY, f64::min);
            assert!(
                f64::from(*d) >= 0.5 * nearest - 0.03 * cell,
                "vertex {p:?}: attribute distance {d}, nearest crack line {nearest}"
            );
            checked += 1;
        }
    }
    assert!(checked > 10_000, "{checked} vertices with _CRACK_DISTANCE");
}

#[test]
fn a_margin_grows_only_where_the_cracks_go_onto_the_input() {
    // The strip may never reach the output: with the simulation surface as
    // the output, the margin is left out with a warning; with mud's gaps
    // it grows (more simulated triangles than without).
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plate.obj");
    shapes::write_obj(&input, &shapes::jittered_plate(48, 10.0, 0.3, 1));
    let simulated = |preset: &str, extra: &[&str]| -> (u64, String, serde_json::Value) {
        let out = dir.path().join("out.glb");
        let report = dir.path().join("report.json");
        let mut args: Vec<&std::ffi::OsStr> =
            vec!["crack".as_ref(), input.as_os_str(), out.as_os_str()];
        for a in ["--preset", preset, "--report"] {
            args.push(a.as_ref());
        }
        args.push(report.as_os_str());
        for a in extra {
            args.push(a.as_ref());
        }
        let o = common::run_ok(args);
        let r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
        (
            r["triangles"]["before"].as_u64().unwrap(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
            r["meshes"][0]["post"]["margin"].clone(),
        )
    };
    let left_out = "simulation.margin is left out";
    for (preset, extra) in [
        ("mud", &["--set", "post.output=\"simulation\""][..]),
        (
            "glaze",
            &[
                "--set",
                "post.output=\"simulation\"",
                "--set",
                "simulation.margin=1.5",
            ][..],
        ),
    ] {
        let (with, err, margin) = simulated(preset, extra);
        let mut none = extra.to_vec();
        none.extend(["--set", "simulation.margin=0"]);
        let (without, _, _) = simulated(preset, &none);
        assert!(margin.is_null(), "{preset} {extra:?}: {margin}");
        assert!(err.contains(left_out), "{preset} {extra:?}: {err}");
        assert_eq!(with, without, "{preset} {extra:?}");
    }
    let (grown, err, margin) = simulated("mud", &[]);
    let (free, _, none) = simulated("mud", &["--set", "simulation.margin=0"]);
    assert!(!err.contains(left_out), "{err}");
    assert!(grown as f64 > 1.5 * free as f64, "{grown} against {free}");
    // The report says what grew: the input's triangles (48 x 48 x 2) and
    // the strip's, as grown.
    assert_eq!(margin["input_triangles"], 4608, "{margin}");
    assert!(margin["strip_triangles"].as_u64().unwrap() > 0, "{margin}");
    assert!(none.is_null(), "{none}");
}
