//! The torn solid returned as the artist's own surface: the input's
//! triangles, each vertex carried by the tetrahedron that holds it at rest
//! (its barycentric place in the grid, moved by the grid's deformation),
//! cut exactly along the border of the tear ([`crate::mesh::imprint`]: new
//! vertices on the input's edges, attributes interpolated in its faces) so
//! that only the torn faces are new. The part of the input the tear opened
//! (where the material under the surface is gone) is dropped, and each
//! torn face's border vertex is moved onto the cut input's, so the two
//! meet without a seam.

use crate::bridge::SimEntry;
use crate::mesh::spatial::Faces;
use crate::mesh::spatial::{bbox, dist2, Grid};
use crate::mesh::{FaceId, MeshError, SimMesh};
use crate::sim::ductile::surface::TornSurface;
use crate::sim::ductile::Ductile;
use std::collections::HashMap;

/// Point location in the solid's tetrahedra at rest.
struct Locator<'a> {
    d: &'a Ductile,
    index: HashMap<[u32; 4], usize>,
}

impl<'a> Locator<'a> {
    fn new(d: &'a Ductile) -> Locator<'a> {
        // By the grid's nodes: a virtual node stands at its home.
        let index = d
            .tets
            .iter()
            .enumerate()
            .map(|(i, t)| (t.map(|n| d.home(n as usize) as u32), i))
            .collect();
        Locator { d, index }
    }

    /// Barycentric coordinates of rest point `p` (metres) in tetrahedron `e`.
    fn bary(&self, e: usize, p: [f64; 3]) -> [f64; 4] {
        let x = self.d.tets[e].map(|n| self.d.rest_x[n as usize]);
        let col = |k: usize| {
            nalgebra::Vector3::new(x[k][0] - x[0][0], x[k][1] - x[0][1], x[k][2] - x[0][2])
        };
        let m = nalgebra::Matrix3::from_columns(&[col(1), col(2), col(3)]);
        let r = nalgebra::Vector3::new(p[0] - x[0][0], p[1] - x[0][1], p[2] - x[0][2]);
        match m.try_inverse() {
            Some(inv) => {
                let l = inv * r;
                [1.0 - l[0] - l[1] - l[2], l[0], l[1], l[2]]
            }
            None => [f64::NEG_INFINITY; 4],
        }
    }

    /// The material tetrahedron holding rest point `p` (metres); a point
    /// in none (the grid's material ends a little short of the input's
    /// surface there) takes the nearest one of its cube's and the
    /// neighbouring cubes'.
    fn locate(&self, p: [f64; 3]) -> Option<usize> {
        let g = &self.d.grid;
        let cell: [i64; 3] = std::array::from_fn(|k| ((p[k] - g.origin[k]) / g.h).floor() as i64);
        let mut best: Option<(f64, usize)> = None;
        for ring in 0..=1i64 {
            for dk in -ring..=ring {
                for dj in -ring..=ring {
                    for di in -ring..=ring {
                        let c = [cell[0] + di, cell[1] + dj, cell[2] + dk];
                        if (0..3).any(|k| c[k] < 0 || c[k] >= g.n[k] as i64) {
                            continue;
                        }
                        for t in g.cube_tets(c[0] as usize, c[1] as usize, c[2] as usize) {
                            let Some(&e) = self.index.get(&t) else {
                                continue;
                            };
                            let score = self.bary(e, p).into_iter().fold(f64::INFINITY, f64::min);
                            if best.is_none_or(|(s, b)| score > s || (score == s && e < b)) {
                                best = Some((score, e));
                            }
                        }
                    }
                }
            }
            if best.is_some_and(|(s, _)| s >= -1e-9) {
                break;
            }
        }
        best.map(|(_, e)| e)
    }

    /// The level set now at rest point `p` (metres): positive where no
    /// material is left (and beyond the material tetrahedra).
    fn phi(&self, p: [f64; 3]) -> f64 {
        match self.locate(p) {
            Some(e) => {
                let b = self.bary(e, p);
                if b.iter().any(|&x| x < -0.5) {
                    return f64::INFINITY;
                }
                (0..4)
                    .map(|k| b[k] * self.d.phi[self.d.tets[e][k] as usize])
                    .sum()
            }
            None => f64::INFINITY,
        }
    }
}

/// The input's surface as the torn solid returns it.
pub(super) struct Embedded {
    /// The input cut along the tear's border, its vertices moved by the
    /// deformation (scene units), its normals and tangents turned by it.
    pub cut: SimMesh,
    /// Per face of `cut`: its piece, or `None` where the tear opened it.
    pub piece: Vec<Option<u32>>,
    /// Per vertex of the torn surface on the tear's border: its place on
    /// the cut input, deformed (scene units).
    pub border: HashMap<u32, [f64; 3]>,
    /// Faces of the cut input dropped where the tear opened the surface.
    pub dropped: usize,
    /// Border segments the cut left out (see [`crate::mesh::imprint`]).
    pub skipped: usize,
}

/// The border of the tear on the torn surface `s`: edges between a torn
/// and an original triangle, as vertex pairs.
pub(super) fn border_edges(s: &TornSurface) -> Vec<(u32, u32)> {
    let mut sides: std::collections::BTreeMap<(u32, u32), [usize; 2]> = Default::default();
    for (t, &torn) in s.triangles.iter().zip(&s.torn) {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            sides.entry((a.min(b), a.max(b))).or_default()[usize::from(torn)] += 1;
        }
    }
    sides
        .into_iter()
        .filter(|(_, [orig, torn])| *orig > 0 && *torn > 0)
        .map(|(k, _)| k)
        .collect()
}

/// Why the tear cannot be cut into the input's own triangles (the torn
/// surface is then the grid's).
#[derive(Debug, thiserror::Error)]
pub(super) enum EmbedError {
    /// No input triangle lies near the tear's border.
    #[error("the input has no triangle near the tear")]
    NoTriangleNear,
    /// The border cannot be imprinted.
    #[error("the tear's border cannot be cut into the input: {0}")]
    Cut(MeshError),
    /// An input vertex outside the grid the solid was embedded in.
    #[error("input vertex {vertex} lies outside the solid's grid")]
    OutsideGrid {
        /// The vertex.
        vertex: u32,
    },
    /// The moved positions do not fit the cut mesh.
    #[error(transparent)]
    Move(MeshError),
}

/// The input of `e` cut along the tear of `d` (surface `s`) and moved by
/// its deformation.
///
/// # Errors
/// A message when the tear's border cannot be cut into the input or a
/// vertex of the input lies outside the solid's grid.
pub(super) fn embed(e: &SimEntry, d: &Ductile, s: &TornSurface) -> Result<Embedded, EmbedError> {
    let base = &e.sim;
    let input = Faces::of_mesh(base);
    // The border's vertices on the input at rest.
    let edges = border_edges(s);
    let mut on_input: HashMap<u32, [f64; 3]> = HashMap::new();
    for &(a, b) in &edges {
        for v in [a, b] {
            if let std::collections::hash_map::Entry::Vacant(slot) = on_input.entry(v) {
                let r = d.to_scene(s.rest[v as usize]);
                let (_, _, q) = input.closest(r).ok_or(EmbedError::NoTriangleNear)?;
                slot.insert(q);
            }
        }
    }
    smooth_border(&mut on_input, &edges, &input);
    let segments: Vec<[[f64; 3]; 2]> = edges
        .iter()
        .map(|(a, b)| [on_input[a], on_input[b]])
        .filter(|[p, q]| p != q)
        .collect();
    let (mut cut, skipped) = if segments.is_empty() {
        (base.clone(), 0)
    } else {
        let n = base.n_vertices();
        let im = crate::mesh::imprint::imprint(
            base,
            base,
            &segments,
            &vec![0.0; segments.len()],
            &vec![[0.0; 3]; n],
            &vec![f64::NAN; n],
            &[],
        )
        .map_err(EmbedError::Cut)?;
        (im.mesh, im.skipped)
    };
    let loc = Locator::new(d);
    let metres = |p: [f64; 3]| d.to_metres(p);
    let piece = pieces(&cut, d, s, &loc);
    let dropped = piece.iter().filter(|p| p.is_none()).count();
    // Each vertex moved by a tetrahedron of its own piece: the one the
    // nearest vertex of that piece's grid surface was cut from (a
    // tetrahedron holding the vertex may reach across the tear, its corners
    // on both sides, and would pull the vertex towards the other piece).
    let nearest = PieceVertices::new(d, s);
    let mut vertex_piece: Vec<Option<u32>> = vec![None; cut.n_vertices()];
    for f in cut.faces() {
        if let Some(k) = piece[f.idx()] {
            for v in cut.face_vertices(f) {
                vertex_piece[v.idx()].get_or_insert(k);
            }
        }
    }
    let mut tet_of: Vec<usize> = Vec::with_capacity(cut.n_vertices());
    let mut moved = Vec::with_capacity(cut.n_vertices());
    for v in cut.vertices() {
        let at = cut.position(v);
        let own = vertex_piece[v.idx()].and_then(|k| nearest.tet(k, at));
        let t = own
            .or_else(|| loc.locate(metres(at)))
            .ok_or(EmbedError::OutsideGrid { vertex: v.0 })?;
        tet_of.push(t);
        moved.push(d.to_scene(d.deform(t, metres(at))));
    }
    let mut border: HashMap<u32, [f64; 3]> = on_input
        .iter()
        .map(|(&v, &q)| {
            let piece = nearest.piece_of(v);
            let t = piece
                .and_then(|k| nearest.tet(k, q))
                .unwrap_or(s.tet_of[v as usize] as usize);
            (v, d.to_scene(d.deform(t, metres(q))))
        })
        .collect();
    // The cut's vertices onto the torn faces' border: each where it lies
    // along its border segment at rest, so the two meet without a gap.
    let cube = dist2(d.to_scene([d.grid.h, 0.0, 0.0]), d.to_scene([0.0; 3])).sqrt();
    let seam = Seam::new(&edges, &on_input, &nearest, cube);
    let on_seam: Vec<(usize, (u32, u32, f64))> = cut
        .vertices()
        .filter(|&v| vertex_piece[v.idx()].is_some() && cut.is_boundary_vertex(v))
        .filter_map(|v| {
            seam.on(cut.position(v), cube, vertex_piece[v.idx()])
                .map(|hit| (v.idx(), hit))
        })
        .collect();
    // An input vertex the cut runs through stays where the deformation
    // puts it, and the torn border's nearer end moves to it ...
    for &(v, (a, b, t)) in &on_seam {
        if cut.vertex_source(crate::mesh::VertexId(v as u32)).is_some() {
            border.insert(if t < 0.5 { a } else { b }, moved[v]);
        }
    }
    // ... and a vertex the cut made lies on the torn border.
    for &(v, (a, b, t)) in &on_seam {
        if cut.vertex_source(crate::mesh::VertexId(v as u32)).is_none() {
            let (p, q) = (border[&a], border[&b]);
            moved[v] = [0, 1, 2].map(|k| p[k] + t * (q[k] - p[k]));
        }
    }
    // Normals and tangents turned by each vertex's deformation.
    turn_attributes(&mut cut, d, &tet_of);
    cut.set_positions(&moved).map_err(EmbedError::Move)?;
    Ok(Embedded {
        cut,
        piece,
        border,
        dropped,
        skipped,
    })
}

/// Each face of `cut` (the input cut along the tear's border): the piece
/// it belongs to, by the torn surface's original triangles nearest its
/// connected component (an area-weighted vote), or none where the tear
/// opened the material under most of the component.
fn pieces(cut: &SimMesh, d: &Ductile, s: &TornSurface, loc: &Locator) -> Vec<Option<u32>> {
    let metres = |p: [f64; 3]| d.to_metres(p);
    // Faces the tear opened: the material under them is gone.
    let depth = 0.5 * d.grid.h;
    let (n_comp, comp) = cut.connected_components();
    let mut open_area = vec![0.0; n_comp];
    let mut area = vec![0.0; n_comp];
    for f in cut.faces() {
        let a = cut.face_area(f);
        let n = cut.face_normal(f);
        let c = centroid(cut, f);
        let probe = metres(c);
        let probe = [0, 1, 2].map(|k| probe[k] - depth * n[k]);
        let k = comp[f.idx()] as usize;
        area[k] += a;
        if loc.phi(probe) > 0.0 {
            open_area[k] += a;
        }
    }
    // The pieces: by the torn surface's original triangles nearest each
    // component's faces (area-weighted vote).
    let original: Vec<usize> = (0..s.triangles.len()).filter(|&t| !s.torn[t]).collect();
    let grid_surface = Faces::new(
        s.rest.iter().map(|&p| d.to_scene(p)).collect(),
        original.iter().map(|&t| s.triangles[t]).collect(),
    );
    let mut votes: Vec<std::collections::BTreeMap<u32, f64>> = vec![Default::default(); n_comp];
    for f in cut.faces() {
        let k = comp[f.idx()] as usize;
        if open_area[k] > 0.5 * area[k] {
            continue;
        }
        if let Some((t, _, _)) = grid_surface.closest(centroid(cut, f)) {
            *votes[k].entry(s.piece[original[t]]).or_default() += cut.face_area(f);
        }
    }
    let piece_of_comp: Vec<Option<u32>> = votes
        .iter()
        .enumerate()
        .map(|(k, v)| {
            if open_area[k] > 0.5 * area[k] {
                return None;
            }
            v.iter()
                .max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(a.0)))
                .map(|(&p, _)| p)
                .or(Some(0))
        })
        .collect();
    cut.faces()
        .map(|f| piece_of_comp[comp[f.idx()] as usize])
        .collect()
}

/// Passes of [`smooth_border`].
const BORDER_SMOOTHING: usize = 6;

/// Smooth the border's vertices along the border (each to halfway towards
/// its neighbours' middle), then put them back onto the input: the grid's
/// border zig-zags across its cubes, and the input is cut along it.
fn smooth_border(at: &mut HashMap<u32, [f64; 3]>, edges: &[(u32, u32)], input: &Faces) {
    let mut near: std::collections::BTreeMap<u32, Vec<u32>> = Default::default();
    for &(a, b) in edges {
        near.entry(a).or_default().push(b);
        near.entry(b).or_default().push(a);
    }
    for _ in 0..BORDER_SMOOTHING {
        let moved: Vec<(u32, [f64; 3])> = near
            .iter()
            // Only along a chain: where borders meet, a vertex stays.
            .filter(|(_, n)| n.len() == 2)
            .map(|(&v, n)| {
                let (p, a, b) = (at[&v], at[&n[0]], at[&n[1]]);
                (v, [0, 1, 2].map(|k| 0.5 * p[k] + 0.25 * (a[k] + b[k])))
            })
            .collect();
        for (v, q) in moved {
            at.insert(v, q);
        }
    }
    // Back onto the input once: where the border ran along a crease,
    // zig-zagging from one side to the other, it now lies on the crease.
    for p in at.values_mut() {
        if let Some((_, _, q)) = input.closest(*p) {
            *p = q;
        }
    }
}

/// A border segment: its ends (grid-surface vertices), their places on the
/// input at rest, and its piece.
type Segment = (u32, u32, [f64; 3], [f64; 3], Option<u32>);

/// The border's segments at rest, for finding the one a point lies on.
struct Seam {
    segments: Vec<Segment>,
    grid: Grid,
}

impl Seam {
    fn new(
        edges: &[(u32, u32)],
        at: &HashMap<u32, [f64; 3]>,
        pieces: &PieceVertices,
        cube: f64,
    ) -> Seam {
        let segments: Vec<_> = edges
            .iter()
            .map(|&(a, b)| (a, b, at[&a], at[&b], pieces.piece_of(a)))
            .collect();
        let grid = Grid::new(segments.iter().map(|&(_, _, p, q, _)| bbox(&[p, q])), cube);
        Seam { segments, grid }
    }

    /// The segment of piece `piece` nearest `p` within `reach`, and where
    /// along it `p` lies (0 at its first end, 1 at its second).
    fn on(&self, p: [f64; 3], reach: f64, piece: Option<u32>) -> Option<(u32, u32, f64)> {
        let mut best: Option<(f64, usize, f64)> = None;
        self.grid.search(p, |i| {
            let (_, _, a, b, k) = self.segments[i];
            if k != piece {
                return best.map(|b| b.0);
            }
            let ab = [0, 1, 2].map(|k| b[k] - a[k]);
            let len2 = ab.iter().map(|x| x * x).sum::<f64>();
            let t = if len2 > 0.0 {
                ((0..3).map(|k| (p[k] - a[k]) * ab[k]).sum::<f64>() / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let c = [0, 1, 2].map(|k| a[k] + t * ab[k]);
            let d = dist2(p, c);
            if best.is_none_or(|b| d < b.0 || (d == b.0 && i < b.1)) {
                best = Some((d, i, t));
            }
            best.map(|b| b.0)
        });
        best.filter(|b| b.0 <= reach * reach).map(|(_, i, t)| {
            let (a, b, _, _, _) = self.segments[i];
            (a, b, t)
        })
    }
}

/// The grid surface's vertices per piece, for the nearest one's
/// tetrahedron.
struct PieceVertices<'a> {
    s: &'a TornSurface,
    /// Per vertex of the grid surface: its piece.
    piece: Vec<Option<u32>>,
    /// Per piece: its vertices (scene units at rest) and a grid over them.
    pieces: Vec<(Vec<u32>, Vec<[f64; 3]>, Grid)>,
}

impl<'a> PieceVertices<'a> {
    fn new(d: &Ductile, s: &'a TornSurface) -> PieceVertices<'a> {
        let mut piece = vec![None; s.rest.len()];
        for (t, &k) in s.triangles.iter().zip(&s.piece) {
            for &v in t {
                piece[v as usize].get_or_insert(k);
            }
        }
        // A grid cube in scene units.
        let cube = dist2(d.to_scene([d.grid.h, 0.0, 0.0]), d.to_scene([0.0; 3])).sqrt();
        let pieces = (0..s.pieces as u32)
            .map(|k| {
                let ids: Vec<u32> = (0..s.rest.len() as u32)
                    .filter(|&v| piece[v as usize] == Some(k))
                    .collect();
                let at: Vec<[f64; 3]> = ids
                    .iter()
                    .map(|&v| d.to_scene(s.rest[v as usize]))
                    .collect();
                let grid = Grid::new(at.iter().map(|&p| (p, p)), cube);
                (ids, at, grid)
            })
            .collect();
        PieceVertices { s, piece, pieces }
    }

    fn piece_of(&self, v: u32) -> Option<u32> {
        self.piece.get(v as usize).copied().flatten()
    }

    /// The tetrahedron piece `k`'s grid-surface vertex nearest `p` (scene
    /// units) was cut from.
    fn tet(&self, k: u32, p: [f64; 3]) -> Option<usize> {
        let (ids, at, grid) = self.pieces.get(k as usize)?;
        let mut best: Option<(f64, usize)> = None;
        grid.search(p, |i| {
            let d = dist2(p, at[i]);
            if best.is_none_or(|b| d < b.0 || (d == b.0 && i < b.1)) {
                best = Some((d, i));
            }
            best.map(|b| b.0)
        });
        best.map(|(_, i)| self.s.tet_of[ids[i] as usize] as usize)
    }
}

fn centroid(m: &SimMesh, f: FaceId) -> [f64; 3] {
    let [a, b, c] = m.face_vertices(f).map(|v| m.position(v));
    [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)
}

/// `NORMAL` by `F^-T`, `TANGENT` by `F`, of each wedge's vertex's
/// tetrahedron.
fn turn_attributes(cut: &mut SimMesh, d: &Ductile, tet_of: &[usize]) {
    let corners: Vec<(usize, usize)> = cut
        .faces()
        .flat_map(|f| {
            let vs = cut.face_vertices(f);
            let ws = cut.face_wedges(f);
            (0..3).map(move |k| (ws[k].idx(), vs[k].idx()))
        })
        .collect();
    for (name, inverse) in [("NORMAL", true), ("TANGENT", false)] {
        let Some(c) = cut.wedges().channel(name).map(|c| c.components) else {
            continue;
        };
        if c < 3 {
            continue;
        }
        let Some(values) = cut.wedge_values_mut(name) else {
            continue;
        };
        let mut done = vec![false; values.len() / c];
        for &(w, v) in &corners {
            if done[w] {
                continue;
            }
            done[w] = true;
            let f = d.deformation(tet_of[v]);
            let m = if inverse {
                f.try_inverse().map_or(f, |i| i.transpose())
            } else {
                f
            };
            let x = &mut values[w * c..w * c + 3];
            let t = m * nalgebra::Vector3::new(x[0], x[1], x[2]);
            if let Some(u) = t.try_normalize(1e-30) {
                x.copy_from_slice(&[u[0], u[1], u[2]]);
            }
        }
    }
}
