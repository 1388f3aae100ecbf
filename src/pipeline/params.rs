//! Each mesh's simulation parameters: the pipeline's, with the mesh's
//! fixed groups (`select.fix`) resolved to its primitives.

use super::Pipeline;
use crate::bridge::SimEntry;
use crate::scene::{Geometry, Scene};
use crate::sim::SimParams;
use crate::Result;
use std::path::Path;

/// Each mesh's simulation parameters (its fixed groups from the
/// pipeline's `select.fix`, every name of which must match).
pub(super) fn mesh_params(
    scene: &Scene,
    entries: &[SimEntry],
    pipe: &Pipeline,
    input: &Path,
) -> Result<Vec<SimParams>> {
    let mut matched: Vec<String> = Vec::new();
    let mut params_of = Vec::new();
    for e in entries {
        let (groups, m) = fixed_groups(scene, e.mesh_index, &pipe.select.fix);
        matched.extend(m);
        params_of.push(pipe.params(&groups));
    }
    if let Some(missing) = pipe.select.fix.iter().find(|n| !matched.contains(n)) {
        return Err(crate::error::UsageError::NoFixName {
            name: missing.clone(),
            asset: input.to_path_buf(),
            names: all_names(scene),
        }
        .into());
    }
    Ok(params_of)
}

/// Groups (primitive indices) of mesh `mesh_index` whose material or OBJ
/// group name is in `names`, and the names that matched.
pub fn fixed_groups(scene: &Scene, mesh_index: usize, names: &[String]) -> (Vec<u32>, Vec<String>) {
    let mut groups = Vec::new();
    let mut matched = Vec::new();
    for (pi, p) in scene.meshes[mesh_index].primitives.iter().enumerate() {
        let material = p
            .material
            .and_then(|m| scene.materials.get(m))
            .and_then(|m| m.name());
        let group = match &p.geometry {
            Geometry::Triangles(t) => t.group.as_deref(),
            Geometry::Raw(_) => None,
        };
        for n in names {
            if Some(n.as_str()) == material || Some(n.as_str()) == group {
                groups.push(pi as u32);
                matched.push(n.clone());
            }
        }
    }
    (groups, matched)
}

/// Every material and group name in the scene, for error messages.
fn all_names(scene: &Scene) -> Vec<String> {
    let mut out: Vec<String> = scene
        .materials
        .iter()
        .filter_map(|m| m.name().map(str::to_owned))
        .collect();
    for m in &scene.meshes {
        for p in &m.primitives {
            if let Geometry::Triangles(t) = &p.geometry {
                out.extend(t.group.clone());
            }
        }
    }
    out.sort();
    out.dedup();
    out
}
