//! Resolving file references (buffer and image URIs, MTL libraries, texture
//! maps) safely: a reference may only name a file inside the asset's folder.

use std::path::{Component, Path, PathBuf};

/// Resolve `reference` (a relative URI or path as written in an asset) against
/// `base_dir`, the folder of the asset.
///
/// Percent-escapes are decoded and backslashes are taken as separators
/// (`.\tex\a.png`). Absolute paths, drive letters, URI schemes other than a
/// plain relative path, and any `..` component are refused with a message, so
/// an asset never makes the tool read outside its own folder.
pub fn resolve_inside(base_dir: &Path, reference: &str) -> Result<PathBuf, String> {
    let decoded = percent_decode(reference)
        .ok_or_else(|| format!("invalid percent-escape in reference '{reference}'"))?;
    let normalized = decoded.replace('\\', "/");
    if normalized.is_empty() {
        return Err("empty file reference".into());
    }
    if normalized.starts_with('/') {
        return Err(format!("absolute path '{reference}' is not followed (only files inside the asset's folder are read)"));
    }
    // A scheme (http:, file:) or a drive letter (C:)
    if let Some(colon) = normalized.find(':') {
        let before = &normalized[..colon];
        if !before.contains('/') {
            return Err(format!("reference '{reference}' is a URI or absolute path and is not followed (only relative paths inside the asset's folder are read)"));
        }
    }
    let mut out = base_dir.to_path_buf();
    for comp in Path::new(&normalized).components() {
        match comp {
            Component::Normal(c) => out.push(c),
            Component::CurDir => {}
            Component::ParentDir => {
                return Err(format!(
                    "reference '{reference}' leaves the asset's folder ('..' is not followed)"
                ))
            }
            Component::RootDir | Component::Prefix(_) => {
                return Err(format!("absolute path '{reference}' is not followed"))
            }
        }
    }
    Ok(out)
}

/// Decode `%XX` escapes; `None` when an escape is malformed or the result is not UTF-8.
pub fn percent_decode(s: &str) -> Option<String> {
    if !s.contains('%') {
        return Some(s.to_string());
    }
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = s.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inside_paths_resolve() {
        let b = Path::new("/assets/a");
        assert_eq!(
            resolve_inside(b, "x.bin").unwrap(),
            PathBuf::from("/assets/a/x.bin")
        );
        assert_eq!(
            resolve_inside(b, "./tex/y z.png").unwrap(),
            PathBuf::from("/assets/a/tex/y z.png")
        );
        assert_eq!(
            resolve_inside(b, ".\\SpiderTex.jpg").unwrap(),
            PathBuf::from("/assets/a/SpiderTex.jpg")
        );
        assert_eq!(
            resolve_inside(b, "fuze%20uv.jpg").unwrap(),
            PathBuf::from("/assets/a/fuze uv.jpg")
        );
    }

    #[test]
    fn escaping_paths_are_refused() {
        let b = Path::new("/assets/a");
        for r in [
            "../secret.bin",
            "/etc/passwd",
            "C:\\x.bin",
            "file:///etc/passwd",
            "http://x/y.bin",
            "a/../../b",
            "..\\b",
            "%2e%2e/x",
            "",
        ] {
            assert!(resolve_inside(b, r).is_err(), "{r} should be refused");
        }
    }
}
