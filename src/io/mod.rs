//! Reading and writing assets: OBJ (+MTL), glTF and GLB.

pub mod accessor;
pub mod gltf_read;
pub mod gltf_write;
pub mod obj;
pub mod paths;

use crate::error::{Error, Result};
use crate::scene::Scene;
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
            _ => Err(Error::input(
                path,
                "unknown file type (expected .obj, .gltf or .glb)",
            )),
        }
    }
}

/// Read an asset (OBJ, glTF or GLB, by extension).
///
/// # Errors
/// A clear [`Error`] naming the file and element when the file cannot be read,
/// is malformed, or needs an extension the tool cannot decode.
pub fn read(path: &Path) -> Result<Scene> {
    match Format::from_path(path)? {
        Format::Obj => obj::read_obj(path),
        Format::Gltf | Format::Glb => gltf_read::read_gltf(path),
    }
}
