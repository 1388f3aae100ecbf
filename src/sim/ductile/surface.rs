//! The deformed, torn surface: the level set's zero surface cut from each
//! tetrahedron (marching tetrahedra, one vertex per cut grid edge, so the
//! surface is closed), mapped through the tetrahedron's deformation. Each
//! triangle is on the original surface or on the torn surface (where the
//! material was inside at the start), and belongs to one piece. The border
//! between the two runs along an iso-line of the start's level set, not
//! along the triangles' edges: triangles it crosses are split on it.

use super::fem::edges;
use super::grid::cut_edges;
use super::Ductile;
use crate::math::v3::{add, dot, scale, sub};
use std::collections::HashMap;

/// The extracted surface, in metres.
#[derive(Clone, Debug, Default)]
pub struct TornSurface {
    /// Vertex positions, deformed: where the surface is. A smoothed torn
    /// vertex's position is smoothed itself, not its rest position mapped
    /// by [`TornSurface::tet_of`]'s tetrahedron: smoothing moves it off the
    /// edge it was cut from, and the tetrahedron's map there weighs grid
    /// nodes the material hardly holds (on a block turned 30 degrees to the
    /// grid and torn at 24 cubes, the mapped torn faces came out 1e9 m
    /// away).
    pub positions: Vec<[f64; 3]>,
    /// Vertex positions at rest.
    pub rest: Vec<[f64; 3]>,
    /// The tetrahedron each vertex was cut from (its deformation maps
    /// points on the vertex's cut edge; for the vertex itself read
    /// [`TornSurface::positions`]).
    pub tet_of: Vec<u32>,
    /// Triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle: on the torn surface rather than the original.
    pub torn: Vec<bool>,
    /// Per triangle: its piece (0..pieces), pieces ordered by their first
    /// triangle.
    pub piece: Vec<u32>,
    /// How many pieces.
    pub pieces: usize,
}

impl Ductile {
    /// Tetrahedron `e`'s deformation gradient.
    pub fn deformation(&self, e: usize) -> nalgebra::Matrix3<f64> {
        edges(self.tets[e].map(|n| self.x[n as usize])) * self.rest[e].bm
    }

    /// The deformed point of rest point `p` by tetrahedron `e`'s affine map.
    pub fn deform(&self, e: usize, p: [f64; 3]) -> [f64; 3] {
        let t = self.tets[e];
        let x0 = self.rest_x[t[0] as usize];
        let d =
            self.deformation(e) * nalgebra::Vector3::new(p[0] - x0[0], p[1] - x0[1], p[2] - x0[2]);
        let y0 = self.x[t[0] as usize];
        [y0[0] + d[0], y0[1] + d[1], y0[2] + d[2]]
    }

    /// The surface of the material now; `torn_depth` (metres): a triangle
    /// whose centre was at least this deep inside at the start is torn.
    pub fn surface(&self, torn_depth: f64) -> TornSurface {
        let mut s = TornSurface::default();
        let mut vertex_of: HashMap<(u32, u32), u32> = HashMap::new();
        // Per vertex: the start's level set there plus `torn_depth`
        // (negative: torn).
        let mut start: Vec<f64> = Vec::new();
        // Per triangle: the tetrahedron it was cut from.
        let mut tet_of_triangle: Vec<u32> = Vec::new();
        for (e, t) in self.tets.iter().enumerate() {
            let phi = t.map(|n| self.phi[n as usize]);
            let edge_pairs = cut_edges(phi);
            if edge_pairs.is_empty() {
                continue;
            }
            let mut corner = |a: usize, b: usize| -> u32 {
                let (na, nb) = (t[a], t[b]);
                let key = (na.min(nb), na.max(nb));
                *vertex_of.entry(key).or_insert_with(|| {
                    let (pa, pb) = (self.phi[key.0 as usize], self.phi[key.1 as usize]);
                    let w = pa / (pa - pb);
                    let lerp = |x: &[[f64; 3]]| {
                        let (p, q) = (x[key.0 as usize], x[key.1 as usize]);
                        [0, 1, 2].map(|k| p[k] + w * (q[k] - p[k]))
                    };
                    s.rest.push(lerp(&self.rest_x));
                    s.positions.push(lerp(&self.x));
                    s.tet_of.push(e as u32);
                    let (sa, sb) = (self.phi0[key.0 as usize], self.phi0[key.1 as usize]);
                    start.push(sa + w * (sb - sa) + torn_depth);
                    (s.rest.len() - 1) as u32
                })
            };
            let polygon: Vec<u32> = edge_pairs.iter().map(|&(a, b)| corner(a, b)).collect();
            // Outward: along the level set's gradient (towards phi > 0).
            let grad = {
                let g = self.rest[e].gradients();
                let v = g
                    .iter()
                    .zip(phi)
                    .fold(nalgebra::Vector3::zeros(), |acc, (g, p)| acc + g * p);
                [v[0], v[1], v[2]]
            };
            // Orientation from the corners moved off the nodes (a zero on a
            // node makes triangles of no area, whose normal says nothing).
            let off_node: Vec<[f64; 3]> = edge_pairs
                .iter()
                .map(|&(a, b)| {
                    let w = (phi[a] / (phi[a] - phi[b])).clamp(0.05, 0.95);
                    let (p, q) = (self.rest_x[t[a] as usize], self.rest_x[t[b] as usize]);
                    [0, 1, 2].map(|k| p[k] + w * (q[k] - p[k]))
                })
                .collect();
            for k in 1..polygon.len() - 1 {
                let mut tri = [polygon[0], polygon[k], polygon[k + 1]];
                let (a, b, c) = (off_node[0], off_node[k], off_node[k + 1]);
                let n =
                    crate::math::v3::cross(crate::math::v3::sub(b, a), crate::math::v3::sub(c, a));
                if crate::math::v3::dot(n, grad) < 0.0 {
                    tri.swap(1, 2);
                }
                s.triangles.push(tri);
                tet_of_triangle.push(e as u32);
            }
        }
        self.split_on_the_border(&mut s, &mut start, &tet_of_triangle);
        let (piece, pieces) = pieces(&s.triangles, s.rest.len());
        // Slivers of rounding (pieces enclosing less than `SLIVER` of a
        // cube) are dropped; the rest are numbered again in order.
        let mut volume = vec![0.0; pieces];
        for (t, &p) in s.triangles.iter().zip(&piece) {
            let [a, b, c] = t.map(|v| s.rest[v as usize]);
            volume[p as usize] += crate::math::v3::dot(a, crate::math::v3::cross(b, c)) / 6.0;
        }
        let least = super::SLIVER * self.grid.h.powi(3);
        let mut renumber = vec![u32::MAX; pieces];
        let mut kept = 0u32;
        for (p, v) in volume.iter().enumerate() {
            if *v >= least {
                renumber[p] = kept;
                kept += 1;
            }
        }
        let keep: Vec<bool> = piece
            .iter()
            .map(|&p| renumber[p as usize] != u32::MAX)
            .collect();
        let mut k = 0;
        s.triangles.retain(|_| {
            k += 1;
            keep[k - 1]
        });
        let mut k = 0;
        s.torn.retain(|_| {
            k += 1;
            keep[k - 1]
        });
        s.piece = piece
            .iter()
            .filter(|&&p| renumber[p as usize] != u32::MAX)
            .map(|&p| renumber[p as usize])
            .collect();
        s.pieces = kept as usize;
        smooth_torn(&mut s, self.params.smooth_tear, self.grid.h);
        s
    }

    /// Class each triangle torn or original by `start` at its corners
    /// (negative: torn), splitting those with corners on both sides along
    /// the zero line of `start` (linear along each edge, one new vertex per
    /// cut edge, shared by both its triangles: the surface stays closed).
    /// A value within a thousandth of a cube of zero counts as original, so
    /// no cut falls on a corner.
    /// A new vertex is mapped by its triangle's tetrahedron, which holds
    /// its edge.
    fn split_on_the_border(&self, s: &mut TornSurface, start: &mut Vec<f64>, tets: &[u32]) {
        let snap = 1e-3 * self.grid.h;
        for g in start.iter_mut() {
            if g.abs() < snap {
                *g = snap;
            }
        }
        let mut cut_of: HashMap<(u32, u32), u32> = HashMap::new();
        let triangles = std::mem::take(&mut s.triangles);
        for (tri, &e) in triangles.into_iter().zip(tets) {
            let torn = tri.map(|v| start[v as usize] < 0.0);
            if torn[0] == torn[1] && torn[1] == torn[2] {
                s.triangles.push(tri);
                s.torn.push(torn[0]);
                continue;
            }
            // The corner alone on its side first, the order kept.
            let i = (0..3)
                .find(|&i| torn[i] != torn[(i + 1) % 3] && torn[i] != torn[(i + 2) % 3])
                .expect("one corner alone");
            let [a, b, c] = [tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]];
            let mut cut = |p: u32, q: u32| -> u32 {
                *cut_of.entry((p.min(q), p.max(q))).or_insert_with(|| {
                    let (p, q) = (p.min(q), p.max(q));
                    let (gp, gq) = (start[p as usize], start[q as usize]);
                    let w = gp / (gp - gq);
                    let lerp = |x: &[[f64; 3]]| {
                        let (u, v) = (x[p as usize], x[q as usize]);
                        [0, 1, 2].map(|k| u[k] + w * (v[k] - u[k]))
                    };
                    let (rest, now) = (lerp(&s.rest), lerp(&s.positions));
                    s.rest.push(rest);
                    s.positions.push(now);
                    s.tet_of.push(e);
                    start.push(snap);
                    (s.rest.len() - 1) as u32
                })
            };
            let (ab, ac) = (cut(a, b), cut(a, c));
            let alone = torn[i];
            s.triangles.push([a, ab, ac]);
            s.torn.push(alone);
            s.triangles.push([ab, b, c]);
            s.torn.push(!alone);
            s.triangles.push([ab, c, ac]);
            s.torn.push(!alone);
        }
    }
}

/// How far (in cubes, at rest) [`smooth_torn`] lets a torn vertex move
/// from where it was cut: the grid's own uncertainty about the zero
/// surface, which a terrace's step of one cube fits within.
const TEAR_BAND: f64 = 1.0;

/// The torn surface relaxed towards the smooth surface its terraces stand
/// for, `passes` times: each vertex inside it (off every original
/// triangle: the tear's border and the input's surface stay put) steps
/// half way to its neighbours' mean, cut short at [`TEAR_BAND`] cubes
/// from where it was cut at rest (elastic surface nets, Gibson 1998,
/// relaxing a voxel surface within its cells). The torn surface is cut
/// from a grid and, where the tear steps from one layer of nodes to the
/// next, shows the grid's terraces, whose faces all face along its axes;
/// relaxed within a cube of the cut the steps become the slope they
/// approximate, while a shape wider than a cube stays. The deformed
/// position takes the same step, cut short in the same proportion (the
/// tetrahedron's map there may weigh nodes the material hardly holds).
/// The triangles stay as they are; each pass reads the last one's
/// positions only, so the order of the vertices does not matter.
fn smooth_torn(s: &mut TornSurface, passes: usize, h: f64) {
    if passes == 0 {
        return;
    }
    let n = s.rest.len();
    let mut free = vec![true; n];
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (t, &torn) in s.triangles.iter().zip(&s.torn) {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            if !torn {
                free[a] = false;
            }
            neighbours[a].push(b as u32);
            neighbours[b].push(a as u32);
        }
    }
    for (v, list) in neighbours.iter_mut().enumerate() {
        list.sort_unstable();
        list.dedup();
        if list.is_empty() {
            free[v] = false;
        }
    }
    let moving: Vec<usize> = (0..n).filter(|&v| free[v]).collect();
    let cut: Vec<[f64; 3]> = moving.iter().map(|&v| s.rest[v]).collect();
    let radius = TEAR_BAND * h;
    let step = |x: &[[f64; 3]], v: usize| -> [f64; 3] {
        let list = &neighbours[v];
        let mut mean = [0.0; 3];
        for &u in list {
            mean = add(mean, x[u as usize]);
        }
        let mean = scale(mean, 1.0 / list.len() as f64);
        scale(sub(mean, x[v]), 0.5)
    };
    for _ in 0..passes {
        let steps: Vec<([f64; 3], [f64; 3])> = moving
            .iter()
            .zip(&cut)
            .map(|(&v, &origin)| {
                let (dr, dx) = (step(&s.rest, v), step(&s.positions, v));
                let t = within(sub(s.rest[v], origin), dr, radius);
                (scale(dr, t), scale(dx, t))
            })
            .collect();
        for (&v, (dr, dx)) in moving.iter().zip(steps) {
            s.rest[v] = add(s.rest[v], dr);
            s.positions[v] = add(s.positions[v], dx);
        }
    }
}

/// The largest `t` in `[0, 1]` with `|a + t d| <= radius`, for `|a| <=
/// radius` (0 when even `t = 0` is outside, by rounding).
fn within(a: [f64; 3], d: [f64; 3], radius: f64) -> f64 {
    let end = add(a, d);
    if dot(end, end) <= radius * radius {
        return 1.0;
    }
    // |a + t d|^2 = radius^2: q t^2 + 2 b t + c = 0, c <= 0 < q.
    let (q, b, c) = (dot(d, d), dot(a, d), dot(a, a) - radius * radius);
    if q <= 0.0 || c > 0.0 {
        return 0.0;
    }
    ((-b + (b * b - q * c).max(0.0).sqrt()) / q).clamp(0.0, 1.0)
}

/// Connected pieces of a triangle list (through shared vertices), numbered
/// by their first triangle.
fn pieces(triangles: &[[u32; 3]], n_vertices: usize) -> (Vec<u32>, usize) {
    let mut parent: Vec<u32> = (0..n_vertices as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for t in triangles {
        for k in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut number: HashMap<u32, u32> = HashMap::new();
    let piece = triangles
        .iter()
        .map(|t| {
            let r = find(&mut parent, t[0]);
            let next = number.len() as u32;
            *number.entry(r).or_insert(next)
        })
        .collect();
    (piece, number.len())
}

#[cfg(test)]
mod tests {
    use super::within;

    /// The step cut short on the band's sphere, whole inside it, none from
    /// outside it.
    #[test]
    fn a_step_stops_on_the_band() {
        assert_eq!(within([0.0; 3], [0.5, 0.0, 0.0], 1.0), 1.0);
        let t = within([0.5, 0.0, 0.0], [1.0, 0.0, 0.0], 1.0);
        assert!((t - 0.5).abs() < 1e-12, "{t}");
        let t = within([0.0, 0.6, 0.0], [1.0, 0.0, 0.0], 1.0);
        assert!((t - 0.8).abs() < 1e-12, "{t}");
        assert_eq!(within([2.0, 0.0, 0.0], [1.0, 0.0, 0.0], 1.0), 0.0);
    }
}
