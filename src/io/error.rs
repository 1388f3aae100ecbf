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
    /// The file's extension is none of `.obj`, `.gltf` and `.glb`.
    #[error("{path}: unknown file type (expected .obj, .gltf or .glb)")]
    UnknownType {
        /// The file.
        path: PathBuf,
    },
    /// An asset read from memory names another file.
    #[error("{path}: names the file '{uri}'; an asset read from memory must hold all its data (embed it, or read the file with crackle::read)")]
    NamesFile {
        /// The asset's name.
        path: PathBuf,
        /// The file it names.
        uri: String,
    },
    /// An asset read from memory is neither a glTF document nor UTF-8 text.
    #[error("{path}: neither glTF nor OBJ text: {error}")]
    NotText {
        /// The asset's name.
        path: PathBuf,
        /// Why it is not text.
        error: std::str::Utf8Error,
    },
    /// Reading an asset failed on another file (one it names), which the
    /// error names.
    #[error("{path}: {error}")]
    Asset {
        /// The asset.
        path: PathBuf,
        /// The other file's error.
        error: Box<IoError>,
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
    /// OBJ output was asked for.
    #[error("{path}: cannot write: OBJ output is not supported; use .gltf or .glb")]
    ObjOutput {
        /// The output file.
        path: PathBuf,
    },
    /// The scene holds a value that is not a finite number.
    #[error("{path}: cannot write: {value}")]
    NonFinite {
        /// The output file.
        path: PathBuf,
        /// Where the value is, and what it is.
        value: super::gltf_write::NonFinite,
    },
    /// The output document cannot be encoded.
    #[error("{path}: cannot write: {error}")]
    Encode {
        /// The output file.
        path: PathBuf,
        /// The encoder's error.
        error: serde_json::Error,
    },
    /// The output's folder cannot be made.
    #[error("{path}: cannot write: cannot create the output folder: {error}")]
    OutputFolder {
        /// The folder.
        path: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
}

impl IoError {
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
