//! `crackle diff`: compare two assets ([`crate::compare`]) and print the
//! result as text or JSON; `--geometry` (with `--same-indices`) compares
//! only whether b is a's own mesh ([`crate::compare::Mode::Geometry`]).

use anyhow::Result;
use std::path::Path;

/// Arguments of `crackle diff`.
pub struct DiffArgs<'a> {
    /// First file (the reference: tolerances scale with its values).
    pub a: &'a Path,
    /// Second file.
    pub b: &'a Path,
    /// Tolerance, relative to max(1, largest absolute value of the attribute in a).
    pub tolerance: f64,
    /// Print one JSON object instead of text.
    pub json: bool,
    /// Everything, or only whether b is a's own mesh (`--geometry`).
    pub mode: crate::compare::Mode,
    /// How the files are read.
    pub read: crate::io::ReadOptions,
}

/// Compare `a.a` with `a.b` and print the result on stdout.
///
/// Returns Ok(true) when the files are equivalent, Ok(false) when they differ
/// (the caller exits 1), Err on unreadable input (the message names the file)
/// or a bad tolerance, both with exit code 2 (as `cmp` and `diff` do, so
/// that 1 always means "the files differ").
pub fn run(a: DiffArgs) -> Result<bool> {
    let c = crate::compare::compare_files_with(a.a, a.b, a.tolerance, a.mode, &a.read)
        .map_err(|e| super::UsageError(e.to_string()))?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&c.to_json(a.a, a.b))?);
    } else {
        print!("{}", c.to_text(a.a, a.b));
    }
    Ok(c.equivalent())
}

/// The comparison mode of the `--geometry` and `--same-indices` flags.
pub fn mode(geometry: bool, same_indices: bool) -> crate::compare::Mode {
    if geometry {
        crate::compare::Mode::Geometry { same_indices }
    } else {
        crate::compare::Mode::Full
    }
}
