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
    /// Crack width: move every node by this multiple of its accumulated
    /// relaxation displacement, so the sides of each crack pull apart
    /// (unitless; 0: no width). Default 0. Width and curling are
    /// [`crate::post::width::displace`].
    pub width: f64,
    /// Largest gap across a crack, in scene units (0: no limit). Default 0.
    pub max_width: f64,
    /// Curling: lift crack nodes along the normal by this fraction of how
    /// far they moved (0: none). Default 0.
    pub curl: f64,
    /// Rings of neighbouring nodes the lift falls off over. Default 3.
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
    /// Shader attributes on the surface: `_CRACK_DISTANCE` (distance along
    /// the surface to the nearest crack, scene units) and `_CRACK_TIME`
    /// (when the nearest crack formed, 0..1). Default false.
    pub attributes: bool,
    /// Write each piece the cracks cut the surface into as its own mesh on
    /// its own node, with its pivot at the piece's centroid. Default false.
    pub split_islands: bool,
}

impl Default for Post {
    fn default() -> Self {
        Post {
            finish: false,
            width: 0.0,
            max_width: 0.0,
            curl: 0.0,
            curl_rings: 3,
            curl_falloff: 0.5,
            walls: false,
            wall_depth: 0.0,
            wall_depth_relative: 1.0,
            wall_material: "crack_wall".into(),
            lines: true,
            attributes: false,
            split_islands: false,
        }
    }
}

/// An invalid post-processing option; the message names the key and its
/// value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct OptionsError(pub String);

impl Post {
    /// Every value checked, naming the key.
    pub fn check(&self) -> Result<(), OptionsError> {
        self.check_values().map_err(OptionsError)
    }

    fn check_values(&self) -> Result<(), String> {
        let nonneg = |k: &str, x: f64| {
            if x.is_finite() && x >= 0.0 {
                Ok(())
            } else {
                Err(format!("post.{k} must be a number >= 0, got {x}"))
            }
        };
        nonneg("width", self.width)?;
        nonneg("max_width", self.max_width)?;
        nonneg("curl", self.curl)?;
        nonneg("wall_depth", self.wall_depth)?;
        nonneg("wall_depth_relative", self.wall_depth_relative)?;
        if !(0.0..=1.0).contains(&self.curl_falloff) {
            return Err(format!(
                "post.curl_falloff must be in [0, 1], got {}",
                self.curl_falloff
            ));
        }
        if self.walls && self.wall_depth == 0.0 && self.wall_depth_relative == 0.0 {
            return Err("post.walls needs wall_depth or wall_depth_relative > 0".into());
        }
        if self.walls && self.width == 0.0 {
            return Err(
                "post.walls needs post.width > 0 (without width there is no gap to fill)".into(),
            );
        }
        if self.wall_material.is_empty() {
            return Err("post.wall_material must not be empty".into());
        }
        Ok(())
    }
}
