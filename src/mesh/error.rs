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
    #[error("invalid option: {fault}")]
    InvalidOption {
        /// Which option, and how.
        fault: OptionFault,
    },
    /// An edit was asked for something impossible (boundary edge to open,
    /// parameter out of range, id out of range).
    #[error("invalid mesh edit: {0}")]
    InvalidEdit(String),
    /// A mesh invariant does not hold (reported by
    /// [`SimMesh::validate`](super::SimMesh::validate)).
    #[error("mesh invariant violated: {0}")]
    Invariant(String),
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
