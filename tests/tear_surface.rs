//! A torn solid comes back as the artist's own surface (issue 42): the
//! input's triangles, cut along the tear and moved by the solid's
//! deformation, with the torn faces added and meeting them without a gap.
//! Measured on the output's triangles with the independent reader
//! (`common/measure.rs`), against the input's OBJ.

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

use measure::{Tri, P3};

fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: P3, b: P3) -> P3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: P3) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// Unit normal and area.
fn normal(t: &Tri) -> (P3, f64) {
    let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
    let l = norm(n);
    ([n[0] / l, n[1] / l, n[2] / l], 0.5 * l)
}

/// Share of the area of `tris` whose normal lies within `deg` degrees of
/// one of `reference`'s normals (either way round).
fn area_along(tris: &[Tri], reference: &[P3], deg: f64) -> f64 {
    let c = deg.to_radians().cos();
    let (mut ok, mut all) = (0.0, 0.0);
    for t in tris {
        let (n, a) = normal(t);
        if !a.is_finite() || a == 0.0 {
            continue;
        }
        all += a;
        if reference
            .iter()
            .any(|r| (n[0] * r[0] + n[1] * r[1] + n[2] * r[2]).abs() >= c)
        {
            ok += a;
        }
    }
    ok / all
}

/// The notched block's OBJ `text` turned 30 degrees about z.
fn turned_block(text: &str) -> String {
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    shapes::map_vertices(text, |p| [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]])
}

/// Edges used by one triangle of `tris` only (ends rounded to 1e-6 to
/// match shared corners).
fn open_edges(tris: &[Tri]) -> Vec<[P3; 2]> {
    let key = |p: P3| p.map(|x| (x * 1e6).round() as i64);
    type Key = ([i64; 3], [i64; 3]);
    let mut count: std::collections::BTreeMap<Key, (usize, [P3; 2])> = Default::default();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (ka, kb) = (key(a), key(b));
            let e = if ka <= kb { (ka, kb) } else { (kb, ka) };
            count.entry(e).or_insert((0, [a, b])).0 += 1;
        }
    }
    count
        .into_values()
        .filter(|(n, _)| *n == 1)
        .map(|(_, s)| s)
        .collect()
}

fn distance_to_segment(p: P3, [a, b]: [P3; 2]) -> f64 {
    let ab = sub(b, a);
    let l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    let t = if l2 > 0.0 {
        ((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1] + (p[2] - a[2]) * ab[2]) / l2
    } else {
        0.0
    };
    let t = t.clamp(0.0, 1.0);
    norm(sub(
        p,
        [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]],
    ))
}

/// The notched block torn at 24 cubes: its untorn faces keep the input's
/// face directions (the grid's surface rounded its corners and terraced
/// its faces: 0.927 of the area within 5 degrees of an input face at 40
/// cubes, 0.882 at 24; now 0.967 at 24), every open edge of the untorn part lies on an open edge of the
/// same piece's torn faces (no gap where they meet), and the first frame
/// of the time-lapse, at rest, is the input's own geometry.
#[test]
fn the_torn_block_is_its_own_surface_cut_along_the_tear() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("notched_block.obj");
    let out = dir.path().join("torn.glb");
    let frames = dir.path().join("frames");
    let args = [
        "--preset",
        "tear",
        "--set",
        "simulation.ductile.grid=24",
        "--frames",
        "2",
        frames.to_str().unwrap(),
    ];
    let o = common::crack(&input, &out, &args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = common::report(&out);
    let post = &r["meshes"][0]["post"];
    assert_eq!(post["surface"]["surface"], "input", "{post}");
    let pieces = post["pieces"].as_u64().unwrap();
    assert!(pieces >= 2, "{post}");
    let source = measure::read_model(&input).triangles(|_| true);
    let normals: Vec<P3> = source.iter().map(|t| normal(t).0).collect();
    let size = {
        let (lo, hi) = measure::bounds(source.iter().flatten());
        norm(sub(hi, lo))
    };
    let model = measure::read_model(&out);
    let mut untorn_all = Vec::new();
    for inst in &model.instances {
        let untorn: Vec<Tri> = inst
            .primitives
            .iter()
            .filter(|p| p.material != "tear_interior")
            .flat_map(|p| p.triangles.clone())
            .collect();
        let torn: Vec<Tri> = inst
            .primitives
            .iter()
            .filter(|p| p.material == "tear_interior")
            .flat_map(|p| p.triangles.clone())
            .collect();
        if untorn.is_empty() || torn.is_empty() {
            continue;
        }
        let torn_edges = open_edges(&torn);
        let worst = open_edges(&untorn)
            .iter()
            .flatten()
            .map(|&p| {
                torn_edges
                    .iter()
                    .map(|&e| distance_to_segment(p, e))
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max);
        eprintln!(
            "{}: untorn border to torn border at most {:.2e} of the block",
            inst.node,
            worst / size
        );
        assert!(
            worst <= 1e-5 * size,
            "{}: a gap of {worst} where the torn faces meet the input's",
            inst.node
        );
        untorn_all.extend(untorn);
    }
    let along = area_along(&untorn_all, &normals, 5.0);
    eprintln!("untorn area within 5 degrees of an input face: {along:.4}");
    // The tear starts later since its onset reads a nonlocal energy
    // (first tear at 0.0825 of the length, not 0.0275): the block necks
    // more before it comes apart, its faces bend a little more (0.967).
    assert!(
        along >= 0.95,
        "{along:.4} of the untorn area along the input's faces"
    );
    // At rest: the input itself.
    let first = std::fs::read_dir(&frames)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "glb"))
        .min()
        .unwrap();
    let rest = measure::read_model(&first).triangles(|_| true);
    assert_eq!(rest.len(), source.len(), "the rest frame's triangles");
    let key = |p: P3| p.map(|x| (x * 1e5).round() as i64);
    let want: std::collections::BTreeSet<_> = source.iter().flatten().map(|&p| key(p)).collect();
    let got: std::collections::BTreeSet<_> = rest.iter().flatten().map(|&p| key(p)).collect();
    assert_eq!(got, want, "the rest frame's vertices are the input's");
}

/// The notched block turned 30 degrees about z (so its faces and the tear
/// lie across the grid's axes), pulled along y and torn at 24 cubes: every
/// vertex of the output lies near the pulled block. Grid nodes that the
/// material hardly held drifted without bound (one 7e8 m), and the input's
/// vertices in their tetrahedra came out up to 0.9 of the block's length
/// below it, smoothed torn faces' vertices mapped through them 1e9 away.
#[test]
fn a_block_turned_to_the_grid_tears_without_stray_vertices() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(common::fixture("notched_block.obj")).unwrap();
    let turned = turned_block(&text);
    let input = dir.path().join("turned.obj");
    std::fs::write(&input, turned).unwrap();
    let out = dir.path().join("torn.glb");
    let args = ["--preset", "tear", "--set", "simulation.ductile.grid=24"];
    let o = common::crack(&input, &out, &args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let source = measure::read_model(&input).triangles(|_| true);
    let (lo, hi) = measure::bounds(source.iter().flatten());
    let longest = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    // The ends move 0.15 of the length each; a quarter of it is room.
    let room = 0.25 * longest;
    let model = measure::read_model(&out);
    let mut worst = 0.0f64;
    for t in model.triangles(|_| true) {
        for p in t {
            for k in 0..3 {
                worst = worst.max(lo[k] - p[k]).max(p[k] - hi[k]);
            }
        }
    }
    assert!(
        worst <= room,
        "a vertex lies {worst:.3e} outside the block's box (room {room:.3})"
    );
}

/// Share of the area of `tris` whose normal lies within 5 degrees of one
/// of the world axes other than `pull` (either way round): the ductile
/// grid's axes across the pull, where a torn face cut along the grid's
/// layers stands (its terraces' risers).
fn share_along_axes_across(tris: &[Tri], pull: usize) -> f64 {
    let axes: Vec<P3> = (0..3)
        .filter(|&k| k != pull)
        .map(|k| {
            let mut a = [0.0; 3];
            a[k] = 1.0;
            a
        })
        .collect();
    area_along(tris, &axes, 5.0)
}

/// The torn faces do not follow the grid: the share of their area whose
/// normal lies within 5 degrees of a grid axis across the pull at most 1.5
/// times a random orientation's (two axes: `2 (1 - cos 5)` = 0.0076), on
/// the notched block at 16, 24 and 40 cubes and turned 30 degrees to the
/// grid at 24 and 40. Measured when the faces were relaxed within their
/// cubes (elastic surface nets, not Taubin passes): 0.0049 / 0.0056 /
/// 0.0000 and 0.0037 / 0.0004 (Taubin: 0.0272 / 0.0094 / 0.0323, 0.0044 /
/// 0.0183).
#[test]
fn torn_faces_do_not_stand_along_the_grid() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(common::fixture("notched_block.obj")).unwrap();
    let turned = turned_block(&text);
    let random = 2.0 * (1.0 - 5f64.to_radians().cos());
    let mut failures = Vec::new();
    for (name, text, grids) in [
        ("block", text.clone(), &[16, 24, 40][..]),
        ("turned", turned, &[24, 40][..]),
    ] {
        let input = dir.path().join(format!("{name}.obj"));
        std::fs::write(&input, &text).unwrap();
        let source = measure::read_model(&input).triangles(|_| true);
        let (lo, hi) = measure::bounds(source.iter().flatten());
        let pull = (0..3)
            .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
            .unwrap();
        for &g in grids {
            let out = dir.path().join(format!("{name}-{g}.glb"));
            let grid = format!("simulation.ductile.grid={g}");
            let o = common::crack(&input, &out, &["--preset", "tear", "--set", &grid]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let torn = measure::read_model(&out).triangles(|m| m == "tear_interior");
            assert!(!torn.is_empty(), "{name} at {g} cubes: no torn faces");
            let share = share_along_axes_across(&torn, pull);
            eprintln!("{name} at {g} cubes: {share:.4} of the torn area along a grid axis across the pull (random {random:.4})");
            if share > 1.5 * random {
                failures.push(format!("{name} at {g} cubes: {share:.4}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?} over 1.5 x {random:.4}");
}
