//! Errors of a pipeline (a file or preset): its syntax, its `--set`
//! overrides, and each key's value, naming the key. They reach the
//! library's user as a [`PipelineError`](super::PipelineError), which adds
//! the pipeline's name.

use crate::post::OptionsError;
use crate::sim::ParamError;
use crate::stress::field::FieldError;
use crate::stress::texture::{TextureError, SLOTS};

/// What is wrong with a pipeline.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The TOML does not parse, or a key is unknown or of the wrong type.
    #[error("{}", .0.to_string().trim())]
    Syntax(toml::de::Error),
    /// A `--set` override cannot be applied.
    #[error("--set {set}: {error}")]
    Set {
        /// The override as given (`key=value`).
        set: String,
        /// Why it cannot be applied.
        error: SetError,
    },
    /// No preset has this name.
    #[error("no such preset; the presets are: {}", presets.join(", "))]
    NoPreset {
        /// The presets there are.
        presets: Vec<String>,
    },
    /// A `[simulation]` value is invalid.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// A `[post]` value is invalid.
    #[error(transparent)]
    Post(#[from] OptionsError),
    /// A `[[stress]]` entry is invalid.
    #[error("stress[{index}] ({kind}): {error}")]
    Entry {
        /// The entry's index.
        index: usize,
        /// The entry's kind as written.
        kind: String,
        /// What is wrong with it.
        error: EntryError,
    },
}

/// Why a `--set key=value` override cannot be applied.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SetError {
    /// No `=`.
    #[error("expected key=value")]
    NoValue,
    /// The value is not a TOML value (nor a bare string).
    #[error("bad value: {0}")]
    BadValue(toml::de::Error),
    /// The value parsed to nothing.
    #[error("bad value")]
    NoParsedValue,
    /// The key has an empty part.
    #[error("bad key '{key}'")]
    BadKey {
        /// The key.
        key: String,
    },
    /// A numbered entry (`stress.3`) the pipeline does not have.
    #[error("'{table}' has no entry {entry} (the pipeline has none; its entries come from --preset or --pipeline)")]
    NoEntry {
        /// The table (`stress`).
        table: String,
        /// The entry asked for.
        entry: String,
    },
    /// A part of the key inside an array is not an index.
    #[error("'{part}' in '{key}' must be an index")]
    NotIndex {
        /// The part.
        part: String,
        /// The whole key.
        key: String,
    },
    /// An index beyond the array.
    #[error("index {index} in '{key}' is out of range (there are {len})")]
    IndexOutOfRange {
        /// The index.
        index: usize,
        /// The whole key.
        key: String,
        /// The array's length.
        len: usize,
    },
    /// The key goes inside a plain value.
    #[error("'{key}' goes inside a value that is not a table")]
    NotTable {
        /// The key.
        key: String,
    },
}

/// What is wrong with one `[[stress]]` entry (or its mask).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EntryError {
    /// The kind is not one of the kinds.
    #[error("unknown kind '{kind}'; the kinds are uniform, directional, concentric, impact, noise, curvature")]
    UnknownKind {
        /// The kind as written.
        kind: String,
    },
    /// A key of another kind.
    #[error("key '{key}' does not apply to this kind")]
    NotForKind {
        /// The key.
        key: &'static str,
    },
    /// A key that applies only to another form of the entry (a mask's
    /// `slot` to a material, its `tex_coord` to an image).
    #[error("key '{key}' applies to {applies}")]
    AppliesTo {
        /// The key.
        key: &'static str,
        /// What it applies to.
        applies: &'static str,
    },
    /// Two keys that exclude each other.
    #[error("give '{first}' or '{second}', not both")]
    Both {
        /// The first key.
        first: &'static str,
        /// The second key.
        second: &'static str,
    },
    /// Neither of two keys, one of which is needed.
    #[error("missing key '{key}' (or '{alternative}')")]
    Missing {
        /// The key.
        key: &'static str,
        /// The key that may stand for it.
        alternative: &'static str,
    },
    /// A key that needs another one.
    #[error("key '{key}' needs '{needs}'")]
    Needs {
        /// The key given.
        key: &'static str,
        /// The key it needs.
        needs: &'static str,
    },
    /// A curvature entry with no weight and no separation.
    #[error("a curvature entry needs 'init', 'evolve' or 'separation'")]
    NoCurvatureLoad,
    /// An empty list of points.
    #[error("'{key}' is empty: give at least one point, or leave it out for the default hit")]
    NoPoints {
        /// The key (`points` or `points_relative`).
        key: &'static str,
    },
    /// A value outside its range.
    #[error("{key} must be {expected}, got {got}")]
    Range {
        /// The key.
        key: &'static str,
        /// What it must be.
        expected: &'static str,
        /// The value given.
        got: String,
    },
    /// `concentric_factor` with a star of radial cracks.
    #[error("'concentric_factor' is the paper's disc's: not with 'speed' or 'radial_cracks'")]
    ConcentricFactorWithRays,
    /// The term's values are invalid.
    #[error(transparent)]
    Term(#[from] FieldError),
    /// A mask slot that is not a texture slot.
    #[error("slot: unknown texture slot '{slot}' (valid slots: {})", SLOTS.join(", "))]
    UnknownSlot {
        /// The slot as written.
        slot: String,
    },
    /// The entry's mask is invalid.
    #[error("mask: {0}")]
    Mask(Box<EntryError>),
    /// The entry has a mask but none was given to the run.
    #[error("mask not loaded")]
    MaskNotLoaded,
    /// The mask's image cannot be used.
    #[error("mask.image: {0}")]
    MaskImage(MaskImageError),
    /// The mask's material texture cannot be used.
    #[error("mask.material: {0}")]
    MaskMaterial(MaskMaterialError),
}

/// Why a mask's image cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MaskImageError {
    /// A `builtin:` name there is no image for.
    #[error("no built-in image '{name}'; there are: {}", builtins.join(", "))]
    NoBuiltin {
        /// The name after `builtin:`.
        name: String,
        /// The built-in images (`builtin:NAME`).
        builtins: Vec<String>,
    },
    /// A relative path in a preset, which has no folder.
    #[error("'{image}' is relative, and a preset has no folder; give an absolute path or a builtin: image")]
    RelativeInPreset {
        /// The path as written.
        image: String,
    },
    /// The images were not loaded before the masks were asked for.
    #[error("the image was not loaded (call load_images first)")]
    NotLoaded,
    /// The image cannot be read or decoded.
    #[error(transparent)]
    Texture(#[from] TextureError),
}

/// Why a mask's material texture cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MaskMaterialError {
    /// The input has no material of that name.
    #[error("the input has no material named '{name}' (materials: {})", if names.is_empty() { "none with a name".to_string() } else { names.join(", ") })]
    NoMaterial {
        /// The name asked for.
        name: String,
        /// The input's material names.
        names: Vec<String>,
    },
    /// The texture cannot be found, read or decoded.
    #[error(transparent)]
    Texture(#[from] TextureError),
}

/// Why a `--frames N DIR` request cannot be met.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FramesError {
    /// Not two values.
    #[error("--frames takes two values: N DIR")]
    Values,
    /// N is not a whole number.
    #[error("--frames N: '{value}' is not a whole number")]
    NotNumber {
        /// The value given.
        value: String,
    },
    /// N out of range.
    #[error("--frames N must be in 2..=10000, got {count}")]
    Count {
        /// The count given.
        count: usize,
    },
    /// DIR is a file.
    #[error("--frames DIR: {} is not a folder", dir.display())]
    NotFolder {
        /// The path given.
        dir: std::path::PathBuf,
    },
}
