//! Reading and writing assets: OBJ (+MTL), glTF and GLB.

pub mod accessor;
mod error;
pub mod gltf_read;
pub mod gltf_write;
pub mod image;
pub mod image_decode;
pub mod obj;
pub mod paths;
pub mod write;

use crate::scene::Scene;
pub use error::{IoError, IoResult};
use error::{IoError as Error, IoResult as Result};
use std::path::Path;

/// Input formats, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Wavefront OBJ.
    Obj,
    /// glTF JSON (`.gltf`).
    Gltf,
    /// Binary glTF (`.glb`).
    Glb,
}

impl Format {
    /// The format of `path` from its extension, or an error naming the file.
    pub fn from_path(path: &Path) -> Result<Format> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("obj") => Ok(Format::Obj),
            Some("gltf") => Ok(Format::Gltf),
            Some("glb") => Ok(Format::Glb),
            _ => Err(Error::UnknownType {
                path: path.to_path_buf(),
            }),
        }
    }
}

/// Default of [`ReadOptions::max_memory`]: 8 GiB.
pub const DEFAULT_MAX_MEMORY: u64 = 8 << 30;

/// How assets are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadOptions {
    /// Most bytes one glTF document's decoded accessors may take (the
    /// CLI's `--max-memory`); each document's own budget is also bounded
    /// by its real size. Default 8 GiB.
    pub max_memory: u64,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            max_memory: DEFAULT_MAX_MEMORY,
        }
    }
}

/// Memory a run takes per mesh primitive (an OBJ object, group or
/// material run; a glTF primitive) beyond its vertices and triangles: the
/// scene's, the weld's and the output's structures. Measured: 100,000
/// one-triangle OBJ objects converted in 1.58 GB, 100,000 glTF primitives
/// in 1.17 GB.
pub const PRIMITIVE_BYTES: u64 = 16 << 10;

/// The largest model file (OBJ text, glTF JSON, GLB) read under
/// `max_memory`: a file is held whole while it is read.
pub fn model_cap(max_memory: u64) -> u64 {
    paths::MAX_MODEL_BYTES.min(max_memory)
}

/// What a model file is called in the message when it is over
/// [`model_cap`].
pub fn model_what(max_memory: u64) -> &'static str {
    if max_memory < paths::MAX_MODEL_BYTES {
        "model file (read whole, within the memory budget, --max-memory)"
    } else {
        "model file"
    }
}

/// `count` primitives within `max_memory` at [`PRIMITIVE_BYTES`] each, or an
/// error with the numbers (checked before the primitives are built).
pub fn check_primitive_count(
    count: usize,
    what: &'static str,
    max_memory: u64,
) -> std::result::Result<(), PrimitiveBudgetError> {
    let need = (count as u64).saturating_mul(PRIMITIVE_BYTES);
    if need > max_memory {
        return Err(PrimitiveBudgetError {
            count,
            what,
            need,
            max_memory,
        });
    }
    Ok(())
}

/// More primitives than the memory budget allows.
#[derive(Debug, thiserror::Error)]
#[error("{count} {what} need about {} MiB ({} KiB each), more than the memory budget of {} MiB (--max-memory); merge objects or raise --max-memory", need >> 20, PRIMITIVE_BYTES >> 10, max_memory >> 20)]
pub struct PrimitiveBudgetError {
    /// How many primitives.
    pub count: usize,
    /// What they are (`mesh primitives`, `objects (...)`).
    pub what: &'static str,
    /// Bytes they need.
    pub need: u64,
    /// The budget.
    pub max_memory: u64,
}

/// Read an asset (OBJ, glTF or GLB, by extension).
///
/// # Errors
/// A clear [`Error`] naming the file and element when the file cannot be read,
/// is malformed, or needs an extension the tool cannot decode.
pub fn read(path: &Path) -> Result<Scene> {
    read_with(path, &ReadOptions::default())
}

/// [`read`] with `options`.
///
/// # Errors
/// Those of [`read`].
pub fn read_with(path: &Path, options: &ReadOptions) -> Result<Scene> {
    match Format::from_path(path)? {
        Format::Obj => obj::read_obj_with(path, options),
        Format::Gltf | Format::Glb => gltf_read::read_gltf_with(path, options),
    }
}
