//! Creating files without following links: every file the tool writes goes
//! through a temporary created exclusively (never through an existing
//! file or symbolic link of that name) under an unpredictable name beside
//! its target, then renamed into place (a rename replaces a link at the
//! target, it does not write through it); folders under an output root are
//! made one by one, refusing any that is a symbolic link.

use std::fs::File;
use std::io::Write as _;
use std::path::{Component, Path, PathBuf};

/// Marker in temporary names: `.NAME.crackle-tmp-PID-RANDOM`.
pub const TEMP_MARK: &str = ".crackle-tmp-";

/// Tries at a fresh temporary name before giving up (each fails only when
/// the name already exists).
const TEMP_TRIES: usize = 16;

/// 64 unpredictable bits: std's per-process random hash keys (seeded from
/// the operating system) over a counter.
fn random_u64() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(NEXT.fetch_add(1, Ordering::Relaxed));
    h.write_u128(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos()),
    );
    h.finish()
}

/// A new temporary file beside `path`, created exclusively: `create_new`
/// fails on any existing name, a symbolic link (dangling or not)
/// included, so a link planted under a temporary's name is never written
/// through. Its name carries this process's id (for the stale-temporary
/// sweep) and 64 random bits.
pub fn create_temp(path: &Path) -> std::io::Result<(PathBuf, File)> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    let mut last = None;
    for _ in 0..TEMP_TRIES {
        let tmp = path.with_file_name(format!(
            ".{name}{TEMP_MARK}{}-{:016x}",
            std::process::id(),
            random_u64()
        ));
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
        {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or_else(|| std::io::Error::other("no temporary name")))
}

/// Write `bytes` to a new temporary beside `path` ([`create_temp`]) and
/// return its name; nothing is left behind on failure.
pub fn write_temp(path: &Path, bytes: &[u8]) -> std::io::Result<PathBuf> {
    let (tmp, mut f) = create_temp(path)?;
    if let Err(e) = f.write_all(bytes).and_then(|_| f.flush()) {
        drop(f);
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    Ok(tmp)
}

/// Write `bytes` to `path` as a unit: a new temporary, then a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = write_temp(path, bytes)?;
    std::fs::rename(&tmp, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

/// Copy the file `from` (at most `cap` bytes; a larger one is refused
/// from its length before anything is read, and the copy stops past the
/// cap should it grow meanwhile) to a new temporary beside `path`, file to
/// file, so the kernel copies it (`copy_file_range` where the system has
/// it); nothing is left on failure. Returns its name and the bytes copied;
/// renaming it into place is the caller's (several files can then be
/// copied before any is put in place).
pub fn copy_temp(from: &File, path: &Path, cap: u64) -> std::io::Result<(PathBuf, u64)> {
    let len = from.metadata()?.len();
    if len > cap {
        return Err(std::io::Error::other(format!(
            "{len} bytes, larger than the {cap}-byte limit"
        )));
    }
    let (tmp, mut f) = create_temp(path)?;
    let result = std::io::copy(&mut std::io::Read::take(from, cap + 1), &mut f).and_then(|n| {
        if n > cap {
            Err(std::io::Error::other(format!(
                "larger than the {cap}-byte limit"
            )))
        } else {
            f.flush().map(|_| n)
        }
    });
    match result {
        Ok(n) => Ok((tmp, n)),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// A folder [`make_dirs_below`] made or checked, held open by its
/// descriptor: files created through [`HeldDir::path`] land in the folder
/// that was checked even if a folder on the way is swapped for a symbolic
/// link afterwards (on Linux the path is `/proc/self/fd/N`, which names the
/// open folder itself, not a path walked again; elsewhere it is the
/// checked path).
#[derive(Debug)]
pub struct HeldDir {
    shown: PathBuf,
    held: Option<(File, PathBuf)>,
}

impl HeldDir {
    /// The path to create files in the folder by.
    pub fn path(&self) -> &Path {
        self.held.as_ref().map_or(&self.shown, |(_, p)| p)
    }

    /// The folder by the name the user knows it by.
    pub fn shown(&self) -> &Path {
        &self.shown
    }

    /// `text` (a path or a message) with the held path replaced by the
    /// name the user knows the folder by.
    pub fn show(&self, text: &str) -> String {
        match self.renaming() {
            Some((held, shown)) => text.replace(&held, &shown),
            None => text.to_string(),
        }
    }

    /// The held path and the name the user knows the folder by, as text,
    /// when they differ ([`HeldDir::show`] replaces the one by the other).
    pub fn renaming(&self) -> Option<(String, String)> {
        let (_, p) = self.held.as_ref()?;
        Some((
            p.to_string_lossy().into_owned(),
            self.shown.to_string_lossy().into_owned(),
        ))
    }
}

/// Make the folder `dir` (`root` or a folder below it by its text), one
/// folder at a time from `root` down: `root` itself may be anything the
/// user named, but every folder below it must be a real folder, not a
/// symbolic link (which would put what is written there anywhere). Each
/// folder is opened from the one above it without following a link, and
/// the last is held open ([`HeldDir`]). Errors name the folder.
pub fn make_dirs_below(root: &Path, dir: &Path) -> Result<HeldDir, DirError> {
    std::fs::create_dir_all(root).map_err(|error| DirError::Create {
        dir: root.to_path_buf(),
        error,
    })?;
    let rest = dir.strip_prefix(root).map_err(|_| DirError::NotInside {
        dir: dir.to_path_buf(),
        root: root.to_path_buf(),
    })?;
    let mut at = root.to_path_buf();
    let mut parts = Vec::new();
    for c in rest.components() {
        let Component::Normal(part) = c else {
            return Err(DirError::NotPlain {
                dir: dir.to_path_buf(),
                root: root.to_path_buf(),
            });
        };
        at.push(part);
        parts.push(part);
    }
    let link = |at: &Path| DirError::Link {
        at: at.to_path_buf(),
        root: root.to_path_buf(),
    };
    #[cfg(target_os = "linux")]
    {
        let held = held::open_below(root, &parts, link)?;
        let proc_path = PathBuf::from(format!("/proc/self/fd/{}", {
            use std::os::fd::AsRawFd as _;
            held.as_raw_fd()
        }));
        if std::fs::metadata(&proc_path).is_ok_and(|m| m.is_dir()) {
            return Ok(HeldDir {
                shown: at,
                held: Some((held, proc_path)),
            });
        }
        // Without /proc the checked path is used (checked again below).
    }
    let mut at = root.to_path_buf();
    let not_folder = |at: &Path| DirError::NotFolder {
        at: at.to_path_buf(),
    };
    let read = |at: &Path| {
        let at = at.to_path_buf();
        move |error| DirError::Read { at, error }
    };
    for part in parts {
        at.push(part);
        match std::fs::symlink_metadata(&at) {
            Ok(m) if m.file_type().is_symlink() => return Err(link(&at)),
            Ok(m) if m.is_dir() => {}
            Ok(_) => return Err(not_folder(&at)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                match std::fs::create_dir(&at) {
                    Ok(()) => {}
                    // Made meanwhile by another job: checked on the next
                    // pass of the loop's test below.
                    Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                    Err(error) => {
                        return Err(DirError::Create {
                            dir: at.clone(),
                            error,
                        })
                    }
                }
                let m = std::fs::symlink_metadata(&at).map_err(read(&at))?;
                if !m.is_dir() || m.file_type().is_symlink() {
                    return Err(not_folder(&at));
                }
            }
            Err(e) => return Err(read(&at)(e)),
        }
    }
    Ok(HeldDir {
        shown: at,
        held: None,
    })
}

/// Why a folder below the output folder cannot be made or used; every
/// message names the folder.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DirError {
    /// The folder cannot be created.
    #[error("{}: cannot create the folder: {error}", dir.display())]
    Create {
        /// The folder.
        dir: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// The folder is not below the output folder.
    #[error("{}: not inside the output folder {}", dir.display(), root.display())]
    NotInside {
        /// The folder.
        dir: PathBuf,
        /// The output folder.
        root: PathBuf,
    },
    /// The path below the output folder has `..` or a root.
    #[error("{}: not a plain folder below {}", dir.display(), root.display())]
    NotPlain {
        /// The folder.
        dir: PathBuf,
        /// The output folder.
        root: PathBuf,
    },
    /// A symbolic link on the way down.
    #[error("{}: a symbolic link inside the output folder {} (not written through)", at.display(), root.display())]
    Link {
        /// The link.
        at: PathBuf,
        /// The output folder.
        root: PathBuf,
    },
    /// A file where a folder goes.
    #[error("{}: not a folder", at.display())]
    NotFolder {
        /// The path.
        at: PathBuf,
    },
    /// A folder that cannot be examined.
    #[error("{}: cannot read: {error}", at.display())]
    Read {
        /// The folder.
        at: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// A folder that cannot be opened.
    #[error("{}: cannot open the folder: {error}", at.display())]
    Open {
        /// The folder.
        at: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// A folder name with a NUL byte.
    #[error("{}: a folder name with a NUL byte", at.display())]
    NulName {
        /// The path.
        at: PathBuf,
    },
}

/// Descending folder by folder through descriptors (`mkdirat`, then
/// `openat` with `O_NOFOLLOW | O_DIRECTORY`): no folder's name is looked up
/// again after it was checked.
#[cfg(target_os = "linux")]
mod held {
    use std::ffi::{CString, OsStr};
    use std::fs::File;
    use std::os::fd::{AsRawFd as _, FromRawFd as _};
    use std::os::unix::ffi::OsStrExt as _;
    use std::path::{Path, PathBuf};

    use super::DirError;

    fn open_dir_at(dir: &File, name: &CString) -> std::io::Result<File> {
        // SAFETY: `openat` on a descriptor `dir` owns and a NUL-terminated
        // name; the returned descriptor is owned by the new `File`.
        let fd = unsafe {
            libc::openat(
                dir.as_raw_fd(),
                name.as_ptr(),
                libc::O_RDONLY | libc::O_DIRECTORY | libc::O_NOFOLLOW | libc::O_CLOEXEC,
            )
        };
        if fd < 0 {
            return Err(std::io::Error::last_os_error());
        }
        // SAFETY: `fd` is a fresh descriptor nothing else owns.
        Ok(unsafe { File::from_raw_fd(fd) })
    }

    fn is_link_at(dir: &File, name: &CString) -> bool {
        // SAFETY: `fstatat` writes into a zeroed `stat` this function owns.
        unsafe {
            let mut st: libc::stat = std::mem::zeroed();
            libc::fstatat(
                dir.as_raw_fd(),
                name.as_ptr(),
                &mut st,
                libc::AT_SYMLINK_NOFOLLOW,
            ) == 0
                && (st.st_mode & libc::S_IFMT) == libc::S_IFLNK
        }
    }

    pub(super) fn open_below(
        root: &Path,
        parts: &[&OsStr],
        link: impl Fn(&Path) -> DirError,
    ) -> Result<File, DirError> {
        let open = |at: &Path| {
            let at = at.to_path_buf();
            move |error| DirError::Open { at, error }
        };
        let mut dir = File::open(root).map_err(open(root))?;
        let mut at: PathBuf = root.to_path_buf();
        for part in parts {
            at.push(part);
            let name =
                CString::new(part.as_bytes()).map_err(|_| DirError::NulName { at: at.clone() })?;
            // SAFETY: `mkdirat` on a descriptor `dir` owns and a
            // NUL-terminated name.
            if unsafe { libc::mkdirat(dir.as_raw_fd(), name.as_ptr(), 0o777) } != 0 {
                let e = std::io::Error::last_os_error();
                if e.kind() != std::io::ErrorKind::AlreadyExists {
                    return Err(DirError::Create {
                        dir: at.clone(),
                        error: e,
                    });
                }
            }
            dir = match open_dir_at(&dir, &name) {
                Ok(d) => d,
                Err(_) if is_link_at(&dir, &name) => return Err(link(&at)),
                Err(e) if e.raw_os_error() == Some(libc::ENOTDIR) => {
                    return Err(DirError::NotFolder { at: at.clone() })
                }
                Err(e) => return Err(open(&at)(e)),
            };
        }
        Ok(dir)
    }
}

/// Whether `a` and `b` name the same file: the same file on disk when both
/// exist (links followed), else the same name in the same real folder.
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
        use std::os::unix::fs::MetadataExt as _;
        return x.dev() == y.dev() && x.ino() == y.ino();
    }
    let real = |p: &Path| -> Option<PathBuf> {
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty());
        let dir = dir.unwrap_or(Path::new(".")).canonicalize().ok()?;
        Some(dir.join(p.file_name()?))
    };
    match (real(a), real(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporaries_never_follow_a_planted_link() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim.txt");
        std::fs::write(&victim, b"precious").unwrap();
        let out = dir.path().join("a.glb");
        // Links planted under many names a temporary could take: none is
        // written through (the names are random; each try is exclusive).
        for i in 0..64 {
            let name = format!(".a.glb{TEMP_MARK}{}-{i:016x}", std::process::id());
            std::os::unix::fs::symlink(&victim, dir.path().join(name)).unwrap();
        }
        write_atomic(&out, b"new").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
        assert_eq!(std::fs::read(&out).unwrap(), b"new");
        assert!(!std::fs::symlink_metadata(&out)
            .unwrap()
            .file_type()
            .is_symlink());
        // A link at the target itself is replaced, not written through.
        let out2 = dir.path().join("b.glb");
        std::os::unix::fs::symlink(&victim, &out2).unwrap();
        write_atomic(&out2, b"new").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
        assert!(!std::fs::symlink_metadata(&out2)
            .unwrap()
            .file_type()
            .is_symlink());
        // Two temporaries of one target never share a name.
        let (a, _) = create_temp(&out).unwrap();
        let (b, _) = create_temp(&out).unwrap();
        assert_ne!(a, b);
    }

    #[test]
    fn a_copy_over_the_cap_is_refused_by_its_length_before_reading() {
        let dir = tempfile::tempdir().unwrap();
        let big = dir.path().join("big.bin");
        // A sparse file: its length alone is over the cap.
        std::fs::File::create(&big)
            .unwrap()
            .set_len(5 << 30)
            .unwrap();
        let out = dir.path().join("out");
        std::fs::create_dir(&out).unwrap();
        let err = copy_temp(&File::open(&big).unwrap(), &out.join("big.bin"), 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(err.contains("5368709120 bytes"), "{err}");
        assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0);
        // Within the cap the copy is whole.
        let small = dir.path().join("small.bin");
        std::fs::write(&small, vec![7u8; 100_000]).unwrap();
        let (tmp, n) = copy_temp(
            &File::open(&small).unwrap(),
            &out.join("small.bin"),
            1 << 20,
        )
        .unwrap();
        std::fs::rename(tmp, out.join("small.bin")).unwrap();
        assert_eq!(n, 100_000);
        assert_eq!(
            std::fs::read(out.join("small.bin")).unwrap(),
            vec![7u8; 100_000]
        );
    }

    #[test]
    fn the_same_file_by_any_name() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.obj");
        std::fs::write(&a, b"v 0 0 0").unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        assert!(same_file(&a, &dir.path().join("sub/../a.obj")));
        std::os::unix::fs::symlink(&a, dir.path().join("link.obj")).unwrap();
        assert!(same_file(&a, &dir.path().join("link.obj")));
        let new = dir.path().join("new.glb");
        assert!(same_file(&new, &dir.path().join("sub/../new.glb")));
        assert!(!same_file(&new, &a));
    }

    #[test]
    fn folders_below_the_root_are_never_links() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("out");
        let elsewhere = dir.path().join("elsewhere");
        std::fs::create_dir_all(&elsewhere).unwrap();
        make_dirs_below(&root, &root.join("a/b")).unwrap();
        assert!(root.join("a/b").is_dir());
        std::os::unix::fs::symlink(&elsewhere, root.join("a/link")).unwrap();
        let err = make_dirs_below(&root, &root.join("a/link/c"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("symbolic link"), "{err}");
        assert!(!elsewhere.join("c").exists());
        assert!(make_dirs_below(&root, &dir.path().join("x")).is_err());
        assert!(make_dirs_below(&root, &root.join("a/../../x")).is_err());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_folder_swapped_for_a_link_after_the_check_is_not_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("out");
        let elsewhere = dir.path().join("elsewhere");
        std::fs::create_dir_all(&elsewhere).unwrap();
        let held = make_dirs_below(&root, &root.join("a/b")).unwrap();
        assert_eq!(held.shown(), root.join("a/b"));
        // The checked folder `a` is moved away and a link to `elsewhere`
        // put in its place before anything is written.
        std::fs::rename(root.join("a"), root.join("moved")).unwrap();
        std::os::unix::fs::symlink(&elsewhere, root.join("a")).unwrap();
        std::fs::create_dir(elsewhere.join("b")).unwrap();
        write_atomic(&held.path().join("x.glb"), b"new").unwrap();
        assert!(!elsewhere.join("b/x.glb").exists());
        assert_eq!(std::fs::read(root.join("moved/b/x.glb")).unwrap(), b"new");
        // Messages speak of the folder by the name the user gave.
        let held_text = held.path().join("x.glb").display().to_string();
        assert_eq!(
            held.show(&format!("{held_text}: cannot write")),
            format!("{}: cannot write", root.join("a/b/x.glb").display())
        );
        // And a link met on the way down is refused as before.
        let err = make_dirs_below(&root, &root.join("a/b"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("symbolic link"), "{err}");
    }
}
