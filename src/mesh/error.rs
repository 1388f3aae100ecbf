//! Errors of mesh building, editing and validation.

use super::ids::{FaceId, HalfedgeId, VertexId};

/// What can go wrong when building, editing or validating a
/// `SimMesh`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The input has no vertices or no triangles.
    #[error("mesh input is empty ({vertices} vertices, {triangles} triangles)")]
    EmptyInput {
        /// Number of input vertices.
        vertices: usize,
        /// Number of input triangles.
        triangles: usize,
    },
    /// Every input triangle is degenerate (repeated, coincident or
    /// non-finite corners, or zero area).
    #[error("all {dropped} triangles of the mesh are degenerate")]
    AllDegenerate {
        /// Number of triangles dropped.
        dropped: usize,
    },
    /// A triangle references a vertex that does not exist.
    #[error("triangle {triangle} references vertex {index} but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        /// The input triangle.
        triangle: usize,
        /// The offending vertex index.
        index: u32,
        /// Number of input vertices.
        vertices: usize,
    },
    /// An input array has the wrong length.
    #[error("{what} has {got} entries, expected {expected}")]
    LengthMismatch {
        /// Which array (e.g. `face_groups`, `wedge channel "NORMAL"`).
        what: String,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// An option value is invalid.
    #[error("invalid option: {fault}")]
    InvalidOption {
        /// Which option, and how.
        fault: OptionFault,
    },
    /// An edit was asked for something impossible (boundary edge to open,
    /// parameter out of range, id out of range).
    #[error("invalid mesh edit: {fault}")]
    InvalidEdit {
        /// What was asked, and why it cannot be done.
        fault: EditFault,
    },
    /// A mesh invariant does not hold (reported by
    /// `SimMesh::validate`).
    #[error("mesh invariant violated: {fault}")]
    Invariant {
        /// The first invariant found broken.
        fault: InvariantFault,
    },
}

/// A broken invariant of the half-edge mesh ([`MeshError::Invariant`]):
/// an internal fault, never the input's (the input's defects are repaired
/// or refused before the mesh is built).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvariantFault {
    /// Not three halfedges per face.
    #[error("{halfedges} halfedges for {faces} faces")]
    HalfedgeCount {
        /// Halfedges.
        halfedges: usize,
        /// Faces.
        faces: usize,
    },
    /// A per-element array whose length is not its elements' count.
    #[error("{array} has {len} entries for {count} {elements}")]
    ArrayLength {
        /// The array.
        array: &'static str,
        /// Its length.
        len: usize,
        /// The elements' count.
        count: usize,
        /// Which elements (`halfedges`, `faces`, `vertices`).
        elements: &'static str,
    },
    /// A crack halfedge with a twin.
    #[error("a crack halfedge has a twin")]
    CrackTwin,
    /// The wedges' attribute channels of different lengths.
    #[error("wedge channel lengths do not match {wedges} wedges")]
    WedgeChannels {
        /// Wedges.
        wedges: usize,
    },
    /// More halfedges than ids.
    #[error("too many halfedges")]
    TooManyHalfedges,
    /// A vertex position that is not finite.
    #[error("vertex {vertex} has non-finite position {position:?}")]
    NonFinite {
        /// The vertex.
        vertex: usize,
        /// Its position.
        position: [f64; 3],
    },
    /// An id an element holds out of range.
    #[error("{element} {index} has {field} {value} out of range ({count})")]
    OutOfRange {
        /// The holder (`vertex`, `halfedge`).
        element: &'static str,
        /// Its index.
        index: usize,
        /// The id's field (`outgoing halfedge`, `parent`, `origin`, `wedge`, `twin`).
        field: &'static str,
        /// The id.
        value: u32,
        /// The count it must be below.
        count: usize,
    },
    /// A face with a vertex twice.
    #[error("face {face} has repeated vertex: {} {} {}", vertices[0], vertices[1], vertices[2])]
    RepeatedVertex {
        /// The face.
        face: FaceId,
        /// Its corners.
        vertices: [VertexId; 3],
    },
    /// A halfedge whose `next` does not cycle in three within its face.
    #[error("halfedge {0}: next^3 != id")]
    NextCycle(HalfedgeId),
    /// A halfedge that is its own twin.
    #[error("halfedge {0} is its own twin")]
    SelfTwin(HalfedgeId),
    /// Twins that are not each other's.
    #[error("twin of {halfedge} is {twin} but twin of {twin} is not {halfedge}")]
    TwinAsymmetric {
        /// The halfedge.
        halfedge: HalfedgeId,
        /// Its twin.
        twin: HalfedgeId,
    },
    /// Twins that do not run opposite ways along one edge.
    #[error("halfedge {halfedge} ({} -> {}) and twin {twin} ({} -> {}) not opposite", ends[0], ends[1], twin_ends[0], twin_ends[1])]
    TwinNotOpposite {
        /// The halfedge.
        halfedge: HalfedgeId,
        /// Its ends.
        ends: [VertexId; 2],
        /// Its twin.
        twin: HalfedgeId,
        /// The twin's ends.
        twin_ends: [VertexId; 2],
    },
    /// Two halfedges from one vertex to one other.
    #[error("halfedges h{} and h{} both go from v{from} to v{to}", halfedges[0], halfedges[1])]
    DuplicateEdge {
        /// The two halfedges.
        halfedges: [u32; 2],
        /// Where they start.
        from: u32,
        /// Where they end.
        to: u32,
    },
    /// A vertex's outgoing halfedge that starts elsewhere.
    #[error("outgoing halfedge {halfedge} of vertex {vertex} leaves {leaves}")]
    OutgoingElsewhere {
        /// The vertex.
        vertex: VertexId,
        /// Its outgoing halfedge.
        halfedge: HalfedgeId,
        /// Where that starts.
        leaves: VertexId,
    },
    /// A vertex with several boundary halfedges leaving it.
    #[error("vertex {vertex} has {count} boundary outgoing halfedges (several fans)")]
    SeveralFans {
        /// The vertex.
        vertex: VertexId,
        /// Its boundary outgoing halfedges.
        count: u32,
    },
    /// A boundary vertex whose outgoing halfedge is not the boundary one.
    #[error("vertex {vertex} is on a boundary but its outgoing halfedge {halfedge} is not")]
    BoundaryOutgoing {
        /// The vertex.
        vertex: VertexId,
        /// Its outgoing halfedge.
        halfedge: HalfedgeId,
    },
    /// A vertex's fan that reaches a halfedge leaving another vertex.
    #[error("fan of {vertex} reaches {halfedge} leaving {leaves}")]
    FanStray {
        /// The vertex.
        vertex: VertexId,
        /// The halfedge reached.
        halfedge: HalfedgeId,
        /// Where that starts.
        leaves: VertexId,
    },
    /// A vertex's fan that does not come back to its start.
    #[error("fan of vertex {0} does not close")]
    FanOpen(VertexId),
    /// An interior vertex's fan that ends at a border.
    #[error("fan of interior vertex {vertex} ends at {halfedge}")]
    InteriorFanEnds {
        /// The vertex.
        vertex: VertexId,
        /// Where its fan ends.
        halfedge: HalfedgeId,
    },
    /// A vertex whose faces are more than its one fan (non-manifold).
    #[error("vertex {vertex} has {degree} incident faces but its fan has {fan} (non-manifold)")]
    NonManifoldFan {
        /// The vertex.
        vertex: VertexId,
        /// Its incident faces.
        degree: u32,
        /// Faces in its fan.
        fan: u32,
    },
}

/// An invalid option of a mesh operation ([`MeshError::InvalidOption`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OptionFault {
    /// A weld tolerance that is negative or not finite.
    #[error("relative_tolerance must be finite and >= 0, got {0}")]
    RelativeTolerance(f64),
    /// More vertices or triangles than the ids can hold.
    #[error("mesh too large ({vertices} vertices, {triangles} triangles)")]
    TooLarge {
        /// The input's vertices.
        vertices: usize,
        /// The input's triangles.
        triangles: usize,
    },
    /// A margin width or ring spacing that is not a positive number.
    #[error("a margin needs a positive width and ring spacing, got {width} and {spacing}")]
    MarginSize {
        /// The width.
        width: f64,
        /// The ring spacing.
        spacing: f64,
    },
    /// A margin of more than 1000 rings.
    #[error("a margin of {width} in rings of {spacing} needs {rings} rings (at most 1000)")]
    MarginRings {
        /// The width.
        width: f64,
        /// The ring spacing.
        spacing: f64,
        /// The rings it needs.
        rings: usize,
    },
    /// A remeshing target edge length that is not a positive number.
    #[error("remeshing needs a positive target edge length, got {0}")]
    RemeshTarget(f64),
}

impl From<OptionFault> for MeshError {
    fn from(fault: OptionFault) -> Self {
        MeshError::InvalidOption { fault }
    }
}

/// An impossible mesh edit ([`MeshError::InvalidEdit`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EditFault {
    /// A halfedge id out of range.
    #[error("halfedge {halfedge} out of range ({count} halfedges)")]
    HalfedgeRange {
        /// The id.
        halfedge: HalfedgeId,
        /// The mesh's halfedges.
        count: usize,
    },
    /// A face id out of range.
    #[error("face {face} out of range ({count} faces)")]
    FaceRange {
        /// The id.
        face: FaceId,
        /// The mesh's faces.
        count: usize,
    },
    /// An edge split parameter not strictly inside (0, 1).
    #[error("split_edge parameter {0} not in (0, 1)")]
    SplitParameter(f64),
    /// Face split coordinates not all finite and positive.
    #[error("split_face barycentric coordinates {0:?} must be finite and > 0")]
    Barycentric([f64; 3]),
    /// An edge that cannot be flipped.
    #[error("flip_edge {halfedge}: {why}")]
    Flip {
        /// The edge's halfedge.
        halfedge: HalfedgeId,
        /// Why not.
        why: FlipRefusal,
    },
    /// An edge to open that is already on a boundary.
    #[error("open_edge: halfedge {0} is already on a boundary")]
    AlreadyOpen(HalfedgeId),
    /// Positions of another vertex count.
    #[error("set_positions: {positions} positions for {vertices} vertices")]
    PositionCount {
        /// The positions given.
        positions: usize,
        /// The mesh's vertices.
        vertices: usize,
    },
    /// A position that is not finite.
    #[error("set_positions: vertex {0} is not finite")]
    NotFinite(usize),
    /// Cracks to cut into a mesh without faces.
    #[error("the input mesh has no faces to cut")]
    NoFacesToCut,
    /// Too many crack segments that cannot be cut into the input.
    #[error("{skipped} of {segments} crack segments cannot be cut into the input, e.g. {example}")]
    SkippedSegments {
        /// The segments left out.
        skipped: usize,
        /// All segments.
        segments: usize,
        /// The first one left out.
        example: Box<SkippedSegment>,
    },
}

/// Why an edge cannot be flipped ([`EditFault::Flip`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FlipRefusal {
    /// It is on the boundary.
    #[error("a boundary edge")]
    Boundary,
    /// It is a seam.
    #[error("a seam")]
    Seam,
    /// Its faces are of two groups.
    #[error("faces of two groups")]
    Groups,
    /// Its far corners are already joined.
    #[error("its far corners are already joined")]
    Joined,
}

/// A crack segment that cannot be cut into the input ([`EditFault::SkippedSegments`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("crack segment {index} from {from:?} to {to:?}: {why}")]
pub struct SkippedSegment {
    /// The segment.
    pub index: usize,
    /// Its start.
    pub from: [f64; 3],
    /// Its end.
    pub to: [f64; 3],
    /// Why it cannot be walked.
    pub why: WalkFault,
}

/// Why one crack segment cannot be walked across the input's faces.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum WalkFault {
    /// The walk did not reach its end.
    #[error("the walk did not reach its end")]
    NotReached,
    /// The walk strayed away from its end.
    #[error("the walk strayed away from its end")]
    Strayed,
    /// The walk came back to a vertex.
    #[error("the walk came back to a vertex")]
    CameBack,
    /// The ends are not joined by the input's edges nearby.
    #[error("its ends are not joined by the input's edges nearby")]
    NotJoined,
    /// No edge to cross from a vertex.
    #[error("the walk from vertex {vertex} found no edge to cross")]
    NoEdgeToCross {
        /// The vertex.
        vertex: VertexId,
    },
    /// A vertex without faces.
    #[error("vertex {vertex} has no face to walk through")]
    NoFace {
        /// The vertex.
        vertex: VertexId,
    },
    /// No face of a vertex faces the end.
    #[error("no face of vertex {vertex} faces the crack's end")]
    NoFaceFacing {
        /// The vertex.
        vertex: VertexId,
    },
    /// A split on the way failed.
    #[error(transparent)]
    Split {
        /// The split's error.
        error: Box<MeshError>,
    },
}

impl From<MeshError> for WalkFault {
    fn from(e: MeshError) -> Self {
        WalkFault::Split { error: Box::new(e) }
    }
}

impl From<EditFault> for MeshError {
    fn from(fault: EditFault) -> Self {
        MeshError::InvalidEdit { fault }
    }
}
