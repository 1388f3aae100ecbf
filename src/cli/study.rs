//! `crackle study`: error against run time for every relaxation integrator
//! on one mesh and pipeline ([`crate::study`]).
//!
//! Output: a table on stdout; with `--out`, `study.csv`, `study.json`, and
//! the plot as `study.svg` and `study.png`.

use crate::pipeline::Config;
use crate::study::{Row, StudyOptions, TARGET_ERROR};
use serde_json::json;
use std::path::{Path, PathBuf};

/// Options of the study command.
pub struct StudyArgs<'a> {
    pub input: &'a Path,
    pub pipeline: crate::pipeline::Pipeline,
    pub pipeline_dir: Option<PathBuf>,
    pub out: Option<&'a Path>,
    pub rounds: usize,
    pub repeat: usize,
    pub full: bool,
    pub weld: crate::mesh::WeldOptions,
    /// How the input is read.
    pub read: crate::io::ReadOptions,
}

/// Run the study and print (and write) its results.
pub fn run(mut a: StudyArgs) -> anyhow::Result<()> {
    if a.pipeline.has_masks() {
        a.pipeline
            .load_images(a.pipeline_dir.as_deref())
            .map_err(|e| super::UsageError(e.to_string()))?;
    }
    let scene = crate::pipeline::read_crackable(a.input, &a.read)?;
    let config = Config {
        pipeline: a.pipeline,
        weld: a.weld,
        asset: a.input.to_path_buf(),
        frames: None,
        output: PathBuf::new(),
        read: a.read,
    };
    let options = StudyOptions {
        rounds: a.rounds,
        repeat: a.repeat,
        full: a.full,
    };
    let study = crate::study::study(&scene, &config, &options)?;
    let rows = &study.rows;
    let (rounds, rt, h, change) = (
        study.rounds,
        study.relax_time,
        study.stable_dt,
        study.reference_change,
    );
    // Output: table, CSV, JSON, SVG.
    println!(
        "{:<10} {:<15} {:>10} {:>8} {:>9} {:>11} {:>11} {:>7} {:>8}",
        "kind", "integrator", "dt", "tol", "seconds", "error", "of change", "steps", "cg iters"
    );
    for r in rows {
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
    let explicit = study.fastest(&["paper-euler", "euler"]);
    let implicit = study.fastest(&["backward-euler"]);
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
        for r in rows {
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
            "mesh": study.mesh,
            "triangles": study.triangles,
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
            rows,
            &dir.join("study.svg"),
            &format!("{} ({} triangles)", study.mesh, study.triangles),
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
) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let e = |x: &dyn std::fmt::Debug| anyhow::anyhow!("{x:?}");
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
