//! Errors of the library.

use std::path::PathBuf;

/// Everything that can go wrong in the library.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The input is malformed or not supported; the message names the element.
    #[error("{path}: {message}")]
    Input {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the element.
        message: String,
    },
    /// A configuration value is invalid.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// What was asked cannot be done with this input or these options (a
    /// name the input does not have, a cell size above the triangle
    /// budget, a bad mask or frames request); the message says which.
    /// The command line exits with 2 for it.
    #[error("{0}")]
    Usage(String),
    /// A stage failed on one mesh of an asset.
    #[error("{}: {mesh}: {message}", asset.display())]
    Mesh {
        /// The asset.
        asset: PathBuf,
        /// The mesh's label.
        mesh: String,
        /// What failed (the stage's error).
        message: String,
    },
    /// A mesh edit the pipeline made was refused (a bug, not bad input).
    #[error("{mesh}: {message}")]
    Internal {
        /// The mesh's label.
        mesh: String,
        /// What was refused.
        message: String,
    },
    /// The time-lapse frames could not be made or written.
    #[error("{0}")]
    Frames(String),
    /// The asset has nothing to crack.
    #[error("{}: nothing to crack: {why}", path.display())]
    NothingToCrack {
        /// The asset.
        path: PathBuf,
        /// Why (the reader's warnings, or that it has no triangle mesh).
        why: String,
    },
    /// Output could not be produced.
    #[error("{path}: cannot write: {message}")]
    Output {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

impl Error {
    /// An input error for `path`.
    pub fn input(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::Input {
            path: path.into(),
            message: message.into(),
        }
    }
    /// A stage's failure on mesh `mesh` of `asset`.
    pub fn mesh(asset: &std::path::Path, mesh: &str, message: impl std::fmt::Display) -> Self {
        Error::Mesh {
            asset: asset.to_path_buf(),
            mesh: mesh.to_string(),
            message: message.to_string(),
        }
    }
    /// An I/O error for `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

/// Result with the library's error.
pub type Result<T, E = Error> = std::result::Result<T, E>;
