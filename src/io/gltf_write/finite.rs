//! The output is finite: a scene whose decoded geometry holds a NaN or an
//! infinity (a wall's texture coordinate past `f32`'s range, a curl of
//! 1e300) is refused before anything is written, naming the mesh, the
//! primitive, the attribute and the vertex; glTF forbids such values.

use crate::scene::{Geometry, Scene, VertexAttribute};

/// The first non-finite value of `scene`'s triangle geometry, described.
pub(super) fn first_non_finite(scene: &Scene) -> Option<String> {
    let bad = |data: &[f32], components: usize| {
        data.iter()
            .position(|x| !x.is_finite())
            .map(|i| (i / components.max(1), data[i]))
    };
    for (m, mesh) in scene.meshes.iter().enumerate() {
        let name = mesh
            .name
            .as_deref()
            .map_or_else(|| format!("mesh {m}"), |n| format!("mesh {m} '{n}'"));
        for (k, p) in mesh.primitives.iter().enumerate() {
            let Geometry::Triangles(t) = &p.geometry else {
                continue;
            };
            let at = |what: &str, hit: Option<(usize, f32)>| {
                hit.map(|(v, x)| {
                    format!(
                        "{name}, primitive {k}: {what} of vertex {v} is {x}, not a finite number"
                    )
                })
            };
            let flat: Vec<f32> = t.positions.iter().flatten().copied().collect();
            if let Some(e) = at("POSITION", bad(&flat, 3)) {
                return Some(e);
            }
            let attr = |a: &VertexAttribute, target: Option<usize>| {
                let what = match target {
                    Some(i) => format!("{} of morph target {i}", a.semantic),
                    None => a.semantic.clone(),
                };
                at(&what, bad(&a.data, a.components))
            };
            for a in &t.attributes {
                if let Some(e) = attr(a, None) {
                    return Some(e);
                }
            }
            for (i, target) in t.targets.iter().enumerate() {
                for a in target {
                    if let Some(e) = attr(a, Some(i)) {
                        return Some(e);
                    }
                }
            }
        }
    }
    None
}
