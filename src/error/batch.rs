//! Errors of a batch: its inputs ([`InputsError`]), its rules file
//! ([`RulesError`], [`RuleError`]) and the folders and files it reads and
//! writes ([`BatchError`]).

use crate::io::paths::PathError;
use std::path::PathBuf;

/// The inputs or outputs of a batch cannot be used as given (the command
/// line exits with 2 for it).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InputsError {
    /// No input at all.
    #[error("no input: give files, folders or globs")]
    NoInput,
    /// A file that is not a mesh.
    #[error("{spec}: not an .obj, .gltf or .glb file")]
    NotMesh {
        /// The input as given.
        spec: String,
    },
    /// A glob that does not parse.
    #[error("{spec}: invalid glob: {error}")]
    Glob {
        /// The input as given.
        spec: String,
        /// Why it does not parse.
        error: globset::Error,
    },
    /// An input that is neither a file, a folder nor a glob.
    #[error("{spec}: no such file or folder")]
    NotFound {
        /// The input as given.
        spec: String,
    },
    /// An asset's output is one of the inputs.
    #[error("{}: the output {} is an input; choose another --out", input.display(), output.display())]
    OutputIsInput {
        /// The asset's input.
        input: PathBuf,
        /// Its output.
        output: PathBuf,
    },
    /// Two assets would write the same output.
    #[error("{} and {} would both write {}; rename one or split the batch", first.display(), second.display(), output.display())]
    SameOutput {
        /// The first asset's input.
        first: PathBuf,
        /// The second asset's input.
        second: PathBuf,
        /// The output both would write.
        output: PathBuf,
    },
    /// The output folder is an input folder.
    #[error("--out {} is the input folder {spec}: the outputs would be read as inputs next time; choose another folder (one inside it is fine)", out.display())]
    OutIsInput {
        /// The output folder.
        out: PathBuf,
        /// The input folder as given.
        spec: String,
    },
    /// A pipeline's mask image cannot be read (to fingerprint it).
    #[error("{label}: mask image {}: {error}", path.display())]
    MaskImage {
        /// The pipeline's label.
        label: String,
        /// The image.
        path: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
}

/// A rules file cannot be used (the command line exits with 2 for it).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RulesError {
    /// The file cannot be read.
    #[error("{}: cannot read the rules: {error}", path.display())]
    Read {
        /// The rules file.
        path: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// The TOML does not parse, or a key is unknown or of the wrong type.
    #[error("{}: {error}", path.display())]
    Syntax {
        /// The rules file.
        path: PathBuf,
        /// The parser's error.
        error: toml::de::Error,
    },
    /// `unmatched` is neither `skip` nor `copy`.
    #[error("{}: unmatched = \"{value}\": expected \"skip\" or \"copy\"", path.display())]
    Unmatched {
        /// The rules file.
        path: PathBuf,
        /// The value given.
        value: String,
    },
    /// A rule is invalid.
    #[error("{}: rule {number} ('{glob}'): {error}", path.display())]
    Rule {
        /// The rules file.
        path: PathBuf,
        /// The rule's number, from 1.
        number: usize,
        /// The rule's glob as written.
        glob: String,
        /// What is wrong with it.
        error: RuleError,
    },
}

/// What is wrong with one rule of a rules file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RuleError {
    /// The glob does not parse.
    #[error("invalid glob: {0}")]
    Glob(globset::Error),
    /// Both a preset and a pipeline file.
    #[error("give preset or pipeline, not both")]
    PresetAndPipeline,
    /// The rule's pipeline cannot be made (the error of the caller's
    /// `MakePipeline`).
    #[error("{0}")]
    Pipeline(Box<dyn std::error::Error + Send + Sync>),
    /// A copy or skip rule with a pipeline.
    #[error("a copy or skip rule takes no preset, pipeline or set")]
    PipelineNotCracked,
    /// An action that is none of the actions.
    #[error("action = \"{action}\": expected \"crack\", \"copy\" or \"skip\"")]
    UnknownAction {
        /// The action as written.
        action: String,
    },
}

/// A batch could not read an input folder or write its outputs, copies or
/// state; the message names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BatchError {
    /// An input folder cannot be read.
    #[error("{}: cannot read the folder: {error}", dir.display())]
    ReadFolder {
        /// The folder.
        dir: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// The output folder cannot be made.
    #[error("{}: cannot create the output folder: {error}", out.display())]
    CreateOutput {
        /// The output folder.
        out: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// The worker threads cannot be started.
    #[error("cannot start {jobs} worker threads: {error}")]
    Threads {
        /// How many were asked for.
        jobs: usize,
        /// The thread pool's error.
        error: rayon::ThreadPoolBuildError,
    },
    /// The batch state cannot be written.
    #[error("{}: cannot write the batch state: {error}", path.display())]
    WriteState {
        /// The state file.
        path: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// The batch state cannot be encoded.
    #[error("{}: cannot write the batch state: {error}", path.display())]
    EncodeState {
        /// The state file.
        path: PathBuf,
        /// The encoder's error.
        error: serde_json::Error,
    },
    /// A file a copied asset names cannot be read.
    #[error("names '{source_file}', which cannot be read ({error}): not copied")]
    MissingSource {
        /// The file, relative to the asset's folder.
        source_file: String,
        /// The OS error.
        error: std::io::Error,
    },
    /// A file of a copied asset is not a regular file inside its folder.
    #[error("{}: {error}", input.display())]
    Source {
        /// The asset.
        input: PathBuf,
        /// What is wrong with the file.
        error: PathError,
    },
    /// A file of a copied asset cannot be opened.
    #[error("{}: cannot read: {error}", from.display())]
    ReadCopy {
        /// The file.
        from: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// A file of a copied asset cannot be copied.
    #[error("{}: cannot copy to {}: {error}", from.display(), to.display())]
    Copy {
        /// The file.
        from: PathBuf,
        /// Its copy.
        to: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// A copy cannot be put in place.
    #[error("{}: cannot write: {error}", to.display())]
    WriteCopy {
        /// The copy.
        to: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
}
