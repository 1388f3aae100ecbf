//! The load of an impact on a brittle shell as a star: `N` radial cracks
//! from the hit, rings between them at spacings that grow outward, intact
//! material beyond.
//!
//! A hit on a thin brittle plate first opens `N` radial cracks from the
//! hoop (circumferential) tension under the load, `N` growing as the
//! square root of the impact speed at fixed thickness and material
//! (Vandenberghe, Vermorel and Villermaux, PRL 110, 174302, 2013); the
//! plate's bending then breaks some of the wedges between them along
//! arcs. Here the load is a rest stress on each face from the distance
//! *along the surface* ([`super::geodesic`]), so it wraps over a curved
//! asset and stops at a gap:
//! - hoop tension (cracks open across it: radial cracks) decaying as
//!   `1 / (1 + (d / 0.9 R)^4)`, with no cut-off: cracks end where it
//!   falls below the toughness. It is nearly all along `N` rays from the hit
//!   (seeded angles, each ray its own strength, so rays end at different
//!   distances), which is where the star's cracks start and run;
//! - radial tension (cracks open across it: arcs), rising from the hit
//!   as `x^2 / (1 + x^2)` with `x = d / 0.3 R` (the wedges between the
//!   rays bend and break away from the hit, not under it) and decaying as
//!   `1 / (1 + (d / 0.7 R)^4)`, along rings at
//!   `0.2 R * 1.6^(j + p - 1/2)`, in a seeded half of the sectors between
//!   rays; each sector has its own phase `p` in [0, 1), spread evenly over
//!   the sectors (a golden-ratio sequence from a seeded start), so the arcs
//!   of neighbouring sectors meet a ray at different distances (a ring is
//!   a broken polygon, not a circle, and no circle holds much of the
//!   length).
//!
//! A faster hit also loads harder: the term's weight is the load of a
//! star of [`LOAD_RAYS`] rays, and a star of `N` carries `sqrt(N / 8)` of
//! it. The impact's energy grows as `N^2` (N as the square root of the
//! speed), so each of the `N` cracks takes energy in proportion to `N`,
//! and elastic energy goes as the stress squared. Without it a slow hit's
//! few rays, as loaded as a fast hit's many, split and run in parallel
//! (4 rays made 6 to 9 radial cracks at half the radius).
//!
//! Widths are in cells (the simulation surface's mean edge), so the
//! pattern is the same at any scale and tessellation.

use super::frame::{face_frame, in_plane, unit};
use crate::math::{hash_unit, v3, Sym3};
use crate::mesh::SimMesh;

/// Impact speed (m/s) that gives [`RAYS_AT_ONE`] radial cracks.
const REFERENCE_SPEED: f64 = 1.0;
/// Radial cracks at [`REFERENCE_SPEED`].
const RAYS_AT_ONE: f64 = 4.0;
/// Fewest radial cracks of a star.
pub const MIN_RAYS: u32 = 3;
/// Most radial cracks of a star.
pub const MAX_RAYS: u32 = 64;

/// Radial cracks for an impact at `speed` m/s: `4 sqrt(speed / 1 m/s)`,
/// rounded, within [`MIN_RAYS`, `MAX_RAYS`] (N doubles when the speed
/// quadruples, as measured on thin glass plates).
pub fn rays_for_speed(speed: f64) -> u32 {
    let n = (RAYS_AT_ONE * (speed / REFERENCE_SPEED).max(0.0).sqrt()).round();
    (n as u32).clamp(MIN_RAYS, MAX_RAYS)
}

/// Rays of the star whose load is the term's weight (4 m/s).
pub const LOAD_RAYS: f64 = 8.0;

/// Hoop tension's decay length, in radii: it falls as
/// `1 / (1 + (d / (0.9 R))^4)`, to 0.40 at `R` (at 0.7 the rays of
/// `glass-impact` ended short and its arcs held too much of the length;
/// at 0.8, with the rings at half the rays' strength, the radial share
/// from 0.2 to 0.8 R fell under 0.65 on 3 and the fullest band of 0.05 R
/// rose over 0.10 on 5 of 32 seeds on plates, the teapot and spot).
const HOOP_DECAY: f64 = 0.9;
/// The rings' decay length, in radii: `1 / (1 + (d / (0.7 R))^4)`, to a
/// fifth at `R` (reaching as far as the rays, the rings filled a slow
/// hit's wide sectors with arcs that curled into rays).
const RING_DECAY: f64 = 0.7;
/// Ring tension against the hoop tension on a ray (at 0.5 the arcs
/// between 0.3 and 0.6 R held up to half of those bands' length on the
/// teapot and spot).
const RING_STRENGTH: f64 = 0.4;
/// Where the ring tension rises, in radii: it is `x^2 / (1 + x^2)` of
/// full with `x = d / (0.3 R)`, a tenth at 0.1 R, half at 0.3 R. Rising
/// from the hit, the arcs break the wedges between the rays; at full
/// strength up to the hit, the first rings (0.2 and 0.32 R, closer than
/// a cell) closed into a polygon around it that held up to 12% of the
/// length in one band of 0.05 R, and the star's radial share fell under
/// 0.65 on 3 of 16 seeds (regular and jittered plates).
const RING_INNER: f64 = 0.3;
/// How far a ray may move from even spacing, as a share of the gap.
const RAY_JITTER: f64 = 0.4;
/// Hoop tension between rays, as a share of that on a ray.
const BETWEEN_RAYS: f64 = 0.03;
/// Width of a ray or ring, in cells.
const WIDTH_CELLS: f64 = 1.2;
/// The first ring, in radii, and the ratio of one ring to the next.
const FIRST_RING: f64 = 0.2;
const RING_RATIO: f64 = 1.6;
/// Share of the sectors between rays a ring crosses.
const RING_SECTORS: f64 = 0.5;

/// One impact's load over a mesh's faces.
pub struct Star {
    /// Per face: distance along the surface (infinite where the surface
    /// does not reach), in-plane unit direction away from the hit, and
    /// angle around it.
    faces: Vec<(f64, [f64; 3], f64)>,
    /// The rays' angles and strengths.
    rays: Vec<(f64, f64)>,
    rings: Vec<f64>,
    /// Per sector (between ray `k` and the next): the factor on its rings'
    /// distances, `1.6^(p - 1/2)` for its phase `p`.
    ring_phase: Vec<f64>,
    width: f64,
    radius: f64,
    /// `sqrt(N / LOAD_RAYS)`: the load of this star against the weight's.
    load: f64,
    seed: u64,
}

/// The smallest angle between `a` and `b` (radians, in [0, pi]).
fn angle_between(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d)
}

impl Star {
    /// The load of a hit at `point` (on the surface) with `rays` radial
    /// cracks and reference radius `radius`; `seed` and `index` (which
    /// impact) choose the rays' angles and strengths and the rings'
    /// sectors.
    pub fn new(
        mesh: &SimMesh,
        point: [f64; 3],
        radius: f64,
        rays: u32,
        seed: u64,
        index: u64,
    ) -> Star {
        // The face the hit lands on: the nearest centroid.
        let frames: Vec<_> = mesh.faces().map(|f| face_frame(mesh, f)).collect();
        let hit = frames
            .iter()
            .enumerate()
            .filter_map(|(i, fr)| fr.map(|(c, _)| (v3::norm(v3::sub(c, point)), i)))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .map_or(0, |x| x.1);
        let dist = super::geodesic::distances(mesh, point, hit);
        // A frame in the tangent plane at the hit, for angles.
        let n0 = frames
            .get(hit)
            .copied()
            .flatten()
            .map_or([0.0, 0.0, 1.0], |(_, n)| n);
        let pick = if n0[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let e1 = unit(in_plane(pick, n0)).unwrap_or([1.0, 0.0, 0.0]);
        let e2 = v3::cross(n0, e1);
        let faces = mesh
            .faces()
            .zip(&frames)
            .map(|(f, frame)| {
                let vs = mesh.face_vertices(f);
                let [da, db, dc] = vs.map(|v| dist[v.idx()]);
                let d = (da + db + dc) / 3.0;
                // Degenerate faces carry no stress (the field skips them).
                let Some((centroid, n)) = frame.filter(|_| d.is_finite()) else {
                    return (f64::INFINITY, [0.0; 3], 0.0);
                };
                // The gradient of the distance over the face.
                let [a, b, c] = vs.map(|v| mesh.position(v));
                let g = gradient(v3::sub(b, a), v3::sub(c, a), n, db - da, dc - da);
                let r = v3::sub(centroid, point);
                let away = unit(g).or_else(|| unit(in_plane(r, n))).unwrap_or([0.0; 3]);
                let theta = v3::dot(r, e2).atan2(v3::dot(r, e1));
                (d, away, theta)
            })
            .collect();
        let key = |k: u64| seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ k;
        let unit01 = |k: u64, i: u64| 0.5 * (hash_unit(key(k), i) + 1.0);
        let phase = std::f64::consts::TAU * unit01(0x7261_7973, 0);
        let step = std::f64::consts::TAU / f64::from(rays.max(1));
        let load = (f64::from(rays.max(1)) / LOAD_RAYS).sqrt();
        let rays: Vec<(f64, f64)> = (0..u64::from(rays))
            .map(|i| {
                // Evenly around, each moved by up to a fifth of the gap.
                let jitter = (unit01(0x6A69_7474, i) - 0.5) * RAY_JITTER * step;
                let strength = 0.8 + 0.5 * unit01(0x7374_7267, i);
                (phase + step * i as f64 + jitter, strength)
            })
            .collect();
        // Each sector's phase: the golden ratio's multiples from a seeded
        // start, so no two sectors' arcs lie at one distance.
        let ring_seed = key(0x7269_6e67);
        let start = 0.5 * (hash_unit(ring_seed, 0x7068_6173) + 1.0);
        let ring_phase = (0..rays.len())
            .map(|k| RING_RATIO.powf((start + 0.618_033_988_749_895 * k as f64).fract() - 0.5))
            .collect();
        let mut rings = Vec::new();
        let mut r = FIRST_RING;
        while r < 1.2 {
            rings.push(r * radius);
            r *= RING_RATIO;
        }
        Star {
            faces,
            rays,
            rings,
            ring_phase,
            width: WIDTH_CELLS * mesh.mean_edge_length(),
            radius,
            load,
            seed: ring_seed,
        }
    }

    /// The load on face `f` (normal `n`): zero where the surface from the
    /// hit does not reach.
    pub fn tensor(&self, f: usize, n: [f64; 3]) -> Sym3 {
        let (d, away, theta) = self.faces[f];
        if !d.is_finite() || away == [0.0; 3] {
            return Sym3::ZERO;
        }
        let rho = d / self.radius;
        let hoop_decay = 1.0 / (1.0 + (rho / HOOP_DECAY).powi(4));
        // The rays: the nearest one's profile across it (arc distance).
        let mut on_ray: f64 = 0.0;
        let mut nearest = (f64::INFINITY, 0usize);
        for (k, &(angle, strength)) in self.rays.iter().enumerate() {
            let gap = angle_between(theta, angle);
            if gap < nearest.0 {
                nearest = (gap, k);
            }
            let arc = d * gap.min(std::f64::consts::FRAC_PI_2);
            on_ray = on_ray.max(strength * (-(arc / self.width).powi(2)).exp());
        }
        let hoop = self.load * hoop_decay * (BETWEEN_RAYS + (1.0 - BETWEEN_RAYS) * on_ray);
        // The rings, each across a seeded share of the sectors: the
        // sector is the one between the nearest ray and its neighbour on
        // this side.
        let sector = {
            let (_, k) = nearest;
            let side = (theta - self.rays[k].0).sin() >= 0.0;
            let n = self.rays.len();
            if side {
                k
            } else {
                (k + n - 1) % n
            }
        };
        let phase = self.ring_phase[sector];
        let mut ring: f64 = 0.0;
        for (j, &rj) in self.rings.iter().enumerate() {
            let h = hash_unit(self.seed, (j * 1024 + sector) as u64);
            if 0.5 * (h + 1.0) > RING_SECTORS {
                continue;
            }
            let rj = rj * phase;
            ring = ring.max((-((d - rj) / self.width).powi(2)).exp());
        }
        let ring_decay = 1.0 / (1.0 + (rho / RING_DECAY).powi(4));
        let rise = (rho / RING_INNER).powi(2);
        let ring_rise = rise / (1.0 + rise);
        let radial = self.load * RING_STRENGTH * ring_decay * ring_rise * ring;
        let hoop_dir = v3::cross(n, away);
        Sym3::outer(hoop_dir) * hoop + Sym3::outer(away) * radial
    }
}

/// The gradient in the face's plane of a linear function rising by `gb`
/// along `ab` and `gc` along `ac` (normal `n`).
fn gradient(ab: [f64; 3], ac: [f64; 3], n: [f64; 3], gb: f64, gc: f64) -> [f64; 3] {
    // g = (gb (ac x n) + gc (n x ab)) / (2 area), with (ab x ac) . n = 2 area.
    let twice_area = v3::dot(v3::cross(ab, ac), n);
    if twice_area.abs() < 1e-300 {
        return [0.0; 3];
    }
    let g = v3::add(
        v3::scale(v3::cross(ac, n), gb),
        v3::scale(v3::cross(n, ab), gc),
    );
    v3::scale(g, 1.0 / twice_area)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_grow_as_the_square_root_of_the_speed() {
        assert_eq!(rays_for_speed(1.0), 4);
        assert_eq!(rays_for_speed(4.0), 8);
        assert_eq!(rays_for_speed(16.0), 16);
        assert_eq!(rays_for_speed(0.0), MIN_RAYS);
        assert_eq!(rays_for_speed(1e9), MAX_RAYS);
    }

    #[test]
    fn a_star_of_more_rays_carries_more_load() {
        let (mesh, _) = crate::mesh::shapes::build(&crate::mesh::shapes::grid_input(40, 40));
        let peak = |rays| {
            let star = Star::new(&mesh, [20.0, 20.0, 0.0], 12.0, rays, 1, 0);
            (0..mesh.n_faces())
                .map(|f| star.tensor(f, [0.0, 0.0, 1.0]).frobenius_sq().sqrt())
                .fold(0.0, f64::max)
        };
        let (eight, thirty_two) = (peak(8), peak(32));
        // The weight is the load of eight rays' star (up to a ray's
        // strength, 0.8 to 1.3); four times the rays, twice the load.
        assert!((0.8..=1.3).contains(&eight), "{eight}");
        assert!(
            (thirty_two / eight - 2.0).abs() < 0.35,
            "{eight} {thirty_two}"
        );
    }

    #[test]
    fn the_gradient_of_a_linear_function() {
        let n = [0.0, 0.0, 1.0];
        // f = 2x + 3y on a right triangle.
        let g = gradient([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], n, 2.0, 3.0);
        assert!(
            (g[0] - 2.0).abs() < 1e-12 && (g[1] - 3.0).abs() < 1e-12,
            "{g:?}"
        );
        let g = gradient(
            [2.0, 1.0, 0.0],
            [-1.0, 3.0, 0.0],
            n,
            2.0 * 2.0 + 3.0,
            -2.0 + 9.0,
        );
        assert!(
            (g[0] - 2.0).abs() < 1e-12 && (g[1] - 3.0).abs() < 1e-12,
            "{g:?}"
        );
    }
}
