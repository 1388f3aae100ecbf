//! The simulation mesh: a welded, manifold half-edge triangle mesh with
//! per-corner attribute wedges, and the local edits the crack engine needs.
//!
//! Modules, one responsibility each:
//! typed ids ([`ids`]), the wedge table ([`attributes`]), the mesh and its
//! queries ([`halfedge`]), building from a [`MeshInput`] with welding and
//! manifold repair ([`build`]), the [`DefectReport`] ([`defects`]), local
//! edits ([`edit`]), the invariant check ([`validate`](mod@validate)) and
//! errors ([`error`]).
//!
//! Input vertices are welded by position within
//! [`WeldOptions::relative_tolerance`] times the bounding-box diagonal; each
//! face corner keeps the input vertex it came from as its wedge, so UV and
//! normal seams survive welding while the surface is joined.

pub mod attributes;
pub mod build;
pub mod defects;
pub mod edit;
pub mod error;
pub mod halfedge;
pub(crate) mod hash;
pub mod ids;
pub mod imprint;
pub mod margin;
pub mod remesh;
mod sizing;
pub(crate) mod spatial;
pub mod validate;
mod weld;

pub mod shapes;

pub use attributes::{Channel, ChannelKind, WedgeAttributes};
pub use build::{MeshInput, WeldOptions};
pub use defects::DefectReport;
pub use edit::{OpenEdgeResult, SplitEdgeResult, SplitFaceResult};
pub use error::{
    EditFault, FlipRefusal, InvariantFault, MeshError, OptionFault, SkippedSegment, WalkFault,
};
pub use halfedge::{SimMesh, VertexOutgoing};
pub use ids::{FaceId, HalfedgeId, VertexId, WedgeId};
