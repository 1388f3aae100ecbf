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

use super::crack::{CrackArgs, SimArgs};
use super::UsageError;
use crackle::io::paths::{read_capped, real_file_inside, MAX_MODEL_BYTES, MAX_MTL_BYTES};
use crackle::mesh::WeldOptions;
use crackle::pipeline::Pipeline;
use serde_json::{json, Value};
use sha2::{Digest, Sha256};
use std::collections::{BTreeMap, BTreeSet};
use std::io::IsTerminal;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

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

/// `K/N` with 1 <= K <= N.
fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let bad = || format!("--shard '{s}': expected K/N with 1 <= K <= N, e.g. 2/4");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n): (usize, usize) = (
        k.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if k == 0 || n == 0 || k > n {
        return Err(bad());
    }
    Ok((k, n))
}

/// 64-bit FNV-1a: the shard of an asset is the hash of its relative path,
/// so adding or removing assets does not move the others between shards.
fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

fn canonical_or_lexical(p: &Path) -> PathBuf {
    if let Ok(c) = p.canonicalize() {
        return c;
    }
    // Not there yet: its nearest existing ancestor, canonical, plus the rest.
    let abs = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(p)
    };
    let mut rest = Vec::new();
    let mut cur = abs.as_path();
    loop {
        if let Ok(c) = cur.canonicalize() {
            let mut out = c;
            for r in rest.iter().rev() {
                out.push(r);
            }
            return out;
        }
        match (cur.parent(), cur.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                cur = parent;
            }
            _ => return abs,
        }
    }
}

fn is_mesh_file(p: &Path) -> bool {
    matches!(
        p.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Some("obj" | "gltf" | "glb")
    )
}

fn has_glob_chars(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

/// `/`-separated form of a relative path.
fn slash_path(p: &Path) -> String {
    p.components()
        .filter_map(|c| match c {
            Component::Normal(s) => Some(s.to_string_lossy().into_owned()),
            _ => None,
        })
        .collect::<Vec<_>>()
        .join("/")
}

/// Every file under `dir` (recursively when `recursive`), sorted, leaving
/// out `skip` (the output folder) and hidden files.
/// A link (to a file or a folder) whose target lies outside `dir` is not
/// followed, with a warning: nothing outside the folders given is read.
fn walk(dir: &Path, recursive: bool, skip: &Path, out: &mut Vec<PathBuf>) -> anyhow::Result<()> {
    let root = canonical_or_lexical(dir);
    walk_seen(dir, recursive, skip, out, &mut (root, BTreeSet::new()))
}

/// [`walk`], entering each real folder once (folder links may loop);
/// `seen` holds the real root and the real folders entered.
fn walk_seen(
    dir: &Path,
    recursive: bool,
    skip: &Path,
    out: &mut Vec<PathBuf>,
    seen: &mut (PathBuf, BTreeSet<PathBuf>),
) -> anyhow::Result<()> {
    if !seen.1.insert(canonical_or_lexical(dir)) {
        return Ok(());
    }
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| anyhow::anyhow!("{}: cannot read the folder: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    for p in entries {
        let hidden = p
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with('.'));
        if hidden {
            continue;
        }
        let link = std::fs::symlink_metadata(&p).is_ok_and(|m| m.file_type().is_symlink());
        if link {
            match p.canonicalize() {
                Ok(real) if real.starts_with(&seen.0) => {}
                Ok(real) => {
                    log::warn!(
                        "{}: a link to '{}', outside the input folder '{}'; not followed",
                        p.display(),
                        real.display(),
                        seen.0.display()
                    );
                    continue;
                }
                Err(_) => continue, // dangling
            }
        }
        if p.is_dir() {
            if recursive && canonical_or_lexical(&p) != skip {
                walk_seen(&p, recursive, skip, out, seen)?;
            }
        } else if p.is_file() {
            out.push(p);
        }
    }
    Ok(())
}

/// The assets named by the inputs, each with its path relative to the root
/// it was found under, sorted by that path.
fn collect_inputs(
    inputs: &[String],
    recursive: bool,
    out_canon: &Path,
) -> anyhow::Result<Vec<Asset>> {
    if inputs.is_empty() {
        return Err(UsageError("no input: give files, folders or globs".into()).into());
    }
    let mut assets: Vec<Asset> = Vec::new();
    // The same file under the same relative path once (a link to a file
    // elsewhere in the tree is an asset of its own).
    let mut seen: BTreeSet<(PathBuf, String)> = BTreeSet::new();
    let mut push = |input: PathBuf, rel: String, assets: &mut Vec<Asset>| {
        if seen.insert((canonical_or_lexical(&input), rel.clone())) {
            assets.push(Asset {
                input,
                rel,
                action: Action::Skip,
                output: PathBuf::new(),
                rule: None,
            });
        }
    };
    for spec in inputs {
        let path = Path::new(spec);
        if path.is_file() {
            let rel = path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            if !is_mesh_file(path) {
                return Err(UsageError(format!("{spec}: not an .obj, .gltf or .glb file")).into());
            }
            push(path.to_path_buf(), rel, &mut assets);
        } else if path.is_dir() {
            let mut files = Vec::new();
            walk(path, recursive, out_canon, &mut files)?;
            for f in files.into_iter().filter(|f| is_mesh_file(f)) {
                let rel = slash_path(f.strip_prefix(path).unwrap_or(&f));
                push(f, rel, &mut assets);
            }
        } else if has_glob_chars(spec) {
            // The folder before the first component with a glob character.
            let mut base = PathBuf::new();
            let mut pattern_parts = Vec::new();
            let mut in_pattern = false;
            for c in Path::new(spec).components() {
                let s = c.as_os_str().to_string_lossy();
                if in_pattern || has_glob_chars(&s) {
                    in_pattern = true;
                    pattern_parts.push(s.into_owned());
                } else {
                    base.push(c);
                }
            }
            let base_dir = if base.as_os_str().is_empty() {
                PathBuf::from(".")
            } else {
                base.clone()
            };
            let glob = globset::GlobBuilder::new(&pattern_parts.join("/"))
                .literal_separator(true)
                .build()
                .map_err(|e| UsageError(format!("{spec}: invalid glob: {e}")))?
                .compile_matcher();
            let mut files = Vec::new();
            if base_dir.is_dir() {
                walk(&base_dir, true, out_canon, &mut files)?;
            }
            let mut any = false;
            for f in files {
                let rel = slash_path(f.strip_prefix(&base_dir).unwrap_or(&f));
                if glob.is_match(&rel) && is_mesh_file(&f) {
                    any = true;
                    push(f, rel, &mut assets);
                }
            }
            if !any {
                log::warn!("{spec}: no .obj, .gltf or .glb file matches");
            }
        } else {
            return Err(UsageError(format!("{spec}: no such file or folder")).into());
        }
    }
    assets.sort_by(|a, b| a.rel.cmp(&b.rel).then(a.input.cmp(&b.input)));
    Ok(assets)
}

/// A rule's matcher: a glob without `/` matches the file name at any depth,
/// one with `/` the whole relative path.
struct RuleGlob {
    matcher: globset::GlobMatcher,
    name_only: bool,
}

impl RuleGlob {
    fn matches(&self, rel: &str) -> bool {
        if self.name_only {
            let name = rel.rsplit('/').next().unwrap_or(rel);
            self.matcher.is_match(name)
        } else {
            self.matcher.is_match(rel)
        }
    }
}

type Rules = (Vec<PipeSpec>, Vec<(RuleGlob, Action)>, Action);

fn load_rules(path: &Path, sim: &SimArgs) -> anyhow::Result<Rules> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| UsageError(format!("{}: cannot read the rules: {e}", path.display())))?;
    let file: RulesFile =
        toml::from_str(&text).map_err(|e| UsageError(format!("{}: {e}", path.display())))?;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let unmatched = match file.unmatched.as_deref() {
        None | Some("skip") => Action::Skip,
        Some("copy") => Action::Copy,
        Some(x) => {
            return Err(UsageError(format!(
                "{}: unmatched = \"{x}\": expected \"skip\" or \"copy\"",
                path.display()
            ))
            .into())
        }
    };
    let mut pipes: Vec<PipeSpec> = Vec::new();
    let mut rules = Vec::new();
    for (i, r) in file.rules.iter().enumerate() {
        let at = |m: String| {
            UsageError(format!(
                "{}: rule {} ('{}'): {m}",
                path.display(),
                i + 1,
                r.glob
            ))
        };
        let pattern = r.glob.trim_start_matches("./");
        let matcher = globset::GlobBuilder::new(pattern)
            .literal_separator(true)
            .build()
            .map_err(|e| at(format!("invalid glob: {e}")))?
            .compile_matcher();
        let glob = RuleGlob {
            matcher,
            name_only: !pattern.contains('/'),
        };
        let action = match r.action.as_deref().unwrap_or("crack") {
            "crack" => {
                if r.preset.is_some() && r.pipeline.is_some() {
                    return Err(at("give preset or pipeline, not both".into()).into());
                }
                let file_path = r.pipeline.as_ref().map(|p| dir.join(p));
                let pipeline = sim
                    .pipeline_with(file_path.as_deref(), r.preset.as_deref(), &r.set)
                    .map_err(|e| at(format!("{e:#}")))?;
                let label = match (&r.preset, &file_path) {
                    (Some(p), _) => format!("preset {p}"),
                    (None, Some(f)) => format!("pipeline {}", f.display()),
                    (None, None) => "defaults".to_string(),
                };
                let pdir = file_path.as_ref().map(|f| {
                    f.parent()
                        .filter(|d| !d.as_os_str().is_empty())
                        .unwrap_or(Path::new("."))
                        .to_path_buf()
                });
                pipes.push(pipe_spec(
                    label,
                    file_path,
                    r.preset.clone(),
                    r.set.clone(),
                    pipeline,
                    pdir,
                )?);
                Action::Crack(pipes.len() - 1)
            }
            "copy" | "skip" if r.preset.is_some() || r.pipeline.is_some() || !r.set.is_empty() => {
                return Err(
                    at("a copy or skip rule takes no preset, pipeline or set".into()).into(),
                )
            }
            "copy" => Action::Copy,
            "skip" => Action::Skip,
            x => {
                return Err(at(format!(
                    "action = \"{x}\": expected \"crack\", \"copy\" or \"skip\""
                ))
                .into())
            }
        };
        rules.push((glob, action));
    }
    Ok((pipes, rules, unmatched))
}

fn pipe_spec(
    label: String,
    file: Option<PathBuf>,
    preset: Option<String>,
    sets: Vec<String>,
    pipeline: Pipeline,
    dir: Option<PathBuf>,
) -> anyhow::Result<PipeSpec> {
    // The parsed pipeline (every key, defaults filled in) and the bytes of
    // the mask images it reads.
    let mut anonymous = pipeline.clone();
    anonymous.source_name.clear();
    anonymous.description.clear();
    let mut fingerprint = format!("{anonymous:?}").into_bytes();
    for e in &pipeline.stress {
        if let Some(image) = e.mask.as_ref().and_then(|m| m.image.as_ref()) {
            if image.starts_with("builtin:") {
                continue;
            }
            let p = match &dir {
                Some(d) if Path::new(image).is_relative() => d.join(image),
                _ => PathBuf::from(image),
            };
            fingerprint.extend(
                read_capped(&p, crackle::io::paths::MAX_IMAGE_BYTES, "mask image")
                    .map_err(|e| UsageError(format!("{label}: mask image {}: {e}", p.display())))?,
            );
        }
    }
    Ok(PipeSpec {
        label,
        file,
        preset,
        sets,
        pipeline,
        dir,
        fingerprint,
    })
}

/// Refuse outputs that would overwrite an input or each other.
fn check_outputs(assets: &[Asset]) -> anyhow::Result<()> {
    let inputs: BTreeMap<PathBuf, &Asset> = assets
        .iter()
        .map(|a| (canonical_or_lexical(&a.input), a))
        .collect();
    let mut outputs: BTreeMap<PathBuf, &Asset> = BTreeMap::new();
    for a in assets.iter().filter(|a| a.action != Action::Skip) {
        let o = canonical_or_lexical(&a.output);
        if inputs.contains_key(&o) {
            return Err(UsageError(format!(
                "{}: the output {} is an input; choose another --out",
                a.input.display(),
                a.output.display()
            ))
            .into());
        }
        if let Some(other) = outputs.insert(o, a) {
            return Err(UsageError(format!(
                "{} and {} would both write {}; rename one or split the batch",
                other.input.display(),
                a.input.display(),
                a.output.display()
            ))
            .into());
        }
    }
    Ok(())
}

/// What, besides the input files, decides the asset's output.
fn action_fingerprint(asset: &Asset, pipes: &[PipeSpec], format: OutFormat, weld: f64) -> Vec<u8> {
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
fn tool_id() -> &'static str {
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
fn asset_key(input: &Path, sources: &[String], fingerprint: &[u8]) -> Option<String> {
    let mut h = Sha256::new();
    h.update((fingerprint.len() as u64).to_le_bytes());
    h.update(fingerprint);
    let bytes = read_capped(input, MAX_MODEL_BYTES, "model file").ok()?;
    h.update((bytes.len() as u64).to_le_bytes());
    h.update(&bytes);
    let dir = input.parent().unwrap_or(Path::new("."));
    for s in sources {
        h.update((s.len() as u64).to_le_bytes());
        h.update(s.as_bytes());
        // Only what the reader itself would read: inside the folder, a
        // regular file, within the largest size read.
        let read = real_file_inside(dir, &dir.join(s), s)
            .ok()
            .and_then(|p| read_capped(&p, MAX_MODEL_BYTES, "file").ok());
        match read {
            Some(b) => {
                h.update((b.len() as u64).to_le_bytes());
                h.update(&b);
            }
            None => h.update(u64::MAX.to_le_bytes()),
        }
    }
    Some(format!("{:x}", h.finalize()))
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

/// The files an asset refers to, found without decoding it: a glTF's
/// external buffers and images, an OBJ's material libraries and their
/// texture maps. Only references inside the asset's folder are returned.
fn scan_references(input: &Path) -> Vec<PathBuf> {
    use crackle::io::paths::resolve_inside;
    let dir = input.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    let ext = input
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let Ok(bytes) = read_capped(input, MAX_MODEL_BYTES, "model file") else {
        return out;
    };
    if ext == "obj" {
        let text = String::from_utf8_lossy(&bytes);
        // The whole rest of a line when that names a file (names may hold
        // spaces), else its last word (options come first).
        let named = |rest: &str, base: &Path| -> Option<PathBuf> {
            let rest = rest.trim();
            resolve_inside(base, rest)
                .ok()
                .filter(|p| p.is_file())
                .or_else(|| resolve_inside(base, rest.split_whitespace().last()?).ok())
        };
        for line in text.lines() {
            let Some(rest) = line.trim_start().strip_prefix("mtllib") else {
                continue;
            };
            let Some(lib) = named(rest, dir) else {
                continue;
            };
            let mtl = real_file_inside(dir, &lib, rest)
                .ok()
                .and_then(|p| read_capped(&p, MAX_MTL_BYTES, "material library").ok());
            if let Some(mtl) = mtl {
                for l in String::from_utf8_lossy(&mtl).lines() {
                    let l = l.trim_start();
                    let (key, rest) = l.split_once(char::is_whitespace).unwrap_or((l, ""));
                    let key = key.to_ascii_lowercase();
                    let is_map = key.starts_with("map_")
                        || matches!(key.as_str(), "bump" | "disp" | "decal" | "refl" | "norm");
                    if is_map {
                        out.extend(named(rest, dir));
                    }
                }
            }
            out.push(lib);
        }
    } else {
        let json: Option<Value> = if bytes.starts_with(b"glTF") {
            gltf::binary::Glb::from_slice(&bytes)
                .ok()
                .and_then(|g| serde_json::from_slice(&g.json).ok())
        } else {
            serde_json::from_slice(&bytes).ok()
        };
        if let Some(json) = json {
            for uri in crackle::io::gltf_read::file_uris(&json) {
                out.extend(resolve_inside(dir, uri).ok());
            }
        }
    }
    out.sort();
    out.dedup();
    out
}

/// Copy through a temporary file and a rename.
fn copy_atomic(from: &Path, to: &Path) -> anyhow::Result<()> {
    if let Some(d) = to.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d)
            .map_err(|e| anyhow::anyhow!("{}: cannot create the folder: {e}", d.display()))?;
    }
    let tmp = crackle::io::gltf_write::temp_path(to);
    std::fs::copy(from, &tmp).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        anyhow::anyhow!("{}: cannot copy to {}: {e}", from.display(), to.display())
    })?;
    std::fs::rename(&tmp, to).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        anyhow::anyhow!("{}: cannot write: {e}", to.display())
    })?;
    Ok(())
}

/// What the state file records of an asset (paths relative to the output
/// folder; sources relative to the asset's folder).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
struct StateEntry {
    key: String,
    sources: Vec<String>,
    outputs: Vec<String>,
}

/// The state file: per output path, the key of its last successful build.
#[derive(Default, serde::Serialize, serde::Deserialize)]
struct State {
    version: u32,
    assets: BTreeMap<String, StateEntry>,
    /// Entries this run set (merged into the file as it is on disk, so
    /// batches sharing an output folder keep each other's entries).
    #[serde(skip)]
    updated: BTreeSet<String>,
    /// When this run last wrote the file.
    #[serde(skip)]
    saved: Option<Instant>,
}

impl State {
    fn load(path: &Path) -> State {
        std::fs::read(path)
            .ok()
            .and_then(|b| serde_json::from_slice::<State>(&b).ok())
            .filter(|s| s.version == 1)
            .unwrap_or(State {
                version: 1,
                ..Default::default()
            })
    }

    fn entry(&self, output: &str) -> Option<&StateEntry> {
        self.assets.get(output)
    }

    fn set(&mut self, output: String, key: String, sources: Vec<String>, outputs: Vec<String>) {
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
    fn save_soon(&mut self, path: &Path) -> anyhow::Result<()> {
        if self.saved.is_some_and(|t| t.elapsed().as_secs_f64() < 1.0) {
            return Ok(());
        }
        self.save(path)
    }

    /// Merge this run's entries into the file on disk, under a lock, and
    /// write it through a temporary file and a rename, so a killed batch
    /// leaves the last complete state and concurrent batches (shards into
    /// one folder) lose nothing.
    fn save(&mut self, path: &Path) -> anyhow::Result<()> {
        let err = |e: std::io::Error| {
            anyhow::anyhow!("{}: cannot write the batch state: {e}", path.display())
        };
        let _lock = StateLock::acquire(path).map_err(err)?;
        let mut merged = State::load(path);
        for k in &self.updated {
            if let Some(e) = self.assets.get(k) {
                merged.assets.insert(k.clone(), e.clone());
            }
        }
        let bytes = serde_json::to_vec_pretty(&merged)?;
        let tmp = crackle::io::gltf_write::temp_path(path);
        let result = std::fs::write(&tmp, bytes).and_then(|_| std::fs::rename(&tmp, path));
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result.map_err(err)?;
        self.saved = Some(Instant::now());
        Ok(())
    }
}

/// An exclusive lock on a state file: a lock file created with
/// `create_new` (atomic), removed when dropped. A lock older than a minute
/// is taken to be left by a killed run and removed.
struct StateLock(PathBuf);

impl StateLock {
    fn acquire(state: &Path) -> std::io::Result<StateLock> {
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

/// The overall bar and one line per worker on a terminal; a line per
/// finished asset otherwise.
struct Progress {
    multi: Option<(
        indicatif::MultiProgress,
        indicatif::ProgressBar,
        Vec<indicatif::ProgressBar>,
    )>,
    quiet: bool,
    finished: AtomicUsize,
    total: usize,
}

impl Progress {
    fn new(total: usize, workers: usize, quiet: bool) -> Progress {
        let multi = (!quiet && std::io::stderr().is_terminal()).then(|| {
            let m = indicatif::MultiProgress::new();
            let overall = m.add(indicatif::ProgressBar::new(total as u64));
            overall.set_style(
                indicatif::ProgressStyle::with_template(
                    "[{bar:30}] {pos}/{len} assets, {elapsed} elapsed, ETA {eta} {msg}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            let lines = (0..workers)
                .map(|_| {
                    let b = m.add(indicatif::ProgressBar::new_spinner());
                    b.set_style(
                        indicatif::ProgressStyle::with_template("  {spinner} {msg}")
                            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
                    );
                    b
                })
                .collect();
            (m, overall, lines)
        });
        Progress {
            multi,
            quiet,
            finished: AtomicUsize::new(0),
            total,
        }
    }

    fn start(&self, worker: usize, rel: &str) {
        self.stage(worker, rel, "start");
    }

    fn stage(&self, worker: usize, rel: &str, stage: &str) {
        if let Some((_, _, lines)) = &self.multi {
            lines[worker].set_message(format!("{rel}: {stage}"));
            lines[worker].tick();
        }
    }

    fn done(&self, worker: usize, asset: &Asset, o: &Outcome) {
        let n = self.finished.fetch_add(1, Ordering::SeqCst) + 1;
        match &self.multi {
            Some((m, overall, lines)) => {
                overall.inc(1);
                lines[worker].set_message(String::new());
                if let Some(e) = &o.error {
                    let _ = m.println(format!("FAILED {}: {e}", asset.input.display()));
                }
            }
            None if !self.quiet => {
                let what = match &o.error {
                    Some(e) => format!("FAILED {}: {e}", asset.input.display()),
                    None => format!(
                        "{} {} -> {} ({:.2} s)",
                        o.status,
                        asset.input.display(),
                        asset.output.display(),
                        o.seconds
                    ),
                };
                eprintln!("[{n}/{}] {what}", self.total);
            }
            None => {}
        }
    }

    fn finish(&self) {
        if let Some((m, overall, lines)) = &self.multi {
            for l in lines {
                l.finish_and_clear();
            }
            overall.finish_and_clear();
            let _ = m.clear();
        }
    }
}

fn write_report(
    path: Option<&Path>,
    a: &BatchArgs,
    assets: &[Asset],
    outcomes: &[Outcome],
    pipes: &[PipeSpec],
    seconds: f64,
) -> anyhow::Result<()> {
    let Some(path) = path else { return Ok(()) };
    let count = |s: &str| outcomes.iter().filter(|o| o.status == s).count();
    let rows: Vec<Value> = assets
        .iter()
        .zip(outcomes)
        .map(|(x, o)| {
            let r = &o.report;
            json!({
                "input": x.input.display().to_string(),
                "output": (x.action != Action::Skip).then(|| x.output.display().to_string()),
                "action": match x.action { Action::Crack(_) => "crack", Action::Copy => "copy", Action::Skip => "skip" },
                "pipeline": match x.action { Action::Crack(k) => Some(pipes[k].label.clone()), _ => None },
                "rule": x.rule.map(|k| k + 1),
                "status": o.status,
                "error": o.error,
                "seconds": o.seconds,
                "stages": r.get("stages").cloned().unwrap_or(Value::Null),
                "cracks": r.get("cracks").cloned().unwrap_or(Value::Null),
                "crack_length": r.get("crack_length").cloned().unwrap_or(Value::Null),
                "triangles": r.get("triangles").cloned().unwrap_or(Value::Null),
                "input_bytes": std::fs::metadata(&x.input).map(|m| m.len()).ok(),
                "output_bytes": r.get("bytes").cloned().unwrap_or(Value::Null),
                "files": r.get("files").cloned().unwrap_or(Value::Null),
            })
        })
        .collect();
    let total_cracks: u64 = outcomes
        .iter()
        .filter_map(|o| o.report.get("cracks").and_then(Value::as_u64))
        .sum();
    let doc = json!({
        "crackle": env!("CARGO_PKG_VERSION"),
        "out": a.out.display().to_string(),
        "shard": a.shard,
        "assets": rows,
        "totals": {
            "assets": assets.len(),
            "cracked": count("cracked"),
            "copied": count("copied"),
            "up_to_date": count("up-to-date"),
            "skipped": count("skipped"),
            "failed": count("failed"),
            "not_run": count("not-run"),
            "cracks": total_cracks,
            "seconds": seconds,
        },
    });
    std::fs::write(path, serde_json::to_vec_pretty(&doc)?)
        .map_err(|e| anyhow::anyhow!("{}: cannot write the report: {e}", path.display()))
}

/// Quote for a POSIX shell.
fn sh_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// A path in a Ninja build line.
fn ninja_path(p: &Path) -> String {
    let s = p.display().to_string();
    s.replace('$', "$$").replace(' ', "$ ").replace(':', "$:")
}

/// A path in a Make rule's targets or prerequisites.
fn make_path(p: &Path) -> String {
    let s = p.display().to_string();
    s.replace('$', "$$").replace(' ', "\\ ").replace(':', "\\:")
}

/// The command line that cracks or copies one asset (without the input
/// and output).
fn crack_args(a: &BatchArgs, spec: &PipeSpec) -> Vec<String> {
    let mut args = Vec::new();
    match (&spec.file, &spec.preset) {
        (Some(f), _) => {
            args.push("--pipeline".to_string());
            args.push(canonical_or_lexical(f).display().to_string());
        }
        (None, Some(p)) => {
            args.push("--preset".to_string());
            args.push(p.clone());
        }
        (None, None) => {}
    }
    for s in a.sim.overrides(&spec.sets) {
        args.push("--set".into());
        args.push(s);
    }
    for f in a.sim.fix_names() {
        args.push("--fix".into());
        args.push(f.clone());
    }
    args.push("--weld-tolerance".into());
    args.push(format!("{:?}", a.weld_tolerance));
    args.push("-q".into());
    args
}

/// One edge of an emitted build file.
struct Edge {
    output: PathBuf,
    input: PathBuf,
    deps: Vec<PathBuf>,
    cmd: Vec<String>,
    desc: String,
}

/// Characters a Makefile cannot hold in a target or prerequisite path.
const MAKE_UNSAFE: &[char] = &['#', '%', ';', '\n', '\t', '*', '?', '[', '|'];

/// The build file of `--emit`: one edge per asset (and, for copies, one per
/// file the asset references).
fn emit_build_file(
    emit: Emit,
    a: &BatchArgs,
    assets: &[Asset],
    pipes: &[PipeSpec],
) -> anyhow::Result<String> {
    let exe = std::env::current_exe()
        .map(|p| p.display().to_string())
        .unwrap_or_else(|_| "crackle".into());
    let mut edges: Vec<Edge> = Vec::new();
    let mut by_output: BTreeMap<PathBuf, PathBuf> = BTreeMap::new();
    let mut add = |e: Edge, edges: &mut Vec<Edge>| -> anyhow::Result<()> {
        match by_output.get(&e.output) {
            // The same file copied for two assets: one edge.
            Some(src) if *src == e.input => Ok(()),
            Some(src) => Err(UsageError(format!(
                "{} and {} would both be copied to {}",
                src.display(),
                e.input.display(),
                e.output.display()
            ))
            .into()),
            None => {
                by_output.insert(e.output.clone(), e.input.clone());
                edges.push(e);
                Ok(())
            }
        }
    };
    for asset in assets.iter().filter(|x| x.action != Action::Skip) {
        let refs: Vec<PathBuf> = scan_references(&asset.input)
            .into_iter()
            .filter(|d| d.is_file())
            .collect();
        match &asset.action {
            Action::Crack(k) => {
                let spec = &pipes[*k];
                let mut deps = refs;
                if let Some(f) = &spec.file {
                    deps.push(f.clone());
                }
                let mut cmd = vec![exe.clone(), "crack".into()];
                cmd.push(asset.input.display().to_string());
                cmd.push(asset.output.display().to_string());
                cmd.extend(crack_args(a, spec));
                add(
                    Edge {
                        output: asset.output.clone(),
                        input: asset.input.clone(),
                        deps,
                        cmd,
                        desc: format!("crack {}", asset.rel),
                    },
                    &mut edges,
                )?;
            }
            Action::Copy => {
                let out_dir = asset.output.parent().unwrap_or(Path::new("."));
                let mut files = vec![(asset.input.clone(), asset.output.clone())];
                for r in &refs {
                    if let Some(rel) = source_rel(&asset.input, r) {
                        files.push((r.clone(), out_dir.join(rel)));
                    }
                }
                for (from, to) in files {
                    let cmd = vec![
                        "cp".into(),
                        from.display().to_string(),
                        to.display().to_string(),
                    ];
                    let desc = format!("copy {}", from.display());
                    add(
                        Edge {
                            output: to,
                            input: from,
                            deps: Vec::new(),
                            cmd,
                            desc,
                        },
                        &mut edges,
                    )?;
                }
            }
            Action::Skip => {}
        }
    }
    // Paths the build file cannot spell are refused, naming them.
    for e in &edges {
        for p in std::iter::once(&e.output)
            .chain(std::iter::once(&e.input))
            .chain(&e.deps)
        {
            let s = p.display().to_string();
            let bad = match emit {
                Emit::Ninja => s.contains('\n'),
                Emit::Make => s.contains(MAKE_UNSAFE),
            };
            if bad {
                return Err(UsageError(format!(
                    "{s}: this path cannot be written in a {} file{}",
                    if emit == Emit::Ninja { "Ninja" } else { "Make" },
                    if emit == Emit::Make {
                        " (it holds one of # % ; * ? [ | or a tab or newline); try --emit ninja"
                    } else {
                        ""
                    }
                ))
                .into());
            }
        }
    }
    let mkdir = |output: &Path| {
        output
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .map(|d| format!("mkdir -p {} && ", sh_quote(&d.display().to_string())))
            .unwrap_or_default()
    };
    let command = |e: &Edge| {
        let c: Vec<String> = e.cmd.iter().map(|s| sh_quote(s)).collect();
        format!("{}{}", mkdir(&e.output), c.join(" "))
    };
    let mut out = String::new();
    match emit {
        Emit::Ninja => {
            out += "# Generated by `crackle batch --emit ninja`: one edge per asset.\n";
            out += "rule crackle\n  command = $cmd\n  description = $desc\n\n";
            for e in &edges {
                out += &format!(
                    "build {}: crackle {}",
                    ninja_path(&e.output),
                    ninja_path(&e.input)
                );
                if !e.deps.is_empty() {
                    out += " |";
                    for d in &e.deps {
                        out += " ";
                        out += &ninja_path(d);
                    }
                }
                out += "\n";
                out += &format!("  cmd = {}\n", command(e).replace('$', "$$"));
                out += &format!("  desc = {}\n\n", e.desc.replace('$', "$$"));
            }
            out += "default";
            for e in &edges {
                out += " ";
                out += &ninja_path(&e.output);
            }
            out += "\n";
        }
        Emit::Make => {
            out += "# Generated by `crackle batch --emit make`: one rule per asset.\n";
            out += ".PHONY: all\nall:";
            for e in &edges {
                out += " ";
                out += &make_path(&e.output);
            }
            out += "\n\n";
            for e in &edges {
                out += &format!("{}: {}", make_path(&e.output), make_path(&e.input));
                for d in &e.deps {
                    out += " ";
                    out += &make_path(d);
                }
                out += "\n";
                out += &format!("\t@{}\n\n", command(e).replace('$', "$$"));
            }
        }
    }
    Ok(out)
}
