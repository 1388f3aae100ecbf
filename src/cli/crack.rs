//! `crackle crack`: read, weld, grow cracks, write the cracked scene with the
//! crack network as a LINES primitive, and report.

use anyhow::Result;
use crackle::bridge::build_sim_meshes;
use crackle::geometry::curvature::{self, CurvatureField};
use crackle::mesh::{remesh, WeldOptions};
use crackle::pipeline::{Bounds, Pipeline, Placement};
use crackle::scene::{Geometry, Scene};
use crackle::sim::SimReport;
use crackle::stress::StressField;
use serde_json::json;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Simulation options of the crack command: a pipeline (file or preset)
/// plus overrides. Each flag below is short for `--set simulation.KEY=VALUE`
/// (defaults and units: README). Lengths and times are in the mesh's own
/// units normalised by its mean edge length; stress is dimensionless.
#[derive(clap::Args, Debug)]
pub struct SimArgs {
    /// Pipeline file (TOML): mesh selection, stress terms, simulation
    #[arg(long, value_name = "FILE", conflicts_with = "preset")]
    pipeline: Option<PathBuf>,
    /// Built-in pipeline (`crackle presets` lists them)
    #[arg(long, value_name = "NAME")]
    preset: Option<String>,
    /// Override a pipeline key (repeatable), e.g. `--set simulation.toughness=3`; a stress entry's key by its index, e.g. `--preset glass-impact --set stress.0.radius_relative=0.1` (`crackle presets NAME` shows a preset's entries)
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Cell size of the pattern in scene units (replaces the pipeline's cell size)
    #[arg(long, value_name = "SIZE")]
    cell_size: Option<f64>,
    /// Cell size as a fraction of each mesh's bounding-box diagonal (replaces the pipeline's cell size)
    #[arg(long, value_name = "FRACTION")]
    cell_size_relative: Option<f64>,
    /// Most triangles of the remeshed simulation surface [default: 2000000]
    #[arg(long, value_name = "N")]
    max_triangles: Option<usize>,
    /// Toughness: a node fails when its separation eigenvalue exceeds it [default: 2]
    #[arg(long)]
    toughness: Option<f64>,
    /// Fraction of the residual stress handed to crack tips, in [0, 1] [default: 0.8]
    #[arg(long)]
    alpha: Option<f64>,
    /// Constant added to the residual at crack tips, for long joined cracks [default: 1]
    #[arg(long)]
    residual_constant: Option<f64>,
    /// Uniform shrinkage added per unit of relaxation time [default: 0.05]
    #[arg(long)]
    shrink_rate: Option<f64>,
    /// How long the load acts; then the run goes on until nothing fails [default: 120]
    #[arg(long)]
    load_time: Option<f64>,
    /// Seeded variation of the load between triangles, in [0, 1] [default: 0.2]
    #[arg(long)]
    noise: Option<f64>,
    /// Seed of every random choice [default: 1]
    #[arg(long)]
    seed: Option<u64>,
    /// Relaxation time between crack checks [default: 5]
    #[arg(long)]
    relax_time: Option<f64>,
    /// Largest relaxation step; 0: the stable step [default: 0]
    #[arg(long)]
    relax_dt: Option<f64>,
    /// Relaxation steps per round; 0: as many as --relax-time needs [default: 0]
    #[arg(long)]
    relax_steps: Option<usize>,
    /// Relaxation integrator: local-euler, euler, paper-euler (needs --relax-dt), backward-euler, equilibrium, rkl, or auto (local-euler unless the mesh is stiff, then backward-euler) [default: auto]
    #[arg(long, value_name = "NAME")]
    integrator: Option<String>,
    /// Relative residual of each backward-Euler solve [default: 1e-4]
    #[arg(long)]
    tolerance: Option<f64>,
    /// Finishing passes relax only this many rings around their new cracks; 0: the whole mesh [default: 8]
    #[arg(long, value_name = "RINGS")]
    finish_rings: Option<usize>,
    /// Most relaxation rounds [default: 200]
    #[arg(long)]
    max_rounds: Option<usize>,
    /// Most crack events per mesh [default: 1000000]
    #[arg(long)]
    max_cracks: Option<usize>,
    /// Most crack events per round before the load is held; 0: 1% of the nodes [default: 0]
    #[arg(long)]
    max_cracks_per_round: Option<usize>,
    /// Conditioning cap on element gradients, times the input mean [default: 4]
    #[arg(long)]
    clamp_factor: Option<f64>,
    /// Fix the mesh's open boundary instead of leaving it free
    #[arg(long)]
    fixed_boundary: bool,
    /// Fix every node of the primitives with this material or OBJ group name (repeatable)
    #[arg(long, value_name = "NAME")]
    fix: Vec<String>,
    /// Do not bond the surface to the body under it (closed shells then shrink instead of cracking)
    #[arg(long)]
    unbonded: bool,
    /// Write each piece the cracks cut a mesh into as its own node (same as --set post.split_islands=true)
    #[arg(long)]
    split_islands: bool,
}

impl SimArgs {
    /// The folder of the pipeline file (relative mask images are found
    /// there); `None` for a preset or the defaults.
    pub fn pipeline_dir(&self) -> Option<PathBuf> {
        self.pipeline.as_ref().map(|p| {
            p.parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."))
                .to_path_buf()
        })
    }

    /// The pipeline these options give: the file or preset (or the
    /// defaults), then the flags, then `--set`, all checked.
    pub fn pipeline(&self) -> Result<Pipeline> {
        self.pipeline_with(self.pipeline.as_deref(), self.preset.as_deref(), &[])
    }

    /// The `--pipeline` file, if given.
    pub fn pipeline_file(&self) -> Option<&Path> {
        self.pipeline.as_deref()
    }

    /// The `--preset` name, if given.
    pub fn preset_name(&self) -> Option<&str> {
        self.preset.as_deref()
    }

    /// The `--fix` names.
    pub fn fix_names(&self) -> &[String] {
        &self.fix
    }

    /// Whether `--pipeline` or `--preset` was given.
    pub fn has_choice(&self) -> bool {
        self.pipeline.is_some() || self.preset.is_some()
    }

    /// The pipeline of `file` or `preset` (or the defaults) with these
    /// options' flags and `--set` on top.
    pub fn pipeline_with(
        &self,
        file: Option<&Path>,
        preset: Option<&str>,
        extra: &[String],
    ) -> Result<Pipeline> {
        let sets = self.overrides(extra);
        let usage = |e: crackle::pipeline::PipelineError| super::UsageError(e.to_string());
        let mut p = match (file, preset) {
            (Some(path), _) => {
                let text = std::fs::read_to_string(path).map_err(|e| {
                    super::UsageError(format!("{}: cannot read the pipeline: {e}", path.display()))
                })?;
                Pipeline::parse(&text, &path.display().to_string(), &sets).map_err(usage)?
            }
            (None, Some(name)) => Pipeline::preset(name, &sets).map_err(usage)?,
            (None, None) => Pipeline::parse("", "defaults", &sets).map_err(usage)?,
        };
        p.select.fix.extend(self.fix.iter().cloned());
        Ok(p)
    }

    /// Every override as a `--set KEY=VALUE` string: `extra` first, then
    /// the flags, then `--set`.
    pub fn overrides(&self, extra: &[String]) -> Vec<String> {
        let mut sets: Vec<String> = extra.to_vec();
        let mut set = |k: &str, v: Option<String>| {
            if let Some(v) = v {
                sets.push(format!("simulation.{k}={v}"));
            }
        };
        set("cell_size", self.cell_size.map(|x| format!("{x:?}")));
        set(
            "cell_size_relative",
            self.cell_size_relative.map(|x| format!("{x:?}")),
        );
        set("max_triangles", self.max_triangles.map(|x| x.to_string()));
        set("toughness", self.toughness.map(|x| format!("{x:?}")));
        set("alpha", self.alpha.map(|x| format!("{x:?}")));
        set(
            "residual_constant",
            self.residual_constant.map(|x| format!("{x:?}")),
        );
        set("shrink_rate", self.shrink_rate.map(|x| format!("{x:?}")));
        set("load_time", self.load_time.map(|x| format!("{x:?}")));
        set("noise", self.noise.map(|x| format!("{x:?}")));
        set("seed", self.seed.map(|x| x.to_string()));
        set("relax_time", self.relax_time.map(|x| format!("{x:?}")));
        set("relax_dt", self.relax_dt.map(|x| format!("{x:?}")));
        set("relax_steps", self.relax_steps.map(|x| x.to_string()));
        set("integrator", self.integrator.clone());
        set("tolerance", self.tolerance.map(|x| format!("{x:?}")));
        set("finish_rings", self.finish_rings.map(|x| x.to_string()));
        set("max_rounds", self.max_rounds.map(|x| x.to_string()));
        set("max_cracks", self.max_cracks.map(|x| x.to_string()));
        set(
            "max_cracks_per_round",
            self.max_cracks_per_round.map(|x| x.to_string()),
        );
        set("clamp_factor", self.clamp_factor.map(|x| format!("{x:?}")));
        set("bonded", self.unbonded.then(|| "false".to_string()));
        if self.fixed_boundary {
            sets.push("select.fixed_boundary=true".into());
        }
        if self.split_islands {
            sets.push("post.split_islands=true".into());
        }
        sets.extend(self.sets.iter().cloned());
        sets
    }
}

/// Options of the crack command.
pub struct CrackArgs<'a> {
    pub input: &'a Path,
    pub output: &'a Path,
    pub report: Option<&'a Path>,
    pub weld: WeldOptions,
    pub pipeline: Pipeline,
    /// Folder of the pipeline file, for relative mask images.
    pub pipeline_dir: Option<PathBuf>,
    pub quiet: bool,
    /// `--frames N DIR`.
    pub frames: Option<super::frames::FramesArgs>,
    /// Told what the run is doing (`read`, `weld`, `simulate <mesh> round
    /// 3/200`...), for a batch's progress display.
    pub on_stage: Option<&'a (dyn Fn(&str) + Sync)>,
    /// Name a `.gltf` output's image files `<stem>_<name>` (a batch, where
    /// outputs share folders).
    pub prefix_images: bool,
}

/// Groups (primitive indices) of mesh `mesh_index` whose material or OBJ
/// group name is in `names`, and the names that matched.
pub fn fixed_groups(scene: &Scene, mesh_index: usize, names: &[String]) -> (Vec<u32>, Vec<String>) {
    let mut groups = Vec::new();
    let mut matched = Vec::new();
    for (pi, p) in scene.meshes[mesh_index].primitives.iter().enumerate() {
        let material = p
            .material
            .and_then(|m| scene.materials.get(m))
            .and_then(|m| m.name());
        let group = match &p.geometry {
            Geometry::Triangles(t) => t.group.as_deref(),
            Geometry::Raw(_) => None,
        };
        for n in names {
            if Some(n.as_str()) == material || Some(n.as_str()) == group {
                groups.push(pi as u32);
                matched.push(n.clone());
            }
        }
    }
    (groups, matched)
}

/// Every material and group name in the scene, for error messages.
fn all_names(scene: &Scene) -> Vec<String> {
    let mut out: Vec<String> = scene
        .materials
        .iter()
        .filter_map(|m| m.name().map(str::to_owned))
        .collect();
    for m in &scene.meshes {
        for p in &m.primitives {
            if let Geometry::Triangles(t) = &p.geometry {
                out.extend(t.group.clone());
            }
        }
    }
    out.sort();
    out.dedup();
    out
}

/// A batch's stage callback.
type StageFn<'a> = &'a (dyn Fn(&str) + Sync);

struct Bar<'a> {
    bar: Option<indicatif::ProgressBar>,
    /// The mesh's label and ": " for the per-round log lines.
    label: String,
    /// The batch's stage callback and the mesh's label.
    stage: Option<(StageFn<'a>, String)>,
}

impl crackle::sim::Observer for Bar<'_> {
    fn round(&mut self, round: usize, max_rounds: usize, cracks: usize, relax_steps: usize) {
        log::info!(
            "{}round {round}: {cracks} cracks, {relax_steps} relaxation steps",
            self.label
        );
        if let Some(b) = &self.bar {
            b.set_length(max_rounds as u64);
            b.set_position(round as u64);
            b.set_message(format!("{cracks} cracks"));
        }
        if let Some((f, label)) = &self.stage {
            f(&format!("simulate {label}: round {round}, {cracks} cracks"));
        }
    }
}

/// `crackle crack`: process, write the report, print the summary line.
pub fn run(a: CrackArgs) -> Result<()> {
    let (input, output, report_path, quiet) = (a.input, a.output, a.report, a.quiet);
    let report = process(a)?;
    if let Some(p) = report_path {
        std::fs::write(p, serde_json::to_vec_pretty(&report)?)
            .map_err(|e| anyhow::anyhow!("{}: cannot write the report: {e}", p.display()))?;
    }
    if !quiet {
        eprintln!(
            "{} -> {}: {} cracks, crack length {:.3}, {} -> {} triangles, {} relaxation steps",
            input.display(),
            output.display(),
            report["cracks"],
            report["crack_length"].as_f64().unwrap_or(0.0),
            report["triangles"]["before"],
            report["triangles"]["after"],
            report["relaxation_steps"]
        );
    }
    Ok(())
}

/// Read, crack and write one asset; returns its report.
pub fn process(mut a: CrackArgs) -> Result<serde_json::Value> {
    let stage = |name: &str| {
        if let Some(f) = a.on_stage {
            f(name);
        }
    };
    // Mask images are decoded before anything else, so a bad image is
    // refused before any work.
    let t = Instant::now();
    let mut texture_seconds = 0.0;
    if a.pipeline.has_masks() {
        a.pipeline
            .load_images(a.pipeline_dir.as_deref())
            .map_err(|e| super::UsageError(e.to_string()))?;
        texture_seconds += t.elapsed().as_secs_f64();
    }
    let pipe = &a.pipeline;
    let mut stages = Vec::new();
    let t = Instant::now();
    stage("read");
    let mut scene = super::read_crackable(a.input)?;
    stages.push(json!({"name": "read", "seconds": t.elapsed().as_secs_f64()}));
    let masks = if pipe.has_masks() {
        let t = Instant::now();
        let asset_dir = a
            .input
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let masks = pipe
            .masks_for(&scene, asset_dir)
            .map_err(|m| super::UsageError(format!("{}: {m}", a.input.display())))?;
        texture_seconds += t.elapsed().as_secs_f64();
        stages.push(json!({"name": "texture", "seconds": texture_seconds}));
        masks
    } else {
        Vec::new()
    };
    let t = Instant::now();
    stage("weld");
    let (mut entries, skipped) = build_sim_meshes(&scene, &a.weld);
    for s in &skipped {
        log::warn!(
            "{}: {} is written unchanged: {}",
            a.input.display(),
            s.label,
            s.reason
        );
    }
    // Mesh selection by name.
    if !pipe.select.meshes.is_empty() {
        let name_of = |i: usize| scene.meshes[i].name.clone().unwrap_or_default();
        if let Some(missing) = pipe
            .select
            .meshes
            .iter()
            .find(|n| !entries.iter().any(|e| &name_of(e.mesh_index) == *n))
        {
            let names: Vec<String> = entries.iter().map(|e| name_of(e.mesh_index)).collect();
            return Err(super::UsageError(format!(
                "select.meshes: {} has no crackable mesh named '{missing}' (meshes: {})",
                a.input.display(),
                names.join(", ")
            ))
            .into());
        }
        entries.retain(|e| pipe.select.meshes.contains(&name_of(e.mesh_index)));
    }
    stages.push(json!({"name": "weld", "seconds": t.elapsed().as_secs_f64()}));
    let mut matched: Vec<String> = Vec::new();
    let mut params_of = Vec::new();
    for e in &entries {
        let (groups, m) = fixed_groups(&scene, e.mesh_index, &pipe.select.fix);
        matched.extend(m);
        params_of.push(pipe.params(&groups));
    }
    if let Some(missing) = pipe.select.fix.iter().find(|n| !matched.contains(n)) {
        return Err(super::UsageError(format!(
            "--fix {missing}: no crackable primitive of {} has that material or group name (names: {})",
            a.input.display(),
            all_names(&scene).join(", ")
        ))
        .into());
    }
    // Isotropic remeshing to the cell size: a stage only when a pipeline
    // asks for a cell size. Every budget is checked before any work.
    if entries
        .iter()
        .zip(&params_of)
        .any(|(e, p)| p.isotropic_remesh && p.cell_size_for(&e.sim).is_some())
    {
        let t = Instant::now();
        stage("remesh");
        let mut plans = Vec::new();
        for (e, p) in entries.iter().zip(&params_of) {
            let plan = p
                .cell_size_for(&e.sim)
                .filter(|_| p.isotropic_remesh)
                .map(|cell| cell / crackle::sim::film::EDGES_PER_CELL);
            if let Some(target) = plan {
                let estimate = remesh::estimate_triangles(&e.sim, target);
                if estimate > p.max_triangles {
                    return Err(super::UsageError(format!(
                        "{}: {}: a cell size of {:.6} (edges of {:.6}) needs about {} triangles, above simulation.max_triangles = {}; ask for a larger cell size or raise max_triangles",
                        a.input.display(),
                        e.label,
                        target * crackle::sim::film::EDGES_PER_CELL,
                        target,
                        estimate,
                        p.max_triangles
                    ))
                    .into());
                }
            }
            plans.push(plan);
        }
        let mut meshes = Vec::new();
        for ((e, p), plan) in entries.iter_mut().zip(&params_of).zip(plans) {
            let Some(target) = plan else { continue };
            let options = remesh::RemeshOptions {
                target_edge: target,
                coarsen: p.coarsen,
                ..Default::default()
            };
            let (sim, r) = remesh::remesh(&e.sim, &options).map_err(|err| {
                anyhow::anyhow!("{}: {}: remeshing: {err}", a.input.display(), e.label)
            })?;
            e.sim = sim;
            meshes.push(json!({"mesh": e.label, "target_edge": target, "report": r}));
        }
        stages.push(
            json!({"name": "remesh", "seconds": t.elapsed().as_secs_f64(), "meshes": meshes}),
        );
    }
    // Curvature: a stage only when a stress term uses it.
    let mut curvatures: Vec<Option<CurvatureField>> = vec![None; entries.len()];
    if pipe.needs_curvature() {
        let t = Instant::now();
        stage("curvature");
        for (k, e) in curvatures.iter_mut().zip(&entries) {
            *k = Some(curvature::estimate(&e.sim));
        }
        stages.push(json!({"name": "curvature", "seconds": t.elapsed().as_secs_f64()}));
    }
    // Stress fields: a stage only when the pipeline has stress terms.
    let mut fields: Vec<Option<StressField>> = Vec::new();
    if pipe.stress.is_empty() {
        fields.resize(entries.len(), None);
    } else {
        let t = Instant::now();
        stage("stress");
        for ((e, params), k) in entries.iter().zip(&params_of).zip(&curvatures) {
            let field = stress_field(&scene, e, pipe, &masks, k.as_ref(), params.seed, a.input)?;
            fields.push(Some(field));
        }
        stages.push(json!({"name": "stress", "seconds": t.elapsed().as_secs_f64()}));
    }
    // Frames replay each mesh from its start.
    let starts = a.frames.as_ref().map(|_| entries.clone());
    let t = Instant::now();
    let show = !a.quiet && std::io::stderr().is_terminal();
    let mut total = SimReport::default();
    let mut per_mesh = Vec::new();
    for ((e, params), field) in entries.iter_mut().zip(&params_of).zip(&fields) {
        let bar = show.then(|| {
            let b = indicatif::ProgressBar::new(params.max_rounds as u64);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{prefix} [{bar:30}] round {pos}/{len} {msg}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b.set_prefix(e.label.clone());
            b
        });
        stage(&format!("simulate {}", e.label));
        let mut obs = Bar {
            bar,
            label: format!("{}: ", e.label),
            stage: a.on_stage.map(|f| (f, e.label.clone())),
        };
        let r = crackle::sim::run_with(&mut e.sim, params, field.as_ref(), &mut obs)
            .map_err(|err| anyhow::anyhow!("{}: {}: {err}", a.input.display(), e.label))?;
        if let Some(b) = obs.bar {
            b.finish_and_clear();
        }
        if r.cg_unconverged > 0 {
            log::warn!(
                "{}: {}: {} implicit solves stopped before reaching tolerance {}",
                a.input.display(),
                e.label,
                r.cg_unconverged,
                params.tolerance
            );
        }
        if r.dt_limited_rounds > 0 {
            log::warn!(
                "{}: {}: relax_dt {} is above the stable step ({:.3e}) in {} rounds; those rounds took stable steps over the same relaxation time",
                a.input.display(),
                e.label,
                params.relax_dt,
                r.stable_dt,
                r.dt_limited_rounds
            );
        }
        if r.substeps > 1 {
            log::warn!(
                "{}: {}: springs.dt {} is above the stable step ({:.3e}); each step was split into {} stable sub-steps",
                a.input.display(),
                e.label,
                params.springs.dt,
                r.stable_dt,
                r.substeps
            );
        }
        total.cracks += r.cracks;
        total.crack_length += r.crack_length;
        total.rounds = total.rounds.max(r.rounds);
        total.relax_steps += r.relax_steps;
        for k in 0..2 {
            total.triangles[k] += r.triangles[k];
            total.nodes[k] += r.nodes[k];
            total.energy[k] += r.energy[k];
        }
        per_mesh.push((e.mesh_index, r));
    }
    // Finishing runs inside the simulation; it is its own stage.
    let finish_seconds: f64 = per_mesh
        .iter()
        .filter_map(|(_, r)| r.finish.as_ref().map(|f| f.seconds))
        .sum();
    stages.push(json!({"name": "simulate", "seconds": t.elapsed().as_secs_f64() - finish_seconds}));
    if pipe.post.finish {
        stages.push(json!({"name": "finish", "seconds": finish_seconds}));
    }
    let template = a.frames.as_ref().map(|_| scene.clone());
    stage("post");
    let post = super::post::apply(&mut scene, &mut entries, &per_mesh, &pipe.post)?;
    for (name, seconds) in &post.stages {
        stages.push(json!({"name": name, "seconds": seconds}));
    }
    let t = Instant::now();
    stage("write");
    let summary = super::write_output(&scene, a.output, a.prefix_images)?;
    stages.push(json!({"name": "write", "seconds": t.elapsed().as_secs_f64()}));
    let mut frames_report = serde_json::Value::Null;
    if let (Some(frames), Some(starts), Some(template)) = (&a.frames, starts, template) {
        let t = Instant::now();
        let replays = starts
            .into_iter()
            .zip(&params_of)
            .zip(&fields)
            .zip(&per_mesh)
            .map(|(((start, params), field), (_, r))| super::frames::Replay {
                start,
                params,
                field: field.as_ref(),
                end_time: r.time,
            })
            .collect();
        let files = super::frames::write_frames(frames, a.output, &template, replays, &pipe.post)?;
        stages.push(json!({"name": "frames", "seconds": t.elapsed().as_secs_f64()}));
        frames_report = json!({
            "count": files.len(),
            "files": files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        });
    }
    let report = json!({
        "input": a.input.display().to_string(),
        "output": a.output.display().to_string(),
        "files": summary.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        "bytes": summary.bytes,
        "sources": scene.referenced_files().iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        "cracks": total.cracks,
        "crack_length": total.crack_length,
        "triangles": {"before": total.triangles[0], "after": total.triangles[1]},
        "nodes": {"before": total.nodes[0], "after": total.nodes[1]},
        "relaxation_steps": total.relax_steps,
        "rounds": total.rounds,
        "energy": {"start": total.energy[0], "end": total.energy[1]},
        "stages": stages,
        "meshes": per_mesh.iter().zip(&post.details).map(|((mi, r), d)| json!({"index": mi, "report": r, "post": d})).collect::<Vec<_>>(),
        "warnings": scene.warnings,
        "frames": frames_report,
    });
    Ok(report)
}

/// The stress field of simulation mesh `e` from the pipeline's terms:
/// world-space keys mapped through the mesh's first instance.
pub fn stress_field(
    scene: &Scene,
    e: &crackle::bridge::SimEntry,
    pipe: &Pipeline,
    masks: &[Option<std::sync::Arc<crackle::stress::texture::Mask>>],
    curvature: Option<&CurvatureField>,
    seed: u64,
    input: &Path,
) -> Result<StressField> {
    let bounds = Bounds::of(e.sim.vertices().map(|v| e.sim.position(v)));
    let place = if pipe.uses_world_space() {
        // World-space keys map into the mesh through its first instance;
        // the crack pattern is shared by every instance.
        let worlds = scene.mesh_world_matrices(e.mesh_index);
        if worlds.iter().skip(1).any(|w| w != &worlds[0]) {
            log::warn!(
                "{}: {} is instanced {} times with different transforms; world-space stress keys use its first instance",
                input.display(),
                e.label,
                worlds.len()
            );
        }
        match worlds.first() {
            Some(w) => Placement::new(bounds, w)
                .map_err(|m| anyhow::anyhow!("{}: {}: {m}", input.display(), e.label))?,
            None => Placement::local(bounds),
        }
    } else {
        Placement::local(bounds)
    };
    let terms = pipe
        .terms(&place, masks)
        .map_err(|m| super::UsageError(format!("stress: {m}")))?;
    StressField::build_with(&e.sim, &terms, seed, curvature)
        .map_err(|err| anyhow::anyhow!("{}: {}: {err}", input.display(), e.label))
}
