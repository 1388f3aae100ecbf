//! The glTF document of a scene: the items its output uses, renumbered,
//! as JSON, with the binary buffer of their accessors and the image files
//! a `.gltf` names.

use super::names::{sanitize_file_name, unique_name, uri_encode};
use super::refs::{
    as_idx, remap, set_idx, visit_image_refs, visit_texture_refs, visit_variant_material_refs,
};
use super::Document;
use crate::io::accessor::{f32_bounds, vector_type};
use crate::io::gltf_read::{mime_from_extension, sniff_mime};
use crate::scene::{
    Geometry, ImageSource, Node, Primitive, RawAccessor, RawGeometry, Scene, Transform, TriGeometry,
};
use serde_json::{json, Map, Value};
use std::collections::{BTreeMap, BTreeSet};

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

#[derive(Default)]
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, bytes: &[u8], target: Option<u32>, stride: Option<usize>) -> usize {
        while self.data.len() % 4 != 0 {
            self.data.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = t.into();
        }
        if let Some(s) = stride {
            v["byteStride"] = s.into();
        }
        self.data.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn floats(
        &mut self,
        data: &[f32],
        components: usize,
        with_bounds: bool,
        target: Option<u32>,
    ) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        // Vertex attributes in an ARRAY_BUFFER view must be 4-byte aligned; they are.
        let view = self.view(&bytes, target, None);
        let count = data.len() / components;
        let mut a = json!({"bufferView": view, "componentType": 5126, "count": count, "type": vector_type(components)});
        if with_bounds {
            let (min, max) = f32_bounds(data, components);
            a["min"] = min.into_iter().map(|x| x as f64).collect::<Vec<_>>().into();
            a["max"] = max.into_iter().map(|x| x as f64).collect::<Vec<_>>().into();
        }
        self.accessor(a)
    }

    fn raw(&mut self, r: &RawAccessor, target: Option<u32>) -> usize {
        let stride = if target == Some(ARRAY_BUFFER) {
            // Vertex attribute elements must start on 4-byte boundaries.
            let es = r.data.len() / r.count.max(1);
            if es % 4 != 0 {
                let padded = es.div_ceil(4) * 4;
                let mut bytes = Vec::with_capacity(padded * r.count);
                for e in r.data.chunks_exact(es) {
                    bytes.extend_from_slice(e);
                    bytes.resize(bytes.len() + padded - es, 0);
                }
                let view = self.view(&bytes, target, Some(padded));
                return self.raw_accessor_json(r, view);
            }
            None
        } else {
            None
        };
        let view = self.view(&r.data, target, stride);
        self.raw_accessor_json(r, view)
    }

    fn raw_accessor_json(&mut self, r: &RawAccessor, view: usize) -> usize {
        let mut a = json!({"bufferView": view, "componentType": r.component_type, "count": r.count, "type": r.kind});
        if r.normalized {
            a["normalized"] = true.into();
        }
        if let Some(m) = &r.min {
            a["min"] = m.clone();
        }
        if let Some(m) = &r.max {
            a["max"] = m.clone();
        }
        if let Some(n) = &r.name {
            a["name"] = n.clone().into();
        }
        self.accessor(a)
    }
}

fn tri_is_empty(p: &crate::scene::Primitive) -> bool {
    matches!(&p.geometry, Geometry::Triangles(t) if t.triangles.is_empty())
}

/// The items of a scene an output writes: the meshes a node draws (with a
/// triangle), their materials, those materials' textures, the textures'
/// images and samplers, and the nodes' cameras and skins.
struct Used {
    meshes: BTreeSet<usize>,
    materials: BTreeSet<usize>,
    textures: BTreeSet<usize>,
    images: BTreeSet<usize>,
    samplers: BTreeSet<usize>,
    cameras: BTreeSet<usize>,
    skins: BTreeSet<usize>,
}

impl Used {
    /// The items of `scene` its output writes.
    fn of(scene: &Scene) -> Used {
        let mesh_used: BTreeSet<usize> = scene
            .nodes
            .iter()
            .filter_map(|n| n.mesh)
            .filter(|&m| {
                scene
                    .meshes
                    .get(m)
                    .is_some_and(|m| m.primitives.iter().any(|p| !tri_is_empty(p)))
            })
            .collect();
        let mut mat_used = BTreeSet::new();
        for &m in &mesh_used {
            for p in &scene.meshes[m].primitives {
                if tri_is_empty(p) {
                    continue;
                }
                if let Some(mat) = p.material {
                    mat_used.insert(mat);
                }
                let mut rest = p.rest.clone();
                visit_variant_material_refs(&mut rest, &mut |v| {
                    if let Some(i) = as_idx(v) {
                        mat_used.insert(i);
                    }
                });
            }
        }
        mat_used.retain(|&m| m < scene.materials.len());
        let mut tex_used = BTreeSet::new();
        for &m in &mat_used {
            let mut j = Value::Object(scene.materials[m].json.clone());
            visit_texture_refs(&mut j, &mut |v| {
                if let Some(i) = as_idx(v) {
                    tex_used.insert(i);
                }
            });
        }
        tex_used.retain(|&t| t < scene.textures.len());
        let mut img_used = BTreeSet::new();
        let mut sampler_used = BTreeSet::new();
        for &t in &tex_used {
            let mut tj = scene.textures[t].clone();
            visit_image_refs(&mut tj, &mut |v| {
                if let Some(i) = as_idx(v) {
                    img_used.insert(i);
                }
            });
            if let Some(s) = tj.get("sampler").and_then(as_idx) {
                sampler_used.insert(s);
            }
        }
        img_used.retain(|&i| i < scene.images.len());
        sampler_used.retain(|&s| s < scene.samplers.len());
        let camera_used: BTreeSet<usize> = scene
            .nodes
            .iter()
            .filter_map(|n| n.camera)
            .filter(|&c| c < scene.cameras.len())
            .collect();
        let skin_used: BTreeSet<usize> = scene
            .nodes
            .iter()
            .filter_map(|n| n.skin)
            .filter(|&s| s < scene.skins.len())
            .collect();
        Used {
            meshes: mesh_used,
            materials: mat_used,
            textures: tex_used,
            images: img_used,
            samplers: sampler_used,
            cameras: camera_used,
            skins: skin_used,
        }
    }
}

/// Old index -> new index of each kind of item an output writes.
struct Maps {
    mesh: BTreeMap<usize, usize>,
    material: BTreeMap<usize, usize>,
    texture: BTreeMap<usize, usize>,
    image: BTreeMap<usize, usize>,
    sampler: BTreeMap<usize, usize>,
    camera: BTreeMap<usize, usize>,
    skin: BTreeMap<usize, usize>,
}

impl Maps {
    /// The new indices of the `used` items, in their original order.
    fn of(used: &Used) -> Maps {
        Maps {
            mesh: remap(&used.meshes),
            material: remap(&used.materials),
            texture: remap(&used.textures),
            image: remap(&used.images),
            sampler: remap(&used.samplers),
            camera: remap(&used.cameras),
            skin: remap(&used.skins),
        }
    }
}

/// The binary buffer being written, and what writing it tells the document.
struct Writer<'a> {
    scene: &'a Scene,
    bin: Bin,
    /// (Accessor of the scene, target) -> the accessor written for it.
    raw_written: BTreeMap<(usize, Option<u32>), usize>,
    /// Whether a core attribute was written with a non-float type.
    needs_quantization: bool,
    /// Triangles written.
    triangles: usize,
}

impl Writer<'_> {
    /// Write the scene's accessor `i` for `target` (once: again, the same
    /// accessor) and return its index in the output.
    fn raw(&mut self, i: usize, target: Option<u32>) -> std::result::Result<usize, DocumentError> {
        if let Some(&a) = self.raw_written.get(&(i, target)) {
            return Ok(a);
        }
        let r = self
            .scene
            .accessors
            .get(i)
            .ok_or(DocumentError::NoAccessor(i))?;
        let a = self.bin.raw(r, target);
        self.raw_written.insert((i, target), a);
        Ok(a)
    }

    /// The `used` meshes as JSON, their primitives' accessors written.
    fn meshes(
        &mut self,
        used: &BTreeSet<usize>,
        mat_map: &BTreeMap<usize, usize>,
    ) -> std::result::Result<Vec<Value>, DocumentError> {
        let scene = self.scene;
        let mut meshes_json = Vec::new();
        for &mi in used {
            let m = &scene.meshes[mi];
            let mut prims = Vec::new();
            for p in &m.primitives {
                if let Some(pj) = self.primitive(p, mat_map)? {
                    prims.push(pj);
                }
            }
            let mut mj = Map::new();
            if let Some(n) = &m.name {
                mj.insert("name".into(), n.clone().into());
            }
            mj.insert("primitives".into(), prims.into());
            if let Some(w) = &m.weights {
                mj.insert("weights".into(), json!(w));
            }
            mj.extend(m.rest.clone());
            meshes_json.push(Value::Object(mj));
        }
        Ok(meshes_json)
    }

    /// One primitive as JSON, its accessors written; `None` for an empty
    /// triangle list (left out).
    fn primitive(
        &mut self,
        p: &Primitive,
        mat_map: &BTreeMap<usize, usize>,
    ) -> std::result::Result<Option<Value>, DocumentError> {
        let mut pj = Map::new();
        match &p.geometry {
            Geometry::Triangles(t) => {
                if t.triangles.is_empty() {
                    return Ok(None);
                }
                self.triangles += t.triangles.len();
                let (attrs, indices, targets) = write_triangles(&mut self.bin, t)?;
                pj.insert("attributes".into(), Value::Object(attrs));
                pj.insert("indices".into(), indices.into());
                if !targets.is_empty() {
                    pj.insert("targets".into(), targets.into());
                }
            }
            Geometry::Raw(r) => self.raw_geometry(r, &mut pj)?,
        }
        if let Some(mat) = p.material.and_then(|m| mat_map.get(&m)) {
            pj.insert("material".into(), (*mat).into());
        }
        let mut rest = p.rest.clone();
        visit_variant_material_refs(&mut rest, &mut |v| set_idx(v, mat_map));
        pj.extend(rest);
        Ok(Some(Value::Object(pj)))
    }

    /// A passed-through geometry's attributes, indices, mode and morph
    /// targets into the primitive `pj`, their accessors copied.
    fn raw_geometry(
        &mut self,
        r: &RawGeometry,
        pj: &mut Map<String, Value>,
    ) -> std::result::Result<(), DocumentError> {
        let scene = self.scene;
        let mut attrs = Map::new();
        for (k, &a) in &r.attributes {
            let acc = &scene.accessors[a];
            let core =
                k == "POSITION" || k == "NORMAL" || k == "TANGENT" || k.starts_with("TEXCOORD_");
            if core && acc.component_type != 5126 {
                self.needs_quantization = true;
            }
            attrs.insert(k.clone(), self.raw(a, Some(ARRAY_BUFFER))?.into());
        }
        pj.insert("attributes".into(), Value::Object(attrs));
        if let Some(i) = r.indices {
            pj.insert(
                "indices".into(),
                self.raw(i, Some(ELEMENT_ARRAY_BUFFER))?.into(),
            );
        }
        if r.mode != crate::scene::mode::TRIANGLES {
            pj.insert("mode".into(), r.mode.into());
        }
        if !r.targets.is_empty() {
            let mut targets = Vec::new();
            for t in &r.targets {
                let mut tj = Map::new();
                for (k, &a) in t {
                    if scene.accessors[a].component_type != 5126 {
                        self.needs_quantization = true;
                    }
                    tj.insert(k.clone(), self.raw(a, Some(ARRAY_BUFFER))?.into());
                }
                targets.push(Value::Object(tj));
            }
            pj.insert("targets".into(), targets.into());
        }
        Ok(())
    }

    /// The `used` skins as JSON, their inverse bind matrices copied.
    fn skins(&mut self, used: &BTreeSet<usize>) -> std::result::Result<Vec<Value>, DocumentError> {
        let scene = self.scene;
        let mut skins_json = Vec::new();
        for &s in used {
            let mut sj = scene.skins[s].clone();
            if let Some(a) = sj.get("inverseBindMatrices").and_then(as_idx) {
                sj["inverseBindMatrices"] = self.raw(a, None)?.into();
            }
            skins_json.push(sj);
        }
        Ok(skins_json)
    }

    /// The scene's animations as JSON, their samplers' accessors copied.
    fn animations(&mut self) -> std::result::Result<Vec<Value>, DocumentError> {
        let scene = self.scene;
        let mut anims_json = Vec::new();
        for a in &scene.animations {
            let mut aj = a.clone();
            if let Some(samplers) = aj.get_mut("samplers").and_then(Value::as_array_mut) {
                for s in samplers {
                    for key in ["input", "output"] {
                        if let Some(x) = s.get(key).and_then(as_idx) {
                            s[key] = self.raw(x, None)?.into();
                        }
                    }
                }
            }
            anims_json.push(aj);
        }
        Ok(anims_json)
    }

    /// The `used` images as JSON: embedded in the buffer (`glb`), else
    /// named files beside the output, returned with their bytes.
    fn images(
        &mut self,
        used: &BTreeSet<usize>,
        glb: bool,
        stem: &str,
        prefix_images: bool,
    ) -> std::result::Result<Images, DocumentError> {
        let scene = self.scene;
        let mut images_json = Vec::new();
        let mut image_files = Vec::new();
        let mut taken_names: BTreeSet<String> = [format!("{stem}.bin").to_lowercase()].into();
        for &i in used {
            let img = &scene.images[i];
            let bytes = match &img.source {
                ImageSource::Bytes(b) => b.clone(),
                ImageSource::File(p) => {
                    crate::io::paths::read_capped(p, crate::io::paths::MAX_IMAGE_BYTES, "image")
                        .map_err(|error| DocumentError::ImageRead {
                            image: i,
                            file: p.clone(),
                            error,
                        })?
                }
            };
            let mime = img
                .mime_type
                .clone()
                .or_else(|| sniff_mime(&bytes).map(str::to_string))
                .or_else(|| match &img.source {
                    ImageSource::File(p) => mime_from_extension(p).map(str::to_string),
                    _ => None,
                });
            let mut ij = Map::new();
            if let Some(n) = &img.name {
                ij.insert("name".into(), n.clone().into());
            }
            if glb {
                let mime = mime.ok_or(DocumentError::ImageType(i))?;
                let view = self.bin.view(&bytes, None, None);
                ij.insert("bufferView".into(), view.into());
                ij.insert("mimeType".into(), mime.into());
            } else {
                let base = sanitize_file_name(&img.file_name);
                let base = if prefix_images {
                    format!("{stem}_{base}")
                } else {
                    base
                };
                let name = unique_name(&base, &mut taken_names);
                ij.insert("uri".into(), uri_encode(&name).into());
                image_files.push((name, bytes));
            }
            ij.extend(img.rest.clone());
            images_json.push(Value::Object(ij));
        }
        Ok((images_json, image_files))
    }
}

/// Why a scene's output document cannot be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DocumentError {
    /// A primitive names an accessor the scene does not have (a bug).
    #[error("internal: accessor {0} missing")]
    NoAccessor(usize),
    /// A triangle names a vertex the geometry does not have (a bug).
    #[error("internal: triangle index {index} out of range ({vertices} vertices)")]
    TriangleIndex {
        /// The index.
        index: usize,
        /// The geometry's vertices.
        vertices: usize,
    },
    /// An image file cannot be read.
    #[error("image {image}: cannot read '{}': {error}", file.display())]
    ImageRead {
        /// The image.
        image: usize,
        /// Its file.
        file: std::path::PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// An image of unknown type, which a GLB cannot embed.
    #[error("image {0}: unknown image type, cannot embed it in a GLB")]
    ImageType(usize),
}

/// The images' JSON and the image files to write beside a `.gltf`.
type Images = (Vec<Value>, Vec<(String, Vec<u8>)>);

/// The document of `scene`'s output (`glb`: images in the buffer, else
/// files named after `stem`, prefixed with it with `prefix_images`).
pub(super) fn build_document(
    scene: &Scene,
    glb: bool,
    stem: &str,
    prefix_images: bool,
) -> std::result::Result<Document, DocumentError> {
    // ---- what is used
    let used = Used::of(scene);
    let maps = Maps::of(&used);
    let mut w = Writer {
        scene,
        bin: Bin::default(),
        raw_written: BTreeMap::new(),
        needs_quantization: false,
        triangles: 0,
    };
    // ---- meshes
    let meshes_json = w.meshes(&used.meshes, &maps.material)?;
    // ---- nodes (all kept: the hierarchy is the user's)
    let nodes_json: Vec<Value> = scene.nodes.iter().map(|n| node_json(n, &maps)).collect();
    // ---- skins and animations (accessors copied)
    let skins_json = w.skins(&used.skins)?;
    let anims_json = w.animations()?;
    // ---- materials, textures, samplers, images
    let materials_json = materials_json(scene, &used.materials, &maps.texture);
    let textures_json = textures_json(scene, &used.textures, &maps);
    let samplers_json: Vec<Value> = used
        .samplers
        .iter()
        .map(|&s| scene.samplers[s].clone())
        .collect();
    let (images_json, image_files) = w.images(&used.images, glb, stem, prefix_images)?;
    // ---- scenes
    let scenes_json = scenes_json(scene);

    // ---- root
    let mut root = Map::new();
    let mut asset =
        json!({"version": "2.0", "generator": concat!("crackle ", env!("CARGO_PKG_VERSION"))});
    if let Some(c) = &scene.copyright {
        asset["copyright"] = c.clone().into();
    }
    root.insert("asset".into(), asset);
    if !scenes_json.is_empty() {
        root.insert(
            "scene".into(),
            scene
                .default_scene
                .unwrap_or(0)
                .min(scenes_json.len() - 1)
                .into(),
        );
        root.insert("scenes".into(), scenes_json.into());
    }
    let mut bin = w.bin;
    let arrays: [(&str, Vec<Value>); 10] = [
        ("nodes", nodes_json),
        ("meshes", meshes_json),
        ("materials", materials_json),
        ("textures", textures_json),
        ("samplers", samplers_json),
        ("images", images_json),
        (
            "cameras",
            used.cameras
                .iter()
                .map(|&c| scene.cameras[c].clone())
                .collect(),
        ),
        ("skins", skins_json),
        ("animations", anims_json),
        ("accessors", std::mem::take(&mut bin.accessors)),
    ];
    for (k, v) in arrays {
        if !v.is_empty() {
            root.insert(k.into(), v.into());
        }
    }
    if !bin.views.is_empty() {
        root.insert("bufferViews".into(), std::mem::take(&mut bin.views).into());
        while bin.data.len() % 4 != 0 {
            bin.data.push(0);
        }
        let mut b = json!({"byteLength": bin.data.len()});
        if !glb {
            b["uri"] = uri_encode(&format!("{stem}.bin")).into();
        }
        root.insert("buffers".into(), json!([b]));
    }
    if let Some(e) = &scene.extensions {
        if !e.is_empty() {
            root.insert("extensions".into(), Value::Object(e.clone()));
        }
    }
    if let Some(x) = &scene.extras {
        root.insert("extras".into(), x.clone());
    }
    insert_extension_lists(&mut root, scene, w.needs_quantization);
    Ok(Document {
        json: Value::Object(root),
        bin: bin.data,
        bin_name: format!("{stem}.bin"),
        image_files,
        triangles: w.triangles,
    })
}

/// One node as JSON, its mesh, camera and skin renumbered (a skin only
/// with a mesh written).
fn node_json(n: &Node, maps: &Maps) -> Value {
    let mut nj = Map::new();
    if let Some(name) = &n.name {
        nj.insert("name".into(), name.clone().into());
    }
    if !n.children.is_empty() {
        nj.insert("children".into(), json!(n.children));
    }
    match &n.transform {
        Transform::Matrix(m) => {
            if *m != IDENTITY {
                nj.insert("matrix".into(), json!(m));
            }
        }
        Transform::Trs {
            translation,
            rotation,
            scale,
        } => {
            if let Some(t) = translation {
                nj.insert("translation".into(), json!(t));
            }
            if let Some(r) = rotation {
                nj.insert("rotation".into(), json!(r));
            }
            if let Some(s) = scale {
                nj.insert("scale".into(), json!(s));
            }
        }
    }
    if let Some(m) = n.mesh.and_then(|m| maps.mesh.get(&m)) {
        nj.insert("mesh".into(), (*m).into());
        if let Some(w) = &n.weights {
            nj.insert("weights".into(), json!(w));
        }
    }
    if let Some(c) = n.camera.and_then(|c| maps.camera.get(&c)) {
        nj.insert("camera".into(), (*c).into());
    }
    if let Some(s) = n.skin.and_then(|s| maps.skin.get(&s)) {
        if n.mesh.is_some_and(|m| maps.mesh.contains_key(&m)) {
            nj.insert("skin".into(), (*s).into());
        }
    }
    nj.extend(n.rest.clone());
    Value::Object(nj)
}

/// The `used` materials as JSON, their texture references renumbered.
fn materials_json(
    scene: &Scene,
    used: &BTreeSet<usize>,
    tex_map: &BTreeMap<usize, usize>,
) -> Vec<Value> {
    used.iter()
        .map(|&m| {
            let mut j = Value::Object(scene.materials[m].json.clone());
            visit_texture_refs(&mut j, &mut |v| set_idx(v, tex_map));
            j
        })
        .collect()
}

/// The `used` textures as JSON, their images and samplers renumbered (a
/// sampler not written is left out).
fn textures_json(scene: &Scene, used: &BTreeSet<usize>, maps: &Maps) -> Vec<Value> {
    used.iter()
        .map(|&t| {
            let mut j = scene.textures[t].clone();
            visit_image_refs(&mut j, &mut |v| set_idx(v, &maps.image));
            if let Some(s) = j.get_mut("sampler") {
                if as_idx(s).is_some_and(|i| maps.sampler.contains_key(&i)) {
                    set_idx(s, &maps.sampler);
                } else if let Some(o) = j.as_object_mut() {
                    o.remove("sampler");
                }
            }
            j
        })
        .collect()
}

/// The scene's scenes (root node lists) as JSON.
fn scenes_json(scene: &Scene) -> Vec<Value> {
    scene
        .scenes
        .iter()
        .map(|s| {
            let mut sj = Map::new();
            if let Some(n) = &s.name {
                sj.insert("name".into(), n.clone().into());
            }
            sj.insert("nodes".into(), json!(s.nodes));
            sj.extend(s.rest.clone());
            Value::Object(sj)
        })
        .collect()
}

/// `extensionsUsed` (exactly those present in `root`, the input's order
/// first) and `extensionsRequired` (those of the input still used) into
/// `root`.
fn insert_extension_lists(root: &mut Map<String, Value>, scene: &Scene, needs_quantization: bool) {
    // extensionsUsed: exactly those present in the output.
    let mut used = BTreeSet::new();
    collect_extension_names(&Value::Object(root.clone()), &mut used);
    if needs_quantization {
        used.insert("KHR_mesh_quantization".to_string());
    }
    // Keep the input's order first, then any new ones.
    let mut used_list: Vec<String> = scene
        .extensions_used
        .iter()
        .filter(|e| used.contains(*e))
        .cloned()
        .collect();
    for e in &used {
        if !used_list.contains(e) {
            used_list.push(e.clone());
        }
    }
    let required: Vec<String> = scene
        .extensions_required
        .iter()
        .filter(|e| {
            used.contains(*e) && (e.as_str() != "KHR_mesh_quantization" || needs_quantization)
        })
        .cloned()
        .collect();
    if !used_list.is_empty() {
        root.insert("extensionsUsed".into(), json!(used_list));
    }
    if !required.is_empty() {
        root.insert("extensionsRequired".into(), json!(required));
    }
}

const IDENTITY: [f64; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

fn collect_extension_names(v: &Value, out: &mut BTreeSet<String>) {
    match v {
        Value::Object(o) => {
            for (k, c) in o {
                if k == "extras" {
                    continue;
                }
                if k == "extensions" {
                    if let Some(e) = c.as_object() {
                        out.extend(e.keys().cloned());
                    }
                }
                collect_extension_names(c, out);
            }
        }
        Value::Array(a) => a.iter().for_each(|c| collect_extension_names(c, out)),
        _ => {}
    }
}

/// Attributes object, index accessor and morph targets of a written primitive.
type WrittenTriangles = (Map<String, Value>, usize, Vec<Value>);

/// Write one triangle geometry: only referenced vertices, float attributes,
/// u16 or u32 indices. Returns the attributes object, the index accessor and the morph targets.
fn write_triangles(
    bin: &mut Bin,
    t: &TriGeometry,
) -> std::result::Result<WrittenTriangles, DocumentError> {
    let n = t.positions.len();
    // Vertices keep their order (an unused one is left out): an output
    // that keeps the input's mesh keeps its vertex order and indices.
    let mut used = vec![false; n];
    for tri in &t.triangles {
        for &v in tri {
            let v = v as usize;
            if v >= n {
                return Err(DocumentError::TriangleIndex {
                    index: v,
                    vertices: n,
                });
            }
            used[v] = true;
        }
    }
    let mut remap = vec![u32::MAX; n];
    let mut order = Vec::with_capacity(n);
    for (v, _) in used.iter().enumerate().filter(|(_, &u)| u) {
        remap[v] = order.len() as u32;
        order.push(v);
    }
    let indices: Vec<u32> = t
        .triangles
        .iter()
        .flat_map(|tri| tri.map(|v| remap[v as usize]))
        .collect();
    let mut attrs = Map::new();
    let pos: Vec<f32> = order.iter().flat_map(|&v| t.positions[v]).collect();
    attrs.insert(
        "POSITION".into(),
        bin.floats(&pos, 3, true, Some(ARRAY_BUFFER)).into(),
    );
    for a in &t.attributes {
        let c = a.components;
        let data: Vec<f32> = order
            .iter()
            .flat_map(|&v| a.get(v).iter().copied())
            .collect();
        attrs.insert(
            a.semantic.clone(),
            bin.floats(&data, c, false, Some(ARRAY_BUFFER)).into(),
        );
    }
    let mut targets = Vec::new();
    for target in &t.targets {
        let mut tj = Map::new();
        for a in target {
            let c = a.components;
            let data: Vec<f32> = order
                .iter()
                .flat_map(|&v| a.get(v).iter().copied())
                .collect();
            let bounds = a.semantic == "POSITION";
            tj.insert(
                a.semantic.clone(),
                bin.floats(&data, c, bounds, Some(ARRAY_BUFFER)).into(),
            );
        }
        targets.push(Value::Object(tj));
    }
    let (bytes, ct) = crate::io::accessor::encode_indices(&indices, order.len());
    let view = bin.view(&bytes, Some(ELEMENT_ARRAY_BUFFER), None);
    let acc = bin.accessor(
        json!({"bufferView": view, "componentType": ct, "count": indices.len(), "type": "SCALAR"}),
    );
    Ok((attrs, acc, targets))
}
