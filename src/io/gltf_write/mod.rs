//! Writing a [`Scene`] as glTF 2.0: `.gltf` with a `.bin` and image files
//! beside it, or a self-contained `.glb`, chosen by the output extension.
//!
//! The writer emits only what the scene uses: meshes drawn by a node,
//! materials of those meshes, textures of those materials, their images and
//! samplers, and one accessor per attribute actually written. Every file is
//! first written under a temporary name and renamed into place at the end, so
//! a failure leaves no partial output.

use crate::io::Format;
use crate::io::{IoError as Error, IoResult as Result};
use crate::scene::{ImageSource, Scene};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

pub(crate) mod document;
mod files;
pub(crate) mod finite;
mod names;
mod refs;
use document::build_document;
pub use document::DocumentError;
pub use files::*;
pub use finite::NonFinite;
use names::uri_encode;

/// What was written.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct WriteSummary {
    /// Files written (the main file first).
    pub files: Vec<PathBuf>,
    /// Total bytes written.
    pub bytes: u64,
    /// Triangles written (per mesh, not per instance).
    pub triangles: usize,
}

/// Write `scene` to `path` (`.gltf` or `.glb`).
///
/// # Errors
/// When the extension is not `.gltf`/`.glb`, an image cannot be read or has
/// an unknown type, or a file cannot be written. No output file is left
/// behind on error.
pub fn write_scene(scene: &Scene, path: &Path) -> Result<WriteSummary> {
    write_scene_with(scene, path, false)
}

/// [`write_scene`]; with `prefix_images`, a `.gltf` output's image files
/// are named `<stem>_<name>` so that outputs sharing a folder never write
/// the same side file (its `.bin` is `<stem>.bin` either way).
pub fn write_scene_with(scene: &Scene, path: &Path, prefix_images: bool) -> Result<WriteSummary> {
    let format = Format::from_path(path)?;
    if format == Format::Obj {
        return Err(Error::ObjOutput { path: path.into() });
    }
    if let Some(value) = finite::first_non_finite(scene) {
        return Err(Error::NonFinite {
            path: path.into(),
            value,
        });
    }
    let glb = format == Format::Glb;
    let out_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    // A run killed while writing left its temporary files here.
    remove_stale_temps(
        if out_dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            &out_dir
        },
        false,
    );
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene")
        .to_string();
    let mut doc =
        build_document(scene, glb, &stem, prefix_images).map_err(|error| Error::Document {
            path: path.into(),
            error,
        })?;
    if !glb {
        name_side_files_by_content(&mut doc, &stem);
    }
    // Writers of `.gltf` outputs in one folder take turns from reading the
    // old output to sweeping its side files: another writer's sweep would
    // otherwise remove the buffer this writer's main file names.
    let _turn = (!glb).then(|| folder_lock(&out_dir));
    // The side files the output now in place uses, to remove once it is
    // replaced (read before it is).
    let mut old_side_files = if glb {
        Vec::new()
    } else {
        side_files_of(path, &out_dir)
    };
    let mut files: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let json_bytes = serde_json::to_vec(&doc.json).map_err(|error| Error::Encode {
        path: path.into(),
        error,
    })?;
    if glb {
        files.push((path.to_path_buf(), glb_bytes(&json_bytes, &doc.bin)));
    } else {
        files.push((path.to_path_buf(), json_bytes));
        if !doc.bin.is_empty() {
            files.push((out_dir.join(&doc.bin_name), doc.bin));
        }
        for (name, bytes) in doc.image_files {
            files.push((out_dir.join(name), bytes));
        }
    }
    commit_files(&files)?;
    // Old side files no longer referenced go, unless this run reads them
    // (an input beside its output) or wrote them.
    let inputs: BTreeSet<PathBuf> = scene
        .sources
        .iter()
        .chain(scene.images.iter().filter_map(|i| match &i.source {
            ImageSource::File(p) => Some(p),
            ImageSource::Bytes(_) => None,
        }))
        .filter_map(|p| p.canonicalize().ok())
        .collect();
    // And this output's buffers a killed run placed without its main file
    // (`<stem>.<tag>.bin`, named after this output alone).
    if !glb {
        old_side_files.extend(stray_buffers(&out_dir, &stem));
    }
    for old in old_side_files {
        let ours = files.iter().any(|(p, _)| *p == old);
        let input = old.canonicalize().is_ok_and(|c| inputs.contains(&c));
        if !ours && !input {
            let _ = std::fs::remove_file(&old);
        }
    }
    Ok(WriteSummary {
        bytes: files.iter().map(|(_, b)| b.len() as u64).sum(),
        files: files.into_iter().map(|(p, _)| p).collect(),
        triangles: doc.triangles,
    })
}

/// `scene` as the bytes of a self-contained `.glb` (what [`write_scene`]
/// writes to a `.glb` path; `name` names the scene in messages).
///
/// # Errors
/// A non-finite value, or an image that cannot be read or has an unknown type.
pub fn glb_scene_bytes(scene: &Scene, name: &Path) -> Result<Vec<u8>> {
    if let Some(value) = finite::first_non_finite(scene) {
        return Err(Error::NonFinite {
            path: name.into(),
            value,
        });
    }
    let doc = build_document(scene, true, "scene", false).map_err(|error| Error::Document {
        path: name.into(),
        error,
    })?;
    let json = serde_json::to_vec(&doc.json).map_err(|error| Error::Encode {
        path: name.into(),
        error,
    })?;
    Ok(glb_bytes(&json, &doc.bin))
}

struct Document {
    json: Value,
    bin: Vec<u8>,
    /// The buffer file's name (`.gltf` output).
    bin_name: String,
    image_files: Vec<(String, Vec<u8>)>,
    triangles: usize,
}

#[cfg(test)]
mod tests {
    use super::names::{sanitize_file_name, unique_name};
    use super::*;

    #[test]
    fn names_are_safe_and_unique() {
        let mut taken = BTreeSet::new();
        assert_eq!(
            unique_name(&sanitize_file_name("..\\a b.png"), &mut taken),
            "a b.png"
        );
        assert_eq!(unique_name("a b.png", &mut taken), "a b_1.png");
        assert_eq!(uri_encode("a b.png"), "a%20b.png");
    }
}
