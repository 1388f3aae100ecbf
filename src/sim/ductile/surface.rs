//! The deformed, torn surface: the level set's zero surface cut from each
//! tetrahedron (marching tetrahedra, one vertex per cut grid edge, so the
//! surface is closed), mapped through the tetrahedron's deformation. Each
//! triangle is on the original surface or on the torn surface (where the
//! material was inside at the start), and belongs to one piece.

use super::fem::edges;
use super::Ductile;
use std::collections::HashMap;

/// The extracted surface, in metres.
#[derive(Clone, Debug, Default)]
pub struct TornSurface {
    /// Vertex positions, deformed.
    pub positions: Vec<[f64; 3]>,
    /// Vertex positions at rest.
    pub rest: Vec<[f64; 3]>,
    /// The tetrahedron each vertex was cut from (its deformation maps
    /// points near the vertex).
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
        for (e, t) in self.tets.iter().enumerate() {
            let phi = t.map(|n| self.phi[n as usize]);
            let neg: Vec<usize> = (0..4).filter(|&i| phi[i] < 0.0).collect();
            if neg.is_empty() || neg.len() == 4 {
                continue;
            }
            let pos: Vec<usize> = (0..4).filter(|&i| phi[i] >= 0.0).collect();
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
                    (s.rest.len() - 1) as u32
                })
            };
            let polygon: Vec<u32> = match neg.len() {
                1 => pos.iter().map(|&p| corner(neg[0], p)).collect(),
                3 => neg.iter().map(|&n| corner(n, pos[0])).collect(),
                _ => vec![
                    corner(neg[0], pos[0]),
                    corner(neg[0], pos[1]),
                    corner(neg[1], pos[1]),
                    corner(neg[1], pos[0]),
                ],
            };
            // Outward: along the level set's gradient (towards phi > 0).
            let grad = {
                let g = self.rest[e].gradients();
                let v = g
                    .iter()
                    .zip(phi)
                    .fold(nalgebra::Vector3::zeros(), |acc, (g, p)| acc + g * p);
                [v[0], v[1], v[2]]
            };
            let phi0 = t.map(|n| self.phi0[n as usize]);
            // Orientation from the corners moved off the nodes (a zero on a
            // node makes triangles of no area, whose normal says nothing).
            let edge_pairs: Vec<(usize, usize)> = match neg.len() {
                1 => pos.iter().map(|&p| (neg[0], p)).collect(),
                3 => neg.iter().map(|&n| (n, pos[0])).collect(),
                _ => vec![
                    (neg[0], pos[0]),
                    (neg[0], pos[1]),
                    (neg[1], pos[1]),
                    (neg[1], pos[0]),
                ],
            };
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
                let [a, b, c] = tri.map(|v| s.rest[v as usize]);
                // The start's level set at the triangle's centre.
                let centre: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0);
                let start = self.interpolate(e, &phi0, centre);
                s.triangles.push(tri);
                s.torn.push(start < -torn_depth);
            }
        }
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
        s
    }

    /// The linear interpolation of node values `v` of tetrahedron `e` at
    /// rest point `p`.
    fn interpolate(&self, e: usize, v: &[f64; 4], p: [f64; 3]) -> f64 {
        let t = self.tets[e];
        let x0 = self.rest_x[t[0] as usize];
        let d = nalgebra::Vector3::new(p[0] - x0[0], p[1] - x0[1], p[2] - x0[2]);
        let l = self.rest[e].bm * d;
        v[0] * (1.0 - l[0] - l[1] - l[2]) + v[1] * l[0] + v[2] * l[1] + v[3] * l[2]
    }
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
