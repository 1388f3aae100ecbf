//! --emit ninja|make: the batch as a build file, one edge per asset.

use super::*;
use crate::batch::{canonical_or_lexical, scan_references, source_rel};
use crate::cli::UsageError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Quote for a POSIX shell.
pub(super) fn sh_quote(s: &str) -> String {
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
pub(super) fn ninja_path(p: &Path) -> String {
    let s = p.display().to_string();
    s.replace('$', "$$").replace(' ', "$ ").replace(':', "$:")
}

/// A path in a Make rule's targets or prerequisites.
pub(super) fn make_path(p: &Path) -> String {
    let s = p.display().to_string();
    s.replace('$', "$$").replace(' ', "\\ ").replace(':', "\\:")
}

/// The command line that cracks or copies one asset (without the input
/// and output).
pub(super) fn crack_args(a: &BatchArgs, spec: &PipeSpec) -> Vec<String> {
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
    // The look flags first: the --set strings after them win, as on the
    // command line.
    args.extend(a.sim.look_flags());
    for s in a.sim.overrides(&spec.sets) {
        args.push("--set".into());
        args.push(s);
    }
    for f in a.sim.fix_names() {
        args.push("--fix".into());
        args.push(f.clone());
    }
    args.push("--weld-tolerance".into());
    args.push(format!("{:?}", a.weld.relative_tolerance));
    args.push("-q".into());
    args
}

/// One edge of an emitted build file.
pub(super) struct Edge {
    pub(super) output: PathBuf,
    pub(super) input: PathBuf,
    pub(super) deps: Vec<PathBuf>,
    pub(super) cmd: Vec<String>,
    pub(super) desc: String,
}

/// Characters a Makefile cannot hold in a target or prerequisite path.
pub(super) const MAKE_UNSAFE: &[char] = &['#', '%', ';', '\n', '\t', '*', '?', '[', '|'];

/// The build file of `--emit`: one edge per asset (and, for copies, one per
/// file the asset references).
pub(super) fn emit_build_file(
    emit: Emit,
    a: &BatchArgs,
    assets: &[Asset],
    pipes: &[PipeSpec],
) -> anyhow::Result<String> {
    let edges = edges_of(a, assets, pipes)?;
    check_paths(emit, &edges)?;
    Ok(render(emit, &edges))
}

/// One edge per asset to crack, and per file to copy (an asset copied with
/// the files it references); a file copied to one place from two is
/// refused.
fn edges_of(a: &BatchArgs, assets: &[Asset], pipes: &[PipeSpec]) -> anyhow::Result<Vec<Edge>> {
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
    Ok(edges)
}

/// Paths the build file cannot spell are refused, naming them.
fn check_paths(emit: Emit, edges: &[Edge]) -> anyhow::Result<()> {
    for e in edges {
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
    Ok(())
}

/// The build file's text: a Ninja edge or a Make rule per edge.
fn render(emit: Emit, edges: &[Edge]) -> String {
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
            for e in edges {
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
            for e in edges {
                out += " ";
                out += &ninja_path(&e.output);
            }
            out += "\n";
        }
        Emit::Make => {
            out += "# Generated by `crackle batch --emit make`: one rule per asset.\n";
            out += ".PHONY: all\nall:";
            for e in edges {
                out += " ";
                out += &make_path(&e.output);
            }
            out += "\n\n";
            for e in edges {
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
    out
}
