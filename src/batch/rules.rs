//! The rules file of a batch (globs to actions and pipelines) and the
//! fingerprint of a pipeline.

use super::{Action, PipeSpec, Rules};
use crate::error::{InputsError, RuleError, RulesError};
use crate::io::paths::read_capped;
use crate::pipeline::Pipeline;
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// Makes a rule's pipeline from its file, its preset and its `set` list;
/// its error is the caller's, and reaches the user as
/// [`RuleError::Pipeline`].
pub type MakePipeline<'a> = dyn Fn(
        Option<&Path>,
        Option<&str>,
        &[String],
    ) -> std::result::Result<Pipeline, Box<dyn std::error::Error + Send + Sync>>
    + 'a;

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

/// A rule's matcher: a glob without `/` matches the file name at any depth,
/// one with `/` the whole relative path.
pub struct RuleGlob {
    matcher: globset::GlobMatcher,
    name_only: bool,
}

impl RuleGlob {
    /// Whether the asset at `rel` (relative, `/`-separated) matches.
    pub fn matches(&self, rel: &str) -> bool {
        if self.name_only {
            let name = rel.rsplit('/').next().unwrap_or(rel);
            self.matcher.is_match(name)
        } else {
            self.matcher.is_match(rel)
        }
    }
}

/// Load a rules file. `make(file, preset, sets)` makes the pipeline of a
/// crack rule: its pipeline file (relative to the rules file's folder,
/// joined to it) or preset, and its `set` list; the caller adds its own
/// overrides.
///
/// # Errors
/// [`Error::Rules`] naming the file and the rule.
pub fn load_rules(path: &Path, make: &MakePipeline) -> Result<Rules> {
    let text = crate::io::paths::read_config_text(path, "rules file").map_err(|error| {
        RulesError::Read {
            path: path.to_path_buf(),
            error,
        }
    })?;
    let file: RulesFile = toml::from_str(&text).map_err(|error| RulesError::Syntax {
        path: path.to_path_buf(),
        error,
    })?;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let unmatched = match file.unmatched.as_deref() {
        None | Some("skip") => Action::Skip,
        Some("copy") => Action::Copy,
        Some(x) => {
            return Err(RulesError::Unmatched {
                path: path.to_path_buf(),
                value: x.to_string(),
            }
            .into())
        }
    };
    let mut pipes: Vec<PipeSpec> = Vec::new();
    let mut rules = Vec::new();
    for (i, r) in file.rules.iter().enumerate() {
        let at = |error: RuleError| {
            Error::from(RulesError::Rule {
                path: path.to_path_buf(),
                number: i + 1,
                glob: r.glob.clone(),
                error,
            })
        };
        let pattern = r.glob.trim_start_matches("./");
        let matcher = globset::GlobBuilder::new(pattern)
            .literal_separator(true)
            .build()
            .map_err(|e| at(RuleError::Glob(e)))?
            .compile_matcher();
        let glob = RuleGlob {
            matcher,
            name_only: !pattern.contains('/'),
        };
        let action = match r.action.as_deref().unwrap_or("crack") {
            "crack" => {
                if r.preset.is_some() && r.pipeline.is_some() {
                    return Err(at(RuleError::PresetAndPipeline));
                }
                let file_path = r.pipeline.as_ref().map(|p| dir.join(p));
                let pipeline = make(file_path.as_deref(), r.preset.as_deref(), &r.set)
                    .map_err(|e| at(RuleError::Pipeline(e)))?;
                pipes.push(PipeSpec::new(
                    file_path,
                    r.preset.clone(),
                    r.set.clone(),
                    pipeline,
                )?);
                Action::Crack(pipes.len() - 1)
            }
            "copy" | "skip" if r.preset.is_some() || r.pipeline.is_some() || !r.set.is_empty() => {
                return Err(at(RuleError::PipelineNotCracked))
            }
            "copy" => Action::Copy,
            "skip" => Action::Skip,
            x => {
                return Err(at(RuleError::UnknownAction {
                    action: x.to_string(),
                }))
            }
        };
        rules.push((glob, action));
    }
    Ok(Rules {
        pipes,
        rules,
        unmatched,
    })
}

impl PipeSpec {
    /// A pipeline as the user named it, with its fingerprint: the parsed
    /// pipeline (every key, defaults filled in) and the bytes of the mask
    /// images it reads.
    ///
    /// # Errors
    /// [`Error::Inputs`] when a mask image cannot be read.
    pub fn new(
        file: Option<PathBuf>,
        preset: Option<String>,
        sets: Vec<String>,
        pipeline: Pipeline,
    ) -> Result<PipeSpec> {
        let label = match (&file, &preset) {
            (Some(f), _) => format!("pipeline {}", f.display()),
            (None, Some(p)) => format!("preset {p}"),
            (None, None) => "defaults".to_string(),
        };
        // Relative mask images are found beside the pipeline file.
        let dir = file.as_ref().map(|f| {
            f.parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."))
                .to_path_buf()
        });
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
                    read_capped(&p, crate::io::paths::MAX_IMAGE_BYTES, "mask image").map_err(
                        |error| InputsError::MaskImage {
                            label: label.clone(),
                            path: p.clone(),
                            error,
                        },
                    )?,
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
}
