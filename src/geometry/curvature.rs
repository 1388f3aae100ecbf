//! Principal curvatures and directions of a [`SimMesh`], per vertex and per
//! face, by the method of Rusinkiewicz, "Estimating curvatures and their
//! derivatives on triangle meshes" (3DPVT 2004).
//!
//! # Method
//!
//! 1. Per-vertex unit normals, averages of the incident face normals with
//!    the weights of Max ("Weights for computing vertex normals from facet
//!    normals", 1999): `sin(angle) / (|a| |b|)` for the corner's edges `a`,
//!    `b`. These are the weights of Rusinkiewicz's own implementation
//!    (trimesh2) and make the normals exact for vertices on a sphere;
//!    angle- or area-weighted normals leave an error in the normal
//!    differences that does not shrink with the mesh size, giving a
//!    curvature error of 2-3% (angle) or 6-7% (area) on a subdivided
//!    icosahedron at every level.
//! 2. Per face, in the face frame `(t, b)` (`t` along an edge, `b = n x t`),
//!    a least-squares fit of the second fundamental form `II` (a symmetric
//!    2x2 tensor) to the three edges: `II e = dn` for each edge `e` and the
//!    difference `dn` of the vertex normals at its ends.
//! 3. Each face's `II` is expressed in the tangent frame of each of its
//!    corners (read in the vertex frame turned into the face plane by the
//!    smallest rotation) and accumulated there, weighted by
//!    the corner's Voronoi area (clipped to the triangle for obtuse
//!    triangles, as in Rusinkiewicz's code); the sum is divided by the total
//!    weight.
//! 4. Per vertex, the eigen-decomposition of the accumulated tensor gives the
//!    principal curvatures and directions.
//! 5. Per face, the three vertex tensors rotated into the face plane are
//!    averaged (equal weights) and decomposed the same way.
//!
//! # Sign convention
//!
//! `II = dn/dx` with the mesh's own normals (right-handed with the corner
//! order, so outward for counter-clockwise faces seen from outside). Convex
//! is positive: a sphere of radius `R` with outward normals has
//! `k1 = k2 = +1/R`; its inside-out copy has `-1/R`. A cylinder of radius `R`
//! has `k1 = 1/R` around it and `k2 = 0` along it; a saddle has `k1 > 0 > k2`.
//!
//! # Robustness
//!
//! Every output is finite. Degenerate faces (smallest height at most `1e-12`
//! of the longest edge, repeated or out-of-range corners, non-finite
//! positions) get zero curvature and take no part in the normals or the
//! fits; sliver faces (smallest height below `1e-6` of
//! the longest edge) take part in the normals but not in the fits, whose
//! least-squares system they make ill-conditioned. A vertex that no fit
//! reaches (isolated, or only next to degenerate faces) has zero curvature.
//! Zero curvature comes with an arbitrary but valid orthonormal pair of
//! tangent directions. Work is split over faces and vertices with ordered
//! `rayon` maps; every sum runs in a fixed order, so results are
//! deterministic.
//!
//! # Accuracy
//!
//! On regular meshes whose vertices lie on a smooth surface the error
//! shrinks with the edge length (it is zero on spheres and cylinders). On
//! irregular meshes it does not: like every estimator built on normal
//! differences, the error stays at a level set by the irregularity (about
//! 1% median and 5% at worst for parameter jitter of a tenth of an edge).
//! Max's weights favour short edges, so a very small face next to a vertex
//! (a face split close to a corner) pulls that vertex's normal towards its
//! own.

use crate::math::v3;
use crate::math::{Sym2, Sym3};
use crate::mesh::SimMesh;
use rayon::prelude::*;

/// Principal curvatures and directions at a point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Curvature {
    /// Largest principal curvature (`k1 >= k2`; convex positive, see the
    /// [module docs](self)).
    pub k1: f64,
    /// Smallest principal curvature.
    pub k2: f64,
    /// Unit tangent direction of `k1`, in world space.
    pub d1: [f64; 3],
    /// Unit tangent direction of `k2`, in world space; `(d1, d2, normal)` is
    /// right-handed.
    pub d2: [f64; 3],
}

impl Curvature {
    /// Gaussian curvature `k1 k2`.
    pub fn gaussian(&self) -> f64 {
        self.k1 * self.k2
    }

    /// Mean curvature `(k1 + k2) / 2`.
    pub fn mean(&self) -> f64 {
        0.5 * (self.k1 + self.k2)
    }

    /// Frobenius norm of the curvature tensor, `sqrt(k1^2 + k2^2)`.
    pub fn frobenius(&self) -> f64 {
        self.k1.hypot(self.k2)
    }
}

/// Curvature of every vertex and face of a mesh, from [`estimate`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CurvatureField {
    /// Per vertex, indexed by [`VertexId::idx`](crate::mesh::VertexId::idx).
    pub per_vertex: Vec<Curvature>,
    /// Per face, indexed by [`FaceId::idx`](crate::mesh::FaceId::idx).
    pub per_face: Vec<Curvature>,
    /// Per face, the tensor `k1 d1 d1^T + k2 d2 d2^T` in world space, tangent
    /// to the face (zero for a degenerate face).
    pub per_face_tensor: Vec<Sym3>,
}

/// Estimates the principal curvatures of `mesh` per vertex and per face (see
/// the [module docs](self) for the method and the sign convention).
pub fn estimate(mesh: &SimMesh) -> CurvatureField {
    estimate_at_scale(mesh, 0.0)
}

/// As [`estimate`], of the surface seen at the scale `radius` (world units):
/// the vertex normals are first averaged over about that distance (repeated
/// averaging with the neighbours, each pass spreading a normal by about
/// `h / sqrt 2` for a mean edge `h`), so bumps much smaller than `radius`
/// (scan noise, a noisy ground's grain) cancel out and bends larger than it
/// keep their curvature. `radius` 0 is [`estimate`].
pub fn estimate_at_scale(mesh: &SimMesh, radius: f64) -> CurvatureField {
    let faces: Vec<[u32; 3]> = mesh
        .faces()
        .map(|f| mesh.face_vertices(f).map(|v| v.0))
        .collect();
    let h = mesh.mean_edge_length();
    let passes = if radius > 0.0 && h > 0.0 {
        (2.0 * (radius / h).powi(2)).ceil().min(MAX_PASSES as f64) as usize
    } else {
        0
    };
    estimate_soup(mesh.positions(), &faces, passes)
}

/// Most normal-averaging passes of [`estimate_at_scale`] (a radius of 10
/// mean edges).
const MAX_PASSES: usize = 200;

/// `normals` averaged `passes` times with their neighbours across `faces`
/// (each with itself and every vertex it shares an edge with, renormalized;
/// the sums in a fixed order, so the result is the same at any thread
/// count). The neighbours are weighted by the cotangent weights of their
/// edge (negative ones, across obtuse corners, taken as 0), scaled so a
/// vertex's weights sum to its number of neighbours: with them the average
/// of a sphere's normals is its own normal (the cotangent Laplacian of the
/// positions is along the normal), where plain averaging turns each normal
/// toward the middle of its neighbours and bends the curvature.
fn smooth_normals(
    normals: Vec<[f64; 3]>,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    passes: usize,
) -> Vec<[f64; 3]> {
    if passes == 0 {
        return normals;
    }
    let nv = normals.len();
    let mut edges = cotangent_weights(positions, faces.iter().copied(), nv);
    let mut start = vec![0usize; nv + 1];
    for &(a, _, _) in &edges {
        start[a as usize + 1] += 1;
    }
    for i in 0..nv {
        start[i + 1] += start[i];
    }
    // Each vertex's weights, summing to its number of neighbours (plain
    // averaging where they are all 0).
    for i in 0..nv {
        let ring = &mut edges[start[i]..start[i + 1]];
        let sum: f64 = ring.iter().map(|e| e.2).sum();
        let n = ring.len() as f64;
        for e in ring.iter_mut() {
            e.2 = if sum > 0.0 { e.2 * n / sum } else { 1.0 };
        }
    }
    let mut n = normals;
    for _ in 0..passes {
        n = (0..nv)
            .into_par_iter()
            .map(|i| {
                let s = edges[start[i]..start[i + 1]]
                    .iter()
                    .fold(n[i], |s, &(_, j, w)| {
                        v3::add(s, v3::scale(n[j as usize], w))
                    });
                let l = v3::norm(s);
                if l > 1e-12 && l.is_finite() {
                    v3::scale(s, 1.0 / l)
                } else {
                    n[i]
                }
            })
            .collect();
    }
    n
}

/// The cotangent weight of every edge of `faces` (vertices below `nv`;
/// faces with a repeated or out-of-range corner left out), both ways:
/// `(a, b, w)` sorted by `(a, b)`, `w` half the sum of the cotangents of
/// the corners across the edge, negative or non-finite sums (across obtuse
/// corners) taken as 0. The sums run in a fixed order: the same weights at
/// any thread count.
pub(crate) fn cotangent_weights(
    positions: &[[f64; 3]],
    faces: impl Iterator<Item = [u32; 3]>,
    nv: usize,
) -> Vec<(u32, u32, f64)> {
    let mut pairs: Vec<(u32, u32, f64)> = Vec::new();
    for f in faces {
        if f.iter().any(|&i| i as usize >= nv) || f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
            continue;
        }
        let p = f.map(|i| positions[i as usize]);
        for k in 0..3 {
            let (a, b) = (f[(k + 1) % 3], f[(k + 2) % 3]);
            let (u, v) = (v3::sub(p[(k + 1) % 3], p[k]), v3::sub(p[(k + 2) % 3], p[k]));
            let sin = v3::norm(v3::cross(u, v));
            let cot = if sin > 0.0 { v3::dot(u, v) / sin } else { 0.0 };
            pairs.push((a, b, 0.5 * cot));
            pairs.push((b, a, 0.5 * cot));
        }
    }
    pairs.sort_unstable_by_key(|x| (x.0, x.1));
    let mut edges: Vec<(u32, u32, f64)> = Vec::with_capacity(pairs.len() / 2);
    for run in pairs.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let w: f64 = run.iter().map(|x| x.2).sum();
        edges.push((
            run[0].0,
            run[0].1,
            if w.is_finite() { w.max(0.0) } else { 0.0 },
        ));
    }
    edges
}

/// Faces whose double area is at most this times their longest edge squared
/// are degenerate.
const DEGENERATE: f64 = 1e-12;

/// Faces whose double area is at most this times their longest edge squared
/// (smallest height below this fraction of the longest edge) are left out of
/// the fits.
const SLIVER: f64 = 1e-6;

/// Geometry of one face.
#[derive(Clone, Copy, Debug)]
struct FaceGeom {
    /// Unit normal, tangent axes `t` and `b = n x t`.
    n: [f64; 3],
    t: [f64; 3],
    b: [f64; 3],
    /// Area.
    area: f64,
    /// Squared lengths of the edges opposite each corner.
    l2: [f64; 3],
    /// Voronoi (mixed) area of each corner.
    corner_areas: [f64; 3],
    /// Whether the face is too thin for the fit.
    sliver: bool,
}

/// Geometry of the face with corners `p`, or `None` if it is degenerate.
fn face_geom(p: [[f64; 3]; 3]) -> Option<FaceGeom> {
    if !p.iter().flatten().all(|x| x.is_finite()) {
        return None;
    }
    // e[i] is the edge opposite corner i (from corner i+1 to corner i+2).
    let e = [
        v3::sub(p[2], p[1]),
        v3::sub(p[0], p[2]),
        v3::sub(p[1], p[0]),
    ];
    let l2 = e.map(|x| v3::dot(x, x));
    let lmax2 = l2[0].max(l2[1]).max(l2[2]);
    let c = v3::cross(e[2], v3::scale(e[1], -1.0));
    let double_area = v3::norm(c);
    if !(double_area.is_finite() && lmax2.is_finite() && double_area > DEGENERATE * lmax2) {
        return None;
    }
    let n = v3::scale(c, 1.0 / double_area);
    let t = v3::scale(e[2], 1.0 / l2[2].sqrt());
    let b = v3::cross(n, t);
    let area = 0.5 * double_area;
    // Voronoi areas of the corners, clipped to the triangle for obtuse ones,
    // as in Rusinkiewicz's code.
    let ew = [
        l2[0] * (l2[1] + l2[2] - l2[0]),
        l2[1] * (l2[2] + l2[0] - l2[1]),
        l2[2] * (l2[0] + l2[1] - l2[2]),
    ];
    let mut corner_areas = [0.0; 3];
    if let Some(o) = (0..3).find(|&i| ew[i] <= 0.0) {
        // Obtuse at corner o: the other corners get the parts cut off by the
        // perpendicular bisectors of their edges to o, corner o the rest.
        let (a, b) = ((o + 1) % 3, (o + 2) % 3);
        corner_areas[a] = -0.25 * l2[b] * area / v3::dot(e[o], e[b]);
        corner_areas[b] = -0.25 * l2[a] * area / v3::dot(e[o], e[a]);
        corner_areas[o] = area - corner_areas[a] - corner_areas[b];
    } else {
        let s = 0.5 * area / (ew[0] + ew[1] + ew[2]);
        for j in 0..3 {
            corner_areas[j] = s * (ew[(j + 1) % 3] + ew[(j + 2) % 3]);
        }
    }
    if !corner_areas.iter().all(|x| x.is_finite() && *x >= 0.0) {
        corner_areas = [area / 3.0; 3];
    }
    Some(FaceGeom {
        n,
        t,
        b,
        area,
        l2,
        corner_areas,
        sliver: double_area <= SLIVER * lmax2,
    })
}

/// A unit vector orthogonal to the unit vector `n` (Duff et al. 2017).
fn orthogonal(n: [f64; 3]) -> [f64; 3] {
    let s = 1f64.copysign(n[2]);
    let a = -1.0 / (s + n[2]);
    let b = n[0] * n[1] * a;
    [1.0 + s * n[0] * n[0] * a, s * b, -s * n[0]]
}

/// The frame `(u, v)` turned by the smallest rotation that takes its normal
/// `u x v` to `new_n` (Rusinkiewicz's `rot_coord_sys`); opposite normals
/// flip the frame.
fn rotate_frame(u: [f64; 3], v: [f64; 3], new_n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let old_n = v3::cross(u, v);
    let d = v3::dot(old_n, new_n);
    if d <= -1.0 + 1e-12 {
        return (v3::scale(u, -1.0), v3::scale(v, -1.0));
    }
    let perp = v3::sub(new_n, v3::scale(old_n, d));
    let dperp = v3::scale(v3::add(old_n, new_n), 1.0 / (1.0 + d));
    (
        v3::sub(u, v3::scale(dperp, v3::dot(u, perp))),
        v3::sub(v, v3::scale(dperp, v3::dot(v, perp))),
    )
}

/// The tensor `s`, given in the orthonormal frame `(ou, ov)`, expressed in
/// the orthonormal frame `(nu, nv)` after turning the latter into the plane
/// of the former (Rusinkiewicz's `proj_curv`).
fn reproject(s: &Sym2, ou: [f64; 3], ov: [f64; 3], nu: [f64; 3], nv: [f64; 3]) -> Sym2 {
    let (ru, rv) = rotate_frame(nu, nv, v3::cross(ou, ov));
    let (u1, v1) = (v3::dot(ru, ou), v3::dot(ru, ov));
    let (u2, v2) = (v3::dot(rv, ou), v3::dot(rv, ov));
    Sym2 {
        xx: s.xx * u1 * u1 + s.xy * (2.0 * u1 * v1) + s.yy * v1 * v1,
        xy: s.xx * u1 * u2 + s.xy * (u1 * v2 + u2 * v1) + s.yy * v1 * v2,
        yy: s.xx * u2 * u2 + s.xy * (2.0 * u2 * v2) + s.yy * v2 * v2,
    }
}

/// Least-squares second fundamental form of a face in its frame `(t, b)`,
/// from its corners `p` and vertex normals `n`; `None` if the system is
/// singular.
fn fit_face(g: &FaceGeom, p: [[f64; 3]; 3], n: [[f64; 3]; 3]) -> Option<Sym2> {
    // Unknowns x = (II_tt, II_tb, II_bb); per edge e with normal change dn:
    // II_tt u + II_tb v = dn.t and II_tb u + II_bb v = dn.b, (u, v) = (e.t, e.b).
    let mut w = [[0.0f64; 3]; 3];
    let mut m = [0.0f64; 3];
    for j in 0..3 {
        let (prev, next) = ((j + 2) % 3, (j + 1) % 3);
        let e = v3::sub(p[prev], p[next]);
        let dn = v3::sub(n[prev], n[next]);
        let (u, v) = (v3::dot(e, g.t), v3::dot(e, g.b));
        let (dnu, dnv) = (v3::dot(dn, g.t), v3::dot(dn, g.b));
        w[0][0] += u * u;
        w[0][1] += u * v;
        w[2][2] += v * v;
        m[0] += dnu * u;
        m[1] += dnu * v + dnv * u;
        m[2] += dnv * v;
    }
    w[1][1] = w[0][0] + w[2][2];
    w[1][2] = w[0][1];
    w[1][0] = w[0][1];
    w[2][1] = w[1][2];
    let x = solve_spd3(w, m)?;
    let s = Sym2 {
        xx: x[0],
        xy: x[1],
        yy: x[2],
    };
    (s.xx.is_finite() && s.xy.is_finite() && s.yy.is_finite()).then_some(s)
}

/// Solves the symmetric positive definite system `a x = y` by Cholesky
/// (`a = L L^T`); `None` if a pivot is not clearly positive.
fn solve_spd3(a: [[f64; 3]; 3], y: [f64; 3]) -> Option<[f64; 3]> {
    let scale = a[0][0].max(a[1][1]).max(a[2][2]);
    let pivot = |p: f64| (p > 1e-14 * scale && p.is_finite()).then(|| p.sqrt());
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let l00 = pivot(a[0][0])?;
    let (l10, l20) = (a[1][0] / l00, a[2][0] / l00);
    let l11 = pivot(a[1][1] - l10 * l10)?;
    let l21 = (a[2][1] - l20 * l10) / l11;
    let l22 = pivot(a[2][2] - l20 * l20 - l21 * l21)?;
    // L z = y, then L^T x = z.
    let z0 = y[0] / l00;
    let z1 = (y[1] - l10 * z0) / l11;
    let z2 = (y[2] - l20 * z0 - l21 * z1) / l22;
    let x2 = z2 / l22;
    let x1 = (z1 - l21 * x2) / l11;
    let x0 = (z0 - l10 * x1 - l20 * x2) / l00;
    Some([x0, x1, x2])
}

/// Principal curvatures and directions of the tensor `s` given in the
/// orthonormal tangent frame `(u, v)` with normal `n = u x v`.
fn diagonalize(s: &Sym2, u: [f64; 3], v: [f64; 3], n: [f64; 3]) -> Curvature {
    let ([k2, k1], [_, e1]) = s.eigen();
    let d1 = v3::add(v3::scale(u, e1[0]), v3::scale(v, e1[1]));
    let d1 = v3::scale(d1, 1.0 / v3::norm(d1));
    let d2 = v3::cross(n, d1);
    let c = Curvature { k1, k2, d1, d2 };
    if [c.k1, c.k2]
        .iter()
        .chain(&c.d1)
        .chain(&c.d2)
        .all(|x| x.is_finite())
    {
        c
    } else {
        Curvature {
            k1: 0.0,
            k2: 0.0,
            d1: u,
            d2: v,
        }
    }
}

/// Zero curvature with a valid orthonormal direction pair for a face without
/// a tangent plane: the longest edge and a vector orthogonal to it.
fn degenerate_curvature(p: [[f64; 3]; 3]) -> Curvature {
    let mut d1 = [1.0, 0.0, 0.0];
    let mut best = 0.0;
    for i in 0..3 {
        let e = v3::sub(p[(i + 1) % 3], p[i]);
        let l = v3::norm(e);
        if l.is_finite() && l > best {
            best = l;
            d1 = v3::scale(e, 1.0 / l);
        }
    }
    if !d1.iter().all(|x| x.is_finite()) || (v3::norm(d1) - 1.0).abs() > 1e-6 {
        d1 = [1.0, 0.0, 0.0];
    }
    Curvature {
        k1: 0.0,
        k2: 0.0,
        d1,
        d2: orthogonal(d1),
    }
}

/// [`estimate`] on positions and triangles (corner indices into
/// `positions`; out-of-range corners make the face degenerate).
fn estimate_soup(positions: &[[f64; 3]], faces: &[[u32; 3]], passes: usize) -> CurvatureField {
    let nv = positions.len();
    let corners = |f: &[u32; 3]| -> Option<[[f64; 3]; 3]> {
        if f.iter().any(|&i| i as usize >= nv) || f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
            return None;
        }
        Some(f.map(|i| positions[i as usize]))
    };
    let geoms: Vec<Option<FaceGeom>> = faces
        .par_iter()
        .map(|f| corners(f).and_then(face_geom))
        .collect();

    // 1. Vertex normals with Max's weights, in face order. The weights are
    // taken in units of the longest edge so they neither overflow nor
    // underflow at any mesh scale. A vertex whose sum cancels (folded
    // leftovers) takes its largest face's normal; one with no face gets +z.
    let s2 = geoms
        .iter()
        .flatten()
        .map(|g| g.l2[0].max(g.l2[1]).max(g.l2[2]))
        .fold(0.0f64, f64::max);
    let mut sum = vec![[0.0f64; 3]; nv];
    let mut weight = vec![0.0f64; nv];
    let mut largest = vec![(0.0f64, [0.0f64, 0.0, 1.0]); nv];
    for (f, g) in faces.iter().zip(&geoms) {
        let Some(g) = g else { continue };
        let l2 = g.l2.map(|x| x / s2);
        let double_area = 2.0 * g.area / s2;
        for (k, &vi) in f.iter().enumerate() {
            let i = vi as usize;
            let w = double_area / (l2[(k + 1) % 3] * l2[(k + 2) % 3]);
            sum[i] = v3::add(sum[i], v3::scale(g.n, w));
            weight[i] += w;
            if g.area > largest[i].0 {
                largest[i] = (g.area, g.n);
            }
        }
    }
    let normals: Vec<[f64; 3]> = (0..nv)
        .map(|i| {
            let l = v3::norm(sum[i]);
            if l > 1e-9 * weight[i] && l.is_finite() {
                v3::scale(sum[i], 1.0 / l)
            } else {
                largest[i].1
            }
        })
        .collect();
    let normals = smooth_normals(normals, positions, faces, passes);
    // Vertex frames (u, v, n), right-handed.
    let frames: Vec<([f64; 3], [f64; 3])> = normals
        .iter()
        .map(|&n| {
            let u = orthogonal(n);
            (u, v3::cross(n, u))
        })
        .collect();

    // 2. Per-face fits.
    let fits: Vec<Option<Sym2>> = faces
        .par_iter()
        .zip(&geoms)
        .map(|(f, g)| {
            let g = g.as_ref().filter(|g| !g.sliver)?;
            let p = f.map(|i| positions[i as usize]);
            let n = f.map(|i| normals[i as usize]);
            fit_face(g, p, n)
        })
        .collect();

    // 3. Accumulation at the vertices, in face order.
    let mut acc = vec![Sym2::default(); nv];
    let mut acc_w = vec![0.0f64; nv];
    for ((f, g), fit) in faces.iter().zip(&geoms).zip(&fits) {
        let (Some(g), Some(fit)) = (g, fit) else {
            continue;
        };
        for (k, &vi) in f.iter().enumerate() {
            let i = vi as usize;
            // Corner areas are finite and non-negative (see face_geom).
            let w = g.corner_areas[k];
            if w <= 0.0 {
                continue;
            }
            let (u, v) = frames[i];
            let s = reproject(fit, g.t, g.b, u, v);
            acc[i].xx += w * s.xx;
            acc[i].xy += w * s.xy;
            acc[i].yy += w * s.yy;
            acc_w[i] += w;
        }
    }

    // 4. Per-vertex decomposition.
    let vertex_tensors: Vec<Sym2> = acc
        .iter()
        .zip(&acc_w)
        .map(|(s, &w)| {
            if w > 0.0 && w.is_finite() {
                Sym2 {
                    xx: s.xx / w,
                    xy: s.xy / w,
                    yy: s.yy / w,
                }
            } else {
                Sym2::default()
            }
        })
        .collect();
    let per_vertex: Vec<Curvature> = (0..nv)
        .into_par_iter()
        .map(|i| {
            let (u, v) = frames[i];
            diagonalize(&vertex_tensors[i], u, v, normals[i])
        })
        .collect();

    // 5. Per-face tensors: the vertex tensors turned into the face plane.
    let (per_face, per_face_tensor): (Vec<Curvature>, Vec<Sym3>) = faces
        .par_iter()
        .zip(&geoms)
        .map(|(f, g)| {
            let Some(g) = g else {
                let p = corners(f).unwrap_or([[0.0; 3]; 3]);
                return (degenerate_curvature(p), Sym3::ZERO);
            };
            let mut s = Sym2::default();
            for &vi in f {
                let i = vi as usize;
                let (u, v) = frames[i];
                let r = reproject(&vertex_tensors[i], u, v, g.t, g.b);
                s.xx += r.xx / 3.0;
                s.xy += r.xy / 3.0;
                s.yy += r.yy / 3.0;
            }
            let c = diagonalize(&s, g.t, g.b, g.n);
            let tensor = Sym3::outer(c.d1) * c.k1 + Sym3::outer(c.d2) * c.k2;
            (c, tensor)
        })
        .unzip();

    CurvatureField {
        per_vertex,
        per_face,
        per_face_tensor,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{MeshInput, SimMesh};
    use std::f64::consts::TAU;

    fn build(positions: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> SimMesh {
        let input = MeshInput {
            positions,
            triangles,
            ..Default::default()
        };
        SimMesh::build(&input, &Default::default())
            .expect("build")
            .0
    }

    fn normalize(a: [f64; 3]) -> [f64; 3] {
        v3::scale(a, 1.0 / v3::norm(a))
    }

    /// Icosahedron subdivided `level` times, on a sphere of radius `r`.
    fn icosphere(level: usize, r: f64) -> SimMesh {
        let input = crate::mesh::shapes::icosphere_input(level);
        build(
            input.positions.iter().map(|&x| v3::scale(x, r)).collect(),
            input.triangles,
        )
    }

    /// A triangulated `nu` x `nv` parameter grid over `[0, 1]^2` mapped by
    /// `f`; a periodic direction closes up (its last column is welded to the
    /// first). Triangles are counter-clockwise in `(u, v)`.
    fn grid(
        nu: usize,
        nv: usize,
        periodic_u: bool,
        periodic_v: bool,
        f: impl Fn(f64, f64) -> [f64; 3],
    ) -> SimMesh {
        jittered_grid(nu, nv, periodic_u, periodic_v, 0.0, f)
    }

    /// [`grid`] with interior parameter points moved by up to `jitter`
    /// cells in each direction (seeded), so the mesh is irregular but its
    /// vertices stay on the surface.
    fn jittered_grid(
        nu: usize,
        nv: usize,
        periodic_u: bool,
        periodic_v: bool,
        jitter: f64,
        f: impl Fn(f64, f64) -> [f64; 3],
    ) -> SimMesh {
        let cu = if periodic_u { nu } else { nu + 1 };
        let cv = if periodic_v { nv } else { nv + 1 };
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rand = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let mut positions = Vec::new();
        for j in 0..cv {
            for i in 0..cu {
                let (mut du, mut dv) = (jitter * rand(), jitter * rand());
                if !periodic_u && (i == 0 || i == nu) {
                    du = 0.0;
                }
                if !periodic_v && (j == 0 || j == nv) {
                    dv = 0.0;
                }
                positions.push(f((i as f64 + du) / nu as f64, (j as f64 + dv) / nv as f64));
            }
        }
        let id = |i: usize, j: usize| ((j % cv) * cu + (i % cu)) as u32;
        let mut triangles = Vec::new();
        for j in 0..nv {
            for i in 0..nu {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        build(positions, triangles)
    }

    /// Open cylinder of radius `r` around z, `n` segments around, rows as
    /// high as the segments are wide.
    fn cylinder(n: usize, r: f64) -> SimMesh {
        let h = TAU * r / n as f64;
        let rows = n / 2;
        grid(n, rows, true, false, |u, v| {
            let a = TAU * u;
            [r * a.cos(), r * a.sin(), (v - 0.5) * rows as f64 * h]
        })
    }

    fn cylinder_truth(p: [f64; 3], r: f64) -> Curvature {
        let a = p[1].atan2(p[0]);
        Curvature {
            k1: 1.0 / r,
            k2: 0.0,
            d1: [-a.sin(), a.cos(), 0.0],
            d2: [0.0, 0.0, 1.0],
        }
    }

    /// Torus around z with radii `big` and `small`, jittered by `jitter`
    /// cells.
    fn torus(nu: usize, nv: usize, big: f64, small: f64, jitter: f64) -> SimMesh {
        jittered_grid(nu, nv, true, true, jitter, |u, v| {
            let (a, b) = (TAU * u, TAU * v);
            let rho = big + small * b.cos();
            [rho * a.cos(), rho * a.sin(), small * b.sin()]
        })
    }

    fn torus_truth(p: [f64; 3], big: f64, small: f64) -> Curvature {
        let a = p[1].atan2(p[0]);
        let b = p[2].atan2(p[0].hypot(p[1]) - big);
        Curvature {
            // Around the tube, then along it (cos b / (R + r cos b) < 1 / r).
            k1: 1.0 / small,
            k2: b.cos() / (big + small * b.cos()),
            d1: [-b.sin() * a.cos(), -b.sin() * a.sin(), b.cos()],
            d2: [-a.sin(), a.cos(), 0.0],
        }
    }

    /// The saddle z = (x^2 - y^2) / 2 over `[-1, 1]^2`, normals up, jittered
    /// by `jitter` cells.
    fn saddle(n: usize, jitter: f64) -> SimMesh {
        jittered_grid(n, n, false, false, jitter, |u, v| {
            let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            [x, y, 0.5 * (x * x - y * y)]
        })
    }

    fn saddle_truth(p: [f64; 3]) -> Curvature {
        let (x, y) = (p[0], p[1]);
        let (fx, fy) = (x, -y);
        let w = (1.0 + fx * fx + fy * fy).sqrt();
        // First fundamental form and (convex-positive, upward normal) second.
        let (e, f, g) = (1.0 + fx * fx, fx * fy, 1.0 + fy * fy);
        let (l, m, n) = (-1.0 / w, 0.0, 1.0 / w);
        // det(II - k I) = 0.
        let qa = e * g - f * f;
        let qb = -(l * g + n * e - 2.0 * m * f);
        let qc = l * n - m * m;
        let disc = (qb * qb - 4.0 * qa * qc).max(0.0).sqrt();
        let ks = [(-qb + disc) / (2.0 * qa), (-qb - disc) / (2.0 * qa)];
        let dirs = ks.map(|k| {
            let r1 = [-(m - k * f), l - k * e];
            let r2 = [n - k * g, -(m - k * f)];
            let [a, b] = if r1[0].hypot(r1[1]) >= r2[0].hypot(r2[1]) {
                r1
            } else {
                r2
            };
            normalize([a, b, fx * a + fy * b])
        });
        Curvature {
            k1: ks[0],
            k2: ks[1],
            d1: dirs[0],
            d2: dirs[1],
        }
    }

    fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
        let c = v3::dot(a, b).abs() / (v3::norm(a) * v3::norm(b));
        c.min(1.0).acos().to_degrees()
    }

    /// Largest errors over the checked elements.
    #[derive(Debug, Default)]
    struct Errors {
        /// |k - k_true| / max(|k1_true|, |k2_true|), for k1 and k2.
        k1: f64,
        k2: f64,
        /// Angle between d1 and its true direction, in degrees, where the
        /// true |k1 - k2| is at least a fifth of the largest |k|.
        dir: f64,
        checked: usize,
    }

    impl Errors {
        fn add(&mut self, est: &Curvature, truth: &Curvature, directions: bool) {
            let scale = truth.k1.abs().max(truth.k2.abs());
            self.k1 = self.k1.max((est.k1 - truth.k1).abs() / scale);
            self.k2 = self.k2.max((est.k2 - truth.k2).abs() / scale);
            if directions && (truth.k1 - truth.k2).abs() >= 0.2 * scale {
                self.dir = self.dir.max(angle_deg(est.d1, truth.d1));
                self.dir = self.dir.max(angle_deg(est.d2, truth.d2));
            }
            self.checked += 1;
        }
    }

    fn assert_valid(field: &CurvatureField, mesh: &SimMesh) {
        assert_eq!(field.per_vertex.len(), mesh.n_vertices());
        assert_eq!(field.per_face.len(), mesh.n_faces());
        assert_eq!(field.per_face_tensor.len(), mesh.n_faces());
        for c in field.per_vertex.iter().chain(&field.per_face) {
            assert!(
                c.k1.is_finite() && c.k2.is_finite() && c.k1 >= c.k2,
                "{c:?}"
            );
            assert!((v3::norm(c.d1) - 1.0).abs() < 1e-9, "{c:?}");
            assert!((v3::norm(c.d2) - 1.0).abs() < 1e-9, "{c:?}");
            assert!(v3::dot(c.d1, c.d2).abs() < 1e-9, "{c:?}");
        }
        assert!(field.per_face_tensor.iter().all(Sym3::is_finite));
    }

    /// Checks `mesh` against `truth` (evaluated at vertices and face
    /// centroids) away from the boundary: boundary vertices and their 1-ring
    /// are skipped, and faces touching them. Returns (vertex, face) errors.
    fn check(
        name: &str,
        mesh: &SimMesh,
        truth: impl Fn([f64; 3]) -> Curvature,
        directions: bool,
    ) -> (Errors, Errors) {
        let field = estimate(mesh);
        assert_valid(&field, mesh);
        let mut excluded = vec![false; mesh.n_vertices()];
        for f in mesh.faces() {
            let vs = mesh.face_vertices(f);
            if vs.iter().any(|&v| mesh.is_boundary_vertex(v)) {
                vs.iter().for_each(|v| excluded[v.idx()] = true);
            }
        }
        let mut ev = Errors::default();
        for v in mesh.vertices().filter(|v| !excluded[v.idx()]) {
            ev.add(
                &field.per_vertex[v.idx()],
                &truth(mesh.position(v)),
                directions,
            );
        }
        let mut ef = Errors::default();
        for f in mesh.faces() {
            let vs = mesh.face_vertices(f);
            if vs.iter().any(|v| excluded[v.idx()]) {
                continue;
            }
            let c = vs.iter().fold([0.0; 3], |s, &v| {
                v3::add(s, v3::scale(mesh.position(v), 1.0 / 3.0))
            });
            let est = &field.per_face[f.idx()];
            // Face directions lie in the face plane, which is tilted from the
            // tangent plane at the centroid by about an edge length over the
            // radius: compare with the true directions projected into it.
            let n = mesh.face_normal(f);
            let mut t = truth(c);
            for d in [&mut t.d1, &mut t.d2] {
                *d = normalize(v3::sub(*d, v3::scale(n, v3::dot(*d, n))));
            }
            ef.add(est, &t, directions);
            // The tensor is k1 d1 d1^T + k2 d2 d2^T, tangent to the face.
            let t = field.per_face_tensor[f.idx()];
            assert!(v3::norm(t.mul_vec(n)) < 1e-9 * (1.0 + est.frobenius()));
            assert!((t.quad(est.d1, est.d1) - est.k1).abs() < 1e-9 * (1.0 + est.frobenius()));
            assert!((t.quad(est.d2, est.d2) - est.k2).abs() < 1e-9 * (1.0 + est.frobenius()));
        }
        eprintln!(
            "{name}: {} vertices, {} faces; vertices checked {}: k1 {:.4}% k2 {:.4}% dir {:.3} deg; faces checked {}: k1 {:.4}% k2 {:.4}% dir {:.3} deg",
            mesh.n_vertices(),
            mesh.n_faces(),
            ev.checked,
            100.0 * ev.k1,
            100.0 * ev.k2,
            ev.dir,
            ef.checked,
            100.0 * ef.k1,
            100.0 * ef.k2,
            ef.dir,
        );
        assert!(ev.checked > 0 && ef.checked > 0);
        for (what, e) in [("vertex", &ev), ("face", &ef)] {
            assert!(
                e.k1 <= 0.02 && e.k2 <= 0.02,
                "{name} {what}: curvature error above 2%: {e:?}"
            );
            assert!(
                e.dir <= 3.0,
                "{name} {what}: direction error above 3 deg: {e:?}"
            );
        }
        (ev, ef)
    }

    #[test]
    fn sphere() {
        for (level, r) in [(3, 1.0), (4, 2.5)] {
            let mesh = icosphere(level, r);
            let truth = |_| Curvature {
                k1: 1.0 / r,
                k2: 1.0 / r,
                ..Default::default()
            };
            check(&format!("icosphere level {level}"), &mesh, truth, false);
        }
    }

    #[test]
    fn cylinder_open() {
        for n in [32, 64] {
            let r = 0.7;
            check(
                &format!("cylinder {n}"),
                &cylinder(n, r),
                |p| cylinder_truth(p, r),
                true,
            );
        }
    }

    #[test]
    fn torus_both_resolutions() {
        let (big, small) = (3.0, 1.0);
        for (nu, nv) in [(96, 32), (192, 64)] {
            check(
                &format!("torus {nu}x{nv}"),
                &torus(nu, nv, big, small, 0.0),
                |p| torus_truth(p, big, small),
                true,
            );
        }
    }

    #[test]
    fn saddle_patch() {
        for n in [20, 40] {
            check(
                &format!("saddle {n}x{n}"),
                &saddle(n, 0.0),
                saddle_truth,
                true,
            );
        }
    }

    /// Irregular meshes (parameter points jittered by 0.1 cell): estimators
    /// from normal differences do not converge there (the error does not
    /// shrink with the edge length), so this only guards against
    /// regressions, with bounds well above the measured errors (vertex
    /// medians 0.7% on the torus and 1.3% on the saddle, maxima 4.5% and
    /// 6.2%).
    #[test]
    fn irregular_meshes_stay_close() {
        let (big, small) = (3.0, 1.0);
        let meshes = [
            ("jittered torus", torus(192, 64, big, small, 0.1), 0),
            ("jittered saddle", saddle(60, 0.1), 1),
        ];
        for (name, mesh, kind) in meshes {
            let truth = |p| match kind {
                0 => torus_truth(p, big, small),
                _ => saddle_truth(p),
            };
            let field = estimate(&mesh);
            assert_valid(&field, &mesh);
            let mut errors: Vec<f64> = mesh
                .vertices()
                .filter(|&v| !mesh.is_boundary_vertex(v))
                .filter(|&v| {
                    mesh.vertex_faces(v).all(|f| {
                        mesh.face_vertices(f)
                            .iter()
                            .all(|&w| !mesh.is_boundary_vertex(w))
                    })
                })
                .map(|v| {
                    let (e, t) = (&field.per_vertex[v.idx()], truth(mesh.position(v)));
                    let scale = t.k1.abs().max(t.k2.abs());
                    (e.k1 - t.k1).abs().max((e.k2 - t.k2).abs()) / scale
                })
                .collect();
            errors.sort_by(f64::total_cmp);
            let median = errors[errors.len() / 2];
            let max = errors[errors.len() - 1];
            eprintln!(
                "{name}: median {:.3}% max {:.3}%",
                100.0 * median,
                100.0 * max
            );
            assert!(
                median < 0.03 && max < 0.15,
                "{name}: median {median} max {max}"
            );
        }
    }

    fn rotate(p: [f64; 3]) -> [f64; 3] {
        // A fixed rotation: about z by 0.3, then about x by 1.1.
        let (s1, c1) = 0.3f64.sin_cos();
        let (s2, c2) = 1.1f64.sin_cos();
        let q = [c1 * p[0] - s1 * p[1], s1 * p[0] + c1 * p[1], p[2]];
        [q[0], c2 * q[1] - s2 * q[2], s2 * q[1] + c2 * q[2]]
    }

    #[test]
    fn flat_plate_is_exactly_zero() {
        let plates = [
            jittered_grid(12, 9, false, false, 0.25, |u, v| [2.0 * u, 1.5 * v, 0.0]),
            jittered_grid(12, 9, false, false, 0.25, |u, v| {
                rotate([2.0 * u - 0.3, 1.5 * v + 0.7, 0.4])
            }),
        ];
        for mesh in plates {
            let field = estimate(&mesh);
            assert_valid(&field, &mesh);
            for c in field.per_vertex.iter().chain(&field.per_face) {
                assert!(c.k1.abs() < 1e-12 && c.k2.abs() < 1e-12, "{c:?}");
            }
            for t in &field.per_face_tensor {
                assert!(t.frobenius_sq().sqrt() < 1e-12, "{t:?}");
            }
        }
    }

    #[test]
    fn degenerate_faces_get_zero_and_no_nan() {
        let r = 1.3;
        let mut mesh = icosphere(3, r);
        // Exactly collinear (the new vertex is the midpoint of an edge: the
        // third coordinate is lost in rounding), coincident with a corner,
        // and a sliver (height 1e-9 of the edge).
        let splits: [(u32, [f64; 3]); 3] = [
            (10, [0.5, 0.5, 1e-20]),
            (200, [1.0, 1e-20, 1e-20]),
            (600, [0.5, 0.5, 1e-9]),
        ];
        // Corners of the split faces and their 1-rings see the change.
        let mut touched = vec![false; mesh.n_vertices()];
        for (f, _) in splits {
            for v in mesh.face_vertices(crate::mesh::FaceId(f)) {
                for g in mesh.vertex_faces(v) {
                    for w in mesh.face_vertices(g) {
                        touched[w.idx()] = true;
                    }
                }
            }
        }
        for (f, bary) in splits {
            mesh.split_face(crate::mesh::FaceId(f), bary)
                .expect("split");
        }
        // Zero area up to rounding (the cross product of exactly collinear
        // edges is not exactly zero in floating point).
        let h2 = mesh.mean_edge_length().powi(2);
        let zero_area: Vec<_> = mesh
            .faces()
            .filter(|&f| mesh.face_area(f) < 1e-15 * h2)
            .collect();
        assert_eq!(zero_area.len(), 3, "the test needs zero-area faces");
        assert!(zero_area.iter().any(|&f| mesh.face_area(f) == 0.0));
        let field = estimate(&mesh);
        assert_valid(&field, &mesh);
        for f in &zero_area {
            let c = field.per_face[f.idx()];
            assert_eq!((c.k1, c.k2), (0.0, 0.0));
            assert_eq!(field.per_face_tensor[f.idx()], Sym3::ZERO);
        }
        // Elsewhere the sphere is unaffected.
        let untouched = touched.iter().filter(|&&t| !t).count();
        assert!(untouched > 500);
        for v in mesh
            .vertices()
            .take(touched.len())
            .filter(|v| !touched[v.idx()])
        {
            let c = field.per_vertex[v.idx()];
            assert!(
                (c.k1 * r - 1.0).abs() < 0.02 && (c.k2 * r - 1.0).abs() < 0.02,
                "{c:?}"
            );
        }
        // A collinear input triangle is dropped by the build; still no NaN.
        let mut input_p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.2],
            [2.0, 0.0, 0.0],
        ];
        input_p.push([1.0, 1.0, 0.5]);
        let mesh = build(input_p, vec![[0, 1, 2], [0, 1, 3], [1, 4, 2]]);
        assert_valid(&estimate(&mesh), &mesh);
    }

    #[test]
    fn broken_soups_give_finite_values() {
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.3],
            [0.5, 0.0, 1.0],
            [7.0, 7.0, 7.0], // isolated
            [0.5, 0.0, 0.0], // on the edge 0-1
            [f64::NAN, 0.0, 0.0],
            [1e300, 1e300, 0.0],
            [-1e300, 1e300, 1e300],
        ];
        let faces = vec![
            [0, 1, 2],
            [1, 0, 3],
            [0, 1, 4],  // third face on edge 0-1: non-manifold
            [1, 0, 2],  // the first face, reversed
            [0, 6, 1],  // collinear
            [0, 0, 2],  // repeated corner
            [0, 1, 99], // out of range
            [7, 1, 2],  // NaN corner
            [8, 9, 1],  // overflowing
        ];
        let field = estimate_soup(&p, &faces, 0);
        assert_eq!(field.per_vertex.len(), p.len());
        assert_eq!(field.per_face.len(), faces.len());
        for c in field.per_vertex.iter().chain(&field.per_face) {
            assert!(
                c.k1.is_finite() && c.k2.is_finite() && c.k1 >= c.k2,
                "{c:?}"
            );
            assert!((v3::norm(c.d1) - 1.0).abs() < 1e-9 && (v3::norm(c.d2) - 1.0).abs() < 1e-9);
            assert!(v3::dot(c.d1, c.d2).abs() < 1e-9, "{c:?}");
        }
        assert!(field.per_face_tensor.iter().all(Sym3::is_finite));
        assert_eq!(field.per_vertex[5].k1, 0.0, "isolated vertex");
        for f in 4..9 {
            assert_eq!(field.per_face[f].k1, 0.0, "degenerate face {f}");
            assert_eq!(field.per_face_tensor[f], Sym3::ZERO);
        }
        let empty = estimate_soup(&[], &[], 0);
        assert!(empty.per_vertex.is_empty() && empty.per_face.is_empty());
    }

    #[test]
    fn sign_scale_and_determinism() {
        for r in [1e-4, 1.0, 1e5] {
            let mesh = icosphere(3, r);
            let field = estimate(&mesh);
            for c in &field.per_vertex {
                assert!(
                    (c.k1 * r - 1.0).abs() < 1e-9 && (c.k2 * r - 1.0).abs() < 1e-9,
                    "{c:?}"
                );
                assert!((c.gaussian() * r * r - 1.0).abs() < 1e-8);
                assert!((c.mean() * r - 1.0).abs() < 1e-9);
                assert!((c.frobenius() * r - 2f64.sqrt()).abs() < 1e-8);
            }
            assert_eq!(field, estimate(&mesh), "deterministic");
        }
        // Inside out: concave, negative.
        let mesh = icosphere(3, 2.0);
        let flipped = build(
            mesh.positions().to_vec(),
            mesh.faces()
                .map(|f| {
                    let [a, b, c] = mesh.face_vertices(f);
                    [a.0, c.0, b.0]
                })
                .collect(),
        );
        for c in estimate(&flipped).per_vertex {
            assert!(
                (c.k1 + 0.5).abs() < 1e-9 && (c.k2 + 0.5).abs() < 1e-9,
                "{c:?}"
            );
        }
    }

    /// Seen at a scale, a plane with fine bumps (a noisy ground) is flat and
    /// a sphere keeps its curvature: the grain cancels out in the averaged
    /// normals, a bend larger than the scale does not.
    #[test]
    fn at_a_scale_the_grain_cancels_and_the_bend_stays() {
        let mut lcg = crate::mesh::shapes::Lcg(7);
        let heights: Vec<f64> = (0..81 * 81)
            .map(|_| 0.02 * (lcg.next_f64() - 0.5))
            .collect();
        let ground = grid(80, 80, false, false, |u, v| {
            let (i, j) = ((u * 80.0).round() as usize, (v * 80.0).round() as usize);
            [4.0 * u, heights[j * 81 + i], 4.0 * v]
        });
        let rms = |k: &CurvatureField| {
            let n = k.per_vertex.len() as f64;
            (k.per_vertex
                .iter()
                .map(|c| c.frobenius().powi(2))
                .sum::<f64>()
                / n)
                .sqrt()
        };
        // Edges of 0.05: the grain's curvature is about 0.02 / 0.05^2.
        let (raw, seen) = (
            rms(&estimate(&ground)),
            rms(&estimate_at_scale(&ground, 0.4)),
        );
        assert!(raw > 1.0, "{raw}");
        assert!(seen < 0.05 * raw, "raw {raw}, at 0.4: {seen}");
        let sphere = icosphere(4, 2.0);
        let k = estimate_at_scale(&sphere, 0.5);
        for c in &k.per_vertex {
            assert!((c.k1 * 2.0 - 1.0).abs() < 0.05 && (c.k2 * 2.0 - 1.0).abs() < 0.05);
        }
        assert_eq!(k, estimate_at_scale(&sphere, 0.5), "deterministic");
    }
}
