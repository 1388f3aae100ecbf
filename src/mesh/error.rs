//! Errors of mesh building, editing and validation.

/// What can go wrong when building, editing or validating a
/// [`SimMesh`](super::SimMesh).
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
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// An edit was asked for something impossible (boundary edge to open,
    /// parameter out of range, id out of range).
    #[error("invalid mesh edit: {0}")]
    InvalidEdit(String),
    /// A mesh invariant does not hold (reported by
    /// [`SimMesh::validate`](super::SimMesh::validate)).
    #[error("mesh invariant violated: {0}")]
    Invariant(String),
}
