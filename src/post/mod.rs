//! Post-processing of a cracked simulation mesh (Iben & O'Brien 2009,
//! sec. 5): crack width and curling, side walls, and per-vertex shader
//! attributes. Pure geometry: no I/O, nothing printed.

pub mod bake;
pub mod distance;
pub mod islands;
pub(crate) mod options;
pub mod paths;
pub mod taper;
pub mod walls;
pub mod width;

pub use options::{
    OptionsError, Post, BAKE_SIZE_CAP, BAKE_TEXELS_PER_CRACK, BAKE_WIDTH_OF_DIAGONAL,
};
