//! Geometric helpers shared by the readers and the mesh code.

pub mod triangulate;

pub use triangulate::{newell_normal, triangulate_polygon};
