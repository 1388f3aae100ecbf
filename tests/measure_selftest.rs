//! Tests of the independent crack measure (`tests/common/measure.rs`) on known inputs.
//! No crackle run is needed.

#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

use measure::{Seg, P3};

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

/// A polyline through the points, as segments.
fn polyline(points: &[P3]) -> Vec<Seg> {
    points.windows(2).map(|w| [w[0], w[1]]).collect()
}

#[test]
fn lines_along_a_regular_plates_edges_have_edge_share_one() {
    // 8 x 8 plate, size 2: grid lines at x, z = -1 + k/4; diagonals (i,j)-(i+1,j+1).
    let tris = measure::parse_obj(&shapes::regular_plate(8, 2.0));
    assert_eq!(tris.len(), 128);
    let mut lines = Vec::new();
    // Along the row z = -0.5, in pieces that do not stop at vertices.
    lines.extend(polyline(&[
        [-1.0, 0.0, -0.5],
        [-0.1, 0.0, -0.5],
        [0.6, 0.0, -0.5],
    ]));
    // Along the column x = 0.25.
    lines.push([[0.25, 0.0, -1.0], [0.25, 0.0, 0.9]]);
    // Along the diagonal through (-1, -1) and (1, 1): it follows the quads' split.
    lines.push([[-0.9, 0.0, -0.9], [0.7, 0.0, 0.7]]);
    let share = measure::edge_share(&lines, &tris, measure::DEFAULT_TOL_REL);
    assert!(close(share, 1.0, 1e-12), "share {share}");
}

#[test]
fn lines_across_the_edges_have_edge_share_near_zero() {
    let tris = measure::parse_obj(&shapes::regular_plate(8, 2.0));
    // A generic direction crosses edges only at points.
    let across = vec![[[-0.93, 0.0, -0.71], [0.88, 0.0, 0.05]]];
    let share = measure::edge_share(&across, &tris, measure::DEFAULT_TOL_REL);
    assert!(share < 0.01, "share {share}");
    // Parallel to an edge but 1e-4 off it (100x the tolerance): not on the edge.
    let off = vec![[[-1.0, 0.0, -0.5 + 1e-4], [1.0, 0.0, -0.5 + 1e-4]]];
    assert_eq!(
        measure::edge_share(&off, &tris, measure::DEFAULT_TOL_REL),
        0.0
    );
    // Shorter than the tolerance, across an edge: near it everywhere, but not along it.
    let tiny = vec![[[0.1, 0.0, -0.5 - 1e-7], [0.1, 0.0, -0.5 + 1e-7]]];
    assert_eq!(
        measure::edge_share(&tiny, &tris, measure::DEFAULT_TOL_REL),
        0.0
    );
    // Half along an edge, half off it: one half, length-weighted.
    let half = vec![
        [[-1.0, 0.0, -0.5], [0.0, 0.0, -0.5]],
        [[-0.37, 0.0, -0.61], [0.63, 0.0, 0.02]],
    ];
    let share = measure::edge_share(&half, &tris, measure::DEFAULT_TOL_REL);
    let l2 = (1.0f64 + 0.63 * 0.63).sqrt();
    assert!(close(share, 1.0 / (1.0 + l2), 0.01), "share {share}");
}

#[test]
fn edge_share_is_one_along_a_fine_spheres_own_edges_and_fast() {
    let tris = measure::parse_obj(&shapes::latlong_sphere(400, 200));
    assert_eq!(tris.len(), 400 * 2 + 400 * 198 * 2);
    // Every 7th edge of the sphere (not axis-aligned), and the same edges moved off the surface.
    let lines: Vec<Seg> = measure::triangle_edges(&tris)
        .into_iter()
        .step_by(7)
        .collect();
    let start = std::time::Instant::now();
    let share = measure::edge_share(&lines, &tris, measure::DEFAULT_TOL_REL);
    let took = start.elapsed().as_secs_f64();
    eprintln!(
        "edge_share: {} lines on {} triangles: {took:.2} s",
        lines.len(),
        tris.len()
    );
    assert!(close(share, 1.0, 1e-12), "share {share}");
    let lifted: Vec<Seg> = lines
        .iter()
        .map(|s| s.map(|p| p.map(|x| x * 1.001)))
        .collect();
    let share = measure::edge_share(&lifted, &tris, measure::DEFAULT_TOL_REL);
    assert!(share < 1e-3, "lifted share {share}");
}

fn at_angle(deg: f64, len: f64, from: P3) -> Seg {
    let (s, c) = deg.to_radians().sin_cos();
    [from, [from[0] + len * c, 0.0, from[2] + len * s]]
}

#[test]
fn orientation_bins_of_known_angles() {
    let frame = measure::plate_frame([0.0, 0.0, 0.0], [10.0, 0.0, 10.0], 0.5);
    let lines = vec![
        at_angle(10.0, 1.0, [2.0, 0.0, 2.0]),
        at_angle(40.0, 2.0, [3.0, 0.0, 3.0]),
        at_angle(100.0, 1.0, [4.0, 0.0, 4.0]),
        at_angle(-10.0, 1.0, [5.0, 0.0, 5.0]), // 170 degrees once folded
        at_angle(182.0, 1.0, [6.0, 0.0, 6.0]), // 2 degrees: axis
        at_angle(91.0, 1.0, [7.0, 0.0, 5.0]),  // near the z axis
        at_angle(-3.0, 1.0, [7.0, 0.0, 7.0]),  // 177 degrees: axis
        at_angle(87.0, 1.0, [8.0, 0.0, 2.0]),  // axis, from below
        at_angle(60.0, 0.2, [0.1, 0.0, 3.0]),  // midpoint within 0.5 of x = 0: left out
        at_angle(120.0, 1.0, [9.8, 0.0, 5.0]), // midpoint within 0.5 of x = 10: left out
    ];
    let (bins, axis) = measure::orientation_bins(&lines, frame);
    let total = 9.0;
    // Bins of 30 degrees centred on 0, 30, ..., 150: 10, 170, 2 and 177
    // in the first; 40 (twice as long) in the second; 100, 91 and 87 in
    // the fourth.
    let want = [4.0, 2.0, 0.0, 3.0, 0.0, 0.0].map(|l| l / total);
    for k in 0..6 {
        assert!(
            close(bins[k], want[k], 1e-12),
            "bins {bins:?}, want {want:?}"
        );
    }
    assert!(close(axis, 4.0 / total, 1e-12), "axis {axis}");
}

#[test]
fn latlong_frame_measures_against_east_and_north() {
    let frame = measure::latlong_frame([0.0; 3], [0.0, 0.0, 1.0], 0.8);
    let (s, c) = (0.3f64.sin(), 0.3f64.cos());
    let meridian = [[c, s, -0.01], [c, s, 0.01]]; // north, at longitude 0.3
    let parallel = [[1.0, -0.01, 0.0], [1.0, 0.01, 0.0]]; // east, on the equator
    let polar = [[0.1, 0.0, 0.99], [0.1, 0.01, 0.99]]; // cos polar angle 0.99 > 0.8
    let (bins, axis) = measure::orientation_bins(&[meridian, polar], &frame);
    assert!(
        close(bins[3], 1.0, 1e-9) && close(axis, 1.0, 1e-9),
        "{bins:?}"
    );
    let (bins, _) = measure::orientation_bins(&[parallel], &frame);
    assert!(close(bins[0] + bins[5], 1.0, 1e-9), "{bins:?}");
    let (bins, axis) = measure::orientation_bins(&[polar], &frame);
    assert_eq!((bins, axis), ([0.0; 6], 0.0));
}

/// The 1 x 1 square [0, 1] x [0, 1] of the xz-plane as four whole border segments.
fn square_border() -> Vec<Seg> {
    let c = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
    ];
    (0..4).map(|k| [c[k], c[(k + 1) % 4]]).collect()
}

#[test]
fn a_stem_ending_mid_segment_splits_it() {
    let lines = vec![
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
        [[0.4, 0.0, 0.5], [0.4, 0.0, 0.0]],
    ];
    let g = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    assert_eq!(g.nodes.len(), 4);
    assert_eq!(g.edges.len(), 3);
    let mut deg = g.degree.clone();
    deg.sort();
    assert_eq!(deg, vec![1, 1, 1, 3]);
}

#[test]
fn a_chord_over_a_junction_is_split_only_on_a_curved_surface() {
    // The stem ends 1e-3 off the long segment's chord (a chord's sag over a curved surface).
    let lines = vec![
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
        [[0.5, 0.5, 0.0], [0.5, 1e-3, 0.0]],
    ];
    let strict = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    assert_eq!(
        (strict.edges.len(), measure::open_tips(&strict, &[])),
        (2, 4)
    );
    let loose = measure::loose_ends(&strict, &[], 0.01);
    assert!(
        loose.len() == 1 && close(loose[0].1, 1e-3, 1e-12),
        "{loose:?}"
    );
    let curved = measure::crack_graph_curved(&lines, measure::DEFAULT_WELD_REL, 0.01);
    assert_eq!(
        (curved.edges.len(), measure::open_tips(&curved, &[])),
        (3, 3)
    );
    assert!(measure::loose_ends(&curved, &[], 0.01).is_empty());
    // Beyond the sag allowed, the stem stays apart.
    let apart = measure::crack_graph_curved(&lines, measure::DEFAULT_WELD_REL, 5e-4);
    assert_eq!(apart.edges.len(), 2);
}

#[test]
fn planar_cells_of_a_grid_over_a_square() {
    // Vertical cracks x = 1/4, 1/2, 3/4 as single long segments; horizontal ones in pieces
    // that end in the middle of the verticals (T-junctions) and of the border.
    let mut lines = Vec::new();
    for k in 1..4 {
        let x = k as f64 / 4.0;
        lines.push([[x, 0.0, 0.0], [x, 0.0, 1.0]]);
    }
    for k in 1..4 {
        let z = k as f64 / 4.0;
        let xs = [0.0, 0.25, 0.5, 0.75, 1.0];
        lines.extend(polyline(&xs.map(|x| [x, 0.0, z])));
    }
    // A dangling crack from a cell's wall (walked around) and a free one change nothing.
    lines.push([[0.25, 0.0, 0.1], [0.1, 0.0, 0.15]]);
    lines.push([[0.6, 0.0, 0.6], [0.65, 0.0, 0.7]]);
    let g = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    let cells = measure::planar_cells(&g, &square_border(), 1e-6);
    assert_eq!(cells.len(), 16, "cells {cells:?}");
    for a in &cells {
        assert!(close(*a, 1.0 / 16.0, 1e-12), "area {a}");
    }
    let d = measure::cell_diameters(&cells);
    assert!(
        close(d, (4.0 / 16.0 / std::f64::consts::PI).sqrt(), 1e-12),
        "d {d}"
    );
    // Without the border, only the 4 closed inner cells remain.
    let inner = measure::planar_cells(&g, &[], 1e-6);
    assert_eq!(inner.len(), 4, "inner {inner:?}");
}

#[test]
fn loose_ends_find_a_stem_that_stops_short_and_ignore_one_that_meets() {
    // Crack A runs across from border to border (x = 0 and x = 1).
    let mut lines = polyline(&[
        [0.0, 0.0, 0.0],
        [0.3, 0.0, 0.0],
        [0.7, 0.0, 0.0],
        [1.0, 0.0, 0.0],
    ]);
    // B stops 1e-3 short of A; C meets A in the middle of its segment.
    lines.extend(polyline(&[
        [0.5, 0.0, 0.5],
        [0.5, 0.0, 0.2],
        [0.5, 0.0, 1e-3],
    ]));
    lines.push([[0.2, 0.0, 0.5], [0.2, 0.0, 0.0]]);
    let border = vec![
        [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]],
        [[1.0, 0.0, -1.0], [1.0, 0.0, 1.0]],
    ];
    let g = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
    assert_eq!(measure::open_tips(&g, &border), 3);
    assert_eq!(measure::open_tips(&g, &[]), 5);
    let loose = measure::loose_ends(&g, &border, 0.05);
    assert_eq!(loose.len(), 1, "{loose:?}");
    let (node, d) = loose[0];
    assert!(
        close(g.nodes[node][2], 1e-3, 1e-12),
        "node {:?}",
        g.nodes[node]
    );
    assert!(close(d, 1e-3, 1e-12), "distance {d}");
    // Within a radius below the gap, nothing.
    assert!(measure::loose_ends(&g, &border, 5e-4).is_empty());
}

#[test]
fn paired_share_of_parallel_lines() {
    let a = polyline(&[[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    let with = |z: f64| {
        let mut l = a.clone();
        l.extend(polyline(&[[0.0, 0.0, z], [0.5, 0.0, z], [1.0, 0.0, z]]));
        l
    };
    assert!(close(
        measure::paired_share(&with(0.01), 0.05, 20.0),
        1.0,
        1e-12
    ));
    assert_eq!(measure::paired_share(&with(0.2), 0.05, 20.0), 0.0);
    // Close but at 45 degrees: not parallel.
    let mut crossing = a.clone();
    crossing.push([[0.2, 0.0, 0.01], [0.3, 0.0, 0.11]]);
    assert_eq!(measure::paired_share(&crossing, 0.05, 20.0), 0.0);
    // Two sides of one hairpin joined within 3 * distance: the same crack, not a pair.
    let hairpin = |end: usize| {
        let bottom: Vec<P3> = (0..=end)
            .rev()
            .map(|k| [0.02 * k as f64, 0.0, 0.0])
            .collect();
        let top: Vec<P3> = (0..=end).map(|k| [0.02 * k as f64, 0.0, 0.01]).collect();
        polyline(&[bottom, top].concat())
    };
    assert_eq!(measure::paired_share(&hairpin(3), 0.05, 20.0), 0.0);
    // A long one: only the edges with midpoints within 0.055 of the bend are one crack.
    let share = measure::paired_share(&hairpin(50), 0.05, 20.0);
    let want = 2.0 * (1.0 - 0.06) / 2.01;
    assert!(close(share, want, 1e-9), "share {share}, want {want}");
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while b.len() % 4 != 0 {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    for w in [0x4654_6C67u32, 2, total as u32, j.len() as u32, 0x4E4F_534A] {
        out.extend(w.to_le_bytes());
    }
    out.extend(&j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(0x004E_4942u32.to_le_bytes());
    out.extend(&b);
    out
}

fn floats(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

#[test]
fn a_hand_made_glb_reads_back_in_world_coordinates() {
    // Bytes 0..36: triangle positions; 36..42: u16 indices (2, 1, 0) + pad;
    // 44..76: two line points with a 16-byte stride (4 bytes of padding each).
    let mut bin = floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    bin.extend([2u16, 1, 0, 0].iter().flat_map(|x| x.to_le_bytes()));
    bin.extend(floats(&[0.0, 0.0, 0.0, 9.0, 0.0, 0.0, 1.0, 9.0]));
    let json = r#"{
      "asset": {"version": "2.0"},
      "scene": 0,
      "scenes": [{"nodes": [0, 2]}],
      "nodes": [
        {"name": "parent", "translation": [1, 2, 3], "children": [1]},
        {"name": "child", "mesh": 0, "scale": [2, 2, 2],
         "rotation": [0, 0, 0.7071067811865476, 0.7071067811865476]},
        {"name": "matrix", "mesh": 0,
         "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 10,20,30,1]}
      ],
      "meshes": [{"name": "m", "primitives": [
        {"attributes": {"POSITION": 0}, "indices": 1, "material": 0},
        {"attributes": {"POSITION": 2}, "mode": 1, "material": 1}
      ]}],
      "materials": [{"name": "body"}, {"name": "crack_lines"}],
      "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
        {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
        {"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC3"}
      ],
      "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": 36},
        {"buffer": 0, "byteOffset": 36, "byteLength": 6},
        {"buffer": 0, "byteOffset": 44, "byteLength": 32, "byteStride": 16}
      ],
      "buffers": [{"byteLength": 76}]
    }"#;
    let model = measure::parse_glb(&glb(json, &bin), None);
    assert_eq!(model.instances.len(), 2);
    assert_eq!(model.instances[0].node, "child");
    let tris = model.triangles(|m| m == "body");
    assert_eq!(tris.len(), 2);
    // child: scale 2, rotate 90 degrees about z, translate (1, 2, 3); indices reversed.
    let want = [
        [[-1.0, 2.0, 3.0], [1.0, 4.0, 3.0], [1.0, 2.0, 3.0]],
        [[10.0, 21.0, 30.0], [11.0, 20.0, 30.0], [10.0, 20.0, 30.0]],
    ];
    for (got, want) in tris.iter().zip(&want) {
        for k in 0..3 {
            for c in 0..3 {
                assert!(close(got[k][c], want[k][c], 1e-6), "{got:?} vs {want:?}");
            }
        }
    }
    let lines = model.lines("crack_lines");
    assert_eq!(lines.len(), 2);
    // The line (0,0,0)-(0,0,1) through the child's transform and through the matrix.
    for (c, want) in [(0, [1.0, 2.0, 5.0]), (1, [10.0, 20.0, 31.0])] {
        for k in 0..3 {
            assert!(close(lines[c][1][k], want[k], 1e-6), "{:?}", lines[c]);
        }
    }
    assert_eq!(measure::crack_length(&lines), 3.0);
}

#[test]
fn a_gltf_with_an_external_bin_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let bin = floats(&[0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 4.0, 0.0]);
    std::fs::write(dir.path().join("my data.bin"), &bin).unwrap();
    // Non-indexed: the first two points as LINES, all three as TRIANGLES.
    let json = r#"{"asset": {"version": "2.0"}, "nodes": [{"mesh": 0}],
      "meshes": [{"primitives": [{"attributes": {"POSITION": 1}, "mode": 1},
                                 {"attributes": {"POSITION": 0}}]}],
      "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                    {"bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3"}],
      "bufferViews": [{"buffer": 0, "byteLength": 36}],
      "buffers": [{"byteLength": 36, "uri": "my%20data.bin"}]}"#;
    let path = dir.path().join("t.gltf");
    std::fs::write(&path, json).unwrap();
    let model = measure::read_model(&path);
    assert_eq!(model.lines(""), vec![[[0.0; 3], [3.0, 0.0, 0.0]]]);
    let tris = model.triangles(|_| true);
    assert_eq!(tris, vec![[[0.0; 3], [3.0, 0.0, 0.0], [0.0, 4.0, 0.0]]]);
}

#[test]
#[should_panic(expected = "sparse accessors are not supported")]
fn a_sparse_accessor_is_refused() {
    let json = r#"{"asset": {"version": "2.0"}, "nodes": [{"mesh": 0}],
      "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
      "accessors": [{"componentType": 5126, "count": 3, "type": "VEC3",
        "sparse": {"count": 1, "indices": {}, "values": {}}}]}"#;
    measure::parse_glb(&glb(json, &[]), None);
}

#[test]
fn obj_faces_in_every_form_and_negative_indices() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n\
                f 1/1 2/1/1 3//1 4\nf -4 -2 -1 # comment\n";
    let tris = measure::parse_obj(text);
    assert_eq!(tris.len(), 3);
    assert_eq!(tris[1], [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]);
    assert_eq!(tris[2], [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]);
}

#[test]
fn shapes_are_what_they_say() {
    let plate = measure::parse_obj(&shapes::regular_plate(4, 1.0));
    assert_eq!(plate.len(), 32);
    assert_eq!(
        measure::boundary_edges(&plate, measure::DEFAULT_WELD_REL).len(),
        16
    );
    for t in &plate {
        let (e1, e2) = (
            [t[1][0] - t[0][0], t[1][2] - t[0][2]],
            [t[2][0] - t[0][0], t[2][2] - t[0][2]],
        );
        assert!(e1[1] * e2[0] - e1[0] * e2[1] > 0.0, "facing +y: {t:?}");
    }
    let jit = measure::parse_obj(&shapes::jittered_plate(4, 1.0, 0.3, 7));
    let moved = plate.iter().zip(&jit).filter(|(a, b)| a != b).count();
    assert!(moved > 20 && measure::boundary_edges(&jit, 1e-7).len() == 16);
    for (name, text, count) in [
        ("uv", shapes::latlong_sphere(8, 4), 8 * 2 + 8 * 2 * 2),
        ("ico", shapes::icosphere(2), 320),
    ] {
        let t = measure::parse_obj(&text);
        assert_eq!(t.len(), count, "{name}");
        assert!(
            measure::boundary_edges(&t, 1e-7).is_empty(),
            "{name} is closed"
        );
        for p in t.iter().flatten() {
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            assert!(close(r, 1.0, 1e-12), "{name}: radius {r}");
        }
    }
}
