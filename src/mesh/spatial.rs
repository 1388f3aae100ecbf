//! A uniform grid for nearest-item searches, triangles with such a grid
//! for closest points and distances ([`Faces`]), and the small geometry the
//! remesher and the pattern statistics share (closest points on segments
//! and triangles).

pub(crate) use crate::math::v3::{add, cross, dist2, dot, norm, scale, sub};

/// A uniform grid of items' bounding boxes, stored flat (each cell's items
/// as a range of one array).
#[derive(Clone, Debug)]
pub(crate) struct Grid {
    origin: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
    n: usize,
}

impl Grid {
    pub(crate) fn new(items: impl Iterator<Item = ([f64; 3], [f64; 3])>, size: f64) -> Grid {
        let boxes: Vec<([f64; 3], [f64; 3])> = items.collect();
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (a, b) in &boxes {
            for k in 0..3 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
            }
        }
        if boxes.is_empty() {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        // About two items a cell, never more cells than a few per item.
        let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        let mut cell = (2.0 * size).max(1e-300);
        let budget = 4.0 * boxes.len() as f64 + 64.0;
        while (ext[0] / cell + 1.0) * (ext[1] / cell + 1.0) * (ext[2] / cell + 1.0) > budget {
            cell *= 1.5;
        }
        let dims = ext.map(|e| (e / cell).floor() as usize + 1);
        let g = Grid {
            origin: lo,
            cell,
            dims,
            start: Vec::new(),
            items: Vec::new(),
            n: boxes.len(),
        };
        let ranges: Vec<([usize; 3], [usize; 3])> =
            boxes.iter().map(|(a, b)| (g.at(*a), g.at(*b))).collect();
        let n_cells = dims[0] * dims[1] * dims[2];
        let mut count = vec![0u32; n_cells + 1];
        let each = |r: &([usize; 3], [usize; 3]), f: &mut dyn FnMut(usize)| {
            for z in r.0[2]..=r.1[2] {
                for y in r.0[1]..=r.1[1] {
                    for x in r.0[0]..=r.1[0] {
                        f(x + dims[0] * (y + dims[1] * z));
                    }
                }
            }
        };
        for r in &ranges {
            each(r, &mut |c| count[c + 1] += 1);
        }
        for c in 0..n_cells {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut items = vec![0u32; count[n_cells] as usize];
        for (i, r) in ranges.iter().enumerate() {
            each(r, &mut |c| {
                items[fill[c] as usize] = i as u32;
                fill[c] += 1;
            });
        }
        Grid {
            start: count,
            items,
            ..g
        }
    }

    fn at(&self, p: [f64; 3]) -> [usize; 3] {
        [0, 1, 2].map(|k| {
            (((p[k] - self.origin[k]) / self.cell).floor().max(0.0) as usize).min(self.dims[k] - 1)
        })
    }

    /// Visit the items near `p` in growing shells of cells (an item may be
    /// visited more than once); `visit` returns the best squared distance
    /// so far, and the search stops once a shell lies farther than it.
    pub(crate) fn search(&self, p: [f64; 3], mut visit: impl FnMut(usize) -> Option<f64>) {
        if self.n == 0 {
            return;
        }
        let c = self.at(p).map(|x| x as i64);
        let dims = self.dims.map(|d| d as i64);
        let max_r = *dims.iter().max().unwrap_or(&1);
        let mut best: Option<f64> = None;
        for r in 0..=max_r {
            if let Some(b) = best {
                // An item first seen in shell r lies outside the block of
                // cells within r - 1 of the centre: at least this far.
                let reach = (0..3)
                    .map(|k| {
                        let lo = self.origin[k] + (c[k] - (r - 1)) as f64 * self.cell;
                        let hi = self.origin[k] + (c[k] + r) as f64 * self.cell;
                        (p[k] - lo).min(hi - p[k]).max(0.0)
                    })
                    .fold(f64::INFINITY, f64::min);
                if reach * reach > b {
                    break;
                }
            }
            let (z0, z1) = ((c[2] - r).max(0), (c[2] + r).min(dims[2] - 1));
            let (y0, y1) = ((c[1] - r).max(0), (c[1] + r).min(dims[1] - 1));
            let (x0, x1) = ((c[0] - r).max(0), (c[0] + r).min(dims[0] - 1));
            for z in z0..=z1 {
                for y in y0..=y1 {
                    let inner = (z - c[2]).abs() < r && (y - c[1]).abs() < r;
                    let mut x = x0;
                    while x <= x1 {
                        if inner && (x - c[0]).abs() < r {
                            // Skip the inside of the shell.
                            x = c[0] + r;
                            continue;
                        }
                        let cell = (x + dims[0] * (y + dims[1] * z)) as usize;
                        let (s, e) = (self.start[cell] as usize, self.start[cell + 1] as usize);
                        for &i in &self.items[s..e] {
                            if let Some(d) = visit(i as usize) {
                                best = Some(best.map_or(d, |b: f64| b.min(d)));
                            }
                        }
                        x += 1;
                    }
                }
            }
        }
    }
}

/// A position as a map key: its coordinates' bits, -0.0 taken as 0.0, so
/// points are equal exactly when their coordinates are.
pub(crate) fn position_key(p: [f64; 3]) -> [u64; 3] {
    p.map(|x| (x + 0.0).to_bits())
}

/// The keys ([`position_key`]) of `mesh`'s vertices on its own border (an
/// open edge that is not a crack's side).
pub(crate) fn border_keys(mesh: &super::SimMesh) -> std::collections::BTreeSet<[u64; 3]> {
    mesh.halfedges()
        .filter(|&h| mesh.is_boundary_halfedge(h) && !mesh.is_crack_halfedge(h))
        .flat_map(|h| [mesh.origin(h), mesh.dest(h)])
        .map(|v| position_key(mesh.position(v)))
        .collect()
}

/// Triangles with a grid for closest-point searches.
#[derive(Clone, Debug)]
pub(crate) struct Faces {
    positions: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    grid: Grid,
}

impl Faces {
    pub(crate) fn new(positions: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Faces {
        let mean_edge = mean_edge(&positions, &triangles);
        let grid = Grid::new(
            triangles
                .iter()
                .map(|t| bbox(&t.map(|i| positions[i as usize]))),
            mean_edge,
        );
        Faces {
            positions,
            triangles,
            grid,
        }
    }

    /// Whether there are no triangles.
    pub(crate) fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// How many triangles.
    pub(crate) fn len(&self) -> usize {
        self.triangles.len()
    }

    /// The triangles of `mesh` (its vertices as they are).
    pub(crate) fn of_mesh(mesh: &super::SimMesh) -> Faces {
        Faces::new(
            mesh.positions().to_vec(),
            mesh.faces()
                .map(|f| mesh.face_vertices(f).map(|v| v.0))
                .collect(),
        )
    }

    /// The distance from `p` to the closest point (infinite without
    /// triangles).
    pub(crate) fn distance(&self, p: [f64; 3]) -> f64 {
        self.closest(p)
            .map_or(f64::INFINITY, |(_, _, q)| dist2(p, q).sqrt())
    }

    /// The closest point to `p`: (triangle, barycentric coordinates, point).
    pub(crate) fn closest(&self, p: [f64; 3]) -> Option<(usize, [f64; 3], [f64; 3])> {
        let mut best: Option<(f64, usize, [f64; 3], [f64; 3])> = None;
        self.grid.search(p, |f| {
            let t = self.triangles[f].map(|i| self.positions[i as usize]);
            let (q, bary) = closest_on_triangle(p, t);
            let d = dist2(p, q);
            // Ties go to the lower index, so the result does not depend on
            // the order cells are visited in.
            if best.is_none_or(|b| d < b.0 || (d == b.0 && f < b.1)) {
                best = Some((d, f, bary, q));
            }
            best.map(|b| b.0)
        });
        best.map(|(_, f, b, q)| (f, b, q))
    }
}

fn mean_edge(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> f64 {
    let mut sum = 0.0;
    for t in triangles {
        for k in 0..3 {
            sum += dist2(positions[t[k] as usize], positions[t[(k + 1) % 3] as usize]).sqrt();
        }
    }
    (sum / (3 * triangles.len()).max(1) as f64).max(1e-12)
}

pub(crate) fn bbox(p: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for q in p {
        for k in 0..3 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    (lo, hi)
}

pub(crate) fn closest_on_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    add(a, scale(sub(b, a), segment_parameter(p, a, b)))
}

/// Where along `a`-`b` (0 at `a`, 1 at `b`) its closest point to `p` lies;
/// 0 when the segment has no length.
fn segment_parameter(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    let l = dot(ab, ab);
    if l > 0.0 {
        (dot(sub(p, a), ab) / l).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The closest point of triangle `t` to `p`, and its barycentric
/// coordinates (Ericson, Real-Time Collision Detection 5.1.5).
pub(crate) fn closest_on_triangle(p: [f64; 3], t: [[f64; 3]; 3]) -> ([f64; 3], [f64; 3]) {
    let (a, b, c) = (t[0], t[1], t[2]);
    let ab = sub(b, a);
    let ac = sub(c, a);
    // A triangle with no area (two corners at one point, or all three on
    // a line, as at the poles of a modelled surface): the closest point of
    // its edges, whose divisions below would be 0 / 0.
    let n = cross(ab, ac);
    if dot(n, n) <= 1e-24 * dot(ab, ab) * dot(ac, ac) || dot(n, n) == 0.0 {
        return closest_on_edges(p, t);
    }
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (add(a, scale(ab, v)), [1.0 - v, v, 0.0]);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (add(a, scale(ac, w)), [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add(b, scale(sub(c, b), w)), [0.0, 1.0 - w, w]);
    }
    let denom = va + vb + vc;
    if denom.is_nan() || denom == 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let v = vb / denom;
    let w = vc / denom;
    (add(a, add(scale(ab, v), scale(ac, w))), [1.0 - v - w, v, w])
}

/// The closest point to `p` of the three edges of `t` (a triangle with no
/// area), with its barycentric coordinates (finite; ties to the first edge).
fn closest_on_edges(p: [f64; 3], t: [[f64; 3]; 3]) -> ([f64; 3], [f64; 3]) {
    let mut best: Option<(f64, [f64; 3], [f64; 3])> = None;
    for k in 0..3 {
        let (i, j) = (k, (k + 1) % 3);
        let s = segment_parameter(p, t[i], t[j]);
        let q = add(t[i], scale(sub(t[j], t[i]), s));
        let mut bary = [0.0; 3];
        bary[i] = 1.0 - s;
        bary[j] += s;
        let d = dist2(p, q);
        if best.is_none_or(|b| d < b.0) {
            best = Some((d, q, bary));
        }
    }
    best.map_or((t[0], [1.0, 0.0, 0.0]), |(_, q, bary)| (q, bary))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangle with no area gives the closest point of its edges with
    /// finite barycentric coordinates (two corners at one point made 0 / 0:
    /// NaN coordinates that stopped `crackle stats` cutting lines into a
    /// surface).
    #[test]
    fn a_triangle_with_no_area_gives_finite_coordinates() {
        let p = [0.5, 1.0, 0.0];
        for t in [
            [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            [[2.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
            [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
            [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
        ] {
            let (q, bary) = closest_on_triangle(p, t);
            assert!(bary.iter().all(|b| b.is_finite() && *b >= 0.0), "{t:?}: {bary:?}");
            assert!((bary.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{bary:?}");
            let at = (0..3).fold([0.0; 3], |s, k| add(s, scale(t[k], bary[k])));
            assert!(dist2(at, q) < 1e-24, "{t:?}: {q:?} against {at:?}");
            let want = if t[0] == t[2] { 1.0 } else { 0.5 };
            assert!((q[0] - want).abs() < 1e-12 && q[1] == 0.0, "{t:?}: {q:?}");
        }
        // A proper triangle as before.
        let (q, bary) = closest_on_triangle([0.2, 0.2, 1.0], [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        assert!(dist2(q, [0.2, 0.2, 0.0]) < 1e-24 && (bary[0] - 0.6).abs() < 1e-12);
    }
}
