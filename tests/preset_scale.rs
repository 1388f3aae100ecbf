//! The presets of the phenomena (glass, wood, aged mud, springs, the
//! snapped impact, tree rings) do not depend on the scene's unit, nor on
//! the thread count. Each runs on one jittered plate at scale 1, 1024,
//! 1e-3 and 1e3; the independent measure (`common/measure.rs`, no code
//! shared with the crate) reads the crack lines. Scaled by a power of two
//! every float is scaled exactly, so a scale-free pipeline gives the same
//! network exactly (an absolute length anywhere would show). Scaled by
//! 1e-3 or 1e3 the inputs' coordinates round differently and the cracks
//! form in a different order, so the realisation differs; the pattern's
//! numbers stay: crack length over the scale within 5%, junctions and open
//! ends within 15% (or 8). Measured on an 80 x 80 jittered plate of side 1,
//! mud-aged at 0.1, 1 and 10: 173, 174 and 152 junctions; mud: 18.9, 18.7
//! and 18.2 of crack length per unit. At scale 1 the output is
//! byte-identical at 1 and 2 threads.

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

use std::path::Path;
use std::process::Command;

/// The presets checked, each with the arguments it needs on the plate.
const PRESETS: [&str; 8] = [
    "glass-impact",
    "glass-tempered",
    "mud-aged",
    "wood-grain",
    "tree-rings",
    "springs-mud",
    "springs-glaze",
    "impact-snapped",
];

/// What the measure reads of one output: crack length over the scale,
/// three-way (or more) junctions and open ends.
#[derive(Debug, Clone, Copy)]
struct Network {
    length: f64,
    junctions: usize,
    ends: usize,
}

fn network(out: &Path, scale: f64) -> Network {
    let lines = measure::read_model(out).rest_lines("crack_lines");
    let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    Network {
        length: measure::crack_length(&lines) / scale,
        junctions: graph.degree.iter().filter(|&&d| d >= 3).count(),
        ends: graph.degree.iter().filter(|&&d| d == 1).count(),
    }
}

/// `preset` on `input` with its crack lines, at `threads` threads.
fn crack(input: &Path, out: &Path, preset: &str, threads: &str) {
    let o = Command::new(common::crackle_bin())
        .args(["crack".as_ref(), input.as_os_str(), out.as_os_str()])
        .args(["-q", "--preset", preset, "--set", "post.lines=true"])
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{preset} on {}: {}",
        input.display(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Counts within 15% (or 8) of each other.
fn close(a: usize, b: usize) -> bool {
    a.abs_diff(b) as f64 <= (0.15 * a.max(b) as f64).max(8.0)
}

#[test]
fn the_presets_do_not_depend_on_the_unit_or_the_threads() {
    let dir = tempfile::tempdir().unwrap();
    let plate = shapes::jittered_plate(80, 1.0, 0.3, 2);
    let mut inputs = Vec::new();
    for (k, scale) in [1.0, 1024.0, 1e-3, 1e3].into_iter().enumerate() {
        let scaled = shapes::map_vertices(&plate, |p| p.map(|x| x * scale));
        let path = dir.path().join(format!("plate-{k}.obj"));
        std::fs::write(&path, scaled).unwrap();
        inputs.push((path, scale));
    }
    let mut failures = Vec::new();
    for preset in PRESETS {
        let one = dir.path().join(format!("{preset}-1.glb"));
        let two = dir.path().join(format!("{preset}-2.glb"));
        crack(&inputs[0].0, &one, preset, "1");
        crack(&inputs[0].0, &two, preset, "2");
        if std::fs::read(&one).unwrap() != std::fs::read(&two).unwrap() {
            failures.push(format!("{preset}: the output depends on the thread count"));
        }
        let base = network(&one, 1.0);
        assert!(
            base.length > 0.0 && base.ends + base.junctions >= 3,
            "{preset}: {base:?}"
        );
        for (input, scale) in &inputs[1..] {
            let out = dir.path().join(format!("{preset}-{scale:e}.glb"));
            crack(input, &out, preset, "2");
            let n = network(&out, *scale);
            eprintln!("{preset} at {scale:e}: {n:?} against {base:?}");
            let same = if *scale == 1024.0 {
                (n.length - base.length).abs() <= 1e-12 * base.length
                    && (n.junctions, n.ends) == (base.junctions, base.ends)
            } else {
                (n.length - base.length).abs() <= 0.05 * base.length
                    && close(n.junctions, base.junctions)
                    && close(n.ends, base.ends)
            };
            if !same {
                failures.push(format!("{preset} at {scale:e}: {n:?} against {base:?}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
