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
//! kind = "impact"        # uniform | directional | concentric | impact | noise
//! init = 6.0
//! points_relative = [[0.5, 0.5, 1.0]]
//! radius_relative = 0.3
//! ```
//!
//! Unknown keys are errors naming the key and the file. Every value is
//! checked before any work starts.

use crate::sim::SimParams;
use crate::stress::{Term, TermKind};
use serde::Deserialize;

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
    /// uniform | directional | concentric | impact | noise.
    pub kind: String,
    /// Weight on the initial stress (dimensionless stress). Default 0.
    #[serde(default)]
    pub init: f64,
    /// Weight added per unit of relaxation time while the load acts. Default 0.
    #[serde(default)]
    pub evolve: f64,
    /// directional: the direction (unitless, normalised).
    pub direction: Option<[f64; 3]>,
    /// concentric: a point on the axis, in scene units.
    pub center: Option<[f64; 3]>,
    /// concentric: a point on the axis as fractions of the mesh's bounding box.
    pub center_relative: Option<[f64; 3]>,
    /// concentric: the axis direction.
    pub axis: Option<[f64; 3]>,
    /// impact: points in scene units (projected onto the surface).
    pub points: Option<Vec<[f64; 3]>>,
    /// impact: points as fractions of the mesh's bounding box.
    pub points_relative: Option<Vec<[f64; 3]>>,
    /// impact: radius in scene units.
    pub radius: Option<f64>,
    /// impact: radius as a fraction of the bounding-box diagonal.
    pub radius_relative: Option<f64>,
    /// impact: concentric over radial factor. Default 1.25.
    pub concentric_factor: Option<f64>,
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
    /// Simulation keys (units as in [`SimParams`]; lengths in mean edge
    /// lengths). Its fixed boundary and groups are not keys here.
    #[serde(default)]
    pub simulation: SimParams,
    /// Stress terms, summed. None: uniform shrinkage only (`simulation.shrink_rate`).
    #[serde(default)]
    pub stress: Vec<StressEntry>,
}

/// The built-in presets: (name, TOML).
pub const PRESETS: &[(&str, &str)] = &[
    ("glaze", include_str!("../pipeline/glaze.toml")),
    ("mud", include_str!("../pipeline/mud.toml")),
    ("mud-jagged", include_str!("../pipeline/mud-jagged.toml")),
    (
        "glass-impact",
        include_str!("../pipeline/glass-impact.toml"),
    ),
    ("wood-grain", include_str!("../pipeline/wood-grain.toml")),
    ("tree-rings", include_str!("../pipeline/tree-rings.toml")),
];

/// A pipeline error; the message names the file (or preset) and the key.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("{source_name}: {message}")]
pub struct PipelineError {
    /// File path or `preset NAME`.
    pub source_name: String,
    /// What is wrong, naming the key.
    pub message: String,
}

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

    fn at(&self, f: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| self.min[k] + f[k] * (self.max[k] - self.min[k]))
    }

    fn diagonal(&self) -> f64 {
        (0..3)
            .map(|k| (self.max[k] - self.min[k]).powi(2))
            .sum::<f64>()
            .sqrt()
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
        let err = |message: String| PipelineError {
            source_name: source_name.to_string(),
            message,
        };
        let mut value: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| err(e.to_string().trim().to_string()))?;
        for s in sets {
            apply_set(&mut value, s).map_err(|m| err(format!("--set {s}: {m}")))?;
        }
        let p: Pipeline = toml::Value::Table(value)
            .try_into()
            .map_err(|e: toml::de::Error| err(e.to_string().trim().to_string()))?;
        p.check().map_err(err)?;
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
                message: format!(
                    "no such preset; the presets are: {}",
                    PRESETS
                        .iter()
                        .map(|(n, _)| *n)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            });
        };
        Pipeline::parse(text, &format!("preset {name}"), sets)
    }

    /// Every value checked, naming the key.
    fn check(&self) -> Result<(), String> {
        self.params(&[]).validate()?;
        let unit_box = Bounds {
            min: [0.0; 3],
            max: [1.0; 3],
        };
        for (i, e) in self.stress.iter().enumerate() {
            e.term(&unit_box)
                .and_then(|t| t.validate().map_err(|x| x.to_string()))
                .map_err(|m| format!("stress[{i}] ({}): {m}", e.kind))?;
        }
        Ok(())
    }

    /// Simulation parameters (fixed groups are resolved per mesh by the caller).
    pub fn params(&self, fixed_groups: &[u32]) -> SimParams {
        SimParams {
            fixed_boundary: self.select.fixed_boundary,
            fixed_groups: fixed_groups.to_vec(),
            ..self.simulation.clone()
        }
    }

    /// The stress terms for a mesh with bounds `b`.
    ///
    /// # Errors
    /// A term with missing or conflicting keys (checked by [`Pipeline::parse`] already).
    pub fn terms(&self, b: &Bounds) -> Result<Vec<Term>, String> {
        self.stress.iter().map(|e| e.term(b)).collect()
    }
}

/// Apply one `a.b.c=value` override to a TOML table.
fn apply_set(root: &mut toml::Table, set: &str) -> Result<(), String> {
    let (key, raw) = set
        .split_once('=')
        .ok_or_else(|| "expected key=value".to_string())?;
    let key = key.trim();
    let value: toml::Value = {
        let doc: toml::Table = format!("v = {}", raw.trim())
            .parse()
            .or_else(|_| format!("v = \"{}\"", raw.trim()).parse())
            .map_err(|e: toml::de::Error| format!("bad value: {e}"))?;
        doc.get("v").cloned().ok_or("bad value")?
    };
    let parts: Vec<&str> = key.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(format!("bad key '{key}'"));
    }
    let mut cur: &mut toml::Value = &mut *root
        .entry(parts[0].to_string())
        .or_insert_with(|| toml::Value::Table(Default::default()));
    for (i, part) in parts.iter().enumerate().skip(1) {
        let last = i == parts.len() - 1;
        cur = match cur {
            toml::Value::Table(t) => {
                if last {
                    t.insert(part.to_string(), value);
                    return Ok(());
                }
                t.entry(part.to_string())
                    .or_insert_with(|| toml::Value::Table(Default::default()))
            }
            toml::Value::Array(a) => {
                let n: usize = part
                    .parse()
                    .map_err(|_| format!("'{part}' in '{key}' must be an index"))?;
                let len = a.len();
                let slot = a.get_mut(n).ok_or_else(|| {
                    format!("index {n} in '{key}' is out of range (there are {len})")
                })?;
                if last {
                    *slot = value;
                    return Ok(());
                }
                slot
            }
            _ => return Err(format!("'{key}' goes inside a value that is not a table")),
        };
    }
    // A single-part key: a top-level value.
    *cur = value;
    Ok(())
}

impl StressEntry {
    /// The kind-specific keys this entry gives.
    fn present(&self) -> Vec<&'static str> {
        [
            ("direction", self.direction.is_some()),
            ("center", self.center.is_some()),
            ("center_relative", self.center_relative.is_some()),
            ("axis", self.axis.is_some()),
            ("points", self.points.is_some()),
            ("points_relative", self.points_relative.is_some()),
            ("radius", self.radius.is_some()),
            ("radius_relative", self.radius_relative.is_some()),
            ("concentric_factor", self.concentric_factor.is_some()),
        ]
        .into_iter()
        .filter_map(|(k, given)| given.then_some(k))
        .collect()
    }

    /// The term this entry describes on a mesh with bounds `b`.
    fn term(&self, b: &Bounds) -> Result<Term, String> {
        let allowed: &[&str] = match self.kind.as_str() {
            "uniform" | "noise" => &[],
            "directional" => &["direction"],
            "concentric" => &["center", "center_relative", "axis"],
            "impact" => &[
                "points",
                "points_relative",
                "radius",
                "radius_relative",
                "concentric_factor",
            ],
            other => {
                return Err(format!(
                    "unknown kind '{other}'; the kinds are uniform, directional, concentric, impact, noise"
                ))
            }
        };
        if let Some(k) = self.present().into_iter().find(|k| !allowed.contains(k)) {
            return Err(format!("key '{k}' does not apply to this kind"));
        }
        let one_of = |a: bool, b: bool, an: &str, bn: &str| match (a, b) {
            (true, true) => Err(format!("give '{an}' or '{bn}', not both")),
            (false, false) => Err(format!("missing key '{an}' (or '{bn}')")),
            _ => Ok(()),
        };
        let kind = match self.kind.as_str() {
            "uniform" => TermKind::Uniform,
            "noise" => TermKind::Noise,
            "directional" => TermKind::Directional {
                direction: self.direction.ok_or("missing key 'direction'")?,
            },
            "concentric" => {
                one_of(
                    self.center.is_some(),
                    self.center_relative.is_some(),
                    "center",
                    "center_relative",
                )?;
                TermKind::Concentric {
                    center: self
                        .center
                        .or(self.center_relative.map(|c| b.at(c)))
                        .unwrap_or_default(),
                    axis: self.axis.ok_or("missing key 'axis'")?,
                }
            }
            _ => {
                one_of(
                    self.points.is_some(),
                    self.points_relative.is_some(),
                    "points",
                    "points_relative",
                )?;
                one_of(
                    self.radius.is_some(),
                    self.radius_relative.is_some(),
                    "radius",
                    "radius_relative",
                )?;
                let points = match (&self.points, &self.points_relative) {
                    (Some(p), _) => p.clone(),
                    (None, Some(p)) => p.iter().map(|&q| b.at(q)).collect(),
                    _ => Vec::new(),
                };
                let radius = match (self.radius, self.radius_relative) {
                    (Some(r), _) => r,
                    (None, Some(r)) => r * b.diagonal(),
                    _ => 0.0,
                };
                if let Some(r) = self.radius.or(self.radius_relative) {
                    if !(r.is_finite() && r > 0.0) {
                        let key = if self.radius.is_some() {
                            "radius"
                        } else {
                            "radius_relative"
                        };
                        return Err(format!("{key} must be > 0, got {r}"));
                    }
                }
                TermKind::Impact {
                    points,
                    radius,
                    concentric_factor: self.concentric_factor.unwrap_or(1.25),
                }
            }
        };
        Ok(Term {
            kind,
            init: self.init,
            evolve: self.evolve,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn relative_points_and_radius_follow_the_bounds() {
        let t = "[[stress]]\nkind = \"impact\"\ninit = 1\npoints_relative = [[0.5,0.5,1]]\nradius_relative = 0.25\n";
        let p = Pipeline::parse(t, "x.toml", &[]).unwrap();
        let b = Bounds {
            min: [0.0, 0.0, 0.0],
            max: [4.0, 4.0, 2.0],
        };
        let terms = p.terms(&b).unwrap();
        match &terms[0].kind {
            TermKind::Impact { points, radius, .. } => {
                assert_eq!(points, &vec![[2.0, 2.0, 2.0]]);
                assert!((radius - 1.5).abs() < 1e-12);
            }
            k => panic!("{k:?}"),
        }
    }
}
