//! An independent measure of a crackle output (no code shared with `crackle stats`):
//!
//! `cargo run --release --example measure -- OUTPUT.glb --input INPUT.(obj|glb|gltf)
//!  [--frame plate|disc|latlong] [--axis x|y|z] [--cell D] [--impact X,Y,Z --radius R]`
//! prints JSON (with `--impact`, radial and concentric crack length by distance from the
//! point, see `impact_stats`);
//! `cargo run --release --example measure -- shapes DIR` writes test meshes into DIR;
//! `cargo run --release --example measure -- gaps OUTPUT.glb CELL` prints the widths of a
//! plate's opened gaps (`gap_widths` on the top surface, every material but `crack_wall`, out to
//! a cell `CELL`, a cell from the border left out): median, quartiles and pinched shares.
//!
//! Crack lines are the LINES primitives of material `crack_lines`, taken at rest
//! (their `_CRACK_REST` attribute, where crackle moved them with opened gaps). The border is the
//! boundary of the input's triangles (where crackle's outline lies; the output's own
//! boundary also follows the cracks' cut sides and is printed separately). With
//! `--frame plate` the lines and the border are first projected onto the input plate's
//! plane, since some presets lift the lines off the surface; otherwise open tips and loose
//! ends are also given for a graph that splits a chord passing within 1% of its length of
//! a stem's end (`crack_graph_curved`: on a curved surface a long segment is a chord).

#[path = "../tests/common/measure.rs"]
mod measure;
#[path = "../tests/common/shapes.rs"]
mod shapes;

use std::path::{Path, PathBuf};

use measure::Seg;
use serde_json::json;

const USAGE: &str = "usage: measure OUTPUT.glb --input INPUT [--frame plate|disc|latlong] \
                     [--axis x|y|z] [--cell D]\n       measure shapes DIR\n       \
                     measure gaps OUTPUT.glb CELL";

fn fail(msg: &str) -> ! {
    eprintln!("measure: {msg}\n{USAGE}");
    std::process::exit(2)
}

fn print_gaps(path: &Path, cell: f64) {
    let top = measure::read_model(path).triangles(|m| m != "crack_wall");
    let (lo, hi) = measure::bounds(top.iter().flatten());
    let flat = measure::flat_axis(lo, hi);
    let w = measure::gap_widths(&top, flat, 1e-7, cell, cell);
    let mut sorted: Vec<f64> = w.iter().map(|x| x.0).collect();
    sorted.sort_by(f64::total_cmp);
    let q = |f: f64| {
        sorted
            .get((f * (sorted.len().max(1) - 1) as f64) as usize)
            .copied()
    };
    let out = json!({
        "edges": w.len(),
        "quartiles": [q(0.25), q(0.5), q(0.75)],
        "pinched_0.25": measure::pinched_share(&w, 0.25),
        "pinched_0.5": measure::pinched_share(&w, 0.5),
    });
    println!("{}", serde_json::to_string_pretty(&out).unwrap_or_default());
}

fn write_shapes(dir: &Path) {
    let list = [
        ("regular_160.obj", shapes::regular_plate(160, 10.0)),
        ("regular_320.obj", shapes::regular_plate(320, 10.0)),
        ("latlong_400x200.obj", shapes::latlong_sphere(400, 200)),
        ("icosphere_6.obj", shapes::icosphere(6)),
        ("disc_160.obj", shapes::regular_disc(160, 10.0)),
        (
            "jittered_160.obj",
            shapes::jittered_plate(160, 10.0, 0.3, 1),
        ),
    ];
    for (name, text) in list {
        let path = dir.join(name);
        shapes::write_obj(&path, &text);
        println!("{}", path.display());
    }
}

struct Args {
    output: PathBuf,
    input: PathBuf,
    frame: String,
    axis: [f64; 3],
    cell: Option<f64>,
    impact: Option<([f64; 3], f64)>,
}

fn parse_args(args: &[String]) -> Args {
    let (mut output, mut input, mut frame, mut axis, mut cell) = (None, None, None, 2, None);
    let (mut impact, mut radius) = (None, None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || {
            it.next()
                .cloned()
                .unwrap_or_else(|| fail(&format!("{a} needs a value")))
        };
        match a.as_str() {
            "--input" => input = Some(PathBuf::from(value())),
            "--frame" => frame = Some(value()),
            "--axis" => {
                let v = value();
                axis = ["x", "y", "z"]
                    .iter()
                    .position(|n| *n == v)
                    .unwrap_or_else(|| fail("--axis is x, y or z"));
            }
            "--cell" => {
                let v: f64 = value()
                    .parse()
                    .unwrap_or_else(|_| fail("--cell needs a number"));
                if v.is_nan() || v <= 0.0 {
                    fail("--cell must be positive");
                }
                cell = Some(v);
            }
            "--impact" => {
                let v: Vec<f64> = value()
                    .split(',')
                    .map(|x| x.parse().unwrap_or_else(|_| fail("--impact X,Y,Z")))
                    .collect();
                if v.len() != 3 {
                    fail("--impact X,Y,Z");
                }
                impact = Some([v[0], v[1], v[2]]);
            }
            "--radius" => {
                radius = Some(
                    value()
                        .parse::<f64>()
                        .unwrap_or_else(|_| fail("--radius needs a number")),
                )
            }
            s if s.starts_with("--") => fail(&format!("unknown option {s}")),
            s if output.is_none() => output = Some(PathBuf::from(s)),
            s => fail(&format!("unexpected argument {s}")),
        }
    }
    let frame = frame.unwrap_or_else(|| "none".into());
    if !["plate", "disc", "latlong", "none"].contains(&frame.as_str()) {
        fail("--frame is plate or latlong");
    }
    let mut unit = [0.0; 3];
    unit[axis] = 1.0;
    Args {
        output: output.unwrap_or_else(|| fail("no output file")),
        input: input.unwrap_or_else(|| fail("--input is required")),
        frame,
        axis: unit,
        cell,
        impact: impact.map(|c| (c, radius.unwrap_or_else(|| fail("--impact needs --radius")))),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("shapes") {
        let dir = args.get(1).unwrap_or_else(|| fail("shapes needs a folder"));
        write_shapes(Path::new(dir));
        return;
    }
    if args.first().map(String::as_str) == Some("gaps") {
        let (Some(path), Some(cell)) = (args.get(1), args.get(2).and_then(|c| c.parse().ok()))
        else {
            fail(USAGE)
        };
        print_gaps(Path::new(path), cell);
        return;
    }
    let a = parse_args(&args);
    let out = measure::read_model(&a.output);
    let input = measure::read_model(&a.input);
    // The network at rest (`_CRACK_REST` where the lines follow opened
    // gaps or curls): its topology is the pattern's; the moved lines are
    // only drawn.
    let lines = out.rest_lines("crack_lines");
    let reference = input.triangles(|_| true);
    let (lo, hi) = measure::bounds(reference.iter().flatten());
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f64, f64::max);
    let plate = a.frame == "plate" || a.frame == "disc";
    let flat = measure::flat_axis(lo, hi);
    let level = 0.5 * (lo[flat] + hi[flat]);
    let in_plane = |s: &[Seg]| {
        if plate {
            measure::flatten(s, flat, level)
        } else {
            s.to_vec()
        }
    };

    let border = in_plane(&measure::boundary_edges(
        &reference,
        measure::DEFAULT_WELD_REL,
    ));
    let out_tris = out.triangles(|_| true);
    let out_border = in_plane(&measure::boundary_edges(
        &out_tris,
        measure::DEFAULT_WELD_REL,
    ));
    let flat_lines = in_plane(&lines);
    let graph = measure::crack_graph(&flat_lines, measure::DEFAULT_WELD_REL);

    let edge_share = measure::edge_share(&lines, &reference, measure::DEFAULT_TOL_REL);
    let orientation = match a.frame.as_str() {
        "plate" => Some(measure::orientation_bins(
            &lines,
            measure::plate_frame(lo, hi, 0.05 * size),
        )),
        "disc" => Some(measure::orientation_bins(
            &lines,
            measure::disc_frame(lo, hi, 0.05 * size),
        )),
        "latlong" => {
            let center = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
            Some(measure::orientation_bins(
                &lines,
                measure::latlong_frame(center, a.axis, 0.8),
            ))
        }
        _ => None,
    };
    let min_area_rel = 1e-4;
    let cells = plate.then(|| measure::planar_cells(&graph, &border, min_area_rel));
    let mean_d = cells.as_ref().map(|c| measure::cell_diameters(c));
    let (d, d_from) = match (a.cell, mean_d) {
        (Some(d), _) => (d, "--cell"),
        (None, Some(d)) if d > 0.0 => (d, "mean planar cell diameter"),
        _ => fail("--cell D is required unless --frame plate finds cells"),
    };
    let loose = measure::loose_ends(&graph, &border, 0.05 * d);
    let mut report = json!({
        "output": a.output.display().to_string(),
        "input": a.input.display().to_string(),
        "frame": a.frame,
        "projected_onto_plate": plate,
        "segments": lines.len(),
        "input_triangles": reference.len(),
        "output_triangles": out.triangles(|m| m != "crack_wall").len(),
        "crack_length": measure::crack_length(&lines),
        "edge_share": edge_share,
        "nodes": graph.nodes.len(),
        "graph_edges": graph.edges.len(),
        "open_tips": measure::open_tips(&graph, &border),
        "open_tips_output_border": measure::open_tips(&graph, &out_border),
        "border_segments": border.len(),
        "output_border_segments": out_border.len(),
        "cell": d,
        "cell_from": d_from,
        "loose_end_radius": 0.05 * d,
        "loose_ends": loose.len(),
        "loose_end_distances": loose.iter().map(|l| l.1).collect::<Vec<_>>(),
        "paired_distance": 0.25 * d,
        "paired_share": measure::paired_share(&flat_lines, 0.25 * d, 20.0),
    });
    let map = report.as_object_mut().expect("object");
    if plate {
        let e = measure::edge_share(&flat_lines, &reference, measure::DEFAULT_TOL_REL);
        map.insert("edge_share_in_plane".into(), json!(e));
    }
    if !plate {
        // On a curved surface a chord can pass over a junction the stem ends on.
        let sag_rel = 0.01;
        let curved = measure::crack_graph_curved(&flat_lines, measure::DEFAULT_WELD_REL, sag_rel);
        let loose = measure::loose_ends(&curved, &border, 0.05 * d);
        map.insert("curved_sag_rel".into(), json!(sag_rel));
        map.insert(
            "open_tips_curved".into(),
            json!(measure::open_tips(&curved, &border)),
        );
        map.insert("loose_ends_curved".into(), json!(loose.len()));
        let at: Vec<_> = loose.iter().map(|l| (curved.nodes[l.0], l.1)).collect();
        map.insert("curved_loose_ends_at".into(), json!(at));
        let paired = measure::paired_share_in(&curved, 0.25 * d, 20.0);
        map.insert("paired_share_curved".into(), json!(paired));
    }
    if let Some((bins, axis)) = orientation {
        map.insert("orientation_bins".into(), json!(bins));
        map.insert("axis_share".into(), json!(axis));
    }
    // Junction angles with arms of a tenth of a cell (the crack's own wiggle is finer).
    let mut normal = [0.0; 3];
    if plate {
        normal[flat] = 1.0;
    }
    map.insert(
        "junctions".into(),
        measure::junction_stats(&graph, 0.1 * d, normal),
    );
    if plate {
        let sides = measure::planar_cell_sides(&graph, &border, min_area_rel, 0.1 * d, 150.0);
        let mean = sides.iter().sum::<usize>() as f64 / sides.len().max(1) as f64;
        map.insert("inner_cells".into(), json!(sides.len()));
        map.insert("mean_inner_cell_sides".into(), json!(mean));
    }
    if let Some(c) = &cells {
        map.insert("planar_cells".into(), json!(c.len()));
        map.insert("mean_cell_diameter".into(), json!(mean_d));
        map.insert("cell_min_area_rel".into(), json!(min_area_rel));
        // Evenness of the cells' areas (tempered glass dices into near-equal cells).
        let n = c.len().max(1) as f64;
        let mean = c.iter().sum::<f64>() / n;
        let var = c.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / n;
        let largest = c.iter().fold(0.0f64, |m, &a| m.max(a));
        map.insert("cell_area_cv".into(), json!(var.sqrt() / mean));
        map.insert("largest_cell_over_mean".into(), json!(largest / mean));
    }
    if let Some((center, radius)) = a.impact {
        // Distances in the plate's plane on a plate, else straight-line.
        let mut normal = [0.0; 3];
        if plate {
            normal[flat] = 1.0;
        }
        map.insert(
            "impact".into(),
            measure::impact_stats(&lines, center, normal, radius),
        );
    }
    println!("{}", serde_json::to_string_pretty(&report).expect("JSON"));
}
