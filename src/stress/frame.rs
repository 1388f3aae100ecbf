//! What the stress terms share: a face's centroid and normal, vectors in
//! its plane, and the terms' error.

use crate::math::v3;
use crate::mesh::{FaceId, SimMesh};

/// Errors in a term's values.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FieldError {
    /// A value of a term is out of range.
    #[error("{fault}")]
    Value {
        /// Which value, and how.
        fault: TermFault,
    },
    /// A value of the `index`th term is out of range.
    #[error("stress term {index}: {fault}")]
    Term {
        /// The term (from 0).
        index: usize,
        /// Which value, and how.
        fault: TermFault,
    },
    /// A curvature estimate of another mesh.
    #[error("the curvature estimate has {estimate} faces, the mesh {mesh}")]
    CurvatureFaces {
        /// The estimate's faces.
        estimate: usize,
        /// The mesh's faces.
        mesh: usize,
    },
}

/// A value of a stress term out of range (the value as given).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TermFault {
    /// `init` or `evolve` is not finite.
    #[error("init and evolve weights must be finite numbers")]
    Weights,
    /// A zero or non-finite direction.
    #[error("direction must be a nonzero vector, got {0:?}")]
    Direction([f64; 3]),
    /// `checks` outside 0.5 to 50 cell sizes.
    #[error("checks must be 0.5 to 50 cell sizes long, got {0}")]
    Checks(f64),
    /// A zero or non-finite axis.
    #[error("axis must be a nonzero vector, got {0:?}")]
    Axis([f64; 3]),
    /// A non-finite center.
    #[error("center must be finite, got {0:?}")]
    Center([f64; 3]),
    /// `in_turn` without radial cracks.
    #[error("in_turn needs stars: give 'speed' or 'radial_cracks'")]
    InTurnWithoutStars,
    /// `in_turn` with an `evolve` weight.
    #[error("in_turn hits load at once: give 'init', not 'evolve'")]
    InTurnEvolves,
    /// A radius not above 0.
    #[error("radius must be > 0, got {0}")]
    Radius(f64),
    /// A negative or non-finite `concentric_factor`.
    #[error("concentric_factor must be >= 0, got {0}")]
    ConcentricFactor(f64),
    /// More radial cracks than `max`.
    #[error("radial_cracks must be at most {max}, got {got}")]
    RadialCracks {
        /// The count given.
        got: u32,
        /// The most allowed.
        max: u32,
    },
    /// A non-finite impact point.
    #[error("impact points must be finite")]
    Points,
    /// A negative or non-finite curvature `strength`.
    #[error("strength must be >= 0, got {0}")]
    Strength(f64),
    /// A curvature `max_factor` not above 0.
    #[error("max_factor must be > 0, got {0}")]
    MaxFactor(f64),
    /// The mask samples a UV set the mesh lacks while it has others.
    #[error("the mask samples TEXCOORD_{tex_coord}, which the mesh does not have (it has other UV sets: pick one with the mask's tex_coord)")]
    NoUvSet {
        /// The mask's `tex_coord`.
        tex_coord: u32,
    },
}

impl From<TermFault> for FieldError {
    fn from(fault: TermFault) -> Self {
        FieldError::Value { fault }
    }
}

/// `a` scaled to unit length (`None` when zero or not finite).
pub(super) fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = v3::norm(a);
    (n > 0.0 && n.is_finite()).then(|| v3::scale(a, 1.0 / n))
}

/// Centroid and unit normal of a face (`None` when degenerate).
pub(super) fn face_frame(mesh: &SimMesh, f: FaceId) -> Option<([f64; 3], [f64; 3])> {
    let [a, b, c] = mesh.face_vertices(f).map(|v| mesh.position(v));
    let n = unit(v3::cross(v3::sub(b, a), v3::sub(c, a)))?;
    let centroid = v3::scale(v3::add(v3::add(a, b), c), 1.0 / 3.0);
    Some((centroid, n))
}

/// Project `v` into the plane with unit normal `n`.
pub(super) fn in_plane(v: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    v3::sub(v, v3::scale(n, v3::dot(v, n)))
}
