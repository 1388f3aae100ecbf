//! `cargo run --release --example fuzz -- <obj|gltf|glb|hostile> <seconds> [seed]`:
//! fuzz one reader for a while, or (`hostile`) run the `crackle` binary
//! on hostile asset folders (see `tests/fuzz_engine`); reproducers of
//! failures go to `fuzz-out/`. `hostile-case SEED` builds and runs one
//! hostile case again (its folder kept in `fuzz-out/hostile/`). Exit 1
//! when anything failed. The binary is the `crackle` beside this
//! example's folder (`target/<profile>/crackle`), or `$CRACKLE_BIN`.

#[path = "../tests/fuzz_engine/mod.rs"]
mod fuzz_engine;

const USAGE: &str =
    "usage: fuzz <obj|gltf|glb|hostile> <seconds> [seed] | fuzz hostile-case <seed>";

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    match args.first().map(String::as_str) {
        Some("hostile") | Some("hostile-case") => hostile(&root, &args),
        _ => readers(&root, &args),
    }
}

fn readers(root: &std::path::Path, args: &[String]) {
    let kind = args
        .first()
        .and_then(|k| fuzz_engine::Kind::parse(k))
        .expect(USAGE);
    let seconds: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(60.0);
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    // Panics are counted, not printed.
    std::panic::set_hook(Box::new(|_| {}));
    let sum = fuzz_engine::fuzz(
        root,
        kind,
        seed,
        usize::MAX,
        seconds,
        16 << 20,
        6 << 30,
        &root.join("fuzz-out"),
    );
    println!(
        "{:?} for {seconds} s, seed {seed}: {} mutants, {} read, {} refused, {} failures",
        kind,
        sum.cases,
        sum.read,
        sum.refused,
        sum.failures.len()
    );
    for f in &sum.failures {
        println!("  {f}");
    }
    std::process::exit(i32::from(!sum.failures.is_empty()));
}

#[cfg(not(unix))]
fn hostile(_: &std::path::Path, _: &[String]) {
    eprintln!("the hostile classes need Unix (links, FIFOs, /proc)");
    std::process::exit(2);
}

#[cfg(unix)]
fn hostile(root: &std::path::Path, args: &[String]) {
    use fuzz_engine::hostile_run::{fuzz_hostile, one_case, settings, HostileSummary};
    let bin = std::env::var_os("CRACKLE_BIN")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            let me = std::env::current_exe().unwrap();
            me.parent().unwrap().parent().unwrap().join("crackle")
        });
    assert!(
        bin.is_file(),
        "no crackle binary at {} (build it, or set CRACKLE_BIN)",
        bin.display()
    );
    let s = settings(bin, root, std::time::Duration::from_secs(120), 5_000);
    let work = root.join("fuzz-out/hostile");
    let (sum, what) = if args[0] == "hostile-case" {
        let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).expect(USAGE);
        let mut sum = HostileSummary::default();
        sum.failures = one_case(&s, seed, &work, &mut sum);
        (sum, format!("case {seed}"))
    } else {
        let seconds: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(60.0);
        let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
        let sum = fuzz_hostile(&s, seed, usize::MAX, seconds, &work);
        (sum, format!("for {seconds} s, seed {seed}"))
    };
    println!(
        "Hostile {what}: {} cases, {} succeeded, {} refused, {} failures; peak memory {} MB, slowest case {:.1} s",
        sum.cases,
        sum.succeeded,
        sum.refused,
        sum.failures.len(),
        sum.peak >> 20,
        sum.slowest
    );
    println!("  classes {:?}", sum.per_class);
    println!("  commands {:?}", sum.per_command);
    for f in &sum.failures {
        println!("  {f}");
    }
    std::process::exit(i32::from(!sum.failures.is_empty()));
}
