//! A batch's run: what is up to date ([`triage`]), and the rest cracked or
//! copied in parallel ([`execute`]), each asset's failure its own.

use super::inputs::{scan_references, slash_path, source_rel};
use super::state::{action_fingerprint, asset_key, State};
use super::{Action, Asset, Options, Outcome, Plan, Produced, Status, STATE_FILE};
use crate::error::BatchError;
use crate::io::IoError;
use crate::pipeline::{crack_file, Config};
use crate::{Error, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Told what a batch is doing, from its worker threads. Every method has
/// an empty default.
pub trait BatchObserver: Sync {
    /// Worker `worker` starts `asset`.
    fn start(&self, _worker: usize, _asset: &Asset) {}
    /// A stage of `asset` starts (`read`, `simulate body: round 3, 120
    /// cracks`, `copy`...).
    fn stage(&self, _worker: usize, _asset: &Asset, _stage: &str) {}
    /// `asset` ended.
    fn done(&self, _worker: usize, _asset: &Asset, _outcome: &Outcome) {}
}

impl BatchObserver for () {}

/// The state of the output folder and what is left to do.
pub struct Triage {
    /// Indices of the assets to run, in plan order.
    pub todo: Vec<usize>,
    /// One per asset: skipped and up-to-date ones decided, the rest
    /// pending.
    pub outcomes: Vec<Outcome>,
    state: State,
}

/// Decide which assets are up to date (their outputs there, their key in
/// the state file unchanged) unless `force`. With `sweep`, first remove the
/// temporary files a killed run left in the output folder.
pub fn triage(plan: &Plan, options: &Options, sweep: bool) -> Triage {
    let out = &options.out;
    if sweep {
        crate::io::gltf_write::remove_stale_temps(out, true);
    }
    let state = State::load(&out.join(STATE_FILE));
    let mut todo: Vec<usize> = Vec::new();
    let mut outcomes: Vec<Outcome> = vec![Outcome::default(); plan.assets.len()];
    for (i, asset) in plan.assets.iter().enumerate() {
        if asset.action == Action::Skip {
            outcomes[i].status = Status::Skipped;
            continue;
        }
        let fp = fingerprint(plan, options, asset);
        let fresh = (!options.force)
            .then(|| state.entry(&out_rel(out, &asset.output)))
            .flatten()
            .filter(|e| {
                e.outputs.iter().all(|o| out.join(o).is_file())
                    && asset_key(&asset.input, &e.sources, &fp).as_deref() == Some(e.key.as_str())
            })
            .is_some();
        if fresh {
            outcomes[i].status = Status::UpToDate;
        } else {
            todo.push(i);
        }
    }
    Triage {
        todo,
        outcomes,
        state,
    }
}

fn fingerprint(plan: &Plan, options: &Options, asset: &Asset) -> Vec<u8> {
    action_fingerprint(
        asset,
        &plan.pipes,
        options.format,
        options.weld.relative_tolerance,
    )
}

/// Run the assets `triage` left to do on `options.jobs` threads (0: one
/// per core), recording each success in the state file; returns every
/// asset's outcome and the run's wall-clock seconds. An asset's failure
/// (or a panic, which is a bug) fails that asset, not the batch; under
/// `fail_fast` no asset starts after one failed.
///
/// # Errors
/// [`Error::Batch`] when the output folder cannot be made or the threads
/// cannot be started.
pub fn execute(
    plan: &Plan,
    options: &Options,
    triage: Triage,
    observer: &dyn BatchObserver,
) -> Result<(Vec<Outcome>, f64)> {
    let out = &options.out;
    std::fs::create_dir_all(out).map_err(|error| BatchError::CreateOutput {
        out: out.clone(),
        error,
    })?;
    let started = Instant::now();
    let jobs = options.workers();
    let Triage {
        todo,
        outcomes,
        state,
    } = triage;
    let state_path = out.join(STATE_FILE);
    let state = Mutex::new(state);
    let outcomes_m = Mutex::new(outcomes);
    let stop = AtomicBool::new(false);
    // `jobs` threads in all: assets are tasks of one pool, and an asset's
    // own parallel loops run on the same threads, so they help when fewer
    // assets than threads are left.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|error| BatchError::Threads { jobs, error })?;
    pool.install(|| {
        use rayon::prelude::*;
        todo.par_iter().with_max_len(1).for_each(|&i| {
            if stop.load(Ordering::SeqCst) {
                return;
            }
            let worker = rayon::current_thread_index().unwrap_or(0) % jobs;
            let asset = &plan.assets[i];
            observer.start(worker, asset);
            let t0 = Instant::now();
            let on_stage = |s: &str| observer.stage(worker, asset, s);
            // The asset and the files it refers to, hashed before it is
            // cracked: if any changes while it runs, its output is from
            // bytes that are no longer there, and it stays out of date.
            let fp = fingerprint(plan, options, asset);
            let scanned = scanned_sources(&asset.input);
            let before = asset_key(&asset.input, &scanned, &fp);
            log::info!("{}: started (its files hashed)", asset.rel);
            // A panic is a bug; it fails this asset, not the batch.
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                run_asset(asset, plan, options, &on_stage)
            }))
            .unwrap_or_else(|p| {
                let payload = p
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                Err(AssetError::Panic { payload })
            });
            let seconds = t0.elapsed().as_secs_f64();
            let outcome = match result {
                Ok(done) => {
                    let after = asset_key(&asset.input, &scanned, &fp);
                    let unchanged = before.is_some() && after == before;
                    // The key is over the files the run read: the scan's
                    // (just hashed) unless the reader's differ.
                    let key = if done.sources == scanned {
                        after
                    } else {
                        asset_key(&asset.input, &done.sources, &fp)
                    }
                    .filter(|_| unchanged);
                    if let Some(key) = key {
                        let mut st = state.lock().unwrap_or_else(|p| p.into_inner());
                        let outputs = done
                            .outputs
                            .iter()
                            .map(|o| out_rel(out, Path::new(o)))
                            .collect();
                        st.set(out_rel(out, &asset.output), key, done.sources, outputs);
                        if let Err(e) = st.save_soon(&state_path) {
                            log::warn!("{e}");
                        }
                    }
                    Outcome {
                        status: done.status,
                        error: None,
                        warning: (!unchanged).then(|| {
                            "the asset or a file it refers to changed while it was processed; \
                             its output is left out of date (the next run processes it again)"
                                .to_string()
                        }),
                        seconds,
                        produced: done.produced,
                    }
                }
                Err(e) => {
                    if options.fail_fast {
                        stop.store(true, Ordering::SeqCst);
                    }
                    Outcome {
                        status: Status::Failed,
                        error: Some(e.to_string()),
                        warning: None,
                        seconds,
                        produced: Produced::Nothing,
                    }
                }
            };
            observer.done(worker, asset, &outcome);
            outcomes_m.lock().unwrap_or_else(|p| p.into_inner())[i] = outcome;
        });
    });
    let mut state = state.into_inner().unwrap_or_else(|p| p.into_inner());
    if !state.updated.is_empty() {
        if let Err(e) = state.save(&state_path) {
            log::warn!("{e}");
        }
    }
    let mut outcomes = outcomes_m.into_inner().unwrap_or_else(|p| p.into_inner());
    for &i in &todo {
        if outcomes[i].status == Status::Pending {
            outcomes[i].status = Status::NotRun;
        }
    }
    Ok((outcomes, started.elapsed().as_secs_f64()))
}

/// A written file's path relative to the output folder (as given when it
/// is not inside it).
fn out_rel(out: &Path, file: &Path) -> String {
    match file.strip_prefix(out) {
        Ok(r) => slash_path(r),
        Err(_) => file.display().to_string(),
    }
}

/// The files `input` refers to (as the batch's reference scan finds them),
/// relative to its folder, sorted.
fn scanned_sources(input: &Path) -> Vec<String> {
    let mut out: Vec<String> = scan_references(input)
        .iter()
        .filter_map(|p| source_rel(input, p))
        .collect();
    out.sort();
    out.dedup();
    out
}

/// What one asset's run did.
struct Done {
    status: Status,
    produced: Produced,
    /// The files it read, relative to its folder.
    sources: Vec<String>,
    /// The files it wrote.
    outputs: Vec<String>,
}

/// Forwards a run's stages and rounds to a batch's stage callback.
struct Stages<'a>(&'a dyn Fn(&str));

impl crate::pipeline::Observer for Stages<'_> {
    fn stage(&mut self, name: &str) {
        (self.0)(name);
    }

    fn round(&mut self, mesh: &str, round: usize, _max: usize, cracks: usize, _steps: usize) {
        (self.0)(&format!("simulate {mesh}: round {round}, {cracks} cracks"));
    }
}

/// Error text: the error and its causes, as `a: b: c`.
fn chain(e: &Error) -> String {
    let mut s = e.to_string();
    let mut cause = std::error::Error::source(e);
    while let Some(c) = cause {
        s.push_str(&format!(": {c}"));
        cause = c.source();
    }
    s
}

/// Why one asset of a batch failed.
#[derive(Debug, thiserror::Error)]
enum AssetError {
    /// Its folder below the output folder cannot be made.
    #[error(transparent)]
    Folder(#[from] crate::io::write::DirError),
    /// Cracking or copying it failed. The message holds the error's causes,
    /// and speaks of a held output folder by the name the user gave
    /// (`shown`: the held path and that name, [`HeldDir::renaming`]).
    ///
    /// [`HeldDir::renaming`]: crate::io::write::HeldDir::renaming
    #[error("{}", failed(error, shown.as_ref()))]
    Failed {
        /// The error.
        error: Box<Error>,
        /// The held path and its name.
        shown: Option<(String, String)>,
    },
    /// A panic (a bug), with its message.
    #[error("internal error (please report it): {payload}")]
    Panic {
        /// The panic's message (empty when it was not text).
        payload: String,
    },
}

/// The text of [`AssetError::Failed`].
fn failed(error: &Error, shown: Option<&(String, String)>) -> String {
    let text = chain(error);
    match shown {
        Some((held, name)) => text.replace(held.as_str(), name),
        None => text,
    }
}

/// Crack or copy one asset.
fn run_asset(
    asset: &Asset,
    plan: &Plan,
    options: &Options,
    on_stage: &dyn Fn(&str),
) -> std::result::Result<Done, AssetError> {
    match &asset.action {
        Action::Crack(k) => {
            // Every folder from the output folder down to the output's
            // is a real folder: a link there would put the output (and its
            // side files) anywhere.
            let dir = asset.output.parent().unwrap_or(Path::new("."));
            let held = crate::io::write::make_dirs_below(&options.out, dir)?;
            let output = match asset.output.file_name() {
                Some(name) => held.path().join(name),
                None => asset.output.clone(),
            };
            let spec = &plan.pipes[*k];
            let config = Config {
                pipeline: spec.pipeline.clone(),
                weld: options.weld.clone(),
                asset: asset.input.clone(),
                frames: None,
                output,
                read: options.read,
            };
            let prefix_images = options.format == super::OutFormat::Gltf;
            let mut report = crack_file(
                config,
                spec.dir.as_deref(),
                prefix_images,
                &mut Stages(on_stage),
            )
            .map_err(|error| AssetError::Failed {
                error: Box::new(error),
                shown: held.renaming(),
            })?;
            report.output = held.show(&report.output);
            for f in &mut report.files {
                *f = held.show(f);
            }
            let sources = report
                .sources
                .iter()
                .filter_map(|s| source_rel(&asset.input, Path::new(s)))
                .collect();
            let outputs = report.files.clone();
            Ok(Done {
                status: Status::Cracked,
                produced: Produced::Cracked(Box::new(report)),
                sources,
                outputs,
            })
        }
        Action::Copy => {
            on_stage("copy");
            copy_asset(asset, &options.out).map_err(|error| AssetError::Failed {
                error: Box::new(error),
                shown: None,
            })
        }
        Action::Skip => Ok(Done {
            status: Status::Skipped,
            produced: Produced::Nothing,
            sources: Vec::new(),
            outputs: Vec::new(),
        }),
    }
}

/// Copy an asset and every file it references, to the same places
/// relative to it (found without decoding the asset, so assets crackle
/// cannot read, compressed ones say, are copied too). Every file is read
/// as the reader reads it: a regular file whose real path lies inside the
/// asset's folder (a link out of it, to another file or to `/proc`, is
/// refused and the asset fails), within the reader's size cap; it is
/// written below the output folder through no symbolic link.
fn copy_asset(asset: &Asset, out_root: &Path) -> Result<Done> {
    use crate::io::paths::{real_file_inside, MAX_MODEL_BYTES};
    let in_dir = asset.input.parent().unwrap_or(Path::new("."));
    let out_dir = asset.output.parent().unwrap_or(Path::new("."));
    let mut sources: Vec<String> = Vec::new();
    for s in scan_references(&asset.input) {
        let Some(rel) = source_rel(&asset.input, &s) else {
            continue;
        };
        // A file the asset names but the folder does not hold: the copy
        // would name a file the output does not have.
        if let Err(e) = std::fs::symlink_metadata(&s) {
            return Err(BatchError::MissingSource {
                source_file: rel,
                error: e,
            }
            .into());
        }
        sources.push(rel);
    }
    let mut files: Vec<(PathBuf, PathBuf, String)> =
        vec![(asset.input.clone(), asset.output.clone(), asset.rel.clone())];
    for s in &sources {
        files.push((in_dir.join(s), out_dir.join(s), s.clone()));
    }
    // Every file copied to a temporary first, then all put in place: a
    // file that cannot be read (changed meanwhile, say) leaves no part of
    // the asset in the output.
    let mut staged: Vec<(PathBuf, PathBuf, PathBuf)> = Vec::new();
    let mut held_dirs = Vec::new();
    let mut outputs = Vec::new();
    let mut bytes = 0u64;
    let copied = (|| -> Result<()> {
        for (from, to, name) in &files {
            let real =
                real_file_inside(in_dir, from, name).map_err(|error| BatchError::Source {
                    input: asset.input.clone(),
                    error,
                })?;
            let dir = to.parent().unwrap_or(Path::new("."));
            let held = crate::io::write::make_dirs_below(out_root, dir).map_err(IoError::from)?;
            let src =
                crate::io::paths::open_no_follow(&real).map_err(|error| BatchError::ReadCopy {
                    from: from.clone(),
                    error,
                })?;
            let at = match to.file_name() {
                Some(name) => held.path().join(name),
                None => to.clone(),
            };
            let (tmp, n) =
                crate::io::write::copy_temp(&src, &at, MAX_MODEL_BYTES).map_err(|error| {
                    BatchError::Copy {
                        from: from.clone(),
                        to: to.clone(),
                        error,
                    }
                })?;
            // The held folders stay open (and their paths valid) until
            // every file is in place.
            staged.push((tmp, at, to.clone()));
            held_dirs.push(held);
            bytes += n;
            outputs.push(to.display().to_string());
        }
        for (tmp, at, to) in &staged {
            std::fs::rename(tmp, at).map_err(|error| BatchError::WriteCopy {
                to: to.clone(),
                error,
            })?;
        }
        Ok(())
    })();
    if let Err(e) = copied {
        for (tmp, _, _) in &staged {
            let _ = std::fs::remove_file(tmp);
        }
        return Err(e);
    }
    Ok(Done {
        status: Status::Copied,
        produced: Produced::Copied {
            files: outputs.clone(),
            bytes,
        },
        sources,
        outputs,
    })
}
