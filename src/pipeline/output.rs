//! Writing the cracked scene (and each time-lapse frame) to its file: the
//! one place the pipeline's run, tearing and frames write from.

use crate::scene::Scene;
use crate::Result;
use std::path::Path;

/// Write `scene` to `output`, creating the output folder first (see
/// [`crate::io::gltf_write::write_scene_with`] for `prefix_images`).
///
/// # Errors
/// A folder that cannot be created, and the writer's errors.
pub fn write_output(
    scene: &Scene,
    output: &Path,
    prefix_images: bool,
) -> Result<crate::io::gltf_write::WriteSummary> {
    if let Some(dir) = output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|error| crate::io::IoError::OutputFolder {
            path: dir.to_path_buf(),
            error,
        })?;
    }
    Ok(crate::io::gltf_write::write_scene_with(
        scene,
        output,
        prefix_images,
    )?)
}
