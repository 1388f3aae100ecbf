//! The fuzzing engine shared by `tests/fuzz.rs` (a short seeded run in the
//! test suite) and `examples/fuzz.rs` (`scripts/fuzz.sh [seconds]`): it
//! mutates the fixtures and the eval-data meshes (bytes, JSON numbers, OBJ
//! indices, huge counts, truncation, repetition, GLB chunk lengths) and runs
//! the reader on each mutant in this process, recording any panic, hang or
//! memory overrun with its reproducer. `hostile` and `hostile_run` build
//! hostile asset folders and run the real binary on them (kind `hostile`).
#![allow(dead_code)]

#[cfg(unix)]
pub mod hostile;
#[cfg(unix)]
pub mod hostile_run;

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Which reader a corpus file goes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Obj,
    Gltf,
    Glb,
}

impl Kind {
    pub fn parse(s: &str) -> Option<Kind> {
        match s {
            "obj" => Some(Kind::Obj),
            "gltf" => Some(Kind::Gltf),
            "glb" => Some(Kind::Glb),
            _ => None,
        }
    }

    pub fn ext(self) -> &'static str {
        match self {
            Kind::Obj => "obj",
            Kind::Gltf => "gltf",
            Kind::Glb => "glb",
        }
    }
}

/// One seed file: its path (its folder resolves references) and bytes.
pub struct Seed {
    pub path: PathBuf,
    pub bytes: Vec<u8>,
}

/// Seed files of `kind` under the fixtures and (when present) the
/// eval-data, at most `max_bytes` each, sorted by path.
pub fn corpus(root: &Path, kind: Kind, max_bytes: u64) -> Vec<Seed> {
    let mut dirs = vec![root.join("fixtures")];
    let eval = root.join("../shared/eval-data");
    for sub in ["obj", "gltf", "derived", "reject"] {
        dirs.push(eval.join(sub));
    }
    let mut files = Vec::new();
    let mut stack = dirs;
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            let Ok(meta) = std::fs::symlink_metadata(&p) else {
                continue;
            };
            if meta.is_dir() {
                stack.push(p);
            } else if meta.is_file()
                && meta.len() <= max_bytes
                && p.extension()
                    .and_then(|x| x.to_str())
                    .is_some_and(|x| x.eq_ignore_ascii_case(kind.ext()))
            {
                files.push(p);
            }
        }
    }
    files.sort();
    files
        .into_iter()
        .filter_map(|path| {
            let bytes = std::fs::read(&path).ok()?;
            Some(Seed { path, bytes })
        })
        .collect()
}

/// A small deterministic generator (xorshift64*).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        let mut x = self.0.max(1);
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// Numbers that break naive readers.
const HOSTILE_NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "2",
    "3",
    "255",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "99999999999999999999",
    "1e308",
    "-1e308",
    "1e-320",
    "nan",
    "inf",
    "-0",
    "0.5",
    "1000000000",
];

/// Digit runs of `b`: (start, end) of each maximal `[0-9]+`.
fn numbers(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() {
            let s = i;
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            out.push((s, i));
        } else {
            i += 1;
        }
    }
    out
}

/// One mutant of `seed` (1 or 2 mutations stacked).
pub fn mutate(seed: &[u8], kind: Kind, rng: &mut Rng) -> Vec<u8> {
    let mut b = seed.to_vec();
    for _ in 0..1 + rng.below(2) {
        if b.is_empty() {
            b.push(b'0');
        }
        // Half the mutations change a number: the file stays parseable
        // and the reader's checks, not its parser, meet the mutant.
        let op = if rng.below(2) == 0 { 1 } else { rng.below(7) };
        match op {
            // Flip bytes.
            0 => {
                for _ in 0..1 + rng.below(8) {
                    let i = rng.below(b.len());
                    b[i] ^= 1 << rng.below(8);
                }
            }
            // A number (JSON value, OBJ index or coordinate, count) becomes
            // a hostile one.
            1 | 2 => {
                let nums = numbers(&b);
                if nums.is_empty() {
                    continue;
                }
                let (s, e) = nums[rng.below(nums.len())];
                let mut with = HOSTILE_NUMBERS[rng.below(HOSTILE_NUMBERS.len())].to_string();
                if kind == Kind::Obj && rng.below(3) == 0 {
                    with = format!("-{}", 1 + rng.below(100_000));
                }
                b.splice(s..e, with.bytes());
            }
            // Truncate.
            3 => {
                let at = rng.below(b.len());
                b.truncate(at);
            }
            // Repeat a slice (lines, array elements) many times.
            4 => {
                let s = rng.below(b.len());
                let len = (1 + rng.below(200)).min(b.len() - s);
                let piece = b[s..s + len].to_vec();
                let times = 1 + rng.below(2_000);
                let mut rep = Vec::with_capacity(piece.len() * times);
                for _ in 0..times {
                    rep.extend_from_slice(&piece);
                }
                b.splice(s..s, rep);
            }
            // GLB: a header or chunk length becomes hostile.
            5 if kind == Kind::Glb && b.len() >= 20 => {
                let at = [8, 12, 16][rng.below(3)];
                let v: u32 = [0, 1, 3, 0x7fff_ffff, 0xffff_ffff, b.len() as u32 + 4][rng.below(6)];
                b[at..at + 4].copy_from_slice(&v.to_le_bytes());
            }
            // Insert random bytes.
            _ => {
                let at = rng.below(b.len() + 1);
                let n = 1 + rng.below(16);
                let junk: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                b.splice(at..at, junk);
            }
        }
    }
    b
}

/// What one mutant did.
#[derive(Debug, PartialEq, Eq)]
pub enum Outcome {
    Read,
    Refused,
    Panic(String),
    Hang,
}

/// Run the reader of `kind` on `bytes` as a file in `dir`, in a thread
/// given `limit` (a hang is reported, and its thread left behind).
pub fn run_one(kind: Kind, bytes: Vec<u8>, dir: PathBuf, limit: Duration) -> Outcome {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let r = std::panic::catch_unwind(|| match kind {
            Kind::Obj => crackle::io::obj::read_obj_from_str(
                &String::from_utf8_lossy(&bytes),
                &dir,
                "fuzz.obj",
            )
            .map(|_| ())
            .map_err(|e| e.to_string()),
            Kind::Gltf | Kind::Glb => crackle::io::gltf_read::read_gltf_bytes(
                &bytes,
                &dir,
                Path::new(if kind == Kind::Glb {
                    "fuzz.glb"
                } else {
                    "fuzz.gltf"
                }),
            )
            .map(|_| ())
            .map_err(|e| e.to_string()),
        });
        let _ = tx.send(r);
    });
    match rx.recv_timeout(limit) {
        Ok(Ok(Ok(()))) => Outcome::Read,
        Ok(Ok(Err(_))) => Outcome::Refused,
        Ok(Err(p)) => Outcome::Panic(
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default(),
        ),
        Err(_) => Outcome::Hang,
    }
}

/// The peak resident memory of this process (Linux), in bytes.
pub fn peak_rss() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    Some(line.split_whitespace().nth(1)?.parse::<u64>().ok()? * 1024)
}

/// Counts of a fuzzing run.
#[derive(Debug, Default)]
pub struct Summary {
    pub cases: usize,
    pub read: usize,
    pub refused: usize,
    /// Reproducers of panics, hangs and overruns (paths written).
    pub failures: Vec<String>,
}

/// Fuzz the reader of `kind` for `cases` mutants or `seconds`, whichever
/// ends first, from `seed`; each failure's mutant is written to `out` (the
/// one being run is kept as `<out>/current.<ext>` so a hang that stops the
/// process leaves it). A hang or an overrun of `max_rss` stops the run.
#[allow(clippy::too_many_arguments)]
pub fn fuzz(
    root: &Path,
    kind: Kind,
    seed: u64,
    cases: usize,
    seconds: f64,
    max_seed_bytes: u64,
    max_rss: u64,
    out: &Path,
) -> Summary {
    let seeds = corpus(root, kind, max_seed_bytes);
    assert!(
        !seeds.is_empty(),
        "no {} seed file under {}",
        kind.ext(),
        root.display()
    );
    std::fs::create_dir_all(out).unwrap();
    let mut rng = Rng(seed ^ 0x9e37_79b9_7f4a_7c15);
    let mut sum = Summary::default();
    let start = Instant::now();
    while sum.cases < cases && start.elapsed().as_secs_f64() < seconds {
        let s = &seeds[rng.below(seeds.len())];
        let mutant = mutate(&s.bytes, kind, &mut rng);
        let current = out.join(format!("current.{}", kind.ext()));
        let _ = std::fs::write(&current, &mutant);
        let dir = s.path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let outcome = run_one(kind, mutant.clone(), dir, Duration::from_secs(20));
        sum.cases += 1;
        let mut fail = |what: String| {
            let p = out.join(format!(
                "{}-{}-{}.{}",
                kind.ext(),
                seed,
                sum.cases,
                kind.ext()
            ));
            let _ = std::fs::write(&p, &mutant);
            sum.failures.push(format!(
                "{what} on a mutant of {} (reproducer {})",
                s.path.display(),
                p.display()
            ));
        };
        match outcome {
            Outcome::Read => sum.read += 1,
            Outcome::Refused => sum.refused += 1,
            Outcome::Panic(m) => fail(format!("panic '{m}'")),
            Outcome::Hang => {
                fail("hang (more than 20 s)".into());
                break;
            }
        }
        if peak_rss().is_some_and(|r| r > max_rss) {
            fail(format!("peak memory over {} MB", max_rss >> 20));
            break;
        }
    }
    let _ = std::fs::remove_file(out.join(format!("current.{}", kind.ext())));
    sum
}
