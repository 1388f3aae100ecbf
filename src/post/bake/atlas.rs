//! An automatic UV atlas for meshes that have no UV set to bake into (or
//! whose UVs overlap): the surface is cut into charts of nearly the same
//! direction, each chart is projected onto the plane across its first
//! triangle's normal, turned to its principal axes, and the charts are
//! packed into the square at one texel density (world units per texel the
//! same everywhere) with a gutter of texels between them.
//!
//! Charts grow across edges of coincident positions, so the two sides of a
//! crack (split vertices at the same place) share a chart and their UVs. A
//! triangle joins a chart when its normal is within [`MAX_ANGLE_COS`] of
//! the chart's first normal: projecting then never flips a triangle and
//! stretches it at most `1 / MAX_ANGLE_COS` times. Deterministic and
//! linear in the triangle count (apart from sorting).

use crate::geometry::adjacency::{neighbours, weld};
use crate::math::v3;
use std::collections::VecDeque;

/// Cosine of the largest angle between a chart's triangles and its first.
pub const MAX_ANGLE_COS: f64 = 0.7;

/// An atlas: a UV per triangle corner (corners in triangle order).
#[derive(Clone, Debug, PartialEq)]
pub struct Atlas {
    /// UV of each corner, in [0, 1].
    pub uvs: Vec<[f64; 2]>,
    /// Number of charts.
    pub charts: usize,
    /// Texels per world unit.
    pub density: f64,
}

/// Why no atlas could be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AtlasError {
    /// The charts with their gutters do not fit the map at any density.
    #[error("{charts} charts with {padding}-texel gutters do not fit a {size} x {size} map")]
    TooManyCharts {
        /// Charts.
        charts: usize,
        /// Gutter.
        padding: u32,
        /// Map size.
        size: u32,
    },
    /// No triangle has an area.
    #[error("the surface has no area")]
    NoArea,
}

/// Cut `triangles` into charts and pack them into a `size` map with
/// `padding` texels around each chart.
///
/// # Errors
/// [`AtlasError`] when the charts cannot fit or there is no area.
pub fn atlas(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    size: u32,
    padding: u32,
) -> Result<Atlas, AtlasError> {
    let welded = weld(positions);
    let neighbours = neighbours(&welded, triangles);
    let normals: Vec<Option<[f64; 3]>> = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            v3::unit(v3::cross(v3::sub(b, a), v3::sub(c, a)))
        })
        .collect();
    let (chart_of, charts) = grow_charts(&normals, &neighbours);
    // Project each chart.
    let mut corner_xy = vec![[0.0f64; 2]; triangles.len() * 3];
    let mut boxes: Vec<[f64; 4]> = Vec::with_capacity(charts.len());
    for faces in &charts {
        let seed = normals[faces[0] as usize].unwrap_or([0.0, 0.0, 1.0]);
        let [e1, e2] = v3::plane_basis(seed);
        let project = |p: [f64; 3]| [v3::dot(p, e1), v3::dot(p, e2)];
        // Principal axes of the projected corners.
        let pts: Vec<[f64; 2]> = faces
            .iter()
            .flat_map(|&f| triangles[f as usize].map(|i| project(positions[i as usize])))
            .collect();
        let n = pts.len() as f64;
        let m = pts
            .iter()
            .fold([0.0, 0.0], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for p in &pts {
            let (x, y) = (p[0] - m[0], p[1] - m[1]);
            sxx += x * x;
            sxy += x * y;
            syy += y * y;
        }
        let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let (s, c) = angle.sin_cos();
        let mut bx = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for &f in faces {
            for k in 0..3 {
                let p = project(positions[triangles[f as usize][k] as usize]);
                let (x, y) = (p[0] - m[0], p[1] - m[1]);
                let q = [c * x + s * y, -s * x + c * y];
                corner_xy[f as usize * 3 + k] = q;
                bx = [
                    bx[0].min(q[0]),
                    bx[1].min(q[1]),
                    bx[2].max(q[0]),
                    bx[3].max(q[1]),
                ];
            }
        }
        boxes.push(bx);
    }
    let (uvs, density) = place_charts(
        &boxes,
        &chart_of,
        |f, k| corner_xy[f * 3 + k],
        size,
        padding,
    )?;
    Ok(Atlas {
        uvs,
        charts: charts.len(),
        density,
    })
}

/// UVs closer than this are the same (1/10 texel at 8192; the two sides
/// of a crack may round their interpolated UVs differently).
const UV_EQUAL: f64 = 1e-5;

/// Most an island's world-per-UV scale may differ from the whole set's.
const MAX_ISLAND_SCALE: f64 = 4.0;

/// Repack the islands of a UV set that overlaps itself (mirrored or
/// stacked islands) into a `size` map without overlap: each island (the
/// triangles joined across edges of equal positions and equal UVs, with
/// the same UV winding, so a mirrored half is its own island) keeps its
/// shape, orientation and proportions, only moved and scaled, all islands
/// to one world density (texels per world unit, as [`atlas`]). A texture
/// resampled from the old set into the new one is then a scaled copy of
/// each island: its edges fall on the island's seams, as the asset's own
/// texture's did, and a normal map's tangent frame stays as it was. `uvs`
/// per vertex; the density returned is texels per world unit.
///
/// # Errors
/// [`AtlasError`] when the islands cannot fit or have no UV area.
pub fn islands(
    positions: &[[f64; 3]],
    uvs: &[[f64; 2]],
    triangles: &[[u32; 3]],
    size: u32,
    padding: u32,
) -> Result<Atlas, AtlasError> {
    let welded = weld(positions);
    let neighbours = neighbours(&welded, triangles);
    let uv = |i: u32| uvs.get(i as usize).copied().unwrap_or([0.0; 2]);
    let winding: Vec<f64> = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(uv);
            ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).signum()
        })
        .collect();
    // The UV of triangle `f`'s corner at welded vertex `w`.
    let uv_at = |f: usize, w: u32| {
        triangles[f]
            .iter()
            .find(|&&i| welded[i as usize] == w)
            .map(|&i| uv(i))
    };
    // Triangles remeshing folded over in UV space are charts of their own
    // (a fold joined to its neighbours would overlap them).
    let same_uvs = |f: usize, k: usize, g: usize| {
        let t = triangles[f];
        [t[k], t[(k + 1) % 3]].iter().all(|&i| {
            uv_at(g, welded[i as usize]).is_some_and(|q| {
                (q[0] - uv(i)[0]).abs() <= UV_EQUAL && (q[1] - uv(i)[1]).abs() <= UV_EQUAL
            })
        })
    };
    let joins = |f: usize, k: usize, g: usize| winding[f] * winding[g] >= 0.0 && same_uvs(f, k, g);
    let (chart_of, charts) = flood(&neighbours, |_, f, k, g| joins(f, k, g));
    // Each island at one world density: its UVs scaled by its own world
    // length per UV length (so a crack is as many texels wide on every
    // island), never turned.
    // An island whose UVs are squeezed far below the others' (a sliver,
    // a collapsed strip) keeps within MAX_ISLAND_SCALE of the whole set's
    // ratio, so it cannot take the map.
    let areas: Vec<(f64, f64)> = charts
        .iter()
        .map(|faces| {
            let (mut world, mut flat) = (0.0, 0.0);
            for &f in faces {
                let t = triangles[f as usize];
                let [a, b, c] = t.map(|i| positions[i as usize]);
                world += v3::norm(v3::cross(v3::sub(b, a), v3::sub(c, a)));
                let [p, q, r] = t.map(uv);
                flat += ((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])).abs();
            }
            (world, flat)
        })
        .collect();
    let total = areas
        .iter()
        .fold((0.0, 0.0), |acc, a| (acc.0 + a.0, acc.1 + a.1));
    let overall = (total.0 / total.1).sqrt();
    let overall = if overall.is_finite() && overall > 0.0 {
        overall
    } else {
        1.0
    };
    let scale: Vec<f64> = areas
        .iter()
        .map(|&(world, flat)| {
            let k = (world / flat).sqrt();
            if k.is_finite() && k > 0.0 {
                k.clamp(overall / MAX_ISLAND_SCALE, overall * MAX_ISLAND_SCALE)
            } else {
                overall
            }
        })
        .collect();
    let corner = |f: usize, k: usize| {
        let q = uv(triangles[f][k]);
        let c = scale[chart_of[f] as usize];
        [q[0] * c, q[1] * c]
    };
    let empty = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut boxes = vec![empty; charts.len()];
    for f in 0..triangles.len() {
        let b = &mut boxes[chart_of[f] as usize];
        for k in 0..3 {
            let q = corner(f, k);
            *b = [
                b[0].min(q[0]),
                b[1].min(q[1]),
                b[2].max(q[0]),
                b[3].max(q[1]),
            ];
        }
    }
    if !boxes.iter().flatten().all(|x| x.is_finite()) {
        return Err(AtlasError::NoArea);
    }
    let (out, density) = place_charts(&boxes, &chart_of, corner, size, padding)?;
    Ok(Atlas {
        uvs: out,
        charts: boxes.len(),
        density,
    })
}

/// Each triangle's corners (`corner(f, k)`, in its chart's plane) placed
/// in the `size` map: the charts' boxes (`[min x, min y, max x, max y]`)
/// packed at one density with `padding` texels around each. Returns a UV
/// per corner and the density.
fn place_charts(
    boxes: &[[f64; 4]],
    chart_of: &[u32],
    corner: impl Fn(usize, usize) -> [f64; 2],
    size: u32,
    padding: u32,
) -> Result<(Vec<[f64; 2]>, f64), AtlasError> {
    let dims: Vec<[f64; 2]> = boxes.iter().map(|b| [b[2] - b[0], b[3] - b[1]]).collect();
    let (density, places) = pack(&dims, size, padding).ok_or(AtlasError::TooManyCharts {
        charts: boxes.len(),
        padding,
        size,
    })?;
    if !(density.is_finite() && density > 0.0) {
        return Err(AtlasError::NoArea);
    }
    let s = f64::from(size);
    let mut uvs = vec![[0.0; 2]; chart_of.len() * 3];
    for (f, &ch) in chart_of.iter().enumerate() {
        let b = boxes[ch as usize];
        let at = places[ch as usize];
        for k in 0..3 {
            let q = corner(f, k);
            uvs[f * 3 + k] = [
                (at[0] + (q[0] - b[0]) * density) / s,
                (at[1] + (q[1] - b[1]) * density) / s,
            ];
        }
    }
    Ok((uvs, density))
}

/// Charts grown breadth-first from the lowest unassigned triangle; returns
/// each triangle's chart and each chart's triangles (first: the seed).
fn grow_charts(normals: &[Option<[f64; 3]>], neighbours: &[[u32; 3]]) -> (Vec<u32>, Vec<Vec<u32>>) {
    flood(neighbours, |seed, _, _, g| {
        match (normals[seed], normals[g]) {
            (Some(d), Some(n)) => v3::dot(d, n) >= MAX_ANGLE_COS,
            // Triangles without area go with a neighbour.
            (_, None) => true,
            (None, Some(_)) => false,
        }
    })
}

/// Triangles grouped breadth-first from the lowest unassigned one (the
/// seed): a neighbour `g` across edge `k` of `f` joins when `joins(seed,
/// f, k, g)`. Returns each triangle's group and each group's triangles.
fn flood(
    neighbours: &[[u32; 3]],
    joins: impl Fn(usize, usize, usize, usize) -> bool,
) -> (Vec<u32>, Vec<Vec<u32>>) {
    let mut chart_of = vec![u32::MAX; neighbours.len()];
    let mut charts: Vec<Vec<u32>> = Vec::new();
    let mut queue = VecDeque::new();
    for seed in 0..neighbours.len() {
        if chart_of[seed] != u32::MAX {
            continue;
        }
        let id = charts.len() as u32;
        chart_of[seed] = id;
        let mut faces = vec![seed as u32];
        queue.push_back(seed);
        while let Some(f) = queue.pop_front() {
            for (k, &g) in neighbours[f].iter().enumerate() {
                if g == u32::MAX
                    || chart_of[g as usize] != u32::MAX
                    || !joins(seed, f, k, g as usize)
                {
                    continue;
                }
                chart_of[g as usize] = id;
                faces.push(g);
                queue.push_back(g as usize);
            }
        }
        charts.push(faces);
    }
    (chart_of, charts)
}

/// Shelf-pack boxes of world size `dims` into a `size` square at the
/// highest density (texels per world unit) that fits, with `padding`
/// texels around each. Returns the density and each box's corner (texels).
fn pack(dims: &[[f64; 2]], size: u32, padding: u32) -> Option<(f64, Vec<[f64; 2]>)> {
    let s = f64::from(size);
    let pad = f64::from(padding);
    let mut order: Vec<usize> = (0..dims.len()).collect();
    order.sort_by(|&a, &b| dims[b][1].total_cmp(&dims[a][1]).then(a.cmp(&b)));
    let place = |k: f64| -> Option<Vec<[f64; 2]>> {
        let mut at = vec![[0.0; 2]; dims.len()];
        let (mut x, mut y, mut shelf) = (0.0f64, 0.0f64, 0.0f64);
        for &i in &order {
            let w = (dims[i][0] * k).ceil().max(1.0) + 2.0 * pad;
            let h = (dims[i][1] * k).ceil().max(1.0) + 2.0 * pad;
            if w > s {
                return None;
            }
            if x + w > s {
                y += shelf;
                x = 0.0;
                shelf = 0.0;
            }
            if y + h > s {
                return None;
            }
            at[i] = [x + pad, y + pad];
            x += w;
            shelf = shelf.max(h);
        }
        Some(at)
    };
    let area: f64 = dims.iter().map(|d| d[0] * d[1]).sum();
    let widest = dims.iter().map(|d| d[0].max(d[1])).fold(0.0, f64::max);
    if !(area > 0.0 && widest > 0.0) {
        return None;
    }
    let mut hi = (s / area.sqrt()).min(s / widest);
    let mut lo = 0.0;
    if let Some(at) = place(hi) {
        return Some((hi, at));
    }
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if place(mid).is_some() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    if lo <= 0.0 {
        return None;
    }
    place(lo).map(|at| (lo, at))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed cube of 12 triangles, corners not shared between faces.
    fn cube() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for axis in 0..3 {
            for side in [0.0, 1.0] {
                let base = p.len() as u32;
                for (u, v) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                    let mut q = [0.0; 3];
                    q[axis] = side;
                    q[(axis + 1) % 3] = u;
                    q[(axis + 2) % 3] = v;
                    p.push(q);
                }
                if side == 1.0 {
                    t.push([base, base + 1, base + 2]);
                    t.push([base, base + 2, base + 3]);
                } else {
                    t.push([base, base + 2, base + 1]);
                    t.push([base, base + 3, base + 2]);
                }
            }
        }
        (p, t)
    }

    #[test]
    fn a_cube_gets_six_charts_that_do_not_overlap() {
        let (p, t) = cube();
        let a = atlas(&p, &t, 256, 4).unwrap();
        assert_eq!(a.charts, 6);
        let r = super::super::raster::rasterize(&a.uvs_flat(), &a.corner_triangles(), 256, 0);
        assert_eq!(r.overlapping, 0);
        // Every face is a unit square: the same texel count each.
        assert!(r.covered > 6 * 50 * 50, "{}", r.covered);
        // One density: every triangle's UV area over its world area is the same.
        for f in 0..t.len() {
            let uv = &a.uvs[f * 3..f * 3 + 3];
            let area = 0.5
                * ((uv[1][0] - uv[0][0]) * (uv[2][1] - uv[0][1])
                    - (uv[1][1] - uv[0][1]) * (uv[2][0] - uv[0][0]))
                    .abs()
                * 256.0
                * 256.0;
            let ratio = area / (a.density * a.density * 0.5);
            assert!((ratio - 1.0).abs() < 1e-9, "triangle {f}: {ratio}");
        }
        assert!(a
            .uvs
            .iter()
            .all(|uv| (0.0..=1.0).contains(&uv[0]) && (0.0..=1.0).contains(&uv[1])));
    }

    /// A strip of two unit squares in 3D whose UVs mirror the left square
    /// onto the right one (they share the middle edge's UVs): the mirrored
    /// halves become two charts, each a moved and scaled copy of its own
    /// UVs.
    #[test]
    fn mirrored_islands_are_repacked_apart_keeping_their_shape() {
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [2.0, 1.0, 0.0],
        ];
        // u mirrored about x = 1: x 0 and 2 both map to u 0.1, x 1 to 0.6.
        let uv = vec![
            [0.1, 0.2],
            [0.6, 0.2],
            [0.1, 0.2],
            [0.1, 0.7],
            [0.6, 0.7],
            [0.1, 0.7],
        ];
        let t = vec![[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]];
        let a = islands(&p, &uv, &t, 256, 2).unwrap();
        assert_eq!(a.charts, 2);
        let r = crate::post::bake::rasterize(&a.uvs_flat(), &a.corner_triangles(), 256, 0);
        assert_eq!(r.overlapping, 0);
        assert!(r.covered > 2 * 60 * 60, "{}", r.covered);
        // Each island spans 1 world unit per 0.5 of UV: 2 world units per UV
        // unit, at `density` texels per world unit.
        let k = a.density * 2.0 / 256.0;
        for (f, tri) in t.iter().enumerate() {
            for (i, j) in [(0, 1), (0, 2)] {
                let new = [0, 1].map(|c| a.uvs[f * 3 + j][c] - a.uvs[f * 3 + i][c]);
                let old = [0, 1].map(|c| uv[tri[j] as usize][c] - uv[tri[i] as usize][c]);
                for c in 0..2 {
                    assert!(
                        (new[c] - k * old[c]).abs() < 1e-12,
                        "triangle {f}: {new:?} vs {old:?}"
                    );
                }
            }
        }
        // Without the mirror, the strip is one island.
        let uv2 = vec![
            [0.1, 0.2],
            [0.3, 0.2],
            [0.5, 0.2],
            [0.1, 0.4],
            [0.3, 0.4],
            [0.5, 0.4],
        ];
        assert_eq!(islands(&p, &uv2, &t, 256, 2).unwrap().charts, 1);
    }

    impl Atlas {
        fn uvs_flat(&self) -> Vec<[f64; 2]> {
            self.uvs.clone()
        }
        fn corner_triangles(&self) -> Vec<[u32; 3]> {
            (0..self.uvs.len() as u32 / 3)
                .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
                .collect()
        }
    }
}
