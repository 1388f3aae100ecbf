//! A batch's progress display and its report file.

use super::*;
use serde_json::{json, Value};
use std::io::IsTerminal;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The overall bar and one line per worker on a terminal; a line per
/// finished asset otherwise.
pub(super) struct Progress {
    pub(super) multi: Option<(
        indicatif::MultiProgress,
        indicatif::ProgressBar,
        Vec<indicatif::ProgressBar>,
    )>,
    pub(super) quiet: bool,
    pub(super) finished: AtomicUsize,
    pub(super) total: usize,
}

impl Progress {
    pub(super) fn new(total: usize, workers: usize, quiet: bool) -> Progress {
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

    pub(super) fn start(&self, worker: usize, rel: &str) {
        self.stage(worker, rel, "start");
    }

    pub(super) fn stage(&self, worker: usize, rel: &str, stage: &str) {
        if let Some((_, _, lines)) = &self.multi {
            lines[worker].set_message(format!("{rel}: {stage}"));
            lines[worker].tick();
        }
    }

    pub(super) fn done(&self, worker: usize, asset: &Asset, o: &Outcome) {
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

    pub(super) fn finish(&self) {
        if let Some((m, overall, lines)) = &self.multi {
            for l in lines {
                l.finish_and_clear();
            }
            overall.finish_and_clear();
            let _ = m.clear();
        }
    }
}

pub(super) fn write_report(
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
