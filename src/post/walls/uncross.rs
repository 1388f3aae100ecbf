//! Walls that do not cross: the bottoms pulled back where walls of different cracks would intersect, and the triangle intersection tests that find such pairs.

use super::*;
use crate::math::v3;
use crate::mesh::{FaceId, SimMesh, VertexId};
use parry3d::bounding_volume::Aabb;
use parry3d::math::Vector;
use parry3d::partitioning::{Bvh, BvhBuildStrategy};

/// Passes of [`build_walls_uncrossed`] that halve the crossing nodes'
/// moves before the next ones shut them.
pub(super) const HALVINGS_BEFORE_SHUTTING: usize = 3;

/// What [`build_walls_uncrossed`] had to do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Uncrossing {
    /// Crossing pairs of the walls at the positions given ([`crossings`]).
    pub crossing_before: usize,
    /// Crossing pairs left (0 unless the moves were dropped entirely and
    /// the walls still cross).
    pub crossing_after: usize,
    /// Passes of shortening.
    pub passes: usize,
    /// Nodes whose move was shortened.
    pub shortened_nodes: usize,
}

/// [`build_walls`] for the displaced positions `top`, where walls that
/// pass through the surface or each other (a side pushed across a
/// neighbouring crack, narrow sheared gaps at junctions) are not left:
/// the moves from rest of the crack nodes involved, with the nodes tied to
/// them, are halved ([`crate::post::width::shorten`]) and the walls built
/// again, a few times, then the cracks there are shut
/// ([`crate::post::width::shut`]), until none
/// crosses or [`MAX_HALVINGS`](crate::post::width::MAX_HALVINGS) passes
/// are done; the passes that left the fewest crossings are kept. `top` is
/// updated in place. The bottom line hangs from `hang` where given
/// ([`build_walls_hung`]) unless the mesh's own crosses less. `tied`: a
/// crack node's move is halved with every node tied to it (gaps opened by
/// moving whole cells), or alone (gaps opened in a band, each copy by its
/// own opening: halving the far side too pinched the gap there shut).
pub fn build_walls_uncrossed(
    mesh: &SimMesh,
    top: &mut [[f64; 3]],
    opts: &WallOptions,
    hang: Option<Hang>,
    tied: bool,
) -> (Walls, Uncrossing) {
    let max = crate::post::width::MAX_HALVINGS;
    let mut walls = build_walls_hung(mesh, top, opts, hang);
    let (mut count, mut nodes) = crossings(mesh, top, &walls);
    // A bottom line hung from another mesh's can cross itself where that
    // mesh's cracks met otherwise (a crossing there, two T-junctions a
    // snapping distance apart here): such walls cross at any opening, and
    // shortening them shut the gap at the junction. The mesh's own bottom
    // line, when its walls cross less.
    let mut hang = hang;
    if hang.is_some() && count > 0 {
        let own = build_walls_hung(mesh, top, opts, None);
        let (own_count, own_nodes) = crossings(mesh, top, &own);
        if own_count < count {
            (hang, walls, count, nodes) = (None, own, own_count, own_nodes);
        }
    }
    let mut fix = Uncrossing {
        crossing_before: count,
        ..Uncrossing::default()
    };
    if count == 0 {
        return (walls, fix);
    }
    let given: Vec<[f64; 3]> = top.to_vec();
    let mut best: Option<(usize, Vec<[f64; 3]>, Walls)> = None;
    while count > 0 && fix.passes <= max {
        // Halving helps where a side was pushed across another crack; a
        // nearly shut crack whose two walls cross (its sides' opening
        // directions differ at a bend) crosses at any fraction of its
        // opening, and only shutting it helps.
        if fix.passes < HALVINGS_BEFORE_SHUTTING {
            crate::post::width::shorten(mesh, top, &nodes, 0.5, tied);
        } else {
            crate::post::width::shut(mesh, top, &nodes, tied);
        }
        walls = build_walls_hung(mesh, top, opts, hang);
        (count, nodes) = crossings(mesh, top, &walls);
        fix.passes += 1;
        if count < best.as_ref().map_or(fix.crossing_before, |b| b.0) {
            best = Some((count, top.to_vec(), walls.clone()));
        }
    }
    // Shortening that did not help is undone (some crossings come from
    // the walls' construction, not from the moves).
    match best {
        Some((count, positions, best_walls)) => {
            top.copy_from_slice(&positions);
            walls = best_walls;
            fix.crossing_after = count;
            fix.shortened_nodes = given.iter().zip(top.iter()).filter(|(a, b)| a != b).count();
        }
        None => {
            top.copy_from_slice(&given);
            walls = build_walls_hung(mesh, top, opts, hang);
            fix.crossing_after = fix.crossing_before;
        }
    }
    (walls, fix)
}

/// Where the walls pass through the surface or each other: the number of
/// crossing (wall, wall) and (wall, surface face) pairs, and the crack
/// vertices involved (the ends of the walls' crack sides and the crack
/// vertices of the surface faces), sorted. Only surface faces at crack
/// vertices take part. Every triangle is shrunk towards its centroid by 1%
/// first, so pairs that only touch along an edge or at a corner (as the
/// walls of one crack do by construction) are not counted.
pub fn crossings(mesh: &SimMesh, top: &[[f64; 3]], walls: &Walls) -> (usize, Vec<VertexId>) {
    const SHRINK: f64 = 1e-2;
    let on_crack = crate::post::distance::crack_vertices(mesh);
    let mut is_crack = vec![false; mesh.n_vertices()];
    for v in &on_crack {
        is_crack[v.idx()] = true;
    }
    let mut faces: Vec<FaceId> = on_crack
        .iter()
        .flat_map(|&v| mesh.vertex_faces(v))
        .collect();
    faces.sort();
    faces.dedup();
    let mut pos: Vec<P3> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();
    let mut push = |p: [P3; 3]| {
        let c: P3 = std::array::from_fn(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0);
        let base = pos.len() as u32;
        for q in p {
            pos.push(std::array::from_fn(|k| q[k] + SHRINK * (c[k] - q[k])));
        }
        tris.push([base, base + 1, base + 2]);
    };
    for t in &walls.triangles {
        push(t.map(|i| walls.positions[i as usize]));
    }
    let n_walls = walls.triangles.len();
    for &f in &faces {
        push(mesh.face_vertices(f).map(|v| top[v.idx()]));
    }
    let mut nodes: Vec<VertexId> = Vec::new();
    let mut count = 0;
    for (a, b) in intersecting_pairs(&pos, &tris) {
        if a >= n_walls && b >= n_walls {
            continue; // surface with surface: not the walls' doing
        }
        count += 1;
        for t in [a, b] {
            if t < n_walls {
                let h = walls.sides[t];
                nodes.extend([mesh.origin(h), mesh.dest(h)]);
            } else {
                let f = faces[t - n_walls];
                nodes.extend(
                    mesh.face_vertices(f)
                        .into_iter()
                        .filter(|v| is_crack[v.idx()]),
                );
            }
        }
    }
    nodes.sort();
    nodes.dedup();
    (count, nodes)
}

/// The pairs `(i, j)`, `i < j`, of triangles (indices into `triangles`,
/// which index `positions`) that intersect or touch, sorted. Pairs that
/// share a vertex position (exactly equal coordinates) are ignored: they
/// touch along shared edges or corners by construction. Degenerate (zero
/// area) and non-finite triangles never intersect.
///
/// Candidate pairs come from a parry3d [`Bvh`] over the triangles' bounding
/// boxes (in `f32`, padded outward); each is then tested exactly enough in
/// `f64`: two non-coplanar triangles intersect iff an edge of one meets the
/// other; coplanar ones are tested in 2D. Touching within a relative
/// tolerance of `1e-12` counts as intersecting.
///
/// # Panics
/// If a triangle indexes past `positions`.
pub fn intersecting_pairs(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<(usize, usize)> {
    let tris: Vec<[P3; 3]> = triangles
        .iter()
        .map(|t| t.map(|i| positions[i as usize]))
        .collect();
    let finite = |t: &[P3; 3]| t.iter().flatten().all(|x| x.is_finite());
    let max_abs = tris
        .iter()
        .filter(|t| finite(t))
        .flat_map(|t| t.iter().flatten())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    // Covers the f32 rounding of every coordinate.
    let pad = (1e-6 * max_abs) as f32 + f32::MIN_POSITIVE;
    let aabb = |t: &[P3; 3]| {
        let lo: [f32; 3] = std::array::from_fn(|k| {
            t.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min) as f32 - pad
        });
        let hi: [f32; 3] = std::array::from_fn(|k| {
            t.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max) as f32 + pad
        });
        Aabb::new(
            Vector::new(lo[0], lo[1], lo[2]),
            Vector::new(hi[0], hi[1], hi[2]),
        )
    };
    let boxes: Vec<(usize, Aabb)> = tris
        .iter()
        .enumerate()
        .filter(|(_, t)| finite(t))
        .map(|(i, t)| (i, aabb(t)))
        .collect();
    let mut pairs = Vec::new();
    if boxes.is_empty() {
        return pairs;
    }
    let bvh = Bvh::from_iter(BvhBuildStrategy::Binned, boxes.iter().copied());
    for (i, bx) in &boxes {
        let a = &tris[*i];
        for j in bvh.intersect_aabb(bx) {
            let j = j as usize;
            if j <= *i {
                continue;
            }
            let b = &tris[j];
            let shares = a.iter().any(|p| b.contains(p));
            if !shares && triangles_intersect(a, b) {
                pairs.push((*i, j));
            }
        }
    }
    pairs.sort_unstable();
    pairs
}

/// Whether triangles `a` and `b` intersect or touch (see
/// [`intersecting_pairs`]).
pub(super) fn triangles_intersect(a: &[P3; 3], b: &[P3; 3]) -> bool {
    let normal = |t: &[P3; 3]| v3::cross(v3::sub(t[1], t[0]), v3::sub(t[2], t[0]));
    let (na, nb) = (normal(a), normal(b));
    let (la, lb) = (v3::norm(na), v3::norm(nb));
    let scale = a
        .iter()
        .chain(b)
        .flat_map(|p| a.iter().chain(b).map(move |q| v3::norm(v3::sub(*p, *q))))
        .fold(0.0, f64::max);
    if !(la > 0.0 && lb > 0.0 && scale > 0.0) {
        return false;
    }
    // Signed distances (times |n|) of each triangle's corners to the other's
    // plane, with their tolerances.
    let da = a.map(|p| v3::dot(nb, v3::sub(p, b[0])));
    let db = b.map(|p| v3::dot(na, v3::sub(p, a[0])));
    let (ta, tb) = (INTERSECT_TOL * lb * scale, INTERSECT_TOL * la * scale);
    let one_side = |d: &[f64; 3], t: f64| d.iter().all(|&x| x > t) || d.iter().all(|&x| x < -t);
    if one_side(&da, ta) || one_side(&db, tb) {
        return false;
    }
    if da.iter().all(|x| x.abs() <= ta) {
        // Coplanar.
        let (pa, pb) = (project(a, nb), project(b, nb));
        let eps = INTERSECT_TOL * scale * scale;
        return (0..3).any(|i| segment_hits_triangle_2d(pa[i], pa[(i + 1) % 3], &pb, eps))
            || point_in_triangle_2d(pb[0], &pa, eps);
    }
    (0..3).any(|i| edge_hits_triangle(a[i], a[(i + 1) % 3], da[i], da[(i + 1) % 3], b, nb, ta))
        || (0..3)
            .any(|i| edge_hits_triangle(b[i], b[(i + 1) % 3], db[i], db[(i + 1) % 3], a, na, tb))
}

/// Whether segment `p - q`, whose ends have signed plane distances (times
/// `|n|`) `dp`, `dq` to triangle `t` with normal `n`, meets `t`.
pub(super) fn edge_hits_triangle(
    p: P3,
    q: P3,
    dp: f64,
    dq: f64,
    t: &[P3; 3],
    n: P3,
    tol: f64,
) -> bool {
    let (p_in, q_in) = (dp.abs() <= tol, dq.abs() <= tol);
    if p_in && q_in {
        // The segment lies in the plane (2D orientations scale like |n|).
        let eps = INTERSECT_TOL * v3::norm(n);
        let pt = project(t, n);
        let [pp, pq] = [p, q].map(|x| project(&[x; 3], n)[0]);
        return segment_hits_triangle_2d(pp, pq, &pt, eps);
    }
    if (dp > tol && dq > tol) || (dp < -tol && dq < -tol) {
        return false;
    }
    let x = if p_in {
        p
    } else if q_in {
        q
    } else {
        v3::add(p, v3::scale(v3::sub(q, p), dp / (dp - dq)))
    };
    // Inside (or on) every edge, seen along n (the products scale like
    // |n|^2).
    let eps = INTERSECT_TOL * v3::dot(n, n);
    (0..3).all(|i| {
        let e = v3::sub(t[(i + 1) % 3], t[i]);
        v3::dot(v3::cross(e, v3::sub(x, t[i])), n) >= -eps
    })
}

/// Drops the coordinate along which `n` is largest; the result's
/// orientation may be flipped, which the 2D tests do not care about.
pub(super) fn project(t: &[P3; 3], n: P3) -> [[f64; 2]; 3] {
    let k = (0..3)
        .max_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs()))
        .unwrap_or(2);
    let (x, y) = ((k + 1) % 3, (k + 2) % 3);
    t.map(|p| [p[x], p[y]])
}

pub(super) fn orient_2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether `p` is inside or on triangle `t` (either orientation).
pub(super) fn point_in_triangle_2d(p: [f64; 2], t: &[[f64; 2]; 3], eps: f64) -> bool {
    let o = [0, 1, 2].map(|i| orient_2d(t[i], t[(i + 1) % 3], p));
    o.iter().all(|&x| x >= -eps) || o.iter().all(|&x| x <= eps)
}

/// Whether 2D segments `p1 - p2` and `q1 - q2` meet (touching included).
pub(super) fn segments_meet_2d(
    p1: [f64; 2],
    p2: [f64; 2],
    q1: [f64; 2],
    q2: [f64; 2],
    eps: f64,
) -> bool {
    let d1 = orient_2d(q1, q2, p1);
    let d2 = orient_2d(q1, q2, p2);
    let d3 = orient_2d(p1, p2, q1);
    let d4 = orient_2d(p1, p2, q2);
    let straddle = |x: f64, y: f64| (x > eps && y < -eps) || (x < -eps && y > eps);
    if straddle(d1, d2) && straddle(d3, d4) {
        return true;
    }
    // Touching or collinear: an endpoint on the other segment (within its
    // bounding box, with a relative slack).
    let extent = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs().max((a[1] - b[1]).abs());
    let slack = INTERSECT_TOL * (extent(p1, p2) + extent(q1, q2));
    let on = |a: [f64; 2], b: [f64; 2], p: [f64; 2], d: f64| {
        d.abs() <= eps
            && (0..2).all(|k| p[k] >= a[k].min(b[k]) - slack && p[k] <= a[k].max(b[k]) + slack)
    };
    on(q1, q2, p1, d1) || on(q1, q2, p2, d2) || on(p1, p2, q1, d3) || on(p1, p2, q2, d4)
}

/// Whether 2D segment `p - q` meets triangle `t`.
pub(super) fn segment_hits_triangle_2d(
    p: [f64; 2],
    q: [f64; 2],
    t: &[[f64; 2]; 3],
    eps: f64,
) -> bool {
    point_in_triangle_2d(p, t, eps)
        || point_in_triangle_2d(q, t, eps)
        || (0..3).any(|i| segments_meet_2d(p, q, t[i], t[(i + 1) % 3], eps))
}
