//! Errors of reading a glTF or GLB document; each names the element (a
//! node, mesh primitive, attribute, buffer, image) by its index.

use crate::io::accessor::AccessorError;
use crate::io::paths::{PathError, MAX_MODEL_BYTES};
use crate::io::PrimitiveBudgetError;
use std::path::PathBuf;

/// A glTF document that cannot be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GltfError {
    /// The GLB container is malformed.
    #[error("invalid GLB container: {0}")]
    Glb(GlbError),
    /// The JSON does not parse.
    #[error("invalid JSON: {0}")]
    Json(serde_json::Error),
    /// The JSON is not an object.
    #[error("the glTF JSON is not an object")]
    NotObject,
    /// A glTF version other than 2.x.
    #[error("unsupported glTF version '{version}' (only 2.x is read)")]
    Version {
        /// The file's `asset.version`.
        version: String,
    },
    /// No `asset.version`.
    #[error("missing asset.version (not a glTF 2.0 file)")]
    NoVersion,
    /// Required extensions that cannot be decoded.
    #[error("requires extension{} {} which crackle cannot decode", if .0.len() > 1 { "s" } else { "" }, .0.join(", "))]
    Extensions(Vec<String>),
    /// More primitives than the memory budget allows.
    #[error(transparent)]
    Primitives(#[from] PrimitiveBudgetError),
    /// A primitive's POSITION names no accessor.
    #[error("mesh {mesh} primitive {primitive}: POSITION accessor {accessor} does not exist ({accessors} accessors)")]
    NoPositionAccessor {
        /// The mesh.
        mesh: usize,
        /// The primitive.
        primitive: usize,
        /// The value given (as JSON).
        accessor: String,
        /// Accessors in the document.
        accessors: usize,
    },
    /// The JSON is not a glTF document by the schema.
    #[error("invalid glTF JSON: {0}")]
    SchemaJson(serde_json::Error),
    /// The schema's checks failed (the first five are kept).
    #[error("invalid glTF ({count} error{}): {}", if *count > 1 { "s" } else { "" }, errors.join("; "))]
    Schema {
        /// How many checks failed.
        count: usize,
        /// The first of them (path and error).
        errors: Vec<String>,
    },
    /// The error of one element of the document.
    #[error("{at}: {error}")]
    At {
        /// The element.
        at: Element,
        /// What is wrong with it.
        error: Box<GltfError>,
    },
    /// An accessor cannot be decoded.
    #[error(transparent)]
    Accessor(#[from] AccessorError),
    /// A file reference is refused or cannot be followed.
    #[error(transparent)]
    Reference(#[from] PathError),
    /// A data URI cannot be decoded.
    #[error(transparent)]
    DataUri(#[from] DataUriError),
    /// A file cannot be read.
    #[error("{0}")]
    Read(std::io::Error),
    /// A buffer cannot be loaded.
    #[error("buffer {buffer}: {fault}")]
    Buffer {
        /// The buffer.
        buffer: usize,
        /// What is wrong.
        fault: BufferFault,
    },
    /// A buffer without a URI that is not buffer 0.
    #[error("buffer {0} has no uri (only buffer 0 may refer to the GLB binary chunk)")]
    BufferNoUri(usize),
    /// Buffer 0 without a URI in a file without a binary chunk.
    #[error("buffer {0} has no uri and the file has no GLB binary chunk")]
    NoChunk(usize),
    /// An image has no data.
    #[error("image {0} has neither uri nor bufferView")]
    NoImageSource(usize),
    /// A buffer view does not exist.
    #[error("bufferView {0} does not exist")]
    NoView(usize),
    /// A buffer view lacks a field (`buffer`, `byteLength`).
    #[error("bufferView without {0}")]
    ViewMissing(&'static str),
    /// A buffer view's buffer was not loaded.
    #[error("buffer {0} not loaded")]
    BufferNotLoaded(usize),
    /// A buffer view beyond its buffer.
    #[error("bufferView {view} exceeds buffer {buffer}")]
    ViewOutside {
        /// The view.
        view: usize,
        /// The buffer.
        buffer: usize,
    },
    /// A numeric array (`matrix`, `rotation`...) of the wrong length.
    #[error("'{key}' must have {len} numbers")]
    Numbers {
        /// The key.
        key: &'static str,
        /// The length it must have.
        len: usize,
    },
    /// A numeric array with a non-finite value.
    #[error("'{0}' must hold finite numbers")]
    NotFinite(&'static str),
    /// POSITION is not VEC3.
    #[error("POSITION accessor {accessor} is {kind}, not VEC3")]
    NotVec3 {
        /// The accessor.
        accessor: usize,
        /// Its type.
        kind: String,
    },
    /// A position that is not finite.
    #[error("POSITION accessor {accessor}: vertex {vertex} is not finite")]
    PositionNotFinite {
        /// The accessor.
        accessor: usize,
        /// The vertex.
        vertex: usize,
    },
    /// An attribute with another count than POSITION.
    #[error("{attribute} accessor {accessor} has {count} elements but POSITION has {positions}")]
    Count {
        /// The attribute.
        attribute: String,
        /// Its accessor.
        accessor: usize,
        /// Its count.
        count: usize,
        /// POSITION's count.
        positions: usize,
    },
    /// An index beyond the vertices.
    #[error("indices accessor {accessor}: index {index} out of range ({vertices} vertices)")]
    Index {
        /// The index accessor.
        accessor: usize,
        /// The index.
        index: u32,
        /// The primitive's vertices.
        vertices: usize,
    },
    /// A morph target's attribute that is not an accessor index.
    #[error("morph target {target}: {attribute} is not an accessor index")]
    TargetNotIndex {
        /// The target.
        target: usize,
        /// The attribute.
        attribute: String,
    },
    /// A morph target's attribute with another count than POSITION.
    #[error("morph target {target} {attribute} has {count} elements but POSITION has {positions}")]
    TargetCount {
        /// The target.
        target: usize,
        /// The attribute.
        attribute: String,
        /// Its count.
        count: usize,
        /// POSITION's count.
        positions: usize,
    },
    /// The node hierarchy is not a forest.
    #[error(transparent)]
    Hierarchy(#[from] HierarchyError),
}

impl GltfError {
    /// This error as the error of element `at`.
    pub fn at(self, at: Element) -> GltfError {
        GltfError::At {
            at,
            error: Box::new(self),
        }
    }
}

/// An element of a glTF document, as errors name it.
#[derive(Debug)]
#[non_exhaustive]
pub enum Element {
    /// A node.
    Node(usize),
    /// A skin.
    Skin(usize),
    /// An animation.
    Animation(usize),
    /// An image.
    Image(usize),
    /// An image's file, by its URI.
    ImageFile {
        /// The image.
        index: usize,
        /// Its URI.
        uri: String,
    },
    /// A primitive of a mesh.
    Primitive {
        /// The mesh.
        mesh: usize,
        /// The mesh's name.
        name: Option<String>,
        /// The primitive.
        primitive: usize,
    },
    /// A vertex attribute (`POSITION`, `NORMAL`...).
    Attribute {
        /// The attribute's semantic name.
        semantic: String,
    },
    /// The primitive's indices.
    Indices,
    /// An attribute of a morph target.
    Target {
        /// The target.
        target: usize,
        /// The attribute.
        attribute: String,
    },
}

impl std::fmt::Display for Element {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Element::Node(i) => write!(f, "node {i}"),
            Element::Skin(i) => write!(f, "skin {i}"),
            Element::Animation(i) => write!(f, "animation {i}"),
            Element::Image(i) => write!(f, "image {i}"),
            Element::ImageFile { index, uri } => write!(f, "image {index} ('{uri}')"),
            Element::Primitive {
                mesh,
                name: Some(n),
                primitive,
            } => write!(f, "mesh {mesh} '{n}' primitive {primitive}"),
            Element::Primitive {
                mesh,
                name: None,
                primitive,
            } => write!(f, "mesh {mesh} primitive {primitive}"),
            Element::Attribute { semantic } => write!(f, "{semantic}"),
            Element::Indices => write!(f, "indices"),
            Element::Target { target, attribute } => {
                write!(f, "morph target {target} {attribute}")
            }
        }
    }
}

/// A GLB container that cannot be split into its chunks.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GlbError {
    /// Under 12 bytes.
    #[error("shorter than its 12-byte header")]
    Short,
    /// A length under the header's.
    #[error("the header gives a length of {0} bytes, less than the header itself")]
    Length(u32),
    /// The container's chunks are malformed.
    #[error("{0}")]
    Chunks(gltf::Error),
}

/// A data URI that cannot be decoded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DataUriError {
    /// No comma.
    #[error("malformed data URI")]
    Malformed,
    /// Not base64.
    #[error("data URI is not base64")]
    NotBase64,
    /// Invalid base64.
    #[error("invalid base64 in data URI: {0}")]
    Base64(base64::DecodeError),
}

/// What is wrong with one buffer.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BufferFault {
    /// No `byteLength`.
    #[error("missing byteLength")]
    NoLength,
    /// An external file over the size limit.
    #[error("byteLength {declared} is over the {} GiB limit of a buffer file", MAX_MODEL_BYTES >> 30)]
    TooLarge {
        /// Its declared length.
        declared: u64,
    },
    /// Over the memory budget with the buffers before it.
    #[error("byteLength {declared} (with the buffers before it {total} bytes) is over the memory budget of {max_memory} bytes (--max-memory)")]
    OverBudget {
        /// Its declared length.
        declared: u64,
        /// With the buffers before it.
        total: u64,
        /// The budget.
        max_memory: u64,
    },
    /// A binary chunk shorter than declared.
    #[error("GLB binary chunk holds {holds} bytes but byteLength declares {declared}")]
    ShortChunk {
        /// Bytes the chunk holds.
        holds: usize,
        /// Bytes declared.
        declared: u64,
    },
    /// A data URI too short for the declared length.
    #[error("data URI is shorter than the declared byteLength {declared}")]
    ShortUri {
        /// Bytes declared.
        declared: u64,
    },
    /// A data URI that decodes to fewer bytes than declared.
    #[error("data URI holds {holds} bytes, byteLength declares {declared}")]
    ShortData {
        /// Bytes decoded.
        holds: usize,
        /// Bytes declared.
        declared: u64,
    },
    /// The data URI cannot be decoded.
    #[error("{0}")]
    DataUri(DataUriError),
    /// The file reference is refused.
    #[error("{0}")]
    Reference(PathError),
    /// The file cannot be opened.
    #[error("cannot open '{}': {error}", file.display())]
    Open {
        /// The file.
        file: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// The file is shorter than declared.
    #[error("'{}' has {len} bytes but byteLength declares {declared}", file.display())]
    ShortFile {
        /// The file.
        file: PathBuf,
        /// Its length.
        len: u64,
        /// Bytes declared.
        declared: u64,
    },
    /// The file cannot be read.
    #[error("cannot read '{}': {error}", file.display())]
    ReadFile {
        /// The file.
        file: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
}

/// A node hierarchy that is not a forest.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum HierarchyError {
    /// A child index beyond the nodes.
    #[error("node {node}: child {child} does not exist")]
    NoChild {
        /// The parent.
        node: usize,
        /// The child index.
        child: usize,
    },
    /// A node with two parents.
    #[error("node {0} has more than one parent")]
    TwoParents(usize),
    /// A cycle.
    #[error("node {0} is part of a cycle in the node hierarchy")]
    Cycle(usize),
}
