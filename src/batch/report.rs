//! What a batch did: one row per asset and the totals, as the `--report`
//! JSON file shows them.

use super::{Action, Outcome, Plan, Produced, Status};
use crate::pipeline::{BeforeAfter, Stage};
use serde::Serialize;
use std::path::Path;

/// A batch's report.
#[derive(Clone, Debug, Serialize)]
pub struct BatchReport {
    /// The tool's version.
    pub crackle: &'static str,
    /// The output folder.
    pub out: String,
    /// The shard run (`K/N`), if any.
    pub shard: Option<String>,
    /// Each asset, in the plan's order.
    pub assets: Vec<AssetRow>,
    /// The totals.
    pub totals: Totals,
}

/// One asset of a [`BatchReport`].
#[derive(Clone, Debug, Serialize)]
pub struct AssetRow {
    /// The input file.
    pub input: String,
    /// The output file (none for a skip).
    pub output: Option<String>,
    /// `crack`, `copy` or `skip`.
    pub action: &'static str,
    /// The pipeline's label, for a crack.
    pub pipeline: Option<String>,
    /// The rule that matched (1-based), if any.
    pub rule: Option<usize>,
    /// `cracked`, `copied`, `up-to-date`, `skipped`, `failed`, `not-run`.
    pub status: &'static str,
    /// Why it failed.
    pub error: Option<String>,
    /// What the user should know although it did not fail.
    pub warning: Option<String>,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// The crack's stages.
    pub stages: Option<Vec<Stage>>,
    /// Crack events.
    pub cracks: Option<usize>,
    /// Total crack length (scene units).
    pub crack_length: Option<f64>,
    /// Triangles of the simulation meshes.
    pub triangles: Option<BeforeAfter<usize>>,
    /// Bytes of the input file.
    pub input_bytes: Option<u64>,
    /// Bytes written.
    pub output_bytes: Option<u64>,
    /// The files written.
    pub files: Option<Vec<String>>,
}

/// The totals of a [`BatchReport`].
#[derive(Clone, Debug, Serialize)]
pub struct Totals {
    /// Assets of the plan.
    pub assets: usize,
    /// Assets cracked.
    pub cracked: usize,
    /// Assets copied.
    pub copied: usize,
    /// Assets up to date.
    pub up_to_date: usize,
    /// Assets skipped.
    pub skipped: usize,
    /// Assets that failed.
    pub failed: usize,
    /// Assets not run (`fail_fast`).
    pub not_run: usize,
    /// Crack events over every asset.
    pub cracks: usize,
    /// Wall-clock seconds of the run.
    pub seconds: f64,
}

impl BatchReport {
    /// The report of `plan` with `outcomes` (one per asset), for the
    /// output folder `out`.
    pub fn new(
        plan: &Plan,
        out: &Path,
        shard: Option<(usize, usize)>,
        outcomes: &[Outcome],
        seconds: f64,
    ) -> BatchReport {
        let count = |s: Status| outcomes.iter().filter(|o| o.status == s).count();
        let assets = plan
            .assets
            .iter()
            .zip(outcomes)
            .map(|(x, o)| row(plan, x, o))
            .collect();
        let cracks = outcomes
            .iter()
            .map(|o| match &o.produced {
                Produced::Cracked(r) => r.run.cracks,
                _ => 0,
            })
            .sum();
        BatchReport {
            crackle: env!("CARGO_PKG_VERSION"),
            out: out.display().to_string(),
            shard: shard.map(|(k, n)| format!("{k}/{n}")),
            assets,
            totals: Totals {
                assets: plan.assets.len(),
                cracked: count(Status::Cracked),
                copied: count(Status::Copied),
                up_to_date: count(Status::UpToDate),
                skipped: count(Status::Skipped),
                failed: count(Status::Failed),
                not_run: count(Status::NotRun),
                cracks,
                seconds,
            },
        }
    }
}

fn row(plan: &Plan, x: &super::Asset, o: &Outcome) -> AssetRow {
    let mut row = AssetRow {
        input: x.input.display().to_string(),
        output: (x.action != Action::Skip).then(|| x.output.display().to_string()),
        action: x.action.name(),
        pipeline: match x.action {
            Action::Crack(k) => Some(plan.pipes[k].label.clone()),
            _ => None,
        },
        rule: x.rule.map(|k| k + 1),
        status: o.status.as_str(),
        error: o.error.clone(),
        warning: o.warning.clone(),
        seconds: o.seconds,
        stages: None,
        cracks: None,
        crack_length: None,
        triangles: None,
        input_bytes: std::fs::metadata(&x.input).map(|m| m.len()).ok(),
        output_bytes: None,
        files: None,
    };
    match &o.produced {
        Produced::Nothing => {}
        Produced::Cracked(r) => {
            row.stages = Some(r.run.stages.clone());
            row.cracks = Some(r.run.cracks);
            row.crack_length = Some(r.run.crack_length);
            row.triangles = Some(r.run.triangles);
            row.output_bytes = Some(r.bytes);
            row.files = Some(r.files.clone());
        }
        Produced::Copied { files, bytes } => {
            row.output_bytes = Some(*bytes);
            row.files = Some(files.clone());
        }
    }
    row
}
