//! Stress tensors and (in later stages) stress initialisers and evolution terms.

pub mod tensor;

pub use tensor::{Sym2, Sym3};
