//! What the stress terms share: a face's centroid and normal, vectors in
//! its plane, and the terms' error.

use crate::math::v3;
use crate::mesh::{FaceId, SimMesh};

/// Errors in a term's values.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FieldError {
    /// A value is out of range; the message names it.
    #[error("{0}")]
    Invalid(String),
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
