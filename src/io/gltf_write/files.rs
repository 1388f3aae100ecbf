//! The files of an output: temporary names, side files named by a content tag, stale side files and temporaries removed, and the commit of every file as a unit.

use super::*;
use crate::io::{IoError as Error, IoResult as Result};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Remove the temporary files (`.NAME.crackle-tmp-PID-RANDOM`, regular files
/// only) that a killed run left in `dir`, and in its subfolders when
/// `recursive` (folder links are not followed), when their process is gone.
/// Errors are ignored: this is tidying, not the run's work.
pub fn remove_stale_temps(dir: &Path, recursive: bool) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let Ok(kind) = e.file_type() else {
            continue;
        };
        let p = e.path();
        if kind.is_dir() {
            if recursive {
                remove_stale_temps(&p, true);
            }
            continue;
        }
        if !kind.is_file() {
            continue;
        }
        let Some(name) = p.file_name().and_then(|n| n.to_str()) else {
            continue;
        };
        let Some((_, pid)) = name.rsplit_once(crate::io::write::TEMP_MARK) else {
            continue;
        };
        let pid = pid.split('-').next().unwrap_or(pid);
        let alive = pid.parse::<u32>().is_ok_and(|pid| {
            pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists()
        });
        if name.starts_with('.') && !alive {
            let _ = std::fs::remove_file(&p);
        }
    }
}

/// An exclusive advisory lock on the folder `dir` (`flock` on the folder
/// itself: no lock file is left behind), held until the value is dropped;
/// `None` where the folder cannot be opened or the file system does not
/// lock (the write goes on without it).
pub(super) fn folder_lock(dir: &Path) -> Option<std::fs::File> {
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let folder = std::fs::File::open(dir).ok()?;
    #[cfg(unix)]
    {
        use std::os::fd::AsRawFd as _;
        // Waits for the lock, again when a signal interrupts the wait.
        loop {
            // SAFETY: `flock` on a descriptor this function owns; the lock
            // goes with the descriptor when the file is dropped.
            if unsafe { libc::flock(folder.as_raw_fd(), libc::LOCK_EX) } == 0 {
                return Some(folder);
            }
            if std::io::Error::last_os_error().kind() != std::io::ErrorKind::Interrupted {
                return None;
            }
        }
    }
    #[cfg(not(unix))]
    {
        drop(folder);
        None
    }
}

/// Side files named after their content (`<stem>.<16 hex digits>.bin`,
/// `<image>.<16 hex digits>.png`): a new output never shares a side file's
/// name with an old one unless their bytes are the same, so an old main
/// file still in place never points at a new side file, and an output
/// image never takes the name of an input image it differs from.
pub(super) fn name_side_files_by_content(doc: &mut Document, stem: &str) {
    if !doc.bin.is_empty() {
        let name = format!("{stem}.{}.bin", content_tag(&doc.bin));
        if let Some(b) = doc.json.pointer_mut("/buffers/0") {
            b["uri"] = uri_encode(&name).into();
        }
        doc.bin_name = name;
    }
    // Images with a file are those with a `uri`, in order.
    let mut files = doc.image_files.iter_mut();
    if let Some(images) = doc.json.get_mut("images").and_then(Value::as_array_mut) {
        for img in images.iter_mut().filter(|i| i.get("uri").is_some()) {
            let Some((name, bytes)) = files.next() else {
                break;
            };
            *name = tagged(name, &content_tag(bytes));
            img["uri"] = uri_encode(name).into();
        }
    }
}

/// The first 8 bytes of the SHA-256 of `bytes`, in hex.
pub(super) fn content_tag(bytes: &[u8]) -> String {
    use sha2::Digest as _;
    sha2::Sha256::digest(bytes)[..8]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// `name` with `.tag` before its extension.
pub(super) fn tagged(name: &str, tag: &str) -> String {
    match name.rfind('.') {
        Some(i) if i > 0 => format!("{}.{tag}{}", &name[..i], &name[i..]),
        _ => format!("{name}.{tag}"),
    }
}

/// Whether `part` is a content tag: 16 hex digits.
pub(super) fn is_content_tag(part: &str) -> bool {
    part.len() == 16 && part.bytes().all(|b| b.is_ascii_hexdigit())
}

/// Whether a file name carries a content tag (`.<16 hex digits>.` or at
/// its end): the side files this writer names.
pub(super) fn has_content_tag(name: &str) -> bool {
    name.split('.').skip(1).any(is_content_tag)
}

/// The tagged side files (buffers and images, plain names in `out_dir`)
/// the glTF at `path` refers to, if it is a readable glTF of ours.
pub(super) fn side_files_of(path: &Path, out_dir: &Path) -> Vec<PathBuf> {
    let Ok(bytes) = crate::io::paths::read_capped(path, 256 << 20, "glTF") else {
        return Vec::new();
    };
    let Ok(json) = serde_json::from_slice::<Value>(&bytes) else {
        return Vec::new();
    };
    crate::io::gltf_read::file_uris(&json)
        .into_iter()
        .filter_map(crate::io::paths::percent_decode)
        .filter(|name| !name.contains(['/', '\\', ':']) && has_content_tag(name))
        .map(|name| out_dir.join(name))
        .collect()
}

/// The `<stem>.<tag>.bin` files in `dir`.
pub(super) fn stray_buffers(out_dir: &Path, stem: &str) -> Vec<PathBuf> {
    let dir = if out_dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        out_dir
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut out: Vec<PathBuf> = entries
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter(|e| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            name.strip_prefix(stem)
                .and_then(|r| r.strip_prefix('.'))
                .and_then(|r| r.strip_suffix(".bin"))
                .is_some_and(is_content_tag)
        })
        // Named as the files written are (`out_dir` may be empty).
        .map(|e| out_dir.join(e.file_name()))
        .collect();
    out.sort();
    out
}

/// Write every file under a temporary name, then rename all into place,
/// the main file (the first) last: a run killed in between leaves the old
/// main file, never a new one beside old side files. On failure, the side
/// files this run placed under new names are removed again.
pub(super) fn commit_files(files: &[(PathBuf, Vec<u8>)]) -> Result<()> {
    let mut temps = Vec::new();
    let cleanup = |temps: &[PathBuf]| {
        for t in temps {
            let _ = std::fs::remove_file(t);
        }
    };
    let existed: Vec<bool> = files
        .iter()
        .map(|(p, _)| std::fs::symlink_metadata(p).is_ok())
        .collect();
    for (p, bytes) in files {
        match crate::io::write::write_temp(p, bytes) {
            Ok(tmp) => temps.push(tmp),
            Err(e) => {
                cleanup(&temps);
                return Err(Error::io(p, e));
            }
        }
    }
    let mut placed: Vec<&PathBuf> = Vec::new();
    for (k, ((p, _), tmp)) in files.iter().zip(&temps).enumerate().rev() {
        if let Err(e) = std::fs::rename(tmp, p) {
            cleanup(&temps);
            for q in placed {
                let _ = std::fs::remove_file(q);
            }
            return Err(Error::io(p, e));
        }
        if !existed[k] {
            placed.push(p);
        }
    }
    Ok(())
}

pub(super) fn glb_bytes(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let jlen = json.len().div_ceil(4) * 4;
    let blen = bin.len().div_ceil(4) * 4;
    let total = 12 + 8 + jlen + if bin.is_empty() { 0 } else { 8 + blen };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(jlen as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(json);
    out.resize(out.len() + jlen - json.len(), b' ');
    if !bin.is_empty() {
        out.extend_from_slice(&(blen as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(bin);
        out.resize(out.len() + blen - bin.len(), 0);
    }
    out
}
