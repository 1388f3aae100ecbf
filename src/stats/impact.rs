//! An impact's pattern seen from the hit: how the crack length splits into
//! radial cracks (running away from the hit) and concentric ones (across
//! that) with the distance from it, and how many cracks cross the circle
//! at half the reference radius (the radial cracks there).
//!
//! Distances are straight-line (in the surface's units) from the hit; a
//! segment's direction is compared with the way away from the hit projected
//! into the surface's tangent plane where the segment's ends are vertices
//! of the surface, else with the straight way away. Each crack segment is
//! cut into `PIECES` pieces, each binned by the distance of its middle.

use super::{vertex_normals, PatternInput};
use crate::math::v3::{add, dot, norm, scale, sub, unit};
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

/// See the module documentation.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ImpactStats {
    /// The hit, as given.
    pub center: [f64; 3],
    /// The reference radius, as given.
    pub radius: f64,
    /// Radial crack length in each band of `BAND` radii from the hit, out to
    /// `REACH` radii.
    pub radial: Vec<f64>,
    /// Concentric crack length in each band.
    pub concentric: Vec<f64>,
    /// All crack length in each band.
    pub total: Vec<f64>,
    /// Crack length per area of each band's annulus (`pi (r1^2 - r0^2)`).
    pub per_area: Vec<f64>,
    /// Crack length beyond `REACH` radii.
    pub beyond: f64,
    /// The radial share of the crack length between 0.2 and 0.8 radii.
    pub radial_share_mid: f64,
    /// Crack segments crossing the circle at half the radius.
    pub crossings_half: usize,
}

/// The impact statistics of `input` for a hit at `center` with reference
/// radius `radius` (> 0).
pub fn impact_stats(input: &PatternInput, center: [f64; 3], radius: f64) -> ImpactStats {
    let pos = &input.positions;
    let normals = vertex_normals(input);
    let bands = (REACH / BAND).round() as usize;
    let mut s = ImpactStats {
        center,
        radius,
        radial: vec![0.0; bands],
        concentric: vec![0.0; bands],
        total: vec![0.0; bands],
        ..Default::default()
    };
    let (cos_in, sin_in) = (WITHIN_DEG.to_radians().cos(), WITHIN_DEG.to_radians().sin());
    let half = 0.5 * radius;
    let (mut mid_radial, mut mid_all) = (0.0, 0.0);
    for e in &input.cracks {
        let (a, b) = (pos[e[0] as usize], pos[e[1] as usize]);
        let (da, db) = (norm(sub(a, center)), norm(sub(b, center)));
        if (da < half) != (db < half) {
            s.crossings_half += 1;
        }
        let n = add(normals[e[0] as usize], normals[e[1] as usize]);
        let n = unit(n);
        let step = scale(sub(b, a), 1.0 / PIECES as f64);
        let len = norm(step);
        let Some(t) = unit(step) else { continue };
        for k in 0..PIECES {
            let m = add(a, scale(step, k as f64 + 0.5));
            let away = sub(m, center);
            let away = match n {
                Some(n) => sub(away, scale(n, dot(away, n))),
                None => away,
            };
            let d = norm(sub(m, center)) / radius;
            let c = unit(away).map_or(0.0, |w| dot(w, t).abs());
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
    s.per_area = (0..bands)
        .map(|i| {
            let (r0, r1) = (i as f64 * BAND * radius, (i + 1) as f64 * BAND * radius);
            s.total[i] / (std::f64::consts::PI * (r1 * r1 - r0 * r0))
        })
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
        assert_eq!(s.crossings_half, 4);
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
}
