//! Errors of a simulation run.

use crate::mesh::MeshError;

/// Errors of a simulation run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A parameter is invalid.
    #[error("invalid parameter: {0}")]
    Param(String),
    /// Relaxation diverged (an explicit step above the stable one).
    #[error("{0}")]
    Diverged(String),
    /// A mesh invariant broke (a bug).
    #[error("internal mesh error: {0}")]
    Mesh(#[from] MeshError),
}
