//! One crack event at a failing node (Iben & O'Brien 2009, sec. 4.3): the
//! crack plane through the node, with the separation tensor's eigenvector as
//! its normal, is intersected with the node's fan; each crossing becomes a
//! crack segment, either along an existing edge (snapped below `theta1`) or
//! along a new edge to a vertex inserted on the crossed far edge (which also
//! splits the neighbour across that edge, keeping the mesh conforming). The
//! segments are then opened, duplicating vertices where a fan separates.
//!
//! Directions within `theta2` of an existing crack edge at the node are not
//! cracked again (no back-cracking), and a crack tip cracks forward only.

use crate::math::v3;
use crate::mesh::{FaceId, HalfedgeId, MeshError, SimMesh, VertexId};

/// Geometric rules of cracking.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrackRules {
    /// Snap to an existing edge when the crack direction is within this angle (radians).
    pub theta1: f64,
    /// Do not crack within this angle of an existing crack edge (radians).
    pub theta2: f64,
    /// A new vertex is placed only between this fraction and `1 - min_split`
    /// of the crossed edge; closer to an end, the crack snaps to that end's edge
    /// so no sliver is created.
    pub min_split: f64,
    /// A split is made only when every triangle it creates has at least this
    /// quality (`4 sqrt(3) area / sum of squared edge lengths`, 1 for an
    /// equilateral triangle); otherwise the crack snaps to an existing edge.
    pub min_quality: f64,
}

impl Default for CrackRules {
    fn default() -> Self {
        CrackRules {
            theta1: 15f64.to_radians(),
            theta2: 25f64.to_radians(),
            min_split: 0.15,
            min_quality: 0.1,
        }
    }
}

/// What a crack event changed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CrackEvent {
    /// Crack edges created, as (node, far end) before opening.
    pub segments: Vec<(VertexId, VertexId)>,
    /// Faces split: (parent, child); the child inherits the parent's stress.
    pub split_faces: Vec<(FaceId, FaceId)>,
    /// Vertices inserted on crossed edges.
    pub inserted: Vec<VertexId>,
    /// For each inserted vertex, the ends of the edge it split and whether
    /// that edge was a boundary edge (the mesh's border or an earlier crack).
    pub inserted_on: Vec<(VertexId, VertexId, bool)>,
    /// Vertices duplicated by opening: (new, original).
    pub duplicated: Vec<(VertexId, VertexId)>,
    /// Total length of the crack edges created (mesh units).
    pub length: f64,
}

fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    match (v3::unit(a), v3::unit(b)) {
        (Some(a), Some(b)) => v3::dot(a, b).clamp(-1.0, 1.0).acos(),
        _ => 0.0,
    }
}

/// Directions (unit vectors from the node) of the boundary edges at `v`:
/// crack edges and the mesh's own border alike, so a crack never runs
/// within `theta2` along either.
pub fn crack_directions(mesh: &SimMesh, v: VertexId) -> Vec<[f64; 3]> {
    let pv = mesh.position(v);
    let mut out: Vec<[f64; 3]> = Vec::new();
    for h in mesh.vertex_outgoing(v) {
        // Edge v -> dest(h), and edge prev(h): b -> v. The two sides of an
        // opened crack edge end at the same place (the same vertex, or its
        // duplicate): count the direction once.
        for (e, other) in [(h, mesh.dest(h)), (mesh.prev(h), mesh.origin(mesh.prev(h)))] {
            if mesh.is_boundary_halfedge(e) {
                if let Some(d) = v3::unit(v3::sub(mesh.position(other), pv)) {
                    if out.iter().all(|&x| v3::dot(x, d) < 1.0 - 1e-12) {
                        out.push(d);
                    }
                }
            }
        }
    }
    out
}

/// Triangle quality `4 sqrt(3) A / (l0^2 + l1^2 + l2^2)`: 1 for an
/// equilateral triangle, 0 for a degenerate one.
pub fn triangle_quality(p: [[f64; 3]; 3]) -> f64 {
    let e = [
        v3::sub(p[1], p[0]),
        v3::sub(p[2], p[1]),
        v3::sub(p[0], p[2]),
    ];
    let l2: f64 = e.iter().map(|x| v3::dot(*x, *x)).sum();
    let area = 0.5 * v3::norm(v3::cross(e[0], v3::scale(e[2], -1.0)));
    if l2 > 0.0 {
        4.0 * 3f64.sqrt() * area / l2
    } else {
        0.0
    }
}

/// Worst quality among the triangles that splitting halfedge `far` at `s`
/// would create (in its face and in the neighbour across it).
fn split_quality(mesh: &SimMesh, far: HalfedgeId, s: f64) -> f64 {
    let (a, b) = (mesh.origin(far), mesh.dest(far));
    let (pa, pb) = (mesh.position(a), mesh.position(b));
    let q = v3::add(pa, v3::scale(v3::sub(pb, pa), s));
    let mut worst = f64::INFINITY;
    let mut apexes = vec![mesh.position(mesh.origin(mesh.prev(far)))];
    if let Some(t) = mesh.twin(far) {
        apexes.push(mesh.position(mesh.origin(mesh.prev(t))));
    }
    for c in apexes {
        worst = worst
            .min(triangle_quality([pa, q, c]))
            .min(triangle_quality([q, pb, c]));
    }
    worst
}

/// A crossing of the crack plane with the far edge of a fan face.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    /// Halfedge a -> b (the far edge of the face, seen from the node).
    far: HalfedgeId,
    /// Parameter along a -> b.
    s: f64,
    /// Direction from the node to the crossing point.
    dir: [f64; 3],
}

fn crossings(mesh: &SimMesh, v: VertexId, n: [f64; 3]) -> Vec<Crossing> {
    let pv = mesh.position(v);
    let mut out = Vec::new();
    for h in mesh.vertex_outgoing(v) {
        let far = mesh.next(h);
        let (a, b) = (mesh.origin(far), mesh.dest(far));
        let (pa, pb) = (mesh.position(a), mesh.position(b));
        let sa = v3::dot(n, v3::sub(pa, pv));
        let sb = v3::dot(n, v3::sub(pb, pv));
        // Strict sign change, or the plane through b (a crossing at a is
        // found as the b of the previous face, so each is found once).
        if (sa < 0.0 && sb > 0.0) || (sa > 0.0 && sb < 0.0) || (sb == 0.0 && sa != 0.0) {
            let s = sa / (sa - sb);
            let q = v3::add(pa, v3::scale(v3::sub(pb, pa), s));
            if let Some(dir) = v3::unit(v3::sub(q, pv)) {
                out.push(Crossing { far, s, dir });
            }
        }
    }
    out
}

/// Crack node `v` with crack-plane normal `normal`. Returns what changed
/// (no segment when every direction is already cracked or blocked).
///
/// # Errors
/// Only on a broken mesh invariant (a bug), never for geometry.
pub fn crack_node(
    mesh: &mut SimMesh,
    v: VertexId,
    normal: [f64; 3],
    rules: &CrackRules,
) -> Result<CrackEvent, MeshError> {
    crack_node_avoiding(mesh, v, normal, rules, &|_, _| false)
}

/// [`crack_node`], with `junction(mesh, w)` telling which vertices a new
/// segment should not end on when it can avoid them (where four cracks
/// already meet): there it splits the crossed edge when the split makes no
/// triangle below `min_quality` (even close to the edge's end or within
/// `theta1` of it), or else takes the edge's other end within `theta2`, so
/// no more than four cracks meet at a vertex. With splits off (`theta1`
/// of pi) it snaps, leaves out a segment that would end on such a vertex
/// when the edge's other end will not do, and a node already on a crack
/// branches one new crack off it (a T), none at a junction of three.
///
/// # Errors
/// Only on a broken mesh invariant (a bug), never for geometry.
pub fn crack_node_avoiding(
    mesh: &mut SimMesh,
    v: VertexId,
    normal: [f64; 3],
    rules: &CrackRules,
    junction: &dyn Fn(&SimMesh, VertexId) -> bool,
) -> Result<CrackEvent, MeshError> {
    let mut ev = CrackEvent::default();
    let Some(n) = v3::unit(normal) else {
        return Ok(ev);
    };
    let existing = crack_directions(mesh, v);
    let mut dirs: Vec<Crossing> = crossings(mesh, v, n)
        .into_iter()
        .filter(|c| existing.iter().all(|&d| angle(c.dir, d) > rules.theta2))
        .collect();
    // A crack tip (one crack edge, interior otherwise) cracks forward only:
    // keep the direction most opposite to its crack.
    if existing.len() == 1 {
        let back = existing[0];
        dirs.sort_by(|a, b| v3::dot(a.dir, back).total_cmp(&v3::dot(b.dir, back)));
        dirs.truncate(1);
    }
    // With splits off (cracks snap to edges), a node on a crack already
    // (two or more crack edges) branches one new crack off it, a T: the
    // two sides of the old crack are apart, so a crack across it would be
    // two cracks ending on it, which do not meet at one point (a four-way
    // crossing); a junction of three takes no fourth.
    let snapping = rules.theta1 >= std::f64::consts::PI;
    if snapping && existing.len() >= 2 {
        dirs.truncate(if existing.len() >= 3 { 0 } else { 1 });
    }
    dirs.truncate(2);
    // Targets first (splits keep earlier ids valid), then open the edges.
    let mut targets = Vec::new();
    for want in dirs {
        // Re-find the crossing: earlier splits may have changed the fan.
        let Some(c) = crossings(mesh, v, n)
            .into_iter()
            .min_by(|a, b| angle(a.dir, want.dir).total_cmp(&angle(b.dir, want.dir)))
        else {
            continue;
        };
        let (a, b) = (mesh.origin(c.far), mesh.dest(c.far));
        let pv = mesh.position(v);
        let ang_a = angle(c.dir, v3::sub(mesh.position(a), pv));
        let ang_b = angle(c.dir, v3::sub(mesh.position(b), pv));
        let quality = split_quality(mesh, c.far, c.s);
        let snap = ang_a.min(ang_b) < rules.theta1
            || c.s < rules.min_split
            || c.s > 1.0 - rules.min_split
            || quality < rules.min_quality;
        // The closer edge, and the other one.
        let (near, other, other_angle) = if ang_a <= ang_b {
            (a, b, ang_b)
        } else {
            (b, a, ang_a)
        };
        let crowded = snap && junction(mesh, near);
        let target = if snap && !crowded {
            near
        } else if crowded
            && !(rules.theta1 < std::f64::consts::PI
                && c.s > 0.02
                && c.s < 0.98
                && quality >= rules.min_quality)
        {
            if other_angle < rules.theta2 && !junction(mesh, other) {
                other
            } else if snapping {
                // Neither end of the edge takes another crack and it
                // cannot be split: no crack that way (one more crack at a
                // junction of three is a four-way crossing).
                continue;
            } else {
                near
            }
        } else {
            let border = mesh.twin(c.far).is_none();
            let r = mesh.split_edge(c.far, c.s)?;
            ev.split_faces.extend(r.new_faces.iter().copied());
            ev.inserted.push(r.vertex);
            ev.inserted_on.push((a, b, border));
            r.vertex
        };
        if !targets.contains(&target) {
            targets.push(target);
        }
    }
    for t in targets {
        let Some(h) = mesh
            .find_halfedge(v, t)
            .or_else(|| mesh.find_halfedge(t, v))
        else {
            continue;
        };
        if mesh.twin(h).is_none() {
            continue; // already a boundary or crack edge
        }
        ev.length += v3::norm(v3::sub(mesh.position(t), mesh.position(v)));
        ev.segments.push((v, t));
        let r = mesh.open_edge(h)?;
        ev.duplicated.extend(r.new_vertices);
    }
    Ok(ev)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::jittered_plate;
    use crate::sim::forces::face_points;

    fn node_at(mesh: &SimMesh, x: f64, y: f64) -> VertexId {
        mesh.vertices()
            .find(|&v| {
                let p = mesh.position(v);
                (p[0] - x).abs() < 1e-9 && (p[1] - y).abs() < 1e-9
            })
            .unwrap()
    }

    #[test]
    fn interior_node_cracks_both_ways_and_mesh_stays_valid() {
        let mut mesh = jittered_plate(8, 0.0, 1);
        let area = mesh.total_area();
        let v = node_at(&mesh, 4.0, 4.0);
        // Crack plane normal along x: the crack runs along y through the node.
        let ev = crack_node(&mut mesh, v, [1.0, 0.0, 0.0], &CrackRules::default()).unwrap();
        mesh.validate().unwrap();
        assert_eq!(ev.segments.len(), 2, "{ev:?}");
        for (a, b) in &ev.segments {
            let d = v3::sub(mesh.position(*b), mesh.position(*a));
            assert!(d[0].abs() < 1e-9, "segment should run along y: {d:?}");
        }
        assert!(((mesh.total_area() - area) / area).abs() < 1e-12);
        assert!((ev.length - 2.0).abs() < 1e-9);
        // Cracking the same node the same way again is back-cracking: nothing happens.
        let again = crack_node(&mut mesh, v, [1.0, 0.0, 0.0], &CrackRules::default()).unwrap();
        assert!(again.segments.is_empty(), "{again:?}");
    }

    #[test]
    fn oblique_crack_splits_far_edges_and_preserves_area() {
        let mut mesh = jittered_plate(8, 0.25, 3);
        let area = mesh.total_area();
        let v = mesh
            .vertices()
            .find(|&v| !mesh.is_boundary_vertex(v))
            .unwrap();
        let n = [0.3f64.cos(), 0.3f64.sin(), 0.0];
        let ev = crack_node(&mut mesh, v, n, &CrackRules::default()).unwrap();
        mesh.validate().unwrap();
        assert!(!ev.segments.is_empty());
        assert!(((mesh.total_area() - area) / area).abs() < 1e-12);
        // Every crack segment lies (nearly) in the crack plane or was snapped within theta1.
        for (a, b) in &ev.segments {
            let d = v3::sub(mesh.position(*b), mesh.position(*a));
            let off = v3::dot(d, n).abs() / v3::norm(d);
            assert!(
                off < (15f64.to_radians()).sin() + 0.35,
                "segment far off the plane: {off}"
            );
        }
    }

    #[test]
    fn splits_never_create_triangles_below_min_quality() {
        let rules = CrackRules::default();
        let mut rng = crate::mesh::shapes::Lcg(11);
        let mut mesh = jittered_plate(12, 0.35, 5);
        let area = mesh.total_area();
        let mut splits = 0;
        for _ in 0..300 {
            let v = VertexId((rng.next_f64() * mesh.n_vertices() as f64) as u32);
            let a = rng.next_f64() * std::f64::consts::PI;
            let ev = crack_node(&mut mesh, v, [a.cos(), a.sin(), 0.0], &rules).unwrap();
            // After every edit: a valid mesh with the same area.
            mesh.validate().unwrap();
            assert!(((mesh.total_area() - area) / area).abs() < 1e-12);
            for &(parent, child) in &ev.split_faces {
                splits += 1;
                for f in [parent, child] {
                    let q = triangle_quality(face_points(&mesh, f));
                    assert!(
                        q >= rules.min_quality,
                        "split made face {f:?} of quality {q}"
                    );
                }
            }
        }
        mesh.validate().unwrap();
        assert!(splits > 50, "the test exercised splits: {splits}");
    }

    #[test]
    fn quality_of_known_triangles() {
        let eq = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 3f64.sqrt() / 2.0, 0.0],
        ];
        assert!((triangle_quality(eq) - 1.0).abs() < 1e-12);
        assert_eq!(
            triangle_quality([[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]),
            0.0
        );
    }

    #[test]
    fn crack_tip_cracks_forward_and_cracks_join_into_a_cut() {
        let mut mesh = jittered_plate(6, 0.0, 1);
        let rules = CrackRules::default();
        // Start a crack at (3,3) along y, then keep cracking its tips until the plate is cut.
        let v = node_at(&mesh, 3.0, 3.0);
        crack_node(&mut mesh, v, [1.0, 0.0, 0.0], &rules).unwrap();
        for _ in 0..6 {
            let tips: Vec<VertexId> = mesh
                .vertices()
                .filter(|&t| {
                    let p = mesh.position(t);
                    (p[0] - 3.0).abs() < 1e-9
                        && p[1] > 0.0
                        && p[1] < 6.0
                        && crack_directions(&mesh, t).len() == 1
                })
                .collect();
            for t in tips {
                let ev = crack_node(&mut mesh, t, [1.0, 0.0, 0.0], &rules).unwrap();
                assert!(ev.segments.len() <= 1, "a tip cracks forward only: {ev:?}");
                mesh.validate().unwrap();
            }
        }
        let (components, _) = mesh.connected_components();
        assert_eq!(components, 2, "the crack cuts the plate in two");
    }
}
