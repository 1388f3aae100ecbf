//! Stress fields: the load terms (shrinkage, grain, rings, impact, curvature,
//! texture masks, noise) that set each triangle's rest stress.

pub mod field;
pub(crate) mod frame;
pub mod geodesic;
pub mod impact;
mod mask_coords;
pub mod texture;

pub use field::{CurvatureMeasure, CurvatureScale, StressField, Term, TermKind};
