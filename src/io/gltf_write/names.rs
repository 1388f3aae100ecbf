//! File names of written images: safe, unique, and percent-encoded for a
//! URI.

use std::collections::BTreeSet;

/// A file name without folders or characters that are unsafe in file names.
pub(super) fn sanitize_file_name(name: &str) -> String {
    let base = name.rsplit(['/', '\\']).next().unwrap_or(name);
    let s: String = base
        .chars()
        .map(|c| {
            if c.is_control() || matches!(c, ':' | '*' | '?' | '"' | '<' | '>' | '|') {
                '_'
            } else {
                c
            }
        })
        .collect();
    let s = s.trim_start_matches('.').to_string();
    if s.is_empty() {
        "image".into()
    } else {
        s
    }
}

pub(super) fn unique_name(name: &str, taken: &mut BTreeSet<String>) -> String {
    let (stem, ext) = match name.rfind('.') {
        Some(i) => (&name[..i], &name[i..]),
        None => (name, ""),
    };
    let mut candidate = name.to_string();
    let mut k = 1;
    while taken.contains(&candidate.to_lowercase()) {
        candidate = format!("{stem}_{k}{ext}");
        k += 1;
    }
    taken.insert(candidate.to_lowercase());
    candidate
}

/// Percent-encode a relative file name for a glTF URI.
pub(super) fn uri_encode(name: &str) -> String {
    let mut out = String::new();
    for b in name.bytes() {
        if b.is_ascii_alphanumeric() || b"-_.~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}
