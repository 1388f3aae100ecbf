//! The options of post-processing (a pipeline's `[post]` table), used as
//! they are by the pipeline file and by the algorithms of this module.

use serde::Deserialize;

/// Post-processing (`[post]`): what is done to the cracked mesh after the
/// simulation. Each step runs only when asked for.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Post {
    /// Finish cracks: run every open crack tip on until it meets another
    /// crack or the border (with relaxation), before the other steps.
    /// Default false.
    pub finish: bool,
    /// With `finish` on a film: run on only the tips that have another
    /// crack ahead of them within this many cell sizes (straight-line
    /// distance, within 45 degrees of the tip's direction), each at most
    /// twice that far: the arcs between an impact's rays join them, while
    /// the rays' outer tips stay where the load left them. 0: every tip
    /// runs on until it meets a crack or the border. On the spring model:
    /// a tip runs on only to a crack or the border within this many cell
    /// sizes along its path of springs (0: one cell size). Default 0.
    pub finish_reach: f64,
    /// Crack width: move every node by this multiple of its accumulated
    /// relaxation displacement, so the sides of each crack pull apart
    /// (unitless; 0: no width). Default 0. Width and curling are
    /// `post::width::displace`.
    pub width: f64,
    /// Largest gap across a crack, in scene units (0: no limit). Default 0.
    pub max_width: f64,
    /// Gaps opened locally: each side of a crack moves by its opening only
    /// (the crack line stays; a cell's corners where cracks meet round off
    /// on a circle of the sides' opening, half the gap, as radius), and the nodes off the cracks follow in a
    /// band this many times the nearest crack node's opening wide (along
    /// the surface), their moves the smooth (harmonic) blend of the crack
    /// nodes' moves fading to rest across the band, so cell interiors,
    /// their texture and the silhouette stay put. 0: every node moves by
    /// its displacement, whole cells shrinking as in the paper. Default 0.
    pub gap_band: f64,
    /// Curling: lift crack nodes along the normal by this fraction of how
    /// far they moved (0: none). With `gap_band` the lift of every node in
    /// the band is this fraction of its own move, so it fades over the
    /// band's width along the surface; without, over `curl_rings` rings of
    /// neighbours. Default 0.
    pub curl: f64,
    /// Rings of neighbouring nodes the lift falls off over, without
    /// `gap_band`. Default 3.
    pub curl_rings: usize,
    /// Lift factor from one ring to the next, in [0, 1]. Default 0.5.
    pub curl_falloff: f64,
    /// Side walls: fill each gap down to the crack line, offset inward
    /// along the normal, in their own primitive and material. Default false.
    pub walls: bool,
    /// Wall depth in scene units (0: use `wall_depth_relative`). Default 0.
    pub wall_depth: f64,
    /// Wall depth as a multiple of the mesh's mean gap width, when
    /// `wall_depth` is 0. Default 1.
    pub wall_depth_relative: f64,
    /// Material of the walls: an input material of this name, or a new
    /// plain one. Default `crack_wall`.
    pub wall_material: String,
    /// The crack network as a LINES primitive (material `crack_lines`,
    /// attribute `_CRACK_TIME`). Default true.
    pub lines: bool,
    /// Passes that take cracks running along the simulation surface's
    /// edges (the spring model, the snapping variant) off its zig-zag
    /// (`post::paths`); 0 leaves them on the edges. Films that
    /// split their triangles along the crack are not touched. Default 4.
    pub smooth_paths: usize,
    /// Shader attributes on the surface: `_CRACK_DISTANCE` (distance along
    /// the surface to the nearest crack, scene units) and `_CRACK_TIME`
    /// (when the nearest crack formed, 0..1). Default false.
    pub attributes: bool,
    /// Write each piece the cracks cut the surface into as its own mesh on
    /// its own node, with its pivot at the piece's centroid. Default false.
    pub split_islands: bool,
    /// Bake crack maps (base colour, groove normal map, occlusion) into the
    /// mesh's UVs and give its material a variant that uses them, so any
    /// viewer shows the cracks (`post::bake`). Default false.
    pub bake: bool,
    /// Width and height of the baked maps in texels; 0: sized to the asset
    /// (a crack [`BAKE_TEXELS_PER_CRACK`] texels wide, at least the
    /// material's own base colour texture's density, a multiple of 64 from
    /// 256 to [`BAKE_SIZE_CAP`]). Default 0.
    pub bake_size: u32,
    /// The UV set to bake into (`TEXCOORD_n`). Default 0.
    pub bake_texcoord: u32,
    /// When to make an automatic atlas (a new UV set): `auto` when the mesh
    /// lacks the UV set or its UVs overlap, `always`, or `never` (then such
    /// a mesh is an error). Default `auto`.
    pub bake_atlas: String,
    /// The maps' image format: `png` (any viewer), or `webp`: lossless
    /// WebP through `EXT_texture_webp`, required, without a PNG fallback
    /// (three.js and Blender 5.0 read it, Blender 3.4 does not; a quarter
    /// smaller on the Duck). Default `png`.
    pub bake_format: String,
    /// Crack width in the maps, in scene units (0: use
    /// `bake_width_relative` or `bake_width_cells`). Default 0.
    pub bake_width: f64,
    /// Crack width as a fraction of the mesh's bounding-box diagonal, when
    /// `bake_width` is 0 (0: use `bake_width_cells`). Default 0.
    pub bake_width_relative: f64,
    /// Crack width as a fraction of the run's cell size, when `bake_width`
    /// and `bake_width_relative` are 0, so finer cells draw finer cracks
    /// (models without a cell size: [`BAKE_WIDTH_OF_DIAGONAL`] of the
    /// diagonal). Default 0.04 (`glaze`'s cells of 0.05 of the diagonal:
    /// 0.002 of it).
    pub bake_width_cells: f64,
    /// Colour inside a crack, linear RGB in [0, 1]. Default a dark brown.
    pub crack_color: [f64; 3],
    /// Depth over half-width of the groove the normal map draws (1: walls
    /// at 45 degrees). Default 1.
    pub bake_groove_slope: f64,
    /// How much the occlusion map darkens along the cracks, in [0, 1].
    /// Default 0.8.
    pub bake_occlusion: f64,
    /// Fade with age: a crack that formed at fraction `t` of the run is
    /// `1 - bake_fade_age * t` as wide (the first cracks widest), in [0, 1].
    /// Default 0.
    pub bake_fade_age: f64,
    /// Fade with depth: a crack whose sides opened `o` (their accumulated
    /// relaxation displacements apart), against `o_max`, the 95th
    /// percentile of the mesh's crack openings, is `1 - bake_fade_depth *
    /// (1 - min(1, o / o_max))` as wide, in [0, 1] (shallow cracks thin;
    /// models without displacements do not fade).
    /// Default 0.
    pub bake_fade_depth: f64,
    /// Taper: each crack's baked width closes towards its free tips as an
    /// elastic crack's opening does (`sqrt(1 - (x / a)^2)` at `x` from the
    /// middle of a crack of half-length `a`; a crack ending on another or
    /// on the border as half of one), so a check between two free tips is
    /// lens-shaped, widest in its middle (`post::taper`).
    /// Default false.
    pub bake_taper: bool,
    /// Texels the maps' islands are grown by, so filtering never reads
    /// background. Default 8.
    pub bake_dilate: u32,
    /// Smooth normals for an input without them: the crease angle in
    /// degrees (Blender's auto smooth), 0 to 180; triangles meeting at a
    /// sharper edge stay faceted there (`geometry::normals`). 0
    /// writes no `NORMAL` (viewers shade flat). Inputs with normals keep
    /// theirs. Default 30.
    pub smooth_angle: f64,
    /// Real grooves: cut each crack into the surface as a V channel this
    /// wide (scene units; 0: use `groove_relative`), walled down to the
    /// crack line in `groove_material` (`post::width::groove`).
    /// Default 0.
    pub groove: f64,
    /// Groove width as a fraction of the cell size (the film models'
    /// `simulation.cell_size`; the mesh's bounding-box diagonal for the other
    /// models), when `groove` is 0. Default 0 (no grooves).
    pub groove_relative: f64,
    /// Depth of the groove below the surface, scene units (0: as deep as it
    /// is wide). Default 0.
    pub groove_depth: f64,
    /// Material of the groove walls: an input material of this name, or a
    /// new plain one. Default `crack_wall`.
    pub groove_material: String,
    /// The groove's profile: `v` (walls straight down to the crack line)
    /// or `u` (walls dropping straight from the edges and rounding into
    /// the bottom, in `U_ROWS` (4) rows). Default `v`.
    pub groove_profile: String,
    /// What the output's surface is. `input` (the default): the artist's
    /// own mesh. When nothing moves or cuts the surface (no `width`,
    /// `curl`, `walls`, `groove` or `split_islands`), its triangles,
    /// vertices and attributes come back unchanged (morph targets, skins
    /// and UV layouts untouched) and the cracks show in what is added over
    /// it: the baked maps, the crack lines (on the input's surface) and the
    /// crack attributes; otherwise the cracks, simulated on the private
    /// simulation surface, are cut into the input's triangles exactly
    /// along their curves (`mesh::imprint`) and the gaps, walls,
    /// curls, grooves and pieces are made there, the rest of the input's
    /// tessellation as it was. `simulation`: the simulation surface,
    /// cracked, in place of the input's triangles.
    pub output: String,
    /// The most bytes one decoded material texture may take when baking:
    /// the run's memory budget (`--max-memory`, set by the run; not a
    /// pipeline key). Default: no limit beyond the decoder's pixel cap.
    #[serde(skip, default = "no_budget")]
    pub memory_budget: u64,
}

fn no_budget() -> u64 {
    u64::MAX
}

impl Post {
    /// These options with decoded textures held to `budget` bytes.
    #[must_use]
    pub fn within(&self, budget: u64) -> Post {
        Post {
            memory_budget: budget,
            ..self.clone()
        }
    }
}

impl Default for Post {
    fn default() -> Self {
        Post {
            finish: false,
            finish_reach: 0.0,
            width: 0.0,
            max_width: 0.0,
            gap_band: 0.0,
            curl: 0.0,
            curl_rings: 3,
            curl_falloff: 0.5,
            walls: false,
            wall_depth: 0.0,
            wall_depth_relative: 1.0,
            wall_material: "crack_wall".into(),
            lines: true,
            smooth_paths: 4,
            attributes: false,
            split_islands: false,
            bake: false,
            bake_size: 0,
            bake_texcoord: 0,
            bake_atlas: "auto".into(),
            bake_format: "png".into(),
            bake_width: 0.0,
            bake_width_relative: 0.0,
            bake_width_cells: 0.04,
            crack_color: [0.02, 0.015, 0.01],
            bake_groove_slope: 1.0,
            bake_occlusion: 0.8,
            bake_fade_age: 0.0,
            bake_fade_depth: 0.0,
            bake_taper: false,
            bake_dilate: 8,
            smooth_angle: crate::geometry::normals::DEFAULT_CREASE_DEGREES,
            groove: 0.0,
            groove_relative: 0.0,
            groove_depth: 0.0,
            groove_material: "crack_wall".into(),
            groove_profile: "v".into(),
            output: "input".into(),
            memory_budget: no_budget(),
        }
    }
}

/// The baked crack width, as a fraction of the bounding-box diagonal, of a
/// model without a cell size (the springs, the snapping variant, tearing)
/// when no width is given.
pub const BAKE_WIDTH_OF_DIAGONAL: f64 = 0.002;

/// Texels across a crack in maps sized to the asset (`bake_size = 0`).
pub const BAKE_TEXELS_PER_CRACK: f64 = 3.0;

/// Largest map sized to the asset: the size given before maps followed the
/// asset, so no output's maps grow (at 4096 one group's bake would take
/// about 0.7 GB).
pub const BAKE_SIZE_CAP: u32 = 2048;

/// Rows of a U groove's walls (a quarter ellipse each).
pub const U_ROWS: usize = 4;

/// An invalid post-processing option; the message names the key and its
/// value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OptionsError {
    /// A value outside its range: `{key} must be {expected}, got {got}`.
    #[error("{key} must be {expected}, got {got}")]
    Range {
        /// The key (e.g. `post.width`).
        key: String,
        /// What it must be.
        expected: String,
        /// The value given.
        got: String,
    },
    /// A stage that needs another key, or keys that do not go together;
    /// the message is the key followed by the reason.
    #[error("{key} {reason}")]
    Invalid {
        /// The key.
        key: String,
        /// Why (e.g. `needs post.width > 0 ...`).
        reason: String,
    },
    /// Two keys that exclude each other were both given.
    #[error("{first} and {second}: give one, not both")]
    Both {
        /// The first key.
        first: String,
        /// The second key.
        second: String,
    },
}

impl OptionsError {
    fn range(
        key: impl Into<String>,
        expected: impl Into<String>,
        got: impl std::fmt::Display,
    ) -> Self {
        OptionsError::Range {
            key: key.into(),
            expected: expected.into(),
            got: got.to_string(),
        }
    }
    fn invalid(key: &str, reason: &str) -> Self {
        OptionsError::Invalid {
            key: key.into(),
            reason: reason.into(),
        }
    }
}

impl Post {
    /// Whether a stage moves the surface or cuts it into pieces (gaps,
    /// curls, walls, grooves, pieces).
    pub fn changes_surface(&self) -> bool {
        self.width > 0.0 || self.curl > 0.0 || self.walls || self.grooves() || self.split_islands
    }

    /// Whether the output is the input's own mesh as it was, the cracks
    /// drawn over it (`output = "input"`, nothing moving the surface).
    pub fn keeps_input(&self) -> bool {
        self.output == "input" && !self.changes_surface()
    }

    /// Whether the cracks are cut into the input's own mesh
    /// (`output = "input"` with a stage that moves or cuts the surface).
    pub fn cuts_input(&self) -> bool {
        self.output == "input" && self.changes_surface()
    }

    /// Whether cracks are cut as grooves.
    pub fn grooves(&self) -> bool {
        self.groove > 0.0 || self.groove_relative > 0.0
    }

    /// The groove's width for a mesh of cell size `cell` (or bounding-box
    /// diagonal, for models without a cell size): `groove`, else
    /// `groove_relative * cell`.
    pub fn groove_width(&self, cell: f64) -> f64 {
        if self.groove > 0.0 {
            self.groove
        } else {
            self.groove_relative * cell
        }
    }

    /// Rows of the groove walls: 0 for a V, `U_ROWS` (4) for a U.
    pub fn groove_rows(&self) -> usize {
        if self.groove_profile == "u" {
            U_ROWS
        } else {
            0
        }
    }

    /// The baked crack width for a mesh of bounding-box diagonal
    /// `diagonal` cracked at cell size `cell` (none: a model without one):
    /// `bake_width`, else `bake_width_relative * diagonal`, else
    /// `bake_width_cells * cell`, else [`BAKE_WIDTH_OF_DIAGONAL`] of the
    /// diagonal.
    pub fn bake_width_for(&self, diagonal: f64, cell: Option<f64>) -> f64 {
        if self.bake_width > 0.0 {
            self.bake_width
        } else if self.bake_width_relative > 0.0 {
            self.bake_width_relative * diagonal
        } else {
            match cell.filter(|c| *c > 0.0 && self.bake_width_cells > 0.0) {
                Some(c) => self.bake_width_cells * c,
                None => BAKE_WIDTH_OF_DIAGONAL * diagonal,
            }
        }
    }

    /// A crack's width factor in the maps: formed at fraction `age` of the
    /// run, as deep as `depth` of the deepest crack (both in [0, 1]).
    pub fn fade(&self, age: f64, depth: f64) -> f64 {
        (1.0 - self.bake_fade_age * age.clamp(0.0, 1.0))
            * (1.0 - self.bake_fade_depth * (1.0 - depth.clamp(0.0, 1.0)))
    }

    /// Every value checked, naming the key.
    pub fn check(&self) -> Result<(), OptionsError> {
        let nonneg = |k: &str, x: f64| {
            if x.is_finite() && x >= 0.0 {
                Ok(())
            } else {
                Err(OptionsError::range(format!("post.{k}"), "a number >= 0", x))
            }
        };
        nonneg("finish_reach", self.finish_reach)?;
        nonneg("width", self.width)?;
        nonneg("max_width", self.max_width)?;
        nonneg("gap_band", self.gap_band)?;
        nonneg("curl", self.curl)?;
        nonneg("wall_depth", self.wall_depth)?;
        nonneg("wall_depth_relative", self.wall_depth_relative)?;
        if !(0.0..=1.0).contains(&self.curl_falloff) {
            return Err(OptionsError::range(
                "post.curl_falloff",
                "in [0, 1]",
                self.curl_falloff,
            ));
        }
        if self.walls && self.wall_depth == 0.0 && self.wall_depth_relative == 0.0 {
            return Err(OptionsError::invalid(
                "post.walls",
                "needs wall_depth or wall_depth_relative > 0",
            ));
        }
        if self.walls && self.width == 0.0 {
            return Err(OptionsError::invalid(
                "post.walls",
                "needs post.width > 0 (without width there is no gap to fill)",
            ));
        }
        nonneg("bake_width", self.bake_width)?;
        nonneg("bake_width_relative", self.bake_width_relative)?;
        nonneg("bake_width_cells", self.bake_width_cells)?;
        nonneg("bake_groove_slope", self.bake_groove_slope)?;
        let unit = |k: &str, x: f64| {
            if (0.0..=1.0).contains(&x) {
                Ok(())
            } else {
                Err(OptionsError::range(format!("post.{k}"), "in [0, 1]", x))
            }
        };
        unit("bake_occlusion", self.bake_occlusion)?;
        unit("bake_fade_age", self.bake_fade_age)?;
        unit("bake_fade_depth", self.bake_fade_depth)?;
        for (i, c) in self.crack_color.iter().enumerate() {
            unit(&format!("crack_color[{i}]"), *c)?;
        }
        if self.bake_size != 0 && !(16..=8192).contains(&self.bake_size) {
            return Err(OptionsError::range(
                "post.bake_size",
                "0 (sized to the asset) or between 16 and 8192 texels",
                self.bake_size,
            ));
        }
        if self.bake_texcoord > 7 {
            return Err(OptionsError::range(
                "post.bake_texcoord",
                "a UV set 0..7",
                self.bake_texcoord,
            ));
        }
        if !["png", "webp"].contains(&self.bake_format.as_str()) {
            return Err(OptionsError::range(
                "post.bake_format",
                "\"png\" or \"webp\"",
                format!("\"{}\"", self.bake_format),
            ));
        }
        if !["auto", "always", "never"].contains(&self.bake_atlas.as_str()) {
            return Err(OptionsError::range(
                "post.bake_atlas",
                "\"auto\", \"always\" or \"never\"",
                format!("\"{}\"", self.bake_atlas),
            ));
        }
        if !(0.0..=180.0).contains(&self.smooth_angle) {
            return Err(OptionsError::range(
                "post.smooth_angle",
                "0 to 180 degrees",
                self.smooth_angle,
            ));
        }
        if self.bake_dilate > 64 {
            return Err(OptionsError::range(
                "post.bake_dilate",
                "at most 64 texels",
                self.bake_dilate,
            ));
        }
        if self.bake
            && self.bake_width == 0.0
            && self.bake_width_relative == 0.0
            && self.bake_width_cells == 0.0
        {
            return Err(OptionsError::invalid(
                "post.bake",
                "needs bake_width, bake_width_relative or bake_width_cells > 0",
            ));
        }
        nonneg("groove", self.groove)?;
        nonneg("groove_relative", self.groove_relative)?;
        nonneg("groove_depth", self.groove_depth)?;
        if self.groove > 0.0 && self.groove_relative > 0.0 {
            return Err(OptionsError::Both {
                first: "post.groove".into(),
                second: "post.groove_relative".into(),
            });
        }
        if self.grooves() && (self.width > 0.0 || self.walls || self.curl > 0.0) {
            return Err(OptionsError::invalid("post.groove", "cuts the cracks as channels of its own width: use it without post.width, post.walls and post.curl"));
        }
        if !["input", "simulation"].contains(&self.output.as_str()) {
            return Err(OptionsError::range(
                "post.output",
                "\"input\" (the artist's mesh) or \"simulation\" (the simulation surface)",
                format!("\"{}\"", self.output),
            ));
        }
        if !["v", "u"].contains(&self.groove_profile.as_str()) {
            return Err(OptionsError::range(
                "post.groove_profile",
                "\"v\" or \"u\"",
                format!("\"{}\"", self.groove_profile),
            ));
        }
        if self.groove_material.is_empty() {
            return Err(OptionsError::invalid(
                "post.groove_material",
                "must not be empty",
            ));
        }
        if self.wall_material.is_empty() {
            return Err(OptionsError::invalid(
                "post.wall_material",
                "must not be empty",
            ));
        }
        Ok(())
    }
}
