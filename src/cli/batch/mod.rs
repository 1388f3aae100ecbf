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

use crate::batch::{self, Action, Asset, Choice, Options, Outcome, PipeSpec, Plan, Status, Triage};
use crate::cli::crack::SimArgs;
use crate::cli::UsageError;
use crate::mesh::WeldOptions;
use std::path::Path;

mod emit;
use emit::*;

mod progress;
use progress::*;

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
    pub weld: WeldOptions,
    pub quiet: bool,
    /// How inputs are read.
    pub read: crate::io::ReadOptions,
}

/// `K/N` with 1 <= K <= N.
fn parse_shard(s: &str) -> Result<(usize, usize), UsageError> {
    let bad = || {
        UsageError(format!(
            "--shard '{s}': expected K/N with 1 <= K <= N, e.g. 2/4"
        ))
    };
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

/// The pipelines: the rules file's, or the one of `--pipeline`/`--preset`.
fn choice(a: &BatchArgs) -> anyhow::Result<Choice> {
    if let Some(path) = a.rules {
        let make = |file: Option<&Path>, preset: Option<&str>, sets: &[String]| {
            a.sim.pipeline_with(file, preset, sets).map_err(Into::into)
        };
        return Ok(Choice::Rules(batch::load_rules(path, &make)?));
    }
    let pipeline = a.sim.pipeline()?;
    let file = a.sim.pipeline_file().map(Path::to_path_buf);
    let preset = a.sim.preset_name().map(str::to_owned);
    let spec = PipeSpec::new(file, preset, Vec::new(), pipeline)?;
    Ok(Choice::One(Box::new(spec)))
}

pub fn run(a: BatchArgs) -> anyhow::Result<u8> {
    let shard = a.shard.map(parse_shard).transpose()?;
    if a.rules.is_some() && a.sim.has_choice() {
        return Err(UsageError(
            "--rules chooses the pipeline of each asset; it cannot be combined with --pipeline or --preset".into(),
        )
        .into());
    }
    let options = Options {
        inputs: a.inputs.to_vec(),
        out: a.out.to_path_buf(),
        recursive: a.recursive,
        format: match a.format {
            OutFormat::Glb => batch::OutFormat::Glb,
            OutFormat::Gltf => batch::OutFormat::Gltf,
        },
        jobs: a.jobs,
        fail_fast: a.fail_fast,
        force: a.force,
        shard,
        weld: a.weld.clone(),
        read: a.read,
    };
    let plan = batch::plan(&options, choice(&a)?)?;
    let active = plan.active();
    if let Some(emit) = a.emit {
        if active == 0 {
            log::warn!("nothing to do: no asset selected");
            return Ok(3);
        }
        let text = emit_build_file(emit, &a, &plan.assets, &plan.pipes)?;
        // A closed pipe (`| head`) is not an error.
        use std::io::Write;
        let _ = std::io::stdout().lock().write_all(text.as_bytes());
        return Ok(0);
    }
    // (A run first clears what a killed run left behind.)
    let triage = batch::triage(&plan, &options, !a.dry_run);
    if a.dry_run {
        print_dry_run(&plan, &triage);
        return Ok(if active == 0 { 3 } else { 0 });
    }
    if active == 0 {
        log::warn!(
            "nothing to do: {}",
            if plan.assets.is_empty() {
                "no .obj, .gltf or .glb asset among the inputs"
            } else {
                "every asset is skipped"
            }
        );
        write_report(a.report, &plan, &options, &triage.outcomes, 0.0)?;
        return Ok(3);
    }
    let progress = Progress::new(triage.todo.len(), options.workers(), a.quiet);
    let (outcomes, seconds) = batch::execute(&plan, &options, triage, &progress)?;
    progress.finish();
    write_report(a.report, &plan, &options, &outcomes, seconds)?;
    let count = |s: Status| outcomes.iter().filter(|o| o.status == s).count();
    let failed = count(Status::Failed);
    if !a.quiet {
        eprintln!(
            "{} assets: {} cracked, {} copied, {} up to date, {} skipped, {} failed{} ({:.1} s)",
            plan.assets.len(),
            count(Status::Cracked),
            count(Status::Copied),
            count(Status::UpToDate),
            count(Status::Skipped),
            failed,
            match count(Status::NotRun) {
                0 => String::new(),
                n => format!(", {n} not run (--fail-fast)"),
            },
            seconds
        );
        for (asset, o) in plan.assets.iter().zip(&outcomes) {
            if let Some(e) = &o.error {
                eprintln!("error: {}: {e}", asset.input.display());
            }
            if let Some(w) = &o.warning {
                eprintln!("warning: {}: {w}", asset.input.display());
            }
        }
    }
    Ok(if failed > 0 { 1 } else { 0 })
}

/// `--dry-run`: what each asset would get, and the counts.
fn print_dry_run(plan: &Plan, triage: &Triage) {
    // A closed pipe (`| head`) ends the listing quietly.
    use std::io::Write;
    let mut so = std::io::stdout().lock();
    let outcomes = &triage.outcomes;
    for (i, asset) in plan.assets.iter().enumerate() {
        let what = match (&asset.action, outcomes[i].status) {
            (Action::Skip, _) => "skip".to_string(),
            (_, Status::UpToDate) => "up to date".to_string(),
            (Action::Copy, _) => "copy".to_string(),
            (Action::Crack(k), _) => format!("crack ({})", plan.pipes[*k].label),
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
    let count = |s: Status| outcomes.iter().filter(|o| o.status == s).count();
    let _ = writeln!(
        so,
        "{} assets: {} to do, {} up to date, {} skipped",
        plan.assets.len(),
        triage.todo.len(),
        count(Status::UpToDate),
        count(Status::Skipped)
    );
}

/// Write the `--report` file, if asked.
fn write_report(
    path: Option<&Path>,
    plan: &Plan,
    options: &Options,
    outcomes: &[Outcome],
    seconds: f64,
) -> anyhow::Result<()> {
    let Some(path) = path else { return Ok(()) };
    let report = batch::BatchReport::new(plan, &options.out, options.shard, outcomes, seconds);
    crate::io::write::write_atomic(path, &serde_json::to_vec_pretty(&report)?)
        .map_err(|e| anyhow::anyhow!("{}: cannot write the report: {e}", path.display()))
}
