//! Pipelines: a run declared as TOML (mesh selection, stress terms,
//! simulation), with `key=value` overrides and built-in presets.
//!
//! ```toml
//! description = "mud drying on the ground"
//! [select]
//! meshes = []            # mesh names to crack; empty: every crackable mesh
//! fix = []               # material or OBJ group names whose nodes are fixed
//! fixed_boundary = false
//! [simulation]
//! toughness = 2.0        # see SimParams for every key, its unit and default
//! shrink_rate = 0.05
//! [[stress]]
//! kind = "impact"        # uniform | directional | concentric | impact | noise | curvature
//! init = 6.0
//! points_relative = [[0.5, 0.5, 1.0]]
//! radius_relative = 0.3
//! mask = { image = "stains.png" }   # optional, on any entry: black = full stress
//! ```
//!
//! Unknown keys are errors naming the key and the file. Every value is
//! checked before any work starts; mask images are decoded by
//! [`Pipeline::load_images`] before the input is read.

pub use crate::error::{
    ConfigError, EntryError, MaskImageError, MaskMaterialError, PipelineError, SetError,
};
pub use crate::post::Post;
use crate::scene::Scene;
use crate::sim::SimParams;
use crate::stress::texture::{mask_from_material, Mask, SLOTS};
use crate::stress::{CurvatureMeasure, Term};
use serde::Deserialize;
use std::path::Path;
use std::sync::Arc;

/// Images built into the tool, for `mask = { image = "builtin:NAME" }`.
pub const BUILTIN_IMAGES: &[(&str, &[u8])] =
    &[("blotches", include_bytes!("../../fixtures/crack_mask.png"))];

/// Per stress entry, its mask once loaded (`None`: no mask).
pub type Masks = Vec<Option<Arc<Mask>>>;

/// A texture mask on a stress entry: the entry's stress on each face is
/// multiplied by the mask's weight at the face centroid's UV (bilinear,
/// black = 1, white = 0; `invert` swaps them).
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaskSpec {
    /// A grey or colour PNG/JPEG (luminance is used), relative to the
    /// pipeline file's folder, or `builtin:NAME` (see [`BUILTIN_IMAGES`]).
    /// Sampled with repeat wrapping.
    pub image: Option<String>,
    /// Or: the input's material of this name; its texture in `slot` is the
    /// mask, with the texture's sampler wrap modes, `texCoord` and
    /// `KHR_texture_transform`.
    pub material: Option<String>,
    /// The material's texture slot. Default `baseColorTexture`.
    pub slot: Option<String>,
    /// White = full stress instead of black. Default false.
    #[serde(default)]
    pub invert: bool,
    /// For `image`: the UV set (`TEXCOORD_n`) sampled. Default 0.
    pub tex_coord: Option<u32>,
    /// Also scale each node's separation by the weight, as if white regions
    /// were infinitely tough (the mask marks where the cracking layer is):
    /// cracks then stay where the mask is dark instead of running on into
    /// the unstressed surface around it. Default false.
    #[serde(default)]
    pub confine: bool,
}

impl MaskSpec {
    fn check(&self) -> Result<(), EntryError> {
        match (&self.image, &self.material) {
            (Some(_), Some(_)) => {
                return Err(EntryError::Both {
                    first: "image",
                    second: "material",
                })
            }
            (None, None) => {
                return Err(EntryError::Missing {
                    key: "image",
                    alternative: "material",
                })
            }
            (Some(_), None) if self.slot.is_some() => {
                return Err(EntryError::AppliesTo {
                    key: "slot",
                    applies: "a material mask, not an image",
                })
            }
            (None, Some(_)) if self.tex_coord.is_some() => {
                return Err(EntryError::AppliesTo {
                    key: "tex_coord",
                    applies: "an image mask (a material's texture names its own)",
                })
            }
            _ => {}
        }
        if let Some(slot) = &self.slot {
            if !SLOTS.contains(&slot.as_str()) {
                return Err(EntryError::UnknownSlot { slot: slot.clone() });
            }
        }
        Ok(())
    }
}

/// Which meshes a pipeline cracks and what holds them.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Select {
    /// Mesh names to crack; empty: every crackable mesh. Others are written unchanged.
    pub meshes: Vec<String>,
    /// Material or OBJ group names whose nodes are fixed.
    pub fix: Vec<String>,
    /// Fix each mesh's open boundary.
    pub fixed_boundary: bool,
}

/// One `[[stress]]` entry as written. Which keys apply depends on `kind`;
/// a key that does not apply is an error.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct StressEntry {
    /// uniform | directional | concentric | impact | noise | curvature.
    pub kind: String,
    /// Weight on the initial stress (dimensionless stress). Default 0.
    #[serde(default)]
    pub init: f64,
    /// Weight added per unit of relaxation time while the load acts. Default 0.
    #[serde(default)]
    pub evolve: f64,
    /// directional: the direction in world space (unitless, normalised).
    pub direction: Option<[f64; 3]>,
    /// directional (instead of `direction`) and concentric (instead of
    /// `axis`): an axis of each mesh's own frame, `x`, `y`, `z`, or
    /// `longest` (the longest side of its bounding box: along a plank).
    pub mesh_axis: Option<String>,
    /// concentric: a point on the axis, in world space (scene units).
    pub center: Option<[f64; 3]>,
    /// concentric: a point on the axis as fractions of the mesh's bounding box.
    pub center_relative: Option<[f64; 3]>,
    /// concentric: the axis direction in world space.
    pub axis: Option<[f64; 3]>,
    /// impact: points in world space (scene units), projected onto the surface.
    pub points: Option<Vec<[f64; 3]>>,
    /// impact: points as fractions of the mesh's bounding box.
    pub points_relative: Option<Vec<[f64; 3]>>,
    /// impact: radius in world space (scene units).
    pub radius: Option<f64>,
    /// impact: radius as a fraction of the bounding-box diagonal.
    pub radius_relative: Option<f64>,
    /// impact: concentric over radial factor of the paper's disc (no
    /// `speed` or `radial_cracks`). Default 1.25.
    pub concentric_factor: Option<f64>,
    /// impact: the hit's speed in metres per second, giving a star of
    /// `4 sqrt(speed)` radial cracks (3 to 64: N doubles when the speed
    /// quadruples, as on thin glass plates). Instead of `radial_cracks`.
    pub speed: Option<f64>,
    /// impact: the star's number of radial cracks, 3 to 64. Instead of
    /// `speed`. Without either, the paper's disc of crazing.
    pub radial_cracks: Option<u32>,
    /// impact with stars: the points hit one after another, each once the
    /// cracks before it have stopped (a later star ends at the earlier
    /// cracks). Default false: all at once.
    pub in_turn: Option<bool>,
    /// curvature: also scale each node's separation by this curvature
    /// measure: gaussian (|k1 k2|), mean (|k1 + k2|/2), frobenius
    /// (sqrt(k1^2 + k2^2)) or sum_squares (k1^2 + k2^2).
    pub separation: Option<CurvatureMeasure>,
    /// curvature with `separation`: how strongly, >= 0 (1: proportional to
    /// the measure over its mean; 0: no effect). Default 1.
    pub strength: Option<f64>,
    /// curvature with `separation`: the largest factor, > 0. Default 4.
    pub max_factor: Option<f64>,
    /// directional: drying checks about this many cell sizes long (0.5
    /// to 50), staggered along the grain, instead of cracks from end to end.
    pub checks: Option<f64>,
    /// Any kind: a texture mask multiplying the entry's stress.
    pub mask: Option<MaskSpec>,
}

/// A whole pipeline file.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Pipeline {
    /// One line saying what the pipeline makes.
    #[serde(default)]
    pub description: String,
    /// Mesh selection.
    #[serde(default)]
    pub select: Select,
    /// Simulation keys (units as in the simulation parameters; lengths in mean edge
    /// lengths). Its fixed boundary and groups are not keys here.
    #[serde(default)]
    pub simulation: SimParams,
    /// Stress terms, summed. None: uniform shrinkage only (`simulation.shrink_rate`).
    #[serde(default)]
    pub stress: Vec<StressEntry>,
    /// Post-processing.
    #[serde(default)]
    pub post: Post,
    /// The file or preset the pipeline came from (for messages).
    #[serde(skip)]
    pub source_name: String,
    /// Image masks decoded by [`Pipeline::load_images`], per stress entry.
    #[serde(skip)]
    pub(crate) image_masks: Masks,
}

/// The built-in presets: (name, TOML).
pub const PRESETS: &[(&str, &str)] = &[
    ("glaze", include_str!("../../pipeline/glaze.toml")),
    ("mud", include_str!("../../pipeline/mud.toml")),
    ("mud-jagged", include_str!("../../pipeline/mud-jagged.toml")),
    ("mud-aged", include_str!("../../pipeline/mud-aged.toml")),
    (
        "glass-impact",
        include_str!("../../pipeline/glass-impact.toml"),
    ),
    (
        "glass-tempered",
        include_str!("../../pipeline/glass-tempered.toml"),
    ),
    ("wood-grain", include_str!("../../pipeline/wood-grain.toml")),
    ("tree-rings", include_str!("../../pipeline/tree-rings.toml")),
    ("curvature", include_str!("../../pipeline/curvature.toml")),
    (
        "texture-mask",
        include_str!("../../pipeline/texture-mask.toml"),
    ),
    (
        "springs-mud",
        include_str!("../../pipeline/springs-mud.toml"),
    ),
    (
        "springs-glaze",
        include_str!("../../pipeline/springs-glaze.toml"),
    ),
    (
        "impact-snapped",
        include_str!("../../pipeline/impact-snapped.toml"),
    ),
    ("tear", include_str!("../../pipeline/tear.toml")),
];

/// The mesh's bounding box, for relative lengths and points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Smallest corner.
    pub min: [f64; 3],
    /// Largest corner.
    pub max: [f64; 3],
}

impl Bounds {
    /// Bounds of a set of points.
    pub fn of(points: impl IntoIterator<Item = [f64; 3]>) -> Bounds {
        let mut b = Bounds {
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        };
        for p in points {
            b.min = std::array::from_fn(|k| b.min[k].min(p[k]));
            b.max = std::array::from_fn(|k| b.max[k].max(p[k]));
        }
        b
    }

    pub(super) fn at(&self, f: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| self.min[k] + f[k] * (self.max[k] - self.min[k]))
    }

    /// Length of the box's diagonal.
    pub fn diagonal(&self) -> f64 {
        (0..3)
            .map(|k| (self.max[k] - self.min[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    }
}

/// Where a mesh sits: its bounding box in its own coordinates (for relative
/// keys) and the map from world (scene) coordinates into them (for
/// world-space keys).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// The mesh's bounding box in its own coordinates.
    pub bounds: Bounds,
    /// World to mesh coordinates, column-major 4x4 affine.
    pub world_to_mesh: [f64; 16],
}

impl Placement {
    /// A mesh whose coordinates are world coordinates.
    pub fn local(bounds: Bounds) -> Placement {
        Placement {
            bounds,
            world_to_mesh: crate::scene::IDENTITY,
        }
    }

    /// A mesh drawn with the world matrix `mesh_to_world` (column-major).
    ///
    /// `None` when the matrix is not invertible (zero scale) or not finite.
    pub fn new(bounds: Bounds, mesh_to_world: &[f64; 16]) -> Option<Placement> {
        let m = nalgebra::Matrix4::from_column_slice(mesh_to_world);
        let inv = m
            .try_inverse()
            .filter(|i| i.iter().all(|x| x.is_finite()))?;
        let mut world_to_mesh = [0.0; 16];
        world_to_mesh.copy_from_slice(inv.as_slice());
        Some(Placement {
            bounds,
            world_to_mesh,
        })
    }

    fn apply(&self, p: [f64; 3], w: f64) -> [f64; 3] {
        let m = &self.world_to_mesh;
        std::array::from_fn(|r| m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r] * w)
    }

    /// A world point in mesh coordinates.
    pub(super) fn point(&self, p: [f64; 3]) -> [f64; 3] {
        self.apply(p, 1.0)
    }

    /// A world direction in mesh coordinates.
    pub(super) fn vector(&self, v: [f64; 3]) -> [f64; 3] {
        self.apply(v, 0.0)
    }

    /// A world length in mesh units (the mean scale: cube root of the
    /// linear part's determinant).
    pub(super) fn length(&self, l: f64) -> f64 {
        let m = &self.world_to_mesh;
        let det = m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2])
            + m[8] * (m[1] * m[6] - m[5] * m[2]);
        l * det.abs().cbrt()
    }
}

impl Pipeline {
    /// Parse a pipeline from TOML text, apply `key=value` overrides (dotted
    /// keys, e.g. `simulation.toughness=3` or `stress.0.radius=0.2`; values
    /// in TOML syntax), and check every value.
    ///
    /// # Errors
    /// Syntax, an unknown key, a bad value or a bad override, naming `source_name` and the key.
    pub fn parse(
        text: &str,
        source_name: &str,
        sets: &[String],
    ) -> Result<Pipeline, PipelineError> {
        let err = |error: ConfigError| PipelineError {
            source_name: source_name.to_string(),
            error: Box::new(error),
        };
        let mut value: toml::Table = text.parse().map_err(|e| err(ConfigError::Syntax(e)))?;
        for s in sets {
            apply_set(&mut value, s).map_err(|error| {
                err(ConfigError::Set {
                    set: s.clone(),
                    error,
                })
            })?;
        }
        let mut p: Pipeline = toml::Value::Table(value)
            .try_into()
            .map_err(|e| err(ConfigError::Syntax(e)))?;
        p.check().map_err(err)?;
        p.source_name = source_name.to_string();
        Ok(p)
    }

    /// A built-in preset by name, with overrides.
    ///
    /// # Errors
    /// An unknown name (the message lists the presets) or a bad override.
    pub fn preset(name: &str, sets: &[String]) -> Result<Pipeline, PipelineError> {
        let Some((_, text)) = PRESETS.iter().find(|(n, _)| *n == name) else {
            return Err(PipelineError {
                source_name: format!("preset {name}"),
                error: Box::new(ConfigError::NoPreset {
                    presets: PRESETS.iter().map(|(n, _)| n.to_string()).collect(),
                }),
            });
        };
        Pipeline::parse(text, &format!("preset {name}"), sets)
    }

    /// Every value checked again (after fields were set directly).
    ///
    /// # Errors
    /// The first bad value, naming the pipeline and the key.
    pub fn check_all(&self) -> Result<(), PipelineError> {
        self.check().map_err(|error| PipelineError {
            source_name: self.source_name.clone(),
            error: Box::new(error),
        })
    }

    /// Every value checked, naming the key.
    fn check(&self) -> Result<(), ConfigError> {
        self.params(&[]).validate()?;
        self.post.check()?;
        let unit_box = Placement::local(Bounds {
            min: [0.0; 3],
            max: [1.0; 3],
        });
        for (i, e) in self.stress.iter().enumerate() {
            e.term(&unit_box, None)
                .and_then(|t| Ok(t.validate()?))
                .map_err(|error| e.error(i, error))?;
            if let Some(m) = &e.mask {
                m.check()
                    .map_err(|m| e.error(i, EntryError::Mask(Box::new(m))))?;
            }
        }
        Ok(())
    }

    /// Whether a stress entry needs the curvature estimate.
    pub fn needs_curvature(&self) -> bool {
        self.stress.iter().any(|e| e.kind == "curvature")
    }

    /// Whether a stress entry has a mask (images or material textures).
    pub fn has_masks(&self) -> bool {
        self.stress.iter().any(|e| e.mask.is_some())
    }

    /// Decode the image masks (`mask = { image = ... }`), paths relative to
    /// `base_dir` (the pipeline file's folder; `None` for a preset, which may
    /// only use built-in images). Call before reading any input.
    ///
    /// # Errors
    /// An image that cannot be read or decoded, or an unknown built-in name;
    /// the message names the pipeline and the key.
    pub fn load_images(&mut self, base_dir: Option<&Path>) -> Result<(), PipelineError> {
        self.load_images_within(base_dir, u64::MAX)
    }

    /// [`Pipeline::load_images`] with each decoded image held to `budget`
    /// bytes (the run's `--max-memory`), checked before decoding.
    ///
    /// # Errors
    /// Those of [`Pipeline::load_images`], and an image over the budget.
    pub fn load_images_within(
        &mut self,
        base_dir: Option<&Path>,
        budget: u64,
    ) -> Result<(), PipelineError> {
        let mut masks = Vec::with_capacity(self.stress.len());
        for (i, e) in self.stress.iter().enumerate() {
            let Some(spec) = &e.mask else {
                masks.push(None);
                continue;
            };
            let Some(image) = &spec.image else {
                masks.push(None);
                continue;
            };
            let err = |m: MaskImageError| PipelineError {
                source_name: self.source_name.clone(),
                error: Box::new(e.error(i, EntryError::MaskImage(m))),
            };
            let grey = if let Some(name) = image.strip_prefix("builtin:") {
                let (_, bytes) =
                    BUILTIN_IMAGES
                        .iter()
                        .find(|(n, _)| *n == name)
                        .ok_or_else(|| {
                            err(MaskImageError::NoBuiltin {
                                name: name.to_string(),
                                builtins: BUILTIN_IMAGES
                                    .iter()
                                    .map(|(n, _)| format!("builtin:{n}"))
                                    .collect(),
                            })
                        })?;
                crate::io::image_decode::grey(bytes, image).map_err(|e| err(e.into()))?
            } else {
                let path = Path::new(image);
                let path = match base_dir {
                    Some(d) if path.is_relative() => d.join(path),
                    Some(_) => path.to_path_buf(),
                    None if path.is_absolute() => path.to_path_buf(),
                    None => {
                        return Err(err(MaskImageError::RelativeInPreset {
                            image: image.clone(),
                        }))
                    }
                };
                crate::io::image::open_grey_within(&path, budget).map_err(|e| err(e.into()))?
            };
            let mut mask = Mask::from_image(grey);
            mask.invert = spec.invert;
            mask.tex_coord = spec.tex_coord.unwrap_or(0);
            mask.confine = spec.confine;
            masks.push(Some(Arc::new(mask)));
        }
        self.image_masks = masks;
        Ok(())
    }

    /// Every entry's mask for `scene`: the decoded image masks (from
    /// [`Pipeline::load_images`]) and the material masks, whose textures are
    /// decoded here, each held to `budget` bytes (the run's `--max-memory`),
    /// checked before decoding; texture files must lie inside `asset_dir`.
    ///
    /// # Errors
    /// An image mask not loaded yet, a material name the scene does not have
    /// (the message lists the names), a texture that cannot be used or is
    /// over the budget.
    pub(crate) fn masks_for_within(
        &self,
        scene: &Scene,
        asset_dir: &Path,
        budget: u64,
    ) -> Result<Masks, PipelineError> {
        self.masks_in(scene, asset_dir, budget)
            .map_err(|error| PipelineError {
                source_name: self.source_name.clone(),
                error: Box::new(error),
            })
    }

    fn masks_in(&self, scene: &Scene, asset_dir: &Path, budget: u64) -> Result<Masks, ConfigError> {
        let mut out = Vec::with_capacity(self.stress.len());
        for (i, e) in self.stress.iter().enumerate() {
            let Some(spec) = &e.mask else {
                out.push(None);
                continue;
            };
            if spec.image.is_some() {
                let m =
                    self.image_masks.get(i).cloned().flatten().ok_or_else(|| {
                        e.error(i, EntryError::MaskImage(MaskImageError::NotLoaded))
                    })?;
                out.push(Some(m));
                continue;
            }
            let name = spec.material.as_deref().unwrap_or_default();
            let Some(mi) = scene.materials.iter().position(|m| m.name() == Some(name)) else {
                let names = scene.materials.iter().filter_map(|m| m.name());
                return Err(e.error(
                    i,
                    EntryError::MaskMaterial(MaskMaterialError::NoMaterial {
                        name: name.to_string(),
                        names: names.map(str::to_string).collect(),
                    }),
                ));
            };
            let slot = spec.slot.as_deref().unwrap_or("baseColorTexture");
            let mut m = mask_from_material(
                scene,
                mi,
                slot,
                spec.invert,
                &crate::io::image::Files::inside(asset_dir).within(budget),
            )
            .map_err(|t| e.error(i, EntryError::MaskMaterial(t.into())))?;
            m.confine = spec.confine;
            out.push(Some(Arc::new(m)));
        }
        Ok(out)
    }

    /// Simulation parameters (fixed groups are resolved per mesh by the caller).
    pub fn params(&self, fixed_groups: &[u32]) -> SimParams {
        SimParams {
            fixed_boundary: self.select.fixed_boundary,
            fixed_groups: fixed_groups.to_vec(),
            finish: self.post.finish,
            finish_reach: self.post.finish_reach,
            ..self.simulation.clone()
        }
    }

    /// Whether an entry gives a world-space key (a point, direction, axis or
    /// radius in scene units), which depends on where the mesh is placed.
    pub fn uses_world_space(&self) -> bool {
        self.stress.iter().any(|e| {
            e.direction.is_some()
                || e.center.is_some()
                || e.axis.is_some()
                || e.points.is_some()
                || e.radius.is_some()
        })
    }

    /// The stress terms for a mesh placed at `place`, with the entries'
    /// masks (from [`Pipeline::masks_for_within`]; empty: no masks).
    ///
    /// # Errors
    /// A term with missing or conflicting keys (checked by [`Pipeline::parse`]
    /// already), or an entry with a mask spec but no loaded mask.
    pub(crate) fn terms(
        &self,
        place: &Placement,
        masks: &[Option<Arc<Mask>>],
    ) -> Result<Vec<Term>, PipelineError> {
        self.stress
            .iter()
            .enumerate()
            .map(|(i, e)| {
                let mask = masks.get(i).cloned().flatten();
                if e.mask.is_some() && mask.is_none() {
                    return Err(e.error(i, EntryError::MaskNotLoaded));
                }
                e.term(place, mask).map_err(|error| e.error(i, error))
            })
            .collect::<Result<Vec<Term>, ConfigError>>()
            .map_err(|error| PipelineError {
                source_name: self.source_name.clone(),
                error: Box::new(error),
            })
    }
}

/// The machinery's reach into a [`Pipeline`] (stress terms, masks), which
/// its public face keeps private: for the crate's own tests and tools
/// (`internals`).
pub mod machinery {
    use super::*;

    /// [`Pipeline::terms`].
    ///
    /// # Errors
    /// Those of [`Pipeline::terms`].
    pub fn terms(
        p: &Pipeline,
        place: &Placement,
        masks: &[Option<Arc<Mask>>],
    ) -> Result<Vec<Term>, PipelineError> {
        p.terms(place, masks)
    }

    /// [`Pipeline::masks_for_within`] with no memory budget.
    ///
    /// # Errors
    /// Those of [`Pipeline::masks_for_within`].
    pub fn masks_for(p: &Pipeline, scene: &Scene, asset_dir: &Path) -> Result<Masks, PipelineError> {
        p.masks_for_within(scene, asset_dir, u64::MAX)
    }

    /// The image mask of stress entry `i`, once [`Pipeline::load_images`]
    /// has decoded it.
    pub fn image_mask(p: &Pipeline, i: usize) -> Option<Arc<Mask>> {
        p.image_masks.get(i).cloned().flatten()
    }
}

/// Apply one `a.b.c=value` override to a TOML table.
/// Keys of one table that exclude each other besides the `_relative`
/// pairs: a `--set` of one removes the other.
const ALTERNATIVES: [(&str, &str); 4] = [
    ("image", "material"),
    ("speed", "radial_cracks"),
    ("axis", "mesh_axis"),
    ("direction", "mesh_axis"),
];

fn apply_set(root: &mut toml::Table, set: &str) -> Result<(), SetError> {
    let (key, raw) = set.split_once('=').ok_or(SetError::NoValue)?;
    let key = key.trim();
    let value: toml::Value = {
        let doc: toml::Table = format!("v = {}", raw.trim())
            .parse()
            .or_else(|_| format!("v = \"{}\"", raw.trim()).parse())
            .map_err(SetError::BadValue)?;
        doc.get("v").cloned().ok_or(SetError::NoParsedValue)?
    };
    let parts: Vec<&str> = key.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(SetError::BadKey { key: key.into() });
    }
    let mut cur: &mut toml::Value = &mut *root
        .entry(parts[0].to_string())
        .or_insert_with(|| toml::Value::Table(Default::default()));
    for (i, part) in parts.iter().enumerate().skip(1) {
        let last = i == parts.len() - 1;
        cur = match cur {
            toml::Value::Table(t) => {
                if last {
                    // A key replaces its alternative (radius and
                    // radius_relative, cell_size and cell_size_relative,
                    // a mask's image and material, ...).
                    match part.strip_suffix("_relative") {
                        Some(base) => t.remove(base),
                        None => t.remove(&format!("{part}_relative")),
                    };
                    for (a, b) in ALTERNATIVES {
                        if *part == a {
                            t.remove(b);
                        } else if *part == b {
                            t.remove(a);
                        }
                    }
                    t.insert(part.to_string(), value);
                    return Ok(());
                }
                if part.parse::<usize>().is_ok() && !t.contains_key(*part) {
                    return Err(SetError::NoEntry {
                        table: parts[..i].join("."),
                        entry: part.to_string(),
                    });
                }
                t.entry(part.to_string())
                    .or_insert_with(|| toml::Value::Table(Default::default()))
            }
            toml::Value::Array(a) => {
                let n: usize = part.parse().map_err(|_| SetError::NotIndex {
                    part: part.to_string(),
                    key: key.into(),
                })?;
                let len = a.len();
                let slot = a.get_mut(n).ok_or_else(|| SetError::IndexOutOfRange {
                    index: n,
                    key: key.into(),
                    len,
                })?;
                if last {
                    *slot = value;
                    return Ok(());
                }
                slot
            }
            _ => return Err(SetError::NotTable { key: key.into() }),
        };
    }
    // A single-part key: a top-level value.
    *cur = value;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stress::TermKind;

    #[test]
    fn every_preset_parses_and_has_a_description() {
        for (name, _) in PRESETS {
            let p = Pipeline::preset(name, &[]).unwrap();
            assert!(!p.description.is_empty(), "{name}");
        }
    }

    #[test]
    fn unknown_keys_and_bad_values_are_named() {
        let e = Pipeline::parse("[simulation]\ntoughnes = 2\n", "a.toml", &[]).unwrap_err();
        assert!(
            e.to_string().contains("a.toml") && e.to_string().contains("toughnes"),
            "{e}"
        );
        let e = Pipeline::parse("[simulation]\nalpha = 1.5\n", "b.toml", &[]).unwrap_err();
        assert!(e.to_string().contains("alpha"), "{e}");
        let e = Pipeline::parse("[simulation]\ntoughness = -1\n", "b.toml", &[]).unwrap_err();
        assert!(e.to_string().contains("toughness"), "{e}");
        let t = "[[stress]]\nkind = \"impact\"\ninit = 1\npoints = [[0,0,0]]\nradius = 0\n";
        let e = Pipeline::parse(t, "c.toml", &[]).unwrap_err();
        assert!(
            e.to_string().contains("stress[0]") && e.to_string().contains("radius"),
            "{e}"
        );
        let t = "[[stress]]\nkind = \"uniform\"\nradius = 2\n";
        let e = Pipeline::parse(t, "d.toml", &[]).unwrap_err();
        assert!(e.to_string().contains("'radius' does not apply"), "{e}");
        let t = "[[stress]]\nkind = \"sparkle\"\n";
        let e = Pipeline::parse(t, "e.toml", &[]).unwrap_err();
        assert!(e.to_string().contains("sparkle"), "{e}");
        let e = Pipeline::preset("nope", &[]).unwrap_err();
        assert!(e.to_string().contains("glaze"), "{e}");
    }

    #[test]
    fn overrides_reach_nested_keys_and_are_checked() {
        let t = "[[stress]]\nkind = \"impact\"\ninit = 1\npoints = [[0,0,0]]\nradius = 2\n";
        let p = Pipeline::parse(
            t,
            "x.toml",
            &[
                "simulation.toughness=3.5".into(),
                "stress.0.radius=4".into(),
            ],
        )
        .unwrap();
        assert_eq!(p.simulation.toughness, 3.5);
        assert_eq!(p.stress[0].radius, Some(4.0));
        let e = Pipeline::parse(t, "x.toml", &["simulation.alpha=2".into()]).unwrap_err();
        assert!(e.to_string().contains("alpha"), "{e}");
        let e = Pipeline::parse(t, "x.toml", &["stress.3.radius=1".into()]).unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
        let e = Pipeline::parse(t, "x.toml", &["simulation.bogus=1".into()]).unwrap_err();
        assert!(e.to_string().contains("bogus"), "{e}");
    }

    /// A `--set` of a key replaces its alternative in the same table.
    #[test]
    fn a_set_key_replaces_its_alternative() {
        let t = "[[stress]]\nkind = \"uniform\"\ninit = 1\nmask = { image = \"a.png\", confine = true }\n";
        let p = Pipeline::parse(t, "x.toml", &["stress.0.mask.material=\"Body\"".into()]).unwrap();
        let m = p.stress[0].mask.as_ref().unwrap();
        assert_eq!(m.material.as_deref(), Some("Body"));
        assert!(m.image.is_none() && m.confine, "{m:?}");
        let t = "[[stress]]\nkind = \"impact\"\ninit = 1\nradius = 1\nspeed = 4\n";
        let p = Pipeline::parse(t, "x.toml", &["stress.0.radial_cracks=12".into()]).unwrap();
        assert_eq!(
            (p.stress[0].speed, p.stress[0].radial_cracks),
            (None, Some(12))
        );
    }

    #[test]
    fn relative_points_and_radius_follow_the_bounds() {
        let t = "[[stress]]\nkind = \"impact\"\ninit = 1\npoints_relative = [[0.5,0.5,1]]\nradius_relative = 0.25\n";
        let p = Pipeline::parse(t, "x.toml", &[]).unwrap();
        let b = Bounds {
            min: [0.0, 0.0, 0.0],
            max: [4.0, 4.0, 2.0],
        };
        let terms = p.terms(&Placement::local(b), &[]).unwrap();
        match &terms[0].kind {
            TermKind::Impact { points, radius, .. } => {
                assert_eq!(points, &vec![[2.0, 2.0, 2.0]]);
                assert!((radius - 1.5).abs() < 1e-12);
            }
            k => panic!("{k:?}"),
        }
    }

    #[test]
    fn an_impacts_speed_or_count_of_radial_cracks_makes_a_star() {
        let base = "[[stress]]\nkind = \"impact\"\ninit = 1\npoints_relative = [[0.5,0.5,1]]\nradius_relative = 0.25\n";
        let b = Bounds {
            min: [0.0; 3],
            max: [4.0, 4.0, 2.0],
        };
        let rays = |extra: &str| -> Result<u32, PipelineError> {
            let p = Pipeline::parse(&format!("{base}{extra}"), "x.toml", &[])?;
            let t = p.terms(&Placement::local(b), &[])?;
            match &t[0].kind {
                TermKind::Impact { radial_cracks, .. } => Ok(*radial_cracks),
                k => panic!("{k:?}"),
            }
        };
        assert_eq!(rays("").ok(), Some(0));
        assert_eq!(rays("speed = 4.0\n").ok(), Some(8));
        assert_eq!(rays("speed = 16.0\n").ok(), Some(16));
        assert_eq!(rays("radial_cracks = 5\n").ok(), Some(5));
        for (extra, says) in [
            ("speed = 4.0\nradial_cracks = 5\n", "not both"),
            ("speed = -1.0\n", "speed must be"),
            ("speed = 1e300\n", "speed must be"),
            ("radial_cracks = 2\n", "radial_cracks must be"),
            ("radial_cracks = 65\n", "radial_cracks must be"),
            (
                "speed = 4.0\nconcentric_factor = 1.25\n",
                "concentric_factor",
            ),
        ] {
            let e = rays(extra).unwrap_err().to_string();
            assert!(e.contains(says), "{extra}: {e}");
        }
    }

    #[test]
    fn world_space_keys_map_into_the_mesh_frame() {
        // Mesh drawn rotated 90 deg about z, scaled 2, translated (10, 0, 0):
        // mesh (x, y, z) -> world (10 - 2y, 2x, 2z).
        let m = [
            0.0, 2.0, 0.0, 0.0, -2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 10.0, 0.0, 0.0, 1.0,
        ];
        let b = Bounds {
            min: [0.0; 3],
            max: [4.0, 1.0, 1.0],
        };
        let place = Placement::new(b, &m).unwrap();
        let t = "[[stress]]\nkind = \"impact\"\ninit = 1\npoints = [[8, 2, 0]]\nradius = 2\n\
                 [[stress]]\nkind = \"directional\"\ninit = 1\ndirection = [0, 1, 0]\n\
                 [[stress]]\nkind = \"directional\"\ninit = 1\nmesh_axis = \"longest\"\n\
                 [[stress]]\nkind = \"concentric\"\ninit = 1\ncenter = [10, 0, 0]\nmesh_axis = \"z\"\n";
        let terms = Pipeline::parse(t, "x.toml", &[])
            .unwrap()
            .terms(&place, &[])
            .unwrap();
        let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12);
        match &terms[0].kind {
            TermKind::Impact { points, radius, .. } => {
                assert!(close(points[0], [1.0, 1.0, 0.0]), "{points:?}");
                assert!((radius - 1.0).abs() < 1e-12);
            }
            k => panic!("{k:?}"),
        }
        match (&terms[1].kind, &terms[2].kind, &terms[3].kind) {
            (
                TermKind::Directional {
                    direction: world, ..
                },
                TermKind::Directional {
                    direction: longest, ..
                },
                TermKind::Concentric { center, axis },
            ) => {
                assert!(close(*world, [0.5, 0.0, 0.0]), "{world:?}");
                assert_eq!(*longest, [1.0, 0.0, 0.0]);
                assert!(close(*center, [0.0; 3]));
                assert_eq!(*axis, [0.0, 0.0, 1.0]);
            }
            k => panic!("{k:?}"),
        }
        assert!(Placement::new(b, &[0.0; 16]).is_none());
        let e = Pipeline::parse(
            "[[stress]]\nkind = \"directional\"\ninit = 1\nmesh_axis = \"w\"\n",
            "y.toml",
            &[],
        )
        .unwrap_err();
        assert!(e.to_string().contains("mesh_axis"), "{e}");
        let e = Pipeline::parse(
            "[[stress]]\nkind = \"directional\"\ninit = 1\nmesh_axis = \"x\"\ndirection = [1, 0, 0]\n",
            "y.toml",
            &[],
        )
        .unwrap_err();
        assert!(e.to_string().contains("not both"), "{e}");
    }

    #[test]
    fn instances_have_their_world_matrices() {
        let scene = crate::io::read(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/hierarchy.glb"),
        )
        .unwrap();
        let boxes = scene.mesh_world_matrices(0);
        assert_eq!(boxes.len(), 2, "box: under arm and as box_instance");
        // arm: root translation (0, 1, 0) then a rotation (no translation).
        assert_eq!(&boxes[0][12..15], &[0.0, 1.0, 0.0]);
        // box_instance: root (0, 1, 0) + (1.5, 0, 0), scale 0.5.
        assert!((boxes[1][12] - 1.5).abs() < 1e-12 && (boxes[1][13] - 1.0).abs() < 1e-12);
        assert!((boxes[1][0] - 0.5).abs() < 1e-12);
        assert_eq!(scene.mesh_world_matrices(1).len(), 1);
        assert!(scene.mesh_world_matrices(7).is_empty());
    }
}
