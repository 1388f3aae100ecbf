//! `--frames N DIR`: a time-lapse of the crack state through the run, like
//! the drying-mud animation of Iben & O'Brien (2009).
//!
//! The run is deterministic, so the frames come from a second run of each
//! mesh from the same start: knowing how long the first run took, the
//! observer keeps the state at `N` evenly spaced times, from the uncracked
//! mesh (time 0) to the end (the state written as the output). Each frame is
//! then post-processed with the pipeline's `[post]` steps (width, walls and
//! curling from the displacement reached by then, lines and attributes,
//! crack times as fractions of the whole run) and handed to the run's
//! observer ([`super::Observer::frame`]); [`super::crack_file`] writes each
//! as `DIR/<output stem>_<k>.<ext>`, `k` zero-padded from 0. With one
//! simulated mesh each frame is handed over as soon as it is reached; with
//! several, the states are kept (full copies of the meshes) until all
//! meshes reached them, so memory grows with `N`.

use super::Post;
use crate::bridge::SimEntry;
pub use crate::error::FramesError;
use crate::error::{FrameError, UsageError};
use crate::mesh::SimMesh;
use crate::scene::Scene;
use crate::sim::{Observer, SimParams, SimReport, Snapshot};
use crate::stress::StressField;
use std::path::{Path, PathBuf};

/// One kept state.
struct Kept {
    mesh: SimMesh,
    report: SimReport,
}

/// Where a reached frame goes.
type Sink<'a> = dyn FnMut(usize, Kept) -> crate::Result<()> + 'a;

/// Keeps the state at each target time, or hands it to a sink at once.
struct Keeper<'a> {
    targets: Vec<f64>,
    /// Frames reached so far.
    count: usize,
    kept: Vec<Kept>,
    sink: Option<&'a mut Sink<'a>>,
    error: Option<crate::Error>,
}

impl Observer for Keeper<'_> {
    fn wants_state(&self) -> bool {
        self.count < self.targets.len() && self.error.is_none()
    }

    fn state(&mut self, s: &Snapshot) {
        let end = *self.targets.last().unwrap_or(&0.0);
        let slack = 1e-9 * end.abs().max(1.0);
        while self.count < self.targets.len() && self.targets[self.count] <= s.time + slack {
            let kept = Kept {
                mesh: s.mesh.clone(),
                report: SimReport {
                    time: s.time,
                    displacement: s.displacement.to_vec(),
                    crack_time: s.crack_time.to_vec(),
                    segments: s.segments.to_vec(),
                    segment_times: s.segment_times.to_vec(),
                    ..Default::default()
                },
            };
            match self.sink.as_mut() {
                Some(sink) => {
                    if let Err(e) = sink(self.count, kept) {
                        self.error = Some(e);
                        return;
                    }
                }
                None => self.kept.push(kept),
            }
            self.count += 1;
        }
    }
}

/// The `--frames` request, checked.
#[derive(Clone, Debug)]
pub struct Frames {
    /// How many frames, from the uncracked mesh to the end (2..=10000).
    pub count: usize,
    /// The folder they go in.
    pub dir: PathBuf,
}

impl Frames {
    /// From the two command-line values `N DIR`.
    ///
    /// # Errors
    /// [`crate::Error::FramesRequest`] naming the bad value.
    pub fn parse(values: &[String]) -> crate::Result<Self> {
        let [n, dir] = values else {
            return Err(FramesError::Values.into());
        };
        let count: usize = n
            .parse()
            .map_err(|_| FramesError::NotNumber { value: n.clone() })?;
        if !(2..=10_000).contains(&count) {
            return Err(FramesError::Count { count }.into());
        }
        let dir = PathBuf::from(dir);
        if dir.exists() && !dir.is_dir() {
            return Err(FramesError::NotFolder { dir }.into());
        }
        Ok(Frames { count, dir })
    }

    /// File of frame `k` for output `output`.
    pub fn path(&self, output: &Path, k: usize) -> PathBuf {
        let stem = output
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "frame".into());
        let ext = output
            .extension()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "glb".into());
        let width = (self.count - 1).to_string().len().max(4);
        self.dir.join(format!("{stem}_{k:0width$}.{ext}"))
    }
}

/// One mesh to replay: its start state, parameters, stress field and how
/// long its first run took.
pub struct Replay<'a> {
    /// The mesh as the simulation started from it.
    pub start: SimEntry,
    /// Its parameters.
    pub params: &'a SimParams,
    /// Its stress field.
    pub field: Option<&'a StressField>,
    /// The time its first run ended at.
    pub end_time: f64,
}

/// `--frames` show one drying: refused up front when a mesh dries more
/// than once (`simulation.cycles`), whose later cycles have no frames.
///
/// # Errors
/// [`UsageError::FramesWithCycles`] naming the input.
pub fn refuse_cycles(
    frames: Option<&Frames>,
    params: &[SimParams],
    input: &Path,
) -> crate::Result<()> {
    match params.iter().find(|p| p.cycles > 1) {
        Some(p) if frames.is_some() => Err(UsageError::FramesWithCycles {
            asset: input.to_path_buf(),
            cycles: p.cycles,
        }
        .into()),
        _ => Ok(()),
    }
}

/// Replay every mesh, post-process each of `n` frames on a copy of `scene`
/// (the scene before post-processing) and hand it to `observer`. Returns
/// how many it took.
pub fn replay_frames(
    n: usize,
    scene: &Scene,
    replays: Vec<Replay>,
    post: &Post,
    observer: &mut dyn super::Observer,
) -> crate::Result<usize> {
    // Frames carry the cracks as lines and attributes: a 2048 bake per
    // frame would cost more than the rest of the frame.
    let post = &Post {
        bake: false,
        ..post.clone()
    };
    let targets =
        |end: f64| -> Vec<f64> { (0..n).map(|k| end * k as f64 / (n - 1) as f64).collect() };
    // The replay is the first run again, so it reaches every target (the
    // last at its final time); anything else is a bug, not a short frame set.
    let short = |label: &str, reached: usize| {
        crate::Error::from(FrameError::Short {
            mesh: label.to_string(),
            reached,
            count: n,
        })
    };
    // One simulated mesh: each frame is handed over as soon as it is
    // reached, so memory does not grow with N.
    if replays.len() == 1 {
        let r = replays.into_iter().next().unwrap_or_else(|| unreachable!());
        let mut entry = r.start;
        let template = entry.clone();
        let end = r.end_time;
        let mut write = |k: usize, kept: Kept| -> crate::Result<()> {
            let frame = frame_scene(scene, vec![(&template, end, kept)], post)?;
            observer.frame(k, n, &frame)
        };
        let mut keeper = Keeper {
            targets: targets(end),
            count: 0,
            kept: Vec::new(),
            sink: Some(&mut write),
            error: None,
        };
        crate::sim::run_with(&mut entry.sim, r.params, r.field, &mut keeper).map_err(|error| {
            FrameError::Replay {
                mesh: entry.label.clone(),
                error,
            }
        })?;
        if let Some(e) = keeper.error {
            return Err(e);
        }
        if keeper.count < n {
            return Err(short(&entry.label, keeper.count));
        }
        return Ok(n);
    }
    let mut per_mesh: Vec<(SimEntry, f64, std::vec::IntoIter<Kept>)> = Vec::new();
    for r in replays {
        let mut keeper = Keeper {
            targets: targets(r.end_time),
            count: 0,
            kept: Vec::new(),
            sink: None,
            error: None,
        };
        let mut entry = r.start;
        crate::sim::run_with(&mut entry.sim, r.params, r.field, &mut keeper).map_err(|error| {
            FrameError::Replay {
                mesh: entry.label.clone(),
                error,
            }
        })?;
        if keeper.count < n {
            return Err(short(&entry.label, keeper.count));
        }
        per_mesh.push((entry, r.end_time, keeper.kept.into_iter()));
    }
    for k in 0..n {
        let states = per_mesh
            .iter_mut()
            .filter_map(|(entry, end, kept)| kept.next().map(|s| (&*entry, *end, s)))
            .collect();
        observer.frame(k, n, &frame_scene(scene, states, post)?)?;
    }
    Ok(n)
}

/// Post-process kept states `(mesh entry, end time of its run, state)` on
/// a copy of `scene`.
fn frame_scene(
    scene: &Scene,
    states: Vec<(&SimEntry, f64, Kept)>,
    post: &Post,
) -> crate::Result<Scene> {
    let mut scene_k = scene.clone();
    let mut entries: Vec<SimEntry> = Vec::new();
    let mut reports: Vec<(usize, SimReport)> = Vec::new();
    for (entry, end, kept) in states {
        let mut e = entry.clone();
        e.sim = kept.mesh;
        let mut r = kept.report;
        // Crack times are fractions of the whole run.
        r.time = end;
        reports.push((e.mesh_index, r));
        entries.push(e);
    }
    super::margin::clip(&entries, &mut reports);
    super::post::apply(&mut scene_k, &mut entries, &reports, post)?;
    Ok(scene_k)
}
