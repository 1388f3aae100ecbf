//! A batch's progress display.

use super::*;
use std::io::IsTerminal;
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

impl batch::BatchObserver for Progress {
    fn start(&self, worker: usize, asset: &Asset) {
        self.stage(worker, asset, "start");
    }

    fn stage(&self, worker: usize, asset: &Asset, stage: &str) {
        if let Some((_, _, lines)) = &self.multi {
            lines[worker].set_message(format!("{}: {stage}", asset.rel));
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
                        o.status.as_str(),
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
}
