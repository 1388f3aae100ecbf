//! An output that keeps the input as it is (`post.output = "input"`, nothing
//! moving or cutting the surface): the output has the input's own triangles,
//! vertices and attributes (morph targets, skins and UV layouts untouched);
//! the cracks, simulated on the remeshed surface, are carried onto it. The
//! crack segments are projected onto the input's faces, halved where the
//! input bends away from them (so a baked crack lies on the surface it is
//! drawn on, not a chord's depth above or below it), and
//! the crack attributes are interpolated at each input vertex's closest
//! point of the simulated surface.

use crate::bridge::{simulated_primitives, SimEntry};
use crate::mesh::spatial::{dist2, Faces};
use crate::scene::{Geometry, Scene, VertexAttribute};

/// The input faces the simulation mesh of `entry` was built from, in the
/// mesh's frame.
fn input_faces(scene: &Scene, entry: &SimEntry) -> Faces {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for p in simulated_primitives(entry) {
        if let Geometry::Triangles(t) = &scene.meshes[entry.mesh_index].primitives[p].geometry {
            let base = positions.len() as u32;
            positions.extend(t.positions.iter().map(|q| q.map(f64::from)));
            triangles.extend(t.triangles.iter().map(|tri| tri.map(|i| base + i)));
        }
    }
    Faces::new(positions, triangles)
}

/// Most times a crack segment is halved to follow the input's surface.
const MAX_DEPTH: u32 = 5;

/// `segments` (on the simulated surface) carried onto the input surface of
/// `entry`: their ends moved to their closest input points, and each
/// halved (its middle projected too) while the input's surface lies more
/// than `tolerance` from the piece's middle (0: ends only); `times`
/// follow their segments.
pub(super) fn onto_input(
    scene: &Scene,
    entry: &SimEntry,
    segments: &[[[f64; 3]; 2]],
    times: &[f64],
    tolerance: f64,
) -> (Vec<[[f64; 3]; 2]>, Vec<f64>) {
    let faces = input_faces(scene, entry);
    if faces.is_empty() {
        return (segments.to_vec(), times.to_vec());
    }
    let project = |p: [f64; 3]| faces.closest(p).map_or(p, |(_, _, q)| q);
    let mut out = Vec::with_capacity(segments.len());
    let mut out_times = Vec::with_capacity(segments.len());
    let mut stack: Vec<([f64; 3], [f64; 3], u32)> = Vec::new();
    for (i, [a, b]) in segments.iter().enumerate() {
        let time = times.get(i).copied().unwrap_or(1.0);
        stack.push((project(*a), project(*b), 0));
        while let Some((p, q, depth)) = stack.pop() {
            if tolerance > 0.0 && depth < MAX_DEPTH {
                let mid: [f64; 3] = std::array::from_fn(|c| 0.5 * (p[c] + q[c]));
                let on = project(mid);
                if dist2(mid, on) > tolerance * tolerance {
                    // The second half first on the stack: pieces come out
                    // in order from `a` to `b`.
                    stack.push((on, q, depth + 1));
                    stack.push((p, on, depth + 1));
                    continue;
                }
            }
            out.push([p, q]);
            out_times.push(time);
        }
    }
    (out, out_times)
}

/// Per-vertex scalars of the simulation mesh (`extra`: semantic and value
/// per simulation vertex) added to the input primitives of `entry`, each
/// input vertex taking the value at its closest point of the simulated
/// surface (barycentric mix of the face's corners).
pub(super) fn add_attributes(scene: &mut Scene, entry: &SimEntry, extra: &[(String, Vec<f64>)]) {
    if extra.is_empty() {
        return;
    }
    let sim = &entry.sim;
    let mut corners: Vec<[usize; 3]> = Vec::new();
    for f in sim.faces() {
        corners.push(sim.face_vertices(f).map(|v| v.idx()));
    }
    let positions: Vec<[f64; 3]> = sim.positions().to_vec();
    let triangles: Vec<[u32; 3]> = corners.iter().map(|c| c.map(|i| i as u32)).collect();
    let faces = Faces::new(positions, triangles);
    for p in simulated_primitives(entry) {
        let Geometry::Triangles(t) = &mut scene.meshes[entry.mesh_index].primitives[p].geometry
        else {
            continue;
        };
        let hits: Vec<Option<(usize, [f64; 3])>> = t
            .positions
            .iter()
            .map(|q| faces.closest(q.map(f64::from)).map(|(f, b, _)| (f, b)))
            .collect();
        for (name, values) in extra {
            let data = hits
                .iter()
                .map(|hit| {
                    hit.map_or(0.0, |(f, b)| {
                        (0..3)
                            .map(|k| b[k] * values.get(corners[f][k]).copied().unwrap_or(0.0))
                            .sum::<f64>() as f32
                    })
                })
                .collect();
            t.attributes.retain(|a| &a.semantic != name);
            t.attributes.push(VertexAttribute {
                semantic: name.clone(),
                components: 1,
                data,
            });
        }
    }
}
