//! The assets of a batch: inputs walked (links out of the tree not followed), globs, the rules file, shards, and the files an asset refers to.

use super::*;
use crate::cli::crack::SimArgs;
use crate::cli::UsageError;
use crackle::io::paths::{read_capped, real_file_inside, MAX_MODEL_BYTES, MAX_MTL_BYTES};
use crackle::pipeline::Pipeline;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};

/// `K/N` with 1 <= K <= N.
pub(super) fn parse_shard(s: &str) -> Result<(usize, usize), String> {
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

pub(super) fn canonical_or_lexical(p: &Path) -> PathBuf {
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

pub(super) fn is_mesh_file(p: &Path) -> bool {
    matches!(
        p.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Some("obj" | "gltf" | "glb")
    )
}

pub(super) fn has_glob_chars(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

/// `/`-separated form of a relative path.
pub(super) fn slash_path(p: &Path) -> String {
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
pub(super) fn walk(
    dir: &Path,
    recursive: bool,
    skip: &Path,
    out: &mut Vec<PathBuf>,
) -> anyhow::Result<()> {
    let root = canonical_or_lexical(dir);
    walk_seen(dir, recursive, skip, out, &mut (root, BTreeSet::new()))
}

/// [`walk`], entering each real folder once (folder links may loop);
/// `seen` holds the real root and the real folders entered.
pub(super) fn walk_seen(
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
pub(super) fn collect_inputs(
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
pub(super) struct RuleGlob {
    pub(super) matcher: globset::GlobMatcher,
    pub(super) name_only: bool,
}

impl RuleGlob {
    pub(super) fn matches(&self, rel: &str) -> bool {
        if self.name_only {
            let name = rel.rsplit('/').next().unwrap_or(rel);
            self.matcher.is_match(name)
        } else {
            self.matcher.is_match(rel)
        }
    }
}

pub(super) type Rules = (Vec<PipeSpec>, Vec<(RuleGlob, Action)>, Action);

pub(super) fn load_rules(path: &Path, sim: &SimArgs) -> anyhow::Result<Rules> {
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

pub(super) fn pipe_spec(
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
pub(super) fn check_outputs(assets: &[Asset]) -> anyhow::Result<()> {
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

/// The files an asset refers to, found without decoding it: a glTF's
/// external buffers and images, an OBJ's material libraries and their
/// texture maps. Only references inside the asset's folder are returned.
pub(super) fn scan_references(input: &Path) -> Vec<PathBuf> {
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
