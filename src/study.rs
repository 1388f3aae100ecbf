//! Error against run time for every relaxation integrator on one mesh and
//! pipeline (`crackle study`).
//!
//! Relaxation study: the same relaxation (the pipeline's stress field and
//! load, no cracking) for `rounds` rounds of `relax_time`, by each
//! integrator and a range of steps and tolerances. The error is the
//! area-weighted relative L2 difference of the stress field from a
//! converged reference at the same relaxation time: the paper's forward
//! Euler at a half and a quarter of the stable step, extrapolated
//! (Richardson, `2 S(h/4) - S(h/2)`, second order).
//!
//! Full study ([`StudyOptions::full`]): whole simulations with cracking,
//! compared with the run of the paper's scheme at half the stable step:
//! crack count, crack length, cells (pieces the cracks cut the surface
//! into) and the distance between junction-angle histograms.
//!
//! The study starts where a run starts simulating ([`prepare`]), on the
//! asset's largest simulation mesh.

use crate::math::v3;
use crate::pipeline::{prepare, Config};
use crate::post::islands::face_islands;
use crate::scene::Scene;
use crate::sim::{relax_only, Integrator, Relaxed, SimParams};
use crate::{Error, Result};
use serde_json::{json, Value};
use std::time::Instant;

/// What a study measures.
#[derive(Clone, Copy, Debug)]
pub struct StudyOptions {
    /// Rounds of relaxation (at least 1).
    pub rounds: usize,
    /// Times each relaxation row is run (its time is the least).
    pub repeat: usize,
    /// Also whole simulations with cracking.
    pub full: bool,
}

/// One measured configuration.
pub struct Row {
    /// `relaxation` or `full`.
    pub kind: &'static str,
    /// The integrator's name.
    pub integrator: &'static str,
    /// Its time step.
    pub dt: f64,
    /// Its solver tolerance.
    pub tolerance: f64,
    /// Wall-clock seconds (the least of the repeats).
    pub seconds: f64,
    /// Relaxation: the relative stress error; full: the largest relative
    /// difference of crack count and length from the reference run.
    pub error: f64,
    /// The error relative to how much the reference stress changed over
    /// the run (`|S - S_ref| / |S_ref - S_0|`): the relaxation's own
    /// accuracy when most of the stress is not relaxing.
    pub change_error: f64,
    /// Relaxation steps.
    pub steps: usize,
    /// Conjugate-gradient iterations.
    pub cg_iterations: usize,
    /// A full run's statistics and differences (null for relaxation).
    pub extra: Value,
}

/// The relative stress error the summary times each scheme to.
pub const TARGET_ERROR: f64 = 1e-3;

/// A study's results.
pub struct Study {
    /// The mesh studied (the asset's largest).
    pub mesh: String,
    /// Its triangles.
    pub triangles: usize,
    /// Rounds of relaxation.
    pub rounds: usize,
    /// Relaxation time per round.
    pub relax_time: f64,
    /// The stable forward-Euler step.
    pub stable_dt: f64,
    /// How much the reference changed over the run (relative L2).
    pub reference_change: f64,
    /// The rows: relaxation first, then full runs.
    pub rows: Vec<Row>,
}

impl Study {
    /// The fastest relaxation row of the integrators `names` that reaches
    /// [`TARGET_ERROR`].
    pub fn fastest(&self, names: &[&str]) -> Option<&Row> {
        self.rows
            .iter()
            .filter(|r| r.kind == "relaxation" && names.contains(&r.integrator))
            .filter(|r| r.error <= TARGET_ERROR)
            .min_by(|a, b| a.seconds.total_cmp(&b.seconds))
    }
}

/// Angles (degrees) between angularly adjacent crack edges at every crack
/// junction (a rest position where three or more crack segments meet), as
/// a normalised 12-bin histogram over 0..180.
pub fn junction_histogram(segments: &[[[f64; 3]; 2]]) -> Vec<f64> {
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

/// Run the study on `scene` (read from `config.asset`). The pipeline's
/// mask images must be loaded. The study compares the integrators of the
/// mesh-scale relaxation: a film (a pipeline's cell size) is always solved
/// for equilibrium, so its cell size is left out here (and the mesh is not
/// remeshed, nor grown a margin).
///
/// # Errors
/// What [`prepare`] refuses; [`Error::NothingToCrack`] without a
/// crackable mesh; [`Error::Mesh`] when the mesh has no stable step.
pub fn study(scene: &Scene, config: &Config, options: &StudyOptions) -> Result<Study> {
    let mut config = config.clone();
    config.pipeline.simulation.cell_size = None;
    config.pipeline.simulation.cell_size_relative = None;
    // A margin is grown only round a film: without the cell size there is
    // none to grow (and nothing to warn about).
    config.pipeline.simulation.margin = 0.0;
    let prepared = prepare(scene, &config, &mut ())?;
    let input = config.asset.as_path();
    let Some(k) = (0..prepared.entries.len()).max_by_key(|&k| {
        let e = &prepared.entries[k];
        (e.sim.n_faces(), usize::MAX - e.mesh_index)
    }) else {
        return Err(Error::NothingToCrack {
            path: input.to_path_buf(),
            why: crate::error::Uncrackable::NoCrackableMesh,
        });
    };
    let e = &prepared.entries[k];
    let base = prepared.params[k].clone();
    let field = prepared.fields[k].as_ref();
    let mesh = &e.sim;
    let rounds = options.rounds.max(1);
    let repeat = options.repeat.max(1);
    let setup = Setup {
        mesh,
        base: &base,
        field,
        input,
        label: &e.label,
    };
    log::info!(
        "{}: {} ({} triangles), {} rounds of relaxation time {}",
        input.display(),
        e.label,
        mesh.n_faces(),
        rounds,
        base.relax_time
    );

    let (mut rows, h, change) = relaxation_rows(&setup, rounds, repeat)?;
    if options.full {
        rows.extend(full_rows(&setup, h)?);
    }
    let rt = base.relax_time;
    Ok(Study {
        mesh: e.label.clone(),
        triangles: mesh.n_faces(),
        rounds,
        relax_time: rt,
        stable_dt: h,
        reference_change: change,
        rows,
    })
}

/// What every row runs on.
struct Setup<'a> {
    mesh: &'a crate::mesh::SimMesh,
    base: &'a SimParams,
    field: Option<&'a crate::stress::StressField>,
    input: &'a std::path::Path,
    label: &'a str,
}

impl Setup<'_> {
    /// The base parameters with this integrator, step and tolerance.
    fn with(&self, integrator: Integrator, dt: f64, tolerance: f64) -> SimParams {
        SimParams {
            integrator,
            relax_dt: dt,
            tolerance,
            relax_steps: 0,
            ..self.base.clone()
        }
    }
}

/// The relaxation rows, the stable step and how much the reference
/// changed over the run.
fn relaxation_rows(s: &Setup, rounds: usize, repeat: usize) -> Result<(Vec<Row>, f64, f64)> {
    let (mesh, field, input) = (s.mesh, s.field, s.input);
    let with = |i, dt, tol| s.with(i, dt, tol);
    // The stable step, from a stable-step Euler run (also a study row).
    let euler = relax_only(mesh, &with(Integrator::Euler, 0.0, 1e-4), field, rounds)?;
    let h = euler.report.stable_dt;
    if !(h.is_finite() && h > 0.0) {
        return Err(Error::mesh(input, s.label, "no stable step (no elements?)"));
    }
    let rt = s.base.relax_time;
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
    Ok((rows, h, change))
}

/// Full runs with cracking against the paper's scheme at `h / 2`.
fn full_rows(s: &Setup, h: f64) -> Result<Vec<Row>> {
    let (mesh, field, base) = (s.mesh, s.field, s.base);
    let with = |i, dt, tol| s.with(i, dt, tol);
    let rt = base.relax_time;
    let mut rows = Vec::new();
    let full = |p: &SimParams| -> Result<(Value, f64, Vec<f64>)> {
        let mut m = mesh.clone();
        let t = Instant::now();
        let r = crate::sim::run_with(&mut m, p, field, &mut ())?;
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
    Ok(rows)
}
