//! Helpers shared by the integration tests (`mod common;` in each `tests/*.rs`).
//!
//! - [`eval_data`]: files from the shared evaluation corpus at `../shared/eval-data`.
//! - [`fixture`]: the project's own small meshes in `fixtures/`.
//! - [`validator`]: the Khronos glTF-Validator, run through `node scripts/validate.mjs`
//!   (installed into `tools/node_modules` by `scripts/install-validator.sh`).
//! - [`crackle_bin`] / [`run`]: the built `crackle` CLI.
//!
//! Missing eval data or a missing validator makes a test skip (with a `SKIP:` line on
//! stderr) locally, and fail when the environment variable `CI` is `true`.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// The crate root (where Cargo.toml is).
pub fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// True when running under CI (`CI=true`, or `CI=1`), where skipping is a failure.
pub fn in_ci() -> bool {
    std::env::var("CI")
        .map(|v| v.eq_ignore_ascii_case("true") || v == "1")
        .unwrap_or(false)
}

/// Path of `rel` under `<CARGO_MANIFEST_DIR>/../shared/eval-data/`.
///
/// Returns `None` (after printing a SKIP line) when the file is missing, except under
/// CI, where missing data is a failure and this panics.
pub fn eval_data(rel: &str) -> Option<PathBuf> {
    let path = manifest_dir()
        .join("..")
        .join("shared")
        .join("eval-data")
        .join(rel);
    if path.exists() {
        return Some(path);
    }
    if in_ci() {
        panic!(
            "eval-data file {rel} not found at {} (CI=true: the shared eval data must be \
             checked out beside the project as ../shared/eval-data)",
            path.display()
        );
    }
    eprintln!("SKIP: eval-data file {rel} not found");
    None
}

/// Path of a project fixture under `fixtures/` (these ship with the repo, so a missing
/// one is always a failure).
pub fn fixture(rel: &str) -> PathBuf {
    let path = manifest_dir().join("fixtures").join(rel);
    assert!(
        path.exists(),
        "fixture {rel} not found at {} (regenerate with `python3 fixtures/make_fixtures.py`)",
        path.display()
    );
    path
}

/// The built `crackle` binary.
pub fn crackle_bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_crackle"))
}

/// Runs the `crackle` CLI with `args` (stdin closed) and returns its output.
pub fn run<I, S>(args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    Command::new(crackle_bin())
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("failed to start the crackle binary")
}

/// Like [`run`] but panics (showing stdout/stderr) unless the command succeeded.
pub fn run_ok<I, S>(args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let args: Vec<std::ffi::OsString> = args.into_iter().map(|a| a.as_ref().to_owned()).collect();
    let out = run(&args);
    assert!(
        out.status.success(),
        "crackle {:?} failed with {}\n--- stdout ---\n{}\n--- stderr ---\n{}",
        args,
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// One validator message: (code, message, severity, JSON pointer).
/// Severity: 0 = error, 1 = warning, 2 = info, 3 = hint.
pub type Message = (String, String, u8, String);

/// The summary of one glTF-Validator run on one file.
#[derive(Debug, Clone, Default)]
pub struct ValidationReport {
    pub errors: u64,
    pub warnings: u64,
    pub infos: u64,
    pub hints: u64,
    pub messages: Vec<Message>,
}

impl ValidationReport {
    /// Whether any message has this code.
    pub fn has_code(&self, code: &str) -> bool {
        self.messages.iter().any(|m| m.0 == code)
    }

    /// The messages as readable lines, for panic messages.
    pub fn describe(&self) -> String {
        let mut s = format!(
            "{} errors, {} warnings, {} infos, {} hints",
            self.errors, self.warnings, self.infos, self.hints
        );
        for (code, message, severity, pointer) in &self.messages {
            let sev = match severity {
                0 => "ERROR",
                1 => "WARNING",
                2 => "INFO",
                _ => "HINT",
            };
            s.push_str(&format!("\n  [{sev}] {code} at {pointer}: {message}"));
        }
        s
    }
}

/// A runnable Khronos glTF-Validator (node + tools/node_modules/gltf-validator).
#[derive(Debug, Clone)]
pub struct Validator {
    node: PathBuf,
    script: PathBuf,
}

/// `crackle crack INPUT OUT --report OUT.json EXTRA...`, its report next to
/// the output (see [`report`]).
pub fn crack(input: &Path, out: &Path, extra: &[&str]) -> Output {
    let rep = out.with_extension("json");
    Command::new(crackle_bin())
        .args(["crack".as_ref(), input.as_os_str(), out.as_os_str()])
        .args(["--report".as_ref(), rep.as_os_str()])
        .args(extra)
        .output()
        .unwrap()
}

/// [`crack`] with `preset`, its crack network as lines and no baked maps
/// (what the pattern measures read), then `extra`; panics naming the preset
/// when the run fails.
pub fn crack_lines(input: &Path, out: &Path, preset: &str, extra: &[&str]) {
    let mut args = vec![
        "-q",
        "--preset",
        preset,
        "--set",
        "post.lines=true",
        "--set",
        "post.bake=false",
    ];
    args.extend_from_slice(extra);
    let o = crack(input, out, &args);
    assert!(
        o.status.success(),
        "{preset} on {}: {}",
        input.display(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The report [`crack`] wrote for `out`.
pub fn report(out: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(out.with_extension("json")).unwrap()).unwrap()
}

/// The names of the stages a report lists, in order.
pub fn stages(r: &serde_json::Value) -> Vec<String> {
    r["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap().to_string())
        .collect()
}

/// Finds the glTF-Validator. Returns `None` (after printing a SKIP line) when node or
/// the package is missing, except under CI, where this panics.
pub fn validator() -> Option<Validator> {
    let root = manifest_dir();
    let package = root.join("tools/node_modules/gltf-validator/package.json");
    let script = root.join("scripts/validate.mjs");
    let node = PathBuf::from("node");
    let node_ok = Command::new(&node)
        .arg("--version")
        .stdin(Stdio::null())
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    let problem = if !node_ok {
        Some("node is not on PATH".to_string())
    } else if !package.exists() {
        Some(format!("{} is missing", package.display()))
    } else if !script.exists() {
        Some(format!("{} is missing", script.display()))
    } else {
        None
    };
    match problem {
        None => Some(Validator { node, script }),
        Some(p) if in_ci() => {
            panic!("glTF-Validator unavailable under CI: {p}; run scripts/install-validator.sh")
        }
        Some(p) => {
            eprintln!("SKIP: glTF-Validator unavailable ({p}); run scripts/install-validator.sh");
            None
        }
    }
}

impl Validator {
    /// Validates one .gltf/.glb file (external resources resolved beside it).
    pub fn validate(&self, path: impl AsRef<Path>) -> ValidationReport {
        let path = path.as_ref();
        let out = Command::new(&self.node)
            .arg(&self.script)
            .arg(path)
            .stdin(Stdio::null())
            .output()
            .expect("failed to start node for scripts/validate.mjs");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let line = stdout
            .lines()
            .find(|l| !l.trim().is_empty())
            .unwrap_or_else(|| {
                panic!(
                    "validate.mjs printed nothing for {} (exit {}); stderr:\n{stderr}",
                    path.display(),
                    out.status
                )
            });
        let v: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| {
            panic!("validate.mjs printed invalid JSON ({e}): {line}\nstderr:\n{stderr}")
        });
        let count = |k: &str| v.get(k).and_then(|x| x.as_u64()).unwrap_or(0);
        let text = |m: &serde_json::Value, k: &str| {
            m.get(k)
                .and_then(|x| x.as_str())
                .unwrap_or_default()
                .to_string()
        };
        let messages = v
            .get("messages")
            .and_then(|m| m.as_array())
            .map(|arr| {
                arr.iter()
                    .map(|m| {
                        let severity = m.get("severity").and_then(|s| s.as_u64()).unwrap_or(0);
                        (
                            text(m, "code"),
                            text(m, "message"),
                            severity.min(255) as u8,
                            text(m, "pointer"),
                        )
                    })
                    .collect()
            })
            .unwrap_or_default();
        ValidationReport {
            errors: count("errors"),
            warnings: count("warnings"),
            infos: count("infos"),
            hints: count("hints"),
            messages,
        }
    }

    /// Panics unless `out` has no error and no warning (by code) that
    /// `input`, a glTF file, does not have itself, and no unused object.
    pub fn assert_no_worse(&self, input: impl AsRef<Path>, out: impl AsRef<Path>) {
        let (input, out) = (input.as_ref(), out.as_ref());
        let before = self.validate(input);
        let after = self.validate(out);
        let had = |code: &str| before.messages.iter().any(|m| m.0 == code);
        let new: Vec<&Message> = after
            .messages
            .iter()
            .filter(|m| {
                m.2 <= 1 || (m.0 == "UNUSED_OBJECT" && !m.3.contains("/attributes/TEXCOORD_"))
            })
            .filter(|m| !had(&m.0))
            .collect();
        assert!(
            new.is_empty(),
            "glTF-Validator finds in {} what {} does not have: {new:?}",
            out.display(),
            input.display()
        );
    }

    /// Panics (listing every message) unless the file has no errors, no warnings and
    /// no `UNUSED_OBJECT` info/hint (crackle must not write unused objects).
    pub fn assert_clean(&self, path: impl AsRef<Path>) {
        let path = path.as_ref();
        let report = self.validate(path);
        // Unused objects are failures, except UV sets the validator calls "may be
        // unused" because no texture samples them: those are the artist's UVs and are kept.
        let unused = report.messages.iter().any(|(code, _, _, pointer)| {
            code == "UNUSED_OBJECT" && !pointer.contains("/attributes/TEXCOORD_")
        });
        // A primitive without normals is drawn flat and its tangents are
        // ignored (glTF 2.0, 3.7.2.1): a normal map on it can only use
        // tangents the viewer makes, and adding normals would change the
        // artist's shading. The validator's warning about that is expected.
        let json = gltf_json(path);
        let expected = report
            .messages
            .iter()
            .filter(|(code, _, severity, pointer)| {
                *severity == 1
                    && code == "MESH_PRIMITIVE_GENERATED_TANGENT_SPACE"
                    && primitive_of(&json, pointer)
                        .is_some_and(|p| p["attributes"].get("NORMAL").is_none())
            })
            .count() as u64;
        if report.errors > 0 || report.warnings > expected || unused {
            panic!(
                "glTF-Validator is not clean for {}{}: {}",
                path.display(),
                if unused { " (has UNUSED_OBJECT)" } else { "" },
                report.describe()
            );
        }
    }
}

/// The JSON of a .gltf or .glb file.
pub fn gltf_json(path: &Path) -> serde_json::Value {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let text = if bytes.starts_with(b"glTF") && bytes.len() >= 20 {
        let len = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
        &bytes[20..(20 + len).min(bytes.len())]
    } else {
        &bytes[..]
    };
    serde_json::from_slice(text).unwrap_or(serde_json::Value::Null)
}

/// The primitive a validator pointer such as `/meshes/0/primitives/1/material` is in.
fn primitive_of<'a>(json: &'a serde_json::Value, pointer: &str) -> Option<&'a serde_json::Value> {
    let parts: Vec<&str> = pointer.split('/').collect();
    let (m, p) = match parts.as_slice() {
        ["", "meshes", m, "primitives", p, ..] => {
            (m.parse::<usize>().ok()?, p.parse::<usize>().ok()?)
        }
        _ => return None,
    };
    json.get("meshes")?.get(m)?.get("primitives")?.get(p)
}

/// Every file below `dir` whose extension is one of `exts`, sorted, recursively.
pub fn files_under(dir: &Path, exts: &[&str]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            out.extend(files_under(&p, exts));
        } else if p
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| exts.contains(&e))
        {
            out.push(p);
        }
    }
    out
}

/// The image of the GLB at `path` that its first base-coloured material's
/// base colour texture names, through `EXT_texture_webp` or `source`:
/// (MIME type, bytes).
pub fn base_color_image(path: &std::path::Path) -> (String, Vec<u8>) {
    let b = std::fs::read(path).unwrap();
    let n = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    let j: serde_json::Value = serde_json::from_slice(&b[20..20 + n]).unwrap();
    let bin = &b[20 + n + 8..];
    let tex = j["materials"]
        .as_array()
        .unwrap()
        .iter()
        .find_map(|m| m["pbrMetallicRoughness"]["baseColorTexture"]["index"].as_u64())
        .expect("a base colour map") as usize;
    let t = &j["textures"][tex];
    let image = t["extensions"]["EXT_texture_webp"]["source"]
        .as_u64()
        .or(t["source"].as_u64())
        .unwrap() as usize;
    let img = &j["images"][image];
    let view = &j["bufferViews"][img["bufferView"].as_u64().unwrap() as usize];
    let off = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    let len = view["byteLength"].as_u64().unwrap() as usize;
    (
        img["mimeType"].as_str().unwrap_or_default().to_string(),
        bin[off..off + len].to_vec(),
    )
}

/// The base colour map (a PNG) of the GLB at `path`, as (width, height,
/// luminance).
pub fn base_color(path: &std::path::Path) -> (usize, usize, Vec<f64>) {
    let (_, bytes) = base_color_image(path);
    let mut decoder = png::Decoder::new(std::io::Cursor::new(&bytes[..]));
    // Palette images (a map of few colours) as their colours.
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let lum = buf[..info.buffer_size()]
        .chunks(channels)
        .map(|p| {
            p[..channels.min(3)]
                .iter()
                .map(|&x| f64::from(x))
                .sum::<f64>()
                / channels.min(3) as f64
        })
        .collect();
    (info.width as usize, info.height as usize, lum)
}
