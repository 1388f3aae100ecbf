//! The artist's controls of `crack` (and `batch`, `study`): the look of the
//! cracks by name, each short for one or a few pipeline keys (`--set`),
//! listed in `--help` before the advanced simulation options.

use super::UsageError;
use crate::pipeline::Pipeline;

/// The look of the cracks. Each flag is short for the `--set` named in its
/// help; a `--set` of the same key comes later and wins.
#[derive(clap::Args, Debug, Default)]
#[command(next_help_heading = "Look")]
pub struct LookArgs {
    /// Crack width in the baked maps, in scene units (--set post.bake_width=W)
    #[arg(long, value_name = "W")]
    width: Option<f64>,
    /// Open the cracks into walled gaps: each side moves by G times its relaxation displacement (mud uses 0.01; 0 closes them) (--set post.width=G --set post.walls=true)
    #[arg(long, value_name = "G")]
    gaps: Option<f64>,
    /// Cut each crack into the surface as a V groove W wide, in scene units (--set post.groove=W)
    #[arg(long, value_name = "W")]
    groove: Option<f64>,
    /// Bake crack maps into the mesh's UVs (an automatic atlas when it has none) (--set post.bake=true)
    #[arg(long, conflicts_with = "no_bake")]
    bake: bool,
    /// Write no crack maps (--set post.bake=false)
    #[arg(long)]
    no_bake: bool,
    /// Where an impact hits, in scene units, for every impact entry of the pipeline; repeat it for several hits at once (--set stress.N.points=[[X,Y,Z]])
    #[arg(long, value_name = "X,Y,Z")]
    impact: Vec<String>,
    /// How far an impact reaches, in scene units, for every impact entry (--set stress.N.radius=R)
    #[arg(long, value_name = "R")]
    radius: Option<f64>,
    /// Crack only where a grey image is dark: a PNG file, or material:NAME for that material's texture; on every stress entry (--set stress.N.mask.image=PATH or stress.N.mask.material=NAME)
    #[arg(long, value_name = "IMAGE|material:NAME")]
    mask: Option<String>,
    /// Colour inside the cracks, linear R,G,B from 0 to 1 (--set post.crack_color=[R,G,B])
    #[arg(long, value_name = "R,G,B")]
    color: Option<String>,
}

/// Three finite numbers `a,b,c`.
fn triple(flag: &str, text: &str) -> Result<[f64; 3], UsageError> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            UsageError(format!(
                "{flag} '{text}': give three numbers separated by commas"
            ))
        })?;
    match v.as_slice() {
        [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok([*a, *b, *c]),
        _ => Err(UsageError(format!(
            "{flag} '{text}': give three finite numbers"
        ))),
    }
}

/// `s` as a TOML basic string.
fn toml_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => out.push_str(&format!("\\u{:04X}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

impl LookArgs {
    /// The `--set` strings these flags stand for, on `base` (the pipeline
    /// file or preset as given: the impact and mask flags set every entry
    /// of its `[[stress]]` list that they apply to).
    ///
    /// # Errors
    /// A malformed value, or an impact or mask flag on a pipeline with no
    /// entry to take it (the message says which preset has one).
    pub fn sets(&self, base: &Pipeline) -> Result<Vec<String>, UsageError> {
        let mut sets = Vec::new();
        if let Some(w) = self.width {
            sets.push(format!("post.bake_width={w:?}"));
        }
        if let Some(g) = self.gaps {
            sets.push(format!("post.width={g:?}"));
            sets.push(format!("post.walls={}", g > 0.0));
        }
        if let Some(w) = self.groove {
            sets.push(format!("post.groove={w:?}"));
        }
        if self.bake || self.no_bake {
            sets.push(format!("post.bake={}", self.bake));
        }
        if let Some(c) = &self.color {
            let [r, g, b] = triple("--color", c)?;
            sets.push(format!("post.crack_color=[{r:?}, {g:?}, {b:?}]"));
        }
        let impacts: Vec<usize> = (0..base.stress.len())
            .filter(|&i| base.stress[i].kind == "impact")
            .collect();
        if (!self.impact.is_empty() || self.radius.is_some()) && impacts.is_empty() {
            return Err(
                "--impact and --radius set the pipeline's impact entries, and it has none (try --preset glass-impact)"
                    .into(),
            );
        }
        if !self.impact.is_empty() {
            let points = self
                .impact
                .iter()
                .map(|t| triple("--impact", t).map(|[x, y, z]| format!("[{x:?}, {y:?}, {z:?}]")))
                .collect::<Result<Vec<_>, _>>()?;
            for &i in &impacts {
                sets.push(format!("stress.{i}.points=[{}]", points.join(", ")));
            }
        }
        if let Some(r) = self.radius {
            for &i in &impacts {
                sets.push(format!("stress.{i}.radius={r:?}"));
            }
        }
        if let Some(m) = &self.mask {
            if base.stress.is_empty() {
                return Err(
                    "--mask masks the pipeline's stress entries, and it has none (try --preset texture-mask)"
                        .into(),
                );
            }
            let (key, value) = match m.strip_prefix("material:") {
                Some(name) => ("material", name),
                None => ("image", m.as_str()),
            };
            if value.is_empty() {
                return Err(UsageError(format!(
                    "--mask '{m}': name an image file or material:NAME"
                )));
            }
            let quoted = toml_string(value);
            for i in 0..base.stress.len() {
                sets.push(format!("stress.{i}.mask.{key}={quoted}"));
            }
        }
        Ok(sets)
    }

    /// These flags as command-line words (for a build file's commands).
    pub fn flags(&self) -> Vec<String> {
        let mut out = Vec::new();
        let mut num = |flag: &str, v: Option<f64>| {
            if let Some(v) = v {
                out.push(flag.to_string());
                out.push(format!("{v:?}"));
            }
        };
        num("--width", self.width);
        num("--gaps", self.gaps);
        num("--groove", self.groove);
        num("--radius", self.radius);
        if self.bake {
            out.push("--bake".into());
        }
        if self.no_bake {
            out.push("--no-bake".into());
        }
        for p in &self.impact {
            out.push("--impact".into());
            out.push(p.clone());
        }
        for (flag, v) in [("--mask", &self.mask), ("--color", &self.color)] {
            if let Some(v) = v {
                out.push(flag.into());
                out.push(v.clone());
            }
        }
        out
    }
}

/// `x` as short as it prints.
fn num(x: f64) -> String {
    format!("{x}")
}

/// What each look flag stands at in `p`, one line each (comments, for
/// `crackle presets NAME`).
pub fn summary(p: &Pipeline) -> Vec<String> {
    let s = &p.simulation;
    let post = &p.post;
    let mut out = vec!["# The look: `crack` flags and where this pipeline has them.".to_string()];
    let mut line = |flag: &str, at: String| out.push(format!("#   {flag:<28} {at}"));
    line(
        "--cell-size[-relative]",
        match (s.cell_size, s.cell_size_relative) {
            (Some(c), _) => format!("{} scene units", num(c)),
            (None, Some(r)) => format!("{} of the bounding-box diagonal", num(r)),
            _ => "none (the paper's model on the input's own triangles)".into(),
        },
    );
    line(
        "--bake / --no-bake",
        if post.bake { "baked maps" } else { "no maps" }.into(),
    );
    line(
        "--width W",
        if post.bake_width > 0.0 {
            format!("{} scene units", num(post.bake_width))
        } else if post.bake_width_relative > 0.0 {
            format!("{} of the diagonal", num(post.bake_width_relative))
        } else {
            format!(
                "{} of the cell size (models without one: {} of the diagonal)",
                num(post.bake_width_cells),
                num(crate::post::BAKE_WIDTH_OF_DIAGONAL)
            )
        },
    );
    line(
        "--gaps G",
        if post.width > 0.0 {
            format!(
                "{} (walls {})",
                num(post.width),
                if post.walls { "on" } else { "off" }
            )
        } else {
            "closed".into()
        },
    );
    line(
        "--groove W",
        if post.groove > 0.0 {
            format!("{} scene units", num(post.groove))
        } else if post.groove_relative > 0.0 {
            format!("{} of the cell size", num(post.groove_relative))
        } else {
            "none".into()
        },
    );
    let [r, g, b] = post.crack_color;
    line("--color R,G,B", format!("{},{},{}", num(r), num(g), num(b)));
    for (i, e) in p.stress.iter().enumerate() {
        if e.kind == "impact" {
            let hit = match (&e.points, &e.points_relative) {
                (Some(p), _) => format!("{p:?}"),
                (None, Some(p)) => format!("{p:?} of the bounding box"),
                _ => "where the asset faces the viewer".into(),
            };
            let reach = match (e.radius, e.radius_relative) {
                (Some(r), _) => format!("{} scene units", num(r)),
                (None, Some(r)) => format!("{} of the diagonal", num(r)),
                _ => "-".into(),
            };
            line(
                "--impact X,Y,Z --radius R",
                format!("stress.{i}: {hit}, reach {reach}"),
            );
        }
        if let Some(m) = &e.mask {
            let what = match (&m.image, &m.material) {
                (Some(img), _) => img.clone(),
                (None, Some(name)) => format!("material:{name}"),
                _ => "-".into(),
            };
            line("--mask IMAGE|material:NAME", format!("stress.{i}: {what}"));
        }
    }
    out
}
