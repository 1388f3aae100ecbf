//! crackle: grow physically plausible surface crack patterns on 3D meshes and
//! write cracked glTF.
//!
//! Pipeline of one asset: read into a [`scene::Scene`], weld each
//! crackable mesh into a simulation mesh, simulate, write glTF.
//! The library does no printing; the binary owns files, progress and exit codes.
//!
//! # The front door
//!
//! [`read`] or [`read_bytes`] an asset, pick a [`Pipeline`] (a built-in
//! preset or your own TOML), [`run`] it on the scene, [`write()`] or
//! [`write_bytes`] the result; or [`crack_file`] does all of it from file to
//! file. [`scene`] is the data model a run works on, [`error`] every error
//! by its layer. The machinery below them is private (public only with the
//! `internals` feature, for the crate's own tests and tools, with no
//! stability promise).
//!
//! ```no_run
//! use crackle::{Config, Pipeline};
//!
//! # fn main() -> crackle::Result<()> {
//! let mut scene = crackle::read("teapot.obj".as_ref())?;
//! let pipeline = Pipeline::preset("glaze", &["simulation.seed=7".into()])?;
//! let config = Config::in_memory(pipeline, "teapot.obj");
//! let report = crackle::run(&mut scene, &config, &mut crackle::Quiet)?;
//! println!("{} cracks", report.cracks);
//! // What each post stage did, typed: here the maps baked per material.
//! if let Some(bake) = &report.meshes[0].post.bake {
//!     println!("baked in {:.1} s", bake.seconds);
//! }
//! let glb: Vec<u8> = crackle::write_bytes(&scene)?;
//! # let _ = glb;
//! # Ok(())
//! # }
//! ```
//!
//! `examples/library.rs` runs both ways, file to file and in memory.
#![warn(missing_docs)]
// Without `internals` the machinery is private, and what only the crate's
// own tests and tools reach (re-exports, helpers) is unused from here.
#![cfg_attr(not(feature = "internals"), allow(dead_code, unused_imports))]
// Every type a user can reach through the front door can be named there
// (`report`, `options`, `error`), so a run's report or an error's fault
// can be matched, stored and documented.
#![cfg_attr(not(feature = "internals"), deny(unnameable_types))]

/// The machinery below the front door: `pub(crate)`, so refactoring it
/// breaks no user; public with the `internals` feature, which the crate's
/// own tests, benchmarks and tools turn on (a dev-dependency on itself) and
/// which carries no stability promise.
macro_rules! internal {
    ($($m:ident),* $(,)?) => {
        $(
            #[cfg(feature = "internals")]
            pub mod $m;
            #[cfg(not(feature = "internals"))]
            pub(crate) mod $m;
        )*
    };
}

internal!(
    batch, bridge, compare, geometry, io, math, mesh, pipeline, post, sim, stats, stress, study
);

pub mod error;
pub mod scene;

#[cfg(feature = "cli")]
mod cli;

/// The `crackle` command line on the process's arguments (the binary's
/// `main`): runs the command and returns its exit code (0 ok, 1 processing
/// failed, 2 bad usage or configuration).
#[cfg(feature = "cli")]
pub use cli::main as command_line;

pub use error::{Error, Result};
pub use io::gltf_write::WriteSummary;
pub use io::ReadOptions;
pub use pipeline::{
    crack_file, run, Config, CrackReport, Frames, MeshRun, Observer, Pipeline, PostReport,
    RunReport,
};
pub use scene::Scene;

/// What a run reports: the whole run ([`RunReport`]), each mesh's
/// simulation and post stages, the frames, a file-to-file run
/// ([`CrackReport`]). Every field is public; the same structure is the
/// command line's `--report` JSON.
pub mod report {
    pub use crate::mesh::remesh::RemeshReport;
    pub use crate::mesh::DefectReport;
    pub use crate::pipeline::{
        AtlasReport, BakeReport, BeforeAfter, CrackReport, CutReport, FramesReport, GapReport,
        IslandsReport, MarginReport, MaterialBake, MeshBake, MeshRun, PathsReport, PostReport,
        Remeshed, RunReport, Stage, StartEnd, SurfaceReport, TearReport, WallsReport,
    };
    pub use crate::sim::ductile::DuctileReport;
    pub use crate::sim::{FilmSolves, FinishReport, Phase, SimReport};
}

/// The options a [`Pipeline`] holds, by section of its TOML (`select`,
/// `simulation`, `stress`, `post`), and those of reading and welding. A
/// pipeline is usually made from a preset or a TOML file with
/// `key=value` overrides ([`Pipeline::preset`], [`Pipeline::parse`]); its
/// fields may also be changed in code before [`run`], which checks them
/// again.
pub mod options {
    pub use crate::io::ReadOptions;
    pub use crate::mesh::WeldOptions;
    pub use crate::pipeline::{Frames, MaskSpec, Select, StressEntry};
    pub use crate::post::options::Post;
    pub use crate::sim::crack::CrackRules;
    pub use crate::sim::ductile::{DuctileParams, Pull, PullMode};
    pub use crate::sim::params::{
        DryingLaw, FilmPreconditioner, Integrator, Model, Propagation, Relaxation, SimParams,
        SpringParams,
    };
    pub use crate::stress::{CurvatureMeasure, CurvatureScale};
    // The constants the options' documentation names.
    pub use crate::pipeline::BUILTIN_IMAGES;
    pub use crate::post::options::{BAKE_SIZE_CAP, BAKE_TEXELS_PER_CRACK, BAKE_WIDTH_OF_DIAGONAL};
    pub use crate::sim::params::{AUTO_STEP_LIMIT, RKL_MAX_STAGES};
    pub use crate::stress::field::BEND_RADIUS_CELLS;
}

use std::path::Path;

/// An [`Observer`] that ignores everything (no progress display).
#[derive(Clone, Copy, Debug, Default)]
pub struct Quiet;

impl Observer for Quiet {}

/// Read an asset file: OBJ (with its MTL and textures), glTF or GLB, by
/// extension; files it names are read only from its folder.
///
/// # Errors
/// A clear [`Error`] naming the file and element when the file cannot be
/// read, is malformed, or needs an extension the tool cannot decode.
pub fn read(path: &Path) -> Result<Scene> {
    Ok(io::read(path)?)
}

/// Read an asset held in memory: a GLB, a glTF JSON document whose buffers
/// and images are embedded (`data:` URIs), or OBJ text without a material
/// library; `name` names it in messages. Nothing is read from disk: a
/// document that names another file is refused.
///
/// # Errors
/// Those of [`read`], and a reference to a file.
pub fn read_bytes(bytes: &[u8], name: &str) -> Result<Scene> {
    let path = Path::new(name);
    let refuse = |uri: String| {
        Err(Error::from(io::IoError::NamesFile {
            path: path.to_path_buf(),
            uri,
        }))
    };
    let text = bytes.trim_ascii_start();
    if bytes.starts_with(b"glTF") || text.starts_with(b"{") {
        let json: Option<serde_json::Value> = if bytes.starts_with(b"glTF") {
            io::gltf_read::split_glb(bytes)
                .ok()
                .and_then(|g| serde_json::from_slice(&g.json).ok())
        } else {
            serde_json::from_slice(bytes).ok()
        };
        if let Some(uri) = json
            .as_ref()
            .and_then(|j| io::gltf_read::file_uris(j).first().map(|u| u.to_string()))
        {
            return refuse(uri);
        }
        // Malformed documents are reported by the reader itself.
        return Ok(io::gltf_read::read_gltf_bytes(bytes, Path::new(""), path)?);
    }
    let text = std::str::from_utf8(bytes).map_err(|error| io::IoError::NotText {
        path: path.to_path_buf(),
        error,
    })?;
    Ok(io::obj::read_obj_from_memory(text, name)?)
}

/// Write `scene` to `path`: `.glb`, or `.gltf` with its buffer and images
/// beside it; nothing is left behind on error.
///
/// # Errors
/// An extension other than `.gltf`/`.glb`, a non-finite value, an image
/// that cannot be read, or a file that cannot be written.
pub fn write(scene: &Scene, path: &Path) -> Result<WriteSummary> {
    pipeline::write_output(scene, path, false)
}

/// `scene` as the bytes of a self-contained `.glb`.
///
/// # Errors
/// A non-finite value, or an image that cannot be read or has an unknown type.
pub fn write_bytes(scene: &Scene) -> Result<Vec<u8>> {
    Ok(io::gltf_write::glb_scene_bytes(
        scene,
        Path::new("scene.glb"),
    )?)
}
