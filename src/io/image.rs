//! Image files a texture mask reads: inside an asset's folder (symbolic
//! links followed to their real place, which must stay inside), regular
//! files only, at most [`MAX_FILE_BYTES`].

use crate::stress::texture::{GreyImage, ImageFiles, TextureError, MAX_FILE_BYTES};
use std::path::{Path, PathBuf};

/// Reads mask images: inside `base` when given, else as named.
#[derive(Clone, Debug, Default)]
pub struct Files {
    /// The folder every image must lie in; `None`: any path as given.
    pub base: Option<PathBuf>,
    /// The most bytes one decoded image may take; `None`: no limit beyond
    /// the decoder's pixel cap.
    pub budget: Option<u64>,
}

impl Files {
    /// Images inside `base`.
    pub fn inside(base: &Path) -> Files {
        Files {
            base: Some(base.to_path_buf()),
            budget: None,
        }
    }

    /// The same files, each decoded image held to `budget` bytes.
    #[must_use]
    pub fn within(self, budget: u64) -> Files {
        Files {
            budget: Some(budget),
            ..self
        }
    }
}

impl ImageFiles for Files {
    fn read(&self, path: &Path, name: &str) -> Result<Vec<u8>, TextureError> {
        let path = checked_path(path, self.base.as_deref(), name)?;
        read_limited(&path, name)
    }

    fn decode(&self, bytes: &[u8], name: &str) -> Result<GreyImage, TextureError> {
        super::image_decode::grey_within(bytes, name, self.budget.unwrap_or(u64::MAX))
    }
}

/// Read and decode an image file; the file's path names it in errors.
///
/// # Errors
/// [`TextureError::Io`] when the file cannot be read or is larger than
/// [`MAX_FILE_BYTES`], and the errors of [`super::image_decode::grey`].
pub fn open_grey(path: &Path) -> Result<GreyImage, TextureError> {
    open_grey_within(path, u64::MAX)
}

/// [`open_grey`] refusing, before decoding, an image whose decoded values
/// would take more than `budget` bytes.
///
/// # Errors
/// Those of [`open_grey`] and [`TextureError::OverBudget`].
pub fn open_grey_within(path: &Path, budget: u64) -> Result<GreyImage, TextureError> {
    let name = format!("'{}'", path.display());
    let bytes = read_limited(path, &name)?;
    super::image_decode::grey_within(&bytes, &name, budget)
}

/// The path to read: as given without `base_dir`; with it, the real path,
/// which must lie inside the real `base_dir`.
fn checked_path(path: &Path, base_dir: Option<&Path>, name: &str) -> Result<PathBuf, TextureError> {
    let Some(base) = base_dir else {
        return Ok(path.to_path_buf());
    };
    let io = |p: &Path| {
        let p = p.to_path_buf();
        move |source| TextureError::Io {
            image: name.to_string(),
            path: p,
            source,
        }
    };
    let real_base = base.canonicalize().map_err(io(base))?;
    let real = path.canonicalize().map_err(io(path))?;
    if !real.starts_with(&real_base) {
        return Err(TextureError::OutsideBase {
            image: name.to_string(),
            path: real,
            base: real_base,
        });
    }
    Ok(real)
}

/// Read a whole regular file of at most [`MAX_FILE_BYTES`].
fn read_limited(path: &Path, name: &str) -> Result<Vec<u8>, TextureError> {
    super::paths::read_capped(path, MAX_FILE_BYTES, "image").map_err(|source| TextureError::Io {
        image: name.to_string(),
        path: path.to_path_buf(),
        source,
    })
}
