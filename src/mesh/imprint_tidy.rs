//! Tidying the input's triangles around a cut: edge flips toward a
//! Delaunay triangulation beside the cracks and splits of long edges
//! leaving them (see [`super::imprint`]).

use crate::mesh::error::MeshError;
use crate::mesh::halfedge::SimMesh;
use crate::mesh::ids::{HalfedgeId, VertexId};
use crate::mesh::spatial::{add, cross, dot, norm, sub};

/// Two faces meeting at a larger angle than this (degrees) are not
/// re-triangulated: a flip there would change the surface's shape.
pub(super) const SETTLE_MAX_DEG: f64 = 2.0;

/// Whether flipping the interior edge of `h` (from `a` to `b` in face
/// `(a, b, c)`, its twin in `(b, a, d)`) into `c`-`d` keeps the surface:
/// the two faces lie in one plane (within [`SETTLE_MAX_DEG`]) and both new
/// faces `(a, d, c)` and `(d, b, c)` face the same way as the old ones.
/// Seams, borders and groups are [`SimMesh::flip_edge`]'s to refuse.
pub(super) fn flip_keeps_surface(mesh: &SimMesh, h: HalfedgeId) -> bool {
    let Some(t) = mesh.twin(h) else {
        return false;
    };
    let a = mesh.position(mesh.origin(h));
    let b = mesh.position(mesh.dest(h));
    let c = mesh.position(mesh.origin(mesh.prev(h)));
    let d = mesh.position(mesh.origin(mesh.prev(t)));
    let nf = cross(sub(b, a), sub(c, a));
    let ng = cross(sub(a, b), sub(d, b));
    let cos_max = SETTLE_MAX_DEG.to_radians().cos();
    if dot(nf, ng) < cos_max * norm(nf) * norm(ng) {
        return false;
    }
    let n = add(nf, ng);
    let faces_up = |x: [f64; 3], y: [f64; 3], z: [f64; 3]| {
        let m = cross(sub(y, x), sub(z, x));
        dot(m, n) > 1e-9 * norm(m) * norm(n) && norm(m) > 0.0
    };
    faces_up(a, d, c) && faces_up(d, b, c)
}

/// Edge flips toward a Delaunay triangulation where the cut made or
/// reshaped faces (`reshaped`: per original face, faces appended since
/// count as reshaped): an edge of such a face (or one across from it) is
/// flipped when its two opposite angles add up to more than 180 degrees,
/// its faces lie in one plane (within [`SETTLE_MAX_DEG`]), it is no crack,
/// border, seam or material border, and the flip keeps both triangles
/// facing the same way. A crack end or crossing that lies close to an
/// input vertex or edge makes needles (a crossing at 1% of an edge: a
/// triangle 1% high); needles turn over as soon as a gap opens beside
/// them, and the opening would be shortened there. Settled, the short
/// edge between the crack point and the input vertex has its third
/// corners off to its sides. The input's vertices, the crack and the
/// surface stay as they are; only faces next to the cut change. Returns
/// how many edges were flipped.
pub(super) fn settle(mesh: &mut SimMesh, reshaped: &[bool]) -> usize {
    let mut near: Vec<bool> = (0..mesh.n_faces())
        .map(|f| reshaped.get(f).copied().unwrap_or(true))
        .collect();
    let mut queue: std::collections::VecDeque<HalfedgeId> = mesh
        .halfedges()
        .filter(|&h| {
            mesh.twin(h).is_some_and(|t| {
                t.0 > h.0 && (near[mesh.face(h).idx()] || near[mesh.face(t).idx()])
            })
        })
        .collect();
    let mut queued = vec![false; mesh.n_halfedges()];
    for h in &queue {
        queued[h.idx()] = true;
    }
    let limit = 4 * queue.len() + 16;
    let mut flips = 0;
    while let Some(h) = queue.pop_front() {
        queued[h.idx()] = false;
        let Some(t) = mesh.twin(h) else { continue };
        let a = mesh.position(mesh.origin(h));
        let b = mesh.position(mesh.dest(h));
        let c = mesh.position(mesh.origin(mesh.prev(h)));
        let d = mesh.position(mesh.origin(mesh.prev(t)));
        let angle = |p: [f64; 3]| {
            let (u, v) = (sub(a, p), sub(b, p));
            norm(cross(u, v)).atan2(dot(u, v))
        };
        if angle(c) + angle(d) <= std::f64::consts::PI + 1e-9 {
            continue;
        }
        if !flip_keeps_surface(mesh, h) {
            continue;
        }
        let (f, g) = (mesh.face(h), mesh.face(t));
        if mesh.flip_edge(h).is_err() {
            continue;
        }
        flips += 1;
        if flips >= limit {
            break;
        }
        for face in [f, g] {
            near[face.idx()] = true;
            for e in mesh.face_halfedges(face) {
                if mesh.twin(e).is_some() && !queued[e.idx()] {
                    queued[e.idx()] = true;
                    queue.push_back(e);
                }
            }
        }
    }
    flips
}

/// Split every edge leaving a crack (or leaving a vertex within `length`
/// of one) that is longer than 1.5 `length` at `length` from its start, so
/// what moves with a crack's sides (a gap, curling) stays within about
/// `length` of it instead of tilting the input's large faces far into the
/// cells. Each split lies in a face's plane and interpolates its corners,
/// so the surface and its attributes are unchanged. Returns the number of
/// edges split.
pub(super) fn refine_along_cracks(mesh: &mut SimMesh, length: f64) -> Result<usize, MeshError> {
    if length <= 0.0 {
        return Ok(0);
    }
    let on = crack_flags(mesh);
    // The crack's vertices, then their neighbours closer than `length`.
    let mut near: Vec<VertexId> = mesh.vertices().filter(|v| on[v.idx()]).collect();
    let mut seen = on.clone();
    for i in 0..near.len() {
        for h in mesh.vertex_outgoing(near[i]) {
            let u = mesh.dest(h);
            if !seen[u.idx()] && mesh.edge_length(h) < length {
                seen[u.idx()] = true;
                near.push(u);
            }
        }
    }
    let mut pairs: Vec<(VertexId, VertexId)> = Vec::new();
    for &v in &near {
        for h in mesh.vertex_outgoing(v) {
            let u = mesh.dest(h);
            if !seen[u.idx()] && mesh.edge_length(h) > 1.5 * length {
                pairs.push((v, u));
            }
        }
    }
    let mut n = 0;
    for (v, u) in pairs {
        // Split edges may have moved on: the edge is looked up again.
        let Some(h) = mesh.find_halfedge(v, u) else {
            continue;
        };
        let l = mesh.edge_length(h);
        if l > 1.5 * length {
            mesh.split_edge(h, length / l)?;
            n += 1;
        }
    }
    Ok(n)
}

/// Per vertex: whether it ends a crack halfedge.
pub(super) fn crack_flags(mesh: &SimMesh) -> Vec<bool> {
    let mut on = vec![false; mesh.n_vertices()];
    for h in mesh.halfedges() {
        if mesh.is_crack_halfedge(h) {
            on[mesh.origin(h).idx()] = true;
            on[mesh.dest(h).idx()] = true;
        }
    }
    on
}
