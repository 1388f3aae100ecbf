//! `post.split_islands`: every piece the cracks cut a mesh into becomes its
//! own mesh on its own node (a pre-fractured shell for game destruction).
//!
//! For a simulated scene mesh `M`, piece `k` (numbered by its smallest
//! simulation face) gets a mesh `<M>_piece_<k>` with the piece's triangles
//! of every simulated primitive (same materials and attributes, morph
//! targets kept) and the walls hanging on its crack sides. Its vertices are
//! relative to the piece's area-weighted centroid, and every node that
//! showed `M` gets one child node per piece, translated to that centroid,
//! so each piece has its pivot at its middle. Instances share the piece
//! meshes. `M` keeps what is not a piece (the crack lines and primitives
//! that were not simulated); a node whose mesh is left empty loses it, and
//! empty meshes are removed.
//!
//! Skinned meshes keep their vertices where they are (a skinned node's
//! transform is ignored by glTF, so a pivot cannot be moved there): their
//! pieces are not recentred, and carry the node's skin.

use crate::bridge::{primitive_faces, SimEntry};
use crate::post::islands::{centroid, face_islands};
use crate::post::walls::Walls;
use crate::scene::{Geometry, Mesh, Node, Primitive, Scene, Transform, TriGeometry};

/// Makes the wall primitive of some wall triangles, moved by `-offset`.
pub type WallPrimitive<'a> =
    dyn Fn(&mut Scene, &Walls, &[usize], [f64; 3]) -> Option<Primitive> + 'a;

/// What splitting one mesh did.
pub struct Split {
    /// Number of pieces.
    pub pieces: usize,
    /// Whether the pieces' vertices were moved to their centroids.
    pub recentred: bool,
    /// Triangles of the largest piece (surface and walls).
    pub largest: usize,
}

/// Triangles `tris` of `t` (in that order), with only the vertices they
/// use (renumbered in order of first use, through the shared scratch map
/// `new_of`, which is left all `u32::MAX` again), moved by `-offset`.
fn subset(t: &TriGeometry, tris: &[usize], offset: [f64; 3], new_of: &mut Vec<u32>) -> TriGeometry {
    new_of.resize(t.positions.len(), u32::MAX);
    let mut order: Vec<usize> = Vec::new();
    let mut triangles = Vec::new();
    for tri in tris.iter().map(|&k| t.triangles[k]) {
        triangles.push(tri.map(|i| {
            let i = i as usize;
            if new_of[i] == u32::MAX {
                new_of[i] = order.len() as u32;
                order.push(i);
            }
            new_of[i]
        }));
    }
    for &i in &order {
        new_of[i] = u32::MAX;
    }
    let pick = |a: &crate::scene::VertexAttribute| crate::scene::VertexAttribute {
        semantic: a.semantic.clone(),
        components: a.components,
        data: order
            .iter()
            .flat_map(|&i| a.get(i).iter().copied())
            .collect(),
    };
    TriGeometry {
        positions: order
            .iter()
            .map(|&i| {
                let p = t.positions[i];
                std::array::from_fn(|k| (p[k] as f64 - offset[k]) as f32)
            })
            .collect(),
        attributes: t.attributes.iter().map(pick).collect(),
        triangles,
        targets: t
            .targets
            .iter()
            .map(|target| target.iter().map(pick).collect())
            .collect(),
        group: t.group.clone(),
    }
}

/// Split scene mesh `e.mesh_index` (already written back, walls not yet
/// added) into pieces; `walls` is its wall geometry, turned into a
/// primitive per piece by `wall_primitive(walls, triangles, offset)`.
pub fn split(
    scene: &mut Scene,
    e: &SimEntry,
    walls: Option<&Walls>,
    wall_primitive: &WallPrimitive,
) -> Split {
    let mi = e.mesh_index;
    let islands = face_islands(&e.sim);
    let pieces = islands.faces();
    let instances: Vec<usize> = (0..scene.nodes.len())
        .filter(|&i| scene.nodes[i].mesh == Some(mi))
        .collect();
    let recentred = instances.iter().all(|&i| scene.nodes[i].skin.is_none());
    let centres: Vec<[f64; 3]> = pieces
        .iter()
        .map(|faces| {
            if recentred {
                centroid(&e.sim, faces, e.sim.positions())
            } else {
                [0.0; 3]
            }
        })
        .collect();

    let per_prim = primitive_faces(e);
    let base = scene.meshes[mi]
        .name
        .clone()
        .unwrap_or_else(|| format!("mesh{mi}"));
    let old = std::mem::take(&mut scene.meshes[mi].primitives);
    let mut kept: Vec<Primitive> = Vec::new();
    let mut piece_prims: Vec<Vec<Primitive>> = vec![Vec::new(); pieces.len()];
    let mut new_of: Vec<u32> = Vec::new();
    for (pi, prim) in old.into_iter().enumerate() {
        let faces = match (&prim.geometry, per_prim.get(pi)) {
            (Geometry::Triangles(t), Some(Some(faces))) if t.triangles.len() == faces.len() => {
                faces
            }
            _ => {
                kept.push(prim);
                continue;
            }
        };
        let Geometry::Triangles(t) = &prim.geometry else {
            continue;
        };
        // Triangles bucketed by piece in one pass.
        let mut tris_of: Vec<Vec<usize>> = vec![Vec::new(); pieces.len()];
        for (k, f) in faces.iter().enumerate() {
            tris_of[islands.of_face[f.idx()] as usize].push(k);
        }
        for ((prims, tris), centre) in piece_prims.iter_mut().zip(&tris_of).zip(&centres) {
            if tris.is_empty() {
                continue;
            }
            prims.push(Primitive {
                material: prim.material,
                geometry: Geometry::Triangles(subset(t, tris, *centre, &mut new_of)),
                rest: prim.rest.clone(),
            });
        }
    }
    if let Some(w) = walls {
        let mut tris_of: Vec<Vec<usize>> = vec![Vec::new(); pieces.len()];
        for (t, f) in w.side_faces.iter().enumerate() {
            tris_of[islands.of_face[f.idx()] as usize].push(t);
        }
        for (k, tris) in tris_of.iter().enumerate() {
            if let Some(p) = wall_primitive(scene, w, tris, centres[k]) {
                piece_prims[k].push(p);
            }
        }
    }
    scene.meshes[mi].primitives = kept;
    let weights = scene.meshes[mi].weights.clone();
    let mut largest = 0;
    let mut piece_mesh: Vec<Option<usize>> = Vec::new();
    for (k, prims) in piece_prims.into_iter().enumerate() {
        if prims.is_empty() {
            piece_mesh.push(None);
            continue;
        }
        let n: usize = prims
            .iter()
            .map(|p| match &p.geometry {
                Geometry::Triangles(t) => t.triangles.len(),
                Geometry::Raw(_) => 0,
            })
            .sum();
        largest = largest.max(n);
        scene.meshes.push(Mesh {
            name: Some(format!("{base}_piece_{k}")),
            primitives: prims,
            weights: weights.clone(),
            rest: Default::default(),
        });
        piece_mesh.push(Some(scene.meshes.len() - 1));
    }
    let empty = scene.meshes[mi].primitives.is_empty();
    for i in instances {
        let first_child = scene.nodes.len();
        let node_name = scene.nodes[i].name.clone().unwrap_or_else(|| base.clone());
        let (skin, node_weights) = (scene.nodes[i].skin, scene.nodes[i].weights.clone());
        for (k, m) in piece_mesh.iter().enumerate() {
            let Some(m) = *m else { continue };
            let c = centres[k];
            scene.nodes.push(Node {
                name: Some(format!("{node_name}_piece_{k}")),
                transform: Transform::Trs {
                    translation: (c != [0.0; 3]).then_some(c),
                    rotation: None,
                    scale: None,
                },
                mesh: Some(m),
                skin,
                weights: node_weights.clone(),
                ..Default::default()
            });
            let child = scene.nodes.len() - 1;
            scene.nodes[i].children.push(child);
        }
        if empty {
            scene.nodes[i].mesh = None;
            scene.nodes[i].skin = None;
            scene.nodes[i].weights = None;
        }
        let children: Vec<usize> = (first_child..scene.nodes.len()).collect();
        drive_piece_weights(scene, i, &children, empty);
    }
    Split {
        pieces: pieces.len(),
        recentred,
        largest,
    }
}

/// Morph-target weights animated on node `node` drive its piece nodes
/// `pieces` too: every `weights` channel targeting the node gets a copy
/// per piece (sharing its sampler). When the node lost its mesh, its own
/// channel moves to the first piece instead (a weights channel on a node
/// without morph targets is invalid).
fn drive_piece_weights(scene: &mut Scene, node: usize, pieces: &[usize], moved: bool) {
    if pieces.is_empty() {
        return;
    }
    for anim in &mut scene.animations {
        let Some(channels) = anim.get_mut("channels").and_then(|c| c.as_array_mut()) else {
            continue;
        };
        let mut added = Vec::new();
        for ch in channels.iter_mut() {
            let target = &ch["target"];
            if target["path"] != "weights" || target["node"].as_u64() != Some(node as u64) {
                continue;
            }
            let first = usize::from(moved);
            for &p in &pieces[first..] {
                let mut c = ch.clone();
                c["target"]["node"] = serde_json::json!(p);
                added.push(c);
            }
            if moved {
                ch["target"]["node"] = serde_json::json!(pieces[0]);
            }
        }
        channels.extend(added);
    }
}

/// Remove meshes without primitives that no node shows, renumbering the
/// nodes' mesh indices.
pub fn remove_empty_meshes(scene: &mut Scene) {
    let used: Vec<bool> = (0..scene.meshes.len())
        .map(|m| scene.nodes.iter().any(|n| n.mesh == Some(m)))
        .collect();
    let mut new_index = vec![usize::MAX; scene.meshes.len()];
    let mut next = 0;
    for (m, mesh) in scene.meshes.iter().enumerate() {
        if !mesh.primitives.is_empty() || used[m] {
            new_index[m] = next;
            next += 1;
        }
    }
    let mut m = 0;
    scene.meshes.retain(|_| {
        let keep = new_index[m] != usize::MAX;
        m += 1;
        keep
    });
    for n in &mut scene.nodes {
        if let Some(i) = n.mesh {
            n.mesh = Some(new_index[i]);
        }
    }
}
