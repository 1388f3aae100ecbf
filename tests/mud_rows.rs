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

/// The share of crack length running within 15 degrees of the plate's
/// axes, in chords a third of a cell long, more than a cell from the
/// border (a random orientation: 1/3), for `mud` on the 10-unit plate
/// `text` (in the xz plane).
fn axis_share(text: &str, args: &[&str]) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plate.obj");
    shapes::write_obj(&input, text);
    let out = dir.path().join("out.glb");
    let mut all = vec!["-q", "--preset", "mud", "--set", "post.lines=true"];
    all.extend(args);
    let o = common::crack(&input, &out, &all);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lines = measure::flatten(&measure::read_model(&out).rest_lines("crack_lines"), 1, 0.0);
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
