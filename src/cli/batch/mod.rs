//! `crackle batch`: crack a whole asset folder into a mirrored output tree.
//!
//! Inputs are files, folders (recursive with `-r`) or globs. Each asset gets
//! an action from `--rules` (first matching glob wins) or the one pipeline
//! of `--pipeline`/`--preset`: crack, copy or skip. Assets run in parallel
//! (`--jobs`); each one's output is written to a temporary file and renamed,
//! and a state file in the output folder records a hash of every input
//! byte the output depends on (the asset, the files it references, the
//! pipeline, the tool version), so the next run redoes only what changed.
//!
//! Exit codes: 0 every asset succeeded (or was up to date), 1 an asset
//! failed, 2 bad usage or configuration, 3 nothing to do.

use crate::cli::crack::{CrackArgs, SimArgs};
use crate::cli::UsageError;
use crackle::mesh::WeldOptions;
use crackle::pipeline::Pipeline;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

mod emit;
use emit::*;

mod progress;
use progress::*;

mod state;
use state::*;

mod inputs;
use inputs::*;

/// Name of the state file in the output folder.
pub const STATE_FILE: &str = ".crackle-batch.json";

/// Build files `--emit` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Emit {
    /// A Ninja build file.
    Ninja,
    /// A Makefile.
    Make,
}

/// Output format of cracked assets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum OutFormat {
    /// Binary glTF (one file).
    Glb,
    /// glTF JSON with its .bin and images beside it.
    Gltf,
}

/// Options of the batch command.
pub struct BatchArgs<'a> {
    pub inputs: &'a [String],
    pub out: &'a Path,
    pub recursive: bool,
    pub format: OutFormat,
    pub sim: &'a SimArgs,
    pub rules: Option<&'a Path>,
    pub jobs: usize,
    pub fail_fast: bool,
    pub force: bool,
    pub report: Option<&'a Path>,
    pub dry_run: bool,
    pub shard: Option<&'a str>,
    pub emit: Option<Emit>,
    pub weld_tolerance: f64,
    pub weld: WeldOptions,
    pub quiet: bool,
    /// How inputs are read.
    pub read: crackle::io::ReadOptions,
}

/// What to do with an asset.
#[derive(Clone, Debug, PartialEq)]
enum Action {
    /// Crack with pipeline `k` of the plan.
    Crack(usize),
    /// Copy unchanged (with the files it references).
    Copy,
    /// Leave out.
    Skip,
}

/// A pipeline an action uses.
struct PipeSpec {
    /// How the user named it (`preset mud`, `pipeline rules/glaze.toml`).
    label: String,
    file: Option<PathBuf>,
    preset: Option<String>,
    /// The rule's own `set` list (before the command line's).
    sets: Vec<String>,
    pipeline: Pipeline,
    dir: Option<PathBuf>,
    /// Everything about the pipeline that changes an output.
    fingerprint: Vec<u8>,
}

/// One asset of the batch.
#[derive(Clone, Debug)]
struct Asset {
    input: PathBuf,
    /// Path relative to the input root it was found under ('/'-separated).
    rel: String,
    action: Action,
    /// Where it goes (for a skip: nothing).
    output: PathBuf,
    /// The rule that matched (index in the rules file), if any.
    rule: Option<usize>,
}

/// The rules file.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RulesFile {
    /// What happens to assets no rule matches: "skip" (default) or "copy".
    #[serde(default)]
    unmatched: Option<String>,
    #[serde(default, rename = "rule")]
    rules: Vec<RuleSpec>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RuleSpec {
    glob: String,
    #[serde(default)]
    action: Option<String>,
    #[serde(default)]
    preset: Option<String>,
    #[serde(default)]
    pipeline: Option<PathBuf>,
    #[serde(default)]
    set: Vec<String>,
}

/// Result of one asset.
#[derive(Clone, Debug, Default)]
struct Outcome {
    /// done, up-to-date, copied, skipped, failed, not-run.
    status: &'static str,
    error: Option<String>,
    seconds: f64,
    report: Value,
}

pub fn run(a: BatchArgs) -> anyhow::Result<u8> {
    let shard = a.shard.map(parse_shard).transpose().map_err(UsageError)?;
    if a.rules.is_some() && a.sim.has_choice() {
        return Err(UsageError(
            "--rules chooses the pipeline of each asset; it cannot be combined with --pipeline or --preset".into(),
        )
        .into());
    }
    let out_canon = canonical_or_lexical(a.out);
    for spec in a.inputs {
        let p = Path::new(spec);
        if p.is_dir() && canonical_or_lexical(p) == out_canon {
            return Err(UsageError(format!(
                "--out {} is the input folder {spec}: the outputs would be read as inputs next time; choose another folder (one inside it is fine)",
                a.out.display()
            ))
            .into());
        }
    }
    // ---- the assets
    let mut found = collect_inputs(a.inputs, a.recursive, &out_canon)?;
    // ---- their actions
    let (pipes, rules, unmatched) = match a.rules {
        Some(path) => load_rules(path, a.sim)?,
        None => {
            let pipeline = a.sim.pipeline()?;
            let file = a.sim.pipeline_file().map(Path::to_path_buf);
            let preset = a.sim.preset_name().map(str::to_owned);
            let label = match (&file, &preset) {
                (Some(f), _) => format!("pipeline {}", f.display()),
                (None, Some(p)) => format!("preset {p}"),
                (None, None) => "defaults".to_string(),
            };
            let dir = a.sim.pipeline_dir();
            let spec = pipe_spec(label, file, preset, Vec::new(), pipeline, dir)?;
            (vec![spec], Vec::new(), Action::Skip)
        }
    };
    for asset in &mut found {
        let (action, rule) = if a.rules.is_some() {
            match rules.iter().position(|r| r.0.matches(&asset.rel)) {
                Some(k) => (rules[k].1.clone(), Some(k)),
                None => (unmatched.clone(), None),
            }
        } else {
            (Action::Crack(0), None)
        };
        asset.action = action;
        asset.rule = rule;
        asset.output = match asset.action {
            Action::Crack(_) => {
                let ext = match a.format {
                    OutFormat::Glb => "glb",
                    OutFormat::Gltf => "gltf",
                };
                a.out.join(Path::new(&asset.rel).with_extension(ext))
            }
            Action::Copy => a.out.join(&asset.rel),
            Action::Skip => PathBuf::new(),
        };
    }
    // Collisions are checked over every shard's assets.
    check_outputs(&found)?;
    // ---- the shard
    if let Some((k, n)) = shard {
        found.retain(|x| fnv1a(x.rel.as_bytes()) % n as u64 == (k - 1) as u64);
    }
    let active: Vec<usize> = (0..found.len())
        .filter(|&i| found[i].action != Action::Skip)
        .collect();
    if let Some(emit) = a.emit {
        if active.is_empty() {
            log::warn!("nothing to do: no asset selected");
            return Ok(3);
        }
        let text = emit_build_file(emit, &a, &found, &pipes)?;
        // A closed pipe (`| head`) is not an error.
        use std::io::Write;
        let _ = std::io::stdout().lock().write_all(text.as_bytes());
        return Ok(0);
    }
    // ---- up to date? (First clear what a killed run left behind.)
    if !a.dry_run {
        crackle::io::gltf_write::remove_stale_temps(a.out, true);
    }
    let state_path = a.out.join(STATE_FILE);
    let state = State::load(&state_path);
    let mut todo: Vec<usize> = Vec::new();
    let mut outcomes: Vec<Outcome> = vec![Outcome::default(); found.len()];
    for (i, asset) in found.iter().enumerate() {
        if asset.action == Action::Skip {
            outcomes[i].status = "skipped";
            continue;
        }
        let fp = action_fingerprint(asset, &pipes, a.format, a.weld_tolerance);
        let fresh = (!a.force)
            .then(|| state.entry(&out_rel(a.out, &asset.output)))
            .flatten()
            .filter(|e| {
                e.outputs.iter().all(|o| a.out.join(o).is_file())
                    && asset_key(&asset.input, &e.sources, &fp).as_deref() == Some(e.key.as_str())
            })
            .is_some();
        if fresh {
            outcomes[i].status = "up-to-date";
        } else {
            todo.push(i);
        }
    }
    if a.dry_run {
        // A closed pipe (`| head`) ends the listing quietly.
        use std::io::Write;
        let mut so = std::io::stdout().lock();
        for (i, asset) in found.iter().enumerate() {
            let what = match (&asset.action, outcomes[i].status) {
                (Action::Skip, _) => "skip".to_string(),
                (_, "up-to-date") => "up to date".to_string(),
                (Action::Copy, _) => "copy".to_string(),
                (Action::Crack(k), _) => format!("crack ({})", pipes[*k].label),
            };
            if asset.action == Action::Skip {
                let _ = writeln!(so, "{what:<24} {}", asset.input.display());
            } else {
                let _ = writeln!(
                    so,
                    "{what:<24} {} -> {}",
                    asset.input.display(),
                    asset.output.display()
                );
            }
        }
        let _ = writeln!(
            so,
            "{} assets: {} to do, {} up to date, {} skipped",
            found.len(),
            todo.len(),
            outcomes.iter().filter(|o| o.status == "up-to-date").count(),
            outcomes.iter().filter(|o| o.status == "skipped").count()
        );
        return Ok(if active.is_empty() { 3 } else { 0 });
    }
    if active.is_empty() {
        log::warn!(
            "nothing to do: {}",
            if found.is_empty() {
                "no .obj, .gltf or .glb asset among the inputs"
            } else {
                "every asset is skipped"
            }
        );
        write_report(a.report, &a, &found, &outcomes, &pipes, 0.0)?;
        return Ok(3);
    }
    std::fs::create_dir_all(a.out).map_err(|e| {
        anyhow::anyhow!("{}: cannot create the output folder: {e}", a.out.display())
    })?;
    // ---- run
    let started = Instant::now();
    let jobs = if a.jobs == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        a.jobs
    };
    let progress = Progress::new(todo.len(), jobs, a.quiet);
    let state = Mutex::new(state);
    let outcomes_m = Mutex::new(outcomes);
    let stop = AtomicBool::new(false);
    // `jobs` threads in all: assets are tasks of one pool, and an asset's
    // own parallel loops run on the same threads, so they help when fewer
    // assets than threads are left.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| anyhow::anyhow!("cannot start {jobs} worker threads: {e}"))?;
    pool.install(|| {
        use rayon::prelude::*;
        todo.par_iter().with_max_len(1).for_each(|&i| {
            if stop.load(Ordering::SeqCst) {
                return;
            }
            let worker = rayon::current_thread_index().unwrap_or(0) % jobs;
            let asset = &found[i];
            progress.start(worker, &asset.rel);
            let t0 = Instant::now();
            let on_stage = |s: &str| progress.stage(worker, &asset.rel, s);
            // A panic is a bug; it fails this asset, not the batch.
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                run_asset(asset, &pipes, &a, &on_stage)
            }))
            .unwrap_or_else(|p| {
                let what = p
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                Err(anyhow::anyhow!("internal error (please report it): {what}"))
            });
            let seconds = t0.elapsed().as_secs_f64();
            let outcome = match result {
                Ok((status, report, sources, outputs)) => {
                    let fp = action_fingerprint(asset, &pipes, a.format, a.weld_tolerance);
                    if let Some(key) = asset_key(&asset.input, &sources, &fp) {
                        let mut st = state.lock().unwrap_or_else(|p| p.into_inner());
                        let outputs = outputs
                            .iter()
                            .map(|o| out_rel(a.out, Path::new(o)))
                            .collect();
                        st.set(out_rel(a.out, &asset.output), key, sources, outputs);
                        if let Err(e) = st.save_soon(&state_path) {
                            log::warn!("{e}");
                        }
                    }
                    Outcome {
                        status,
                        error: None,
                        seconds,
                        report,
                    }
                }
                Err(e) => {
                    if a.fail_fast {
                        stop.store(true, Ordering::SeqCst);
                    }
                    Outcome {
                        status: "failed",
                        error: Some(format!("{e:#}")),
                        seconds,
                        report: Value::Null,
                    }
                }
            };
            progress.done(worker, asset, &outcome);
            outcomes_m.lock().unwrap_or_else(|p| p.into_inner())[i] = outcome;
        });
    });
    progress.finish();
    let mut state = state.into_inner().unwrap_or_else(|p| p.into_inner());
    if !state.updated.is_empty() {
        if let Err(e) = state.save(&state_path) {
            log::warn!("{e}");
        }
    }
    let mut outcomes = outcomes_m.into_inner().unwrap_or_else(|p| p.into_inner());
    for &i in &todo {
        if outcomes[i].status.is_empty() {
            outcomes[i].status = "not-run";
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    write_report(a.report, &a, &found, &outcomes, &pipes, seconds)?;
    let count = |s: &str| outcomes.iter().filter(|o| o.status == s).count();
    let failed = count("failed");
    if !a.quiet {
        eprintln!(
            "{} assets: {} cracked, {} copied, {} up to date, {} skipped, {} failed{} ({:.1} s)",
            found.len(),
            count("cracked"),
            count("copied"),
            count("up-to-date"),
            count("skipped"),
            failed,
            match count("not-run") {
                0 => String::new(),
                n => format!(", {n} not run (--fail-fast)"),
            },
            seconds
        );
        for (asset, o) in found.iter().zip(&outcomes) {
            if let Some(e) = &o.error {
                eprintln!("error: {}: {e}", asset.input.display());
            }
        }
    }
    Ok(if failed > 0 { 1 } else { 0 })
}

/// A written file's path relative to the output folder (as given when it
/// is not inside it).
fn out_rel(out: &Path, file: &Path) -> String {
    match file.strip_prefix(out) {
        Ok(r) => slash_path(r),
        Err(_) => file.display().to_string(),
    }
}

/// A referenced file's path relative to the asset's folder.
fn source_rel(input: &Path, source: &Path) -> Option<String> {
    let dir = input.parent().unwrap_or(Path::new("."));
    source.strip_prefix(dir).ok().map(slash_path).or_else(|| {
        let (d, s) = (canonical_or_lexical(dir), canonical_or_lexical(source));
        s.strip_prefix(&d).ok().map(slash_path)
    })
}

type AssetResult = (&'static str, Value, Vec<String>, Vec<String>);

/// Crack or copy one asset; returns its status, report, sources (relative
/// to its folder) and the files written.
fn run_asset(
    asset: &Asset,
    pipes: &[PipeSpec],
    a: &BatchArgs,
    on_stage: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<AssetResult> {
    match &asset.action {
        Action::Crack(k) => {
            let spec = &pipes[*k];
            let report = super::crack::process(CrackArgs {
                input: &asset.input,
                output: &asset.output,
                report: None,
                weld: a.weld.clone(),
                pipeline: spec.pipeline.clone(),
                pipeline_dir: spec.dir.clone(),
                quiet: true,
                frames: None,
                on_stage: Some(on_stage),
                prefix_images: a.format == OutFormat::Gltf,
                read: a.read,
            })?;
            let sources = report["sources"]
                .as_array()
                .map(|v| {
                    v.iter()
                        .filter_map(Value::as_str)
                        .filter_map(|s| source_rel(&asset.input, Path::new(s)))
                        .collect()
                })
                .unwrap_or_default();
            let outputs = report["files"]
                .as_array()
                .map(|v| {
                    v.iter()
                        .filter_map(Value::as_str)
                        .map(str::to_owned)
                        .collect()
                })
                .unwrap_or_default();
            Ok(("cracked", report, sources, outputs))
        }
        Action::Copy => {
            on_stage("copy");
            // The asset and every file it references, to the same places
            // relative to it (found without decoding the asset, so assets
            // crackle cannot read, compressed ones say, are copied too).
            let sources: Vec<String> = scan_references(&asset.input)
                .iter()
                .filter(|s| s.is_file())
                .filter_map(|s| source_rel(&asset.input, s))
                .collect();
            let out_dir = asset.output.parent().unwrap_or(Path::new("."));
            let in_dir = asset.input.parent().unwrap_or(Path::new("."));
            let mut files: Vec<(PathBuf, PathBuf)> =
                vec![(asset.input.clone(), asset.output.clone())];
            for s in &sources {
                files.push((in_dir.join(s), out_dir.join(s)));
            }
            let mut outputs = Vec::new();
            let mut bytes = 0u64;
            for (from, to) in &files {
                copy_atomic(from, to)?;
                bytes += std::fs::metadata(to).map(|m| m.len()).unwrap_or(0);
                outputs.push(to.display().to_string());
            }
            let report = json!({"files": outputs, "bytes": bytes, "sources": sources});
            Ok(("copied", report, sources, outputs))
        }
        Action::Skip => Ok(("skipped", Value::Null, Vec::new(), Vec::new())),
    }
}
