//! Tests of the isotropic remesher.

use super::*;
use crate::mesh::attributes::{Channel, ChannelKind};
use crate::mesh::shapes::{build, grid_input, icosphere_input};

fn edge_lengths(m: &SimMesh) -> Vec<f64> {
    m.halfedges()
        .filter(|&h| m.twin(h).is_none_or(|t| t.0 > h.0))
        .map(|h| m.edge_length(h))
        .collect()
}

fn valence6_fraction(m: &SimMesh) -> f64 {
    let mut inner = 0;
    let mut six = 0;
    for v in m.vertices() {
        if m.is_boundary_vertex(v) {
            continue;
        }
        inner += 1;
        if m.vertex_outgoing(v).count() == 6 {
            six += 1;
        }
    }
    six as f64 / inner.max(1) as f64
}

/// `m` remeshed to `target` with the default options, checked valid.
fn remesh_valid(m: &SimMesh, target: f64) -> (SimMesh, RemeshReport) {
    let (r, rep) = remesh(
        m,
        &RemeshOptions {
            target_edge: target,
            ..Default::default()
        },
    )
    .unwrap();
    r.validate().unwrap();
    (r, rep)
}

/// A 10 x 10 plate of coarse triangles with uv = (x, y) refines to
/// near-equilateral triangles of the target size with exact UVs, the same
/// boundary and the same area.
#[test]
fn a_plate_refines_isotropically_with_exact_uvs() {
    let (m, _) = build(&grid_input(10, 10));
    let target = 0.25;
    let est = estimate_triangles(&m, target);
    let (r, rep) = remesh_valid(&m, target);
    assert!(rep.remeshed);
    let n = r.n_faces() as f64;
    assert!(
        (0.75..1.25).contains(&(n / est as f64)),
        "{n} faces, estimate {est}"
    );
    let lengths = edge_lengths(&r);
    let mean = lengths.iter().sum::<f64>() / lengths.len() as f64;
    assert!((mean / target - 1.0).abs() < 0.15, "mean edge {mean}");
    let within = lengths
        .iter()
        .filter(|&&l| (0.5 * target..=1.6 * target).contains(&l))
        .count();
    assert!(
        within as f64 > 0.95 * lengths.len() as f64,
        "{within} of {}",
        lengths.len()
    );
    assert!(
        valence6_fraction(&r) > 0.6,
        "valence 6: {}",
        valence6_fraction(&r)
    );
    assert!((r.total_area() - 100.0).abs() < 1e-9);
    // UVs equal the position everywhere.
    let uv = r.wedges().channel("uv").unwrap();
    for f in r.faces() {
        for (v, w) in r.face_vertices(f).into_iter().zip(r.face_wedges(f)) {
            let p = r.position(v);
            let t = &uv.data[w.idx() * 2..w.idx() * 2 + 2];
            assert!(
                (t[0] - p[0]).abs() < 1e-9 && (t[1] - p[1]).abs() < 1e-9,
                "{p:?} {t:?}"
            );
        }
    }
    // The boundary stays the square's.
    for v in r.vertices().filter(|&v| r.is_boundary_vertex(v)) {
        let p = r.position(v);
        let on = [p[0], p[1]]
            .iter()
            .any(|&x| x.abs() < 1e-9 || (x - 10.0).abs() < 1e-9);
        assert!(on, "boundary vertex off the border: {p:?}");
    }
}

/// A UV seam stays a seam: both sides keep their own values.
#[test]
fn a_uv_seam_keeps_both_sides() {
    // Two halves of a plate whose UVs jump at x = 5.
    let mut input = grid_input(10, 4);
    let n = input.positions.len();
    let mut pos = input.positions.clone();
    let mut uv: Vec<f64> = Vec::new();
    for p in &input.positions {
        uv.extend_from_slice(&[p[0], p[1]]);
    }
    // Duplicate the vertices at x = 5 for the right half (u + 100).
    let mut remap = vec![u32::MAX; n];
    for (i, p) in input.positions.iter().enumerate() {
        if (p[0] - 5.0).abs() < 1e-12 {
            remap[i] = pos.len() as u32;
            pos.push(*p);
            uv.extend_from_slice(&[p[0] + 100.0, p[1]]);
        }
    }
    for (i, p) in input.positions.iter().enumerate() {
        if p[0] > 5.0 + 1e-12 {
            uv[2 * i] += 100.0;
        }
    }
    for t in input.triangles.iter_mut() {
        let right = t
            .iter()
            .any(|&v| input.positions[v as usize][0] > 5.0 + 1e-12);
        if right {
            for v in t.iter_mut() {
                if remap[*v as usize] != u32::MAX {
                    *v = remap[*v as usize];
                }
            }
        }
    }
    input.positions = pos;
    input.wedge_channels = vec![Channel::new("uv", 2, ChannelKind::Linear, uv)];
    let (m, _) = build(&input);
    let (r, rep) = remesh(
        &m,
        &RemeshOptions {
            target_edge: 0.3,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        rep.feature_edges >= 4 + 2 * 14,
        "seam and border kept: {}",
        rep.feature_edges
    );
    let uv = r.wedges().channel("uv").unwrap();
    for f in r.faces() {
        let c = r
            .face_vertices(f)
            .iter()
            .fold(0.0, |a, &v| a + r.position(v)[0])
            / 3.0;
        for (v, w) in r.face_vertices(f).into_iter().zip(r.face_wedges(f)) {
            let p = r.position(v);
            let u = uv.data[w.idx() * 2];
            let want = if c > 5.0 { p[0] + 100.0 } else { p[0] };
            assert!(
                (u - want).abs() < 1e-9,
                "face centre x {c}: u {u} at x {}",
                p[0]
            );
        }
    }
}

/// A sphere (no features) refines onto its own surface with unit normals
/// carried; a cube keeps its 12 sharp edges.
#[test]
fn curved_and_sharp_surfaces_stay_on_the_input() {
    let (m, _) = build(&icosphere_input(2));
    let (r, _) = remesh(
        &m,
        &RemeshOptions {
            target_edge: 0.08,
            ..Default::default()
        },
    )
    .unwrap();
    r.validate().unwrap();
    assert!(r.n_faces() > 4 * m.n_faces());
    // Every vertex lies on the input polyhedron (within rounding): its
    // radius is between the faces' inradius and 1.
    for v in r.vertices() {
        let p = r.position(v);
        let rad = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        assert!((0.95..=1.0 + 1e-9).contains(&rad), "radius {rad}");
    }
    assert!(valence6_fraction(&r) > 0.6);
    // The cube.
    let (c, _) = build(&crate::mesh::shapes::cube24_input());
    let (rc, rep) = remesh(
        &c,
        &RemeshOptions {
            target_edge: 0.1,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(rep.feature_edges >= 12);
    let (lo, hi) = c.bounding_box();
    for v in rc.vertices() {
        let p = rc.position(v);
        let on_face = (0..3).any(|k| (p[k] - lo[k]).abs() < 1e-9 || (p[k] - hi[k]).abs() < 1e-9);
        assert!(on_face, "off the cube: {p:?}");
    }
    assert!((rc.total_area() - c.total_area()).abs() < 1e-9 * c.total_area());
}

/// A surface already finer than the target is left as it is when asked
/// (`coarsen = false`); by default it is coarsened to about the triangles
/// the target needs.
#[test]
fn fine_surfaces_are_coarsened_unless_asked_not_to() {
    let (m, _) = build(&grid_input(10, 10));
    let keep = RemeshOptions {
        target_edge: 3.0,
        coarsen: false,
        ..Default::default()
    };
    let (r, rep) = remesh(&m, &keep).unwrap();
    assert!(!rep.remeshed);
    assert_eq!(r.n_faces(), m.n_faces());
    let (r, rep) = remesh_valid(&m, 3.0);
    assert!(rep.remeshed);
    let est = estimate_triangles(&m, 3.0) as f64;
    let n = r.n_faces() as f64;
    assert!((0.6..1.6).contains(&(n / est)), "{n} faces, estimate {est}");
    assert!(remesh(
        &m,
        &RemeshOptions {
            target_edge: 0.0,
            ..Default::default()
        }
    )
    .is_err());
}

/// The interior edges of a plate in the xy plane at least `margin` from
/// its border `[0, size]^2`: (direction in degrees in [0, 180), length).
fn interior_edges(m: &SimMesh, size: f64, margin: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for h in m.halfedges() {
        if m.twin(h).is_none_or(|t| t.0 < h.0) {
            continue;
        }
        let (a, b) = (m.position(m.origin(h)), m.position(m.dest(h)));
        let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
        if mid.iter().any(|&x| x < margin || x > size - margin) {
            continue;
        }
        let angle = (b[1] - a[1])
            .atan2(b[0] - a[0])
            .to_degrees()
            .rem_euclid(180.0);
        out.push((angle, m.edge_length(h)));
    }
    out
}

/// Length-weighted shares of the [`interior_edges`] in `N` bins over 180
/// degrees.
fn direction_bins<const N: usize>(edges: &[(f64, f64)]) -> [f64; N] {
    let mut bins = [0.0; N];
    let width = 180.0 / N as f64;
    for &(angle, l) in edges {
        bins[((angle / width) as usize).min(N - 1)] += l;
    }
    let total: f64 = bins.iter().sum();
    bins.map(|b| b / total)
}

/// Length-weighted directions of the interior edges in 6 bins of 30
/// degrees, and the share within 5 degrees of the x axis, the y axis and
/// the grid's diagonal.
fn edge_directions(m: &SimMesh, size: f64, margin: f64) -> ([f64; 6], f64) {
    let edges = interior_edges(m, size, margin);
    let total: f64 = edges.iter().map(|e| e.1).sum();
    let near_rows: f64 = edges
        .iter()
        .filter(|(angle, _)| {
            [0.0, 45.0, 90.0, 180.0]
                .iter()
                .any(|&r| (angle - r).abs() < 5.0)
        })
        .map(|e| e.1)
        .sum();
    (direction_bins(&edges), near_rows / total)
}

/// A regular grid (rows, columns and one diagonal, as a subdivided plane
/// from a DCC tool) coarsened to 2.2 times its edge: local edits and
/// smoothing alone keep a lattice (the rows survive, and cracks follow
/// them); jittered, the remeshed surface has no direction of its own:
/// every 30-degree bin of edge directions within 15% of uniform, and no
/// more edges within 5 degrees of the grid's three directions than chance
/// (30 of 180 degrees: 0.167).
#[test]
fn a_regular_grid_coarsens_into_a_mesh_without_rows() {
    let (m, _) = build(&grid_input(80, 80));
    let (r, rep) = remesh_valid(&m, 2.2);
    assert!(rep.remeshed);
    let (bins, near_rows) = edge_directions(&r, 80.0, 6.0);
    eprintln!("jittered: bins {bins:?}, near the rows {near_rows:.3}");
    for (k, b) in bins.iter().enumerate() {
        assert!(
            (b * 6.0 - 1.0).abs() < 0.15,
            "bin {k}: {b:.3} of the edge length (uniform 0.167): {bins:?}"
        );
    }
    assert!(near_rows < 0.2, "near the rows {near_rows:.3}");
    // Without the jitter the rows survive (so the test above can fail).
    let (r, _) = remesh(
        &m,
        &RemeshOptions {
            target_edge: 2.2,
            jitter: 0.0,
            ..Default::default()
        },
    )
    .unwrap();
    let (bins, near_rows) = edge_directions(&r, 80.0, 6.0);
    eprintln!("not jittered: bins {bins:?}, near the rows {near_rows:.3}");
    assert!(near_rows > 0.3, "near the rows {near_rows:.3}");
}

/// The same grid refined to under 0.6 of its edge: midpoint splits of a
/// regular grid are a regular grid, and flips and smoothing settle it into
/// an equilateral lattice (without jitter most of the edge length lies
/// within three 15-degree bins). Jittered once after the splits, no
/// 15-degree bin holds more than 30% over or under uniform (1/12).
#[test]
fn a_regular_grid_refines_into_a_mesh_without_rows() {
    let (m, _) = build(&grid_input(40, 40));
    for target in [0.3, 0.45, 0.58] {
        let (r, rep) = remesh_valid(&m, target);
        assert!(rep.remeshed);
        assert!(r.n_faces() > 2 * m.n_faces(), "{} faces", r.n_faces());
        let bins = direction_bins::<12>(&interior_edges(&r, 40.0, 3.0));
        eprintln!("{target}: jittered: bins {bins:.3?}");
        for (k, b) in bins.iter().enumerate() {
            assert!(
                (b * 12.0 - 1.0).abs() < 0.3,
                "target {target}, bin {k}: {b:.3} of the edge length (uniform 0.083): {bins:.3?}"
            );
        }
    }
    // Without the jitter: a lattice (so the test above can fail).
    let (r, _) = remesh(
        &m,
        &RemeshOptions {
            target_edge: 0.58,
            jitter: 0.0,
            ..Default::default()
        },
    )
    .unwrap();
    let mut plain = direction_bins::<12>(&interior_edges(&r, 40.0, 3.0));
    eprintln!("not jittered: bins {plain:.3?}");
    plain.sort_by(f64::total_cmp);
    assert!(
        plain[9] + plain[10] + plain[11] > 0.9,
        "a lattice: three bins hold nearly every edge: {plain:?}"
    );
}

/// A graded surface, fine at one end and coarse at the other, is remeshed
/// although its mean edge is below the target: the area in triangles
/// longer than the split length decides, not the mean. After it, the large
/// triangles are gone.
#[test]
fn graded_surfaces_are_remeshed_although_their_mean_edge_is_short() {
    let mut input = grid_input(40, 10);
    for p in &mut input.positions {
        p[0] = 40.0 * (p[0] / 40.0).powi(3);
    }
    let (m, _) = build(&input);
    let target = 1.5;
    assert!(m.mean_edge_length() < target, "{}", m.mean_edge_length());
    let share = long_edge_area_share(&m, 4.0 / 3.0 * target);
    assert!(share > 0.4, "long share {share}");
    let (r, rep) = remesh_valid(&m, target);
    assert!(rep.remeshed);
    assert_eq!(rep.long_edge_area_share, share);
    let after = long_edge_area_share(&r, 4.0 / 3.0 * target);
    assert!(after < 0.05, "long share after {after}");
    assert!((r.total_area() - m.total_area()).abs() < 1e-9 * m.total_area());
}

/// A tangent channel keeps its handedness sign exactly (the fourth value is
/// a sign, not a vector component).
#[test]
fn tangent_signs_stay_signs() {
    let mut input = grid_input(4, 4);
    let n = input.positions.len();
    let tangents: Vec<f64> = (0..n).flat_map(|_| [1.0, 0.0, 0.0, -1.0]).collect();
    input.wedge_channels.push(Channel::new(
        "TANGENT",
        4,
        ChannelKind::UnitVector,
        tangents,
    ));
    let (m, _) = build(&input);
    let (r, _) = remesh(
        &m,
        &RemeshOptions {
            target_edge: 0.3,
            ..Default::default()
        },
    )
    .unwrap();
    let t = r.wedges().channel("TANGENT").unwrap();
    for w in 0..r.n_wedges() {
        let v = &t.data[w * 4..w * 4 + 4];
        assert_eq!(v[3], -1.0, "{v:?}");
        assert!((v[0] - 1.0).abs() < 1e-12 && v[1].abs() < 1e-12, "{v:?}");
    }
}

/// A remeshed surface is stored in spatial order: consecutive faces lie a
/// few edges apart, and a face's vertices have nearby numbers (splits
/// append their faces and vertices at the end, which without the order
/// would scatter neighbours through memory).
#[test]
fn remeshed_faces_and_vertices_are_stored_near_their_neighbours() {
    let (m, _) = build(&icosphere_input(2));
    let target = m.mean_edge_length() / 8.0;
    let (r, _) = remesh(
        &m,
        &RemeshOptions {
            target_edge: target,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(r.n_faces() > 10_000, "{}", r.n_faces());
    let centroid = |f: FaceId| {
        let p = r.face_vertices(f).map(|v| r.position(v));
        std::array::from_fn::<f64, 3, _>(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0)
    };
    let faces: Vec<FaceId> = r.faces().collect();
    let step: f64 = faces
        .windows(2)
        .map(|w| crate::math::v3::norm(crate::math::v3::sub(centroid(w[0]), centroid(w[1]))))
        .sum::<f64>()
        / (faces.len() - 1) as f64;
    assert!(
        step < 3.0 * target,
        "consecutive faces {step} apart, edge {target}"
    );
    // The vertex numbers of a face span a small part of the numbering.
    let spread: f64 = faces
        .iter()
        .map(|&f| {
            let v = r.face_vertices(f).map(|v| v.0 as f64);
            v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
        })
        .sum::<f64>()
        / faces.len() as f64;
    assert!(
        spread < 0.05 * r.n_vertices() as f64,
        "mean index spread {spread} of {} vertices",
        r.n_vertices()
    );
}

/// Where the surface bends tighter than the target edge can follow, edges
/// shorten so that faces stay near it: a fine sphere coarsened to edges of
/// half its radius keeps its faces within a few `chord_error * target` of
/// the sphere (measured: 0.027 deep against 0.064 with uniform edges).
#[test]
fn tight_curvature_keeps_edges_short_enough_to_follow_it() {
    let (m, _) = build(&icosphere_input(4));
    let depth = |chord_error: f64| {
        let (r, _) = remesh(
            &m,
            &RemeshOptions {
                target_edge: 0.5,
                coarsen: true,
                chord_error,
                ..Default::default()
            },
        )
        .unwrap();
        r.validate().unwrap();
        let deepest = r
            .faces()
            .map(|f| {
                let [a, b, c] = r.face_vertices(f).map(|v| r.position(v));
                let g: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0);
                1.0 - (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt()
            })
            .fold(0.0f64, f64::max);
        (deepest, r.n_faces())
    };
    let (uniform, n_uniform) = depth(0.0);
    let (adaptive, n_adaptive) = depth(0.02);
    // e = 0.01 bounds a chord's midpoint at the asked length; edges run to
    // 4/3 of it and a face's centre lies deeper than its edges': 3e.
    assert!(adaptive < 0.03, "adaptive faces {adaptive} deep");
    assert!(
        uniform > 2.0 * adaptive,
        "uniform {uniform}, adaptive {adaptive}"
    );
    assert!(
        n_adaptive > n_uniform,
        "{n_adaptive} against {n_uniform} faces"
    );
}

/// A fine 120 x 120 grid with a height grain of a fifth of its edges (a
/// scan's noise, a sculpted ground) remeshed to edges six times its own
/// comes out as the flat grid does: the grain neither pins feature lines
/// (its sharp edges are short runs) nor asks for edges shorter than the
/// target. A fold of the same grid stays a feature line.
#[test]
fn grain_finer_than_the_target_is_smoothed_over_and_a_fold_is_kept() {
    let n = 120;
    let target = 6.0;
    let flat = grid_input(n, n);
    let mut grainy = flat.clone();
    let mut rng = crate::mesh::shapes::Lcg(7);
    for p in &mut grainy.positions {
        p[2] = (rng.next_f64() - 0.5) * 0.4;
    }
    let (flat_mesh, _) = build(&flat);
    let (grainy_mesh, _) = build(&grainy);
    let (f, frep) = remesh_valid(&flat_mesh, target);
    let (g, grep) = remesh_valid(&grainy_mesh, target);
    assert_eq!(
        grep.feature_edges, frep.feature_edges,
        "the grain's sharp edges kept as features"
    );
    let ratio = g.n_faces() as f64 / f.n_faces() as f64;
    assert!(
        ratio < 1.4,
        "grainy {} faces against flat {}",
        g.n_faces(),
        f.n_faces()
    );
    // The same grid folded by 90 degrees along x = n / 2.
    let mut folded = flat.clone();
    let half = n as f64 / 2.0;
    for p in &mut folded.positions {
        if p[0] > half {
            p[2] = p[0] - half;
            p[0] = half;
        }
    }
    let (folded_mesh, _) = build(&folded);
    let (r, rep) = remesh_valid(&folded_mesh, target);
    assert!(
        rep.feature_edges >= frep.feature_edges + n,
        "{} feature edges, the flat grid's {}",
        rep.feature_edges,
        frep.feature_edges
    );
    // The fold stays sharp: every vertex lies on one of its two planes.
    for v in r.vertices() {
        let p = r.position(v);
        assert!(
            p[2].abs() < 1e-9 || (p[0] - half).abs() < 1e-9,
            "off the fold's planes: {p:?}"
        );
    }
}

/// The edge list gathered vertex by vertex is the one found by testing
/// each upper half-edge's faces: every edge once from its lower
/// end, a border edge from either end, and not an edge whose faces all
/// hold it from its upper end (two faces turned against each other).
#[test]
fn the_edge_list_is_every_edge_once() {
    let (mesh, _) = build(&grid_input(9, 7));
    let input = Input::new(&mesh, 30.0, 0.0);
    let mut w = Work::from_input(&mesh, &input, vec![1.0; mesh.n_vertices()]);
    // Holes (faces gone, as a collapse leaves them) and a face turned over.
    for f in [3u32, 40, 41, 77] {
        w.alive[f as usize] = false;
        for v in w.faces[f as usize] {
            w.vf[v as usize].retain(|&x| x != f);
        }
    }
    w.faces[20].swap(1, 2);
    let reference = |w: &Work| {
        let mut e = Vec::new();
        for (f, t) in w.faces.iter().enumerate() {
            if !w.alive[f] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let faces = w.vf[a as usize]
                    .iter()
                    .filter(|&&g| w.faces[g as usize].contains(&b))
                    .count();
                if a < b || faces == 1 {
                    e.push(key(a, b));
                }
            }
        }
        e.sort_unstable();
        e.dedup();
        e
    };
    let want = reference(&w);
    assert_eq!(w.edges(), want);
    // The turned face's edges with a neighbour held from the upper end
    // twice are left out, and border edges from the upper end are in.
    let all: std::collections::BTreeSet<(u32, u32)> = w
        .faces
        .iter()
        .enumerate()
        .filter(|(f, _)| w.alive[*f])
        .flat_map(|(_, t)| (0..3).map(move |k| key(t[k], t[(k + 1) % 3])))
        .collect();
    assert!(want.len() < all.len(), "{} of {}", want.len(), all.len());
    let upper_borders = want
        .iter()
        .filter(|&&(a, b)| {
            w.faces
                .iter()
                .enumerate()
                .filter(|(f, t)| w.alive[*f] && t.contains(&a) && t.contains(&b))
                .all(|(_, t)| (0..3).any(|k| t[k] == b && t[(k + 1) % 3] == a))
        })
        .count();
    assert!(upper_borders > 0);
}
