//! Reading glTF 2.0 (`.gltf` with external or data-URI buffers, and `.glb`)
//! into a [`Scene`].
//!
//! The JSON is checked by the `gltf` crate's validator (every index in range,
//! every required field present) and then read as plain JSON so that nothing
//! the tool does not model (material extensions, extras, lights) is lost.
//! Buffers are loaded only when a buffer view uses them, external files only
//! from inside the asset's folder, and every accessor is decoded with bounds
//! checks ([`AccessorReader`]).

use crate::io::accessor::AccessorReader;
use crate::io::paths::{resolve_file_inside, resolve_inside};
use crate::io::{IoError as Error, IoResult as Result};
use crate::scene::{
    mode, Geometry, Image, ImageSource, Material, Mesh, Node, Primitive, RawAccessor, RawGeometry,
    Scene, SceneRoot, Transform, TriGeometry, VertexAttribute,
};
use serde_json::{Map, Value};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

mod buffers;
pub(crate) mod error;
use buffers::*;
pub use error::{BufferFault, DataUriError, Element, GlbError, GltfError, HierarchyError};

/// Extensions that, when required, this reader can still honour: quantized
/// attributes are decoded to floats; the others are material or texture data
/// kept as they are.
fn required_extension_supported(name: &str) -> bool {
    name == "KHR_mesh_quantization"
        || name == "KHR_texture_transform"
        || name.starts_with("KHR_materials_")
        || name == "KHR_lights_punctual"
        || name == "KHR_texture_basisu"
        || name == "EXT_texture_webp"
        || name == "EXT_texture_avif"
}

/// Read a `.gltf` or `.glb` file.
///
/// # Errors
/// Names the file and the element at fault: malformed GLB container or JSON,
/// an index out of range, a required extension the tool cannot decode
/// (Draco, meshopt...), a buffer or image outside the asset's folder or
/// missing, a declared size larger than the data.
pub fn read_gltf(path: &Path) -> Result<Scene> {
    read_gltf_with(path, &crate::io::ReadOptions::default())
}

/// [`read_gltf`] with `options`.
///
/// # Errors
/// Those of [`read_gltf`].
pub fn read_gltf_with(path: &Path, options: &crate::io::ReadOptions) -> Result<Scene> {
    let bytes = crate::io::paths::read_capped(
        path,
        crate::io::model_cap(options.max_memory),
        crate::io::model_what(options.max_memory),
    )
    .map_err(|e| Error::io(path, e))?;
    let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    read_gltf_bytes_with(&bytes, &base_dir, path, options)
}

/// A GLB's chunks, its header's length checked first (under 12, the
/// container's own split subtracts past zero).
///
/// # Errors
/// A message when the header or a chunk is malformed.
pub fn split_glb(bytes: &[u8]) -> std::result::Result<gltf::binary::Glb<'_>, GlbError> {
    let length = bytes
        .get(8..12)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or(GlbError::Short)?;
    if length < 12 {
        return Err(GlbError::Length(length));
    }
    gltf::binary::Glb::from_slice(bytes).map_err(GlbError::Chunks)
}

/// Read a glTF or GLB document held in memory; external files are resolved
/// inside `base_dir`, and `path` names the asset in messages.
pub fn read_gltf_bytes(bytes: &[u8], base_dir: &Path, path: &Path) -> Result<Scene> {
    read_gltf_bytes_with(bytes, base_dir, path, &crate::io::ReadOptions::default())
}

/// [`read_gltf_bytes`] with `options`.
///
/// # Errors
/// Those of [`read_gltf`].
pub fn read_gltf_bytes_with(
    bytes: &[u8],
    base_dir: &Path,
    path: &Path,
    options: &crate::io::ReadOptions,
) -> Result<Scene> {
    read_document(bytes, base_dir, options).map_err(|error| Error::Gltf {
        path: path.to_path_buf(),
        error,
    })
}

fn read_document(
    bytes: &[u8],
    base_dir: &Path,
    options: &crate::io::ReadOptions,
) -> std::result::Result<Scene, GltfError> {
    let (json_bytes, bin): (Vec<u8>, Option<Vec<u8>>) = if bytes.starts_with(b"glTF") {
        let glb = split_glb(bytes).map_err(GltfError::Glb)?;
        (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
    } else {
        (bytes.to_vec(), None)
    };
    let root: Value = serde_json::from_slice(&json_bytes).map_err(GltfError::Json)?;
    if !root.is_object() {
        return Err(GltfError::NotObject);
    }
    let version = root.pointer("/asset/version").and_then(Value::as_str);
    match version {
        Some(v) if v.starts_with("2.") => {}
        Some(v) => {
            return Err(GltfError::Version {
                version: v.to_string(),
            })
        }
        None => return Err(GltfError::NoVersion),
    }
    // Extensions the tool cannot decode: refuse by name.
    if let Some(req) = root.get("extensionsRequired").and_then(Value::as_array) {
        let bad: Vec<String> = req
            .iter()
            .filter_map(Value::as_str)
            .filter(|n| !required_extension_supported(n))
            .map(str::to_string)
            .collect();
        if !bad.is_empty() {
            return Err(GltfError::Extensions(bad));
        }
    }
    let primitives: usize = arr(&root, "meshes")
        .iter()
        .map(|m| arr(m, "primitives").len())
        .sum();
    crate::io::check_primitive_count(primitives, "mesh primitives", options.max_memory)?;
    precheck_positions(&root)?;
    validate_schema(&json_bytes)?;
    let buffers = load_buffers(&root, bin, base_dir, options.max_memory)?;
    let real_bytes = json_bytes.len() as u64
        + buffers
            .iter()
            .flatten()
            .map(|b| b.len() as u64)
            .sum::<u64>();
    let budget = crate::io::accessor::decode_budget(real_bytes, options.max_memory);
    let mut reader = SceneReader {
        root: &root,
        acc: AccessorReader::with_budget(&root, &buffers, budget),
        buffers: &buffers,
        base_dir,
        raw_map: HashMap::new(),
        scene: Scene::default(),
    };
    reader.read()?;
    let mut scene = reader.scene;
    // External buffer files (their paths were checked by `load_buffers`).
    for b in arr(&root, "buffers") {
        if let Some(uri) = b.get("uri").and_then(Value::as_str) {
            if !uri.starts_with("data:") {
                if let Ok(p) = resolve_inside(base_dir, uri) {
                    scene.sources.push(p);
                }
            }
        }
    }
    scene.sources.sort();
    scene.sources.dedup();
    Ok(scene)
}

/// MIME type (if given) and bytes of a data URI.
type DataUri = (Option<String>, Vec<u8>);

struct SceneReader<'a> {
    root: &'a Value,
    acc: AccessorReader<'a>,
    buffers: &'a [Option<Vec<u8>>],
    base_dir: &'a Path,
    /// input accessor index -> index in scene.accessors
    raw_map: HashMap<usize, usize>,
    scene: Scene,
}

fn arr<'v>(v: &'v Value, key: &str) -> &'v [Value] {
    v.get(key)
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[])
}

fn idx(v: &Value, key: &str) -> Option<usize> {
    v.get(key).and_then(Value::as_u64).map(|x| x as usize)
}

fn f64s<const N: usize>(
    v: &Value,
    key: &'static str,
) -> std::result::Result<Option<[f64; N]>, GltfError> {
    match v.get(key) {
        None => Ok(None),
        Some(a) => {
            let a = a
                .as_array()
                .filter(|a| a.len() == N)
                .ok_or(GltfError::Numbers { key, len: N })?;
            let mut out = [0.0; N];
            for (o, x) in out.iter_mut().zip(a) {
                *o = x
                    .as_f64()
                    .filter(|x| x.is_finite())
                    .ok_or(GltfError::NotFinite(key))?;
            }
            Ok(Some(out))
        }
    }
}

/// The object's fields other than `keep_out`, i.e. what the scene does not model.
fn rest_of(v: &Value, modelled: &[&str]) -> Map<String, Value> {
    v.as_object()
        .map(|o| {
            o.iter()
                .filter(|(k, _)| !modelled.contains(&k.as_str()))
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect()
        })
        .unwrap_or_default()
}

impl SceneReader<'_> {
    fn read(&mut self) -> std::result::Result<(), GltfError> {
        let root = self.root;
        self.scene.copyright = root
            .pointer("/asset/copyright")
            .and_then(Value::as_str)
            .map(str::to_string);
        self.scene.extensions_used = arr(root, "extensionsUsed")
            .iter()
            .filter_map(Value::as_str)
            .map(str::to_string)
            .collect();
        self.scene.extensions_required = arr(root, "extensionsRequired")
            .iter()
            .filter_map(Value::as_str)
            .map(str::to_string)
            .collect();
        self.scene.extensions = root.get("extensions").and_then(Value::as_object).cloned();
        self.scene.extras = root.get("extras").cloned();
        self.scene.samplers = arr(root, "samplers").to_vec();
        self.scene.textures = arr(root, "textures").to_vec();
        self.scene.cameras = arr(root, "cameras").to_vec();
        self.scene.materials = arr(root, "materials")
            .iter()
            .map(|m| Material {
                json: m.as_object().cloned().unwrap_or_default(),
            })
            .collect();
        for (i, img) in arr(root, "images").iter().enumerate() {
            let image = self.read_image(i, img)?;
            self.scene.images.push(image);
        }
        // Nodes
        for (i, n) in arr(root, "nodes").iter().enumerate() {
            let at = |e: GltfError| e.at(Element::Node(i));
            let transform = if let Some(m) = f64s::<16>(n, "matrix").map_err(at)? {
                Transform::Matrix(m)
            } else {
                Transform::Trs {
                    translation: f64s::<3>(n, "translation").map_err(at)?,
                    rotation: f64s::<4>(n, "rotation").map_err(at)?,
                    scale: f64s::<3>(n, "scale").map_err(at)?,
                }
            };
            self.scene.nodes.push(Node {
                name: n.get("name").and_then(Value::as_str).map(str::to_string),
                transform,
                children: arr(n, "children")
                    .iter()
                    .filter_map(Value::as_u64)
                    .map(|c| c as usize)
                    .collect(),
                mesh: idx(n, "mesh"),
                camera: idx(n, "camera"),
                skin: idx(n, "skin"),
                weights: n
                    .get("weights")
                    .and_then(Value::as_array)
                    .map(|w| w.iter().filter_map(Value::as_f64).collect()),
                rest: rest_of(
                    n,
                    &[
                        "name",
                        "matrix",
                        "translation",
                        "rotation",
                        "scale",
                        "children",
                        "mesh",
                        "camera",
                        "skin",
                        "weights",
                    ],
                ),
            });
        }
        check_hierarchy(&self.scene.nodes)?;
        // Meshes drawn by skinned nodes are passed through whole.
        let mut skinned_mesh = vec![false; arr(root, "meshes").len()];
        for n in &self.scene.nodes {
            if let (Some(m), Some(_)) = (n.mesh, n.skin) {
                if let Some(s) = skinned_mesh.get_mut(m) {
                    *s = true;
                }
            }
        }
        for (mi, m) in arr(root, "meshes").iter().enumerate() {
            let mesh = self.read_mesh(mi, m, skinned_mesh[mi])?;
            self.scene.meshes.push(mesh);
        }
        // Skins and animations keep their JSON; accessor indices are remapped.
        for (si, s) in arr(root, "skins").iter().enumerate() {
            let mut s = s.clone();
            if let Some(a) = idx(&s, "inverseBindMatrices") {
                let r = self.raw(a).map_err(|e| e.at(Element::Skin(si)))?;
                s["inverseBindMatrices"] = r.into();
            }
            self.scene.skins.push(s);
        }
        for (ai, a) in arr(root, "animations").iter().enumerate() {
            let mut a = a.clone();
            if let Some(samplers) = a.get_mut("samplers").and_then(Value::as_array_mut) {
                for s in samplers {
                    for key in ["input", "output"] {
                        if let Some(x) = idx(s, key) {
                            let r = self.raw(x).map_err(|e| e.at(Element::Animation(ai)))?;
                            s[key] = r.into();
                        }
                    }
                }
            }
            self.scene.animations.push(a);
        }
        // Scenes
        for s in arr(root, "scenes") {
            self.scene.scenes.push(SceneRoot {
                name: s.get("name").and_then(Value::as_str).map(str::to_string),
                nodes: arr(s, "nodes")
                    .iter()
                    .filter_map(Value::as_u64)
                    .map(|n| n as usize)
                    .collect(),
                rest: rest_of(s, &["name", "nodes"]),
            });
        }
        self.scene.default_scene = idx(root, "scene");
        if self.scene.scenes.is_empty() && !self.scene.nodes.is_empty() {
            self.scene.scenes.push(SceneRoot {
                name: None,
                nodes: self.scene.root_nodes(),
                rest: Map::new(),
            });
            self.scene.default_scene = Some(0);
        }
        Ok(())
    }

    fn read_image(&mut self, i: usize, img: &Value) -> std::result::Result<Image, GltfError> {
        let at = |e: GltfError| e.at(Element::Image(i));
        let name = img.get("name").and_then(Value::as_str).map(str::to_string);
        let mut mime_type = img
            .get("mimeType")
            .and_then(Value::as_str)
            .map(str::to_string);
        let rest = rest_of(img, &["name", "mimeType", "uri", "bufferView"]);
        let (source, file_name) = if let Some(uri) = img.get("uri").and_then(Value::as_str) {
            if let Some(r) = decode_data_uri(uri) {
                let (mime, bytes) = r.map_err(|e| at(e.into()))?;
                if mime_type.is_none() {
                    mime_type = mime;
                }
                (ImageSource::Bytes(bytes), None)
            } else {
                let file = resolve_file_inside(self.base_dir, uri).map_err(|e| at(e.into()))?;
                let fname = file
                    .file_name()
                    .and_then(|f| f.to_str())
                    .map(str::to_string);
                // Read once, here, where the path was checked: a file
                // swapped for a link meanwhile is never read later.
                let bytes = crate::io::paths::read_capped(
                    &file,
                    crate::io::paths::MAX_IMAGE_BYTES,
                    "image",
                )
                .map_err(|e| {
                    GltfError::Read(e).at(Element::ImageFile {
                        index: i,
                        uri: uri.to_string(),
                    })
                })?;
                if mime_type.is_none() {
                    mime_type = mime_from_extension(&file).map(str::to_string);
                }
                self.scene.sources.push(file);
                (ImageSource::Bytes(bytes), fname)
            }
        } else if let Some(view) = idx(img, "bufferView") {
            let bytes = self.view_bytes(view).map_err(at)?;
            (ImageSource::Bytes(bytes), None)
        } else {
            return Err(GltfError::NoImageSource(i));
        };
        if mime_type.is_none() {
            mime_type = match &source {
                ImageSource::Bytes(b) => sniff_mime(b).map(str::to_string),
                ImageSource::File(p) => mime_from_extension(p).map(str::to_string),
            };
        }
        let ext = match mime_type.as_deref() {
            Some("image/png") => "png",
            Some("image/jpeg") => "jpg",
            Some("image/webp") => "webp",
            Some("image/ktx2") => "ktx2",
            _ => "bin",
        };
        let file_name = file_name.unwrap_or_else(|| format!("image{i}.{ext}"));
        Ok(Image {
            name,
            mime_type,
            source,
            file_name,
            rest,
        })
    }

    fn view_bytes(&self, view: usize) -> std::result::Result<Vec<u8>, GltfError> {
        let v = self
            .root
            .pointer(&format!("/bufferViews/{view}"))
            .ok_or(GltfError::NoView(view))?;
        let b = idx(v, "buffer").ok_or(GltfError::ViewMissing("buffer"))?;
        let off = idx(v, "byteOffset").unwrap_or(0);
        let len = idx(v, "byteLength").ok_or(GltfError::ViewMissing("byteLength"))?;
        let data = self
            .buffers
            .get(b)
            .and_then(|x| x.as_deref())
            .ok_or(GltfError::BufferNotLoaded(b))?;
        off.checked_add(len)
            .filter(|&e| e <= data.len())
            .map(|e| data[off..e].to_vec())
            .ok_or(GltfError::ViewOutside { view, buffer: b })
    }

    /// Copy input accessor `a` verbatim into the scene (once).
    fn raw(&mut self, a: usize) -> std::result::Result<usize, GltfError> {
        if let Some(&r) = self.raw_map.get(&a) {
            return Ok(r);
        }
        let (info, data) = self.acc.read_packed(a)?;
        let j = self
            .root
            .pointer(&format!("/accessors/{a}"))
            .cloned()
            .unwrap_or(Value::Null);
        let r = self.scene.accessors.len();
        self.scene.accessors.push(RawAccessor {
            component_type: info.component_type,
            kind: info.kind,
            normalized: info.normalized,
            count: info.count,
            min: j.get("min").cloned(),
            max: j.get("max").cloned(),
            name: j.get("name").and_then(Value::as_str).map(str::to_string),
            data,
        });
        self.raw_map.insert(a, r);
        Ok(r)
    }

    fn read_mesh(
        &mut self,
        mi: usize,
        m: &Value,
        skinned: bool,
    ) -> std::result::Result<Mesh, GltfError> {
        let mesh_name = m.get("name").and_then(Value::as_str).map(str::to_string);
        let label = match &mesh_name {
            Some(n) => format!("mesh {mi} '{n}'"),
            None => format!("mesh {mi}"),
        };
        let mut primitives = Vec::new();
        for (pi, p) in arr(m, "primitives").iter().enumerate() {
            let prim = self.read_primitive(p, skinned).map_err(|e| {
                e.at(Element::Primitive {
                    mesh: mi,
                    name: mesh_name.clone(),
                    primitive: pi,
                })
            })?;
            if let Geometry::Raw(raw) = &prim.geometry {
                let why = if skinned || raw.attributes.keys().any(|k| k.starts_with("JOINTS_")) {
                    "skinned"
                } else {
                    match raw.mode {
                        mode::POINTS => "POINTS",
                        mode::LINES | mode::LINE_LOOP | mode::LINE_STRIP => "lines",
                        _ => "no crackable triangles",
                    }
                };
                self.scene.warnings.push(format!(
                    "{label} primitive {pi} ({why}) is passed through without cracking"
                ));
            }
            primitives.push(prim);
        }
        Ok(Mesh {
            name: mesh_name,
            primitives,
            weights: m
                .get("weights")
                .and_then(Value::as_array)
                .map(|w| w.iter().filter_map(Value::as_f64).collect()),
            rest: rest_of(m, &["name", "primitives", "weights"]),
        })
    }

    fn read_primitive(
        &mut self,
        p: &Value,
        skinned: bool,
    ) -> std::result::Result<Primitive, GltfError> {
        let prim_mode = p.get("mode").and_then(Value::as_u64).unwrap_or(4) as u32;
        let attrs: BTreeMap<String, usize> = p
            .get("attributes")
            .and_then(Value::as_object)
            .map(|o| {
                o.iter()
                    .filter_map(|(k, v)| Some((k.clone(), v.as_u64()? as usize)))
                    .collect()
            })
            .unwrap_or_default();
        let has_skin_attrs = attrs
            .keys()
            .any(|k| k.starts_with("JOINTS_") || k.starts_with("WEIGHTS_"));
        let mut rest = rest_of(p, &["attributes", "indices", "material", "mode", "targets"]);
        // A Draco extension that is only *used* has a fallback: read the plain accessors.
        if let Some(ext) = rest.get_mut("extensions").and_then(Value::as_object_mut) {
            ext.remove("KHR_draco_mesh_compression");
            if ext.is_empty() {
                rest.remove("extensions");
            }
        }
        let material = idx(p, "material");
        let triangles = matches!(
            prim_mode,
            mode::TRIANGLES | mode::TRIANGLE_STRIP | mode::TRIANGLE_FAN
        );
        if !triangles || has_skin_attrs || skinned || !attrs.contains_key("POSITION") {
            let mut raw = RawGeometry {
                mode: prim_mode,
                ..Default::default()
            };
            for (k, a) in &attrs {
                raw.attributes.insert(k.clone(), self.raw(*a)?);
            }
            if let Some(i) = idx(p, "indices") {
                raw.indices = Some(self.raw(i)?);
            }
            for t in arr(p, "targets") {
                let mut tm = BTreeMap::new();
                if let Some(o) = t.as_object() {
                    for (k, v) in o {
                        if let Some(a) = v.as_u64() {
                            tm.insert(k.clone(), self.raw(a as usize)?);
                        }
                    }
                }
                raw.targets.push(tm);
            }
            return Ok(Primitive {
                material,
                geometry: Geometry::Raw(raw),
                rest,
            });
        }
        // Crackable triangles: decode.
        let pos_acc = attrs["POSITION"];
        let attribute = |sem: &str| {
            let semantic = sem.to_string();
            move |e: crate::io::accessor::AccessorError| {
                GltfError::from(e).at(Element::Attribute { semantic })
            }
        };
        let (info, pos) = self.acc.read_f32(pos_acc).map_err(attribute("POSITION"))?;
        if info.components != 3 {
            return Err(GltfError::NotVec3 {
                accessor: pos_acc,
                kind: info.kind,
            });
        }
        let n = info.count;
        if let Some(k) = pos.iter().position(|x| !x.is_finite()) {
            return Err(GltfError::PositionNotFinite {
                accessor: pos_acc,
                vertex: k / 3,
            });
        }
        let positions: Vec<[f32; 3]> = pos.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let mut attributes = Vec::new();
        for (sem, &a) in &attrs {
            if sem == "POSITION" {
                continue;
            }
            let (ai, data) = self.acc.read_f32(a).map_err(attribute(sem))?;
            if ai.count != n {
                return Err(GltfError::Count {
                    attribute: sem.clone(),
                    accessor: a,
                    count: ai.count,
                    positions: n,
                });
            }
            attributes.push(VertexAttribute {
                semantic: sem.clone(),
                components: ai.components,
                data,
            });
        }
        let index_list: Vec<u32> = match idx(p, "indices") {
            Some(i) => {
                let v = self
                    .acc
                    .read_indices(i)
                    .map_err(|e| GltfError::from(e).at(Element::Indices))?;
                if let Some(&bad) = v.iter().find(|&&x| x as usize >= n) {
                    return Err(GltfError::Index {
                        accessor: i,
                        index: bad,
                        vertices: n,
                    });
                }
                v
            }
            None => (0..n as u32).collect(),
        };
        let targets = self.read_targets(p, n)?;
        let triangles = assemble_triangles(prim_mode, &index_list);
        let mut geo = TriGeometry {
            positions,
            attributes,
            triangles,
            targets,
            group: None,
        };
        let fixed = normalize_vectors(&mut geo);
        if fixed > 0 {
            self.scene.warnings.push(format!(
                "{fixed} zero or non-finite normals/tangents replaced by the face normal or (1,0,0)"
            ));
        }
        Ok(Primitive {
            material,
            geometry: Geometry::Triangles(geo),
            rest,
        })
    }

    /// A crackable primitive's morph targets, each attribute decoded and
    /// checked against the primitive's `n` vertices.
    fn read_targets(
        &self,
        p: &Value,
        n: usize,
    ) -> std::result::Result<Vec<Vec<VertexAttribute>>, GltfError> {
        let mut targets = Vec::new();
        for (ti, t) in arr(p, "targets").iter().enumerate() {
            let mut tattrs = Vec::new();
            for (sem, a) in t.as_object().into_iter().flatten() {
                let a = a.as_u64().ok_or_else(|| GltfError::TargetNotIndex {
                    target: ti,
                    attribute: sem.clone(),
                })? as usize;
                let (ai, data) = self.acc.read_f32(a).map_err(|e| {
                    GltfError::from(e).at(Element::Target {
                        target: ti,
                        attribute: sem.clone(),
                    })
                })?;
                if ai.count != n {
                    return Err(GltfError::TargetCount {
                        target: ti,
                        attribute: sem.clone(),
                        count: ai.count,
                        positions: n,
                    });
                }
                tattrs.push(VertexAttribute {
                    semantic: sem.clone(),
                    components: ai.components,
                    data,
                });
            }
            targets.push(tattrs);
        }
        Ok(targets)
    }
}

/// Reject cycles and nodes with several parents: they make the hierarchy invalid.
fn check_hierarchy(nodes: &[Node]) -> std::result::Result<(), HierarchyError> {
    check_hierarchy_counted(nodes).map(|_| ())
}

/// [`check_hierarchy`], returning the number of node visits (for the tests'
/// bound on the work).
fn check_hierarchy_counted(nodes: &[Node]) -> std::result::Result<usize, HierarchyError> {
    let mut visits = 0;
    let mut parent: Vec<Option<usize>> = vec![None; nodes.len()];
    for (i, n) in nodes.iter().enumerate() {
        for &c in &n.children {
            if c >= nodes.len() {
                return Err(HierarchyError::NoChild { node: i, child: c });
            }
            if parent[c].is_some() {
                return Err(HierarchyError::TwoParents(c));
            }
            parent[c] = Some(i);
        }
    }
    // With one parent each, a node is in (or below) a cycle exactly when no
    // root reaches it: a walk down from the roots, linear in the nodes (a
    // walk up from every node is quadratic on a deep chain).
    let mut reached = vec![false; nodes.len()];
    let mut stack: Vec<usize> = (0..nodes.len()).filter(|&i| parent[i].is_none()).collect();
    while let Some(i) = stack.pop() {
        reached[i] = true;
        visits += 1;
        stack.extend(nodes[i].children.iter().copied());
    }
    if let Some(start) = reached.iter().position(|&r| !r) {
        return Err(HierarchyError::Cycle(start));
    }
    Ok(visits)
}

/// The `uri`s of a glTF document's buffers and images that name files
/// (not `data:` URIs), in order, as written.
pub fn file_uris(json: &Value) -> Vec<&str> {
    ["buffers", "images"]
        .iter()
        .flat_map(|key| {
            json.get(*key)
                .and_then(Value::as_array)
                .into_iter()
                .flatten()
        })
        .filter_map(|item| item.get("uri").and_then(Value::as_str))
        .filter(|uri| !uri.starts_with("data:"))
        .collect()
}

/// Triangle list from TRIANGLES / TRIANGLE_STRIP / TRIANGLE_FAN indices, with
/// glTF's winding rules.
pub fn assemble_triangles(prim_mode: u32, ix: &[u32]) -> Vec<[u32; 3]> {
    match prim_mode {
        mode::TRIANGLE_STRIP => (0..ix.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [ix[i], ix[i + 1], ix[i + 2]]
                } else {
                    [ix[i + 1], ix[i], ix[i + 2]]
                }
            })
            .collect(),
        mode::TRIANGLE_FAN => (1..ix.len().saturating_sub(1))
            .map(|i| [ix[i], ix[i + 1], ix[0]])
            .collect(),
        _ => ix.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}

/// Make NORMAL unit length and TANGENT xyz unit with w = +-1, as glTF requires.
/// Zero or non-finite normals take the normal of a triangle using the vertex.
/// Returns how many vectors had to be replaced.
pub fn normalize_vectors(geo: &mut TriGeometry) -> usize {
    let mut fixed = 0;
    let mut face_normal: Vec<Option<[f32; 3]>> = Vec::new();
    for a in geo.attributes.iter_mut() {
        let is_normal = a.semantic == "NORMAL" && a.components == 3;
        let is_tangent = a.semantic == "TANGENT" && a.components == 4;
        if !is_normal && !is_tangent {
            continue;
        }
        if is_normal && face_normal.is_empty() {
            face_normal = vec![None; geo.positions.len()];
            for t in &geo.triangles {
                let [p0, p1, p2] = t.map(|i| geo.positions[i as usize]);
                let u = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
                let v = [p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]];
                let n = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if l > 0.0 && l.is_finite() {
                    for &i in t {
                        face_normal[i as usize].get_or_insert([n[0] / l, n[1] / l, n[2] / l]);
                    }
                }
            }
        }
        let c = a.components;
        for (vi, v) in a.data.chunks_exact_mut(c).enumerate() {
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if l > 1e-12 && l.is_finite() {
                if (l - 1.0).abs() > 1e-6 {
                    v[0] /= l;
                    v[1] /= l;
                    v[2] /= l;
                }
            } else {
                fixed += 1;
                let n = if is_normal {
                    face_normal.get(vi).copied().flatten()
                } else {
                    None
                };
                let n = n.unwrap_or([1.0, 0.0, 0.0]);
                v[..3].copy_from_slice(&n);
            }
            if is_tangent {
                v[3] = if v[3] < 0.0 { -1.0 } else { 1.0 };
            }
        }
    }
    fixed
}

/// MIME type from the first bytes of an image.
pub fn sniff_mime(b: &[u8]) -> Option<&'static str> {
    if b.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if b.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if b.len() >= 12 && &b[0..4] == b"RIFF" && &b[8..12] == b"WEBP" {
        Some("image/webp")
    } else if b.starts_with(b"\xABKTX 20\xBB") {
        Some("image/ktx2")
    } else {
        None
    }
}

/// MIME type from a file extension.
pub fn mime_from_extension(p: &Path) -> Option<&'static str> {
    match p.extension()?.to_str()?.to_ascii_lowercase().as_str() {
        "png" => Some("image/png"),
        "jpg" | "jpeg" => Some("image/jpeg"),
        "webp" => Some("image/webp"),
        "ktx2" => Some("image/ktx2"),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A GLB header whose length is under its own 12 bytes is an error
    /// (the container's split subtracted past zero: a panic with overflow
    /// checks, found by the fuzzer), and so is a file shorter than a header.
    #[test]
    fn a_glb_length_under_its_header_is_an_error() {
        for length in [0u32, 11] {
            let mut glb = b"glTF".to_vec();
            glb.extend_from_slice(&2u32.to_le_bytes());
            glb.extend_from_slice(&length.to_le_bytes());
            glb.extend_from_slice(&[0; 20]);
            let e = split_glb(&glb).err().unwrap().to_string();
            assert!(e.contains("less than the header"), "{e}");
        }
        assert!(split_glb(b"glTF\x02\0\0").is_err());
    }

    /// The hierarchy check visits each node once: a 100,000-deep chain (a
    /// walk up from every node took 9 s on it) and a cycle under a chain.
    #[test]
    fn the_hierarchy_check_takes_linear_work() {
        let chain = |n: usize| -> Vec<Node> {
            (0..n)
                .map(|i| Node {
                    children: if i + 1 < n { vec![i + 1] } else { Vec::new() },
                    ..Node::default()
                })
                .collect()
        };
        for n in [1_000, 100_000] {
            assert_eq!(check_hierarchy_counted(&chain(n)), Ok(n));
        }
        // Node 0 is a root over 1 -> 2 -> 3 -> 1: the cycle is named.
        let mut nodes = chain(4);
        nodes[3].children = vec![1];
        nodes[0].children = Vec::new();
        let e = check_hierarchy(&nodes).unwrap_err().to_string();
        assert_eq!(e, "node 1 is part of a cycle in the node hierarchy");
    }

    #[test]
    fn strip_and_fan_winding() {
        // A quad as a strip 0 1 2 3 and as a fan 0 1 2 3: both counter-clockwise pairs.
        assert_eq!(
            assemble_triangles(mode::TRIANGLE_STRIP, &[0, 1, 2, 3]),
            vec![[0, 1, 2], [2, 1, 3]]
        );
        assert_eq!(
            assemble_triangles(mode::TRIANGLE_FAN, &[0, 1, 2, 3]),
            vec![[1, 2, 0], [2, 3, 0]]
        );
        assert!(assemble_triangles(mode::TRIANGLES, &[0, 1]).is_empty());
    }

    #[test]
    fn refuses_required_draco_by_name() {
        let doc = br#"{"asset":{"version":"2.0"},"extensionsUsed":["KHR_draco_mesh_compression"],"extensionsRequired":["KHR_draco_mesh_compression"]}"#;
        let e = read_gltf_bytes(doc, Path::new("."), Path::new("x.gltf"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("KHR_draco_mesh_compression"), "{e}");
    }

    #[test]
    fn refuses_escaping_buffer_uri() {
        let doc = br#"{"asset":{"version":"2.0"},"buffers":[{"uri":"../secret.bin","byteLength":4}],"bufferViews":[{"buffer":0,"byteLength":4}]}"#;
        let e = read_gltf_bytes(doc, Path::new("/tmp"), Path::new("x.gltf"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("..") && e.contains("buffer 0"), "{e}");
    }
}
