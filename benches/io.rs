//! I/O benchmark (release): read + write of the 1.1 M-triangle bunny GLB, and
//! parse of the 496 k-triangle ogre OBJ, plus welding into simulation meshes.
//!
//! Run: `cargo bench --bench io` (needs ../shared/eval-data). Prints the
//! median and minimum of several runs per stage. Target: read + write and OBJ
//! parse each under 1.5 s.

use std::path::{Path, PathBuf};
use std::time::Instant;

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

fn time<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, f64) {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let s = Instant::now();
            std::hint::black_box(f());
            s.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    (t[t.len() / 2], t[0])
}

fn report(name: &str, (median, min): (f64, f64)) {
    println!("{name:<44} median {median:>7.3} s   min {min:>7.3} s");
}

fn main() {
    let runs = std::env::var("BENCH_RUNS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(5);
    let dir = std::env::temp_dir().join(format!("crackle-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    println!(
        "crackle I/O benchmark, {runs} runs per stage, {} rayon threads",
        rayon::current_num_threads()
    );
    if let Some(bunny) = eval("large/bunny_loop2_1.1M.glb") {
        let scene = crackle::io::read(&bunny).unwrap();
        println!("bunny_loop2_1.1M.glb: {} triangles", scene.triangle_count());
        report(
            "bunny 1.1M: read GLB",
            time(runs, || crackle::io::read(&bunny).unwrap()),
        );
        let out = dir.join("bunny.glb");
        report(
            "bunny 1.1M: write GLB",
            time(runs, || {
                crackle::io::gltf_write::write_scene(&scene, &out).unwrap()
            }),
        );
        report(
            "bunny 1.1M: read + write GLB",
            time(runs, || {
                let s = crackle::io::read(&bunny).unwrap();
                crackle::io::gltf_write::write_scene(&s, &out).unwrap()
            }),
        );
        report(
            "bunny 1.1M: weld to simulation mesh",
            time(runs, || {
                crackle::bridge::build_sim_meshes(&scene, &Default::default())
            }),
        );
        report(
            "bunny 1.1M: read + weld + write (convert)",
            time(runs, || {
                let mut s = crackle::io::read(&bunny).unwrap();
                let (entries, _) = crackle::bridge::build_sim_meshes(&s, &Default::default());
                for e in &entries {
                    crackle::bridge::write_back(&mut s, e);
                }
                crackle::io::gltf_write::write_scene(&s, &out).unwrap()
            }),
        );
    }
    if let Some(ogre) = eval("large/ogre_loop1_496k.obj") {
        let scene = crackle::io::read(&ogre).unwrap();
        println!("ogre_loop1_496k.obj: {} triangles", scene.triangle_count());
        report(
            "ogre 496k: parse OBJ",
            time(runs, || crackle::io::read(&ogre).unwrap()),
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
