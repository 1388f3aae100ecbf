//! Writing a [`Scene`] as glTF 2.0: `.gltf` with a `.bin` and image files
//! beside it, or a self-contained `.glb`, chosen by the output extension.
//!
//! The writer emits only what the scene uses: meshes drawn by a node,
//! materials of those meshes, textures of those materials, their images and
//! samplers, and one accessor per attribute actually written. Every file is
//! first written under a temporary name and renamed into place at the end, so
//! a failure leaves no partial output.

use crate::io::accessor::vector_type;
use crate::io::gltf_read::{mime_from_extension, sniff_mime};
use crate::io::Format;
use crate::io::{IoError as Error, IoResult as Result};
use crate::scene::{Geometry, ImageSource, RawAccessor, Scene, Transform, TriGeometry};
use serde_json::{json, Map, Value};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

mod files;
mod finite;
mod names;
mod refs;
pub use files::*;
use names::{sanitize_file_name, unique_name, uri_encode};
use refs::{
    as_idx, remap, set_idx, visit_image_refs, visit_texture_refs, visit_variant_material_refs,
};

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// What was written.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct WriteSummary {
    /// Files written (the main file first).
    pub files: Vec<PathBuf>,
    /// Total bytes written.
    pub bytes: u64,
    /// Triangles written (per mesh, not per instance).
    pub triangles: usize,
}

/// Write `scene` to `path` (`.gltf` or `.glb`).
///
/// # Errors
/// When the extension is not `.gltf`/`.glb`, an image cannot be read or has
/// an unknown type, or a file cannot be written. No output file is left
/// behind on error.
pub fn write_scene(scene: &Scene, path: &Path) -> Result<WriteSummary> {
    write_scene_with(scene, path, false)
}

/// [`write_scene`]; with `prefix_images`, a `.gltf` output's image files
/// are named `<stem>_<name>` so that outputs sharing a folder never write
/// the same side file (its `.bin` is `<stem>.bin` either way).
pub fn write_scene_with(scene: &Scene, path: &Path, prefix_images: bool) -> Result<WriteSummary> {
    let format = Format::from_path(path)?;
    if format == Format::Obj {
        return Err(Error::Output {
            path: path.into(),
            message: "OBJ output is not supported; use .gltf or .glb".into(),
        });
    }
    if let Some(message) = finite::first_non_finite(scene) {
        return Err(Error::Output {
            path: path.into(),
            message,
        });
    }
    let glb = format == Format::Glb;
    let out_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    // A run killed while writing left its temporary files here.
    remove_stale_temps(
        if out_dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            &out_dir
        },
        false,
    );
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene")
        .to_string();
    let mut doc = build_document(scene, glb, &stem, prefix_images).map_err(|m| Error::Output {
        path: path.into(),
        message: m,
    })?;
    if !glb {
        name_side_files_by_content(&mut doc, &stem);
    }
    // Writers of `.gltf` outputs in one folder take turns from reading the
    // old output to sweeping its side files: another writer's sweep would
    // otherwise remove the buffer this writer's main file names.
    let _turn = (!glb).then(|| folder_lock(&out_dir));
    // The side files the output now in place uses, to remove once it is
    // replaced (read before it is).
    let mut old_side_files = if glb {
        Vec::new()
    } else {
        side_files_of(path, &out_dir)
    };
    let mut files: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let json_bytes = serde_json::to_vec(&doc.json).map_err(|e| Error::Output {
        path: path.into(),
        message: e.to_string(),
    })?;
    if glb {
        files.push((path.to_path_buf(), glb_bytes(&json_bytes, &doc.bin)));
    } else {
        files.push((path.to_path_buf(), json_bytes));
        if !doc.bin.is_empty() {
            files.push((out_dir.join(&doc.bin_name), doc.bin));
        }
        for (name, bytes) in doc.image_files {
            files.push((out_dir.join(name), bytes));
        }
    }
    commit_files(&files)?;
    // Old side files no longer referenced go, unless this run reads them
    // (an input beside its output) or wrote them.
    let inputs: BTreeSet<PathBuf> = scene
        .sources
        .iter()
        .chain(scene.images.iter().filter_map(|i| match &i.source {
            ImageSource::File(p) => Some(p),
            ImageSource::Bytes(_) => None,
        }))
        .filter_map(|p| p.canonicalize().ok())
        .collect();
    // And this output's buffers a killed run placed without its main file
    // (`<stem>.<tag>.bin`, named after this output alone).
    if !glb {
        old_side_files.extend(stray_buffers(&out_dir, &stem));
    }
    for old in old_side_files {
        let ours = files.iter().any(|(p, _)| *p == old);
        let input = old.canonicalize().is_ok_and(|c| inputs.contains(&c));
        if !ours && !input {
            let _ = std::fs::remove_file(&old);
        }
    }
    Ok(WriteSummary {
        bytes: files.iter().map(|(_, b)| b.len() as u64).sum(),
        files: files.into_iter().map(|(p, _)| p).collect(),
        triangles: doc.triangles,
    })
}

/// `scene` as the bytes of a self-contained `.glb` (what [`write_scene`]
/// writes to a `.glb` path; `name` names the scene in messages).
///
/// # Errors
/// A non-finite value, or an image that cannot be read or has an unknown type.
pub fn glb_scene_bytes(scene: &Scene, name: &Path) -> Result<Vec<u8>> {
    let fail = |message: String| Error::Output {
        path: name.into(),
        message,
    };
    if let Some(message) = finite::first_non_finite(scene) {
        return Err(fail(message));
    }
    let doc = build_document(scene, true, "scene", false).map_err(fail)?;
    let json = serde_json::to_vec(&doc.json).map_err(|e| fail(e.to_string()))?;
    Ok(glb_bytes(&json, &doc.bin))
}

struct Document {
    json: Value,
    bin: Vec<u8>,
    /// The buffer file's name (`.gltf` output).
    bin_name: String,
    image_files: Vec<(String, Vec<u8>)>,
    triangles: usize,
}

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
            let mut min = vec![f32::INFINITY; components];
            let mut max = vec![f32::NEG_INFINITY; components];
            for v in data.chunks_exact(components) {
                for k in 0..components {
                    min[k] = min[k].min(v[k]);
                    max[k] = max[k].max(v[k]);
                }
            }
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

fn build_document(
    scene: &Scene,
    glb: bool,
    stem: &str,
    prefix_images: bool,
) -> std::result::Result<Document, String> {
    // ---- what is used
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
    let (mesh_map, mat_map, tex_map, img_map, sampler_map, camera_map, skin_map) = (
        remap(&mesh_used),
        remap(&mat_used),
        remap(&tex_used),
        remap(&img_used),
        remap(&sampler_used),
        remap(&camera_used),
        remap(&skin_used),
    );

    let mut bin = Bin::default();
    let mut raw_written: BTreeMap<(usize, Option<u32>), usize> = BTreeMap::new();
    let mut raw =
        |bin: &mut Bin, i: usize, target: Option<u32>| -> std::result::Result<usize, String> {
            if let Some(&a) = raw_written.get(&(i, target)) {
                return Ok(a);
            }
            let r = scene
                .accessors
                .get(i)
                .ok_or(format!("internal: accessor {i} missing"))?;
            let a = bin.raw(r, target);
            raw_written.insert((i, target), a);
            Ok(a)
        };
    let mut needs_quantization = false;
    let mut triangles = 0;

    // ---- meshes
    let mut meshes_json = Vec::new();
    for &mi in &mesh_used {
        let m = &scene.meshes[mi];
        let mut prims = Vec::new();
        for p in &m.primitives {
            let mut pj = Map::new();
            match &p.geometry {
                Geometry::Triangles(t) => {
                    if t.triangles.is_empty() {
                        continue;
                    }
                    triangles += t.triangles.len();
                    let (attrs, indices, targets) = write_triangles(&mut bin, t)?;
                    pj.insert("attributes".into(), Value::Object(attrs));
                    pj.insert("indices".into(), indices.into());
                    if !targets.is_empty() {
                        pj.insert("targets".into(), targets.into());
                    }
                }
                Geometry::Raw(r) => {
                    let mut attrs = Map::new();
                    for (k, &a) in &r.attributes {
                        let acc = &scene.accessors[a];
                        let core = k == "POSITION"
                            || k == "NORMAL"
                            || k == "TANGENT"
                            || k.starts_with("TEXCOORD_");
                        if core && acc.component_type != 5126 {
                            needs_quantization = true;
                        }
                        attrs.insert(k.clone(), raw(&mut bin, a, Some(ARRAY_BUFFER))?.into());
                    }
                    pj.insert("attributes".into(), Value::Object(attrs));
                    if let Some(i) = r.indices {
                        pj.insert(
                            "indices".into(),
                            raw(&mut bin, i, Some(ELEMENT_ARRAY_BUFFER))?.into(),
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
                                    needs_quantization = true;
                                }
                                tj.insert(k.clone(), raw(&mut bin, a, Some(ARRAY_BUFFER))?.into());
                            }
                            targets.push(Value::Object(tj));
                        }
                        pj.insert("targets".into(), targets.into());
                    }
                }
            }
            if let Some(mat) = p.material.and_then(|m| mat_map.get(&m)) {
                pj.insert("material".into(), (*mat).into());
            }
            let mut rest = p.rest.clone();
            visit_variant_material_refs(&mut rest, &mut |v| set_idx(v, &mat_map));
            pj.extend(rest);
            prims.push(Value::Object(pj));
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

    // ---- nodes (all kept: the hierarchy is the user's)
    let mut nodes_json = Vec::new();
    for n in &scene.nodes {
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
        if let Some(m) = n.mesh.and_then(|m| mesh_map.get(&m)) {
            nj.insert("mesh".into(), (*m).into());
            if let Some(w) = &n.weights {
                nj.insert("weights".into(), json!(w));
            }
        }
        if let Some(c) = n.camera.and_then(|c| camera_map.get(&c)) {
            nj.insert("camera".into(), (*c).into());
        }
        if let Some(s) = n.skin.and_then(|s| skin_map.get(&s)) {
            if n.mesh.is_some_and(|m| mesh_map.contains_key(&m)) {
                nj.insert("skin".into(), (*s).into());
            }
        }
        nj.extend(n.rest.clone());
        nodes_json.push(Value::Object(nj));
    }

    // ---- skins and animations (accessors copied)
    let mut skins_json = Vec::new();
    for &s in &skin_used {
        let mut sj = scene.skins[s].clone();
        if let Some(a) = sj.get("inverseBindMatrices").and_then(as_idx) {
            sj["inverseBindMatrices"] = raw(&mut bin, a, None)?.into();
        }
        skins_json.push(sj);
    }
    let mut anims_json = Vec::new();
    for a in &scene.animations {
        let mut aj = a.clone();
        if let Some(samplers) = aj.get_mut("samplers").and_then(Value::as_array_mut) {
            for s in samplers {
                for key in ["input", "output"] {
                    if let Some(x) = s.get(key).and_then(as_idx) {
                        s[key] = raw(&mut bin, x, None)?.into();
                    }
                }
            }
        }
        anims_json.push(aj);
    }

    // ---- materials, textures, samplers, images
    let materials_json: Vec<Value> = mat_used
        .iter()
        .map(|&m| {
            let mut j = Value::Object(scene.materials[m].json.clone());
            visit_texture_refs(&mut j, &mut |v| set_idx(v, &tex_map));
            j
        })
        .collect();
    let textures_json: Vec<Value> = tex_used
        .iter()
        .map(|&t| {
            let mut j = scene.textures[t].clone();
            visit_image_refs(&mut j, &mut |v| set_idx(v, &img_map));
            if let Some(s) = j.get_mut("sampler") {
                if as_idx(s).is_some_and(|i| sampler_map.contains_key(&i)) {
                    set_idx(s, &sampler_map);
                } else if let Some(o) = j.as_object_mut() {
                    o.remove("sampler");
                }
            }
            j
        })
        .collect();
    let samplers_json: Vec<Value> = sampler_used
        .iter()
        .map(|&s| scene.samplers[s].clone())
        .collect();
    let mut images_json = Vec::new();
    let mut image_files = Vec::new();
    let mut taken_names: BTreeSet<String> = [format!("{stem}.bin").to_lowercase()].into();
    for &i in &img_used {
        let img = &scene.images[i];
        let bytes = match &img.source {
            ImageSource::Bytes(b) => b.clone(),
            ImageSource::File(p) => {
                crate::io::paths::read_capped(p, crate::io::paths::MAX_IMAGE_BYTES, "image")
                    .map_err(|e| format!("image {i}: cannot read '{}': {e}", p.display()))?
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
            let mime = mime.ok_or(format!(
                "image {i}: unknown image type, cannot embed it in a GLB"
            ))?;
            let view = bin.view(&bytes, None, None);
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

    // ---- scenes
    let scenes_json: Vec<Value> = scene
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
        .collect();

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
    let arrays: [(&str, Vec<Value>); 10] = [
        ("nodes", nodes_json),
        ("meshes", meshes_json),
        ("materials", materials_json),
        ("textures", textures_json),
        ("samplers", samplers_json),
        ("images", images_json),
        (
            "cameras",
            camera_used
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
    Ok(Document {
        json: Value::Object(root),
        bin: bin.data,
        bin_name: format!("{stem}.bin"),
        image_files,
        triangles,
    })
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
) -> std::result::Result<WrittenTriangles, String> {
    let n = t.positions.len();
    // Vertices keep their order (an unused one is left out): an output
    // that keeps the input's mesh keeps its vertex order and indices.
    let mut used = vec![false; n];
    for tri in &t.triangles {
        for &v in tri {
            let v = v as usize;
            if v >= n {
                return Err(format!(
                    "internal: triangle index {v} out of range ({n} vertices)"
                ));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_safe_and_unique() {
        let mut taken = BTreeSet::new();
        assert_eq!(
            unique_name(&sanitize_file_name("..\\a b.png"), &mut taken),
            "a b.png"
        );
        assert_eq!(unique_name("a b.png", &mut taken), "a b_1.png");
        assert_eq!(uri_encode("a b.png"), "a%20b.png");
    }
}
