//! Running a hostile case ([`super::hostile`]) as a child process and
//! checking it: no panic, abort or signal, no hang (killed after the time
//! limit), peak memory (the child's `ru_maxrss`) within `--max-memory`
//! plus a slack, nothing changed or created outside the output folder (the
//! victim folder's files keep their bytes and times, nothing new appears
//! there), no output holding the secret token, and, after exit 0, every
//! glTF/GLB written readable with the files it names beside it.

use super::hostile::{build, Case, Class, Settings};
use super::Rng;
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How the child ended.
#[derive(Debug)]
pub struct Run {
    pub code: Option<i32>,
    pub signal: Option<i32>,
    /// Killed by us: over the time limit, or over the hard memory cap.
    pub timed_out: bool,
    pub memory_killed: bool,
    /// Peak resident memory, bytes.
    pub peak: u64,
    pub stderr: String,
    pub seconds: f64,
}

/// The current resident memory of `pid` (bytes), from /proc.
fn rss_of(pid: i32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = s.lines().find(|l| l.starts_with("VmRSS:"))?;
    Some(line.split_whitespace().nth(1)?.parse::<u64>().ok()? * 1024)
}

/// Swap each (file, victim) pair: the file moves aside and a link to the
/// victim takes its place, then the file comes back; until `stop`.
fn swapper(swaps: Vec<(PathBuf, PathBuf)>, stop: Arc<AtomicBool>) {
    let aside = |p: &Path| {
        let mut s = p.as_os_str().to_owned();
        s.push(".swap-aside");
        PathBuf::from(s)
    };
    let mut n = 0u64;
    while !stop.load(Ordering::Relaxed) {
        for (p, v) in &swaps {
            if std::fs::rename(p, aside(p)).is_ok() {
                let _ = std::os::unix::fs::symlink(v, p);
            }
        }
        std::thread::sleep(Duration::from_micros(200 + (n % 7) * 300));
        for (p, _) in &swaps {
            let _ = std::fs::remove_file(p);
            let _ = std::fs::rename(aside(p), p);
        }
        std::thread::sleep(Duration::from_micros(300 + (n % 5) * 400));
        n += 1;
    }
}

/// Run the case's command, bounded in time and memory.
// The child is reaped by `wait4` (for its resource usage), not `wait`.
#[allow(clippy::zombie_processes)]
pub fn run_child(s: &Settings, case: &Case) -> Run {
    use std::os::unix::process::CommandExt as _;
    let start = Instant::now();
    // Its own process group: a kill reaches whatever it started.
    let mut child = Command::new(&s.bin)
        .process_group(0)
        .args(&case.args)
        .current_dir(case.dir.join("cwd"))
        .env("CRACKLE_FUZZ_SECRET", &case.token)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start crackle");
    let pid = child.id() as i32;
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = err.read_to_end(&mut v);
        v.truncate(64 << 10);
        String::from_utf8_lossy(&v).into_owned()
    });
    let stop = Arc::new(AtomicBool::new(false));
    let swapping = (!case.swaps.is_empty()).then(|| {
        let (swaps, stop) = (case.swaps.clone(), stop.clone());
        std::thread::spawn(move || swapper(swaps, stop))
    });
    let hard_cap = ((s.max_memory + s.slack) * 2).max(2 << 30);
    let (mut timed_out, mut memory_killed) = (false, false);
    let mut status = 0i32;
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        // SAFETY: `pid` is our own child, not yet reaped; status and usage
        // are valid out-pointers.
        let r = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
        if r == pid {
            break;
        }
        assert!(r == 0, "wait4: {}", std::io::Error::last_os_error());
        let over_time = start.elapsed() > s.limit;
        let over_memory = rss_of(pid).is_some_and(|m| m > hard_cap);
        if over_time || over_memory {
            timed_out |= over_time;
            memory_killed |= over_memory;
            // SAFETY: as above; the child's group is killed, then the
            // child reaped.
            unsafe {
                libc::kill(-pid, libc::SIGKILL);
                libc::wait4(pid, &mut status, 0, &mut usage);
            }
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    stop.store(true, Ordering::Relaxed);
    if let Some(t) = swapping {
        t.join().unwrap();
    }
    let stderr = reader.join().unwrap_or_default();
    let (code, signal) = if libc::WIFEXITED(status) {
        (Some(libc::WEXITSTATUS(status)), None)
    } else if libc::WIFSIGNALED(status) {
        (None, Some(libc::WTERMSIG(status)))
    } else {
        (None, None)
    };
    Run {
        code,
        signal,
        timed_out,
        memory_killed,
        peak: usage.ru_maxrss.max(0) as u64 * 1024,
        stderr,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// What a snapshot keeps of an entry (links are not followed).
#[derive(Clone, Debug, PartialEq, Eq)]
enum Entry {
    File {
        len: u64,
        mtime: (i64, i64),
        hash: Option<String>,
    },
    Dir,
    Link(PathBuf),
    Other,
}

/// Every entry below `root` but `skip` (and its subtree).
fn snapshot(root: &Path, skip: &Path) -> BTreeMap<PathBuf, Entry> {
    use std::os::unix::fs::MetadataExt as _;
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            if p == skip {
                continue;
            }
            let Ok(m) = std::fs::symlink_metadata(&p) else {
                continue;
            };
            let entry = if m.file_type().is_symlink() {
                Entry::Link(std::fs::read_link(&p).unwrap_or_default())
            } else if m.is_dir() {
                stack.push(p.clone());
                Entry::Dir
            } else if m.is_file() {
                // Small files by content too (sparse ones by size and time).
                let hash = (m.len() <= 16 << 20)
                    .then(|| std::fs::read(&p).ok())
                    .flatten()
                    .map(|b| super::hostile::content_tag(&b));
                Entry::File {
                    len: m.len(),
                    mtime: (m.mtime(), m.mtime_nsec()),
                    hash,
                }
            } else {
                Entry::Other
            };
            out.insert(p, entry);
        }
    }
    out
}

/// Regular files below `dir` (links not followed).
fn files_below(dir: &Path) -> Vec<PathBuf> {
    snapshot(dir, Path::new(""))
        .into_iter()
        .filter(|(_, e)| matches!(e, Entry::File { .. }))
        .map(|(p, _)| p)
        .collect()
}

/// Whether the file holds `needle` (read in pieces: outputs may be large).
fn holds(path: &Path, needle: &[u8]) -> bool {
    let Ok(mut f) = std::fs::File::open(path) else {
        return false;
    };
    let mut buf = vec![0u8; 1 << 20];
    let mut keep: Vec<u8> = Vec::new();
    loop {
        let n = match f.read(&mut buf) {
            Ok(0) | Err(_) => return false,
            Ok(n) => n,
        };
        keep.extend_from_slice(&buf[..n]);
        if keep.windows(needle.len()).any(|w| w == needle) {
            return true;
        }
        let tail = keep.len().saturating_sub(needle.len());
        keep.drain(..tail);
    }
}

/// The JSON of a .gltf or .glb output, or why it is malformed.
fn output_json(path: &Path) -> Result<serde_json::Value, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let json = if path.extension().is_some_and(|e| e == "glb") {
        if bytes.len() < 20 || &bytes[..4] != b"glTF" {
            return Err("not a GLB".into());
        }
        let total = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
        if total != bytes.len() {
            return Err(format!("GLB length {total}, file {}", bytes.len()));
        }
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        bytes
            .get(20..20 + len)
            .ok_or("JSON chunk past the end")?
            .to_vec()
    } else {
        bytes
    };
    serde_json::from_slice(&json).map_err(|e| e.to_string())
}

/// `%XX` decoded.
fn uri_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 3 <= b.len() {
            if let Ok(v) = u8::from_str_radix(&s[i + 1..i + 3], 16) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Problems of one glTF/GLB output: malformed, a named file missing, not a
/// regular file, or outside the output folder; unreadable by the reader.
fn check_output(path: &Path, out_root: &Path, max_memory: u64, read: bool) -> Vec<String> {
    let mut bad = Vec::new();
    let json = match output_json(path) {
        Ok(j) => j,
        Err(e) => return vec![format!("{}: malformed output: {e}", path.display())],
    };
    let dir = path.parent().unwrap();
    for key in ["buffers", "images"] {
        for item in json[key].as_array().into_iter().flatten() {
            let Some(uri) = item["uri"].as_str() else {
                continue;
            };
            if uri.starts_with("data:") {
                continue;
            }
            let rel = uri_decode(uri);
            let p = dir.join(&rel);
            let inside = !Path::new(&rel).is_absolute()
                && !Path::new(&rel)
                    .components()
                    .any(|c| matches!(c, std::path::Component::ParentDir))
                && p.starts_with(out_root);
            let regular = std::fs::symlink_metadata(&p).is_ok_and(|m| m.is_file());
            if !inside || !regular {
                bad.push(format!(
                    "{}: {key} uri '{uri}' is {}",
                    path.display(),
                    if inside {
                        "not a regular file in the output folder"
                    } else {
                        "outside the output folder"
                    }
                ));
            }
        }
    }
    if read && bad.is_empty() {
        let options = crackle::io::ReadOptions { max_memory };
        if let Err(e) = crackle::io::read_with(path, &options) {
            bad.push(format!(
                "{}: the output does not read back: {e}",
                path.display()
            ));
        }
    }
    bad
}

/// Run `case` and check it; returns the run and the failures.
pub fn run_case(s: &Settings, case: &Case) -> (Run, Vec<String>) {
    let (out, victim) = (case.out(), case.victim());
    let before = snapshot(&case.dir, &out);
    let out_before = snapshot(&out, Path::new(""));
    let run = run_child(s, case);
    let mut fails = Vec::new();
    let tail: String = {
        let lines: Vec<&str> = run.stderr.lines().collect();
        lines[lines.len().saturating_sub(6)..].join(" | ")
    };
    if run.timed_out {
        fails.push(format!("hang: still running after {:?}", s.limit));
    }
    if run.memory_killed {
        let cap = ((s.max_memory + s.slack) * 2).max(2 << 30);
        fails.push(format!("memory: killed over {} MB resident", cap >> 20));
    } else if run.peak > s.max_memory + s.slack {
        fails.push(format!(
            "memory: peak {} MB, over --max-memory {} MB + {} MB",
            run.peak >> 20,
            s.max_memory >> 20,
            s.slack >> 20
        ));
    }
    if let Some(sig) = run.signal.filter(|_| !run.timed_out && !run.memory_killed) {
        fails.push(format!("signal {sig}: {tail}"));
    }
    if matches!(run.code, Some(101) | Some(134)) || run.stderr.contains("panicked") {
        fails.push(format!("panic or abort (exit {:?}): {tail}", run.code));
    }
    if let Some(c) = run.code.filter(|c| *c > 3) {
        fails.push(format!("exit code {c}: {tail}"));
    }
    // Nothing outside the output folder changed or appeared.
    let after = snapshot(&case.dir, &out);
    for (p, e) in &after {
        match before.get(p) {
            None => fails.push(format!("escape: {} created", p.display())),
            Some(b) if b != e => fails.push(format!("escape: {} changed", p.display())),
            _ => {}
        }
    }
    for p in before.keys().filter(|p| !after.contains_key(*p)) {
        let what = if p.starts_with(&victim) {
            "victim"
        } else {
            "input"
        };
        fails.push(format!("escape: {what} {} removed", p.display()));
    }
    // No output holds the secret.
    let written: Vec<PathBuf> = files_below(&out);
    for f in &written {
        if holds(f, case.token.as_bytes()) {
            fails.push(format!(
                "escape: {} holds the secret (a victim file or the environment)",
                f.display()
            ));
        }
    }
    // After exit 0, what was written reads back.
    if run.code == Some(0) {
        let out_after = snapshot(&out, Path::new(""));
        let asset_hashes: Vec<Option<String>> = before
            .iter()
            .filter(|(p, _)| p.starts_with(case.asset()))
            .filter_map(|(_, e)| match e {
                Entry::File { hash, .. } => Some(hash.clone()),
                _ => None,
            })
            .collect();
        for f in &written {
            let ext = f.extension().and_then(|e| e.to_str()).unwrap_or("");
            let e = out_after.get(f);
            if !matches!(ext, "gltf" | "glb") || out_before.get(f) == e {
                continue;
            }
            // Copies of inputs are the input's bytes: their side files are
            // checked, not their reading.
            let copied = matches!(e, Some(Entry::File { hash: Some(h), .. })
                if asset_hashes.contains(&Some(h.clone())));
            fails.extend(check_output(f, &out, s.max_memory, !copied));
        }
    }
    (run, fails)
}

/// Counts of a hostile run.
#[derive(Debug, Default)]
pub struct HostileSummary {
    pub cases: usize,
    /// Exit 0; exit 1-3 (refused, named).
    pub succeeded: usize,
    pub refused: usize,
    pub per_class: BTreeMap<Class, usize>,
    pub per_command: BTreeMap<String, usize>,
    /// Largest peak resident memory of a child, bytes.
    pub peak: u64,
    /// Longest case, seconds.
    pub slowest: f64,
    /// One line per failure, with its reproducer.
    pub failures: Vec<String>,
}

/// Run `cases` hostile cases (or for `seconds`) from `seed`, in case
/// folders under `work`: a passing case's folder is removed, a failing
/// one's kept, with `repro.sh` (the command line; swapped-file cases need
/// the swapping too: `cargo run --release --example fuzz -- hostile-case
/// SEED`).
pub fn fuzz_hostile(
    s: &Settings,
    seed: u64,
    cases: usize,
    seconds: f64,
    work: &Path,
) -> HostileSummary {
    std::fs::create_dir_all(work).unwrap();
    let mut rng = Rng(seed ^ 0x2545_f491_4f6c_dd1d);
    let mut sum = HostileSummary::default();
    let start = Instant::now();
    while sum.cases < cases && start.elapsed().as_secs_f64() < seconds {
        // The low byte names the main class: N cases go round them all.
        let case_seed = (rng.next() & !0xff) | (sum.cases % 10) as u64;
        let failures = one_case(s, case_seed, work, &mut sum);
        for f in failures {
            sum.failures.push(f);
        }
    }
    sum
}

/// Build, run and check case `case_seed` in `work/case-SEED`; count it in
/// `sum`. Returns its failures, each with its reproducer.
pub fn one_case(
    s: &Settings,
    case_seed: u64,
    work: &Path,
    sum: &mut HostileSummary,
) -> Vec<String> {
    let dir = work.join(format!("case-{case_seed}"));
    if dir.exists() {
        std::fs::remove_dir_all(&dir).unwrap();
    }
    let case = build(s, case_seed, &dir);
    let (run, fails) = run_case(s, &case);
    sum.cases += 1;
    for c in &case.classes {
        *sum.per_class.entry(*c).or_default() += 1;
    }
    *sum.per_command
        .entry(format!("{:?}", case.cmd))
        .or_default() += 1;
    match run.code {
        Some(0) => sum.succeeded += 1,
        Some(1..=3) => sum.refused += 1,
        _ => {}
    }
    sum.peak = sum.peak.max(run.peak);
    sum.slowest = sum.slowest.max(run.seconds);
    if fails.is_empty() {
        let _ = std::fs::remove_dir_all(&dir);
        return fails;
    }
    let cmd = case.command_line(&s.bin);
    let _ = std::fs::write(dir.join("repro.sh"), format!("#!/bin/sh\n{cmd}\n"));
    let swap = if case.swaps.is_empty() {
        String::new()
    } else {
        " (with files swapped while it runs)".into()
    };
    fails
        .into_iter()
        .map(|f| {
            format!(
                "case {case_seed} {:?} {:?}{swap}: {f}\n    reproduce: cargo run --release --example fuzz -- hostile-case {case_seed}\n    or: {cmd}",
                case.cmd, case.classes
            )
        })
        .collect()
}

/// Settings for `bin`, the fixtures under `root`.
pub fn settings(bin: PathBuf, root: &Path, limit: Duration, max_many: usize) -> Settings {
    Settings {
        bin,
        fixtures: root.join("fixtures"),
        max_memory: 256 << 20,
        slack: 256 << 20,
        limit,
        max_many,
    }
}
