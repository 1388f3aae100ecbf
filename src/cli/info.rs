//! `crackle info`: scene summary and per-mesh defect report.

use crate::bridge::{build_sim_meshes, mesh_label};
use crate::mesh::WeldOptions;
use crate::scene::{Geometry, Scene};
use anyhow::Result;
use serde_json::json;
use std::path::Path;

/// Summary of a scene as JSON (used by `info --json` and by `convert --json`).
pub fn scene_summary(scene: &Scene) -> serde_json::Value {
    let (mut crackable, mut passed) = (0, 0);
    for p in scene.meshes.iter().flat_map(|m| &m.primitives) {
        match p.geometry {
            Geometry::Triangles(_) => crackable += 1,
            Geometry::Raw(_) => passed += 1,
        }
    }
    json!({
        "scenes": scene.scenes.len(),
        "nodes": scene.nodes.len(),
        "meshes": scene.meshes.len(),
        "primitives": {"crackable": crackable, "passed_through": passed},
        "triangles": scene.triangle_count(),
        "materials": scene.materials.len(),
        "textures": scene.textures.len(),
        "images": scene.images.len(),
        "cameras": scene.cameras.len(),
        "skins": scene.skins.len(),
        "animations": scene.animations.len(),
        "extensions_used": scene.extensions_used,
    })
}

pub fn run(
    input: &Path,
    as_json: bool,
    weld: &WeldOptions,
    read: &crate::io::ReadOptions,
) -> Result<()> {
    let scene = crate::io::read_with(input, read)?;
    let (entries, skipped) = build_sim_meshes(&scene, weld);
    let instances = |mi: usize| scene.nodes.iter().filter(|n| n.mesh == Some(mi)).count();
    let mut meshes = Vec::new();
    for e in &entries {
        meshes.push(json!({
            "index": e.mesh_index,
            "name": scene.meshes[e.mesh_index].name,
            "instances": instances(e.mesh_index),
            "defects": e.report,
        }));
    }
    for s in &skipped {
        meshes.push(json!({"index": s.mesh_index, "name": scene.meshes[s.mesh_index].name, "error": s.reason}));
    }
    if as_json {
        let mut summary = scene_summary(&scene);
        summary["file"] = input.display().to_string().into();
        summary["simulation_meshes"] = meshes.into();
        summary["warnings"] = scene.warnings.clone().into();
        println!("{}", serde_json::to_string_pretty(&summary)?);
        return Ok(());
    }
    for w in &scene.warnings {
        log::warn!("{}: {w}", input.display());
    }
    let s = scene_summary(&scene);
    println!("{}", input.display());
    println!(
        "  {} nodes, {} meshes ({} crackable primitives, {} passed through), {} triangles",
        s["nodes"],
        s["meshes"],
        s["primitives"]["crackable"],
        s["primitives"]["passed_through"],
        s["triangles"]
    );
    println!(
        "  {} materials, {} textures, {} images, {} cameras, {} skins, {} animations",
        s["materials"], s["textures"], s["images"], s["cameras"], s["skins"], s["animations"]
    );
    for e in &entries {
        let r = &e.report;
        println!(
            "  {} (x{}): {} vertices, {} faces, {} components, {} boundary edges in {} loops",
            e.label,
            instances(e.mesh_index),
            r.vertices,
            r.faces,
            r.components,
            r.boundary_edges,
            r.boundary_loops
        );
        if !r.is_clean() {
            println!(
                "    defects: {} non-manifold edges, {} non-manifold vertices, {} inconsistently oriented edges, {} degenerate triangles dropped, {} duplicate triangles, {} unreferenced vertices",
                r.non_manifold_edges,
                r.non_manifold_vertices,
                r.inconsistent_orientation_edges,
                r.degenerate_triangles_dropped,
                r.duplicate_triangles,
                r.unreferenced_vertices
            );
        }
    }
    for s in &skipped {
        println!(
            "  {}: cannot be simulated: {}",
            mesh_label(&scene, s.mesh_index),
            s.reason
        );
    }
    Ok(())
}
