//! `wood-grain` makes drying checks: short splits along the grain,
//! staggered, none running end to end. Measured with the independent
//! measure (`common/measure.rs`: it reads the output's crack lines itself
//! and shares no code with the crate) on a plank a DCC tool could make (a
//! subdivided box) and on the Stanford bunny.

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

use std::collections::HashMap;

/// The checks' numbers: the share of crack length within 15 degrees of the
/// grain (perpendicular to x, the preset's stress direction), the length
/// of each check (a connected piece of the crack network), and the
/// longest check's extent along `axis`.
struct Checks {
    along_grain: f64,
    lengths: Vec<f64>,
    longest_extent: f64,
}

fn checks(out: &std::path::Path, axis: usize) -> Checks {
    let lines = measure::read_model(out).rest_lines("crack_lines");
    assert!(!lines.is_empty(), "no crack lines");
    let total = measure::crack_length(&lines);
    let along: f64 = lines
        .iter()
        .map(|s| {
            let d = [0, 1, 2].map(|k| s[1][k] - s[0][k]);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if d[0].abs() <= 15f64.to_radians().sin() * len {
                len
            } else {
                0.0
            }
        })
        .sum();
    let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let pieces: Vec<Vec<measure::Seg>> = graph
        .pieces()
        .iter()
        .map(|p| p.iter().map(|&e| graph.segment(e)).collect())
        .collect();
    let mut lengths: Vec<f64> = pieces.iter().map(|p| measure::crack_length(p)).collect();
    lengths.sort_by(f64::total_cmp);
    let longest_extent = pieces
        .iter()
        .map(|p| {
            let (lo, hi) = measure::bounds(p.iter().flatten());
            hi[axis] - lo[axis]
        })
        .fold(0.0, f64::max);
    Checks {
        along_grain: along / total,
        lengths,
        longest_extent,
    }
}

/// At least ten checks, 80% of the crack length within 15 degrees of the
/// grain, the median check 1 to 4 cells long and nine in ten at most 4,
/// and none spanning half of `span` (the extent measured along the grain).
fn assert_checks(what: &str, c: &Checks, cell: f64, span: f64) {
    let median = c.lengths[c.lengths.len() / 2];
    let q = |f: f64| c.lengths[((c.lengths.len() - 1) as f64 * f).round() as usize] / cell;
    eprintln!(
        "{what}: check lengths in cells, 10/25/75/90%: {:.2} {:.2} {:.2} {:.2}",
        q(0.1),
        q(0.25),
        q(0.75),
        q(0.9)
    );
    eprintln!(
        "{what}: {} checks, along the grain {:.3}, median length {:.2} cells, longest extent {:.2} of the span",
        c.lengths.len(),
        c.along_grain,
        median / cell,
        c.longest_extent / span
    );
    assert!(c.lengths.len() >= 10, "{what}: {} checks", c.lengths.len());
    assert!(
        c.along_grain >= 0.8,
        "{what}: along the grain {}",
        c.along_grain
    );
    assert!(
        (1.0..=4.0).contains(&(median / cell)),
        "{what}: median check {} cells",
        median / cell
    );
    // Nine checks in ten at most 4 cells long (the plank measured 3.7, the
    // bunny 2.6); the shortest tenth are slivers under a cell.
    assert!(
        q(0.9) <= 4.0,
        "{what}: a tenth of the checks over {} cells",
        q(0.9)
    );
    assert!(
        c.longest_extent < 0.5 * span,
        "{what}: a check runs {} of the span",
        c.longest_extent / span
    );
}

/// A plank `w` x `h` x `l` (x, y, z: the grain along z), each side a grid
/// of squares about `step` wide, as OBJ text.
fn plank(w: f64, h: f64, l: f64, step: f64) -> String {
    let n = [w, h, l].map(|s| ((s / step).round() as i64).max(1));
    let size = [w, h, l];
    let mut index: HashMap<[i64; 3], usize> = HashMap::new();
    let (mut verts, mut faces) = (String::new(), String::new());
    let mut vertex = |g: [i64; 3], verts: &mut String| -> usize {
        let next = index.len() + 1;
        *index.entry(g).or_insert_with(|| {
            let p = [0, 1, 2].map(|k| size[k] * (g[k] as f64 / n[k] as f64 - 0.5));
            verts.push_str(&format!("v {} {} {}\n", p[0], p[1], p[2]));
            next
        })
    };
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0, n[axis]] {
            for i in 0..n[u] {
                for j in 0..n[v] {
                    let corner = |di: i64, dj: i64| {
                        let mut g = [0; 3];
                        g[axis] = side;
                        g[u] = i + di;
                        g[v] = j + dj;
                        g
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]
                        .map(|g| vertex(g, &mut verts));
                    // Outward winding on both sides.
                    let q = if side == 0 {
                        [q[0], q[3], q[2], q[1]]
                    } else {
                        q
                    };
                    faces.push_str(&format!("f {} {} {}\n", q[0], q[1], q[2]));
                    faces.push_str(&format!("f {} {} {}\n", q[0], q[2], q[3]));
                }
            }
        }
    }
    verts + &faces
}

#[test]
fn wood_grain_makes_short_staggered_checks_along_the_grain_of_a_plank() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plank.obj");
    std::fs::write(&input, plank(1.0, 0.25, 4.0, 0.05)).unwrap();
    let out = dir.path().join("out.glb");
    let o = common::crack(
        &input,
        &out,
        &["-q", "--preset", "wood-grain", "--set", "post.lines=true"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The preset's cell size: 0.05 of the bounding-box diagonal.
    let cell = 0.05 * (1.0f64 + 0.0625 + 16.0).sqrt();
    assert_checks("plank", &checks(&out, 2), cell, 4.0);
}

#[test]
fn wood_grain_makes_checks_on_the_bunny() {
    let Some(input) = common::eval_data("obj/stanford-bunny/stanford-bunny.obj") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.glb");
    let o = common::crack(
        &input,
        &out,
        &["-q", "--preset", "wood-grain", "--set", "post.lines=true"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let model = measure::read_model(&input);
    let (lo, hi) = measure::bounds(model.triangles(|_| true).iter().flatten());
    let diag = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    assert_checks("bunny", &checks(&out, 1), 0.05 * diag, hi[1] - lo[1]);
}

/// Checks crowd toward a board's edges and ends, where wood dries first:
/// on the 160 x 160 jittered plate (10 units, in the xz plane), the crack
/// length per area within a cell of the border is above that more than
/// three cells in (before: 0.56 and 0.63 of it on seeds 1 and 2, the free
/// border relieving the stress across it).
#[test]
fn checks_crowd_toward_the_edges() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plate.obj");
    shapes::write_obj(&input, &shapes::jittered_plate(160, 10.0, 0.3, 1));
    let cell = 0.05 * 200f64.sqrt();
    for seed in ["1", "2"] {
        let out = dir.path().join(format!("out{seed}.glb"));
        common::crack_lines(&input, &out, "wood-grain", &["--seed", seed]);
        let lines = measure::read_model(&out).rest_lines("crack_lines");
        // Length per area in the band [a, b) of distance from the border.
        let density = |a: f64, b: f64| {
            let len: f64 = lines
                .iter()
                .filter(|s| {
                    let m = [0, 2].map(|k| 0.5 * (s[0][k] + s[1][k]));
                    let d = m
                        .iter()
                        .map(|x| 5.0 - x.abs())
                        .fold(f64::INFINITY, f64::min);
                    (a..b).contains(&d)
                })
                .map(|s| {
                    let d = [0, 1, 2].map(|k| s[1][k] - s[0][k]);
                    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
                })
                .sum();
            len / ((10.0 - 2.0 * a).powi(2) - (10.0 - 2.0 * b).powi(2))
        };
        let (edge, inner) = (density(0.0, cell), density(3.0 * cell, 5.0));
        eprintln!("seed {seed}: {edge:.3} per area within a cell of the border, {inner:.3} inside");
        assert!(
            edge >= 1.05 * inner,
            "seed {seed}: {edge} at the border, {inner} inside"
        );
    }
}
