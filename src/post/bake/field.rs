//! The crack network seen from each texel: how much of the texel a crack
//! covers, how much its shadow does, and the tilt of a V-shaped groove's
//! wall, all measured in world units on the surface. A texel's world
//! footprint comes from its triangle (world area over texel area), so a
//! crack is as wide on a stretched UV island as on a tight one, and both
//! sides of a UV seam see the same crack.

use super::raster::{Raster, EMPTY};
use crate::math::v3;
use rayon::prelude::*;

/// The mesh a map is baked for: per vertex, in one frame.
#[derive(Clone, Copy, Debug)]
pub struct Surface<'a> {
    /// Positions.
    pub positions: &'a [[f64; 3]],
    /// Unit normals.
    pub normals: &'a [[f64; 3]],
    /// Tangents (xyz and the bitangent sign w), as the output carries them.
    pub tangents: &'a [[f64; 4]],
    /// The UV set the map is baked in.
    pub uvs: &'a [[f64; 2]],
    /// Triangles.
    pub triangles: &'a [[u32; 3]],
}

/// The crack's cross-section.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    /// Half the crack's width, in world units.
    pub half_width: f64,
    /// Depth over half-width of the V groove (the walls' slope; 1: 45 degrees).
    pub slope: f64,
    /// The shadow band's half-width over the crack's (>= 1).
    pub shadow: f64,
}

/// The cracks: segments in the surface's frame, and per segment a width
/// factor in [0, 1] (empty: all 1).
#[derive(Clone, Copy, Debug)]
pub struct Cracks<'a> {
    /// Segment end points.
    pub segments: &'a [[[f64; 3]; 2]],
    /// Width factor per segment (fading with age), or empty.
    pub widths: &'a [f64],
}

/// What one texel shows of the cracks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrackTexel {
    /// Share of the texel inside a crack, in [0, 1] (box-filtered).
    pub coverage: f32,
    /// Share of the texel inside the shadow band, in [0, 1].
    pub shadow: f32,
    /// The groove's normal in the texel's tangent space (x along the
    /// tangent, y along the bitangent, z along the normal).
    pub normal: [f32; 3],
}

impl CrackTexel {
    /// No crack.
    pub const NONE: CrackTexel = CrackTexel {
        coverage: 0.0,
        shadow: 0.0,
        normal: [0.0, 0.0, 1.0],
    };
}

/// A triangle's texel footprint longer than this many crack widths makes
/// no difference to what it shows; the search radius stops there.
const MAX_FOOTPRINT: f64 = 8.0;

/// Every texel's view of the cracks (row-major as `raster`).
pub fn crack_texels(
    surface: &Surface,
    raster: &Raster,
    cracks: &Cracks,
    profile: &Profile,
) -> Vec<CrackTexel> {
    let hw = profile.half_width;
    let mut out = vec![CrackTexel::NONE; raster.texels.len()];
    if cracks.segments.is_empty() || hw.is_nan() || hw <= 0.0 {
        return out;
    }
    let s = f64::from(raster.size);
    // World length of one texel, per triangle.
    let footprint: Vec<f64> = surface
        .triangles
        .par_iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| surface.positions[i as usize]);
            let world = v3::norm(v3::cross(v3::sub(b, a), v3::sub(c, a)));
            let [p, q, r] = t.map(|i| surface.uvs[i as usize]);
            let uv = ((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])).abs() * s * s;
            if uv > 0.0 {
                (world / uv).sqrt()
            } else {
                MAX_FOOTPRINT * 2.0 * hw
            }
        })
        .collect();
    // How far a crack can reach into a texel of footprint `f`: the shadow's
    // half-width and half the footprint.
    let reach_of = |f: f64| hw * profile.shadow.max(1.0) + 0.5 * f.min(MAX_FOOTPRINT * hw);
    let reach = footprint.iter().copied().map(reach_of).fold(0.0, f64::max);
    let grid = Grid::new(cracks.segments, reach);
    // Texels by triangle (counting sort), so a triangle's candidate
    // segments are found once.
    let n_tris = surface.triangles.len();
    let mut start = vec![0usize; n_tris + 1];
    for t in &raster.texels {
        if t.tri != EMPTY {
            start[t.tri as usize + 1] += 1;
        }
    }
    for i in 0..n_tris {
        start[i + 1] += start[i];
    }
    let mut order = vec![0u32; start[n_tris]];
    let mut next = start.clone();
    for (k, t) in raster.texels.iter().enumerate() {
        if t.tri != EMPTY {
            order[next[t.tri as usize]] = k as u32;
            next[t.tri as usize] += 1;
        }
    }
    let results: Vec<Vec<(u32, CrackTexel)>> = (0..n_tris)
        .into_par_iter()
        .with_min_len(256)
        .map(|t| {
            let texels = &order[start[t]..start[t + 1]];
            if texels.is_empty() {
                return Vec::new();
            }
            let corners = surface.triangles[t].map(|i| i as usize);
            let pts = corners.map(|i| surface.positions[i]);
            let r = reach_of(footprint[t]);
            let f = footprint[t].min(MAX_FOOTPRINT * hw);
            if texels.len() <= TILE * TILE {
                let candidates = near(&grid, &pts, r, reach, cracks);
                if candidates.is_empty() {
                    return Vec::new();
                }
                return texels
                    .iter()
                    .map(|&k| {
                        let frame =
                            Frame::at(surface, corners, raster.texels[k as usize].weights());
                        (k, frame.view(cracks, &candidates, profile, f))
                    })
                    .collect();
            }
            // A triangle of many texels (an input's large faces): its
            // texels in tiles of TILE x TILE, each with the segments near
            // its own points, so the work stays with the texels near a crack.
            let n = raster.size as usize;
            let mut tiles: Vec<(usize, u32)> = texels
                .iter()
                .map(|&k| {
                    let (x, y) = (k as usize % n, k as usize / n);
                    ((y / TILE) * n + x / TILE, k)
                })
                .collect();
            tiles.sort_unstable();
            let mut out = Vec::new();
            for tile in tiles.chunk_by(|a, b| a.0 == b.0) {
                let frames: Vec<(u32, Frame)> = tile
                    .iter()
                    .map(|&(_, k)| {
                        (
                            k,
                            Frame::at(surface, corners, raster.texels[k as usize].weights()),
                        )
                    })
                    .collect();
                let points: Vec<[f64; 3]> = frames.iter().map(|(_, fr)| fr.p).collect();
                let candidates = near(&grid, &points, r, reach, cracks);
                if candidates.is_empty() {
                    continue;
                }
                out.extend(
                    frames
                        .into_iter()
                        .map(|(k, fr)| (k, fr.view(cracks, &candidates, profile, f))),
                );
            }
            out
        })
        .collect();
    for list in results {
        for (k, c) in list {
            out[k as usize] = c;
        }
    }
    out
}

/// Texels a side of the tiles a large triangle's texels are taken in.
const TILE: usize = 8;

/// The segments that come within `r` of the points' bounding sphere, from
/// the grid (whose pieces are at most `reach` long).
fn near(grid: &Grid, points: &[[f64; 3]], r: f64, reach: f64, cracks: &Cracks) -> Vec<u32> {
    let (lo, hi) = points.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            (
                std::array::from_fn(|k| lo[k].min(p[k])),
                std::array::from_fn(|k| hi[k].max(p[k])),
            )
        },
    );
    let mut candidates = grid.near_box(lo, hi, r, reach);
    let centre = v3::scale(v3::add(lo, hi), 0.5);
    let radius = 0.5 * v3::norm(v3::sub(hi, lo));
    candidates.retain(|&s| {
        let [a, b] = cracks.segments[s as usize];
        v3::norm(v3::sub(nearest_on_segment(centre, a, b), centre)) <= radius + r
    });
    candidates
}

/// A texel's point and tangent frame.
struct Frame {
    p: [f64; 3],
    n: [f64; 3],
    t: [f64; 3],
    b: [f64; 3],
}

impl Frame {
    fn at(surface: &Surface, corners: [usize; 3], w: [f64; 3]) -> Frame {
        let mix = |f: &dyn Fn(usize) -> [f64; 3]| {
            let mut acc = [0.0; 3];
            for k in 0..3 {
                acc = v3::add(acc, v3::scale(f(corners[k]), w[k]));
            }
            acc
        };
        let p = mix(&|i| surface.positions[i]);
        let n = v3::unit(mix(&|i| surface.normals[i])).unwrap_or([0.0, 0.0, 1.0]);
        let t = mix(&|i| {
            let t = surface.tangents[i];
            [t[0], t[1], t[2]]
        });
        let t = v3::unit(v3::sub(t, v3::scale(n, v3::dot(t, n))))
            .unwrap_or_else(|| v3::plane_basis(n)[0]);
        let sign = if surface.tangents[corners[0]][3] < 0.0 {
            -1.0
        } else {
            1.0
        };
        let b = v3::scale(v3::cross(n, t), sign);
        Frame { p, n, t, b }
    }

    /// The crack that covers the texel most (ties: the nearer, then the
    /// lower index), with its groove's tilt.
    fn view(&self, cracks: &Cracks, candidates: &[u32], profile: &Profile, f: f64) -> CrackTexel {
        let mut best: Option<(f64, f64, [f64; 3], f64)> = None; // (cover, dist, dir, hw)
        let mut shadow = 0.0f64;
        for &s in candidates {
            let [a, b] = cracks.segments[s as usize];
            let scale = cracks.widths.get(s as usize).copied().unwrap_or(1.0);
            let hw = profile.half_width * scale.clamp(0.0, 1.0);
            if hw <= 0.0 {
                continue;
            }
            let q = nearest_on_segment(self.p, a, b);
            let d_vec = v3::sub(self.p, q);
            let d = v3::norm(d_vec);
            // A crack across a thin sheet (its back face) is not this
            // side's: the way to it runs along the normal.
            if d > 0.25 * f.min(hw) && v3::dot(d_vec, self.n).abs() > 0.7 * d {
                continue;
            }
            shadow = shadow.max(box_cover(d, hw * profile.shadow.max(1.0), f));
            let cover = box_cover(d, hw, f);
            if cover <= 0.0 {
                continue;
            }
            let better = match best {
                None => true,
                Some((c, dist, ..)) => cover > c || (cover == c && d < dist),
            };
            if better {
                best = Some((cover, d, d_vec, hw));
            }
        }
        let Some((cover, d, d_vec, hw)) = best else {
            return CrackTexel {
                shadow: shadow as f32,
                ..CrackTexel::NONE
            };
        };
        // The groove: height -slope * (hw - |x|) for |x| < hw across the
        // crack; its mean slope over the texel, pointing away from the crack.
        let lo = d - f / 2.0;
        let hi = d + f / 2.0;
        let inside = |a: f64, b: f64| (hi.min(b) - lo.max(a)).max(0.0);
        let g = profile.slope * (inside(0.0, hw) - inside(-hw, 0.0)) / f.max(1e-300);
        let u = v3::sub(d_vec, v3::scale(self.n, v3::dot(d_vec, self.n)));
        let normal = match v3::unit(u) {
            Some(u) if d > 0.0 => {
                let x = -g * v3::dot(u, self.t);
                let y = -g * v3::dot(u, self.b);
                let l = (x * x + y * y + 1.0).sqrt();
                [(x / l) as f32, (y / l) as f32, (1.0 / l) as f32]
            }
            _ => [0.0, 0.0, 1.0],
        };
        CrackTexel {
            coverage: cover as f32,
            shadow: shadow.max(cover) as f32,
            normal,
        }
    }
}

/// Share of the interval `[d - f/2, d + f/2]` (a texel's footprint at
/// distance `d` from the crack's middle) inside `[-hw, hw]`.
fn box_cover(d: f64, hw: f64, f: f64) -> f64 {
    if f <= 0.0 {
        return if d <= hw { 1.0 } else { 0.0 };
    }
    let lo = (d - f / 2.0).max(-hw);
    let hi = (d + f / 2.0).min(hw);
    ((hi - lo) / f).clamp(0.0, 1.0)
}

fn nearest_on_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let ab = v3::sub(b, a);
    let l = v3::dot(ab, ab);
    if l <= 0.0 {
        return a;
    }
    let t = (v3::dot(v3::sub(p, a), ab) / l).clamp(0.0, 1.0);
    v3::add(a, v3::scale(ab, t))
}

/// Segments by the cells their pieces' midpoints fall in.
struct Grid {
    cell: f64,
    /// (cell, segment), sorted.
    entries: Vec<([i64; 3], u32)>,
}

impl Grid {
    /// Each segment cut into pieces no longer than `reach`, filed by the
    /// cell (of side `2 reach`) of each piece's midpoint.
    fn new(segments: &[[[f64; 3]; 2]], reach: f64) -> Grid {
        let cell = 2.0 * reach;
        let mut entries: Vec<([i64; 3], u32)> = segments
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, &[a, b])| {
                let pieces = (v3::norm(v3::sub(b, a)) / reach).ceil().clamp(1.0, 1e6) as usize;
                let mut cells: Vec<([i64; 3], u32)> = (0..pieces)
                    .map(|k| {
                        let t = (k as f64 + 0.5) / pieces as f64;
                        let m = v3::add(a, v3::scale(v3::sub(b, a), t));
                        (m.map(|x| (x / cell).floor() as i64), i as u32)
                    })
                    .collect();
                cells.dedup();
                cells.into_iter()
            })
            .collect();
        entries.par_sort_unstable();
        entries.dedup();
        Grid { cell, entries }
    }

    /// Segments with a piece in a cell near the triangle: every segment
    /// within `reach` of it (the grid's pieces are at most `piece` long),
    /// sorted, without repeats.
    #[cfg(test)]
    fn near_triangle(&self, corners: [[f64; 3]; 3], reach: f64, piece: f64) -> Vec<u32> {
        let lo =
            std::array::from_fn(|k| corners.iter().map(|c| c[k]).fold(f64::INFINITY, f64::min));
        let hi = std::array::from_fn(|k| {
            corners
                .iter()
                .map(|c| c[k])
                .fold(f64::NEG_INFINITY, f64::max)
        });
        self.near_box(lo, hi, reach, piece)
    }

    /// Segments with a piece in a cell near the box `lo..hi`: every segment
    /// within `reach` of it (the grid's pieces are at most `piece` long),
    /// sorted, without repeats.
    fn near_box(&self, lo: [f64; 3], hi: [f64; 3], reach: f64, piece: f64) -> Vec<u32> {
        let margin = reach + 0.5 * piece;
        let lo: [i64; 3] = std::array::from_fn(|k| ((lo[k] - margin) / self.cell).floor() as i64);
        let hi: [i64; 3] = std::array::from_fn(|k| ((hi[k] + margin) / self.cell).floor() as i64);
        let mut out = Vec::new();
        if (0..3).any(|k| hi[k] - lo[k] > 64) {
            // A huge triangle: look at every segment.
            out.extend(self.entries.iter().map(|e| e.1));
        } else {
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        let key = [x, y, z];
                        let from = self.entries.partition_point(|e| e.0 < key);
                        out.extend(
                            self.entries[from..]
                                .iter()
                                .take_while(|e| e.0 == key)
                                .map(|e| e.1),
                        );
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_cover_is_the_footprints_share() {
        assert_eq!(box_cover(0.0, 1.0, 1.0), 1.0);
        assert_eq!(box_cover(3.0, 1.0, 1.0), 0.0);
        assert!((box_cover(1.0, 1.0, 1.0) - 0.5).abs() < 1e-12);
        // A crack a tenth of the texel wide covers a tenth of it.
        assert!((box_cover(0.0, 0.05, 1.0) - 0.1).abs() < 1e-12);
    }

    #[test]
    fn the_grid_finds_every_segment_within_reach() {
        let segs = vec![
            [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]],
            [[5.0, 3.0, 0.0], [5.0, 4.0, 0.0]],
        ];
        let g = Grid::new(&segs, 0.5);
        let tri = [[7.0, 0.4, 0.0], [7.2, 0.4, 0.0], [7.0, 0.45, 0.0]];
        assert_eq!(g.near_triangle(tri, 0.5, 0.5), vec![0]);
        let tri = [[5.0, 2.6, 0.0], [5.2, 2.6, 0.0], [5.0, 2.7, 0.0]];
        assert_eq!(g.near_triangle(tri, 0.5, 0.5), vec![1]);
    }
}
