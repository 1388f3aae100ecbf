//! Resolving file references (buffer and image URIs, MTL libraries, texture
//! maps) safely: a reference may only name a file inside the asset's folder.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// A file reference that is refused or cannot be followed; the message
/// names the reference and why ("not found" for a missing file).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PathError {
    /// A malformed `%XX` escape.
    #[error("invalid percent-escape in reference '{reference}'")]
    BadEscape {
        /// The reference as written.
        reference: String,
    },
    /// An empty reference.
    #[error("empty file reference")]
    Empty,
    /// A path from the root (`/x`).
    #[error("absolute path '{reference}' is not followed (only files inside the asset's folder are read)")]
    Absolute {
        /// The reference as written.
        reference: String,
    },
    /// A URI scheme (`http:`) or a drive letter (`C:`).
    #[error("reference '{reference}' is a URI or absolute path and is not followed (only relative paths inside the asset's folder are read)")]
    Uri {
        /// The reference as written.
        reference: String,
    },
    /// A `..` component.
    #[error("reference '{reference}' leaves the asset's folder ('..' is not followed)")]
    LeavesFolder {
        /// The reference as written.
        reference: String,
    },
    /// A root or prefix component found while resolving.
    #[error("absolute path '{reference}' is not followed")]
    RootComponent {
        /// The reference as written.
        reference: String,
    },
    /// The asset's folder cannot be resolved.
    #[error("the asset's folder '{}' cannot be read: {error}", folder.display())]
    Folder {
        /// The folder.
        folder: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// Nothing by that name.
    #[error("'{reference}' not found")]
    NotFound {
        /// The reference as written.
        reference: String,
    },
    /// The file cannot be resolved or read.
    #[error("'{reference}' cannot be read: {error}")]
    Unreadable {
        /// The reference as written.
        reference: String,
        /// The OS error.
        error: std::io::Error,
    },
    /// A symbolic link to a file outside the asset's folder.
    #[error("'{reference}' is a symbolic link to '{}', outside the asset's folder '{}' (only files inside it are read)", real.display(), folder.display())]
    LinkOutside {
        /// The reference as written.
        reference: String,
        /// Where the link leads.
        real: PathBuf,
        /// The asset's real folder.
        folder: PathBuf,
    },
    /// A folder, FIFO, socket or device.
    #[error("'{reference}' is {what}, not a regular file")]
    NotRegular {
        /// The reference as written.
        reference: String,
        /// What it is.
        what: NotRegular,
    },
}

/// What a path names instead of a regular file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum NotRegular {
    /// A named pipe.
    #[error("a FIFO")]
    Fifo,
    /// A socket.
    #[error("a socket")]
    Socket,
    /// A block or character device.
    #[error("a device")]
    Device,
    /// A folder.
    #[error("a folder")]
    Folder,
    /// Anything else.
    #[error("not a file")]
    Other,
}

/// Largest model file (OBJ, glTF, GLB) or external glTF buffer read: 4 GiB.
pub const MAX_MODEL_BYTES: u64 = 4 << 30;
/// Largest pipeline or rules file read: 16 MiB (TOML text).
pub const MAX_CONFIG_BYTES: u64 = 16 << 20;

/// Read a text file the user named (a pipeline, a rules file): a regular
/// file (a FIFO blocked the run forever) of at most [`MAX_CONFIG_BYTES`],
/// UTF-8. `what` names its role in the errors.
pub fn read_config_text(path: &Path, what: &str) -> std::io::Result<String> {
    let bytes = read_capped(path, MAX_CONFIG_BYTES, what)?;
    String::from_utf8(bytes).map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("the {what} is not UTF-8 text"),
        )
    })
}

/// Largest MTL material library read: 64 MiB (a library of text lines).
pub const MAX_MTL_BYTES: u64 = 64 << 20;
/// Largest image file read: 1 GiB.
pub const MAX_IMAGE_BYTES: u64 = 1 << 30;

/// Resolve `reference` like [`resolve_inside`], then follow symbolic links:
/// the real file must lie inside the real `base_dir` (a link inside the
/// folder to a file or folder outside it is refused) and be a regular file
/// (not a folder, FIFO, socket or device). Returns the real path. Errors
/// name the reference; a missing file gives an error whose text contains
/// "not found".
pub fn resolve_file_inside(base_dir: &Path, reference: &str) -> Result<PathBuf, PathError> {
    let path = resolve_inside(base_dir, reference)?;
    real_file_inside(base_dir, &path, reference)
}

/// Where a reference leads: the real path of a regular file inside the
/// asset's folder, or nothing at all there (the path as written).
#[derive(Debug, PartialEq, Eq)]
pub enum Located {
    /// The file's real path, checked as [`resolve_file_inside`] does.
    Found(PathBuf),
    /// Nothing by that name (not even a dangling link).
    Missing(PathBuf),
}

/// [`resolve_file_inside`], telling a missing file (often only a warning)
/// apart from one that is refused.
pub fn locate_inside(base_dir: &Path, reference: &str) -> Result<Located, PathError> {
    let path = resolve_inside(base_dir, reference)?;
    if std::fs::symlink_metadata(&path).is_err() {
        return Ok(Located::Missing(path));
    }
    real_file_inside(base_dir, &path, reference).map(Located::Found)
}

/// The real path of `path` (a file under `base_dir` by its text), checked
/// as [`resolve_file_inside`] does; `reference` names it in errors.
pub fn real_file_inside(
    base_dir: &Path,
    path: &Path,
    reference: &str,
) -> Result<PathBuf, PathError> {
    let reference = || reference.to_string();
    let base = if base_dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base_dir
    };
    let real_base = base.canonicalize().map_err(|error| PathError::Folder {
        folder: base.to_path_buf(),
        error,
    })?;
    let real = match path.canonicalize() {
        Ok(r) => r,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(PathError::NotFound {
                reference: reference(),
            })
        }
        Err(error) => {
            return Err(PathError::Unreadable {
                reference: reference(),
                error,
            })
        }
    };
    if !real.starts_with(&real_base) {
        return Err(PathError::LinkOutside {
            reference: reference(),
            real,
            folder: real_base,
        });
    }
    match regular_file(&real) {
        Ok(Ok(_)) => Ok(real),
        Ok(Err(what)) => Err(PathError::NotRegular {
            reference: reference(),
            what,
        }),
        Err(error) => Err(PathError::Unreadable {
            reference: reference(),
            error,
        }),
    }
}

/// The metadata of a regular file (links followed), else what the path
/// names instead.
fn regular_file(path: &Path) -> std::io::Result<Result<std::fs::Metadata, NotRegular>> {
    let meta = std::fs::metadata(path)?;
    let kind = meta.file_type();
    if kind.is_file() {
        return Ok(Ok(meta));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return Ok(Err(NotRegular::Fifo));
        }
        if kind.is_socket() {
            return Ok(Err(NotRegular::Socket));
        }
        if kind.is_block_device() || kind.is_char_device() {
            return Ok(Err(NotRegular::Device));
        }
    }
    Ok(Err(if kind.is_dir() {
        NotRegular::Folder
    } else {
        NotRegular::Other
    }))
}

/// Open the regular file at `path` for reading without following a link
/// at its last component (one swapped in after the path was checked), and
/// refuse anything that is not a regular file (a FIFO does not block:
/// it is opened non-blocking and refused).
pub fn open_no_follow(path: &Path) -> std::io::Result<std::fs::File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
    }
    let f = options.open(path)?;
    if !f.metadata()?.is_file() {
        return Err(std::io::Error::other("not a regular file"));
    }
    Ok(f)
}

/// Read a whole regular file of at most `cap` bytes; the kind and the size
/// are checked before reading (and the read stops at the cap should the
/// file grow meanwhile). `what` names the file's role in the errors
/// ("material library", "image"...).
pub fn read_capped(path: &Path, cap: u64, what: &str) -> std::io::Result<Vec<u8>> {
    let (file, len) = open_capped(path, cap, what)?;
    let mut data = Vec::with_capacity(len as usize);
    file.take(cap + 1).read_to_end(&mut data)?;
    if data.len() as u64 > cap {
        return Err(too_big(what, data.len() as u64, cap));
    }
    Ok(data)
}

/// `path` opened for reading ([`open_no_follow`]: a link swapped in after
/// the check is refused, not followed) and its length, checked on the path
/// and again on the open file to be a regular file of at most `cap` bytes.
fn open_capped(path: &Path, cap: u64, what: &str) -> std::io::Result<(std::fs::File, u64)> {
    capped_len(path, cap, what)?;
    let file = open_no_follow(path).map_err(|e| {
        std::io::Error::new(
            e.kind(),
            format!(
                "the {what}: {e} (swapped for a link or another kind of file while it was read?)"
            ),
        )
    })?;
    let len = file.metadata()?.len();
    if len > cap {
        return Err(too_big(what, len, cap));
    }
    Ok((file, len))
}

/// The length of `path`, checked to be a regular file of at most `cap`
/// bytes before anything is read ([`read_capped`], [`stream_capped`]).
fn capped_len(path: &Path, cap: u64, what: &str) -> std::io::Result<u64> {
    let meta = match regular_file(path)? {
        Ok(m) => m,
        Err(kind) => {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("the {what} is {kind}, not a regular file"),
            ))
        }
    };
    if meta.len() > cap {
        return Err(too_big(what, meta.len(), cap));
    }
    Ok(meta.len())
}

fn too_big(what: &str, len: u64, cap: u64) -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::InvalidData,
        format!("the {what} has {len} bytes, more than the {cap} accepted"),
    )
}

/// [`read_capped`] without holding the file: its length, then its bytes in
/// pieces of at most 64 KiB, go to `sink` (a hash of a file of any size
/// within `cap` in constant memory). The length given first is the bytes
/// passed; a file whose length changes while it is read is an error.
pub fn stream_capped(
    path: &Path,
    cap: u64,
    what: &str,
    sink: &mut dyn FnMut(&[u8]),
) -> std::io::Result<u64> {
    let (file, len) = open_capped(path, cap, what)?;
    sink(&len.to_le_bytes());
    let mut file = file.take(len + 1);
    let mut buf = vec![0u8; 64 << 10];
    let mut read = 0u64;
    loop {
        let n = match file.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        read += n as u64;
        if read > len {
            break;
        }
        sink(&buf[..n]);
    }
    if read != len {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("the {what} changed while it was read ({len} bytes, then {read})"),
        ));
    }
    Ok(len)
}

/// Resolve `reference` (a relative URI or path as written in an asset) against
/// `base_dir`, the folder of the asset.
///
/// Percent-escapes are decoded and backslashes are taken as separators
/// (`.\tex\a.png`). Absolute paths, drive letters, URI schemes other than a
/// plain relative path, and any `..` component are refused with a message, so
/// an asset never makes the tool read outside its own folder.
pub fn resolve_inside(base_dir: &Path, reference: &str) -> Result<PathBuf, PathError> {
    let r = || reference.to_string();
    let decoded =
        percent_decode(reference).ok_or_else(|| PathError::BadEscape { reference: r() })?;
    let normalized = decoded.replace('\\', "/");
    if normalized.is_empty() {
        return Err(PathError::Empty);
    }
    if normalized.starts_with('/') {
        return Err(PathError::Absolute { reference: r() });
    }
    // A scheme (http:, file:) or a drive letter (C:)
    if let Some(colon) = normalized.find(':') {
        let before = &normalized[..colon];
        if !before.contains('/') {
            return Err(PathError::Uri { reference: r() });
        }
    }
    let mut out = base_dir.to_path_buf();
    for comp in Path::new(&normalized).components() {
        match comp {
            Component::Normal(c) => out.push(c),
            Component::CurDir => {}
            Component::ParentDir => return Err(PathError::LeavesFolder { reference: r() }),
            Component::RootDir | Component::Prefix(_) => {
                return Err(PathError::RootComponent { reference: r() })
            }
        }
    }
    Ok(out)
}

/// Decode `%XX` escapes; `None` when an escape is malformed or the result is not UTF-8.
pub fn percent_decode(s: &str) -> Option<String> {
    if !s.contains('%') {
        return Some(s.to_string());
    }
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = s.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inside_paths_resolve() {
        let b = Path::new("/assets/a");
        assert_eq!(
            resolve_inside(b, "x.bin").unwrap(),
            PathBuf::from("/assets/a/x.bin")
        );
        assert_eq!(
            resolve_inside(b, "./tex/y z.png").unwrap(),
            PathBuf::from("/assets/a/tex/y z.png")
        );
        assert_eq!(
            resolve_inside(b, ".\\SpiderTex.jpg").unwrap(),
            PathBuf::from("/assets/a/SpiderTex.jpg")
        );
        assert_eq!(
            resolve_inside(b, "fuze%20uv.jpg").unwrap(),
            PathBuf::from("/assets/a/fuze uv.jpg")
        );
    }

    #[test]
    fn escaping_paths_are_refused() {
        let b = Path::new("/assets/a");
        for r in [
            "../secret.bin",
            "/etc/passwd",
            "C:\\x.bin",
            "file:///etc/passwd",
            "http://x/y.bin",
            "a/../../b",
            "..\\b",
            "%2e%2e/x",
            "",
        ] {
            assert!(resolve_inside(b, r).is_err(), "{r} should be refused");
        }
    }

    #[test]
    fn only_regular_files_within_the_cap_are_read() {
        let t = tempfile::tempdir().unwrap();
        let f = t.path().join("a.mtl");
        std::fs::write(&f, b"0123456789").unwrap();
        assert_eq!(read_capped(&f, 10, "library").unwrap().len(), 10);
        let e = read_capped(&f, 9, "library").unwrap_err().to_string();
        assert!(e.contains("has 10 bytes, more than the 9"), "{e}");
        let e = read_capped(t.path(), 9, "library").unwrap_err().to_string();
        assert!(e.contains("a folder"), "{e}");
        #[cfg(unix)]
        {
            let e = read_capped(Path::new("/dev/zero"), 9, "library")
                .unwrap_err()
                .to_string();
            assert!(e.contains("a device"), "{e}");
        }
        assert_eq!(
            read_capped(&t.path().join("missing"), 9, "library")
                .unwrap_err()
                .kind(),
            std::io::ErrorKind::NotFound
        );
    }
}
