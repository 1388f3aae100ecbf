//! The scene: everything that is read from an asset and must be written back.
//!
//! A [`Scene`] is format-neutral. Crackable geometry (triangle primitives
//! without skins or morph targets) is decoded into [`TriGeometry`] with every
//! vertex attribute as `f32` components; everything the tool does not crack
//! (points, lines, skinned or morphed primitives, animations, skins) keeps its
//! original accessors as [`RawAccessor`]s and its JSON, so it is written back
//! unchanged. Materials, textures and samplers keep their glTF JSON (all
//! `KHR_materials_*` and `KHR_texture_transform` data included); texture,
//! image, sampler and accessor indices inside them refer to this scene's
//! arrays.

use serde_json::{Map, Value};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// A whole asset.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Scenes (glTF `scenes`); OBJ input has one.
    pub scenes: Vec<SceneRoot>,
    /// The default scene, if the asset names one.
    pub default_scene: Option<usize>,
    /// Every node of the hierarchy.
    pub nodes: Vec<Node>,
    /// Meshes, referenced by nodes (a mesh used by several nodes is instanced).
    pub meshes: Vec<Mesh>,
    /// Materials as glTF material JSON; texture indices refer to [`Scene::textures`].
    pub materials: Vec<Material>,
    /// Textures as glTF texture JSON; `source` refers to [`Scene::images`], `sampler` to [`Scene::samplers`].
    pub textures: Vec<Value>,
    /// Samplers as glTF sampler JSON.
    pub samplers: Vec<Value>,
    /// Images with their bytes or the file they come from.
    pub images: Vec<Image>,
    /// Accessors kept verbatim for what is passed through (skins, animations, morph targets, raw primitives).
    pub accessors: Vec<RawAccessor>,
    /// Cameras as glTF JSON.
    pub cameras: Vec<Value>,
    /// Skins as glTF JSON; `inverseBindMatrices` refers to [`Scene::accessors`], `joints`/`skeleton` to nodes.
    pub skins: Vec<Value>,
    /// Animations as glTF JSON; sampler `input`/`output` refer to [`Scene::accessors`], channel targets to nodes.
    pub animations: Vec<Value>,
    /// Root-level `extensions` object (lights, variants...), kept as is.
    pub extensions: Option<Map<String, Value>>,
    /// Root-level `extras`.
    pub extras: Option<Value>,
    /// `extensionsUsed` of the input; the writer keeps the ones still present in the output.
    pub extensions_used: Vec<String>,
    /// `extensionsRequired` of the input; the writer keeps the ones still used.
    pub extensions_required: Vec<String>,
    /// The input asset's `copyright`, if any.
    pub copyright: Option<String>,
    /// What the reader could not keep or had to change, for the user.
    pub warnings: Vec<String>,
    /// Files the reader read besides the input itself (external buffers,
    /// MTL libraries), sorted. Image files are in [`Scene::images`]; see
    /// [`Scene::referenced_files`].
    pub sources: Vec<PathBuf>,
}

impl Scene {
    /// Every file the asset refers to and the reader used: [`Scene::sources`]
    /// and the images read from files, sorted, without repeats.
    pub fn referenced_files(&self) -> Vec<PathBuf> {
        let mut out = self.sources.clone();
        for img in &self.images {
            if let ImageSource::File(p) = &img.source {
                out.push(p.clone());
            }
        }
        out.sort();
        out.dedup();
        out
    }
}

/// A glTF scene: a set of root nodes.
#[derive(Clone, Debug, Default)]
pub struct SceneRoot {
    /// Scene name.
    pub name: Option<String>,
    /// Root node indices.
    pub nodes: Vec<usize>,
    /// Anything else of the scene object (extras, extensions), kept as is.
    pub rest: Map<String, Value>,
}

/// A node's local transform.
#[derive(Clone, Debug, PartialEq)]
pub enum Transform {
    /// Column-major 4x4 matrix.
    Matrix([f64; 16]),
    /// Translation, rotation (quaternion x, y, z, w) and scale; `None` means the default.
    Trs {
        /// Translation.
        translation: Option<[f64; 3]>,
        /// Rotation quaternion (x, y, z, w).
        rotation: Option<[f64; 4]>,
        /// Scale.
        scale: Option<[f64; 3]>,
    },
}

impl Default for Transform {
    fn default() -> Self {
        Transform::Trs {
            translation: None,
            rotation: None,
            scale: None,
        }
    }
}

impl Transform {
    /// The transform as a column-major 4x4 matrix.
    pub fn matrix(&self) -> [f64; 16] {
        match self {
            Transform::Matrix(m) => *m,
            Transform::Trs {
                translation,
                rotation,
                scale,
            } => {
                let t = translation.unwrap_or([0.0; 3]);
                let [x, y, z, w] = rotation.unwrap_or([0.0, 0.0, 0.0, 1.0]);
                let s = scale.unwrap_or([1.0; 3]);
                let r = [
                    [
                        1.0 - 2.0 * (y * y + z * z),
                        2.0 * (x * y + z * w),
                        2.0 * (x * z - y * w),
                    ],
                    [
                        2.0 * (x * y - z * w),
                        1.0 - 2.0 * (x * x + z * z),
                        2.0 * (y * z + x * w),
                    ],
                    [
                        2.0 * (x * z + y * w),
                        2.0 * (y * z - x * w),
                        1.0 - 2.0 * (x * x + y * y),
                    ],
                ];
                [
                    r[0][0] * s[0],
                    r[0][1] * s[0],
                    r[0][2] * s[0],
                    0.0,
                    r[1][0] * s[1],
                    r[1][1] * s[1],
                    r[1][2] * s[1],
                    0.0,
                    r[2][0] * s[2],
                    r[2][1] * s[2],
                    r[2][2] * s[2],
                    0.0,
                    t[0],
                    t[1],
                    t[2],
                    1.0,
                ]
            }
        }
    }
}

/// One node of the hierarchy.
#[derive(Clone, Debug, Default)]
pub struct Node {
    /// Node name.
    pub name: Option<String>,
    /// Local transform.
    pub transform: Transform,
    /// Child node indices.
    pub children: Vec<usize>,
    /// Mesh index.
    pub mesh: Option<usize>,
    /// Camera index.
    pub camera: Option<usize>,
    /// Skin index.
    pub skin: Option<usize>,
    /// Morph target weights.
    pub weights: Option<Vec<f64>>,
    /// `extensions` and `extras` of the node, kept as is.
    pub rest: Map<String, Value>,
}

/// A mesh: a list of primitives drawn with one transform.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Mesh name.
    pub name: Option<String>,
    /// Primitives.
    pub primitives: Vec<Primitive>,
    /// Default morph weights.
    pub weights: Option<Vec<f64>>,
    /// `extensions` and `extras` of the mesh, kept as is.
    pub rest: Map<String, Value>,
}

impl Mesh {
    /// Whether any primitive of this mesh is crackable triangle geometry.
    pub fn has_triangles(&self) -> bool {
        self.primitives
            .iter()
            .any(|p| matches!(p.geometry, Geometry::Triangles(_)))
    }
}

/// One draw call: geometry with a material.
#[derive(Clone, Debug)]
pub struct Primitive {
    /// Material index.
    pub material: Option<usize>,
    /// The geometry.
    pub geometry: Geometry,
    /// `extensions` and `extras` of the primitive, kept as is (material references
    /// inside `KHR_materials_variants` refer to [`Scene::materials`]).
    pub rest: Map<String, Value>,
}

/// Primitive topology modes of glTF.
pub mod mode {
    /// POINTS
    pub const POINTS: u32 = 0;
    /// LINES
    pub const LINES: u32 = 1;
    /// LINE_LOOP
    pub const LINE_LOOP: u32 = 2;
    /// LINE_STRIP
    pub const LINE_STRIP: u32 = 3;
    /// TRIANGLES
    pub const TRIANGLES: u32 = 4;
    /// TRIANGLE_STRIP
    pub const TRIANGLE_STRIP: u32 = 5;
    /// TRIANGLE_FAN
    pub const TRIANGLE_FAN: u32 = 6;
}

/// Geometry of a primitive.
#[derive(Clone, Debug)]
pub enum Geometry {
    /// Crackable triangles, decoded.
    Triangles(TriGeometry),
    /// Passed through unchanged: attribute and index accessors refer to [`Scene::accessors`].
    Raw(RawGeometry),
}

/// A triangle list with decoded vertex attributes (and morph targets).
#[derive(Clone, Debug, Default)]
pub struct TriGeometry {
    /// Vertex positions (mesh-local).
    pub positions: Vec<[f32; 3]>,
    /// Other vertex attributes (NORMAL, TANGENT, TEXCOORD_n, COLOR_n, custom `_X`), as float components.
    pub attributes: Vec<VertexAttribute>,
    /// Triangles as vertex indices, counter-clockwise front faces.
    pub triangles: Vec<[u32; 3]>,
    /// Morph targets: per target, attribute displacements (`POSITION`, `NORMAL`,
    /// `TANGENT`) per vertex. They are interpolated like any other attribute.
    pub targets: Vec<Vec<VertexAttribute>>,
    /// Name of the OBJ group (or glTF primitive) the triangles come from, if any.
    pub group: Option<String>,
}

impl TriGeometry {
    /// The attribute with this semantic, if present.
    pub fn attribute(&self, semantic: &str) -> Option<&VertexAttribute> {
        self.attributes.iter().find(|a| a.semantic == semantic)
    }
}

/// One vertex attribute stored as `components` floats per vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexAttribute {
    /// glTF semantic (`NORMAL`, `TEXCOORD_0`, `COLOR_0`, `_CUSTOM`...).
    pub semantic: String,
    /// Components per vertex (1 to 4).
    pub components: usize,
    /// `components * vertex count` values.
    pub data: Vec<f32>,
}

impl VertexAttribute {
    /// Number of vertices this attribute covers.
    pub fn len(&self) -> usize {
        self.data.len() / self.components.max(1)
    }
    /// True when there is no vertex.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
    /// The components of vertex `i`.
    pub fn get(&self, i: usize) -> &[f32] {
        &self.data[i * self.components..(i + 1) * self.components]
    }
}

/// Geometry passed through with its original accessors.
#[derive(Clone, Debug, Default)]
pub struct RawGeometry {
    /// Topology mode (see [`mode`]).
    pub mode: u32,
    /// Attribute semantic to accessor index.
    pub attributes: BTreeMap<String, usize>,
    /// Index accessor.
    pub indices: Option<usize>,
    /// Morph targets: semantic to accessor index.
    pub targets: Vec<BTreeMap<String, usize>>,
}

/// A material: its glTF JSON with texture indices into [`Scene::textures`].
#[derive(Clone, Debug, Default)]
pub struct Material {
    /// The material object (name, pbrMetallicRoughness, normalTexture, extensions...).
    pub json: Map<String, Value>,
}

impl Material {
    /// The material's name.
    pub fn name(&self) -> Option<&str> {
        self.json.get("name").and_then(Value::as_str)
    }
}

/// An image and where its bytes are.
#[derive(Clone, Debug)]
pub struct Image {
    /// Image name.
    pub name: Option<String>,
    /// MIME type, if known (`image/png`, `image/jpeg`...).
    pub mime_type: Option<String>,
    /// The bytes, or the file that holds them.
    pub source: ImageSource,
    /// A file name to use when the image is written beside a `.gltf` (no folders).
    pub file_name: String,
    /// `extensions` and `extras` of the image, kept as is.
    pub rest: Map<String, Value>,
}

/// Where an image's bytes are.
#[derive(Clone, Debug)]
pub enum ImageSource {
    /// In memory (embedded in a GLB or data URI).
    Bytes(Vec<u8>),
    /// A file on disk, already checked to lie inside the asset's folder.
    File(PathBuf),
}

/// An accessor kept verbatim: tightly packed data of its component type.
#[derive(Clone, Debug)]
pub struct RawAccessor {
    /// glTF componentType (5120..5126).
    pub component_type: u32,
    /// glTF type (`SCALAR`, `VEC3`, `MAT4`...).
    pub kind: String,
    /// Whether integer data is normalized.
    pub normalized: bool,
    /// Element count.
    pub count: usize,
    /// `min`, if present in the input.
    pub min: Option<Value>,
    /// `max`, if present in the input.
    pub max: Option<Value>,
    /// Name, if any.
    pub name: Option<String>,
    /// `count * element size` bytes, tightly packed (each matrix column padded as glTF requires).
    pub data: Vec<u8>,
}

impl Scene {
    /// Number of triangles in crackable primitives, counted once per mesh (not per instance).
    pub fn triangle_count(&self) -> usize {
        self.meshes
            .iter()
            .flat_map(|m| &m.primitives)
            .map(|p| match &p.geometry {
                Geometry::Triangles(t) => t.triangles.len(),
                Geometry::Raw(_) => 0,
            })
            .sum()
    }

    /// Nodes that have no parent, in index order.
    pub fn root_nodes(&self) -> Vec<usize> {
        let mut has_parent = vec![false; self.nodes.len()];
        for n in &self.nodes {
            for &c in &n.children {
                if c < has_parent.len() {
                    has_parent[c] = true;
                }
            }
        }
        (0..self.nodes.len()).filter(|&i| !has_parent[i]).collect()
    }

    /// World matrices (column-major) of the nodes that instance mesh `mesh`,
    /// in depth-first order from the roots of the default scene (the first
    /// scene when none is default; every root node when there are no
    /// scenes). Empty when no node uses the mesh. A hierarchy deeper than the
    /// node count (a cycle) is not followed further.
    pub fn mesh_world_matrices(&self, mesh: usize) -> Vec<[f64; 16]> {
        let roots = match self
            .default_scene
            .and_then(|s| self.scenes.get(s))
            .or(self.scenes.first())
        {
            Some(s) => s.nodes.clone(),
            None => self.root_nodes(),
        };
        let mut out = Vec::new();
        let mut stack: Vec<(usize, [f64; 16], usize)> =
            roots.iter().rev().map(|&r| (r, IDENTITY, 0)).collect();
        while let Some((n, parent, depth)) = stack.pop() {
            let Some(node) = self.nodes.get(n) else {
                continue;
            };
            if depth > self.nodes.len() {
                continue;
            }
            let world = mat4_mul(&parent, &node.transform.matrix());
            if node.mesh == Some(mesh) {
                out.push(world);
            }
            for &c in node.children.iter().rev() {
                stack.push((c, world, depth + 1));
            }
        }
        out
    }
}

/// The 4x4 identity, column-major.
pub const IDENTITY: [f64; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

/// `a * b` for column-major 4x4 matrices.
pub fn mat4_mul(a: &[f64; 16], b: &[f64; 16]) -> [f64; 16] {
    std::array::from_fn(|i| {
        let (col, row) = (i / 4, i % 4);
        (0..4).map(|k| a[k * 4 + row] * b[col * 4 + k]).sum()
    })
}
