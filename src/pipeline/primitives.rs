//! The primitives the post stages add to a mesh: its crack walls (or
//! grooves) with their shading, and its crack lines; and the materials
//! they are drawn with.

use crate::post::walls::Walls;
use crate::scene::{
    Geometry, Material, Primitive, RawAccessor, RawGeometry, Scene, TriGeometry, VertexAttribute,
};
use serde_json::{json, Value};
use std::collections::HashMap;

/// Index of the material named `name`, added with `json` when missing.
pub(super) fn material(scene: &mut Scene, name: &str, json: Value) -> usize {
    if let Some(i) = scene.materials.iter().position(|m| m.name() == Some(name)) {
        return i;
    }
    let mut m = json.as_object().cloned().unwrap_or_default();
    m.insert("name".into(), json!(name));
    scene.materials.push(Material { json: m });
    scene.materials.len() - 1
}

/// Morph targets the mesh's primitives have (every primitive of a glTF mesh
/// needs the same number).
pub(super) fn n_targets(scene: &Scene, mesh_index: usize) -> usize {
    scene.meshes[mesh_index]
        .primitives
        .iter()
        .map(|p| match &p.geometry {
            Geometry::Triangles(t) => t.targets.len(),
            Geometry::Raw(r) => r.targets.len(),
        })
        .max()
        .unwrap_or(0)
}

/// Triangles `tris` of the walls as a primitive with their own material
/// `name` (normals and UVs from the wall builder; `targets` zero
/// morph-target displacements), positions moved by `-offset`. `None` for
/// no triangles.
pub(super) fn wall_primitive(
    scene: &mut Scene,
    w: &Walls,
    tris: &[usize],
    offset: [f64; 3],
    name: &str,
    targets: usize,
) -> Option<Primitive> {
    if tris.is_empty() {
        return None;
    }
    let m = material(
        scene,
        name,
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.22, 0.16, 0.11, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}),
    );
    // Wall vertices are not shared between triangles: take each
    // triangle's three.
    let corners = || {
        tris.iter()
            .flat_map(|&t| w.triangles[t])
            .map(|i| i as usize)
    };
    let positions: Vec<[f32; 3]> = corners()
        .map(|i| std::array::from_fn(|k| (w.positions[i][k] - offset[k]) as f32))
        .collect();
    let n = positions.len();
    let geo = TriGeometry {
        positions,
        attributes: vec![
            VertexAttribute {
                semantic: "NORMAL".into(),
                components: 3,
                data: corners()
                    .flat_map(|i| w.normals[i])
                    .map(|x| x as f32)
                    .collect(),
            },
            VertexAttribute {
                semantic: "TEXCOORD_0".into(),
                components: 2,
                data: corners().flat_map(|i| w.uvs[i]).map(|x| x as f32).collect(),
            },
            VertexAttribute {
                semantic: "COLOR_0".into(),
                components: 3,
                data: {
                    let deepest = corners().map(|i| w.uvs[i][1]).fold(0.0f64, f64::max);
                    corners()
                        .flat_map(|i| [wall_shade(w.uvs[i][1], deepest) as f32; 3])
                        .collect()
                },
            },
        ],
        triangles: (0..tris.len() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect(),
        targets: (0..targets)
            .map(|_| {
                vec![VertexAttribute {
                    semantic: "POSITION".into(),
                    components: 3,
                    data: vec![0.0; 3 * n],
                }]
            })
            .collect(),
        group: None,
    };
    Some(Primitive {
        material: Some(m),
        geometry: Geometry::Triangles(geo),
        rest: Default::default(),
    })
}

/// How much light reaches a wall `depth` below its top edge, as a factor
/// on the wall's colour (glTF's `COLOR_0` multiplies the base colour):
/// [`WALL_TOP`] at the top edge (already inside the gap, it sees half the
/// sky), falling toward [`WALL_FLOOR`] at the deepest wall's bottom,
/// fastest near the top (to half of that at a twentieth of the depth), as
/// the sky a crack's side sees narrows; so a gap reads as a shadowed crack,
/// dark inside, not as grout.
fn wall_shade(depth: f64, deepest: f64) -> f64 {
    if deepest.is_nan() || deepest <= 0.0 || !depth.is_finite() {
        return 1.0;
    }
    let t = (depth / deepest).clamp(0.0, 1.0);
    WALL_FLOOR + (WALL_TOP - WALL_FLOOR) * (-4.0 * t.sqrt()).exp()
}

/// The light on a wall's top edge and left at the bottom of the deepest.
const WALL_TOP: f64 = 0.5;
const WALL_FLOOR: f64 = 0.08;

/// Add the crack segments of mesh `mesh_index` as a LINES primitive with the
/// `crack_lines` material; `_CRACK_TIME` gives each line vertex the time
/// its segment formed at, as a fraction of the run (for shaders: grow
/// cracks over time); `_CRACK_REST`, given `rest`, where each line vertex
/// lies on the surface at rest (the lines themselves follow the gaps).
pub(super) fn add_crack_lines(
    scene: &mut Scene,
    mesh_index: usize,
    segments: &[[[f64; 3]; 2]],
    times: &[f64],
    rest: Option<&[[[f64; 3]; 2]]>,
) {
    if segments.is_empty() {
        return;
    }
    let f32_accessor = |scene: &mut Scene, kind: &str, comps: usize, data: Vec<f32>, name: &str| {
        let count = data.len() / comps;
        let (min, max) = crate::io::accessor::f32_bounds(&data, comps);
        scene.accessors.push(RawAccessor {
            component_type: 5126,
            kind: kind.into(),
            normalized: false,
            count,
            min: Some(json!(min)),
            max: Some(json!(max)),
            name: Some(name.into()),
            data: data.iter().flat_map(|x| x.to_le_bytes()).collect(),
        });
        scene.accessors.len() - 1
    };
    // One vertex per distinct end (position, time and rest position as
    // written), in order of first use; the segments index them.
    let timed = times.len() == segments.len();
    let rest = rest.filter(|r| r.len() == segments.len());
    let mut at: HashMap<[u32; 7], u32> = HashMap::new();
    let (mut pos, mut t, mut p_rest) = (Vec::new(), Vec::new(), Vec::new());
    let mut indices: Vec<u32> = Vec::with_capacity(2 * segments.len());
    for (i, s) in segments.iter().enumerate() {
        for (e, p) in s.iter().enumerate() {
            let p = p.map(|x| x as f32);
            let time = if timed { times[i] as f32 } else { 0.0 };
            let r = rest.map_or([0.0; 3], |r| r[i][e].map(|x| x as f32));
            let key = [p[0], p[1], p[2], time, r[0], r[1], r[2]].map(f32::to_bits);
            let next = at.len() as u32;
            let k = *at.entry(key).or_insert(next);
            if k == next {
                pos.extend(p);
                t.push(time);
                p_rest.extend(r);
            }
            indices.push(k);
        }
    }
    let n = pos.len() / 3;
    let acc = f32_accessor(scene, "VEC3", 3, pos, "crack_lines");
    let mut geo = RawGeometry {
        mode: crate::scene::mode::LINES,
        ..Default::default()
    };
    geo.attributes.insert("POSITION".into(), acc);
    if timed {
        let acc = f32_accessor(scene, "SCALAR", 1, t, "crack_time");
        geo.attributes.insert("_CRACK_TIME".into(), acc);
    }
    if rest.is_some() {
        let acc = f32_accessor(scene, "VEC3", 3, p_rest, "crack_rest");
        geo.attributes.insert("_CRACK_REST".into(), acc);
    }
    let (data, component_type) = crate::io::accessor::encode_indices(&indices, n);
    scene.accessors.push(RawAccessor {
        component_type,
        kind: "SCALAR".into(),
        normalized: false,
        count: indices.len(),
        min: None,
        max: None,
        name: Some("crack_lines_indices".into()),
        data,
    });
    geo.indices = Some(scene.accessors.len() - 1);
    for _ in 0..n_targets(scene, mesh_index) {
        let acc = f32_accessor(scene, "VEC3", 3, vec![0.0; 3 * n], "crack_lines_target");
        geo.targets
            .push([("POSITION".to_string(), acc)].into_iter().collect());
    }
    let m = material(
        scene,
        "crack_lines",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.02, 0.02, 0.02, 1.0], "metallicFactor": 0.0}}),
    );
    scene.meshes[mesh_index].primitives.push(Primitive {
        material: Some(m),
        geometry: Geometry::Raw(geo),
        rest: Default::default(),
    });
}
