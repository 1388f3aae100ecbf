//! A `[[stress]]` entry as written to the stress term it describes on one
//! mesh: which keys its kind takes, points and axes from the mesh's
//! bounding box, every value checked.

use super::{Bounds, ConfigError, EntryError, Placement, StressEntry};
use crate::stress::texture::Mask;
use crate::stress::{CurvatureScale, Term, TermKind};
use std::sync::Arc;

impl StressEntry {
    /// `error` as the error of this entry, the pipeline's `index`th.
    pub(super) fn error(&self, index: usize, error: EntryError) -> ConfigError {
        ConfigError::Entry {
            index,
            kind: self.kind.clone(),
            error,
        }
    }

    /// The kind-specific keys this entry gives.
    pub(super) fn present(&self) -> Vec<&'static str> {
        [
            ("direction", self.direction.is_some()),
            ("mesh_axis", self.mesh_axis.is_some()),
            ("checks", self.checks.is_some()),
            ("center", self.center.is_some()),
            ("center_relative", self.center_relative.is_some()),
            ("axis", self.axis.is_some()),
            ("points", self.points.is_some()),
            ("points_relative", self.points_relative.is_some()),
            ("radius", self.radius.is_some()),
            ("radius_relative", self.radius_relative.is_some()),
            ("concentric_factor", self.concentric_factor.is_some()),
            ("speed", self.speed.is_some()),
            ("radial_cracks", self.radial_cracks.is_some()),
            ("in_turn", self.in_turn.is_some()),
            ("separation", self.separation.is_some()),
            ("strength", self.strength.is_some()),
            ("max_factor", self.max_factor.is_some()),
        ]
        .into_iter()
        .filter_map(|(k, given)| given.then_some(k))
        .collect()
    }

    /// The unit vector of `mesh_axis` in the mesh's frame.
    pub(super) fn mesh_axis(&self, b: &Bounds) -> Result<[f64; 3], EntryError> {
        let name = self.mesh_axis.as_deref().unwrap_or_default();
        let k = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            "longest" => (0..3)
                .max_by(|&i, &j| {
                    (b.max[i] - b.min[i])
                        .total_cmp(&(b.max[j] - b.min[j]))
                        .then(j.cmp(&i))
                })
                .unwrap_or(0),
            other => {
                return Err(EntryError::Range {
                    key: "mesh_axis",
                    expected: "x, y, z or longest",
                    got: format!("'{other}'"),
                })
            }
        };
        let mut a = [0.0; 3];
        a[k] = 1.0;
        Ok(a)
    }

    /// The term this entry describes on a mesh placed at `place`.
    pub(super) fn term(
        &self,
        place: &Placement,
        mask: Option<Arc<Mask>>,
    ) -> Result<Term, EntryError> {
        let allowed = allowed_keys(&self.kind)?;
        if let Some(k) = self.present().into_iter().find(|k| !allowed.contains(k)) {
            return Err(EntryError::NotForKind { key: k });
        }
        let kind = match self.kind.as_str() {
            "uniform" => TermKind::Uniform,
            "noise" => TermKind::Noise,
            "curvature" => self.curvature_kind()?,
            "directional" => {
                one_of(
                    self.direction.is_some(),
                    self.mesh_axis.is_some(),
                    "direction",
                    "mesh_axis",
                )?;
                TermKind::Directional {
                    direction: match self.direction {
                        Some(d) => place.vector(d),
                        None => self.mesh_axis(&place.bounds)?,
                    },
                    checks: self.checks,
                }
            }
            "concentric" => {
                one_of(
                    self.center.is_some(),
                    self.center_relative.is_some(),
                    "center",
                    "center_relative",
                )?;
                one_of(
                    self.axis.is_some(),
                    self.mesh_axis.is_some(),
                    "axis",
                    "mesh_axis",
                )?;
                TermKind::Concentric {
                    center: match (self.center, self.center_relative) {
                        (Some(c), _) => place.point(c),
                        (None, Some(c)) => place.bounds.at(c),
                        _ => [0.0; 3],
                    },
                    axis: match self.axis {
                        Some(a) => place.vector(a),
                        None => self.mesh_axis(&place.bounds)?,
                    },
                }
            }
            _ => self.impact_kind(place)?,
        };
        Ok(Term {
            kind,
            init: self.init,
            evolve: self.evolve,
            mask,
        })
    }

    /// A curvature entry's kind: the field's scale when `separation` is
    /// given.
    fn curvature_kind(&self) -> Result<TermKind, EntryError> {
        if self.separation.is_none() {
            if let Some(k) = ["strength", "max_factor"]
                .into_iter()
                .find(|k| self.present().contains(k))
            {
                return Err(EntryError::Needs {
                    key: k,
                    needs: "separation",
                });
            }
            if self.init == 0.0 && self.evolve == 0.0 {
                return Err(EntryError::NoCurvatureLoad);
            }
        }
        Ok(TermKind::Curvature {
            scale: self.separation.map(|measure| CurvatureScale {
                measure,
                strength: self.strength.unwrap_or(1.0),
                max_factor: self.max_factor.unwrap_or(4.0),
            }),
        })
    }

    /// An impact entry's kind: its hit points (none: the default hit),
    /// radius and number of radial cracks, checked.
    fn impact_kind(&self, place: &Placement) -> Result<TermKind, EntryError> {
        // Neither: the hit lands where the asset faces the viewer
        // (`stress::field::default_hit`).
        if self.points.is_some() && self.points_relative.is_some() {
            return Err(EntryError::Both {
                first: "points",
                second: "points_relative",
            });
        }
        if let Some((key, [])) = [
            ("points", &self.points),
            ("points_relative", &self.points_relative),
        ]
        .into_iter()
        .find_map(|(k, p)| p.as_ref().map(|p| (k, p.as_slice())))
        {
            return Err(EntryError::NoPoints { key });
        }
        one_of(
            self.radius.is_some(),
            self.radius_relative.is_some(),
            "radius",
            "radius_relative",
        )?;
        let points = match (&self.points, &self.points_relative) {
            (Some(p), _) => p.iter().map(|&q| place.point(q)).collect(),
            (None, Some(p)) => p.iter().map(|&q| place.bounds.at(q)).collect(),
            _ => Vec::new(),
        };
        let radius = match (self.radius, self.radius_relative) {
            (Some(r), _) => place.length(r),
            (None, Some(r)) => r * place.bounds.diagonal(),
            _ => 0.0,
        };
        if let Some(r) = self.radius.or(self.radius_relative) {
            if !(r.is_finite() && r > 0.0) {
                let key = if self.radius.is_some() {
                    "radius"
                } else {
                    "radius_relative"
                };
                return Err(EntryError::Range {
                    key,
                    expected: "> 0",
                    got: r.to_string(),
                });
            }
        }
        let radial_cracks = match (self.speed, self.radial_cracks) {
            (Some(_), Some(_)) => {
                return Err(EntryError::Both {
                    first: "speed",
                    second: "radial_cracks",
                })
            }
            (Some(v), None) if !(v.is_finite() && v > 0.0 && v <= 1e4) => {
                return Err(EntryError::Range {
                    key: "speed",
                    expected: "in (0, 10000] m/s",
                    got: v.to_string(),
                })
            }
            (Some(v), None) => crate::stress::impact::rays_for_speed(v),
            (None, Some(n))
                if !(crate::stress::impact::MIN_RAYS..=crate::stress::impact::MAX_RAYS)
                    .contains(&n) =>
            {
                return Err(EntryError::Range {
                    key: "radial_cracks",
                    expected: "3 to 64",
                    got: n.to_string(),
                })
            }
            (None, Some(n)) => n,
            (None, None) => 0,
        };
        if radial_cracks > 0 && self.concentric_factor.is_some() {
            return Err(EntryError::ConcentricFactorWithRays);
        }
        Ok(TermKind::Impact {
            points,
            radius,
            concentric_factor: self.concentric_factor.unwrap_or(1.25),
            radial_cracks,
            in_turn: self.in_turn.unwrap_or(false),
        })
    }
}

/// The keys a stress entry of `kind` may have beside the common ones.
fn allowed_keys(kind: &str) -> Result<&'static [&'static str], EntryError> {
    Ok(match kind {
        "uniform" | "noise" => &[],
        "curvature" => &["separation", "strength", "max_factor"],
        "directional" => &["direction", "mesh_axis", "checks"],
        "concentric" => &["center", "center_relative", "axis", "mesh_axis"],
        "impact" => &[
            "points",
            "points_relative",
            "radius",
            "radius_relative",
            "concentric_factor",
            "speed",
            "radial_cracks",
            "in_turn",
        ],
        other => {
            return Err(EntryError::UnknownKind {
                kind: other.to_string(),
            })
        }
    })
}

/// Exactly one of two keys `an` and `bn` (present: `a`, `b`).
fn one_of(a: bool, b: bool, an: &'static str, bn: &'static str) -> Result<(), EntryError> {
    match (a, b) {
        (true, true) => Err(EntryError::Both {
            first: an,
            second: bn,
        }),
        (false, false) => Err(EntryError::Missing {
            key: an,
            alternative: bn,
        }),
        _ => Ok(()),
    }
}
