//! Errors of a run: a request this input cannot meet ([`UsageError`]), the
//! time-lapse frames that cannot be made or written ([`FrameError`]), and
//! why an asset has nothing to crack ([`Uncrackable`]).

use super::ConfigError;
use crate::sim::SimError;
use crate::stress::texture::TextureError;
use std::path::PathBuf;

/// What was asked cannot be done with this input or these options; the
/// message names the input and the key or option.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum UsageError {
    /// A ductile run with meshes of another model.
    #[error("{}: model = \"ductile\" must be every simulated mesh's model in one run", asset.display())]
    MixedModels {
        /// The asset.
        asset: PathBuf,
    },
    /// A ductile run asked for surface-only post-processing.
    #[error("{}: model = \"ductile\" has no post.{} (its output is the torn solid, each piece its own node, with post.lines and post.bake for the tear's border)", asset.display(), keys.join(", post."))]
    DuctileSurfaceOnly {
        /// The asset.
        asset: PathBuf,
        /// The `post` keys asked for.
        keys: Vec<&'static str>,
    },
    /// Frames of a ductile run that tears more than one mesh.
    #[error("{}: --frames with model = \"ductile\" follows one torn mesh; this run tears {meshes} (select one with select.meshes)", asset.display())]
    DuctileFramesMeshes {
        /// The asset.
        asset: PathBuf,
        /// How many meshes the run tears.
        meshes: usize,
    },
    /// Frames of a run that ages its cracks over several cycles.
    #[error("{}: --frames shows one drying; simulation.cycles = {cycles} ages its cracks after it, which has no frames (leave out --frames or use cycles = 1)", asset.display())]
    FramesWithCycles {
        /// The asset.
        asset: PathBuf,
        /// The cycles asked for.
        cycles: usize,
    },
    /// A material's texture the bake cannot use.
    #[error("{}: {error}", asset.display())]
    BakeTexture {
        /// The asset.
        asset: PathBuf,
        /// Why the texture cannot be used.
        error: TextureError,
    },
    /// `select.meshes` names a mesh the asset does not have.
    #[error("select.meshes: {} has no crackable mesh named '{name}' (meshes: {})", asset.display(), meshes.join(", "))]
    NoMesh {
        /// The asset.
        asset: PathBuf,
        /// The name asked for.
        name: String,
        /// The crackable meshes' names.
        meshes: Vec<String>,
    },
    /// `--fix` names no material or group of the asset.
    #[error("--fix {name}: no crackable primitive of {} has that material or group name (names: {})", asset.display(), names.join(", "))]
    NoFixName {
        /// The name asked for.
        name: String,
        /// The asset.
        asset: PathBuf,
        /// The asset's material and group names.
        names: Vec<String>,
    },
    /// A cell size whose remeshed surface would exceed the triangle budget.
    #[error("{}: {mesh}: a cell size of {cell:.6} (edges of {edge:.6}) needs about {triangles} triangles, above simulation.max_triangles = {max_triangles}; ask for a larger cell size or raise max_triangles", asset.display())]
    CellTooSmall {
        /// The asset.
        asset: PathBuf,
        /// The mesh's label.
        mesh: String,
        /// The cell size.
        cell: f64,
        /// The target edge length.
        edge: f64,
        /// The triangles it would take, about.
        triangles: usize,
        /// `simulation.max_triangles`.
        max_triangles: usize,
    },
    /// Simulation surfaces that together exceed the memory budget.
    #[error("{}: the simulation surface{} of {meshes} mesh{} need{} about {triangles} triangles, about {} MiB at {bytes_per_triangle} bytes each, more than the memory budget of {} MiB (--max-memory); ask for a larger cell size or raise --max-memory",
        asset.display(),
        if *meshes == 1 { "" } else { "s" },
        if *meshes == 1 { "" } else { "es" },
        if *meshes == 1 { "s" } else { "" },
        triangles.saturating_mul(*bytes_per_triangle) >> 20,
        budget >> 20)]
    OverMemory {
        /// The asset.
        asset: PathBuf,
        /// How many meshes are simulated.
        meshes: usize,
        /// Their triangles together, about.
        triangles: u64,
        /// Memory a triangle takes, about.
        bytes_per_triangle: u64,
        /// The memory budget in bytes.
        budget: u64,
    },
    /// The stress terms cannot be made for this mesh.
    #[error("stress: {error}")]
    Stress {
        /// What is wrong, naming the key.
        error: Box<ConfigError>,
    },
    /// A comparison tolerance that is not a finite number >= 0.
    #[error("--tolerance {tolerance} must be a finite number >= 0")]
    Tolerance {
        /// The tolerance given.
        tolerance: f64,
    },
}

/// The time-lapse frames could not be made or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FrameError {
    /// The run's observer does not take frames.
    #[error("frame {index} of {count}: this observer does not take time-lapse frames (implement Observer::frame, or use crack_file, which writes them)")]
    NotTaken {
        /// The frame.
        index: usize,
        /// How many frames there are.
        count: usize,
    },
    /// The frames' folder cannot be made.
    #[error("{}: cannot create the frames folder: {error}", dir.display())]
    Folder {
        /// The folder.
        dir: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// The replay of a mesh's simulation failed.
    #[error("{mesh}: frames: {error}")]
    Replay {
        /// The mesh's label.
        mesh: String,
        /// The simulation's error.
        error: SimError,
    },
    /// The replay of a mesh's simulation reached too few frames.
    #[error("{mesh}: frames: the replay reached {reached} of {count} frames")]
    Short {
        /// The mesh's label.
        mesh: String,
        /// The frames it reached.
        reached: usize,
        /// The frames asked for.
        count: usize,
    },
}

/// Why an asset has nothing to crack.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Uncrackable {
    /// The asset has no triangle mesh.
    #[error("it has no triangle mesh")]
    NoTriangleMesh,
    /// The reader skipped what the asset has, saying why.
    #[error("{}", warnings.join("; "))]
    Warnings {
        /// The reader's warnings.
        warnings: Vec<String>,
    },
    /// No mesh of the asset can be simulated.
    #[error("no crackable mesh")]
    NoCrackableMesh,
}
