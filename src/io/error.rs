//! Errors of reading and writing files.

use std::path::PathBuf;

/// A file could not be read, decoded or written; every message names the
/// file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IoError {
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
    /// A glTF or GLB document cannot be read.
    #[error("{path}: {error}")]
    Gltf {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the element.
        error: super::gltf_read::GltfError,
    },
    /// An OBJ file cannot be read.
    #[error("{path}: {error}")]
    Obj {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the line.
        error: super::obj::ObjError,
    },
    /// The output document cannot be made.
    #[error("{path}: cannot write: {error}")]
    Document {
        /// The output file.
        path: PathBuf,
        /// What went wrong.
        error: super::gltf_write::DocumentError,
    },
    /// A folder below the output folder cannot be made or used.
    #[error(transparent)]
    Folder(#[from] super::write::DirError),
    /// Output could not be produced.
    #[error("{path}: cannot write: {message}")]
    Output {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

impl IoError {
    /// An input error for `path`.
    pub fn input(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        IoError::Input {
            path: path.into(),
            message: message.into(),
        }
    }
    /// An I/O error for `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        IoError::Io {
            path: path.into(),
            source,
        }
    }
}

/// Result with the I/O layer's error.
pub type IoResult<T, E = IoError> = std::result::Result<T, E>;
