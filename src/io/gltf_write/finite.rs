//! The output is finite: a scene whose decoded geometry holds a NaN or an
//! infinity (a wall's texture coordinate past `f32`'s range, a curl of
//! 1e300) is refused before anything is written, naming the mesh, the
//! primitive, the attribute and the vertex; glTF forbids such values.

use crate::scene::{Geometry, Scene, VertexAttribute};

/// A value of the scene that is not a finite number, and where it is.
#[derive(Debug, Clone, PartialEq)]
pub struct NonFinite {
    /// The mesh's index.
    pub mesh: usize,
    /// The mesh's name.
    pub name: Option<String>,
    /// The primitive's index in the mesh.
    pub primitive: usize,
    /// The attribute's semantic (`POSITION`, `NORMAL`...).
    pub attribute: String,
    /// The morph target, if the value is one's.
    pub target: Option<usize>,
    /// The vertex.
    pub vertex: usize,
    /// The value.
    pub value: f32,
}

impl std::fmt::Display for NonFinite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "mesh {}", self.mesh)?;
        if let Some(n) = &self.name {
            write!(f, " '{n}'")?;
        }
        write!(f, ", primitive {}: {}", self.primitive, self.attribute)?;
        if let Some(i) = self.target {
            write!(f, " of morph target {i}")?;
        }
        write!(
            f,
            " of vertex {} is {}, not a finite number",
            self.vertex, self.value
        )
    }
}

/// The first non-finite value of `scene`'s triangle geometry.
pub(super) fn first_non_finite(scene: &Scene) -> Option<NonFinite> {
    let bad = |data: &[f32], components: usize| {
        data.iter()
            .position(|x| !x.is_finite())
            .map(|i| (i / components.max(1), data[i]))
    };
    for (m, mesh) in scene.meshes.iter().enumerate() {
        for (k, p) in mesh.primitives.iter().enumerate() {
            let Geometry::Triangles(t) = &p.geometry else {
                continue;
            };
            let at = |attribute: &str, target: Option<usize>, hit: Option<(usize, f32)>| {
                hit.map(|(vertex, value)| NonFinite {
                    mesh: m,
                    name: mesh.name.clone(),
                    primitive: k,
                    attribute: attribute.to_string(),
                    target,
                    vertex,
                    value,
                })
            };
            let flat: Vec<f32> = t.positions.iter().flatten().copied().collect();
            if let Some(e) = at("POSITION", None, bad(&flat, 3)) {
                return Some(e);
            }
            let attr = |a: &VertexAttribute, target: Option<usize>| {
                at(&a.semantic, target, bad(&a.data, a.components))
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
