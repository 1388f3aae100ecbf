//! `wood-grain` makes drying checks: short splits along the grain,
//! staggered, none running end to end. Measured with the independent
//! measure (`common/measure.rs`: it reads the output's crack lines itself
//! and shares no code with the crate) on a plank a DCC tool could make (a
//! subdivided box) and on the Stanford bunny.

mod common;
#[path = "common/measure.rs"]
mod measure;

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
    // Connected pieces of the graph: union-find over its edges.
    let segs = graph.segments();
    let mut ids: HashMap<[i64; 3], usize> = HashMap::new();
    let mut parent: Vec<usize> = Vec::new();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut ends = Vec::with_capacity(segs.len());
    for s in &segs {
        let e = s.map(|p| {
            *ids.entry(p.map(|x| (x * 1e7).round() as i64))
                .or_insert_with(|| {
                    parent.push(parent.len());
                    parent.len() - 1
                })
        });
        let (a, b) = (find(&mut parent, e[0]), find(&mut parent, e[1]));
        parent[a.max(b)] = a.min(b);
        ends.push(e);
    }
    let mut pieces: HashMap<usize, (f64, f64, f64)> = HashMap::new();
    for (s, e) in segs.iter().zip(&ends) {
        let root = find(&mut parent, e[0]);
        let len = (0..3)
            .map(|k| (s[1][k] - s[0][k]).powi(2))
            .sum::<f64>()
            .sqrt();
        let p = pieces
            .entry(root)
            .or_insert((0.0, f64::INFINITY, f64::NEG_INFINITY));
        p.0 += len;
        for q in s {
            p.1 = p.1.min(q[axis]);
            p.2 = p.2.max(q[axis]);
        }
    }
    let mut lengths: Vec<f64> = pieces.values().map(|p| p.0).collect();
    lengths.sort_by(f64::total_cmp);
    Checks {
        along_grain: along / total,
        lengths,
        longest_extent: pieces.values().map(|p| p.2 - p.1).fold(0.0, f64::max),
    }
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
    let c = checks(&out, 2);
    // The preset's cell size: 0.05 of the bounding-box diagonal.
    let cell = 0.05 * (1.0f64 + 0.0625 + 16.0).sqrt();
    let median = c.lengths[c.lengths.len() / 2];
    eprintln!(
        "plank: {} checks, along the grain {:.3}, median length {:.2} cells, longest extent {:.2} of the length",
        c.lengths.len(),
        c.along_grain,
        median / cell,
        c.longest_extent / 4.0
    );
    assert!(c.lengths.len() >= 10, "{} checks", c.lengths.len());
    assert!(c.along_grain >= 0.8, "along the grain: {}", c.along_grain);
    assert!(
        (1.0..=4.0).contains(&(median / cell)),
        "median check {} cells",
        median / cell
    );
    assert!(
        c.longest_extent < 0.5 * 4.0,
        "a check runs {} of the plank's length",
        c.longest_extent / 4.0
    );
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
    let c = checks(&out, 1);
    let model = measure::read_model(&input);
    let (lo, hi) = measure::bounds(model.triangles(|_| true).iter().flatten());
    let diag = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    let cell = 0.05 * diag;
    let median = c.lengths[c.lengths.len() / 2];
    eprintln!(
        "bunny: {} checks, along the grain {:.3}, median length {:.2} cells, longest extent {:.2} of the height",
        c.lengths.len(),
        c.along_grain,
        median / cell,
        c.longest_extent / (hi[1] - lo[1])
    );
    assert!(c.lengths.len() >= 10, "{} checks", c.lengths.len());
    assert!(c.along_grain >= 0.8, "along the grain: {}", c.along_grain);
    assert!(
        (1.0..=4.0).contains(&(median / cell)),
        "median check {} cells",
        median / cell
    );
    assert!(
        c.longest_extent < 0.5 * (hi[1] - lo[1]),
        "a check runs {} of the height",
        c.longest_extent / (hi[1] - lo[1])
    );
}
