//! Stress initialisers and evolution terms (Iben & O'Brien 2009, sec. 4.2):
//! each term gives every face a unit tangent tensor from the face's geometry;
//! a term's `init` weight adds it to the starting stress and its `evolve`
//! weight adds it per unit of relaxation time while the load acts. Several
//! terms combine by summing.
//!
//! Positions, directions and radii are in the mesh's own coordinates (scene
//! units of the mesh before its node transforms).

use crate::mesh::{FaceId, SimMesh};
use crate::stress::tensor::{v3, Sym3};

/// What a term adds to a face (before its weights).
#[derive(Clone, Debug, PartialEq)]
pub enum TermKind {
    /// Uniform shrinkage: `I - n n^T` (the tangent identity).
    Uniform,
    /// A direction projected into each triangle, `v v^T` with `v = P d`
    /// (eq. 10): wood grain. Cracks form across it.
    Directional {
        /// World direction (normalised here).
        direction: [f64; 3],
    },
    /// Stress along circles around an axis (tree rings): the impact
    /// construction's perpendicular to the direction away from the axis.
    /// Cracks form across the rings, radially.
    Concentric {
        /// A point on the axis.
        center: [f64; 3],
        /// The axis direction (normalised here).
        axis: [f64; 3],
    },
    /// Impacts (eqs. 11-13): within `radius` of each point (projected onto
    /// the surface), weight `w = 2 cos(d / r)`, radial `v = w P (c - p)/|c - p|`
    /// and concentric `concentric_factor * n x v`, both added as `v v^T`.
    Impact {
        /// Impact points (projected onto the surface before use).
        points: Vec<[f64; 3]>,
        /// Radius of influence (mesh units), > 0.
        radius: f64,
        /// Concentric over radial factor (the paper's 1.25).
        concentric_factor: f64,
    },
    /// Seeded noise for material inhomogeneity: a random magnitude in [0, 1]
    /// along a random in-plane direction per input triangle.
    Noise,
}

/// One stress term with its weights.
#[derive(Clone, Debug, PartialEq)]
pub struct Term {
    /// What it adds.
    pub kind: TermKind,
    /// Weight added to the initial stress (dimensionless stress).
    pub init: f64,
    /// Weight added per unit of relaxation time while the load acts.
    pub evolve: f64,
}

/// Per-face initial stress and evolution rate, indexed by face id.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StressField {
    /// Initial stress.
    pub init: Vec<Sym3>,
    /// Added per unit of relaxation time while the load acts.
    pub evolve: Vec<Sym3>,
}

/// Errors in a term's values.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FieldError {
    /// A value is out of range; the message names it.
    #[error("{0}")]
    Invalid(String),
}

fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = v3::norm(a);
    (n > 0.0 && n.is_finite()).then(|| v3::scale(a, 1.0 / n))
}

/// Centroid and unit normal of a face (`None` when degenerate).
fn face_frame(mesh: &SimMesh, f: FaceId) -> Option<([f64; 3], [f64; 3])> {
    let [a, b, c] = mesh.face_vertices(f).map(|v| mesh.position(v));
    let n = unit(v3::cross(v3::sub(b, a), v3::sub(c, a)))?;
    let centroid = v3::scale(v3::add(v3::add(a, b), c), 1.0 / 3.0);
    Some((centroid, n))
}

/// Project `v` into the plane with unit normal `n`.
fn in_plane(v: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    v3::sub(v, v3::scale(n, v3::dot(v, n)))
}

/// A uniform value in [0, 1) from `seed` and `key`.
fn hash01(seed: u64, key: u64) -> f64 {
    0.5 * (crate::sim::driver::hash_unit(seed, key) + 1.0)
}

impl Term {
    /// Check the term's values, naming the one that is wrong.
    pub fn validate(&self) -> Result<(), FieldError> {
        let bad = |m: String| Err(FieldError::Invalid(m));
        if !self.init.is_finite() || !self.evolve.is_finite() {
            return bad("init and evolve weights must be finite numbers".into());
        }
        match &self.kind {
            TermKind::Directional { direction } => {
                if unit(*direction).is_none() {
                    return bad(format!(
                        "direction must be a nonzero vector, got {direction:?}"
                    ));
                }
            }
            TermKind::Concentric { center, axis } => {
                if unit(*axis).is_none() {
                    return bad(format!("axis must be a nonzero vector, got {axis:?}"));
                }
                if center.iter().any(|x| !x.is_finite()) {
                    return bad(format!("center must be finite, got {center:?}"));
                }
            }
            TermKind::Impact {
                points,
                radius,
                concentric_factor,
            } => {
                if !(radius.is_finite() && *radius > 0.0) {
                    return bad(format!("radius must be > 0, got {radius}"));
                }
                if !(concentric_factor.is_finite() && *concentric_factor >= 0.0) {
                    return bad(format!(
                        "concentric_factor must be >= 0, got {concentric_factor}"
                    ));
                }
                if points.is_empty() {
                    return bad("impact needs at least one point".into());
                }
                if points.iter().flatten().any(|x| !x.is_finite()) {
                    return bad("impact points must be finite".into());
                }
            }
            TermKind::Uniform | TermKind::Noise => {}
        }
        Ok(())
    }

    /// The term's unit tensor on face `f` (zero on a degenerate face).
    /// `impacts` are the impact points already projected onto the surface.
    fn tensor(&self, mesh: &SimMesh, f: FaceId, impacts: &[[f64; 3]], seed: u64) -> Sym3 {
        let Some((c, n)) = face_frame(mesh, f) else {
            return Sym3::ZERO;
        };
        match &self.kind {
            TermKind::Uniform => Sym3::tangent_identity(n, 1.0),
            TermKind::Directional { direction } => {
                let d = unit(*direction).unwrap_or([0.0; 3]);
                Sym3::outer(in_plane(d, n))
            }
            TermKind::Concentric { center, axis } => {
                let a = unit(*axis).unwrap_or([0.0, 0.0, 1.0]);
                let r = v3::sub(c, *center);
                let r = v3::sub(r, v3::scale(a, v3::dot(r, a)));
                match unit(r) {
                    Some(r) => Sym3::outer(v3::cross(n, in_plane(r, n))),
                    None => Sym3::ZERO, // on the axis: no ring direction
                }
            }
            TermKind::Impact {
                radius,
                concentric_factor,
                ..
            } => {
                let mut s = Sym3::ZERO;
                for p in impacts {
                    let to = v3::sub(c, *p);
                    let d = v3::norm(to);
                    if d > *radius {
                        continue;
                    }
                    let w = 2.0 * (d / radius).cos();
                    match unit(to) {
                        Some(u) => {
                            let v_rad = v3::scale(in_plane(u, n), w);
                            let v_circ = v3::scale(v3::cross(n, v_rad), *concentric_factor);
                            s += Sym3::outer(v_rad) + Sym3::outer(v_circ);
                        }
                        // The face the point hits: no direction, the mean of both.
                        None => {
                            s += Sym3::tangent_identity(
                                n,
                                0.5 * w * w * (1.0 + concentric_factor * concentric_factor),
                            )
                        }
                    }
                }
                s
            }
            TermKind::Noise => {
                let key = u64::from(mesh.face_source(f));
                let magnitude = hash01(seed ^ 0x6E6F_6973_6531, key);
                let angle = std::f64::consts::PI * hash01(seed ^ 0x6E6F_6973_6532, key);
                // An in-plane frame from the face's first edge.
                let [a, b, _] = mesh.face_vertices(f).map(|v| mesh.position(v));
                let e1 = unit(in_plane(v3::sub(b, a), n)).unwrap_or([0.0; 3]);
                let e2 = v3::cross(n, e1);
                let d = v3::add(v3::scale(e1, angle.cos()), v3::scale(e2, angle.sin()));
                Sym3::outer(d) * magnitude
            }
        }
    }
}

/// Project points onto the surface of `mesh` (closest point), with parry3d.
/// Only called when an impact term is present.
pub fn project_onto_surface(mesh: &SimMesh, points: &[[f64; 3]]) -> Vec<[f64; 3]> {
    use parry3d::math::Vector;
    use parry3d::query::PointQuery;
    let verts: Vec<Vector> = mesh
        .vertices()
        .map(|v| {
            let p = mesh.position(v);
            Vector::new(p[0] as f32, p[1] as f32, p[2] as f32)
        })
        .collect();
    let tris: Vec<[u32; 3]> = mesh
        .faces()
        .map(|f| mesh.face_vertices(f).map(|v| v.0))
        .collect();
    let Ok(tm) = parry3d::shape::TriMesh::new(verts, tris) else {
        return points.to_vec();
    };
    points
        .iter()
        .map(|p| {
            let q = Vector::new(p[0] as f32, p[1] as f32, p[2] as f32);
            let r = tm.project_local_point(q, false).point;
            [f64::from(r.x), f64::from(r.y), f64::from(r.z)]
        })
        .collect()
}

impl StressField {
    /// Evaluate `terms` on every face of `mesh`.
    ///
    /// # Errors
    /// A term with an invalid value (the message names it and the term).
    pub fn build(mesh: &SimMesh, terms: &[Term], seed: u64) -> Result<StressField, FieldError> {
        for (i, t) in terms.iter().enumerate() {
            t.validate().map_err(|FieldError::Invalid(m)| {
                FieldError::Invalid(format!("stress term {i}: {m}"))
            })?;
        }
        let impacts: Vec<Vec<[f64; 3]>> = terms
            .iter()
            .map(|t| match &t.kind {
                TermKind::Impact { points, .. } => project_onto_surface(mesh, points),
                _ => Vec::new(),
            })
            .collect();
        let mut field = StressField {
            init: vec![Sym3::ZERO; mesh.n_faces()],
            evolve: vec![Sym3::ZERO; mesh.n_faces()],
        };
        for f in mesh.faces() {
            for (t, imp) in terms.iter().zip(&impacts) {
                if t.init == 0.0 && t.evolve == 0.0 {
                    continue;
                }
                let s = t.tensor(mesh, f, imp, seed);
                field.init[f.idx()] += s * t.init;
                field.evolve[f.idx()] += s * t.evolve;
            }
        }
        Ok(field)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::forces::tests::jittered_plate;

    fn eig(s: &Sym3) -> ([f64; 3], [[f64; 3]; 3]) {
        s.eigen()
    }

    #[test]
    fn directional_term_is_the_projected_direction() {
        let mesh = jittered_plate(4, 0.2, 1);
        let t = Term {
            kind: TermKind::Directional {
                direction: [1.0, 0.0, 1.0],
            },
            init: 1.0,
            evolve: 0.0,
        };
        let field = StressField::build(&mesh, &[t], 1).unwrap();
        // The plate is in z = 0: the x part remains, length 1/sqrt(2).
        for s in &field.init {
            assert!((s.xx - 0.5).abs() < 1e-12 && s.yy.abs() < 1e-12 && s.zz.abs() < 1e-12);
        }
    }

    #[test]
    fn concentric_and_impact_directions() {
        let mesh = jittered_plate(10, 0.2, 2);
        let center = [5.0, 5.0, 3.0]; // above the plate: projected to (5, 5, 0)
        let rings = Term {
            kind: TermKind::Concentric {
                center,
                axis: [0.0, 0.0, 1.0],
            },
            init: 1.0,
            evolve: 0.0,
        };
        let impact = Term {
            kind: TermKind::Impact {
                points: vec![center],
                radius: 4.0,
                concentric_factor: 1.25,
            },
            init: 1.0,
            evolve: 0.0,
        };
        let fr = StressField::build(&mesh, &[rings], 1).unwrap();
        let fi = StressField::build(&mesh, &[impact], 1).unwrap();
        for f in mesh.faces() {
            let (c, _) = face_frame(&mesh, f).unwrap();
            let r = [c[0] - 5.0, c[1] - 5.0, 0.0];
            let d = v3::norm(r);
            if d < 1e-9 {
                continue;
            }
            let radial = v3::scale(r, 1.0 / d);
            // Rings: the largest stress is along the circle, none radially.
            let s = &fr.init[f.idx()];
            assert!(s.quad(radial, radial).abs() < 1e-12);
            let (vals, vecs) = eig(s);
            let k = (0..3).max_by(|&a, &b| vals[a].total_cmp(&vals[b])).unwrap();
            assert!(v3::dot(vecs[k], radial).abs() < 1e-9);
            // Impact: inside the radius the concentric part is 1.25^2 the radial one,
            // weight 2 cos(d / r); zero outside.
            let s = &fi.init[f.idx()];
            let circ = [-radial[1], radial[0], 0.0];
            if d <= 4.0 {
                let w = 2.0 * (d / 4.0).cos();
                assert!((s.quad(radial, radial) - w * w).abs() < 1e-9);
                assert!((s.quad(circ, circ) - 1.5625 * w * w).abs() < 1e-9);
            } else {
                assert!(s.frobenius_sq() < 1e-20);
            }
        }
    }

    #[test]
    fn noise_is_seeded_and_bounded() {
        let mesh = jittered_plate(6, 0.2, 3);
        let t = Term {
            kind: TermKind::Noise,
            init: 0.0,
            evolve: 2.0,
        };
        let a = StressField::build(&mesh, std::slice::from_ref(&t), 7).unwrap();
        let b = StressField::build(&mesh, std::slice::from_ref(&t), 7).unwrap();
        let c = StressField::build(&mesh, &[t], 8).unwrap();
        assert_eq!(a, b);
        assert_ne!(a, c);
        for s in &a.evolve {
            let tr = s.trace();
            assert!((0.0..=2.0).contains(&tr), "{tr}");
        }
    }

    #[test]
    fn bad_values_are_named() {
        let mesh = jittered_plate(2, 0.0, 1);
        let t = Term {
            kind: TermKind::Impact {
                points: vec![[0.0; 3]],
                radius: 0.0,
                concentric_factor: 1.25,
            },
            init: 1.0,
            evolve: 0.0,
        };
        let e = StressField::build(&mesh, &[t], 1).unwrap_err().to_string();
        assert!(e.contains("radius") && e.contains("term 0"), "{e}");
    }
}
