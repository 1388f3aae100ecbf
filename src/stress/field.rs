//! Stress initialisers and evolution terms (Iben & O'Brien 2009, sec. 4.2):
//! each term gives every face a unit tangent tensor from the face's geometry;
//! a term's `init` weight adds it to the starting stress and its `evolve`
//! weight adds it per unit of relaxation time while the load acts. Several
//! terms combine by summing.
//!
//! Positions, directions and radii are in the mesh's own coordinates (scene
//! units of the mesh before its node transforms).

use super::frame::{face_frame, in_plane, unit};
pub use super::frame::{FieldError, TermFault};
use super::mask_coords::MaskCoords;
use crate::geometry::curvature::{self, Curvature, CurvatureField};
use crate::math::{v3, Sym3};
use crate::mesh::{FaceId, SimMesh};
use crate::stress::texture::Mask;
use std::sync::Arc;

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
        /// Drying checks instead of cracks from end to end: the stress is
        /// held to staggered lens-shaped patches about this many cell sizes
        /// long along the grain (across the direction) and a third of a
        /// cell wide, from seeded noise stretched along the grain, so each
        /// crack stops where its patch ends. `None`: the same everywhere.
        checks: Option<f64>,
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
    /// Impacts. With `radial_cracks` > 0, a star from each point
    /// ([`super::impact::Star`]: radial cracks, rings between them, no
    /// cut-off; distances along the surface). With 0, the paper's disc
    /// (eqs. 11-13): within `radius` of each point (projected onto the
    /// surface), weight `w = 2 cos(d / r)`, radial `v = w P (c - p)/|c - p|`
    /// and concentric `concentric_factor * n x v`, both added as `v v^T`.
    Impact {
        /// Impact points (projected onto the surface before use); empty:
        /// one hit where the asset faces the viewer ([`default_hit`]).
        points: Vec<[f64; 3]>,
        /// Radius of influence (mesh units), > 0: the disc's radius; the
        /// star's reference radius (its hoop tension halves by 0.35 R).
        radius: f64,
        /// Concentric over radial factor of the disc (the paper's 1.25).
        concentric_factor: f64,
        /// Radial cracks of each star (0: the paper's disc).
        radial_cracks: u32,
        /// The points hit one after another (stars only): the first loads
        /// the start, each further one once the cracks before it have come
        /// to rest, its load measured along the surface as cracked by then
        /// ([`LaterHit`]), so a later star stops at the earlier cracks.
        /// `false`: all at once.
        in_turn: bool,
    },
    /// Seeded noise for material inhomogeneity: a random magnitude in [0, 1]
    /// along a random in-plane direction per input triangle.
    Noise,
    /// Curvature: the per-face curvature tensor `k1 d1 d1^T + k2 d2 d2^T`
    /// (convex positive), scaled so its area-weighted RMS Frobenius norm over
    /// the mesh is that of the tangent identity (`sqrt 2`): a weight of 1 adds
    /// as much stress as uniform shrinkage where the curvature is typical (on
    /// a sphere, exactly the tangent identity).
    /// Optionally also scales every node's separation tensor by a curvature
    /// measure (see [`CurvatureScale`]).
    Curvature {
        /// Scale the separation tensor as well (`None`: only the tensor term).
        scale: Option<CurvatureScale>,
    },
}

/// A scalar measure of curvature per face.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CurvatureMeasure {
    /// `|k1 k2|`.
    Gaussian,
    /// `|k1 + k2| / 2`.
    Mean,
    /// `sqrt(k1^2 + k2^2)`.
    Frobenius,
    /// `k1^2 + k2^2`.
    SumSquares,
}

impl CurvatureMeasure {
    /// The measure's value for `c` (never negative).
    pub(crate) fn of(self, c: &Curvature) -> f64 {
        match self {
            CurvatureMeasure::Gaussian => c.gaussian().abs(),
            CurvatureMeasure::Mean => c.mean().abs(),
            CurvatureMeasure::Frobenius => c.frobenius(),
            CurvatureMeasure::SumSquares => c.k1 * c.k1 + c.k2 * c.k2,
        }
    }
}

/// Scaling of the separation tensor by curvature: each face gets the factor
/// `clamp(1 + strength (m / m_ref - 1), 0, max_factor)`, with `m` the
/// face's measure of the curvature at the cell's scale (`cell_curvature`,
/// in world units) and `m_ref` the measure of a sphere of
/// [`BEND_RADIUS_CELLS`] cells' radius: so how much a surface bends is
/// judged against the cell size, not against the mesh's own mean (a flat
/// noisy ground does not count as curved); a node's separation is
/// multiplied by the mean factor of its faces. `strength = 1` makes the
/// separation proportional to the measure (flat regions never crack);
/// `strength = 0` changes nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvatureScale {
    /// Which measure.
    pub measure: CurvatureMeasure,
    /// How strongly it scales, >= 0.
    pub strength: f64,
    /// Largest factor, > 0.
    pub max_factor: f64,
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
    /// A texture mask multiplying the term on each face by the mask's weight
    /// at the face centroid's UV (black = 1, white = 0 unless inverted).
    pub mask: Option<Arc<Mask>>,
}

/// Per-face initial stress and evolution rate, indexed by face id.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StressField {
    /// Initial stress.
    pub init: Vec<Sym3>,
    /// Added per unit of relaxation time while the load acts.
    pub evolve: Vec<Sym3>,
    /// Factor on each face's contribution to the separation tensor (empty:
    /// 1 everywhere); from [`CurvatureScale`] terms, which multiply.
    pub separation_scale: Vec<f64>,
    /// Hits that land later, in order: each adds its load once the
    /// simulation has come to rest under the loads before it.
    pub later: Vec<LaterHit>,
    /// The terms whose mask is projected along the axes because the mesh
    /// has no UV set (see the term's mask), in order.
    pub projected_masks: Vec<usize>,
}

/// An impact that lands once the cracks before it have come to rest (an
/// impact term's points after its first, with `in_turn`): its star is
/// built on the surface as cracked by then, so its load does not reach
/// past the earlier cracks and its radial cracks end at them.
#[derive(Clone, Debug, PartialEq)]
pub struct LaterHit {
    /// Where it hits (on the surface).
    pub point: [f64; 3],
    /// The star's reference radius (mesh units).
    pub radius: f64,
    /// Radial cracks.
    pub radial_cracks: u32,
    /// Weight on the stress it adds.
    pub weight: f64,
    /// The term's mask, if any.
    pub mask: Option<Arc<Mask>>,
    seed: u64,
    index: u64,
}

impl LaterHit {
    /// The stress the hit adds to each face of `mesh` (the surface as
    /// cracked when it lands).
    pub fn stress(&self, mesh: &SimMesh) -> Vec<Sym3> {
        let star = super::impact::Star::new(
            mesh,
            self.point,
            self.radius,
            self.radial_cracks,
            self.seed,
            self.index,
        );
        let coords = self
            .mask
            .as_ref()
            .and_then(|m| MaskCoords::of(mesh, m).ok());
        mesh.faces()
            .map(|f| {
                let Some((_, n)) = face_frame(mesh, f) else {
                    return Sym3::ZERO;
                };
                let w = match (&self.mask, &coords) {
                    (Some(m), Some(c)) => c.weight(mesh, f, m),
                    _ => 1.0,
                };
                if w == 0.0 {
                    return Sym3::ZERO;
                }
                star.tensor(f.idx(), n) * (w * self.weight)
            })
            .collect()
    }
}

/// A uniform value in [0, 1) from `seed` and `key`.
fn hash01(seed: u64, key: u64) -> f64 {
    0.5 * (crate::math::hash_unit(seed, key) + 1.0)
}

impl Term {
    /// Check the term's values, naming the one that is wrong.
    pub fn validate(&self) -> Result<(), FieldError> {
        let bad = |fault: TermFault| Err(fault.into());
        if !self.init.is_finite() || !self.evolve.is_finite() {
            return bad(TermFault::Weights);
        }
        match &self.kind {
            TermKind::Directional { direction, checks } => {
                if unit(*direction).is_none() {
                    return bad(TermFault::Direction(*direction));
                }
                if let Some(len) = checks {
                    if !(0.5..=50.0).contains(len) {
                        return bad(TermFault::Checks(*len));
                    }
                }
            }
            TermKind::Concentric { center, axis } => {
                if unit(*axis).is_none() {
                    return bad(TermFault::Axis(*axis));
                }
                if center.iter().any(|x| !x.is_finite()) {
                    return bad(TermFault::Center(*center));
                }
            }
            TermKind::Impact {
                points,
                radius,
                concentric_factor,
                radial_cracks,
                in_turn,
            } => {
                if *in_turn && *radial_cracks == 0 {
                    return bad(TermFault::InTurnWithoutStars);
                }
                if *in_turn && self.evolve != 0.0 {
                    return bad(TermFault::InTurnEvolves);
                }
                if !(radius.is_finite() && *radius > 0.0) {
                    return bad(TermFault::Radius(*radius));
                }
                if !(concentric_factor.is_finite() && *concentric_factor >= 0.0) {
                    return bad(TermFault::ConcentricFactor(*concentric_factor));
                }
                if *radial_cracks > super::impact::MAX_RAYS {
                    return bad(TermFault::RadialCracks {
                        got: *radial_cracks,
                        max: super::impact::MAX_RAYS,
                    });
                }
                if points.iter().flatten().any(|x| !x.is_finite()) {
                    return bad(TermFault::Points);
                }
            }
            TermKind::Curvature { scale } => {
                if let Some(sc) = scale {
                    if !(sc.strength.is_finite() && sc.strength >= 0.0) {
                        return bad(TermFault::Strength(sc.strength));
                    }
                    if !(sc.max_factor.is_finite() && sc.max_factor > 0.0) {
                        return bad(TermFault::MaxFactor(sc.max_factor));
                    }
                }
            }
            TermKind::Uniform | TermKind::Noise => {}
        }
        Ok(())
    }

    /// Whether the term needs the curvature estimate.
    pub fn needs_curvature(&self) -> bool {
        matches!(self.kind, TermKind::Curvature { .. })
    }

    /// The term's unit tensor on face `f` times its mask weight.
    fn masked_tensor(&self, mesh: &SimMesh, f: FaceId, ctx: &Context) -> Sym3 {
        let w = match (&self.mask, &ctx.mask_coords) {
            (Some(m), Some(c)) => c.weight(mesh, f, m),
            _ => 1.0,
        };
        if w == 0.0 {
            return Sym3::ZERO;
        }
        self.tensor(mesh, f, ctx) * w
    }

    /// The term's unit tensor on face `f` (zero on a degenerate face).
    fn tensor(&self, mesh: &SimMesh, f: FaceId, ctx: &Context) -> Sym3 {
        let Some((c, n)) = face_frame(mesh, f) else {
            return Sym3::ZERO;
        };
        match &self.kind {
            TermKind::Uniform => Sym3::tangent_identity(n, 1.0),
            TermKind::Directional { direction, checks } => {
                let d = unit(*direction).unwrap_or([0.0; 3]);
                let w = match checks {
                    Some(len) => {
                        let e = mesh
                            .face_vertices(f)
                            .map(|v| {
                                ctx.edge_distance
                                    .get(v.idx())
                                    .copied()
                                    .unwrap_or(f64::INFINITY)
                            })
                            .iter()
                            .sum::<f64>()
                            / 3.0;
                        let near = (-e / (CHECK_EDGE_REACH * ctx.cell)).exp();
                        // Wood dries faster there: more checks, more stress.
                        (1.0 + CHECK_EDGE_BOOST * near)
                            * check_weight(ctx.seed, c, d, *len * ctx.cell, CHECK_EDGE_DROP * near)
                    }
                    None => 1.0,
                };
                Sym3::outer(in_plane(d, n)) * w
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
            TermKind::Impact { radial_cracks, .. } if *radial_cracks > 0 => ctx
                .stars
                .iter()
                .fold(Sym3::ZERO, |s, star| s + star.tensor(f.idx(), n)),
            TermKind::Impact {
                radius,
                concentric_factor,
                ..
            } => {
                let mut s = Sym3::ZERO;
                for p in &ctx.impacts {
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
                let magnitude = hash01(ctx.seed ^ 0x6E6F_6973_6531, key);
                let angle = std::f64::consts::PI * hash01(ctx.seed ^ 0x6E6F_6973_6532, key);
                // An in-plane frame from the face's first edge.
                let [a, b, _] = mesh.face_vertices(f).map(|v| mesh.position(v));
                let e1 = unit(in_plane(v3::sub(b, a), n)).unwrap_or([0.0; 3]);
                let e2 = v3::cross(n, e1);
                let d = v3::add(v3::scale(e1, angle.cos()), v3::scale(e2, angle.sin()));
                Sym3::outer(d) * magnitude
            }
            TermKind::Curvature { .. } => match (ctx.curvature, ctx.curvature_rms) {
                (Some(k), rms) if rms > 0.0 => {
                    k.per_face_tensor[f.idx()] * (std::f64::consts::SQRT_2 / rms)
                }
                _ => Sym3::ZERO,
            },
        }
    }
}

/// What a term needs beyond the face: per term, built once per mesh.
struct Context<'a> {
    seed: u64,
    /// Impact points projected onto the surface (impact terms).
    impacts: Vec<[f64; 3]>,
    /// Each impact's star (impact terms with radial cracks).
    stars: Vec<super::impact::Star>,
    /// Where a mask samples (masked terms).
    mask_coords: Option<MaskCoords<'a>>,
    curvature: Option<&'a CurvatureField>,
    /// Area-weighted RMS of the curvature tensors' Frobenius norms.
    curvature_rms: f64,
    /// The cell size: [`EDGES_PER_CELL`] mean edges (directional checks).
    cell: f64,
    /// Directional checks: each vertex's distance along the surface from
    /// the nearest edge of the piece (its border or a sharp crease).
    edge_distance: Vec<f64>,
}

/// Edges across one cell of the remeshed simulation surface (the film's
/// surface is remeshed to this many edges a cell; on a surface cracked on
/// its own triangles, a cell is this many of them).
pub const EDGES_PER_CELL: f64 = 8.0;

/// A surface bends, for [`CurvatureScale`], where it is as curved as a
/// sphere of this many cells' radius: the measure there is the reference.
pub const BEND_RADIUS_CELLS: f64 = 3.0;

/// The curvature of `mesh` at the pattern's scale: the estimate with the
/// normals averaged over half a cell ([`EDGES_PER_CELL`] mean edges), so a
/// noisy ground's grain does not count as bending and a cell-sized bend does.
pub fn cell_curvature(mesh: &SimMesh) -> CurvatureField {
    curvature::estimate_at_scale(mesh, 0.5 * cell_size(mesh))
}

/// The cell size of `mesh`'s pattern: [`EDGES_PER_CELL`] mean edges.
fn cell_size(mesh: &SimMesh) -> f64 {
    EDGES_PER_CELL * mesh.mean_edge_length()
}

/// How much of a directional term acts at `c` when it makes drying checks
/// `length` long (world units) across the unit direction `d`: seeded noise
/// stretched along the grain (a unit of noise is half the length along it,
/// [`CHECK_STRETCH`] times less across: its bumps are lens-shaped), above a
/// threshold, so patches about `length` long and staggered, stressed most
/// in their middle, with nothing between them.
///
/// `drop` lowers the threshold (and the level of full action) by that much:
/// checks crowd toward the piece's edges and ends, where wood dries first.
fn check_weight(seed: u64, c: [f64; 3], d: [f64; 3], length: f64, drop: f64) -> f64 {
    let across = v3::dot(c, d);
    let along = v3::sub(c, v3::scale(d, across));
    let unit_along = 0.5 * length.max(f64::MIN_POSITIVE);
    let q = v3::add(
        v3::scale(along, 1.0 / unit_along),
        v3::scale(d, across * CHECK_STRETCH / unit_along),
    );
    let v = crate::math::value_noise(seed ^ 0x6368_6563_6b73, q);
    ((v - CHECK_THRESHOLD + drop) / (CHECK_FULL - CHECK_THRESHOLD)).clamp(0.0, 1.0)
}

/// How far the lower threshold at a piece's edges reaches, in cell sizes
/// (it falls as `exp(-distance / reach)`).
const CHECK_EDGE_REACH: f64 = 1.5;
/// How much lower the checks' threshold is right at an edge.
const CHECK_EDGE_DROP: f64 = 0.2;
/// How much more the stress is right at an edge (a share of the term's).
const CHECK_EDGE_BOOST: f64 = 1.0;

/// Each vertex's distance along the surface from the piece's edges: its
/// open border and its sharp creases (faces meeting at more than 60
/// degrees), where wood dries first (end grain, arrises).
fn edge_distances(mesh: &SimMesh) -> Vec<f64> {
    let cos_sharp = 60f64.to_radians().cos();
    let mut sources: Vec<(u32, f64)> = Vec::new();
    for h in mesh.halfedges() {
        let edge = match mesh.twin(h) {
            None => true,
            Some(t) => {
                t.0 > h.0
                    && v3::dot(
                        mesh.face_normal(mesh.face(h)),
                        mesh.face_normal(mesh.face(t)),
                    ) < cos_sharp
            }
        };
        if edge {
            sources.push((mesh.origin(h).0, 0.0));
            sources.push((mesh.dest(h).0, 0.0));
        }
    }
    super::geodesic::distances_from(mesh, &sources)
}

/// How much finer the checks' noise runs across the grain than along it.
const CHECK_STRETCH: f64 = 6.0;
/// The noise level under which a directional term with checks does not act.
const CHECK_THRESHOLD: f64 = 0.2;
/// The noise level from which it acts in full.
const CHECK_FULL: f64 = 0.5;

/// Area-weighted mean of `value` over the faces of `mesh`.
fn area_mean(mesh: &SimMesh, value: impl Fn(FaceId) -> f64) -> f64 {
    let (mut sum, mut area) = (0.0, 0.0);
    for f in mesh.faces() {
        let a = mesh.face_area(f);
        let x = value(f);
        if a > 0.0 && x.is_finite() {
            sum += a * x;
            area += a;
        }
    }
    if area > 0.0 {
        sum / area
    } else {
        0.0
    }
}

/// The surface of `mesh` as a parry3d triangle mesh (`None` when parry
/// refuses it).
fn query_mesh(mesh: &SimMesh) -> Option<parry3d::shape::TriMesh> {
    use parry3d::math::Vector;
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
    parry3d::shape::TriMesh::new(verts, tris).ok()
}

fn closest(tm: &parry3d::shape::TriMesh, p: [f64; 3]) -> [f64; 3] {
    use parry3d::math::Vector;
    use parry3d::query::PointQuery;
    let q = Vector::new(p[0] as f32, p[1] as f32, p[2] as f32);
    let r = tm.project_local_point(q, false).point;
    [f64::from(r.x), f64::from(r.y), f64::from(r.z)]
}

/// Project points onto the surface of `mesh` (closest point), with parry3d.
/// Only called when an impact term is present.
pub fn project_onto_surface(mesh: &SimMesh, points: &[[f64; 3]]) -> Vec<[f64; 3]> {
    match query_mesh(mesh) {
        Some(tm) => points.iter().map(|&p| closest(&tm, p)).collect(),
        None => points.to_vec(),
    }
}

/// The axis (0 x, 1 y, 2 z) an impact with no point given comes along, from
/// its positive side, for a box of extents `ext`: from above (+y, glTF's up)
/// when the asset lies flat (its height under half its smaller horizontal
/// extent: a ground, a pane on a table), else from the front along the
/// thinner horizontal axis (a standing teapot's body, a cow's side, an
/// upright window).
pub fn hit_axis(ext: [f64; 3]) -> usize {
    if ext[1] < 0.5 * ext[0].min(ext[2]) {
        1
    } else if ext[2] <= ext[0] {
        2
    } else {
        0
    }
}

/// Where an impact with no point given lands on `mesh`: the first surface
/// point on a line through the middle of its bounding box along
/// [`hit_axis`], coming from outside; where that line misses the surface (a
/// ring), the surface point closest to the middle of the box's face on that
/// side.
pub fn default_hit(mesh: &SimMesh) -> [f64; 3] {
    use parry3d::math::Vector;
    use parry3d::query::{Ray, RayCast};
    let (lo, hi) = mesh.bounding_box();
    if mesh.n_vertices() == 0 || !lo.iter().chain(&hi).all(|x| x.is_finite()) {
        return [0.0; 3];
    }
    let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let axis = hit_axis(ext);
    let mut face = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    face[axis] = hi[axis];
    let Some(tm) = query_mesh(mesh) else {
        return face;
    };
    let diag = v3::norm(ext);
    let mut origin = face;
    origin[axis] += 0.01 * diag + f64::MIN_POSITIVE;
    let mut dir = [0.0f32; 3];
    dir[axis] = -1.0;
    let ray = Ray::new(
        Vector::new(origin[0] as f32, origin[1] as f32, origin[2] as f32),
        Vector::new(dir[0], dir[1], dir[2]),
    );
    let reach = (ext[axis] + 0.02 * diag) as f32;
    match tm.cast_local_ray(&ray, reach, false) {
        Some(t) => {
            let mut p = origin;
            p[axis] -= f64::from(t);
            closest(&tm, p)
        }
        None => closest(&tm, face),
    }
}

impl StressField {
    /// Evaluate `terms` on every face of `mesh` (estimating the curvature
    /// when a term needs it).
    ///
    /// # Errors
    /// A term with an invalid value, or a mask on a mesh without the UV set
    /// it samples (the message names the term).
    pub fn build(mesh: &SimMesh, terms: &[Term], seed: u64) -> Result<StressField, FieldError> {
        StressField::build_with(mesh, terms, seed, None)
    }

    /// As [`StressField::build`], with the curvature estimate given (it is
    /// estimated here when a term needs it and it is `None`).
    ///
    /// # Errors
    /// As [`StressField::build`].
    pub fn build_with(
        mesh: &SimMesh,
        terms: &[Term],
        seed: u64,
        curvature: Option<&CurvatureField>,
    ) -> Result<StressField, FieldError> {
        let named = |index: usize| {
            move |e: FieldError| match e {
                FieldError::Value { fault } => FieldError::Term { index, fault },
                other => other,
            }
        };
        for (i, t) in terms.iter().enumerate() {
            t.validate().map_err(named(i))?;
        }
        let estimated;
        let curvature = match curvature {
            Some(k) => Some(k),
            None if terms.iter().any(Term::needs_curvature) => {
                estimated = cell_curvature(mesh);
                Some(&estimated)
            }
            None => None,
        };
        if let Some(k) = curvature {
            if k.per_face.len() != mesh.n_faces() || k.per_face_tensor.len() != mesh.n_faces() {
                return Err(FieldError::CurvatureFaces {
                    estimate: k.per_face.len(),
                    mesh: mesh.n_faces(),
                });
            }
        }
        let curvature_rms = match curvature {
            Some(k) => area_mean(mesh, |f| k.per_face_tensor[f.idx()].frobenius_sq()).sqrt(),
            None => 0.0,
        };
        let mut contexts = Vec::with_capacity(terms.len());
        let mut later = Vec::new();
        for (i, t) in terms.iter().enumerate() {
            let (impacts, stars) = impacts_of(mesh, t, seed, &mut later);
            let mask_coords = match &t.mask {
                Some(m) => Some(MaskCoords::of(mesh, m).map_err(named(i))?),
                None => None,
            };
            let checks = matches!(
                t.kind,
                TermKind::Directional {
                    checks: Some(_),
                    ..
                }
            );
            contexts.push(Context {
                seed,
                impacts,
                stars,
                mask_coords,
                curvature,
                curvature_rms,
                cell: if checks { cell_size(mesh) } else { 0.0 },
                edge_distance: if checks {
                    edge_distances(mesh)
                } else {
                    Vec::new()
                },
            });
        }
        let mut field = StressField {
            init: vec![Sym3::ZERO; mesh.n_faces()],
            evolve: vec![Sym3::ZERO; mesh.n_faces()],
            separation_scale: Vec::new(),
            later,
            projected_masks: contexts
                .iter()
                .enumerate()
                .filter(|(_, c)| c.mask_coords.is_some_and(|m| m.projected()))
                .map(|(i, _)| i)
                .collect(),
        };
        for f in mesh.faces() {
            for (t, ctx) in terms.iter().zip(&contexts) {
                if t.init == 0.0 && t.evolve == 0.0 {
                    continue;
                }
                let s = t.masked_tensor(mesh, f, ctx);
                field.init[f.idx()] += s * t.init;
                field.evolve[f.idx()] += s * t.evolve;
            }
        }
        let mut scale = |factor: &dyn Fn(FaceId) -> f64| {
            if field.separation_scale.is_empty() {
                field.separation_scale = vec![1.0; mesh.n_faces()];
            }
            for f in mesh.faces() {
                field.separation_scale[f.idx()] *= factor(f);
            }
        };
        for (t, ctx) in terms.iter().zip(&contexts) {
            if let (Some(m), Some(c)) = (&t.mask, &ctx.mask_coords) {
                if m.confine {
                    scale(&|f| c.weight(mesh, f, m));
                }
            }
            if let (TermKind::Curvature { scale: Some(sc) }, Some(k)) = (&t.kind, curvature) {
                let m = |f: FaceId| sc.measure.of(&k.per_face[f.idx()]);
                let bend = 1.0 / (BEND_RADIUS_CELLS * cell_size(mesh));
                let reference = sc.measure.of(&Curvature {
                    k1: bend,
                    k2: bend,
                    ..Default::default()
                });
                scale(&|f| {
                    let x = m(f);
                    if reference > 0.0 && reference.is_finite() && x.is_finite() {
                        (1.0 + sc.strength * (x / reference - 1.0)).clamp(0.0, sc.max_factor)
                    } else {
                        1.0
                    }
                });
            }
        }
        Ok(field)
    }
}

/// An impact term's hit points on `mesh` (its points projected onto the
/// surface, or the default hit) and their stars (with a number of radial
/// cracks); the hits after the first of an `in_turn` term go to `later`.
/// Empty for other terms.
fn impacts_of(
    mesh: &SimMesh,
    t: &Term,
    seed: u64,
    later: &mut Vec<LaterHit>,
) -> (Vec<[f64; 3]>, Vec<super::impact::Star>) {
    let impacts = match &t.kind {
        TermKind::Impact { points, .. } if points.is_empty() => vec![default_hit(mesh)],
        TermKind::Impact { points, .. } => project_onto_surface(mesh, points),
        _ => Vec::new(),
    };
    let stars = match &t.kind {
        TermKind::Impact {
            radius,
            radial_cracks,
            in_turn,
            ..
        } if *radial_cracks > 0 => impacts
            .iter()
            .enumerate()
            .take(if *in_turn { 1 } else { usize::MAX })
            .map(|(k, &p)| {
                super::impact::Star::new(mesh, p, *radius, *radial_cracks, seed, k as u64)
            })
            .collect(),
        _ => Vec::new(),
    };
    if let TermKind::Impact {
        radius,
        radial_cracks,
        in_turn: true,
        ..
    } = &t.kind
    {
        later.extend(
            impacts
                .iter()
                .enumerate()
                .skip(1)
                .map(|(k, &point)| LaterHit {
                    point,
                    radius: *radius,
                    radial_cracks: *radial_cracks,
                    weight: t.init,
                    mask: t.mask.clone(),
                    seed,
                    index: k as u64,
                }),
        );
    }
    (impacts, stars)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With no point given, an impact lands where the asset faces the
    /// viewer: a standing teapot's body from the front, a cow's side, a
    /// ground from above, whatever plane a flat plate lies in.
    #[test]
    fn an_impact_with_no_point_lands_on_the_side_the_asset_shows() {
        assert_eq!(hit_axis([6.4, 3.15, 4.0]), 2, "teapot: its body's front");
        assert_eq!(hit_axis([0.94, 1.69, 1.72]), 0, "spot: its side");
        assert_eq!(hit_axis([10.0, 0.2, 10.0]), 1, "ground: from above");
        assert_eq!(hit_axis([10.0, 10.0, 0.0]), 2, "an upright pane: its face");
        let (sphere, _) = crate::mesh::shapes::build(&crate::mesh::shapes::icosphere_input(3));
        let p = default_hit(&sphere);
        let r = v3::norm(p);
        assert!(
            p[2] > 0.95 * r && p[0].abs() < 0.05 && p[1].abs() < 0.05,
            "{p:?}"
        );
        let plate = crate::mesh::shapes::jittered_plate(10, 0.3, 1);
        let p = default_hit(&plate);
        assert!(
            (p[0] - 5.0).abs() < 1e-5 && (p[1] - 5.0).abs() < 1e-5 && p[2].abs() < 1e-6,
            "{p:?}"
        );
        // A ring seen through its hole: the closest point to the face's middle.
        let mut ring = crate::mesh::shapes::grid_input(12, 12);
        ring.positions.iter_mut().for_each(|q| q[2] = 0.0);
        let keep: Vec<[u32; 3]> = ring
            .triangles
            .iter()
            .copied()
            .filter(|t| {
                let c = (0..3).fold([0.0; 2], |a, k| {
                    let q = ring.positions[t[k] as usize];
                    [a[0] + q[0] / 3.0, a[1] + q[1] / 3.0]
                });
                (c[0] - 6.0).abs().max((c[1] - 6.0).abs()) > 2.0
            })
            .collect();
        ring.triangles = keep;
        let (ring, _) = crate::mesh::shapes::build(&ring);
        let p = default_hit(&ring);
        assert!(
            (p[0] - 6.0).abs().max((p[1] - 6.0).abs()) >= 2.0 - 1e-6,
            "{p:?}"
        );
    }

    /// Directional checks: the term acts only in patches, which are long
    /// along the grain (across the direction) and short across it, and
    /// `checks` outside 0.5 to 50 cells is refused.
    #[test]
    fn directional_checks_are_patches_long_along_the_grain() {
        let d = [1.0, 0.0, 0.0];
        let len = 2.0;
        let w = |x: f64, z: f64| check_weight(5, [x, 0.0, z], d, len, 0.0);
        let (n, step) = (400, 0.02);
        let mut on = 0;
        // Mean run of "on" samples along the grain (z) and across it (x).
        let runs = |along: bool| {
            let (mut runs, mut total) = (0usize, 0usize);
            for line in 0..40 {
                let mut prev = false;
                for k in 0..n {
                    let t = k as f64 * step;
                    let c = line as f64 * 0.37;
                    let v = if along { w(c, t) } else { w(t, c) } > 0.0;
                    if v {
                        total += 1;
                        if !prev {
                            runs += 1;
                        }
                    }
                    prev = v;
                }
            }
            (total, total as f64 * step / runs.max(1) as f64)
        };
        let (total_along, run_along) = runs(true);
        let (_, run_across) = runs(false);
        on += total_along;
        assert!(
            on > 0 && on < 40 * n,
            "the patches cover part of the board: {on}"
        );
        assert!(
            run_along > 3.0 * run_across,
            "patches {run_along} long along the grain, {run_across} across"
        );
        assert!((0.2 * len..2.0 * len).contains(&run_along), "{run_along}");
        for bad in [0.1, 100.0, f64::NAN] {
            let t = Term {
                kind: TermKind::Directional {
                    direction: d,
                    checks: Some(bad),
                },
                init: 1.0,
                evolve: 0.0,
                mask: None,
            };
            assert!(t.validate().is_err(), "checks = {bad}");
        }
    }
    use crate::mesh::shapes::jittered_plate;

    fn eig(s: &Sym3) -> ([f64; 3], [[f64; 3]; 3]) {
        s.eigen()
    }

    #[test]
    fn directional_term_is_the_projected_direction() {
        let mesh = jittered_plate(4, 0.2, 1);
        let t = Term {
            kind: TermKind::Directional {
                direction: [1.0, 0.0, 1.0],
                checks: None,
            },
            init: 1.0,
            evolve: 0.0,
            mask: None,
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
            mask: None,
        };
        let impact = Term {
            kind: TermKind::Impact {
                points: vec![center],
                radius: 4.0,
                concentric_factor: 1.25,
                radial_cracks: 0,
                in_turn: false,
            },
            init: 1.0,
            evolve: 0.0,
            mask: None,
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
            mask: None,
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
                radial_cracks: 0,
                in_turn: false,
            },
            init: 1.0,
            evolve: 0.0,
            mask: None,
        };
        let e = StressField::build(&mesh, &[t], 1).unwrap_err().to_string();
        assert!(e.contains("radius") && e.contains("term 0"), "{e}");
    }

    /// An `n` x `n` unit grid whose `TEXCOORD_0` spans [0, 1]^2.
    fn uv_plate(n: usize) -> SimMesh {
        let mut input = crate::mesh::shapes::grid_input(n, n);
        let ch = &mut input.wedge_channels[0];
        ch.name = "TEXCOORD_0".into();
        for x in &mut ch.data {
            *x /= n as f64;
        }
        crate::mesh::shapes::build(&input).0
    }

    /// Left half of the image black, right half white (2 x 1 pixels,
    /// clamped so the halves do not blend across the wrap).
    fn half_mask(confine: bool) -> Arc<Mask> {
        let mut m = Mask::from_image(crate::stress::texture::GreyImage {
            width: 2,
            height: 1,
            data: vec![0.0, 1.0],
        });
        m.wrap_s = crate::stress::texture::Wrap::ClampToEdge;
        m.wrap_t = crate::stress::texture::Wrap::ClampToEdge;
        m.confine = confine;
        Arc::new(m)
    }

    #[test]
    fn masks_weight_each_face_by_the_image_at_its_centroid() {
        let mesh = uv_plate(8);
        let t = Term {
            kind: TermKind::Uniform,
            init: 0.0,
            evolve: 2.0,
            mask: Some(half_mask(false)),
        };
        let field = StressField::build(&mesh, &[t], 1).unwrap();
        assert!(
            field.separation_scale.is_empty(),
            "no confinement asked for"
        );
        for f in mesh.faces() {
            let (c, _) = face_frame(&mesh, f).unwrap();
            // Bilinear between the two pixel centres at u = 0.25 and 0.75.
            let u = c[0] / 8.0;
            let expect = 2.0 * (1.0 - ((u - 0.25) / 0.5).clamp(0.0, 1.0));
            let got = field.evolve[f.idx()].trace() / 2.0; // tangent identity: trace 2
            assert!((got - expect).abs() < 1e-6, "u {u}: {got} vs {expect}");
        }
        // Confinement scales the separation by the same weight.
        let t = Term {
            kind: TermKind::Uniform,
            init: 0.0,
            evolve: 1.0,
            mask: Some(half_mask(true)),
        };
        let field = StressField::build(&mesh, &[t], 1).unwrap();
        for f in mesh.faces() {
            let u = face_frame(&mesh, f).unwrap().0[0] / 8.0;
            let w = 1.0 - ((u - 0.25) / 0.5).clamp(0.0, 1.0);
            assert!((field.separation_scale[f.idx()] - w).abs() < 1e-6);
        }
    }

    #[test]
    fn a_mask_on_a_mesh_without_uvs_is_projected_and_a_missing_set_named() {
        // No TEXCOORD set at all (its channel is "uv"): the mask is
        // projected along the axes over the box; the plate lies in z = 0,
        // facing z, so x runs along the image's u.
        let mesh = jittered_plate(8, 0.0, 1);
        let t = Term {
            kind: TermKind::Uniform,
            init: 1.0,
            evolve: 0.0,
            mask: Some(half_mask(false)),
        };
        let field = StressField::build(&mesh, std::slice::from_ref(&t), 1).unwrap();
        assert_eq!(field.projected_masks, vec![0]);
        let (lo, hi) = mesh.bounding_box();
        let (mut on, mut off) = (0, 0);
        for f in mesh.faces() {
            let (c, _) = face_frame(&mesh, f).unwrap();
            let u = (c[0] - lo[0]) / (hi[0] - lo[0]);
            let s = field.init[f.idx()].trace();
            let want = t.mask.as_ref().unwrap().weight([u, 0.5]);
            assert!((s - 2.0 * want).abs() < 1e-9, "{s} against {want} at u {u}");
            if want > 0.5 {
                on += 1;
            } else {
                off += 1;
            }
        }
        assert!(on > 10 && off > 10, "{on} / {off}");
        // A mesh with UV sets, but not the one asked for: an error.
        let mut m = (*t.mask.clone().unwrap()).clone();
        m.tex_coord = 1;
        let t1 = Term {
            mask: Some(Arc::new(m)),
            ..t
        };
        let e = StressField::build(&uv_plate(3), &[t1], 1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("TEXCOORD_1") && e.contains("term 0"), "{e}");
    }

    #[test]
    fn curvature_term_on_a_sphere_is_the_tangent_identity() {
        // Radius 3: k1 = k2 = 1/3 everywhere; normalised by its RMS the
        // tensor is the tangent identity (trace 2, zero along the normal).
        let mut input = crate::mesh::shapes::icosphere_input(3);
        for p in &mut input.positions {
            *p = v3::scale(*p, 3.0);
        }
        let mesh = crate::mesh::shapes::build(&input).0;
        let t = Term {
            kind: TermKind::Curvature { scale: None },
            init: 1.0,
            evolve: 0.0,
            mask: None,
        };
        let field = StressField::build(&mesh, &[t], 1).unwrap();
        for f in mesh.faces() {
            let (_, n) = face_frame(&mesh, f).unwrap();
            let s = &field.init[f.idx()];
            assert!((s.trace() - 2.0).abs() < 0.05, "trace {}", s.trace());
            assert!(s.quad(n, n).abs() < 1e-9);
        }
        // On a flat plate the curvature is zero: no stress, factor 0 at
        // strength 1 (flat never cracks), no NaN.
        let plate = jittered_plate(6, 0.2, 2);
        let t = Term {
            kind: TermKind::Curvature {
                scale: Some(CurvatureScale {
                    measure: CurvatureMeasure::Frobenius,
                    strength: 1.0,
                    max_factor: 4.0,
                }),
            },
            init: 1.0,
            evolve: 1.0,
            mask: None,
        };
        let field = StressField::build(&plate, &[t], 1).unwrap();
        assert!(field.init.iter().all(|s| s.frobenius_sq() < 1e-20));
        assert!(field.separation_scale.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn curvature_scaling_follows_the_measure() {
        // A cylinder-like strip: half flat, half bent. Faces on the bent half
        // get factor m / m_ref (strength 1; m_ref that of a sphere of
        // BEND_RADIUS_CELLS cells), the flat half 0; strength 0.5 halves the
        // deviation from 1; max_factor clamps.
        let n = 16;
        let mut input = crate::mesh::shapes::grid_input(n, 4);
        for p in &mut input.positions {
            if p[0] > 8.0 {
                // bend x in (8, 16] onto a circle of radius 4 (curvature 1/4)
                let a = (p[0] - 8.0) / 4.0;
                *p = [8.0 + 4.0 * a.sin(), p[1], 4.0 - 4.0 * a.cos()];
            }
        }
        let mesh = crate::mesh::shapes::build(&input).0;
        let k = crate::geometry::curvature::estimate(&mesh);
        let term = |strength: f64, max_factor: f64| Term {
            kind: TermKind::Curvature {
                scale: Some(CurvatureScale {
                    measure: CurvatureMeasure::SumSquares,
                    strength,
                    max_factor,
                }),
            },
            init: 0.0,
            evolve: 0.0,
            mask: None,
        };
        let m = |f: FaceId| CurvatureMeasure::SumSquares.of(&k.per_face[f.idx()]);
        let bend = BEND_RADIUS_CELLS * cell_size(&mesh);
        let mean = 2.0 / (bend * bend);
        let full = StressField::build_with(&mesh, &[term(1.0, 100.0)], 1, Some(&k)).unwrap();
        let half = StressField::build_with(&mesh, &[term(0.5, 100.0)], 1, Some(&k)).unwrap();
        let capped = StressField::build_with(&mesh, &[term(1.0, 1.2)], 1, Some(&k)).unwrap();
        let (mut flat, mut bent) = (0, 0);
        for f in mesh.faces() {
            let x = m(f) / mean;
            let a = full.separation_scale[f.idx()];
            assert!((a - x).abs() < 1e-12);
            assert!((half.separation_scale[f.idx()] - (1.0 + 0.5 * (x - 1.0))).abs() < 1e-12);
            assert!(capped.separation_scale[f.idx()] <= 1.2);
            let cx = face_frame(&mesh, f).unwrap().0[0];
            if cx < 6.0 {
                flat += 1;
                assert!(a < 1e-6, "flat face factor {a}");
            } else if cx > 9.5 && cx < 11.0 {
                bent += 1;
                assert!(a > 1.5, "bent face factor {a}");
            }
        }
        assert!(flat > 0 && bent > 0);
    }

    /// Points hit in turn: the first star loads the start, the others wait
    /// as later hits (built when they land); without stars, or with an
    /// `evolve` weight, it is refused by name.
    #[test]
    fn hits_in_turn_wait_for_their_turn() {
        let (mesh, _) = crate::mesh::shapes::build(&crate::mesh::shapes::icosphere_input(3));
        let impact = |points: Vec<[f64; 3]>, radial_cracks, in_turn, evolve| Term {
            kind: TermKind::Impact {
                points,
                radius: 0.5,
                concentric_factor: 1.25,
                radial_cracks,
                in_turn,
            },
            init: 2.0,
            evolve,
            mask: None,
        };
        let (a, b) = ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
        let first = StressField::build(&mesh, &[impact(vec![a], 8, false, 0.0)], 3).unwrap();
        let turn = StressField::build(&mesh, &[impact(vec![a, b], 8, true, 0.0)], 3).unwrap();
        let once = StressField::build(&mesh, &[impact(vec![a, b], 8, false, 0.0)], 3).unwrap();
        assert_eq!(
            turn.init, first.init,
            "in turn, the start carries the first hit only"
        );
        assert_ne!(once.init, first.init, "at once, both");
        assert_eq!(turn.later.len(), 1);
        let later = turn.later[0].stress(&mesh);
        assert!(
            v3::norm(turn.later[0].point) > 0.99,
            "projected onto the sphere"
        );
        // The later star, added to the first, is the pair hit at once.
        for f in mesh.faces() {
            let sum = first.init[f.idx()] + later[f.idx()];
            let d = (sum - once.init[f.idx()]).frobenius_sq().sqrt();
            assert!(
                d <= 1e-9 * (1.0 + sum.frobenius_sq().sqrt()),
                "face {f:?}: {d}"
            );
        }
        for (term, says) in [
            (impact(vec![a, b], 0, true, 0.0), "in_turn needs stars"),
            (impact(vec![a, b], 8, true, 1.0), "not 'evolve'"),
        ] {
            let e = StressField::build(&mesh, &[term], 3).unwrap_err();
            assert!(e.to_string().contains(says), "{e}");
        }
    }
}
