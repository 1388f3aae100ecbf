//! `crackle stats` against an independent measure (`tests/common/measure.rs`,
//! which shares no code with `src/stats.rs`): every preset but `tear` cracks
//! the jittered plate, and the cells, open tips, share of crack length on
//! the input's edges and paired share `crackle stats --input` reports must
//! match the measure's on the crack lines.
//!
//! The measure reads the crack lines' `POSITION`; the lines of an output
//! whose cracks opened into gaps follow the gaps and carry where they lie at
//! rest as `_CRACK_REST`. The network at rest is read here by pointing each
//! LINES primitive's `POSITION` at its `_CRACK_REST` accessor in the file's
//! JSON and handing the file to the measure's own glTF reader.

mod common;
#[path = "common/measure.rs"]
mod measure;

use common::{eval_data, fixture, run_ok};
use measure::Seg;
use serde_json::Value;
use std::path::Path;
use std::time::Instant;

/// Weld distance and border tolerance, relative to the pattern's size (the
/// millionth `crackle stats` documents).
const TOL_REL: f64 = 1e-6;
/// Cells smaller than this share of the plate are slivers between lines
/// meeting at a sharp angle, not cells.
const MIN_CELL_REL: f64 = 1e-6;

/// The presets `crackle presets` lists, but `tear` (a solid torn apart:
/// no crack lines on a surface).
fn presets() -> Vec<String> {
    let out = run_ok(["presets"]);
    let text = String::from_utf8(out.stdout).unwrap();
    let names: Vec<String> = text
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_string)
        .filter(|n| n != "tear")
        .collect();
    assert!(names.len() >= 10, "presets: {text}");
    names
}

/// The GLB's JSON and BIN chunks.
fn glb_chunks(bytes: &[u8]) -> (Vec<u8>, Option<Vec<u8>>) {
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    assert_eq!(word(0), 0x4654_6C67, "not a GLB");
    let (mut json, mut bin, mut at) = (None, None, 12);
    while at + 8 <= bytes.len().min(word(8)) {
        let (len, kind) = (word(at), word(at + 4));
        let data = bytes[at + 8..at + 8 + len].to_vec();
        match kind {
            0x4E4F_534A => json = json.or(Some(data)),
            0x004E_4942 => bin = bin.or(Some(data)),
            _ => {}
        }
        at += 8 + len;
    }
    (json.expect("JSON chunk"), bin)
}

/// The crack lines of `glb` at rest: `_CRACK_REST` where the lines carry
/// it, else where they lie (read by the measure's reader).
fn rest_lines(glb: &Path) -> Vec<Seg> {
    let (json, bin) = glb_chunks(&std::fs::read(glb).unwrap());
    let mut j: Value = serde_json::from_slice(&json).unwrap();
    for mesh in j["meshes"].as_array_mut().into_iter().flatten() {
        for p in mesh["primitives"].as_array_mut().into_iter().flatten() {
            if let Some(rest) = p["attributes"].get("_CRACK_REST").cloned() {
                p["attributes"]["POSITION"] = rest;
            }
        }
    }
    let json = serde_json::to_vec(&j).unwrap();
    measure::parse_gltf(&json, bin, glb.parent()).lines("crack_lines")
}

/// What the measure finds in one output.
#[derive(Debug)]
struct Truth {
    cells: usize,
    tips: usize,
    edge_share: f64,
    paired: f64,
    /// Mean sides of the inner cells and how many there are.
    sides: (f64, usize),
}

/// The measure on the network at rest of `out` (an output of `input`, a
/// plate), the pairs at `paired_distance`.
fn truth(out: &Path, input: &Path, paired_distance: f64) -> Truth {
    let lines = rest_lines(out);
    let input_tris = measure::read_model(input).triangles(|_| true);
    let (lo, hi) = measure::bounds(input_tris.iter().flatten());
    let flat = measure::flat_axis(lo, hi);
    let level = 0.5 * (lo[flat] + hi[flat]);
    let border = measure::boundary_edges(&input_tris, TOL_REL);
    let graph = measure::crack_graph(&lines, TOL_REL);
    let plane_lines = measure::flatten(&lines, flat, level);
    let plane_graph = measure::crack_graph(&plane_lines, TOL_REL);
    let plane_border = measure::flatten(&border, flat, level);
    let cells = measure::planar_cells(&plane_graph, &plane_border, MIN_CELL_REL);
    let arm = 0.1 * measure::cell_diameters(&cells);
    let sides = measure::planar_cell_sides(&plane_graph, &plane_border, MIN_CELL_REL, arm, 150.0);
    Truth {
        cells: cells.len(),
        sides: (
            sides.iter().sum::<usize>() as f64 / sides.len().max(1) as f64,
            sides.len(),
        ),
        tips: measure::open_tips(&graph, &border),
        edge_share: measure::edge_share(&lines, &input_tris, measure::DEFAULT_TOL_REL),
        paired: measure::paired_share_in(&graph, paired_distance, 20.0),
    }
}

/// `crackle stats OUT --input IN --json`.
fn stats(out: &Path, input: &Path) -> Value {
    let o = run_ok([
        "stats".as_ref(),
        out.as_os_str(),
        "--input".as_ref(),
        input.as_os_str(),
        "--json".as_ref(),
    ]);
    serde_json::from_slice(&o.stdout).expect("stats JSON")
}

fn num(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} in {v}"))
}

/// Crack the plate with `preset` (and `extra` arguments), and compare
/// `crackle stats` with the measure: a line of figures, and the
/// differences beyond the tolerances.
fn check(preset: &str, extra: &[&str], dir: &Path) -> (String, Vec<String>) {
    let input = fixture("plate_jittered.obj");
    let name = format!(
        "{preset}{}",
        if extra.is_empty() { "" } else { "-unremeshed" }
    );
    let out = dir.join(format!("{name}.glb"));
    let (i, o) = (input.to_str().unwrap(), out.to_str().unwrap());
    let mut args = vec!["-q", "crack", i, o, "--preset", preset];
    args.extend(extra);
    run_ok(args);
    let preset = name.as_str();
    let s = stats(&out, &input);
    let t = truth(&out, &input, num(&s, "paired_distance"));
    let cells = num(&s, "cells") as usize;
    let tips = num(&s, "dangling_tips") as usize;
    let share = num(&s, "along_reference_edges");
    let paired = num(&s, "paired");
    let sides = (num(&s, "mean_cell_sides"), num(&s, "sided_cells") as usize);
    let line = format!(
        "{preset:26} cells {cells:4} / {:4}  tips {tips:3} / {:3}  on edges {share:.3} / {:.3}  \
         paired {paired:.3} / {:.3} (within {:.4})  sides {:.2} ({}) / {:.2} ({})",
        t.cells,
        t.tips,
        t.edge_share,
        t.paired,
        num(&s, "paired_distance"),
        sides.0,
        sides.1,
        t.sides.0,
        t.sides.1
    );
    let mut bad = Vec::new();
    let off = |a: usize, b: usize| a.abs_diff(b);
    if off(cells, t.cells) > 3.max(t.cells / 20) {
        bad.push(format!("{preset}: {cells} cells, the measure {}", t.cells));
    }
    if off(tips, t.tips) > 2.max(t.tips / 10) {
        bad.push(format!(
            "{preset}: {tips} open tips, the measure {}",
            t.tips
        ));
    }
    if (share - t.edge_share).abs() > 0.02 {
        bad.push(format!(
            "{preset}: {share:.3} of the length on the input's edges, the measure {:.3}",
            t.edge_share
        ));
    }
    if (paired - t.paired).abs() > 0.05 {
        bad.push(format!(
            "{preset}: {paired:.3} paired, the measure {:.3}",
            t.paired
        ));
    }
    if t.sides.1 >= 10 && (sides.0 - t.sides.0).abs() > 0.3 {
        bad.push(format!(
            "{preset}: cells of {:.2} sides, the measure {:.2}",
            sides.0, t.sides.0
        ));
    }
    (line, bad)
}

/// Every preset's output of the plate: `crackle stats` agrees with the
/// measure on cells, open tips, the share on the input's edges and pairs.
/// On the remeshed plate no crack follows the input's edges; three more
/// runs on the plate's own triangles (not remeshed: the cracks run along
/// its edges, kept, opened, and snapped) check the share where it is not 0.
#[test]
fn stats_agree_with_an_independent_measure_on_every_preset() {
    let dir = tempfile::tempdir().unwrap();
    let raw: &[&str] = &["--set", "simulation.isotropic_remesh=false"];
    let mut names: Vec<(String, &[&str])> = presets().into_iter().map(|p| (p, &[][..])).collect();
    for p in ["glaze", "mud", "impact-snapped"] {
        names.push((p.to_string(), raw));
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(Vec::new());
    // Two at a time (two cores).
    std::thread::scope(|scope| {
        for _ in 0..2 {
            scope.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                let Some((name, extra)) = names.get(k) else {
                    break;
                };
                let r = check(name, extra, dir.path());
                results.lock().unwrap().push((k, r));
            });
        }
    });
    let mut results = results.into_inner().unwrap();
    results.sort_by_key(|r| r.0);
    assert_eq!(results.len(), names.len(), "a preset's check panicked");
    eprintln!("{:26} stats / measure", "preset");
    let mut bad = Vec::new();
    for (_, (line, b)) in results {
        eprintln!("{line}");
        bad.extend(b);
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The 69k-triangle Stanford bunny's glaze output: `crackle stats --input`
/// finishes in seconds and finds the cells the lines enclose.
#[test]
fn stats_of_the_stanford_bunny_take_seconds() {
    let Some(bunny) = eval_data("obj/stanford-bunny/stanford-bunny.obj") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bunny.glb");
    let (i, o) = (bunny.to_str().unwrap(), out.to_str().unwrap());
    run_ok(["-q", "crack", i, o, "--preset", "glaze"]);
    let t = Instant::now();
    let s = stats(&out, &bunny);
    let seconds = t.elapsed().as_secs_f64();
    eprintln!(
        "bunny: stats in {seconds:.2} s, {} cells, {} open tips, {:.3} paired",
        s["cells"], s["dangling_tips"], s["paired"]
    );
    assert!(seconds < 20.0, "stats took {seconds:.1} s");
    assert!(num(&s, "cells") >= 100.0, "{s}");
}
