//! The regular grid of tetrahedra the object is embedded in, and the signed
//! distance of its nodes to the input surface (negative inside).

use parry3d::math::Vector;
use parry3d::query::PointQuery;
use parry3d::shape::{TriMesh, TriMeshFlags};
use rayon::prelude::*;

/// A regular grid of `n[0] x n[1] x n[2]` cubes of side `h` from `origin`,
/// each cut into six tetrahedra along its main diagonal (Kuhn's
/// triangulation: neighbouring cubes share their faces' triangles).
#[derive(Clone, Debug)]
pub struct Grid {
    /// Lower corner.
    pub origin: [f64; 3],
    /// Cube side.
    pub h: f64,
    /// Cubes along each axis.
    pub n: [usize; 3],
}

/// The six tetrahedra of a cube as corner bit patterns (bit 0: +x, 1: +y,
/// 2: +z): paths from corner 0 to corner 7 along the axes in each order.
const KUHN: [[u8; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

impl Grid {
    /// The grid over the box `lo..hi` with about one empty cube of margin on
    /// every side and `cells` cubes along the box's longest side (at least
    /// 2).
    pub fn around(lo: [f64; 3], hi: [f64; 3], cells: usize) -> Grid {
        let longest = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let h = longest / cells.max(2) as f64;
        let n = std::array::from_fn(|k| ((hi[k] - lo[k]) / h).ceil().max(1.0) as usize + 2);
        // Centred, then shifted by a fixed odd fraction of a cube: the
        // faces of a solid aligned with the axes would otherwise pass
        // through lines of nodes, whose inside or outside is rounding.
        const SHIFT: [f64; 3] = [0.1374, 0.2718, 0.1931];
        let origin = std::array::from_fn(|k| {
            let span = n[k] as f64 * h;
            0.5 * (lo[k] + hi[k]) - 0.5 * span + SHIFT[k] * h
        });
        Grid { origin, h, n }
    }

    /// Nodes along each axis.
    pub fn nodes_per_axis(&self) -> [usize; 3] {
        self.n.map(|c| c + 1)
    }

    /// How many nodes.
    pub fn n_nodes(&self) -> usize {
        self.nodes_per_axis().iter().product()
    }

    /// The index of node `(i, j, k)`.
    pub fn node(&self, i: usize, j: usize, k: usize) -> usize {
        let [nx, ny, _] = self.nodes_per_axis();
        (k * ny + j) * nx + i
    }

    /// The position of node `index`.
    pub fn position(&self, index: usize) -> [f64; 3] {
        let [nx, ny, _] = self.nodes_per_axis();
        let (i, j, k) = (index % nx, (index / nx) % ny, index / (nx * ny));
        [
            self.origin[0] + i as f64 * self.h,
            self.origin[1] + j as f64 * self.h,
            self.origin[2] + k as f64 * self.h,
        ]
    }

    /// The tetrahedra of cube `(i, j, k)`, positively oriented.
    pub fn cube_tets(&self, i: usize, j: usize, k: usize) -> [[u32; 4]; 6] {
        let corner = |b: u8| {
            self.node(
                i + usize::from(b & 1),
                j + usize::from((b >> 1) & 1),
                k + usize::from((b >> 2) & 1),
            ) as u32
        };
        KUHN.map(|t| {
            let mut tet = t.map(corner);
            // Orientation of the bit path: the permutation's parity.
            let d = |b: u8| {
                [
                    f64::from(b & 1),
                    f64::from((b >> 1) & 1),
                    f64::from((b >> 2) & 1),
                ]
            };
            let [a, b, c, e] = t.map(d);
            let m = [
                [b[0] - a[0], c[0] - a[0], e[0] - a[0]],
                [b[1] - a[1], c[1] - a[1], e[1] - a[1]],
                [b[2] - a[2], c[2] - a[2], e[2] - a[2]],
            ];
            if det3(m) < 0.0 {
                tet.swap(2, 3);
            }
            tet
        })
    }
}

/// The determinant of a 3 x 3 matrix given by rows.
pub fn det3(m: [[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Why a surface cannot be embedded.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EmbedError {
    /// The surface has no triangles or no volume.
    #[error("the surface is empty or flat")]
    Empty,
    /// parry3d refused the surface (it is not an oriented manifold).
    #[error("the surface cannot be used for inside tests: {error:?}")]
    NotOriented {
        /// parry3d's refusal.
        error: parry3d::shape::TriMeshBuilderError,
    },
}

/// The signed distance of each of `points` to the closed, outward-oriented
/// surface `positions` / `triangles` (negative inside).
///
/// # Errors
/// [`EmbedError`] when the surface is empty or not an oriented manifold.
pub fn signed_distances(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    points: &[[f64; 3]],
) -> Result<Vec<f64>, EmbedError> {
    if triangles.is_empty() {
        return Err(EmbedError::Empty);
    }
    // parry works in f32: distances relative to the surface's centre keep
    // its precision where it matters.
    let (lo, hi) = bounds(positions);
    let c: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let vertices: Vec<Vector> = positions
        .iter()
        .map(|p| {
            Vector::new(
                (p[0] - c[0]) as f32,
                (p[1] - c[1]) as f32,
                (p[2] - c[2]) as f32,
            )
        })
        .collect();
    let mesh = TriMesh::with_flags(
        vertices,
        triangles.to_vec(),
        TriMeshFlags::ORIENTED | TriMeshFlags::MERGE_DUPLICATE_VERTICES,
    )
    .map_err(|error| EmbedError::NotOriented { error })?;
    Ok(points
        .par_iter()
        .map(|p| {
            let q = Vector::new(
                (p[0] - c[0]) as f32,
                (p[1] - c[1]) as f32,
                (p[2] - c[2]) as f32,
            );
            let proj = mesh.project_local_point(q, false);
            let d = f64::from((proj.point - q).length());
            if proj.is_inside {
                -d
            } else {
                d
            }
        })
        .collect())
}

/// The bounding box of `points`.
pub fn bounds(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// The edges (inside corner, outside corner) a linear function with node
/// values `phi` crosses zero on, in order around the cut polygon (3 or
/// 4; none when all corners are on one side). Inside: `phi < 0`.
pub fn cut_edges(phi: [f64; 4]) -> Vec<(usize, usize)> {
    let neg: Vec<usize> = (0..4).filter(|&i| phi[i] < 0.0).collect();
    let pos: Vec<usize> = (0..4).filter(|&i| phi[i] >= 0.0).collect();
    match neg.len() {
        1 => pos.iter().map(|&p| (neg[0], p)).collect(),
        3 => neg.iter().map(|&n| (n, pos[0])).collect(),
        2 => vec![
            (neg[0], pos[0]),
            (neg[0], pos[1]),
            (neg[1], pos[1]),
            (neg[1], pos[0]),
        ],
        _ => Vec::new(),
    }
}

/// The fraction of a tetrahedron's volume where the linear function with
/// node values `phi` is negative: the material a cut tetrahedron keeps
/// behind its cut plane.
pub fn inside_fraction(phi: [f64; 4]) -> f64 {
    let neg: Vec<usize> = (0..4).filter(|&i| phi[i] < 0.0).collect();
    match neg.len() {
        0 => 0.0,
        4 => 1.0,
        1 => corner_fraction(phi, neg[0]),
        3 => {
            let pos = (0..4).find(|&i| phi[i] >= 0.0).expect("one node outside");
            1.0 - corner_fraction(phi, pos)
        }
        _ => {
            // Two in (a, b), two out (c, d): the wedge between the end
            // triangles (a, p_ac, p_ad) and (b, p_bc, p_bd), its faces
            // planar, in reference coordinates.
            let (a, b) = (neg[0], neg[1]);
            let out: Vec<usize> = (0..4).filter(|&i| phi[i] >= 0.0).collect();
            let (c, d) = (out[0], out[1]);
            let r = |i: usize| -> [f64; 3] {
                std::array::from_fn(|k| if i > 0 && k == i - 1 { 1.0 } else { 0.0 })
            };
            let cut = |i: usize, j: usize| {
                let t = phi[i] / (phi[i] - phi[j]);
                let (p, q) = (r(i), r(j));
                [0, 1, 2].map(|k| p[k] + t * (q[k] - p[k]))
            };
            let (pa, pb) = (r(a), r(b));
            let (ac, ad, bc, bd) = (cut(a, c), cut(a, d), cut(b, c), cut(b, d));
            let vol = |p: [f64; 3], q: [f64; 3], s: [f64; 3], u: [f64; 3]| {
                det3([
                    [q[0] - p[0], s[0] - p[0], u[0] - p[0]],
                    [q[1] - p[1], s[1] - p[1], u[1] - p[1]],
                    [q[2] - p[2], s[2] - p[2], u[2] - p[2]],
                ])
                .abs()
            };
            // The reference tetrahedron's determinant is 1.
            (vol(pa, ac, ad, pb) + vol(ac, ad, pb, bc) + vol(ad, pb, bc, bd)).clamp(0.0, 1.0)
        }
    }
}

/// The volume fraction of the corner at node `a` cut off by the zero plane
/// when `a` is alone on its side.
fn corner_fraction(phi: [f64; 4], a: usize) -> f64 {
    let mut f = 1.0;
    for i in (0..4).filter(|&i| i != a) {
        f *= phi[a] / (phi[a] - phi[i]);
    }
    f.clamp(0.0, 1.0)
}
