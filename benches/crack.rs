//! Crack-simulation benchmark (release): the whole quasistatic crack loop
//! with default parameters on
//!
//! - `plate`: a jittered 100x100 plate of 20,000 triangles built here, and
//! - `armadillo`: the ~86k-triangle armadillo OBJ (needs ../shared/eval-data).
//!
//! Run: `cargo bench --bench crack`. Environment knobs: `BENCH_RUNS` (runs per
//! case, default 1 since runs are long) and `BENCH_CASES` (comma list of
//! `plate`, `armadillo`; default both). Prints, per case, the wall-clock time
//! of `crackle::sim::run` alone and of the setup (mesh generation or read +
//! weld) separately, the run's report, a checksum to compare runs for
//! determinism, and the speed-up over Iben & O'Brien 2009 (2.05 min for
//! 19,602 triangles, 2.17 h for 75,000 triangles; different machine and
//! meshes, so only an order-of-magnitude comparison).

use crackle::mesh::{SimMesh, WeldOptions};
use crackle::sim::{SimParams, SimReport};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Paper time for 19,602 triangles (2.05 min).
const PAPER_PLATE_S: f64 = 123.0;
/// Paper time for 75,000 triangles (2.17 h).
const PAPER_ARMADILLO_S: f64 = 7812.0;

fn eval(rel: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/eval-data")
        .join(rel);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("SKIP: {} not found", p.display());
        None
    }
}

/// Seconds taken by `f`, and its result.
fn time<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let s = Instant::now();
    let r = std::hint::black_box(f());
    (s.elapsed().as_secs_f64(), r)
}

/// FNV-1a over the bits of every crack segment end point.
fn segment_hash(reports: &[SimReport]) -> u64 {
    let mut h: u64 = 0xcbf29ce484222325;
    for seg in reports.iter().flat_map(|r| &r.segments) {
        for x in seg.iter().flatten() {
            for b in x.to_bits().to_le_bytes() {
                h = (h ^ b as u64).wrapping_mul(0x100000001b3);
            }
        }
    }
    h
}

/// One run of one case: setup and simulation times and the reports of every
/// simulated mesh (one for the plate; one per scene mesh for an asset).
struct Outcome {
    setup: f64,
    run: f64,
    reports: Vec<SimReport>,
}

impl Outcome {
    fn checksum(&self) -> String {
        let faces: usize = self.reports.iter().map(|r| r.triangles[1]).sum();
        let length: f64 = self.reports.iter().map(|r| r.crack_length).sum();
        format!("{faces}/{length:.6}/{:016x}", segment_hash(&self.reports))
    }
}

/// Runs the simulation on every mesh, timing only `crackle::sim::run`.
fn simulate(meshes: &mut [SimMesh], params: &SimParams) -> (f64, Vec<SimReport>) {
    let mut total = 0.0;
    let mut reports = Vec::new();
    for m in meshes.iter_mut() {
        let (t, r) = time(|| crackle::sim::run(m, params, &mut ()));
        total += t;
        reports.push(r.expect("simulation failed"));
    }
    (total, reports)
}

fn plate(params: &SimParams) -> Outcome {
    let (setup, mut meshes) = time(|| {
        let input = crackle::mesh::shapes::jittered_plate_input(100, 0.3, 0x5eed_c0ff_ee00_0001);
        let (m, _defects) =
            SimMesh::build(&input, &WeldOptions::default()).expect("plate mesh build failed");
        vec![m]
    });
    let (run, reports) = simulate(&mut meshes, params);
    Outcome {
        setup,
        run,
        reports,
    }
}

fn asset(path: &Path, params: &SimParams) -> Outcome {
    let (setup, mut meshes) = time(|| {
        let scene = crackle::io::read(path).expect("read failed");
        let (entries, skipped) = crackle::bridge::build_sim_meshes(&scene, &WeldOptions::default());
        for s in &skipped {
            eprintln!("  skipped {}: {}", s.label, s.reason);
        }
        entries.into_iter().map(|e| e.sim).collect::<Vec<_>>()
    });
    let (run, reports) = simulate(&mut meshes, params);
    Outcome {
        setup,
        run,
        reports,
    }
}

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn report(name: &str, paper_s: f64, paper_tris: usize, outs: &[Outcome]) {
    let last = outs.last().expect("at least one run");
    let r = &last.reports;
    let before: usize = r.iter().map(|x| x.triangles[0]).sum();
    let after: usize = r.iter().map(|x| x.triangles[1]).sum();
    let cracks: usize = r.iter().map(|x| x.cracks).sum();
    let rounds: usize = r.iter().map(|x| x.rounds).sum();
    let steps: usize = r.iter().map(|x| x.relax_steps).sum();
    let length: f64 = r.iter().map(|x| x.crack_length).sum();
    let stopped = r
        .iter()
        .map(|x| x.stopped.as_str())
        .collect::<Vec<_>>()
        .join("; ");
    let run = median(outs.iter().map(|o| o.run).collect());
    let run_min = outs.iter().map(|o| o.run).fold(f64::INFINITY, f64::min);
    let setup = median(outs.iter().map(|o| o.setup).collect());
    let sums: Vec<String> = outs.iter().map(Outcome::checksum).collect();
    let deterministic = sums.iter().all(|s| *s == sums[0]);
    println!(
        "{name:<10} tris {before:>7} -> {after:>7}  run {run:>9.3} s (min {run_min:.3}, {n} runs)  \
         setup {setup:>7.3} s  cracks {cracks:>6}  rounds {rounds:>4}  relax_steps {steps:>6}  \
         crack_length {length:.3}  stopped {stopped:?}  checksum {sum}{det}",
        n = outs.len(),
        sum = sums[0],
        det = if deterministic {
            ""
        } else {
            "  NONDETERMINISTIC"
        },
    );
    if !deterministic {
        for (i, s) in sums.iter().enumerate() {
            println!("{:<10} run {i} checksum {s}", "");
        }
    }
    println!(
        "{:<10} paper (Iben & O'Brien 2009): {paper_s:.0} s for {paper_tris} triangles; \
         speed-up {:.1}x",
        "",
        paper_s / run,
    );
}

fn main() {
    let runs: usize = std::env::var("BENCH_RUNS")
        .ok()
        .and_then(|r| r.parse().ok())
        .filter(|&r| r > 0)
        .unwrap_or(1);
    let cases = std::env::var("BENCH_CASES").unwrap_or_else(|_| "plate,armadillo".into());
    let cases: Vec<&str> = cases
        .split(',')
        .map(str::trim)
        .filter(|c| !c.is_empty())
        .collect();
    for c in &cases {
        if !matches!(*c, "plate" | "armadillo") {
            eprintln!("unknown case {c:?} in BENCH_CASES (known: plate, armadillo)");
        }
    }
    let params = SimParams::default();
    println!(
        "crackle crack-simulation benchmark, default parameters, {runs} run(s) per case, {} rayon threads",
        rayon::current_num_threads()
    );
    if cases.contains(&"plate") {
        let outs: Vec<Outcome> = (0..runs)
            .map(|i| {
                eprintln!("plate: run {}/{runs}...", i + 1);
                plate(&params)
            })
            .collect();
        report("plate", PAPER_PLATE_S, 19_602, &outs);
    }
    if cases.contains(&"armadillo") {
        if let Some(path) = eval("obj/armadillo/armadillo.obj") {
            let outs: Vec<Outcome> = (0..runs)
                .map(|i| {
                    eprintln!("armadillo: run {}/{runs}...", i + 1);
                    asset(&path, &params)
                })
                .collect();
            report("armadillo", PAPER_ARMADILLO_S, 75_000, &outs);
        }
    }
}
