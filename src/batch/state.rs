//! What a batch remembers between runs: each asset's key (its content, its sources' and the action's fingerprint), the state file and its lock, and atomic copies.

use super::{Action, Asset, OutFormat, PipeSpec};
use crate::error::BatchError;
use crate::io::paths::{real_file_inside, stream_capped, MAX_MODEL_BYTES};
use crate::Result;
use sha2::{Digest, Sha256};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// 64-bit FNV-1a: the shard of an asset is the hash of its relative path,
/// so adding or removing assets does not move the others between shards.
pub(crate) fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// What, besides the input files, decides the asset's output.
pub(crate) fn action_fingerprint(
    asset: &Asset,
    pipes: &[PipeSpec],
    format: OutFormat,
    weld: f64,
) -> Vec<u8> {
    let mut fp = format!(
        "crackle {} {} batch-state 1\nformat {format:?}\nweld {weld:?}\n",
        env!("CARGO_PKG_VERSION"),
        tool_id()
    )
    .into_bytes();
    match &asset.action {
        Action::Crack(k) => {
            fp.extend_from_slice(b"crack\n");
            fp.extend_from_slice(&pipes[*k].fingerprint);
        }
        Action::Copy => fp.extend_from_slice(b"copy\n"),
        Action::Skip => fp.extend_from_slice(b"skip\n"),
    }
    fp
}

/// A hash of this executable: a rebuilt tool (new code, same version
/// number) does not take older outputs as its own.
pub(crate) fn tool_id() -> &'static str {
    static ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    ID.get_or_init(|| {
        std::env::current_exe()
            .and_then(std::fs::read)
            .map(|b| format!("{:x}", Sha256::digest(&b)))
            .unwrap_or_default()
    })
}

/// Hash of the action, the input's bytes and each source's relative path
/// and bytes; `None` when the input cannot be read.
pub(crate) fn asset_key(input: &Path, sources: &[String], fingerprint: &[u8]) -> Option<String> {
    let mut h = Sha256::new();
    h.update((fingerprint.len() as u64).to_le_bytes());
    h.update(fingerprint);
    // Streamed: a large (or sparse) buffer is hashed in constant memory,
    // whatever `--max-memory` allows the reader to hold.
    stream_capped(input, MAX_MODEL_BYTES, "model file", &mut |b| h.update(b)).ok()?;
    let dir = input.parent().unwrap_or(Path::new("."));
    for s in sources {
        h.update((s.len() as u64).to_le_bytes());
        h.update(s.as_bytes());
        // Only what the reader itself would read: inside the folder, a
        // regular file, within the largest size read.
        // Hashed aside first: a file that cannot be read in full counts as
        // missing, not as the bytes read before the error.
        let mut file = Sha256::new();
        let read = real_file_inside(dir, &dir.join(s), s)
            .ok()
            .and_then(|p| stream_capped(&p, MAX_MODEL_BYTES, "file", &mut |b| file.update(b)).ok());
        match read {
            Some(_) => h.update(file.finalize()),
            None => h.update(u64::MAX.to_le_bytes()),
        }
    }
    Some(format!("{:x}", h.finalize()))
}

/// What the state file records of an asset (paths relative to the output
/// folder; sources relative to the asset's folder).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub(crate) struct StateEntry {
    pub(crate) key: String,
    pub(crate) sources: Vec<String>,
    pub(crate) outputs: Vec<String>,
}

/// The state file: per output path, the key of its last successful build.
#[derive(Default, serde::Serialize, serde::Deserialize)]
pub(crate) struct State {
    pub(crate) version: u32,
    pub(crate) assets: BTreeMap<String, StateEntry>,
    /// Entries this run set (merged into the file as it is on disk, so
    /// batches sharing an output folder keep each other's entries).
    #[serde(skip)]
    pub(crate) updated: BTreeSet<String>,
    /// When this run last wrote the file.
    #[serde(skip)]
    pub(crate) saved: Option<Instant>,
}

impl State {
    pub(crate) fn load(path: &Path) -> State {
        std::fs::read(path)
            .ok()
            .and_then(|b| serde_json::from_slice::<State>(&b).ok())
            .filter(|s| s.version == 1)
            .unwrap_or(State {
                version: 1,
                ..Default::default()
            })
    }

    pub(crate) fn entry(&self, output: &str) -> Option<&StateEntry> {
        self.assets.get(output)
    }

    pub(crate) fn set(
        &mut self,
        output: String,
        key: String,
        sources: Vec<String>,
        outputs: Vec<String>,
    ) {
        self.updated.insert(output.clone());
        self.assets.insert(
            output,
            StateEntry {
                key,
                sources,
                outputs,
            },
        );
    }

    /// [`State::save`] unless the last save was under a second ago (the
    /// file is rewritten whole: saving after every one of many small assets
    /// would cost more than the assets).
    pub(crate) fn save_soon(&mut self, path: &Path) -> Result<()> {
        if self.saved.is_some_and(|t| t.elapsed().as_secs_f64() < 1.0) {
            return Ok(());
        }
        self.save(path)
    }

    /// Merge this run's entries into the file on disk, under a lock, and
    /// write it through a temporary file and a rename, so a killed batch
    /// leaves the last complete state and concurrent batches (shards into
    /// one folder) lose nothing.
    pub(crate) fn save(&mut self, path: &Path) -> Result<()> {
        let err = |error: std::io::Error| BatchError::WriteState {
            path: path.to_path_buf(),
            error,
        };
        let _lock = StateLock::acquire(path).map_err(err)?;
        let mut merged = State::load(path);
        for k in &self.updated {
            if let Some(e) = self.assets.get(k) {
                merged.assets.insert(k.clone(), e.clone());
            }
        }
        let bytes =
            serde_json::to_vec_pretty(&merged).map_err(|error| BatchError::EncodeState {
                path: path.to_path_buf(),
                error,
            })?;
        crate::io::write::write_atomic(path, &bytes).map_err(err)?;
        self.saved = Some(Instant::now());
        Ok(())
    }
}

/// An exclusive lock on a state file: a lock file created with
/// `create_new` (atomic), removed when dropped. A lock older than a minute
/// is taken to be left by a killed run and removed.
pub(crate) struct StateLock(PathBuf);

impl StateLock {
    pub(crate) fn acquire(state: &Path) -> std::io::Result<StateLock> {
        let path = state.with_file_name(".crackle-batch.lock");
        let start = Instant::now();
        loop {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(_) => return Ok(StateLock(path)),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let stale = std::fs::metadata(&path)
                        .and_then(|m| m.modified())
                        .ok()
                        .and_then(|t| t.elapsed().ok())
                        .is_some_and(|age| age.as_secs() > 60);
                    if stale {
                        let _ = std::fs::remove_file(&path);
                    } else if start.elapsed().as_secs() > 120 {
                        return Err(e);
                    } else {
                        std::thread::sleep(std::time::Duration::from_millis(5));
                    }
                }
                Err(e) => return Err(e),
            }
        }
    }
}

impl Drop for StateLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}
