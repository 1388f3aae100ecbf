//! The run of one asset through a pipeline: weld, select, remesh to the
//! cell size, curvature, stress, simulate, post-process ([`run`]); and the
//! same from a file to a file ([`crack_file`]), which `crackle crack`,
//! `crackle batch` and `--frames` use.

use super::frames::{self, Frames, Replay};
use super::output::write_output;
use super::report::{
    BeforeAfter, CrackReport, FramesReport, MeshRun, Remeshed, RunReport, Stage, StartEnd,
};
use super::{Bounds, Pipeline, Placement};
use crate::bridge::{build_sim_meshes, SimEntry};
use crate::error::{FrameError, Uncrackable, UsageError};
use crate::geometry::curvature::CurvatureField;
use crate::mesh::remesh;
use crate::mesh::WeldOptions;
use crate::scene::Scene;
use crate::sim::{SimParams, SimReport};
use crate::stress::StressField;
use crate::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What one run does, besides the scene it works on.
#[derive(Clone, Debug)]
pub struct Config {
    /// The pipeline, checked, with its mask images loaded
    /// ([`Pipeline::load_images`]).
    pub pipeline: Pipeline,
    /// How input meshes are welded into simulation meshes.
    pub weld: WeldOptions,
    /// The asset's file: names it in messages; the textures of material
    /// masks must lie in its folder.
    pub asset: PathBuf,
    /// `--frames N DIR`: a time-lapse of the run, written as it is replayed.
    pub frames: Option<Frames>,
    /// Where the cracked scene will be written (frames are named after it).
    pub output: PathBuf,
    /// How the asset is read (the memory its decoded data may take).
    pub read: crate::io::ReadOptions,
}

/// Told what a run is doing, for progress displays. Every method has an
/// empty default.
pub trait Observer {
    /// A stage starts: `weld`, `remesh`, `curvature`, `stress`,
    /// `simulate <mesh>`, `post`.
    fn stage(&mut self, _name: &str) {}
    /// The simulation of `mesh` starts (at most `max_rounds` rounds).
    fn simulate_start(&mut self, _mesh: &str, _max_rounds: usize) {}
    /// A round of `mesh` ended.
    fn round(
        &mut self,
        _mesh: &str,
        _round: usize,
        _max_rounds: usize,
        _cracks: usize,
        _relax_steps: usize,
    ) {
    }
    /// The simulation of `mesh` ended.
    fn simulate_end(&mut self, _mesh: &str) {}
    /// Time-lapse frame `index` of `count` (asked for by
    /// [`Config::frames`]): the whole scene post-processed at that moment,
    /// handed over as soon as it is reached, so a run keeps no frame and
    /// writes none. [`crack_file`] writes each beside its output. The
    /// default refuses it: a run asked for frames by an observer that does
    /// not take them fails rather than losing them.
    ///
    /// # Errors
    /// Any error stops the run and is returned by it.
    fn frame(&mut self, index: usize, count: usize, _scene: &Scene) -> Result<()> {
        Err(FrameError::NotTaken { index, count }.into())
    }
}

impl Observer for () {}

/// Read an asset, log its warnings, and refuse it when nothing in it can
/// be cracked.
///
/// # Errors
/// The reader's errors, and [`Error::NothingToCrack`].
pub fn read_crackable(input: &Path, options: &crate::io::ReadOptions) -> Result<Scene> {
    let scene = crate::io::read_with(input, options)?;
    for w in &scene.warnings {
        log::warn!("{}: {w}", input.display());
    }
    if scene.triangle_count() == 0 {
        let why = if scene.warnings.is_empty() {
            Uncrackable::NoTriangleMesh
        } else {
            Uncrackable::Warnings {
                warnings: scene.warnings.clone(),
            }
        };
        return Err(Error::NothingToCrack {
            path: input.to_path_buf(),
            why,
        });
    }
    Ok(scene)
}

/// `model = "ductile"`: every simulated mesh torn ([`super::tear`]), with
/// the tear's border as crack lines when `post.lines` asks; the surface
/// models' other post-processing steps are refused by name.
fn tear_run(
    scene: &mut Scene,
    config: &Config,
    entries: &[SimEntry],
    params_of: &[SimParams],
    mut stages: Vec<Stage>,
    observer: &mut dyn Observer,
) -> Result<RunReport> {
    let input = config.asset.as_path();
    if params_of
        .iter()
        .any(|p| p.model != crate::sim::Model::Ductile)
    {
        return Err(UsageError::MixedModels {
            asset: input.to_path_buf(),
        }
        .into());
    }
    let post = &config.pipeline.post.within(config.read.max_memory);
    let surface_only: Vec<&str> = [
        ("finish", post.finish),
        ("width", post.width > 0.0),
        ("curl", post.curl > 0.0),
        ("walls", post.walls),
        ("groove", post.grooves()),
        ("attributes", post.attributes),
    ]
    .into_iter()
    .filter(|(_, on)| *on)
    .map(|(k, _)| k)
    .collect();
    if !surface_only.is_empty() {
        return Err(UsageError::DuctileSurfaceOnly {
            asset: input.to_path_buf(),
            keys: surface_only,
        }
        .into());
    }
    let t = Instant::now();
    observer.stage("tear");
    let before: usize = entries.iter().map(|e| e.sim.n_faces()).sum();
    let frames = config.frames.as_ref().map(|f| f.count);
    let (torn, frame_count) =
        super::tear::tear_meshes(scene, entries, params_of, input, frames, post, observer)?;
    let bake: f64 = torn
        .iter()
        .filter_map(|(_, v)| v.bake.as_ref().map(|b| b.seconds))
        .sum();
    stages.push(Stage::new("tear", t.elapsed().as_secs_f64() - bake));
    if post.bake {
        stages.push(Stage::new("bake", bake));
    }
    let after: usize = torn
        .iter()
        .map(|(_, v)| v.tear.as_ref().map_or(0, |t| t.triangles))
        .sum();
    Ok(RunReport {
        cracks: 0,
        crack_length: 0.0,
        triangles: BeforeAfter { before, after },
        nodes: BeforeAfter {
            before: 0,
            after: 0,
        },
        relaxation_steps: 0,
        rounds: 0,
        energy: StartEnd {
            start: 0.0,
            end: 0.0,
        },
        stages,
        meshes: torn
            .into_iter()
            .map(|(index, post)| MeshRun {
                index,
                report: SimReport::default(),
                post,
            })
            .collect(),
        warnings: scene.warnings.clone(),
        frames: config.frames.as_ref().map(|_| FramesReport {
            count: frame_count,
            files: Vec::new(),
        }),
    })
}

/// Read `config.asset`, crack it and write `config.output`; the report
/// names the files. Mask images are decoded before anything else, so a bad
/// image is refused before any work. `prefix_images` names a `.gltf`
/// output's images `<stem>_<name>` (a batch, where outputs share folders).
///
/// # Errors
/// Those of reading the asset, [`run`] and writing the output.
pub fn crack_file(
    mut config: Config,
    pipeline_dir: Option<&Path>,
    prefix_images: bool,
    observer: &mut dyn Observer,
) -> Result<CrackReport> {
    let t = Instant::now();
    let mut image_seconds = 0.0;
    if config.pipeline.has_masks() {
        config
            .pipeline
            .load_images_within(pipeline_dir, config.read.max_memory)?;
        image_seconds = t.elapsed().as_secs_f64();
    }
    let t = Instant::now();
    observer.stage("read");
    let mut scene = read_crackable(&config.asset, &config.read)?;
    let read = Stage::new("read", t.elapsed().as_secs_f64());
    let triangles_read = scene.triangle_count();
    // `run` post-processes `scene` in place and hands the frames to
    // `frames`, which writes them beside the output.
    let mut frames = FrameFiles {
        inner: observer,
        frames: config.frames.as_ref(),
        output: &config.output,
        written: Vec::new(),
    };
    if let Some(f) = frames.frames {
        std::fs::create_dir_all(&f.dir).map_err(|error| FrameError::Folder {
            dir: f.dir.clone(),
            error,
        })?;
    }
    let mut run = run(&mut scene, &config, &mut frames)?;
    let (observer, written) = (frames.inner, frames.written);
    if let Some(report) = &mut run.frames {
        report.files = written.iter().map(|f| f.display().to_string()).collect();
    }
    if let Some(s) = run.stages.iter_mut().find(|s| s.name == "texture") {
        s.seconds += image_seconds;
    }
    run.stages.insert(0, read);
    let t = Instant::now();
    observer.stage("write");
    let summary = write_output(&scene, &config.output, prefix_images)?;
    let write = Stage::new("write", t.elapsed().as_secs_f64());
    // `run` wrote the frames before this write; the report keeps listing
    // the write before the frames, as it always has.
    match run.stages.iter().position(|s| s.name == "frames") {
        Some(k) => run.stages.insert(k, write),
        None => run.stages.push(write),
    }
    Ok(CrackReport {
        input: config.asset.display().to_string(),
        output: config.output.display().to_string(),
        files: summary
            .files
            .iter()
            .map(|f| f.display().to_string())
            .collect(),
        bytes: summary.bytes,
        sources: scene
            .referenced_files()
            .iter()
            .map(|f| f.display().to_string())
            .collect(),
        mesh_triangles: BeforeAfter {
            before: triangles_read,
            after: scene.triangle_count(),
        },
        run,
    })
}

/// [`crack_file`]'s observer: passes everything on to the caller's and
/// writes each time-lapse frame as `Frames::path` names it.
struct FrameFiles<'a> {
    inner: &'a mut dyn Observer,
    frames: Option<&'a Frames>,
    output: &'a Path,
    written: Vec<std::path::PathBuf>,
}

impl Observer for FrameFiles<'_> {
    fn stage(&mut self, name: &str) {
        self.inner.stage(name);
    }
    fn simulate_start(&mut self, mesh: &str, max_rounds: usize) {
        self.inner.simulate_start(mesh, max_rounds);
    }
    fn round(
        &mut self,
        mesh: &str,
        round: usize,
        max_rounds: usize,
        cracks: usize,
        relax_steps: usize,
    ) {
        self.inner
            .round(mesh, round, max_rounds, cracks, relax_steps);
    }
    fn simulate_end(&mut self, mesh: &str) {
        self.inner.simulate_end(mesh);
    }
    fn frame(&mut self, index: usize, count: usize, scene: &Scene) -> Result<()> {
        let Some(frames) = self.frames else {
            return self.inner.frame(index, count, scene);
        };
        let path = frames.path(self.output, index);
        write_output(scene, &path, false)?;
        self.written.push(path);
        Ok(())
    }
}

/// The simulation meshes of a scene, ready to crack: welded, selected,
/// given their parameters, remeshed to the cell size, with their stress
/// fields ([`prepare`]).
pub struct Prepared {
    /// The simulation meshes.
    pub entries: Vec<SimEntry>,
    /// Each mesh's parameters.
    pub params: Vec<SimParams>,
    /// Each mesh's stress field (none without stress terms).
    pub fields: Vec<Option<StressField>>,
    /// The stages that ran (`texture`, `weld`, `remesh`, `curvature`,
    /// `stress`).
    pub stages: Vec<Stage>,
}

/// Everything [`run`] does before the simulation: mask textures, welding
/// and selection, each mesh's parameters, remeshing to the cell size,
/// curvature and stress. `crackle study` starts from here.
///
/// # Errors
/// [`Error::Usage`] for names the asset does not have, a bad mask or a
/// cell size over the triangle budget; a stage's error on a mesh.
pub fn prepare(scene: &Scene, config: &Config, observer: &mut dyn Observer) -> Result<Prepared> {
    let pipe = &config.pipeline;
    let input = config.asset.as_path();
    let mut stages = Vec::new();
    let masks = if pipe.has_masks() {
        let t = Instant::now();
        let asset_dir = input
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let masks = pipe
            .masks_for_within(scene, asset_dir, config.read.max_memory)
            .map_err(|e| Error::Config {
                asset: input.to_path_buf(),
                error: e.error,
            })?;
        stages.push(Stage::new("texture", t.elapsed().as_secs_f64()));
        masks
    } else {
        Vec::new()
    };
    let t = Instant::now();
    observer.stage("weld");
    let mut entries = select_meshes(scene, pipe, &config.weld, input)?;
    stages.push(Stage::new("weld", t.elapsed().as_secs_f64()));
    if pipe.post.bake {
        // The maps' textures by their headers, before any simulation.
        let meshes: Vec<usize> = entries.iter().map(|e| e.mesh_index).collect();
        super::bake::check_material_images(scene, &meshes, config.read.max_memory).map_err(
            |error| UsageError::BakeTexture {
                asset: input.to_path_buf(),
                error,
            },
        )?;
    }
    let mut params_of = super::params::mesh_params(scene, &entries, pipe, input)?;
    for (e, p) in entries.iter_mut().zip(&params_of) {
        e.along_edges = p.cracks_along_edges();
    }
    super::margin::grow(&mut entries, &mut params_of, &pipe.post, input)?;
    if let Some(stage) = remesh_to_cell_size(
        &mut entries,
        &params_of,
        pipe.post.cuts_input(),
        input,
        config.read.max_memory,
        observer,
    )? {
        stages.push(stage);
    }
    // Curvature: a stage only when a stress term uses it.
    let mut curvatures: Vec<Option<CurvatureField>> = vec![None; entries.len()];
    if pipe.needs_curvature() {
        let t = Instant::now();
        observer.stage("curvature");
        for (k, e) in curvatures.iter_mut().zip(&entries) {
            *k = Some(crate::stress::field::cell_curvature(&e.sim));
        }
        stages.push(Stage::new("curvature", t.elapsed().as_secs_f64()));
    }
    // Stress fields: a stage only when the pipeline has stress terms.
    let mut fields: Vec<Option<StressField>> = Vec::new();
    if pipe.stress.is_empty() {
        fields.resize(entries.len(), None);
    } else {
        let t = Instant::now();
        observer.stage("stress");
        for ((e, params), k) in entries.iter().zip(&params_of).zip(&curvatures) {
            let field = stress_field(scene, e, pipe, &masks, k.as_ref(), params.seed, input)?;
            fields.push(Some(field));
        }
        stages.push(Stage::new("stress", t.elapsed().as_secs_f64()));
    }
    Ok(Prepared {
        entries,
        params: params_of,
        fields,
        stages,
    })
}

/// Crack every crackable mesh of `scene` as `config` says and write the
/// results back into it (post-processed, with crack lines and attributes
/// as the pipeline asks). The pipeline's mask images must be loaded.
///
/// # Errors
/// [`Error::Usage`] for a request the input cannot meet (a mesh or group
/// name it does not have, a cell size above the triangle budget, a bad
/// mask), [`Error::Mesh`] when a stage fails on a mesh.
pub fn run(scene: &mut Scene, config: &Config, observer: &mut dyn Observer) -> Result<RunReport> {
    let pipe = &config.pipeline;
    let input = config.asset.as_path();
    if !pipe.post.keeps_input() {
        super::attributes::add_missing_tangents(scene);
    }
    let Prepared {
        mut entries,
        params: params_of,
        fields,
        mut stages,
    } = prepare(scene, config, observer)?;
    frames::refuse_cycles(config.frames.as_ref(), &params_of, input)?;
    if params_of
        .iter()
        .any(|p| p.model == crate::sim::Model::Ductile)
    {
        return tear_run(scene, config, &entries, &params_of, stages, observer);
    }
    // Frames replay each mesh from its start.
    let starts = config.frames.as_ref().map(|_| entries.clone());
    let t = Instant::now();
    let mut per_mesh = simulate(&mut entries, &params_of, &fields, input, observer)?;
    super::margin::clip(&entries, &mut per_mesh);
    // Finishing runs inside the simulation; it is its own stage.
    let finish_seconds: f64 = per_mesh
        .iter()
        .filter_map(|(_, r)| r.finish.as_ref().map(|f| f.seconds))
        .sum();
    stages.push(Stage::new(
        "simulate",
        t.elapsed().as_secs_f64() - finish_seconds,
    ));
    if pipe.post.finish {
        stages.push(Stage::new("finish", finish_seconds));
    }
    let template = config.frames.as_ref().map(|_| scene.clone());
    observer.stage("post");
    let post_options = pipe.post.within(config.read.max_memory);
    let post = super::post::apply(scene, &mut entries, &per_mesh, &post_options)?;
    for &(name, seconds, peak) in &post.stages {
        stages.push(Stage {
            peak_resident_bytes: peak,
            ..Stage::new(name, seconds)
        });
    }
    let mut frames_report = None;
    if let (Some(frames), Some(starts), Some(template)) = (&config.frames, starts, template) {
        let t = Instant::now();
        let replays = starts
            .into_iter()
            .zip(&params_of)
            .zip(&fields)
            .zip(&per_mesh)
            .map(|(((start, params), field), (_, r))| Replay {
                start,
                params,
                field: field.as_ref(),
                end_time: r.time,
            })
            .collect();
        let count =
            frames::replay_frames(frames.count, &template, replays, &post_options, observer)?;
        stages.push(Stage::new("frames", t.elapsed().as_secs_f64()));
        frames_report = Some(FramesReport {
            count,
            files: Vec::new(),
        });
    }
    let mut total = SimReport::default();
    for (_, r) in &per_mesh {
        total.cracks += r.cracks;
        total.crack_length += r.crack_length;
        total.rounds = total.rounds.max(r.rounds);
        total.relax_steps += r.relax_steps;
        for k in 0..2 {
            total.triangles[k] += r.triangles[k];
            total.nodes[k] += r.nodes[k];
            total.energy[k] += r.energy[k];
        }
    }
    Ok(RunReport {
        cracks: total.cracks,
        crack_length: total.crack_length,
        triangles: BeforeAfter {
            before: total.triangles[0],
            after: total.triangles[1],
        },
        nodes: BeforeAfter {
            before: total.nodes[0],
            after: total.nodes[1],
        },
        relaxation_steps: total.relax_steps,
        rounds: total.rounds,
        energy: StartEnd {
            start: total.energy[0],
            end: total.energy[1],
        },
        stages,
        meshes: per_mesh
            .into_iter()
            .zip(post.details)
            .map(|((index, report), post)| MeshRun {
                index,
                report,
                post,
            })
            .collect(),
        warnings: scene.warnings.clone(),
        frames: frames_report,
    })
}

/// The simulation meshes of `scene`: every crackable mesh, welded, or
/// those `select.meshes` names.
fn select_meshes(
    scene: &Scene,
    pipe: &Pipeline,
    weld: &WeldOptions,
    input: &Path,
) -> Result<Vec<SimEntry>> {
    let (mut entries, skipped) = build_sim_meshes(scene, weld);
    for s in &skipped {
        log::warn!(
            "{}: {} is written unchanged: {}",
            input.display(),
            s.label,
            s.reason
        );
    }
    if !pipe.select.meshes.is_empty() {
        let name_of = |i: usize| scene.meshes[i].name.clone().unwrap_or_default();
        if let Some(missing) = pipe
            .select
            .meshes
            .iter()
            .find(|n| !entries.iter().any(|e| &name_of(e.mesh_index) == *n))
        {
            return Err(UsageError::NoMesh {
                asset: input.to_path_buf(),
                name: missing.clone(),
                meshes: entries.iter().map(|e| name_of(e.mesh_index)).collect(),
            }
            .into());
        }
        entries.retain(|e| pipe.select.meshes.contains(&name_of(e.mesh_index)));
    }
    Ok(entries)
}

/// Memory a run takes per triangle of the simulation surface, about
/// (measured peaks: 20 one-triangle objects simulated on 334,000 triangles
/// under `glaze` in 300 MB; a 2,000-triangle non-manifold fan on 1.64
/// million under `mud` in 1.78 GB; 100 objects on 1.67 million in 694 MB).
const SIM_TRIANGLE_BYTES: u64 = 1024;

/// What the film's multigrid preconditioner adds per simulated triangle,
/// about (its hierarchy: measured peaks 2.58 GB with Jacobi, 3.15 GB with
/// multigrid, on the teapot's 1.88 million under `glaze`).
const MULTIGRID_TRIANGLE_BYTES: u64 = 320;

/// Memory a run takes per simulated triangle under `params`.
fn triangle_bytes(params: &SimParams) -> u64 {
    let multigrid = params.film_preconditioner == crate::sim::FilmPreconditioner::Multigrid;
    SIM_TRIANGLE_BYTES
        + if multigrid {
            MULTIGRID_TRIANGLE_BYTES
        } else {
            0
        }
}

/// Isotropic remeshing to the cell size: a stage only when a pipeline asks
/// for a cell size. Every budget is checked before any work. With
/// `keep_input` each remeshed entry keeps its input mesh (`unremeshed`).
fn remesh_to_cell_size(
    entries: &mut [SimEntry],
    params_of: &[SimParams],
    keep_input: bool,
    input: &Path,
    max_memory: u64,
    observer: &mut dyn Observer,
) -> Result<Option<Stage>> {
    if !entries
        .iter()
        .zip(params_of)
        .any(|(e, p)| p.isotropic_remesh && p.cell_size_for(&e.sim).is_some())
    {
        return Ok(None);
    }
    let t = Instant::now();
    observer.stage("remesh");
    let mut plans = Vec::new();
    let (mut total, mut need): (u64, u64) = (0, 0);
    for (e, p) in entries.iter().zip(params_of) {
        let plan = p
            .cell_size_for(&e.sim)
            .filter(|_| p.isotropic_remesh)
            .map(|cell| cell / crate::sim::film::EDGES_PER_CELL);
        if let Some(target) = plan {
            let estimate = remesh::estimate_triangles(&e.sim, target);
            if estimate > p.max_triangles {
                return Err(UsageError::CellTooSmall {
                    asset: input.to_path_buf(),
                    mesh: e.label.clone(),
                    cell: target * crate::sim::film::EDGES_PER_CELL,
                    edge: target,
                    triangles: estimate,
                    max_triangles: p.max_triangles,
                }
                .into());
            }
            total += estimate as u64;
            need = need.saturating_add((estimate as u64).saturating_mul(triangle_bytes(p)));
        }
        plans.push(plan);
    }
    // Every mesh's simulation surface together, within the memory budget
    // (many small objects each remeshed to a cell size relative to its own
    // size made a 5 MB OBJ ask for billions of triangles).
    if need > max_memory {
        return Err(UsageError::OverMemory {
            asset: input.to_path_buf(),
            meshes: entries.len(),
            triangles: total,
            bytes_per_triangle: need / total.max(1),
            budget: max_memory,
        }
        .into());
    }
    let mut meshes = Vec::new();
    for ((e, p), plan) in entries.iter_mut().zip(params_of).zip(plans) {
        let Some(target) = plan else { continue };
        let options = remesh::RemeshOptions {
            target_edge: target,
            coarsen: p.coarsen,
            seed: p.seed,
            ..Default::default()
        };
        let (sim, r) = remesh::remesh(&e.sim, &options)
            .map_err(|err| Error::mesh(input, &e.label, format!("remeshing: {err}")))?;
        let before = std::mem::replace(&mut e.sim, sim);
        if keep_input {
            e.unremeshed = Some(e.unextended.as_ref().map_or(before, |u| u.input.clone()));
        }
        meshes.push(Remeshed {
            mesh: e.label.clone(),
            target_edge: target,
            report: r,
        });
    }
    Ok(Some(Stage {
        meshes: Some(meshes),
        ..Stage::new("remesh", t.elapsed().as_secs_f64())
    }))
}

/// Passes a mesh's rounds on to the run's observer with the mesh's label.
struct MeshObserver<'a> {
    observer: &'a mut dyn Observer,
    label: &'a str,
}

impl crate::sim::Observer for MeshObserver<'_> {
    fn round(&mut self, round: usize, max_rounds: usize, cracks: usize, relax_steps: usize) {
        self.observer
            .round(self.label, round, max_rounds, cracks, relax_steps);
    }
}

/// Simulate every mesh; each mesh's index in the scene and report.
fn simulate(
    entries: &mut [SimEntry],
    params_of: &[SimParams],
    fields: &[Option<StressField>],
    input: &Path,
    observer: &mut dyn Observer,
) -> Result<Vec<(usize, SimReport)>> {
    let mut per_mesh = Vec::new();
    for ((e, params), field) in entries.iter_mut().zip(params_of).zip(fields) {
        observer.stage(&format!("simulate {}", e.label));
        observer.simulate_start(&e.label, params.max_rounds);
        let mut obs = MeshObserver {
            observer: &mut *observer,
            label: &e.label,
        };
        let r = crate::sim::run_with(&mut e.sim, params, field.as_ref(), &mut obs)
            .map_err(|err| Error::mesh(input, &e.label, err))?;
        observer.simulate_end(&e.label);
        if r.cg_unconverged > 0 {
            log::warn!(
                "{}: {}: {} implicit solves stopped before reaching tolerance {}",
                input.display(),
                e.label,
                r.cg_unconverged,
                params.tolerance
            );
        }
        if r.dt_limited_rounds > 0 {
            log::warn!(
                "{}: {}: relax_dt {} is above the stable step ({:.3e}) in {} rounds; those rounds took stable steps over the same relaxation time",
                input.display(),
                e.label,
                params.relax_dt,
                r.stable_dt,
                r.dt_limited_rounds
            );
        }
        if r.substeps > 1 {
            log::warn!(
                "{}: {}: springs.dt {} is above the stable step ({:.3e}); each step was split into {} stable sub-steps",
                input.display(),
                e.label,
                params.springs.dt,
                r.stable_dt,
                r.substeps
            );
        }
        if r.cracks == 0 {
            warn_no_crack(input, &e.label, field.as_ref());
        }
        per_mesh.push((e.mesh_index, r));
    }
    Ok(per_mesh)
}

/// Say why a mesh came back uncracked: a field that scales the material's
/// cracking down everywhere (a flat surface under the curvature term, a
/// confining mask that is white all over), or a load below the toughness.
fn warn_no_crack(input: &Path, label: &str, field: Option<&StressField>) {
    let most = field
        .filter(|f| !f.separation_scale.is_empty())
        .map(|f| f.separation_scale.iter().copied().fold(0.0, f64::max));
    match most {
        Some(m) if m < 0.5 => log::warn!(
            "{}: {label}: no crack formed: the stress field lets the material crack at most {m:.2} of its full measure anywhere (the curvature term on a surface flat at the cell size's scale, or a confining mask white all over)",
            input.display()
        ),
        _ => log::warn!(
            "{}: {label}: no crack formed: the stress stayed below the toughness everywhere (raise the load, or lower simulation.toughness; for the spring model, simulation.springs.break_strain)",
            input.display()
        ),
    }
}

/// The stress field of simulation mesh `e` from the pipeline's terms:
/// world-space keys mapped through the mesh's first instance.
///
/// # Errors
/// [`Error::Usage`] for a term the mesh cannot take, [`Error::Mesh`] when
/// the field cannot be built.
pub fn stress_field(
    scene: &Scene,
    e: &SimEntry,
    pipe: &Pipeline,
    masks: &[Option<std::sync::Arc<crate::stress::texture::Mask>>],
    curvature: Option<&CurvatureField>,
    seed: u64,
    input: &Path,
) -> Result<StressField> {
    let own = e.unextended.as_ref().map_or(&e.sim, |u| &u.input); // the input's box
    let bounds = Bounds::of(own.vertices().map(|v| own.position(v)));
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
            Some(w) => Placement::new(bounds, w).ok_or_else(|| {
                Error::mesh(
                    input,
                    &e.label,
                    "the mesh's world transform is not invertible (a zero scale?)",
                )
            })?,
            None => Placement::local(bounds),
        }
    } else {
        Placement::local(bounds)
    };
    let terms = pipe
        .terms(&place, masks)
        .map_err(|e| UsageError::Stress { error: e.error })?;
    let field = StressField::build_with(&e.sim, &terms, seed, curvature)
        .map_err(|err| Error::mesh(input, &e.label, err))?;
    for i in &field.projected_masks {
        log::warn!(
            "{}: the mesh has no UVs: stress term {i}'s mask is projected along the three axes over the mesh's box",
            e.label
        );
    }
    Ok(field)
}
