//! Stress tensors and (in later stages) stress initialisers and evolution terms.

pub mod field;
pub mod tensor;
pub mod texture;

pub use field::{CurvatureMeasure, CurvatureScale, StressField, Term, TermKind};
pub use tensor::{Sym2, Sym3};
