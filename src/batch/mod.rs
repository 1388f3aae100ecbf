//! Batches: a whole asset folder cracked into a mirrored output tree.
//!
//! Inputs are files, folders (recursive when asked) or globs ([`plan`]).
//! Each asset gets an action from a rules file (first matching glob wins)
//! or the one pipeline given: crack, copy or skip. [`triage`] sets aside
//! what is up to date: a state file in the output folder records a hash of
//! every input byte an output depends on (the asset, the files it
//! references, the pipeline, the tool), so the next run redoes only what
//! changed. [`execute`] runs the rest in parallel; each output is written
//! to a temporary file and renamed. [`BatchReport`] is what happened.
//!
//! The command line turns its arguments into [`Options`] and a [`Choice`],
//! shows progress through a [`BatchObserver`], and prints.

mod inputs;
mod report;
mod rules;
mod run;
mod state;

pub use inputs::{canonical_or_lexical, scan_references, slash_path, source_rel};
pub use report::{AssetRow, BatchReport, Totals};
pub use rules::{load_rules, MakePipeline};
pub use run::{execute, triage, BatchObserver, Triage};

use crate::io::ReadOptions;
use crate::mesh::WeldOptions;
use crate::pipeline::{CrackReport, Pipeline};
use crate::Result;
use std::path::{Path, PathBuf};

/// Name of the state file in the output folder.
pub const STATE_FILE: &str = ".crackle-batch.json";

/// Output format of cracked assets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OutFormat {
    /// Binary glTF (one file).
    #[default]
    Glb,
    /// glTF JSON with its .bin and images beside it.
    Gltf,
}

impl OutFormat {
    /// The file extension (`glb`, `gltf`).
    pub fn extension(self) -> &'static str {
        match self {
            OutFormat::Glb => "glb",
            OutFormat::Gltf => "gltf",
        }
    }
}

/// What a batch does, besides choosing pipelines.
#[derive(Clone, Debug)]
pub struct Options {
    /// Files, folders or globs (`assets/**/*.obj`).
    pub inputs: Vec<String>,
    /// The output folder: the inputs' tree mirrored.
    pub out: PathBuf,
    /// Go into sub-folders of folder inputs.
    pub recursive: bool,
    /// Output format of cracked assets.
    pub format: OutFormat,
    /// Assets processed at once; 0: one per core.
    pub jobs: usize,
    /// Stop starting new assets after the first failure.
    pub fail_fast: bool,
    /// Rebuild every asset, even those up to date.
    pub force: bool,
    /// Only shard `k` of `n` (1-based): each asset belongs to one shard,
    /// by a hash of its relative path.
    pub shard: Option<(usize, usize)>,
    /// How input meshes are welded (part of every asset's fingerprint).
    pub weld: WeldOptions,
    /// How inputs are read.
    pub read: ReadOptions,
}

impl Options {
    /// The worker threads: `jobs`, or one per core when it is 0.
    pub fn workers(&self) -> usize {
        match self.jobs {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        }
    }
}

/// How the assets' pipelines are chosen.
pub enum Choice {
    /// One pipeline for every asset.
    One(Box<PipeSpec>),
    /// A rules file ([`load_rules`]): its pipelines, its rules and what
    /// happens to assets no rule matches.
    Rules(Rules),
}

/// A rules file, loaded: the pipelines its rules use, each rule's glob and
/// action, and the action of unmatched assets.
pub struct Rules {
    /// The pipelines; [`Action::Crack`] indexes them.
    pub pipes: Vec<PipeSpec>,
    /// Each rule's glob and action, in file order.
    pub rules: Vec<(RuleGlob, Action)>,
    /// What happens to an asset no rule matches.
    pub unmatched: Action,
}

pub use rules::RuleGlob;

/// What to do with an asset.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Crack with pipeline `k` of the plan.
    Crack(usize),
    /// Copy unchanged (with the files it references).
    Copy,
    /// Leave out.
    Skip,
}

impl Action {
    /// `crack`, `copy` or `skip`.
    pub fn name(&self) -> &'static str {
        match self {
            Action::Crack(_) => "crack",
            Action::Copy => "copy",
            Action::Skip => "skip",
        }
    }
}

/// A pipeline an action uses ([`PipeSpec::new`]).
#[derive(Clone, Debug)]
pub struct PipeSpec {
    /// How the user named it (`preset mud`, `pipeline rules/glaze.toml`).
    pub label: String,
    /// The pipeline file, if any.
    pub file: Option<PathBuf>,
    /// The preset, if any.
    pub preset: Option<String>,
    /// The rule's own `set` list (before the command line's).
    pub sets: Vec<String>,
    /// The pipeline.
    pub pipeline: Pipeline,
    /// Folder of relative mask images.
    pub dir: Option<PathBuf>,
    /// Everything about the pipeline that changes an output.
    pub fingerprint: Vec<u8>,
}

/// One asset of the batch.
#[derive(Clone, Debug)]
pub struct Asset {
    /// Its file.
    pub input: PathBuf,
    /// Path relative to the input root it was found under ('/'-separated).
    pub rel: String,
    /// What happens to it.
    pub action: Action,
    /// Where it goes (for a skip: nothing).
    pub output: PathBuf,
    /// The rule that matched (index in the rules file), if any.
    pub rule: Option<usize>,
}

/// How an asset ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Status {
    /// Not decided yet.
    #[default]
    Pending,
    /// Cracked and written.
    Cracked,
    /// Copied unchanged.
    Copied,
    /// Its output was up to date.
    UpToDate,
    /// Left out.
    Skipped,
    /// It failed (the outcome has the error).
    Failed,
    /// Not started: an earlier asset failed under `fail_fast`.
    NotRun,
}

impl Status {
    /// `cracked`, `copied`, `up-to-date`, `skipped`, `failed`, `not-run`.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Pending => "",
            Status::Cracked => "cracked",
            Status::Copied => "copied",
            Status::UpToDate => "up-to-date",
            Status::Skipped => "skipped",
            Status::Failed => "failed",
            Status::NotRun => "not-run",
        }
    }
}

/// What an asset's run produced.
#[derive(Clone, Debug, Default)]
pub enum Produced {
    /// Nothing (skipped, up to date, failed).
    #[default]
    Nothing,
    /// The crack's report.
    Cracked(Box<CrackReport>),
    /// The files copied and their bytes.
    Copied {
        /// Every file written.
        files: Vec<String>,
        /// Bytes written.
        bytes: u64,
    },
}

/// Result of one asset.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// How it ended.
    pub status: Status,
    /// Why it failed.
    pub error: Option<String>,
    /// What the user should know although it did not fail (an asset that
    /// changed while it was processed).
    pub warning: Option<String>,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// What it produced.
    pub produced: Produced,
}

/// The assets of a batch with their actions, and the pipelines they use.
pub struct Plan {
    /// The assets (of this shard), sorted by relative path.
    pub assets: Vec<Asset>,
    /// The pipelines; [`Action::Crack`] indexes them.
    pub pipes: Vec<PipeSpec>,
}

impl Plan {
    /// The assets that are not skipped.
    pub fn active(&self) -> usize {
        self.assets
            .iter()
            .filter(|a| a.action != Action::Skip)
            .count()
    }
}

/// Find the assets, give each its action and output, refuse outputs that
/// would overwrite an input or each other (over every shard), and keep
/// this shard's assets.
///
/// # Errors
/// [`Error::Inputs`](crate::Error::Inputs) for an input that is not there or not a mesh, a bad
/// glob, an output folder that is an input folder, or colliding outputs;
/// [`Error::Batch`](crate::Error::Batch) for a folder that cannot be read.
pub fn plan(options: &Options, choice: Choice) -> Result<Plan> {
    let out = &options.out;
    let out_canon = canonical_or_lexical(out);
    for spec in &options.inputs {
        let p = Path::new(spec);
        if p.is_dir() && canonical_or_lexical(p) == out_canon {
            return Err(crate::error::InputsError::OutIsInput {
                out: out.clone(),
                spec: spec.clone(),
            }
            .into());
        }
    }
    let mut assets = inputs::collect_inputs(&options.inputs, options.recursive, &out_canon)?;
    let (pipes, rules) = match choice {
        Choice::One(spec) => (vec![*spec], None),
        Choice::Rules(r) => (r.pipes, Some((r.rules, r.unmatched))),
    };
    for asset in &mut assets {
        let (action, rule) = match &rules {
            Some((rules, unmatched)) => match rules.iter().position(|r| r.0.matches(&asset.rel)) {
                Some(k) => (rules[k].1.clone(), Some(k)),
                None => (unmatched.clone(), None),
            },
            None => (Action::Crack(0), None),
        };
        asset.action = action;
        asset.rule = rule;
        asset.output = match asset.action {
            Action::Crack(_) => {
                out.join(Path::new(&asset.rel).with_extension(options.format.extension()))
            }
            Action::Copy => out.join(&asset.rel),
            Action::Skip => PathBuf::new(),
        };
    }
    inputs::check_outputs(&assets)?;
    if let Some((k, n)) = options.shard {
        assets.retain(|x| state::fnv1a(x.rel.as_bytes()) % n as u64 == (k - 1) as u64);
    }
    Ok(Plan { assets, pipes })
}
