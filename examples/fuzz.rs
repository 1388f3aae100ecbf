//! `cargo run --release --example fuzz -- <obj|gltf|glb> <seconds> [seed]`:
//! fuzz one reader for a while (see `tests/fuzz_engine`); reproducers of
//! failures go to `fuzz-out/`. Exit 1 when anything failed.

#[path = "../tests/fuzz_engine/mod.rs"]
mod fuzz_engine;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let kind = args
        .first()
        .and_then(|k| fuzz_engine::Kind::parse(k))
        .expect("usage: fuzz <obj|gltf|glb> <seconds> [seed]");
    let seconds: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(60.0);
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    // Panics are counted, not printed.
    std::panic::set_hook(Box::new(|_| {}));
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let sum = fuzz_engine::fuzz(
        &root,
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
