//! Between the scene and the simulation: each mesh with crackable triangles
//! becomes one welded [`SimMesh`] (all its triangle primitives together, so
//! material and UV seams do not become cracks), and a simulation mesh is
//! written back into the scene's primitives with every corner's own UV,
//! normal and colour.

use crate::mesh::{
    Channel, ChannelKind, DefectReport, MeshInput, SimMesh, VertexId, WedgeId, WeldOptions,
};
use crate::scene::{Geometry, Scene, TriGeometry, VertexAttribute};
use std::collections::HashMap;

/// One simulation mesh made from a scene mesh.
#[derive(Clone, Debug)]
pub struct SimEntry {
    /// Index of the mesh in [`Scene::meshes`].
    pub mesh_index: usize,
    /// A label for messages: `mesh 3 'Wheels'`.
    pub label: String,
    /// The welded simulation mesh (face group = primitive index in the mesh).
    pub sim: SimMesh,
    /// Defects found while building it.
    pub report: DefectReport,
    /// The welded input before remeshing, kept when the cracks are to be
    /// cut into it (`post.output = "input"` with a stage that moves or cuts the surface).
    pub unremeshed: Option<SimMesh>,
    /// The welded input before a margin was grown beyond its border
    /// (`simulation.margin`): the cracks are kept only on it.
    pub unextended: Option<Unextended>,
    /// Its cracks run along edges the simulation surface already has (the
    /// spring model, the snapping variant), so they zig-zag at its
    /// triangles' scale ([`crate::post::paths`]).
    pub along_edges: bool,
    /// Per primitive of the mesh: the attribute semantics and sizes it had.
    layouts: Vec<Option<Vec<(String, usize)>>>,
}

/// A simulation mesh's input before its margin was grown
/// ([`SimEntry::unextended`]).
#[derive(Clone, Debug)]
pub struct Unextended {
    /// The welded input.
    pub input: SimMesh,
    /// Its triangles, for distances to it.
    pub(crate) input_faces: crate::mesh::spatial::Faces,
    /// The strip grown beyond its border, for distances to it.
    pub(crate) strip: crate::mesh::spatial::Faces,
}

/// Why a mesh could not become a simulation mesh (it is left as it was).
#[derive(Clone, Debug)]
pub struct SkippedMesh {
    /// Index of the mesh in [`Scene::meshes`].
    pub mesh_index: usize,
    /// A label for messages.
    pub label: String,
    /// What is wrong.
    pub reason: String,
}

/// A label naming a mesh by index and name.
pub fn mesh_label(scene: &Scene, mesh_index: usize) -> String {
    match scene.meshes.get(mesh_index).and_then(|m| m.name.as_deref()) {
        Some(n) => format!("mesh {mesh_index} '{n}'"),
        None => format!("mesh {mesh_index}"),
    }
}

/// The wedge channel name of morph target `t`'s attribute `semantic`.
fn target_channel(t: usize, semantic: &str) -> String {
    format!("target{t}:{semantic}")
}

fn parse_target_channel(name: &str) -> Option<(usize, &str)> {
    let rest = name.strip_prefix("target")?;
    let (t, sem) = rest.split_once(':')?;
    Some((t.parse().ok()?, sem))
}

fn channel_kind(semantic: &str) -> ChannelKind {
    // Morph target displacements are plain vectors: linear.
    if semantic == "NORMAL" || semantic == "TANGENT" {
        ChannelKind::UnitVector
    } else {
        ChannelKind::Linear
    }
}

/// Build one simulation mesh per scene mesh that has crackable triangles.
/// Meshes that cannot be built (for example, every triangle degenerate) are
/// returned as skipped with the reason; the caller decides whether that is
/// fatal.
pub fn build_sim_meshes(scene: &Scene, options: &WeldOptions) -> (Vec<SimEntry>, Vec<SkippedMesh>) {
    let mut entries = Vec::new();
    let mut skipped = Vec::new();
    for (mi, mesh) in scene.meshes.iter().enumerate() {
        if !mesh.has_triangles() {
            continue;
        }
        let label = mesh_label(scene, mi);
        // The union of attribute channels over the mesh's triangle primitives.
        let mut channels: Vec<(String, usize)> = Vec::new();
        let mut layouts = Vec::with_capacity(mesh.primitives.len());
        for p in &mesh.primitives {
            if let Geometry::Triangles(t) = &p.geometry {
                let lay: Vec<(String, usize)> = t
                    .attributes
                    .iter()
                    .map(|a| (a.semantic.clone(), a.components))
                    .chain(t.targets.iter().enumerate().flat_map(|(ti, tg)| {
                        tg.iter()
                            .map(move |a| (target_channel(ti, &a.semantic), a.components))
                    }))
                    .collect();
                for (s, c) in &lay {
                    match channels.iter_mut().find(|(n, _)| n == s) {
                        Some(ch) => ch.1 = ch.1.max(*c),
                        None => channels.push((s.clone(), *c)),
                    }
                }
                layouts.push(Some(lay));
            } else {
                layouts.push(None);
            }
        }
        let mut input = MeshInput::default();
        let mut data: Vec<Vec<f64>> = vec![Vec::new(); channels.len()];
        for (pi, p) in mesh.primitives.iter().enumerate() {
            let Geometry::Triangles(t) = &p.geometry else {
                continue;
            };
            let offset = input.positions.len() as u32;
            input
                .positions
                .extend(t.positions.iter().map(|p| p.map(f64::from)));
            input
                .triangles
                .extend(t.triangles.iter().map(|tri| tri.map(|i| i + offset)));
            input
                .face_groups
                .extend(std::iter::repeat_n(pi as u32, t.triangles.len()));
            for (ci, (sem, comps)) in channels.iter().enumerate() {
                let src = match parse_target_channel(sem) {
                    Some((ti, tsem)) => t
                        .targets
                        .get(ti)
                        .and_then(|tg| tg.iter().find(|a| a.semantic == tsem)),
                    None => t.attribute(sem),
                };
                for v in 0..t.positions.len() {
                    for k in 0..*comps {
                        let x = src.filter(|a| k < a.components).map(|a| a.get(v)[k] as f64);
                        // Missing 4th tangent/colour component: glTF defaults (w = 1, alpha = 1).
                        data[ci].push(x.unwrap_or(if k == 3 { 1.0 } else { 0.0 }));
                    }
                }
            }
        }
        input.wedge_channels = channels
            .iter()
            .zip(data)
            .map(|((s, c), d)| Channel::new(s.clone(), *c, channel_kind(s), d))
            .collect();
        match SimMesh::build(&input, options) {
            Ok((sim, report)) => entries.push(SimEntry {
                mesh_index: mi,
                label,
                sim,
                report,
                unremeshed: None,
                unextended: None,
                along_edges: false,
                layouts,
            }),
            Err(e) => skipped.push(SkippedMesh {
                mesh_index: mi,
                label,
                reason: e.to_string(),
            }),
        }
    }
    (entries, skipped)
}

/// The primitives of the scene mesh the simulation mesh was built from
/// (the ones [`write_back`] rewrites), in order.
pub fn simulated_primitives(entry: &SimEntry) -> Vec<usize> {
    (0..entry.layouts.len())
        .filter(|&i| entry.layouts[i].is_some())
        .collect()
}

/// The simulation faces behind the triangles [`write_back`] writes into
/// each primitive of the scene mesh, in the order written (`None` for a
/// primitive it leaves alone).
pub fn primitive_faces(entry: &SimEntry) -> Vec<Option<Vec<crate::mesh::FaceId>>> {
    let mut out: Vec<Option<Vec<crate::mesh::FaceId>>> = entry
        .layouts
        .iter()
        .map(|l| l.as_ref().map(|_| Vec::new()))
        .collect();
    for f in entry.sim.faces() {
        if let Some(Some(list)) = out.get_mut(entry.sim.face_group(f) as usize) {
            list.push(f);
        }
    }
    out
}

/// Write a simulation mesh back into its scene mesh: each triangle primitive
/// gets the simulation faces of its group, one output vertex per distinct
/// (vertex, wedge) pair, with the attributes the primitive had.
pub fn write_back(scene: &mut Scene, entry: &SimEntry) {
    write_back_with(scene, entry, &[]);
}

/// As [`write_back`], adding per-vertex scalar attributes (`(semantic,
/// value per simulation vertex)`, e.g. `_CRACK_DISTANCE`) to every
/// primitive written.
pub fn write_back_with(scene: &mut Scene, entry: &SimEntry, extra: &[(String, Vec<f64>)]) {
    let mesh = &mut scene.meshes[entry.mesh_index];
    write_faces_into(mesh, entry, &entry.sim, &|_| true, extra);
}

/// As [`write_back_with`], from `sim` (a mesh of `entry`'s input, e.g. cut
/// and moved) into `mesh` (a copy of `entry`'s scene mesh), writing only the
/// faces `keep` takes.
pub fn write_faces_into(
    mesh: &mut crate::scene::Mesh,
    entry: &SimEntry,
    sim: &SimMesh,
    keep: &dyn Fn(crate::mesh::FaceId) -> bool,
    extra: &[(String, Vec<f64>)],
) {
    let n_prims = entry.layouts.len();
    let mut per_group: Vec<Vec<u32>> = vec![Vec::new(); n_prims];
    for f in sim.faces() {
        let g = sim.face_group(f) as usize;
        if g < n_prims && keep(f) {
            per_group[g].push(f.0);
        }
    }
    let wedges = sim.wedges();
    for (pi, prim) in mesh.primitives.iter_mut().enumerate() {
        let (Geometry::Triangles(t), Some(layout)) = (&mut prim.geometry, &entry.layouts[pi])
        else {
            continue;
        };
        let mut key_to_vertex: HashMap<(VertexId, WedgeId), u32> = HashMap::new();
        let mut out = TriGeometry {
            group: t.group.take(),
            ..Default::default()
        };
        let chans: Vec<(&Channel, usize)> = layout
            .iter()
            .filter_map(|(s, c)| wedges.channel(s).map(|ch| (ch, *c)))
            .collect();
        let mut attrs: Vec<VertexAttribute> = chans
            .iter()
            .map(|(ch, c)| VertexAttribute {
                semantic: ch.name.clone(),
                components: *c,
                data: Vec::new(),
            })
            .collect();
        let mut extra_attrs: Vec<VertexAttribute> = extra
            .iter()
            .map(|(name, _)| VertexAttribute {
                semantic: name.clone(),
                components: 1,
                data: Vec::new(),
            })
            .collect();
        let n_targets = t.targets.len();
        for &f in &per_group[pi] {
            let f = crate::mesh::FaceId(f);
            let vs = sim.face_vertices(f);
            let ws = sim.face_wedges(f);
            let mut tri = [0u32; 3];
            for k in 0..3 {
                let next = out.positions.len() as u32;
                let id = *key_to_vertex.entry((vs[k], ws[k])).or_insert_with(|| {
                    out.positions.push(sim.position(vs[k]).map(|x| x as f32));
                    for ((ch, c), a) in chans.iter().zip(attrs.iter_mut()) {
                        a.data.extend(ch.get(ws[k])[..*c].iter().map(|&x| x as f32));
                    }
                    for ((_, values), a) in extra.iter().zip(extra_attrs.iter_mut()) {
                        a.data
                            .push(values.get(vs[k].idx()).copied().unwrap_or(0.0) as f32);
                    }
                    next
                });
                tri[k] = id;
            }
            out.triangles.push(tri);
        }
        // Split the morph-target channels back out.
        out.targets = vec![Vec::new(); n_targets];
        for mut a in attrs {
            match parse_target_channel(&a.semantic).map(|(ti, s)| (ti, s.to_string())) {
                Some((ti, sem)) if ti < n_targets => {
                    a.semantic = sem;
                    out.targets[ti].push(a);
                }
                _ => out.attributes.push(a),
            }
        }
        out.attributes.extend(extra_attrs);
        *t = out;
    }
}
