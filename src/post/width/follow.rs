//! What the surface carries while its vertices slide (the gaps' and
//! grooves' moves of [`super::displace`] and [`super::groove`]): its
//! attributes resampled where each vertex now lies, its normals turned.

use super::vertex_normals;
use crate::math::v3;
use crate::mesh::spatial::closest_on_triangle;
use crate::mesh::{FaceId, HalfedgeId, SimMesh, VertexId, WedgeId};

/// Keep the surface's attributes in place while its vertices slide: the
/// corners of every vertex that moves from its rest position to
/// `positions` get new wedges holding the values (UVs, normal, tangent,
/// colours) the rest surface has where the vertex now lies: from the
/// nearest of the wedge's own faces at rest, across edges without a seam
/// or a crack to the face it lies over (`walk_to`). A gap or a groove then
/// opens over a texture that stays where it was, instead of squeezing the
/// texture beside the crack: on a
/// high-contrast map (an emissive pattern, a glossy normal map) a squeeze
/// shows as detail sliding sideways far wider than the gap. Call before
/// moving the mesh to `positions` (and before [`turn_normals`]). Returns
/// how many wedges were made.
pub fn resample_moved_wedges(mesh: &mut SimMesh, positions: &[[f64; 3]]) -> usize {
    // The corners of each moved vertex, by wedge (copies of a crack vertex
    // may share a wedge; each copy gets its own values).
    let mut corners: Vec<(u32, u32, u32)> = mesh
        .halfedges()
        .filter(|&h| positions[mesh.origin(h).idx()] != mesh.position(mesh.origin(h)))
        .map(|h| (mesh.origin(h).0, mesh.wedge(h).0, h.0))
        .collect();
    corners.sort_unstable();
    // Per wedge of a moved vertex: its corners and the values' sources.
    type Update = (Vec<HalfedgeId>, Vec<(WedgeId, f64)>);
    let mut updates: Vec<Update> = Vec::new();
    for run in corners.chunk_by(|a, b| (a.0, a.1) == (b.0, b.1)) {
        let q = positions[run[0].0 as usize];
        // The walk starts from the face of the wedge nearest to the new
        // position (the first in corner order on a tie).
        let mut best: Option<(f64, FaceId)> = None;
        for &(_, _, h) in run {
            let f = mesh.face(HalfedgeId(h));
            let t = mesh.face_vertices(f).map(|u| mesh.position(u));
            let d = v3::norm(v3::sub(q, closest_on_triangle(q, t).0));
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, f));
            }
        }
        let Some((_, f)) = best else { continue };
        let (f, l) = walk_to(mesh, f, q);
        let sum = l[0] + l[1] + l[2];
        if sum.is_nan() || sum <= 0.0 {
            continue;
        }
        let sources = mesh
            .face_halfedges(f)
            .into_iter()
            .zip(l)
            .map(|(h, t)| (mesh.wedge(h), t / sum))
            .collect();
        updates.push((run.iter().map(|c| HalfedgeId(c.2)).collect(), sources));
    }
    // New wedges only: the sources keep their values while others read them.
    for (hs, sources) in &updates {
        mesh.rewedge_corners(hs, sources);
    }
    updates.len()
}

/// Most faces [`walk_to`] crosses.
const MAX_WALK: usize = 64;

/// From face `f`, the face of the rest surface over which `q` lies and the
/// barycentric coordinates there (of the nearest point of it): walk across
/// the edge `q` lies beyond while that edge joins the faces without a seam
/// (the same wedges on both sides) or a crack, so a vertex that slid past
/// its own narrow faces reads the texture of the face it now lies over.
fn walk_to(mesh: &SimMesh, mut f: FaceId, q: [f64; 3]) -> (FaceId, [f64; 3]) {
    for _ in 0..MAX_WALK {
        let t = mesh.face_vertices(f).map(|u| mesh.position(u));
        // Barycentric coordinates of q projected onto the face's plane.
        let (e0, e1, e2) = (v3::sub(t[1], t[0]), v3::sub(t[2], t[0]), v3::sub(q, t[0]));
        let (d00, d01, d11) = (v3::dot(e0, e0), v3::dot(e0, e1), v3::dot(e1, e1));
        let (d20, d21) = (v3::dot(e2, e0), v3::dot(e2, e1));
        let det = d00 * d11 - d01 * d01;
        if det.is_nan() || det <= 1e-24 * d00 * d11 {
            break;
        }
        let y = (d11 * d20 - d01 * d21) / det;
        let z = (d00 * d21 - d01 * d20) / det;
        let l = [1.0 - y - z, y, z];
        let k = (0..3).min_by(|&a, &b| l[a].total_cmp(&l[b])).unwrap_or(0);
        if l[k] >= 0.0 {
            break;
        }
        // The edge opposite corner k, from corner k + 1 to corner k + 2.
        let h = mesh.face_halfedges(f)[(k + 1) % 3];
        let Some(tw) = mesh.twin(h) else { break };
        let seamless = mesh.wedge(h) == mesh.wedge(mesh.next(tw))
            && mesh.wedge(mesh.next(h)) == mesh.wedge(tw);
        if !seamless {
            break;
        }
        f = mesh.face(tw);
    }
    let t = mesh.face_vertices(f).map(|u| mesh.position(u));
    (f, closest_on_triangle(q, t).1)
}

/// Turn the wedges' `NORMAL` (and `TANGENT` direction) values of every
/// moved vertex by the rotation taking its rest normal to its normal at
/// `positions`, so shading follows curled edges while hard edges stay hard.
/// Call before moving the mesh to `positions`.
pub fn turn_normals(mesh: &mut SimMesh, positions: &[[f64; 3]]) {
    let before = vertex_normals(mesh, mesh.positions());
    let after = vertex_normals(mesh, positions);
    // The rotation of each wedge: from the first corner that uses it.
    let moved = |v: VertexId| positions[v.idx()] != mesh.position(v);
    let keeps: Vec<bool> = mesh
        .vertices()
        .map(|v| {
            !moved(v)
                && mesh
                    .vertex_faces(v)
                    .any(|f| !mesh.face_vertices(f).into_iter().any(moved))
        })
        .collect();
    let mut rot: Vec<Option<([f64; 3], [f64; 3])>> = vec![None; mesh.n_wedges()];
    for h in mesh.halfedges() {
        let (v, w) = (mesh.origin(h), mesh.wedge(h));
        // A vertex that stays with a face that stays (at the border of
        // what moves) keeps its normal, although faces on one side tilt:
        // its faces on the other side keep their shading.
        if keeps[v.idx()] {
            continue;
        }
        if rot[w.idx()].is_none() {
            rot[w.idx()] = Some((before[v.idx()], after[v.idx()]));
        }
    }
    for (name, comps) in [("NORMAL", 3usize), ("TANGENT", 4usize)] {
        let Some(values) = mesh.wedge_values_mut(name) else {
            continue;
        };
        if values.len() != rot.len() * comps {
            continue;
        }
        for (w, r) in rot.iter().enumerate() {
            let Some((a, b)) = r else { continue };
            let x = &mut values[w * comps..w * comps + 3];
            let y = rotate([x[0], x[1], x[2]], *a, *b);
            x.copy_from_slice(&y);
        }
    }
}

/// Rotate `x` by the smallest rotation taking unit `a` to unit `b`
/// (identity when either is zero or they are opposite).
fn rotate(x: [f64; 3], a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let c = v3::dot(a, b);
    let k = v3::cross(a, b);
    let s = v3::norm(k);
    if s < 1e-12 || c <= -1.0 + 1e-12 || v3::norm(a) == 0.0 || v3::norm(b) == 0.0 {
        return x;
    }
    // Rodrigues with k = a x b (|k| = sin): x c + (k x x) + k (k.x) / (1 + c).
    v3::add(
        v3::add(v3::scale(x, c), v3::cross(k, x)),
        v3::scale(k, v3::dot(k, x) / (1.0 + c)),
    )
}
