//! Errors of a simulation run.

use crate::mesh::MeshError;

/// An invalid simulation parameter; the message names it and its value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct ParamError(pub String);

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
