//! `simulation.cycles` and the `mud-aged` preset: mud dried again and again
//! turns its T-junctions into Y-junctions and its cells toward hexagons,
//! on the cracks of the first drying. Measured with the independent measure
//! (`common/measure.rs`: it reads the output's crack lines itself and
//! shares no code with the crate) on a jittered plate a DCC tool could make.

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

use serde_json::Value;

/// What the measure finds on the 160 x 160 jittered plate (10 units wide,
/// in the xz plane) cracked with `args`.
struct Pattern {
    junctions: Value,
    cells: usize,
    mean_sides: f64,
    open_tips: usize,
    /// `crackle stats`' mean cell sides and the cells it is over.
    stats_sides: (f64, u64),
    /// `crackle stats`' share of Y among the three-way junctions.
    stats_y_share: f64,
}

fn mud_on_plate(args: &[&str]) -> Pattern {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plate.obj");
    let text = shapes::jittered_plate(160, 10.0, 0.3, 1);
    shapes::write_obj(&input, &text);
    let out = dir.path().join("out.glb");
    let mut all = vec!["-q", "--set", "post.lines=true"];
    all.extend(args);
    let o = common::crack(&input, &out, &all);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lines = measure::flatten(&measure::read_model(&out).rest_lines("crack_lines"), 1, 0.0);
    assert!(!lines.is_empty(), "no crack lines");
    let tris = measure::parse_obj(&text);
    let border = measure::flatten(
        &measure::boundary_edges(&tris, measure::DEFAULT_WELD_REL),
        1,
        0.0,
    );
    let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let cells = measure::planar_cells(&graph, &border, 1e-4);
    let d = measure::cell_diameters(&cells);
    assert!(d > 0.0, "no cells");
    let sides = measure::planar_cell_sides(&graph, &border, 1e-4, 0.1 * d, 150.0);
    assert!(sides.len() >= 20, "{} inner cells", sides.len());
    let o = common::run_ok(["stats".as_ref(), out.as_os_str(), "--json".as_ref()]);
    let stats: Value = serde_json::from_slice(&o.stdout).unwrap();
    Pattern {
        junctions: measure::junction_stats(&graph, 0.1 * d, [0.0, 1.0, 0.0]),
        cells: cells.len(),
        mean_sides: sides.iter().sum::<usize>() as f64 / sides.len() as f64,
        open_tips: measure::open_tips(&graph, &border),
        stats_sides: (
            stats["mean_cell_sides"].as_f64().unwrap(),
            stats["sided_cells"].as_u64().unwrap(),
        ),
        stats_y_share: stats["y_share"].as_f64().unwrap(),
    }
}

#[test]
fn aged_mud_has_y_junctions_and_near_hexagonal_cells_on_the_first_drying_cracks() {
    let fresh = mud_on_plate(&["--preset", "mud"]);
    let aged = mud_on_plate(&["--preset", "mud-aged"]);
    let num = |p: &Pattern, k: &str| {
        p.junctions[k]
            .as_f64()
            .unwrap_or_else(|| panic!("{k} in {}", p.junctions))
    };
    // One drying: T-junctions (90/90/180), rectangles.
    assert!(num(&fresh, "y_share") < 0.10, "{}", fresh.junctions);
    assert!(fresh.mean_sides < 5.0, "sides {}", fresh.mean_sides);
    // Five: Y-junctions, angles near 120 degrees, near-hexagons.
    assert!(num(&aged, "y_share") >= 0.5, "{}", aged.junctions);
    assert!(
        num(&aged, "mean_deviation_from_120") <= 10.0,
        "{}",
        aged.junctions
    );
    assert!(
        (aged.mean_sides - 6.0).abs() <= 0.5,
        "sides {}",
        aged.mean_sides
    );
    // The same cracks, aged: as many cells and junctions, every crack
    // closed. The pattern runs on beyond the border (the presets' margin),
    // so a junction just outside it can move in or out with the ageing and
    // add or take away a cell the border cuts (102 and 101 cells measured).
    assert!(
        aged.cells.abs_diff(fresh.cells) * 100 <= 3 * fresh.cells,
        "cells: aged {} against fresh {}",
        aged.cells,
        fresh.cells
    );
    let three_way = |p: &Pattern| p.junctions["three_way"].as_u64().unwrap() as f64;
    assert!(
        (three_way(&aged) - three_way(&fresh)).abs() <= 0.1 * three_way(&fresh),
        "{} vs {}",
        aged.junctions,
        fresh.junctions
    );
    assert_eq!((fresh.open_tips, aged.open_tips), (0, 0));
    // `crackle stats` counts the sides as the measure does (on the same
    // inner cells, within a corner in five cells), and the Y share within
    // 0.15 (it reads a junction's angles from its first segments, the
    // measure from arms a tenth of a cell long).
    for p in [&fresh, &aged] {
        let (mean, cells) = p.stats_sides;
        assert!(
            (mean - p.mean_sides).abs() <= 0.2 && cells >= 20,
            "stats {mean} over {cells} cells, measure {}",
            p.mean_sides
        );
        let y = p.junctions["y_share"].as_f64().unwrap();
        assert!(
            (p.stats_y_share - y).abs() <= 0.15,
            "stats' Y share {}, measure {y}",
            p.stats_y_share
        );
    }
}

#[test]
fn cycles_age_step_by_step_and_are_refused_where_they_do_not_apply() {
    let share = |c: &str| {
        let p = mud_on_plate(&[
            "--preset",
            "mud",
            "--set",
            &format!("simulation.cycles={c}"),
        ]);
        p.junctions["y_share"].as_f64().unwrap()
    };
    let (two, three) = (share("2"), share("3"));
    assert!(
        two > 0.1 && three > two,
        "Y share after 2 and 3 cycles: {two}, {three}"
    );
    // Not a film (springs), out of range, or with time-lapse frames.
    let dir = tempfile::tempdir().unwrap();
    let plate = common::fixture("plate_jittered.obj");
    let out = dir.path().join("o.glb");
    for (args, needle) in [
        (
            vec!["--preset", "springs-mud", "--set", "simulation.cycles=3"],
            "cycles",
        ),
        (
            vec!["--preset", "mud", "--set", "simulation.cycles=0"],
            "cycles",
        ),
        (
            vec!["--preset", "mud", "--set", "simulation.cycles=51"],
            "cycles",
        ),
        (
            vec![
                "--preset",
                "mud-aged",
                "--frames",
                "3",
                dir.path().join("frames").to_str().unwrap(),
            ],
            "--frames",
        ),
    ] {
        let o = common::crack(&plate, &out, &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!out.exists());
    }
}
