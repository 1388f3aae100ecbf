//! The crate's error: every layer's error converts into it (`From`), and
//! the run adds its own (what was asked cannot be done, a stage failed on
//! a mesh). It sits in the top layer of the library, beside `pipeline`
//! (ARCHITECTURE.md); [`PipelineError`] is defined here and re-exported by
//! `pipeline`.

pub use crate::io::IoError;
pub use crate::mesh::MeshError;
pub use crate::sim::SimError;
pub use crate::stress::texture::TextureError;
use std::path::PathBuf;

mod batch;
mod config;
mod run;
pub use batch::{BatchError, InputsError, RuleError, RulesError};
pub use config::{
    ConfigError, EntryError, FramesError, MaskImageError, MaskMaterialError, SetError,
};
pub use run::{FrameError, Uncrackable, UsageError};

// What the layers' errors carry, so that a caller can name and match every
// fault: the files' and elements' faults of reading and writing, the mesh's
// broken invariants and refused edits (with the ids they name), the
// simulation's and the stress terms' faults.
pub use crate::io::accessor::{AccessorError, AccessorFault, ViewFault};
pub use crate::io::gltf_read::error::{
    BufferFault, DataUriError, Element, GlbError, GltfError, HierarchyError,
};
pub use crate::io::gltf_write::document::DocumentError;
pub use crate::io::gltf_write::finite::NonFinite;
pub use crate::io::obj::{LineFault, ObjError};
pub use crate::io::paths::{NotRegular, PathError};
pub use crate::io::write::DirError;
pub use crate::io::PrimitiveBudgetError;
pub use crate::mesh::error::{
    EditFault, FlipRefusal, InvariantFault, OptionFault, SkippedSegment, WalkFault,
};
pub use crate::mesh::{FaceId, HalfedgeId, VertexId};
pub use crate::post::options::OptionsError;
pub use crate::sim::{Divergence, Misfit, ParamError};
pub use crate::stress::frame::{FieldError, TermFault};
pub use crate::stress::texture::TransformFault;

/// Everything that can go wrong in the library.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing a file failed (the message names it).
    #[error(transparent)]
    File(#[from] IoError),
    /// A simulation failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A mesh could not be built or edited.
    #[error(transparent)]
    MeshEdit(#[from] MeshError),
    /// A texture mask could not be made.
    #[error(transparent)]
    Texture(#[from] TextureError),
    /// A pipeline is invalid (exit code 2 on the command line).
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// A pipeline's key cannot be met by this asset (a mask's material
    /// the input does not have, a texture that cannot be used); the message
    /// names the asset and the key. The command line exits with 2 for it.
    #[error("{}: {error}", asset.display())]
    Config {
        /// The asset.
        asset: PathBuf,
        /// What is wrong, naming the key.
        error: Box<ConfigError>,
    },
    /// What was asked cannot be done with this input or these options (a
    /// name the input does not have, a cell size above the triangle
    /// budget, a bad mask or frames request); the message says which.
    /// The command line exits with 2 for it.
    #[error(transparent)]
    Usage(#[from] UsageError),
    /// A batch's inputs or outputs cannot be used as given (exit code 2 on
    /// the command line).
    #[error(transparent)]
    Inputs(#[from] InputsError),
    /// A batch's rules file cannot be used (exit code 2 on the command
    /// line).
    #[error(transparent)]
    Rules(#[from] RulesError),
    /// A stage failed on one mesh of an asset.
    #[error("{}: {mesh}: {error}", asset.display())]
    Mesh {
        /// The asset.
        asset: PathBuf,
        /// The mesh's label.
        mesh: String,
        /// What failed (the stage's error).
        error: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A mesh edit the pipeline made was refused (a bug, not bad input).
    #[error("{mesh}: {error}")]
    Internal {
        /// The mesh's label.
        mesh: String,
        /// What was refused (the edit's error).
        error: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The time-lapse frames could not be made or written.
    #[error(transparent)]
    Frames(#[from] FrameError),
    /// The time-lapse frames asked for cannot be made (exit code 2 on the
    /// command line).
    #[error(transparent)]
    FramesRequest(#[from] FramesError),
    /// The asset has nothing to crack.
    #[error("{}: nothing to crack: {why}", path.display())]
    NothingToCrack {
        /// The asset.
        path: PathBuf,
        /// Why.
        why: Uncrackable,
    },
    /// A batch could not read an input folder or write its outputs, copies
    /// or state (the message names the file).
    #[error(transparent)]
    Batch(#[from] BatchError),
}

impl Error {
    /// A stage's failure on mesh `mesh` of `asset`.
    pub fn mesh(
        asset: &std::path::Path,
        mesh: &str,
        error: impl Into<Box<dyn std::error::Error + Send + Sync>>,
    ) -> Self {
        Error::Mesh {
            asset: asset.to_path_buf(),
            mesh: mesh.to_string(),
            error: error.into(),
        }
    }
}

/// A pipeline error; the message names the file (or preset) and the key.
#[derive(Debug, thiserror::Error)]
#[error("{source_name}: {error}")]
pub struct PipelineError {
    /// File path or `preset NAME`.
    pub source_name: String,
    /// What is wrong, naming the key (boxed: a pipeline's errors are
    /// rare, and the library's error stays small).
    pub error: Box<ConfigError>,
}

/// Result with the library's error.
pub type Result<T, E = Error> = std::result::Result<T, E>;
