//! Which triangle, and where in it, each texel of a square map shows: the
//! triangles drawn in their UV space (texel centres inside a triangle), then
//! grown outwards by a band of texels so that filtering across a UV island's
//! border never reads background.

use rayon::prelude::*;

/// No triangle.
pub const EMPTY: u32 = u32::MAX;

/// What a texel shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texel {
    /// The triangle, or [`EMPTY`].
    pub tri: u32,
    /// Barycentric weights of the triangle's second and third corners (the
    /// first has `1 - b[0] - b[1]`); inside the triangle, also for texels of
    /// the dilation band (their point is the nearest point of the triangle).
    pub bary: [f32; 2],
    /// Whether the texel's centre lies inside its triangle (else it is in the
    /// dilation band).
    pub inside: bool,
}

impl Texel {
    const NONE: Texel = Texel {
        tri: EMPTY,
        bary: [0.0; 2],
        inside: false,
    };

    /// Whether the centre lies strictly inside the triangle.
    fn bary_interior(&self) -> bool {
        self.weights().iter().all(|&w| w > 1e-6)
    }

    /// The barycentric weights of the three corners.
    pub fn weights(&self) -> [f64; 3] {
        [
            1.0 - f64::from(self.bary[0]) - f64::from(self.bary[1]),
            f64::from(self.bary[0]),
            f64::from(self.bary[1]),
        ]
    }
}

/// A map's texels.
#[derive(Clone, Debug)]
pub struct Raster {
    /// Width and height in texels.
    pub size: u32,
    /// Row-major texels, row 0 at `v = 0` (the image's top, as in glTF).
    pub texels: Vec<Texel>,
    /// Texels whose centre lies inside a triangle.
    pub covered: usize,
    /// Covered texels whose centre lies strictly inside two or more
    /// triangles: the UVs overlap (mirrored or stacked islands) or tile.
    pub overlapping: usize,
    /// Texels the dilation band filled.
    pub dilated: usize,
}

impl Raster {
    /// Share of the covered texels that more than one triangle covers.
    pub fn overlap_fraction(&self) -> f64 {
        self.overlapping as f64 / self.covered.max(1) as f64
    }
}

/// Most texels one triangle may visit: a triangle whose UVs span more than
/// a few copies of the map (a tiling UV set) is counted as overlapping
/// instead of drawn.
const MAX_TILES: f64 = 4.0;

/// Draw `triangles` (corner indices into `uvs`) into a `size` x `size` map:
/// a texel shows the first triangle, in index order, whose UV triangle
/// holds its centre; UVs outside [0, 1] wrap (REPEAT). Then `dilate` rings
/// of empty texels take the triangle of a neighbour (edge neighbours before
/// diagonal ones, in a fixed order), at the point of that triangle nearest
/// to their centre. Triangles with no UV area draw nothing.
pub fn rasterize(uvs: &[[f64; 2]], triangles: &[[u32; 3]], size: u32, dilate: u32) -> Raster {
    let n = size as usize;
    let s = f64::from(size);
    let mut texels = vec![Texel::NONE; n * n];
    let mut covered = 0;
    let mut overlapping = 0;
    let mut doubled = vec![false; n * n];
    for (t, tri) in triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|i| {
            let uv = uvs[i as usize];
            [uv[0] * s, uv[1] * s]
        });
        let area = cross2(sub2(b, a), sub2(c, a));
        if area.is_nan() || area.abs() <= 1e-12 {
            continue;
        }
        let lo = [a[0].min(b[0]).min(c[0]), a[1].min(b[1]).min(c[1])];
        let hi = [a[0].max(b[0]).max(c[0]), a[1].max(b[1]).max(c[1])];
        if (hi[0] - lo[0]) * (hi[1] - lo[1]) > MAX_TILES * s * s {
            overlapping += 1;
            continue;
        }
        let (x0, x1) = ((lo[0] - 0.5).ceil() as i64, (hi[0] - 0.5).floor() as i64);
        let (y0, y1) = ((lo[1] - 0.5).ceil() as i64, (hi[1] - 0.5).floor() as i64);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                let w1 = cross2(sub2(p, a), sub2(c, a)) / area;
                let w2 = cross2(sub2(b, a), sub2(p, a)) / area;
                let w0 = 1.0 - w1 - w2;
                let eps = -1e-9;
                if w0 < eps || w1 < eps || w2 < eps {
                    continue;
                }
                let k = y.rem_euclid(n as i64) as usize * n + x.rem_euclid(n as i64) as usize;
                let texel = &mut texels[k];
                if texel.tri == EMPTY {
                    *texel = Texel {
                        tri: t as u32,
                        bary: [w1 as f32, w2 as f32],
                        inside: true,
                    };
                    covered += 1;
                } else if w0.min(w1).min(w2) > 1e-6 && texel.bary_interior() && !doubled[k] {
                    doubled[k] = true;
                    overlapping += 1;
                }
            }
        }
    }
    // A triangle smaller than a texel may hold no texel centre; alone in
    // its island (a tiny chart of an atlas) it would then show only what
    // the dilation brings from a neighbouring island. It takes the empty
    // texel under its centre, as a dilated texel (its centroid).
    let mut drew = vec![false; triangles.len()];
    for t in &texels {
        if t.tri != EMPTY {
            drew[t.tri as usize] = true;
        }
    }
    for (t, tri) in triangles.iter().enumerate() {
        if drew[t] {
            continue;
        }
        let [a, b, c] = tri.map(|i| uvs[i as usize]);
        let area = cross2(sub2(b, a), sub2(c, a));
        if area.is_nan() || area.abs() <= 1e-12 / (s * s) {
            continue;
        }
        let centre = [0, 1].map(|k| (a[k] + b[k] + c[k]) / 3.0 * s);
        if !(centre[0].is_finite() && centre[1].is_finite()) {
            continue;
        }
        let (x, y) = (centre[0].floor() as i64, centre[1].floor() as i64);
        let k = y.rem_euclid(n as i64) as usize * n + x.rem_euclid(n as i64) as usize;
        if texels[k].tri == EMPTY {
            texels[k] = Texel {
                tri: t as u32,
                bary: [1.0 / 3.0, 1.0 / 3.0],
                inside: false,
            };
        }
    }
    let dilated = grow(&mut texels, n, dilate, uvs, triangles);
    Raster {
        size,
        texels,
        covered,
        overlapping,
        dilated,
    }
}

/// Neighbour offsets: edge neighbours first, then diagonals.
const NEIGHBOURS: [(i64, i64); 8] = [
    (-1, 0),
    (1, 0),
    (0, -1),
    (0, 1),
    (-1, -1),
    (1, -1),
    (-1, 1),
    (1, 1),
];

/// `rings` passes of dilation; returns the texels filled. Each pass looks
/// only at the empty neighbours of the texels the pass before filled (the
/// first: of every filled texel), and reads the state before the pass, so
/// the result does not depend on the order of work.
fn grow(texels: &mut [Texel], n: usize, rings: u32, uvs: &[[f64; 2]], tris: &[[u32; 3]]) -> usize {
    let s = n as f64;
    let ni = n as i64;
    let neighbour = |k: usize, (dx, dy): (i64, i64)| {
        let (x, y) = ((k % n) as i64, (k / n) as i64);
        (y + dy).rem_euclid(ni) as usize * n + (x + dx).rem_euclid(ni) as usize
    };
    // The first ring: every empty texel next to a filled one.
    let mut next: Vec<usize> = (0..texels.len())
        .into_par_iter()
        .filter(|&k| {
            texels[k].tri == EMPTY
                && NEIGHBOURS
                    .iter()
                    .any(|&d| texels[neighbour(k, d)].tri != EMPTY)
        })
        .collect();
    let mut filled = 0;
    for ring in 0..rings {
        if ring > 0 {
            // The empty neighbours of the ring before.
            let front = std::mem::take(&mut next);
            next = front
                .par_iter()
                .flat_map_iter(|&k| {
                    NEIGHBOURS
                        .iter()
                        .map(move |&d| neighbour(k, d))
                        .filter(|&m| texels[m].tri == EMPTY)
                })
                .collect();
            next.par_sort_unstable();
            next.dedup();
        }
        if next.is_empty() {
            break;
        }
        let grown: Vec<Texel> = next
            .par_iter()
            .map(|&k| {
                let t = NEIGHBOURS
                    .iter()
                    .map(|&d| texels[neighbour(k, d)].tri)
                    .find(|&t| t != EMPTY)
                    .unwrap_or(EMPTY);
                let [a, b, c] = tris[t as usize].map(|i| {
                    let uv = uvs[i as usize];
                    [uv[0] * s, uv[1] * s]
                });
                // The texel's centre in the tile of the triangle.
                let (x, y) = ((k % n) as f64 + 0.5, (k / n) as f64 + 0.5);
                let centroid = [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0];
                let p = [
                    x + ((centroid[0] - x) / s).round() * s,
                    y + ((centroid[1] - y) / s).round() * s,
                ];
                Texel {
                    tri: t,
                    bary: nearest_in_triangle(p, a, b, c).map(|w| w as f32),
                    inside: false,
                }
            })
            .collect();
        for (&k, t) in next.iter().zip(grown) {
            texels[k] = t;
        }
        filled += next.len();
    }
    filled
}

/// Barycentric weights (of `b` and `c`) of the point of triangle `abc`
/// nearest to `p`.
pub fn nearest_in_triangle(p: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> [f64; 2] {
    let area = cross2(sub2(b, a), sub2(c, a));
    if area.abs() > 1e-300 {
        let w1 = cross2(sub2(p, a), sub2(c, a)) / area;
        let w2 = cross2(sub2(b, a), sub2(p, a)) / area;
        if w1 >= 0.0 && w2 >= 0.0 && w1 + w2 <= 1.0 {
            return [w1, w2];
        }
    }
    // On an edge: the nearest of the three edges' nearest points.
    let on = |u: [f64; 2], v: [f64; 2]| {
        let d = sub2(v, u);
        let l = d[0] * d[0] + d[1] * d[1];
        let t = if l > 0.0 {
            ((p[0] - u[0]) * d[0] + (p[1] - u[1]) * d[1]) / l
        } else {
            0.0
        };
        let t = t.clamp(0.0, 1.0);
        let q = [u[0] + t * d[0], u[1] + t * d[1]];
        ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2), t)
    };
    let (dab, tab) = on(a, b);
    let (dbc, tbc) = on(b, c);
    let (dca, tca) = on(c, a);
    if dab <= dbc && dab <= dca {
        [tab, 0.0]
    } else if dbc <= dca {
        [1.0 - tbc, tbc]
    } else {
        [0.0, 1.0 - tca]
    }
}

fn sub2(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles covering the left half of the map.
    fn half() -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
        (
            vec![[0.0, 0.0], [0.5, 0.0], [0.5, 1.0], [0.0, 1.0]],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn covers_the_islands_and_a_band_around_them() {
        let (uv, tris) = half();
        let r = rasterize(&uv, &tris, 16, 2);
        assert_eq!(r.covered, 8 * 16, "the left half's texel centres");
        assert_eq!(r.overlapping, 0);
        // Two rings on each side of the half (the map wraps).
        assert_eq!(r.dilated, 4 * 16);
        for y in 0..16 {
            for x in 0..16 {
                let t = r.texels[y * 16 + x];
                let band = matches!(x, 8 | 9 | 14 | 15);
                assert_eq!(t.tri != EMPTY, x < 8 || band, "texel {x},{y}");
                assert_eq!(t.inside, x < 8);
                assert!(t.weights().iter().all(|&w| w >= -1e-12), "{t:?}");
            }
        }
    }

    #[test]
    fn overlapping_uvs_are_counted() {
        let (mut uv, mut tris) = half();
        uv.extend([[0.0, 0.0], [0.5, 0.0], [0.5, 1.0]]);
        tris.push([4, 5, 6]);
        let r = rasterize(&uv, &tris, 16, 0);
        assert!(r.overlap_fraction() > 0.4, "{}", r.overlap_fraction());
        assert_eq!(r.covered, 8 * 16);
    }

    #[test]
    fn band_texels_take_the_nearest_point() {
        let b = nearest_in_triangle([2.0, -1.0], [0.0, 0.0], [4.0, 0.0], [0.0, 4.0]);
        assert!((b[0] - 0.5).abs() < 1e-12 && b[1].abs() < 1e-12, "{b:?}");
        let b = nearest_in_triangle([3.0, 3.0], [0.0, 0.0], [4.0, 0.0], [0.0, 4.0]);
        assert!((b[0] - 0.5).abs() < 1e-12 && (b[1] - 0.5).abs() < 1e-12);
    }
}
