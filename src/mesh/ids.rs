//! Typed element ids of a [`SimMesh`](super::SimMesh).
//!
//! Every id is a `u32` newtype so that vertex, face, halfedge and wedge
//! indices cannot be mixed up. Use [`idx`](VertexId::idx) to index arrays
//! that a caller keeps in parallel with the mesh (per-vertex or per-face
//! simulation state).

use serde::{Deserialize, Serialize};

/// Sentinel for "no element" in the mesh's internal `u32` arrays.
pub(crate) const INVALID: u32 = u32::MAX;

macro_rules! define_id {
    ($(#[$doc:meta])* $name:ident, $prefix:literal) => {
        $(#[$doc])*
        #[derive(
            Copy, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Serialize, Deserialize,
        )]
        #[serde(transparent)]
        pub struct $name(pub u32);

        impl $name {
            /// The id as an array index.
            #[inline]
            pub fn idx(self) -> usize {
                self.0 as usize
            }

            /// The id of array index `i`.
            ///
            /// # Panics
            /// If `i` does not fit in a `u32` below the internal sentinel.
            #[inline]
            pub fn from_idx(i: usize) -> Self {
                assert!(i < INVALID as usize, "mesh index {i} out of u32 range");
                Self(i as u32)
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, concat!($prefix, "{}"), self.0)
            }
        }
    };
}

define_id!(
    /// A vertex of a `SimMesh`.
    VertexId,
    "v"
);
define_id!(
    /// A triangle of a `SimMesh`.
    FaceId,
    "f"
);
define_id!(
    /// A halfedge of a `SimMesh`: halfedge `3f + k` is the
    /// `k`-th edge of face `f`.
    HalfedgeId,
    "h"
);
define_id!(
    /// A wedge (set of per-corner attribute values) of a
    /// [`SimMesh`](super::SimMesh).
    WedgeId,
    "w"
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_roundtrip_and_display() {
        let v = VertexId::from_idx(7);
        assert_eq!(v.idx(), 7);
        assert_eq!(v.to_string(), "v7");
        assert_eq!(FaceId(3).to_string(), "f3");
        assert_eq!(HalfedgeId(1).to_string(), "h1");
        assert_eq!(WedgeId(0).to_string(), "w0");
        assert!(VertexId(1) < VertexId(2));
    }
}
