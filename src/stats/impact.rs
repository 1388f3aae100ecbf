//! An impact's pattern seen from the hit: how the crack length splits into
//! radial cracks (running away from the hit) and concentric ones (across
//! that) with the distance from it, and how many cracks cross the circle
//! at half the reference radius (the radial cracks there).
//!
//! Distances run along the surface from the hit (geodesic, as the impact's
//! load does: [`crate::stress::geodesic`] over the surface welded by exact
//! position, each point's distance interpolated over its closest triangle),
//! so on a curved asset a crack that runs straight away from the hit over
//! the surface counts as radial, and the bands' areas are the surface's.
//! Each crack segment is cut into `PIECES` pieces, each binned by the
//! distance of its middle; a piece is radial when its distance from the
//! hit changes by at least `cos 30 deg` of its length, concentric when by
//! at most `sin 30 deg`. Where the surface does not carry the distance (no
//! triangles, a piece off the surface the hit is on, as the cells of an
//! output whose cracks were opened into gaps), the whole measure falls back
//! to straight-line distances and directions against the way away from the
//! hit in the tangent plane, the bands' areas to flat annuli, and
//! [`ImpactStats::along_surface`] says so.

use super::{vertex_normals, PatternInput};
use crate::math::v3::{add, cross, dot, norm, scale, sub, unit};
use crate::mesh::spatial::Faces;
use crate::mesh::{MeshInput, SimMesh, WeldOptions};
use serde::Serialize;

/// Width of a distance band, as a fraction of the reference radius.
pub const BAND: f64 = 0.1;
/// Bands out to this many reference radii.
pub const REACH: f64 = 1.5;
/// Pieces each crack segment is cut into for binning.
const PIECES: usize = 8;
/// Within this angle (degrees) of the way away from the hit a piece is
/// radial; within it of across, concentric; between, neither.
const WITHIN_DEG: f64 = 30.0;
/// Each triangle is cut into this many squared sub-triangles for the
/// bands' areas.
const AREA_SPLIT: usize = 4;

/// See the module documentation.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ImpactStats {
    /// The hit, as given.
    pub center: [f64; 3],
    /// The reference radius, as given.
    pub radius: f64,
    /// Whether distances run along the surface (else straight lines; see
    /// the module documentation).
    pub along_surface: bool,
    /// Radial crack length in each band of `BAND` radii from the hit, out to
    /// `REACH` radii.
    pub radial: Vec<f64>,
    /// Concentric crack length in each band.
    pub concentric: Vec<f64>,
    /// All crack length in each band.
    pub total: Vec<f64>,
    /// Each band's area: the surface's within it (straight: the flat
    /// annulus, `pi (r1^2 - r0^2)`).
    pub area: Vec<f64>,
    /// Crack length per area of each band.
    pub per_area: Vec<f64>,
    /// Crack length beyond `REACH` radii.
    pub beyond: f64,
    /// Crack length on parts of the surface the hit does not reach along
    /// it (other pieces of the mesh, or across an opened gap).
    pub unreached: f64,
    /// The radial share of the crack length between 0.2 and 0.8 radii.
    pub radial_share_mid: f64,
    /// Crack segments crossing the circle at half the radius.
    pub crossings_half: usize,
    /// Of `crossings_half`, the radial ones: their distance from the hit
    /// changes by at least cos 30 degrees of their length (the radial cracks
    /// at half the radius; an arc wiggling across the circle is not one).
    pub radial_crossings_half: usize,
}

/// Distances from the hit along a surface: per vertex, each point's over
/// its closest triangle.
struct Along {
    faces: Faces,
    triangles: Vec<[u32; 3]>,
    positions: Vec<[f64; 3]>,
    dist: Vec<f64>,
}

impl Along {
    /// The surface of `input` welded by exact position, and the distance
    /// along it from its closest point to `center`; `None` without
    /// triangles or when they do not make a surface.
    fn new(input: &PatternInput, center: [f64; 3]) -> Option<Along> {
        if input.triangles.is_empty() {
            return None;
        }
        let mesh_input = MeshInput {
            positions: input.positions.clone(),
            triangles: input.triangles.clone(),
            ..Default::default()
        };
        let exact = WeldOptions {
            relative_tolerance: 0.0,
        };
        let (mesh, _) = SimMesh::build(&mesh_input, &exact).ok()?;
        let triangles: Vec<[u32; 3]> = mesh
            .faces()
            .map(|f| mesh.face_vertices(f).map(|v| v.0))
            .collect();
        let positions = mesh.positions().to_vec();
        let faces = Faces::new(positions.clone(), triangles.clone());
        let (face, _, hit) = faces.closest(center)?;
        let dist = crate::stress::geodesic::distances(&mesh, hit, face);
        Some(Along {
            faces,
            triangles,
            positions,
            dist,
        })
    }

    /// The distance at `p` (on or next to the surface); `None` where the
    /// surface from the hit does not reach.
    fn at(&self, p: [f64; 3]) -> Option<f64> {
        let (f, bary, _) = self.faces.closest(p)?;
        let d = self.triangles[f].map(|v| self.dist[v as usize]);
        let v = bary[0] * d[0] + bary[1] * d[1] + bary[2] * d[2];
        v.is_finite().then_some(v)
    }

    /// The surface's area in each of `bands` bands of `width` (each
    /// triangle cut into `AREA_SPLIT^2` sub-triangles, binned by their
    /// centroids' distances).
    fn band_areas(&self, width: f64, bands: usize) -> Vec<f64> {
        let mut area = vec![0.0; bands];
        let m = AREA_SPLIT as f64;
        for t in &self.triangles {
            let d = t.map(|v| self.dist[v as usize]);
            if d.iter().any(|x| !x.is_finite()) {
                continue;
            }
            let p = t.map(|v| self.positions[v as usize]);
            let a = 0.5 * norm(cross(sub(p[1], p[0]), sub(p[2], p[0]))) / (m * m);
            // Centroids of the sub-triangles: up (i, j) and down ones.
            let mut bin = |u: f64, v: f64| {
                let x = (1.0 - u - v) * d[0] + u * d[1] + v * d[2];
                let k = (x / width) as usize;
                if k < bands {
                    area[k] += a;
                }
            };
            for i in 0..AREA_SPLIT {
                for j in 0..AREA_SPLIT - i {
                    let (i, j) = (i as f64, j as f64);
                    bin((i + 1.0 / 3.0) / m, (j + 1.0 / 3.0) / m);
                    if i + j + 1.0 < m {
                        bin((i + 2.0 / 3.0) / m, (j + 2.0 / 3.0) / m);
                    }
                }
            }
        }
        area
    }
}

/// The impact statistics of `input` for a hit at `center` with reference
/// radius `radius` (> 0): along the surface where it carries the distance,
/// else straight (see the module documentation).
pub fn impact_stats(input: &PatternInput, center: [f64; 3], radius: f64) -> ImpactStats {
    if let Some(along) = Along::new(input, center) {
        let s = measure(input, center, radius, Some(&along));
        let all = s.total.iter().sum::<f64>() + s.beyond + s.unreached;
        // Most of the length out of reach: cells opened apart, not a
        // surface the hit's distance runs over.
        if s.unreached <= 0.5 * all {
            return s;
        }
    }
    measure(input, center, radius, None)
}

/// The statistics with distances along `along`, or straight without it.
fn measure(
    input: &PatternInput,
    center: [f64; 3],
    radius: f64,
    along: Option<&Along>,
) -> ImpactStats {
    let pos = &input.positions;
    let normals = vertex_normals(input);
    let bands = (REACH / BAND).round() as usize;
    let mut s = ImpactStats {
        center,
        radius,
        along_surface: along.is_some(),
        radial: vec![0.0; bands],
        concentric: vec![0.0; bands],
        total: vec![0.0; bands],
        ..Default::default()
    };
    let (cos_in, sin_in) = (WITHIN_DEG.to_radians().cos(), WITHIN_DEG.to_radians().sin());
    let straight = |p: [f64; 3]| norm(sub(p, center));
    let distance = |p: [f64; 3]| match along {
        Some(a) => a.at(p),
        None => Some(straight(p)),
    };
    let half = 0.5 * radius;
    let (mut mid_radial, mut mid_all) = (0.0, 0.0);
    for e in &input.cracks {
        let (a, b) = (pos[e[0] as usize], pos[e[1] as usize]);
        if let (Some(da), Some(db)) = (distance(a), distance(b)) {
            if (da < half) != (db < half) {
                s.crossings_half += 1;
                if (db - da).abs() >= cos_in * norm(sub(b, a)) {
                    s.radial_crossings_half += 1;
                }
            }
        }
        let n = unit(add(normals[e[0] as usize], normals[e[1] as usize]));
        let step = scale(sub(b, a), 1.0 / PIECES as f64);
        let len = norm(step);
        let Some(t) = unit(step) else { continue };
        for k in 0..PIECES {
            let m = add(a, scale(step, k as f64 + 0.5));
            // How much of the piece runs away from the hit, and where.
            let (c, d) = if along.is_some() {
                let ends = (
                    distance(add(a, scale(step, k as f64))),
                    distance(add(m, scale(step, 0.5))),
                );
                let (Some(d0), Some(d1)) = ends else {
                    s.unreached += len;
                    continue;
                };
                (((d1 - d0).abs() / len).min(1.0), 0.5 * (d0 + d1))
            } else {
                let away = sub(m, center);
                let away = match n {
                    Some(n) => sub(away, scale(n, dot(away, n))),
                    None => away,
                };
                (unit(away).map_or(0.0, |w| dot(w, t).abs()), straight(m))
            };
            let d = d / radius;
            let band = (d / BAND) as usize;
            if band >= bands {
                s.beyond += len;
                continue;
            }
            s.total[band] += len;
            if c >= cos_in {
                s.radial[band] += len;
            } else if c <= sin_in {
                s.concentric[band] += len;
            }
            if (0.2..0.8).contains(&d) {
                mid_all += len;
                if c >= cos_in {
                    mid_radial += len;
                }
            }
        }
    }
    s.area = match along {
        Some(a) => a.band_areas(BAND * radius, bands),
        None => (0..bands)
            .map(|i| {
                let (r0, r1) = (i as f64 * BAND * radius, (i + 1) as f64 * BAND * radius);
                std::f64::consts::PI * (r1 * r1 - r0 * r0)
            })
            .collect(),
    };
    s.per_area = s
        .total
        .iter()
        .zip(&s.area)
        .map(|(l, a)| if *a > 0.0 { l / a } else { 0.0 })
        .collect();
    s.radial_share_mid = if mid_all > 0.0 {
        mid_radial / mid_all
    } else {
        0.0
    };
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A star of four straight rays and one full ring: the rays are radial
    /// in every band they cross, the ring concentric in its band, each ray
    /// crosses the half-radius circle once, and lengths add up.
    #[test]
    fn a_star_with_a_ring_splits_into_radial_and_concentric_length() {
        let mut positions = vec![[0.0, 0.0, 0.0]];
        let mut cracks = Vec::new();
        // Rays from the hit out to 1.0 along +-x, +-y, in 20 steps.
        for dir in [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]] {
            let mut prev = 0u32;
            for k in 1..=20 {
                let r = k as f64 / 20.0;
                positions.push([dir[0] * r, dir[1] * r, 0.0]);
                let v = positions.len() as u32 - 1;
                cracks.push([prev, v]);
                prev = v;
            }
        }
        // A ring at 0.65, 200 chords.
        let first = positions.len() as u32;
        for k in 0..200 {
            let a = k as f64 * std::f64::consts::TAU / 200.0;
            positions.push([0.65 * a.cos(), 0.65 * a.sin(), 0.0]);
            cracks.push([first + k, first + (k + 1) % 200]);
        }
        let input = PatternInput {
            positions,
            cracks,
            ..Default::default()
        };
        let s = impact_stats(&input, [0.0; 3], 1.0);
        assert_eq!((s.crossings_half, s.radial_crossings_half), (4, 4));
        let total: f64 = s.total.iter().sum::<f64>() + s.beyond;
        let ring = 200.0 * 2.0 * 0.65 * (std::f64::consts::PI / 200.0).sin();
        assert!((total - (4.0 + ring)).abs() < 1e-9, "{total}");
        // Band 6 (0.6..0.7 R) holds the ring and 0.4 of ray length.
        assert!((s.concentric[6] - ring).abs() < 1e-9, "{:?}", s.concentric);
        assert!((s.radial[6] - 0.4).abs() < 1e-9, "{:?}", s.radial);
        for i in (0..10).filter(|&i| i != 6) {
            assert!((s.radial[i] - 0.4).abs() < 1e-9, "band {i}: {:?}", s.radial);
            assert_eq!(s.concentric[i], 0.0, "band {i}");
        }
        // Between 0.2 and 0.8 R: 2.4 of rays, the ring.
        assert!((s.radial_share_mid - 2.4 / (2.4 + ring)).abs() < 1e-9);
        assert!(s.per_area[0] > s.per_area[9]);
        assert_eq!(s.beyond, 0.0);
    }

    /// An arc wiggling across the half-radius circle crosses it often but
    /// is no radial crack: the four rays are the radial crossings.
    #[test]
    fn an_arc_across_half_the_radius_is_not_a_radial_crack() {
        let mut positions = vec![[0.0, 0.0, 0.0]];
        let mut cracks = Vec::new();
        for dir in [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]] {
            positions.push([dir[0], dir[1], 0.0]);
            cracks.push([0, positions.len() as u32 - 1]);
        }
        // Ten chords between 0.49 and 0.51 R from 0.3 to 1.2 radians.
        let first = positions.len() as u32;
        for k in 0..=10 {
            let (a, r) = (0.3 + 0.09 * k as f64, if k % 2 == 0 { 0.49 } else { 0.51 });
            positions.push([r * a.cos(), r * a.sin(), 0.0]);
            if k > 0 {
                cracks.push([first + k - 1, first + k]);
            }
        }
        let input = PatternInput {
            positions,
            cracks,
            ..Default::default()
        };
        let s = impact_stats(&input, [0.0; 3], 1.0);
        assert_eq!((s.crossings_half, s.radial_crossings_half), (14, 4));
    }

    /// A cylinder of radius 1 hit on its side, a crack around it from the
    /// hit: along the surface it runs straight away from the hit (all
    /// radial), in straight lines it bends away from radial past 60
    /// degrees; the bands' areas are the flat annuli (a cylinder unrolls).
    #[test]
    fn on_a_cylinder_a_crack_around_it_from_the_hit_is_radial() {
        let (segments, rows) = (240usize, 80usize);
        let mut positions = Vec::new();
        for j in 0..=rows {
            for i in 0..segments {
                let a = i as f64 * std::f64::consts::TAU / segments as f64;
                let z = -4.0 + 8.0 * j as f64 / rows as f64;
                positions.push([a.cos(), a.sin(), z]);
            }
        }
        let id = |i: usize, j: usize| (j * segments + i % segments) as u32;
        let mut triangles = Vec::new();
        for j in 0..rows {
            for i in 0..segments {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        // Around at z = 0 (row 40) from the hit over 150 degrees.
        let cracks: Vec<[u32; 2]> = (0..100).map(|i| [id(i, 40), id(i + 1, 40)]).collect();
        let surface = PatternInput {
            positions: positions.clone(),
            triangles,
            cracks: cracks.clone(),
            ..Default::default()
        };
        let s = impact_stats(&surface, [1.0, 0.0, 0.0], 2.0);
        assert!(s.along_surface);
        assert_eq!(s.unreached, 0.0);
        assert!(s.radial_share_mid > 0.999, "{}", s.radial_share_mid);
        // 2.6 of arc at radius 2: out to band 13.
        assert!(s.total[12] > 0.0 && s.beyond == 0.0, "{:?}", s.total);
        for i in 0..10 {
            let (r0, r1) = (0.2 * i as f64, 0.2 * (i + 1) as f64);
            let flat = std::f64::consts::PI * (r1 * r1 - r0 * r0);
            assert!(
                (s.area[i] / flat - 1.0).abs() < 0.03,
                "band {i}: {:?}",
                s.area
            );
        }
        let lines = PatternInput {
            positions,
            cracks,
            ..Default::default()
        };
        let straight = impact_stats(&lines, [1.0, 0.0, 0.0], 2.0);
        assert!(!straight.along_surface);
        assert!(
            straight.radial_share_mid < 0.8,
            "{}",
            straight.radial_share_mid
        );
    }

    /// Two pieces of surface: cracks on the one the hit is not on are out
    /// of its reach, and with most of the length there the measure is
    /// straight.
    #[test]
    fn cracks_the_surface_does_not_reach_are_unreached() {
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for (shift, n) in [(0.0, 20u32), (30.0, 20u32)] {
            let base = positions.len() as u32;
            for j in 0..=n {
                for i in 0..=n {
                    positions.push([shift + i as f64, j as f64, 0.0]);
                }
            }
            for j in 0..n {
                for i in 0..n {
                    let v = base + j * (n + 1) + i;
                    triangles.push([v, v + 1, v + n + 2]);
                    triangles.push([v, v + n + 2, v + n + 1]);
                }
            }
        }
        let row =
            |base: u32, j: u32| (0..20).map(move |i| [base + j * 21 + i, base + j * 21 + i + 1]);
        // A ray on the hit's piece, two lines on the other.
        let mut cracks: Vec<[u32; 2]> = row(0, 10).collect();
        let input = PatternInput {
            positions: positions.clone(),
            triangles: triangles.clone(),
            cracks: cracks.clone(),
            ..Default::default()
        };
        let s = impact_stats(&input, [0.0, 10.0, 0.0], 10.0);
        assert!(s.along_surface && s.unreached == 0.0);
        cracks.extend(row(441, 5).chain(row(441, 15)));
        let input = PatternInput {
            cracks: cracks.clone(),
            ..input
        };
        let s = impact_stats(&input, [0.0, 10.0, 0.0], 10.0);
        assert!(!s.along_surface, "{s:?}");
        cracks.truncate(30);
        let input = PatternInput { cracks, ..input };
        let s = impact_stats(&input, [0.0, 10.0, 0.0], 10.0);
        assert!(
            s.along_surface && (s.unreached - 10.0).abs() < 1e-9,
            "{}",
            s.unreached
        );
    }
}
