//! Distance along a surface from a point on it: Dijkstra's order over the
//! vertices with each triangle's unfolded update (the straight line from a
//! virtual source through the triangle's known edge, as fast marching
//! does), so the distance follows the surface, wraps over a curved asset
//! and never jumps across a gap (a vertex the surface does not reach keeps
//! an infinite distance). Deterministic: ties are broken by vertex index.

use crate::math::v3;
use crate::mesh::SimMesh;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// A vertex in the queue: smaller distance first, then smaller index.
#[derive(PartialEq)]
struct Item(f64, u32);

impl Eq for Item {}

impl Ord for Item {
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .0
            .total_cmp(&self.0)
            .then_with(|| other.1.cmp(&self.1))
    }
}

impl PartialOrd for Item {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The distance at `c` from a source seen at distances `da` from `a` and
/// `db` from `b`, through the edge `ab` of the triangle `abc`: the source
/// unfolded into the plane of `abc` on the far side of `ab`; `None` when
/// its straight line to `c` does not cross the edge (or the distances
/// cannot come from one point).
fn unfolded(a: [f64; 3], da: f64, b: [f64; 3], db: f64, c: [f64; 3]) -> Option<f64> {
    let ab = v3::sub(b, a);
    let e = v3::norm(ab);
    if e <= 0.0 {
        return None;
    }
    let ac = v3::sub(c, a);
    let cx = v3::dot(ac, ab) / e;
    let cy2 = v3::dot(ac, ac) - cx * cx;
    if cy2 <= 0.0 {
        return None;
    }
    let cy = cy2.sqrt();
    let sx = (da * da - db * db + e * e) / (2.0 * e);
    let sy2 = da * da - sx * sx;
    if sy2 < 0.0 {
        return None;
    }
    let sy = -sy2.sqrt();
    // Where the line from the source to c crosses the edge's line.
    let t = -sy / (cy - sy);
    let x = sx + (cx - sx) * t;
    (0.0..=e)
        .contains(&x)
        .then(|| ((cx - sx).powi(2) + (cy - sy).powi(2)).sqrt())
}

/// Each vertex's distance along the surface from `point`, which lies on
/// (or next to) face `face`: that face's corners start at their straight
/// distance from it.
pub fn distances(mesh: &SimMesh, point: [f64; 3], face: usize) -> Vec<f64> {
    let p = |v: u32| mesh.positions()[v as usize];
    let sources: Vec<(u32, f64)> = mesh
        .faces()
        .nth(face)
        .map(|f| {
            mesh.face_vertices(f)
                .map(|v| (v.0, v3::norm(v3::sub(p(v.0), point))))
                .to_vec()
        })
        .unwrap_or_default();
    distances_from(mesh, &sources)
}

/// Each vertex's distance along the surface from the nearest of `sources`
/// (vertex, its starting distance).
pub fn distances_from(mesh: &SimMesh, sources: &[(u32, f64)]) -> Vec<f64> {
    let n = mesh.n_vertices();
    let p = |v: u32| mesh.positions()[v as usize];
    let mut dist = vec![f64::INFINITY; n];
    let mut done = vec![false; n];
    let mut queue = BinaryHeap::new();
    for &(v, d) in sources {
        if d < dist[v as usize] {
            dist[v as usize] = d;
            queue.push(Item(d, v));
        }
    }
    while let Some(Item(d, v)) = queue.pop() {
        if done[v as usize] || d > dist[v as usize] {
            continue;
        }
        done[v as usize] = true;
        for f in mesh.vertex_faces(crate::mesh::VertexId(v)) {
            let t = mesh.face_vertices(f).map(|v| v.0);
            for k in 0..3 {
                let c = t[k];
                if done[c as usize] {
                    continue;
                }
                let mut best = d + v3::norm(v3::sub(p(c), p(v)));
                // Through the edge from v to the face's third corner, when
                // that corner is final too.
                let o = t[(k + 1) % 3] ^ t[(k + 2) % 3] ^ v;
                if o != v && done[o as usize] {
                    if let Some(u) = unfolded(p(v), d, p(o), dist[o as usize], p(c)) {
                        best = best.min(u);
                    }
                }
                if best < dist[c as usize] {
                    dist[c as usize] = best;
                    queue.push(Item(best, c));
                }
            }
        }
    }
    dist
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_distance_on_a_plane_is_the_straight_one_and_a_gap_is_not_crossed() {
        // A 40 x 40 grid of right triangles and, beside it, a second grid
        // not joined to it.
        let n = 40;
        let mut positions = Vec::new();
        let mut tris = Vec::new();
        for (shift, base) in [(0.0, 0u32), (1.2, ((n + 1) * (n + 1)) as u32)] {
            for j in 0..=n {
                for i in 0..=n {
                    positions.push([shift + i as f64 / n as f64, 0.0, j as f64 / n as f64]);
                }
            }
            let at = |i: usize, j: usize| base + (j * (n + 1) + i) as u32;
            for j in 0..n {
                for i in 0..n {
                    tris.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                    tris.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
        let input = crate::mesh::MeshInput {
            positions: positions.clone(),
            triangles: tris,
            face_groups: vec![],
            wedge_channels: vec![],
        };
        let (mesh, _) = crate::mesh::shapes::build(&input);
        let src = [0.5, 0.0, 0.5];
        let face = mesh
            .faces()
            .position(|f| {
                let c = mesh
                    .face_vertices(f)
                    .map(|v| mesh.position(v))
                    .iter()
                    .fold([0.0; 3], |s, q| v3::add(s, v3::scale(*q, 1.0 / 3.0)));
                (c[0] - 0.5).abs() < 0.02 && (c[2] - 0.5).abs() < 0.02
            })
            .unwrap();
        let d = distances(&mesh, src, face);
        let mut worst: f64 = 0.0;
        for (i, &x) in d.iter().enumerate() {
            let q = mesh.positions()[i];
            if q[0] > 1.1 {
                assert!(x.is_infinite(), "the gap was crossed at {q:?}");
                continue;
            }
            let exact = v3::norm(v3::sub(q, src));
            worst = worst.max((x - exact).abs() / exact.max(0.05));
        }
        // Dijkstra on edges alone is up to 8% long on this grid.
        assert!(worst < 0.02, "relative error {worst}");
    }
}
