//! `crackle diff`: compare two assets ([`crackle::compare`]) and print the
//! result as text or JSON.

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
    /// How the files are read.
    pub read: crackle::io::ReadOptions,
}

/// Compare `a.a` with `a.b` and print the result on stdout.
///
/// Returns Ok(true) when the files are equivalent, Ok(false) when they differ
/// (the caller exits 1), Err on unreadable input (the message names the file).
pub fn run(a: DiffArgs) -> Result<bool> {
    let c = crackle::compare::compare_files(a.a, a.b, a.tolerance, &a.read)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&c.to_json(a.a, a.b))?);
    } else {
        print!("{}", c.to_text(a.a, a.b));
    }
    Ok(c.equivalent())
}
