//! Attributes a viewer needs that an input may lack, added before any
//! stage so cuts and gaps carry them: smooth normals by angle and the
//! tangents of a normal map.

use crate::scene::{Geometry, Scene};

/// Gives the triangle primitives of mesh `mesh` that have no `NORMAL`s
/// smooth normals by angle (crease at `degrees`; 0 adds none), as a DCC
/// tool shades such an input, smooth across the primitives' shared edges.
/// Run on the output's geometry (before a bake, which draws with them, and
/// after the last stage), never before the simulation: its surface is
/// built from the positions alone. Whether any primitive took normals.
pub(super) fn add_smooth_normals(scene: &mut Scene, mesh: usize, degrees: f64) -> bool {
    if degrees <= 0.0 {
        return false;
    }
    let prims = &mut scene.meshes[mesh].primitives;
    let geos: Vec<&crate::scene::TriGeometry> = prims
        .iter()
        .filter_map(|p| match &p.geometry {
            Geometry::Triangles(t) => Some(t),
            Geometry::Raw(_) => None,
        })
        .collect();
    let with = crate::geometry::normals::with_smooth_normals_together(&geos, degrees);
    let mut with = with.into_iter();
    let mut added = false;
    for p in prims.iter_mut() {
        if let Geometry::Triangles(t) = &mut p.geometry {
            if let Some(Some(w)) = with.next() {
                *t = w;
                added = true;
            }
        }
    }
    added
}

/// Gives every normal-mapped triangle primitive without `TANGENT`s the
/// MikkTSpace tangents of its own triangles, as a viewer would make for the
/// input: the normal map was made for that frame. Remeshing and cutting
/// carry them like any attribute, where tangents made anew on the cracked
/// mesh would turn the map's detail. Not for an output that keeps the
/// input as it is: that one gets no attribute it did not have.
pub(super) fn add_missing_tangents(scene: &mut Scene) {
    let Scene {
        meshes, materials, ..
    } = scene;
    for p in meshes.iter_mut().flat_map(|m| m.primitives.iter_mut()) {
        let Some(set) = p
            .material
            .and_then(|m| materials.get(m))
            .and_then(|m| m.json.get("normalTexture"))
            .map(|n| {
                n.get("texCoord")
                    .and_then(serde_json::Value::as_u64)
                    .unwrap_or(0)
            })
        else {
            continue;
        };
        if let Geometry::Triangles(t) = &mut p.geometry {
            if let Some(with) =
                crate::geometry::tangents::with_generated_tangents(t, &format!("TEXCOORD_{set}"))
            {
                *t = with;
            }
        }
    }
}
