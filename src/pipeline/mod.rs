//! The run of one asset: the pipeline it follows ([`Pipeline`], from TOML
//! or a preset), [`run`] on a scene in memory and [`crack_file`] from a
//! file to a file, the post-processing stages ([`post`]), piece splitting
//! and time-lapse frames.

mod attributes;
mod bake;
mod config;
pub mod frames;
mod islands;
mod keep;
mod memory;
pub mod post;
mod run;
mod tear;

pub use config::*;
pub use frames::Frames;
pub use run::{
    crack_file, fixed_groups, prepare, read_crackable, run, stress_field, write_output,
    BeforeAfter, Config, CrackReport, FramesReport, MeshRun, Observer, Prepared, Remeshed,
    RunReport, Stage, StartEnd,
};
