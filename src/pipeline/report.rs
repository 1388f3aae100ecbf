//! What a run reports: its stages and their times, each simulated mesh's
//! report, and what [`super::crack_file`] wrote.

use super::post_report::PostReport;
use crate::mesh::remesh::RemeshReport;
use crate::sim::SimReport;
use serde::Serialize;

/// One stage of a run and its time.
#[derive(Clone, Debug, Serialize)]
pub struct Stage {
    /// `read`, `texture`, `weld`, `remesh`, `curvature`, `stress`,
    /// `simulate`, `finish`, a post stage, `write`, `frames`.
    pub name: String,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// `remesh`: what it did to each mesh.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub meshes: Option<Vec<Remeshed>>,
    /// The process's peak resident memory when the stage ended, bytes
    /// (`getrusage`; it only grows from one stage to the next).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_resident_bytes: Option<u64>,
}

impl Stage {
    pub(super) fn new(name: &str, seconds: f64) -> Stage {
        Stage {
            name: name.to_string(),
            seconds,
            meshes: None,
            peak_resident_bytes: super::memory::peak_resident_bytes(),
        }
    }
}

/// What remeshing did to one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct Remeshed {
    /// The mesh's label.
    pub mesh: String,
    /// The edge length asked for (scene units).
    pub target_edge: f64,
    /// What the remesher did.
    pub report: RemeshReport,
}

/// A count before and after the run.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct BeforeAfter<T> {
    /// Before.
    pub before: T,
    /// After.
    pub after: T,
}

/// Energy at the start and the end.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct StartEnd {
    /// At the start.
    pub start: f64,
    /// At the end.
    pub end: f64,
}

/// One simulated mesh's part of a run.
#[derive(Clone, Debug, Serialize)]
pub struct MeshRun {
    /// Index of the mesh in the scene.
    pub index: usize,
    /// The simulation's report.
    pub report: SimReport,
    /// What each post stage did to it.
    pub post: PostReport,
}

/// The time-lapse frames a run wrote.
#[derive(Clone, Debug, Serialize)]
pub struct FramesReport {
    /// How many.
    pub count: usize,
    /// The files, in time order.
    pub files: Vec<String>,
}

/// What a run did: totals over its meshes, its stages and each mesh.
#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    /// Crack events.
    pub cracks: usize,
    /// Total crack length (scene units).
    pub crack_length: f64,
    /// Triangles of the simulation meshes.
    pub triangles: BeforeAfter<usize>,
    /// Nodes of the simulation meshes.
    pub nodes: BeforeAfter<usize>,
    /// Relaxation steps.
    pub relaxation_steps: usize,
    /// Rounds of the longest mesh.
    pub rounds: usize,
    /// Stress energy.
    pub energy: StartEnd,
    /// The stages that ran, in order.
    pub stages: Vec<Stage>,
    /// Each simulated mesh.
    pub meshes: Vec<MeshRun>,
    /// The reader's warnings about the scene.
    pub warnings: Vec<String>,
    /// The frames written, when asked.
    pub frames: Option<FramesReport>,
}

impl RunReport {
    /// Pieces the run's meshes came apart into: the ductile model's torn
    /// pieces and `split_islands`' pieces, summed over meshes (`None` when
    /// no mesh was torn or split).
    pub fn pieces(&self) -> Option<usize> {
        let of = |m: &MeshRun| {
            let torn = m.post.tear.as_ref().map(|t| t.pieces);
            torn.or_else(|| m.post.islands.as_ref().map(|i| i.pieces))
        };
        let counts: Vec<usize> = self.meshes.iter().filter_map(of).collect();
        (!counts.is_empty()).then(|| counts.iter().sum())
    }

    /// Area of the ductile model's torn faces, summed over meshes (scene
    /// units squared; `None` when no mesh was torn).
    pub fn torn_area(&self) -> Option<f64> {
        let areas: Vec<f64> = self
            .meshes
            .iter()
            .filter_map(|m| m.post.tear.as_ref().map(|t| t.torn_area))
            .collect();
        (!areas.is_empty()).then(|| areas.iter().sum())
    }
}

/// What [`super::crack_file`] did: the files, then the run.
#[derive(Clone, Debug, Serialize)]
pub struct CrackReport {
    /// The input file.
    pub input: String,
    /// The output file.
    pub output: String,
    /// Every file written (the main file first).
    pub files: Vec<String>,
    /// Bytes written.
    pub bytes: u64,
    /// The files the input refers to (buffers, images, material libraries).
    pub sources: Vec<String>,
    /// Triangles of the scene's meshes as read and as written (the
    /// simulation's own are `triangles`).
    pub mesh_triangles: BeforeAfter<usize>,
    /// The run.
    #[serde(flatten)]
    pub run: RunReport,
}
