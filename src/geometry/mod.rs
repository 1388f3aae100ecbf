//! Geometric helpers shared by the readers, the writer and the mesh code.

pub mod adjacency;
pub mod curvature;
pub mod element;
pub mod normals;
pub mod tangents;
pub mod triangulate;

pub use triangulate::{newell_normal, triangulate_polygon};
