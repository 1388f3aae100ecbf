//! `crackle study`: error against run time for every relaxation integrator
//! on one mesh and pipeline.
//!
//! Relaxation study: the same relaxation (the pipeline's stress field and
//! load, no cracking) for `rounds` rounds of `relax_time`, by each
//! integrator and a range of steps and tolerances. The error is the
//! area-weighted relative L2 difference of the stress field from a
//! converged reference at the same relaxation time: the paper's forward
//! Euler at a half and a quarter of the stable step, extrapolated
//! (Richardson, `2 S(h/4) - S(h/2)`, second order).
//!
//! Full study (`--full`): whole simulations with cracking, compared with the
//! run of the paper's scheme at half the stable step: crack count, crack
//! length, cells (pieces the cracks cut the surface into) and the
//! distance between junction-angle histograms.
//!
//! Output: a table on stdout; with `--out`, `study.csv`, `study.json`, and
//! the plot as `study.svg` and `study.png`.

use crackle::bridge::build_sim_meshes;
use crackle::math::v3;
use crackle::post::islands::face_islands;
use crackle::sim::{relax_only, Integrator, Relaxed, SimParams};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of the study command.
pub struct StudyArgs<'a> {
    pub input: &'a Path,
    pub pipeline: crackle::pipeline::Pipeline,
    pub pipeline_dir: Option<PathBuf>,
    pub out: Option<&'a Path>,
    pub rounds: usize,
    pub repeat: usize,
    pub full: bool,
    pub weld: crackle::mesh::WeldOptions,
    /// How the input is read.
    pub read: crackle::io::ReadOptions,
}

/// One measured configuration.
struct Row {
    kind: &'static str,
    integrator: &'static str,
    dt: f64,
    tolerance: f64,
    seconds: f64,
    error: f64,
    /// The error relative to how much the reference stress changed over
    /// the run (`|S - S_ref| / |S_ref - S_0|`): the relaxation's own
    /// accuracy when most of the stress is not relaxing.
    change_error: f64,
    steps: usize,
    cg_iterations: usize,
    extra: Value,
}

/// The relative stress error the summary times each scheme to.
const TARGET_ERROR: f64 = 1e-3;

/// Angles (degrees) between angularly adjacent crack edges at every crack
/// junction (a rest position where three or more crack segments meet), as
/// a normalised 12-bin histogram over 0..180.
fn junction_histogram(segments: &[[[f64; 3]; 2]]) -> Vec<f64> {
    use std::collections::BTreeMap;
    let key = |p: [f64; 3]| p.map(|x| (x + 0.0).to_bits());
    let mut at: BTreeMap<[u64; 3], Vec<[f64; 3]>> = BTreeMap::new();
    for s in segments {
        for (a, b) in [(s[0], s[1]), (s[1], s[0])] {
            let d = v3::sub(b, a);
            let l = v3::norm(d);
            if l > 0.0 {
                at.entry(key(a)).or_default().push(v3::scale(d, 1.0 / l));
            }
        }
    }
    let mut hist = vec![0.0; 12];
    for dirs in at.values().filter(|d| d.len() >= 3) {
        // Angles around the plane the directions lie in: its normal is the
        // direction of least spread (smallest eigenvector of sum d d^T).
        let mut m = nalgebra::Matrix3::<f64>::zeros();
        for d in dirs {
            let v = nalgebra::Vector3::new(d[0], d[1], d[2]);
            m += v * v.transpose();
        }
        let eig = m.symmetric_eigen();
        let k = (0..3)
            .min_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]))
            .unwrap_or(0);
        let c = eig.eigenvectors.column(k);
        let n = [c[0], c[1], c[2]];
        // First axis: the first direction, flattened into the plane.
        let e1 = v3::sub(dirs[0], v3::scale(n, v3::dot(dirs[0], n)));
        let l1 = v3::norm(e1);
        if l1 <= 0.0 || l1.is_nan() {
            continue;
        }
        let e1 = v3::scale(e1, 1.0 / l1);
        let e2 = v3::cross(n, e1);
        let mut ang: Vec<f64> = dirs
            .iter()
            .map(|d| v3::dot(*d, e2).atan2(v3::dot(*d, e1)))
            .collect();
        ang.sort_by(f64::total_cmp);
        for i in 0..ang.len() {
            let next = if i + 1 < ang.len() {
                ang[i + 1]
            } else {
                ang[0] + 2.0 * std::f64::consts::PI
            };
            let deg = (next - ang[i]).to_degrees().clamp(0.0, 179.999);
            hist[(deg / 15.0) as usize] += 1.0;
        }
    }
    let total: f64 = hist.iter().sum();
    if total > 0.0 {
        for h in &mut hist {
            *h /= total;
        }
    }
    hist
}

pub fn run(mut a: StudyArgs) -> anyhow::Result<()> {
    if a.pipeline.has_masks() {
        a.pipeline
            .load_images(a.pipeline_dir.as_deref())
            .map_err(|e| super::UsageError(e.to_string()))?;
    }
    let pipe = &a.pipeline;
    let scene = crackle::pipeline::read_crackable(a.input, &a.read)?;
    let (entries, _) = build_sim_meshes(&scene, &a.weld);
    let Some(e) = entries
        .iter()
        .max_by_key(|e| (e.sim.n_faces(), usize::MAX - e.mesh_index))
    else {
        anyhow::bail!("{}: no crackable mesh", a.input.display());
    };
    let masks = if pipe.has_masks() {
        let dir = a
            .input
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        pipe.masks_for(&scene, dir)
            .map_err(|m| super::UsageError(format!("{}: {m}", a.input.display())))?
    } else {
        Vec::new()
    };
    let (groups, matched) = crackle::pipeline::fixed_groups(&scene, e.mesh_index, &pipe.select.fix);
    if let Some(missing) = pipe.select.fix.iter().find(|n| !matched.contains(n)) {
        return Err(super::UsageError(format!(
            "--fix {missing}: {} of {} has no primitive with that material or group name",
            e.label,
            a.input.display()
        ))
        .into());
    }
    // The study compares the integrators of the mesh-scale relaxation: a
    // film (a pipeline's cell size) is always solved for equilibrium, so
    // its cell size is left out here.
    let base = crackle::sim::SimParams {
        cell_size: None,
        cell_size_relative: None,
        ..pipe.params(&groups)
    };
    let curvature = pipe
        .needs_curvature()
        .then(|| crackle::geometry::curvature::estimate(&e.sim));
    let field = if pipe.stress.is_empty() {
        None
    } else {
        Some(crackle::pipeline::stress_field(
            &scene,
            e,
            pipe,
            &masks,
            curvature.as_ref(),
            base.seed,
            a.input,
        )?)
    };
    let field = field.as_ref();
    let mesh = &e.sim;
    let rounds = a.rounds.max(1);
    let repeat = a.repeat.max(1);
    let with = |integrator: Integrator, dt: f64, tolerance: f64| SimParams {
        integrator,
        relax_dt: dt,
        tolerance,
        relax_steps: 0,
        ..base.clone()
    };
    log::info!(
        "{}: {} ({} triangles), {} rounds of relaxation time {}",
        a.input.display(),
        e.label,
        mesh.n_faces(),
        rounds,
        base.relax_time
    );

    // The stable step, from a stable-step Euler run (also a study row).
    let euler = relax_only(mesh, &with(Integrator::Euler, 0.0, 1e-4), field, rounds)?;
    let h = euler.report.stable_dt;
    if !(h.is_finite() && h > 0.0) {
        anyhow::bail!(
            "{}: {}: no stable step (no elements?)",
            a.input.display(),
            e.label
        );
    }
    let rt = base.relax_time;
    // Every relaxation row: (integrator, dt, tolerance). The first two are
    // the reference's.
    let mut configs: Vec<(Integrator, f64, f64)> = vec![
        (Integrator::PaperEuler, h / 2.0, 0.0),
        (Integrator::PaperEuler, h / 4.0, 0.0),
        (Integrator::Euler, 0.0, 0.0),
        (Integrator::LocalEuler, 0.0, 0.0),
    ];
    for k in [1.0, 2.0, 4.0, 8.0, 16.0, 32.0] {
        configs.push((Integrator::BackwardEuler, rt / k, 1e-4));
    }
    // RKL super-steps: one per round, then shorter ones (relax_dt).
    for k in [1.0, 2.0, 4.0, 8.0] {
        configs.push((Integrator::Rkl, rt / k, 0.0));
    }
    // One implicit step per round with loose tolerances: the cheapest
    // implicit settings, for the time it takes to reach a given error.
    for tol in [1e-1, 5e-2, 3e-2, 2e-2, 1e-2] {
        configs.push((Integrator::BackwardEuler, rt, tol));
    }
    for tol in [1e-2, 1e-6] {
        configs.push((Integrator::BackwardEuler, rt / 8.0, tol));
    }
    let params_of =
        |&(i, dt, tol): &(Integrator, f64, f64)| with(i, dt, if tol > 0.0 { tol } else { 1e-4 });
    // The repeats are interleaved (every row once, then every row again,
    // ...), so a slow spell of a shared machine hits every row alike; each
    // row's time is its least.
    // The reference first; then every row's error as it is run, its stress
    // dropped (only the errors and reports are kept, not a stress field per
    // row).
    let half = relax_only(mesh, &params_of(&configs[0]), field, rounds)?;
    let quarter = relax_only(mesh, &params_of(&configs[1]), field, rounds)?;
    let reference = Relaxed {
        stress: half
            .stress
            .iter()
            .zip(&quarter.stress)
            .map(|(s2, s4)| *s4 * 2.0 - *s2)
            .collect(),
        areas: quarter.areas.clone(),
        report: quarter.report.clone(),
        seconds: 0.0,
    };
    let (mut half, mut quarter, mut euler) = (Some(half), Some(quarter), Some(euler));
    let mut runs: Vec<(Relaxed, f64)> = Vec::with_capacity(configs.len());
    for (i, c) in configs.iter().enumerate() {
        let ready = match i {
            0 => half.take(),
            1 => quarter.take(),
            _ if c.0 == Integrator::Euler && c.1 == 0.0 => euler.take(),
            _ => None,
        };
        let mut r = match ready {
            Some(r) => r,
            None => relax_only(mesh, &params_of(c), field, rounds)?,
        };
        let error = r.error_against(&reference);
        r.stress = Vec::new();
        r.areas = Vec::new();
        runs.push((r, error));
    }
    let mut seconds: Vec<f64> = runs.iter().map(|r| r.0.seconds).collect();
    for _ in 1..repeat {
        for (c, s) in configs.iter().zip(&mut seconds) {
            *s = s.min(relax_only(mesh, &params_of(c), field, rounds)?.seconds);
        }
    }
    // The start state (no round run): how much the reference changed.
    let initial = relax_only(mesh, &with(Integrator::Euler, 0.0, 1e-4), field, 0)?;
    let change = initial.error_against(&reference);
    let mut rows: Vec<Row> = Vec::new();
    for ((c, (r, error)), &secs) in configs.iter().zip(&runs).zip(&seconds) {
        let error = *error;
        let (integrator, dt, tolerance) = *c;
        let dt = match integrator {
            // The step these schemes took.
            Integrator::Euler | Integrator::LocalEuler => r.report.stable_dt,
            _ => dt,
        };
        rows.push(Row {
            change_error: if change > 0.0 {
                error / change
            } else {
                f64::NAN
            },
            kind: "relaxation",
            integrator: r.report.integrator,
            dt,
            tolerance,
            seconds: secs,
            error,
            steps: r.report.relax_steps,
            cg_iterations: r.report.phases.iter().map(|p| p.cg_iterations).sum(),
            extra: Value::Null,
        });
    }

    // Full runs with cracking against the paper's scheme at h / 2.
    if a.full {
        let full = |p: &SimParams| -> anyhow::Result<(Value, f64, Vec<f64>)> {
            let mut m = mesh.clone();
            let t = Instant::now();
            let r = crackle::sim::run_with(&mut m, p, field, &mut ())?;
            let s = t.elapsed().as_secs_f64();
            let cells = face_islands(&m).count;
            let hist = junction_histogram(&r.segments);
            let cg: usize = r.phases.iter().map(|p| p.cg_iterations).sum();
            Ok((
                json!({"cracks": r.cracks, "crack_length": r.crack_length, "cells": cells, "relax_steps": r.relax_steps, "cg_iterations": cg}),
                s,
                hist,
            ))
        };
        let configs: Vec<(Integrator, f64, f64)> = vec![
            (Integrator::PaperEuler, h / 2.0, 1e-4),
            (Integrator::Euler, 0.0, 1e-4),
            (Integrator::LocalEuler, 0.0, 1e-4),
            (Integrator::BackwardEuler, rt / 8.0, 1e-4),
            (Integrator::BackwardEuler, rt / 2.0, 1e-4),
            (Integrator::BackwardEuler, rt, 1e-4),
            (Integrator::Rkl, rt, 1e-4),
            (Integrator::Rkl, rt / 4.0, 1e-4),
        ];
        // Each run, plus local-euler with the finishing passes relaxing the
        // whole mesh instead of the rings around their cracks (when the
        // pipeline finishes cracks).
        let mut runs: Vec<(&'static str, SimParams, f64, f64)> = configs
            .iter()
            .map(|&(i, dt, tol)| (i.name(), with(i, dt, tol), dt, tol))
            .collect();
        if base.finish && base.finish_rings > 0 {
            runs.push((
                "local-euler global-finishing",
                SimParams {
                    finish_rings: 0,
                    ..with(Integrator::LocalEuler, 0.0, 1e-4)
                },
                0.0,
                1e-4,
            ));
        }
        let mut reference: Option<(Value, Vec<f64>)> = None;
        for (name, params, dt, tol) in runs {
            let (stats, seconds, hist) = full(&params)?;
            let (rs, rh) = reference
                .get_or_insert_with(|| (stats.clone(), hist.clone()))
                .clone();
            let rel = |k: &str| {
                let (x, y) = (
                    stats[k].as_f64().unwrap_or(0.0),
                    rs[k].as_f64().unwrap_or(0.0),
                );
                if y != 0.0 {
                    (x - y).abs() / y.abs()
                } else {
                    (x - y).abs()
                }
            };
            let hist_dist: f64 = 0.5
                * hist
                    .iter()
                    .zip(&rh)
                    .map(|(p, q)| (p - q).abs())
                    .sum::<f64>();
            let error = rel("cracks").max(rel("crack_length"));
            rows.push(Row {
                kind: "full",
                integrator: name,
                dt,
                tolerance: tol,
                seconds,
                error,
                change_error: f64::NAN,
                steps: stats["relax_steps"].as_u64().unwrap_or(0) as usize,
                cg_iterations: stats["cg_iterations"].as_u64().unwrap_or(0) as usize,
                extra: json!({
                    "stats": stats,
                    "crack_count_difference": rel("cracks"),
                    "crack_length_difference": rel("crack_length"),
                    "cells_difference": rel("cells"),
                    "junction_angle_distance": hist_dist,
                }),
            });
        }
    }

    // Output: table, CSV, JSON, SVG.
    println!(
        "{:<10} {:<15} {:>10} {:>8} {:>9} {:>11} {:>11} {:>7} {:>8}",
        "kind", "integrator", "dt", "tol", "seconds", "error", "of change", "steps", "cg iters"
    );
    for r in &rows {
        println!(
            "{:<10} {:<15} {:>10.3e} {:>8.0e} {:>9.3} {:>11.3e} {:>11.3e} {:>7} {:>8}",
            r.kind,
            r.integrator,
            r.dt,
            r.tolerance,
            r.seconds,
            r.error,
            r.change_error,
            r.steps,
            r.cg_iterations
        );
    }
    // The time each scheme needs to reach the target error: the paper's
    // forward Euler (its largest stable step is the `euler` row) against
    // backward Euler.
    let fastest = |names: &[&str]| {
        rows.iter()
            .filter(|r| r.kind == "relaxation" && names.contains(&r.integrator))
            .filter(|r| r.error <= TARGET_ERROR)
            .min_by(|a, b| a.seconds.total_cmp(&b.seconds))
    };
    let explicit = fastest(&["paper-euler", "euler"]);
    let implicit = fastest(&["backward-euler"]);
    let describe = |r: Option<&Row>| match r {
        Some(r) => format!(
            "{:.3} s ({} dt {:.3e} tol {:.0e}: error {:.2e})",
            r.seconds, r.integrator, r.dt, r.tolerance, r.error
        ),
        None => "not reached".into(),
    };
    println!(
        "to error {TARGET_ERROR:.0e}: the paper's forward Euler {}; backward Euler {}",
        describe(explicit),
        describe(implicit)
    );
    let speedup = match (explicit, implicit) {
        (Some(e), Some(i)) if i.seconds > 0.0 => {
            let x = e.seconds / i.seconds;
            println!("backward Euler is {x:.1}x faster to error {TARGET_ERROR:.0e}");
            Some(x)
        }
        _ => None,
    };
    let target_json = |r: Option<&Row>| {
        r.map(|r| {
            json!({"integrator": r.integrator, "dt": r.dt, "tolerance": r.tolerance,
                   "seconds": r.seconds, "error": r.error})
        })
    };
    if let Some(dir) = a.out {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("{}: cannot create the folder: {e}", dir.display()))?;
        let mut csv = String::from(
            "kind,integrator,dt,tolerance,seconds,error,change_error,steps,cg_iterations\n",
        );
        for r in &rows {
            csv += &format!(
                "{},{},{},{},{},{},{},{},{}\n",
                r.kind,
                r.integrator,
                r.dt,
                r.tolerance,
                r.seconds,
                r.error,
                r.change_error,
                r.steps,
                r.cg_iterations
            );
        }
        std::fs::write(dir.join("study.csv"), csv)?;
        let doc = json!({
            "input": a.input.display().to_string(),
            "mesh": e.label,
            "triangles": mesh.n_faces(),
            "rounds": rounds,
            "relax_time": rt,
            "stable_dt": h,
            "reference": "paper-euler at stable_dt/2 and /4, Richardson-extrapolated",
            "reference_change": change,
            "target": {
                "error": TARGET_ERROR,
                "paper_forward_euler": target_json(explicit),
                "backward_euler": target_json(implicit),
                "speedup": speedup,
            },
            "rows": rows.iter().map(|r| json!({
                "kind": r.kind, "integrator": r.integrator, "dt": r.dt, "tolerance": r.tolerance,
                "seconds": r.seconds, "error": r.error, "change_error": r.change_error, "steps": r.steps,
                "cg_iterations": r.cg_iterations, "full": r.extra,
            })).collect::<Vec<_>>(),
        });
        std::fs::write(dir.join("study.json"), serde_json::to_vec_pretty(&doc)?)?;
        plot(
            &rows,
            &dir.join("study.svg"),
            &format!("{} ({} triangles)", e.label, mesh.n_faces()),
        )?;
    }
    Ok(())
}

/// The plot's font (DejaVu Sans, Bitstream Vera license:
/// `assets/fonts/LICENSE-DejaVu.txt`), compiled in so the PNG has labels on
/// any machine.
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Error (log) against seconds (log), one series per integrator, for the
/// relaxation rows: `path` as SVG and the same path with `.png`.
fn plot(rows: &[Row], path: &Path, title: &str) -> anyhow::Result<()> {
    use plotters::prelude::*;
    use plotters::style::FontStyle;
    plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
        .map_err(|_| anyhow::anyhow!("the plot font does not load"))?;
    let err = |p: &Path, e: &dyn std::fmt::Display| anyhow::anyhow!("{}: plot: {e}", p.display());
    let svg = SVGBackend::new(path, (800, 560)).into_drawing_area();
    draw(rows, svg, title).map_err(|e| err(path, &e))?;
    let png_path = path.with_extension("png");
    let png = BitMapBackend::new(&png_path, (800, 560)).into_drawing_area();
    draw(rows, png, title).map_err(|e| err(&png_path, &e))?;
    Ok(())
}

fn draw<DB: plotters::prelude::DrawingBackend>(
    rows: &[Row],
    root: plotters::drawing::DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
) -> Result<(), String> {
    use plotters::prelude::*;
    let e = |x: &dyn std::fmt::Debug| format!("{x:?}");
    let pts: Vec<&Row> = rows
        .iter()
        .filter(|r| r.kind == "relaxation" && r.error > 0.0 && r.seconds > 0.0)
        .collect();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    if pts.is_empty() {
        return root.present().map_err(|x| e(&x));
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, 0.0f64, f64::MAX, 0.0f64);
    for r in &pts {
        x0 = x0.min(r.seconds);
        x1 = x1.max(r.seconds);
        y0 = y0.min(r.error);
        y1 = y1.max(r.error);
    }
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("relaxation error against run time: {title}"),
            ("sans-serif", 20),
        )
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x0 / 1.5..x1 * 1.5).log_scale(),
            (y0 / 2.0..y1 * 2.0).log_scale(),
        )
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc("seconds")
        .y_desc("relative stress error")
        .draw()
        .map_err(|x| e(&x))?;
    let series: [(&str, RGBColor); 4] = [
        ("paper-euler", RGBColor(200, 60, 40)),
        ("euler", RGBColor(230, 150, 30)),
        ("local-euler", RGBColor(40, 130, 60)),
        ("backward-euler", RGBColor(40, 80, 200)),
    ];
    for (name, color) in series {
        let mut s: Vec<(f64, f64)> = pts
            .iter()
            .filter(|r| r.integrator == name && (r.tolerance == 0.0 || r.tolerance == 1e-4))
            .map(|r| (r.seconds, r.error))
            .collect();
        if s.is_empty() {
            continue;
        }
        s.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(s.clone(), color.stroke_width(2)))
            .map_err(|x| e(&x))?
            .label(name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
        chart
            .draw_series(s.iter().map(|&p| Circle::new(p, 4, color.filled())))
            .map_err(|x| e(&x))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()
        .map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))
}
