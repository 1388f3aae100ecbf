//! The assets of a batch: inputs walked (links out of the tree not
//! followed), globs, output collisions, and the files an asset refers to.

use super::{Action, Asset};
use crate::error::{BatchError, InputsError};
use crate::io::paths::{read_capped, real_file_inside, MAX_MODEL_BYTES, MAX_MTL_BYTES};
use crate::Result;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};

/// A path made absolute and canonical; when it is not there yet, its
/// nearest existing ancestor, canonical, plus the rest.
pub fn canonical_or_lexical(p: &Path) -> PathBuf {
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

pub(crate) fn is_mesh_file(p: &Path) -> bool {
    matches!(
        p.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Some("obj" | "gltf" | "glb")
    )
}

pub(crate) fn has_glob_chars(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

/// `/`-separated form of a relative path.
pub fn slash_path(p: &Path) -> String {
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
pub(crate) fn walk(dir: &Path, recursive: bool, skip: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    let root = canonical_or_lexical(dir);
    walk_seen(dir, recursive, skip, out, &mut (root, BTreeSet::new()))
}

/// [`walk`], entering each real folder once (folder links may loop);
/// `seen` holds the real root and the real folders entered.
pub(crate) fn walk_seen(
    dir: &Path,
    recursive: bool,
    skip: &Path,
    out: &mut Vec<PathBuf>,
    seen: &mut (PathBuf, BTreeSet<PathBuf>),
) -> Result<()> {
    if !seen.1.insert(canonical_or_lexical(dir)) {
        return Ok(());
    }
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|error| BatchError::ReadFolder {
            dir: dir.to_path_buf(),
            error,
        })?
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
pub(crate) fn collect_inputs(
    inputs: &[String],
    recursive: bool,
    out_canon: &Path,
) -> Result<Vec<Asset>> {
    if inputs.is_empty() {
        return Err(InputsError::NoInput.into());
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
                return Err(InputsError::NotMesh { spec: spec.clone() }.into());
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
                .map_err(|error| InputsError::Glob {
                    spec: spec.clone(),
                    error,
                })?
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
            return Err(InputsError::NotFound { spec: spec.clone() }.into());
        }
    }
    assets.sort_by(|a, b| a.rel.cmp(&b.rel).then(a.input.cmp(&b.input)));
    Ok(assets)
}

/// Refuse outputs that would overwrite an input or each other.
pub(crate) fn check_outputs(assets: &[Asset]) -> Result<()> {
    let inputs: BTreeMap<PathBuf, &Asset> = assets
        .iter()
        .map(|a| (canonical_or_lexical(&a.input), a))
        .collect();
    let mut outputs: BTreeMap<PathBuf, &Asset> = BTreeMap::new();
    for a in assets.iter().filter(|a| a.action != Action::Skip) {
        let o = canonical_or_lexical(&a.output);
        if inputs.contains_key(&o) {
            return Err(InputsError::OutputIsInput {
                input: a.input.clone(),
                output: a.output.clone(),
            }
            .into());
        }
        if let Some(other) = outputs.insert(o, a) {
            return Err(InputsError::SameOutput {
                first: other.input.clone(),
                second: a.input.clone(),
                output: a.output.clone(),
            }
            .into());
        }
    }
    Ok(())
}

/// The files an asset refers to, found without decoding it: a glTF's
/// external buffers and images, an OBJ's material libraries and their
/// texture maps. Only references inside the asset's folder are returned.
pub fn scan_references(input: &Path) -> Vec<PathBuf> {
    use crate::io::paths::resolve_inside;
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
            crate::io::gltf_read::split_glb(&bytes)
                .ok()
                .and_then(|g| serde_json::from_slice(&g.json).ok())
        } else {
            serde_json::from_slice(&bytes).ok()
        };
        if let Some(json) = json {
            for uri in crate::io::gltf_read::file_uris(&json) {
                out.extend(resolve_inside(dir, uri).ok());
            }
        }
    }
    out.sort();
    out.dedup();
    out
}

/// A referenced file's path relative to the asset's folder.
pub fn source_rel(input: &Path, source: &Path) -> Option<String> {
    let dir = input.parent().unwrap_or(Path::new("."));
    source.strip_prefix(dir).ok().map(slash_path).or_else(|| {
        let (d, s) = (canonical_or_lexical(dir), canonical_or_lexical(source));
        s.strip_prefix(&d).ok().map(slash_path)
    })
}
