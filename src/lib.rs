//! crackle: grow physically plausible surface crack patterns on 3D meshes and
//! write cracked glTF.
//!
//! Pipeline of one asset: read ([`io`]) into a [`scene::Scene`], weld each
//! crackable mesh into a simulation mesh ([`mesh`]), simulate, write glTF.
//! The library does no printing; the binary owns files, progress and exit codes.
#![warn(missing_docs)]

pub mod batch;
pub mod bridge;
pub mod compare;
pub mod error;
pub mod geometry;
pub mod io;
pub mod math;
pub mod mesh;
pub mod pipeline;
pub mod post;
pub mod scene;
pub mod sim;
pub mod stats;
pub mod stress;
pub mod study;

pub use error::{Error, Result};
