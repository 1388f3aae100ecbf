//! Errors of a simulation run.

use crate::mesh::MeshError;

/// An invalid simulation parameter; the message names it and its value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParamError {
    /// A value outside its range: `{key} must be {expected}, got {got}`.
    #[error("{key} must be {expected}, got {got}")]
    Range {
        /// The parameter (e.g. `springs.alpha`, `ductile.young`).
        key: String,
        /// What it must be (e.g. `in (0, 1]`).
        expected: String,
        /// The value given.
        got: String,
    },
    /// A value that cannot be used as given (or with another one); the
    /// message is the key followed by the reason.
    #[error("{key} {reason}")]
    Invalid {
        /// The parameter (or parameters).
        key: String,
        /// Why (e.g. `must be at least 1`).
        reason: String,
    },
    /// Two keys that exclude each other were both given.
    #[error("give {first} or {second}, not both")]
    Both {
        /// The first key.
        first: String,
        /// The second key.
        second: String,
    },
    /// A name (an integrator's) that is not one of the known ones; the
    /// message lists them.
    #[error("{}", crate::sim::params::unknown_integrator(name))]
    UnknownName {
        /// The name given.
        name: String,
    },
}

impl ParamError {
    /// `{key} must be {expected}, got {got}`.
    pub fn range(
        key: impl Into<String>,
        expected: impl Into<String>,
        got: impl std::fmt::Display,
    ) -> Self {
        ParamError::Range {
            key: key.into(),
            expected: expected.into(),
            got: got.to_string(),
        }
    }
    /// `{key} {reason}`.
    pub fn invalid(key: impl Into<String>, reason: impl Into<String>) -> Self {
        ParamError::Invalid {
            key: key.into(),
            reason: reason.into(),
        }
    }
    /// The parameter the error names (the first of two), if one.
    pub fn key(&self) -> Option<&str> {
        match self {
            ParamError::Range { key, .. } | ParamError::Invalid { key, .. } => Some(key),
            ParamError::Both { first, .. } => Some(first),
            ParamError::UnknownName { .. } => None,
        }
    }
}

/// Errors of a simulation run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// A parameter is invalid.
    #[error("invalid parameter: {0}")]
    Params(ParamError),
    /// The mesh or the stress field does not fit the parameters (no edge
    /// of positive length, a field of another mesh, a step too small).
    #[error("invalid parameter: {0}")]
    Param(String),
    /// Relaxation diverged (an explicit step above the stable one).
    #[error("{0}")]
    Diverged(String),
    /// A mesh invariant broke (a bug).
    #[error("internal mesh error: {0}")]
    Mesh(#[from] MeshError),
}

impl From<ParamError> for SimError {
    fn from(e: ParamError) -> Self {
        SimError::Params(e)
    }
}
