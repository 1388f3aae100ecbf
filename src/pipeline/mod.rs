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
mod margin;
mod memory;
mod output;
mod params;
pub mod post;
mod post_report;
mod primitives;
mod report;
mod run;
mod stress_entry;
mod tear;
mod tear_embed;
mod tear_solid;

pub use config::*;
pub use frames::Frames;
pub use output::write_output;
pub use params::fixed_groups;
pub use post_report::{
    AtlasReport, BakeReport, CutReport, GapReport, IslandsReport, MarginReport, MaterialBake,
    MeshBake, PathsReport, PostReport, SurfaceReport, TearReport, WallsReport,
};
pub use report::{
    BeforeAfter, CrackReport, FramesReport, MeshRun, Remeshed, RunReport, Stage, StartEnd,
};
pub use run::{crack_file, prepare, read_crackable, run, stress_field, Config, Observer, Prepared};

impl Config {
    /// A run of `pipeline` on a scene held in memory: `name` names the
    /// asset in messages; default welding and reading, no time-lapse (a
    /// time-lapse is written beside [`Config::output`]).
    pub fn in_memory(pipeline: Pipeline, name: &str) -> Config {
        Config {
            pipeline,
            weld: crate::mesh::WeldOptions::default(),
            asset: std::path::PathBuf::from(name),
            frames: None,
            output: std::path::PathBuf::from(name).with_extension("glb"),
            read: crate::io::ReadOptions::default(),
        }
    }
}
