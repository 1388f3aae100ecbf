//! The statistics of a crack pattern: cells, their size, crack density,
//! junctions and their angles, open tips, crack orientations, cracks along
//! the input's edges and paired parallel cracks. `crackle stats` prints
//! them for an output file; tests use them to check patterns.
//!
//! A pattern ([`PatternInput`]) is a surface (triangles welded by
//! position), its crack network (a graph of line segments) and the edges of
//! the surface the cracks cut. **Cells** are the regions the cracks and the
//! surface's border enclose on the surface: its faces joined across every
//! edge that is not cut; their areas are the surface's. **Degrees, open
//! tips, junction angles, orientations, lengths and pairs** come from the
//! crack graph alone: the lines' ends welded within a millionth of the
//! pattern's size (its bounding-box diagonal), each segment split where
//! another segment's end lies on it (a crack ending on an earlier one whose
//! segment was written whole). An end of degree 1 is an open tip unless it
//! lies within that millionth of the surface's border.
//!
//! Reading an output ([`PatternInput::from_scene`]), each mesh's crack
//! lines (its LINES primitives) are one of three kinds:
//!
//! - **Opened** (the lines carry `_CRACK_REST`: outputs cut and opened into
//!   gaps, as mud): the surface is cut along the cracks already and its
//!   sides moved apart. Its triangles (welded by exact position, the
//!   `crack_wall` faces left out) fall apart into the cells but where a
//!   gap's sides still meet (at its tips); the cuts are the edges the walls
//!   hang from and those still on the network at rest or on a line as
//!   drawn (a crack shut off its rest position). The crack graph is
//!   the network at rest (`_CRACK_REST`, on the uncut surface). The border
//!   is that of the surface and its walls together (not the gaps' own
//!   outlines), and a crack end whose gap does not close (the end is no
//!   vertex of the surface: its sides moved apart) reached it.
//! - **Cut in place** (every line segment is an edge of the surface): the
//!   cells are separated along the lines.
//! - **Kept** (else: the input's own triangles came back uncut, the lines
//!   lying on them across their faces): the lines are cut into a copy of
//!   the surface ([`crate::mesh::imprint::imprint`]), and the cells
//!   separated along the cut.
//!
//! Lengths are in the surface's units (mesh-local coordinates). Every
//! search is a lookup in a uniform grid within a distance, so the work is
//! about linear in the surface and the lines.

mod graph;
pub mod impact;
mod sides;

pub use impact::{impact_stats, ImpactStats};

use crate::math::v3::{add, cross, dot, norm, scale, sub};
use crate::mesh::spatial::{bbox, closest_on_segment, position_key as key};
use crate::mesh::{MeshInput, SimMesh, WeldOptions};
use crate::scene::{Geometry, Scene};
use graph::{line_graph, Buckets, Welder};
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap, HashSet};

/// A line segment.
type Seg = [[f64; 3]; 2];

/// Tolerances (welding, on the border, on an edge) relative to the size
/// of the pattern or reference: its bounding-box diagonal.
const TOLERANCE: f64 = 1e-6;

/// How far (relative to the diagonal) a crack end may lie off the
/// reference's border and still end on it: the network was simulated on a
/// surface whose border is a chain of chords of the reference's, and a
/// crack meets it anywhere along a chord (on the teapot's rims, up to
/// 2e-4 of the diagonal off the curved border).
const BORDER_SAG: f64 = 1e-3;

/// A surface, its crack graph and its cuts; see the module documentation.
#[derive(Clone, Debug, Default)]
pub struct PatternInput {
    /// Vertex positions: the surface's, and the crack graph's nodes (which
    /// may or may not be vertices of the surface).
    pub positions: Vec<[f64; 3]>,
    /// The surface's triangles (indices into `positions`).
    pub triangles: Vec<[u32; 3]>,
    /// The crack graph's edges (indices into `positions`).
    pub cracks: Vec<[u32; 2]>,
    /// Edges of the triangles the cells are separated along, besides the
    /// cracks that are edges of the triangles.
    pub cuts: Vec<[u32; 2]>,
    /// The surface's border, where crack ends are not open tips (a point as
    /// a segment of length 0); empty: the triangles' edges with one face
    /// that are not cut.
    pub border: Vec<[[f64; 3]; 2]>,
    /// What could not be read as asked (lines that could not be cut into
    /// the surface), for the user.
    pub notes: Vec<String>,
}

/// Edges of an input surface: the share of crack length along them, and
/// its border for open tips.
pub struct ReferenceEdges {
    segments: Vec<Seg>,
    grid: Buckets,
    boundary: Vec<Seg>,
    eps: f64,
}

impl ReferenceEdges {
    /// The edges of the triangles `triangles` over `positions`.
    pub fn new(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> ReferenceEdges {
        let mut edges: Vec<(u32, u32)> = triangles.iter().flat_map(edges_of).collect();
        edges.sort_unstable();
        let (mut segments, mut boundary) = (Vec::new(), Vec::new());
        for run in edges.chunk_by(|a, b| a == b) {
            segments.push([positions[run[0].0 as usize], positions[run[0].1 as usize]]);
            if run.len() == 1 {
                boundary.push(segments[segments.len() - 1]);
            }
        }
        let eps = TOLERANCE * diagonal(positions);
        let grid = Buckets::of_segments(&segments, mean_length(&segments).max(4.0 * eps));
        ReferenceEdges {
            segments,
            grid,
            boundary,
            eps,
        }
    }

    /// The share of the length of `cracks` (over `pos`) along the edges:
    /// each segment's length times the share of 8 points spread along it
    /// that lie on an edge parallel to it.
    fn share(&self, pos: &[[f64; 3]], cracks: &[[u32; 2]]) -> f64 {
        let (mut along, mut total) = (0.0, 0.0);
        for [a, b] in cracks.iter().map(|c| c.map(|v| pos[v as usize])) {
            let l = dist(a, b);
            let on_edge = |k: &usize| {
                let p = add(a, scale(sub(b, a), (*k as f64 + 0.5) / 8.0));
                self.grid.near(p, self.eps, |i| {
                    let [s, t] = self.segments[i];
                    dot(sub(b, a), sub(t, s)).abs() >= (1.0 - 1e-6) * l * dist(s, t)
                        && dist(closest_on_segment(p, s, t), p) <= self.eps
                })
            };
            along += l * (0..8).filter(on_edge).count() as f64 / 8.0;
            total += l;
        }
        along / total.max(f64::MIN_POSITIVE)
    }
}

/// The statistics of a pattern.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct PatternStats {
    /// Surface area (of the output's surface as it lies; walls left out).
    pub area: f64,
    /// Total length of the crack graph.
    pub crack_length: f64,
    /// Crack length per area.
    pub crack_length_per_area: f64,
    /// `2 * area / crack_length`: the spacing of parallel cracks that would
    /// give this density over the whole surface.
    pub spacing: f64,
    /// Regions of the surface the cracks and its border enclose (see the
    /// module documentation), each above a billionth of the area.
    pub cells: usize,
    /// Mean equivalent-circle diameter `sqrt(4 A / pi)` of the cells.
    pub mean_cell_diameter: f64,
    /// Cell areas at the 10, 25, 50, 75 and 90 percentiles.
    pub cell_area_quantiles: [f64; 5],
    /// Nodes of the crack graph by degree: where 1, 2, 3 and 4 or more
    /// crack segments meet.
    pub degree: [usize; 4],
    /// Open crack ends: nodes of degree 1 of the crack graph off the
    /// surface's border (the input's border when a reference is given).
    pub dangling_tips: usize,
    /// Degree-3 junctions with one angle above 150 degrees.
    pub t_junctions: usize,
    /// Degree-3 junctions with every angle within 90..150 degrees.
    pub y_junctions: usize,
    /// `t_junctions` over all degree-3 junctions (0 without any).
    pub t_share: f64,
    /// `y_junctions` over all degree-3 junctions (0 without any): under a
    /// tenth for a first drying, over a half for aged mud.
    pub y_share: f64,
    /// Angles at degree-3 junctions (in the plane of the surface where the
    /// node is a vertex of it, else of the crack directions), histogram of
    /// 12 bins of 15 degrees over 0..180.
    pub junction_angles: [usize; 12],
    /// The most crack segments meeting at one node.
    pub max_degree: usize,
    /// The mean number of sides of the cells the cracks enclose off the
    /// border: their corners, the junctions where the inside angle is below
    /// 150 degrees (about 4 for a first drying's T-junctions, 6 for aged mud).
    pub mean_cell_sides: f64,
    /// How many cells `mean_cell_sides` is over.
    pub sided_cells: usize,
    /// Crack length by orientation in the plane of the two largest
    /// bounding-box extents: 6 bins of 30 degrees over 0..180, as
    /// fractions of the crack length.
    pub orientation: [f64; 6],
    /// The share of crack length along the reference edges, when given
    /// (the crack graph at rest for opened outputs).
    pub along_reference_edges: Option<f64>,
    /// The share of crack length with another crack parallel to it (within
    /// 20 degrees) closer than `paired_distance` to its middle, not counting
    /// cracks joined to it within `2 * paired_distance` along the graph.
    pub paired: f64,
    /// The distance `paired` used: a quarter of the median equivalent-circle
    /// diameter of the cells enclosed by cracks (cells with a crack on
    /// their outline and none of the surface's border; when every cell
    /// touches the border, of all cells with a crack on their outline; when
    /// the cracks separate no cells, a quarter of `spacing`). So a pattern
    /// covering part of the surface is paired at its own cells' size, not
    /// at its density over the whole surface.
    pub paired_distance: f64,
}

impl PatternInput {
    /// A cracked simulation mesh's pattern: its vertices welded by
    /// position, its crack edges the cracks.
    pub fn from_sim_mesh(mesh: &SimMesh) -> PatternInput {
        let mut w = Welder::default();
        let ids: Vec<u32> = mesh.positions().iter().map(|p| w.id(*p)).collect();
        let id = |v: crate::mesh::VertexId| ids[v.idx()];
        let triangles = mesh
            .faces()
            .map(|f| mesh.face_vertices(f).map(id))
            .collect();
        let mut cracks: Vec<[u32; 2]> = mesh
            .halfedges()
            .filter(|&h| mesh.is_crack_halfedge(h))
            .map(|h| [id(mesh.origin(h)), id(mesh.dest(h))])
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        cracks.sort_unstable();
        cracks.dedup();
        PatternInput {
            positions: w.positions,
            triangles,
            cracks,
            ..Default::default()
        }
    }

    /// The pattern of a crackle output: every mesh's surface (mesh-local
    /// coordinates), its crack lines and its cuts, each mesh read as the
    /// module documentation says.
    pub fn from_scene(scene: &Scene) -> PatternInput {
        let mut out = PatternInput::default();
        for mesh in &scene.meshes {
            let name = mesh.name.as_deref().unwrap_or("");
            let part = MeshParts::read(scene, mesh).pattern(name);
            let base = out.positions.len() as u32;
            let shift = |e: &[u32; 2]| e.map(|v| v + base);
            out.positions.extend(part.positions);
            out.triangles
                .extend(part.triangles.iter().map(|t| t.map(|v| v + base)));
            out.cracks.extend(part.cracks.iter().map(shift));
            out.cuts.extend(part.cuts.iter().map(shift));
            out.border.extend(part.border);
            out.notes.extend(part.notes);
        }
        out
    }
}

/// One mesh of an output as read: its triangles welded by exact position,
/// its crack lines where they lie and at rest (`_CRACK_REST`, else where
/// they lie), and whether any carried `_CRACK_REST`.
#[derive(Default)]
struct MeshParts {
    welder: Welder,
    surface: Vec<[u32; 3]>,
    walls: Vec<[u32; 3]>,
    lines: Vec<Seg>,
    rest: Vec<Seg>,
    opened: bool,
}

impl MeshParts {
    fn read(scene: &Scene, mesh: &crate::scene::Mesh) -> MeshParts {
        let mut m = MeshParts::default();
        for p in &mesh.primitives {
            let material = p.material.and_then(|i| scene.materials.get(i));
            let name = material.and_then(|i| i.json.get("name")?.as_str());
            match &p.geometry {
                Geometry::Triangles(t) => {
                    let ids: Vec<u32> = t
                        .positions
                        .iter()
                        .map(|q| m.welder.id(q.map(f64::from)))
                        .collect();
                    let tris = t.triangles.iter().map(|x| x.map(|v| ids[v as usize]));
                    match name {
                        Some("crack_wall") => m.walls.extend(tris),
                        _ => m.surface.extend(tris),
                    }
                }
                Geometry::Raw(r) if r.mode == crate::scene::mode::LINES => {
                    let Some(lines) = line_segments(scene, r, "POSITION") else {
                        continue;
                    };
                    let rest =
                        line_segments(scene, r, "_CRACK_REST").filter(|s| s.len() == lines.len());
                    m.opened |= rest.is_some();
                    m.rest.extend(rest.unwrap_or_else(|| lines.clone()));
                    m.lines.extend(lines);
                }
                _ => {}
            }
        }
        m
    }

    /// The mesh's pattern; `name` for notes.
    fn pattern(self, name: &str) -> PatternInput {
        let surface = &self.welder.positions;
        let points: Vec<[f64; 3]> = self.rest.iter().flatten().copied().collect();
        let tol = TOLERANCE * diagonal(&[surface.as_slice(), &points].concat());
        // Faces on each edge: (surface, walls); the border has one in all.
        let mut on_edge: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
        for (tris, wall) in [(&self.surface, 0), (&self.walls, 1)] {
            for e in tris.iter().flat_map(edges_of) {
                let c = on_edge.entry(e).or_default();
                (c.0, c.1) = (c.0 + 1 - wall, c.1 + wall);
            }
        }
        let mut border_edges: Vec<&(u32, u32)> = on_edge
            .iter()
            .filter(|(_, c)| c.0 + c.1 == 1)
            .map(|(e, _)| e)
            .collect();
        border_edges.sort_unstable();
        let at = |v: u32| surface[v as usize];
        let mut border: Vec<Seg> = border_edges.iter().map(|e| [at(e.0), at(e.1)]).collect();
        let (nodes, edges, first) = line_graph(&points, tol);
        let segs: Vec<Seg> = edges.iter().map(|e| e.map(|v| nodes[v as usize])).collect();
        // Is every line segment an edge of the surface?
        let vertex = |v: u32| self.welder.map.get(&key(nodes[v as usize])).copied();
        let in_place: Option<Vec<[u32; 2]>> = edges
            .iter()
            .map(|e| {
                let (a, b) = (vertex(e[0])?, vertex(e[1])?);
                let c = on_edge.get(&(a.min(b), a.max(b)))?;
                (c.0 > 0).then_some([a.min(b), a.max(b)])
            })
            .collect();
        let (mut notes, mut cut_surface) = (Vec::new(), None);
        let cuts = if self.opened {
            // Ends whose gap does not close (no vertex of the surface)
            // reached the border.
            let mut degree = vec![0u32; nodes.len()];
            edges
                .iter()
                .flatten()
                .for_each(|&v| degree[v as usize] += 1);
            for (n, &d) in degree.iter().enumerate() {
                let end = self.lines[first[n] / 2][first[n] % 2];
                if d == 1 && !self.welder.map.contains_key(&key(end)) {
                    border.push([nodes[n]; 2]);
                }
            }
            opened_cuts(
                surface,
                &on_edge,
                &[segs.as_slice(), &self.lines].concat(),
                tol,
            )
        } else if let Some(cracks) = in_place {
            return PatternInput {
                positions: self.welder.positions,
                triangles: self.surface,
                cracks,
                border,
                ..Default::default()
            };
        } else {
            match cut_in(surface, &self.surface, &segs) {
                Ok(p) => cut_surface.insert(p).cracks.clone(),
                Err(err) => {
                    notes.push(format!(
                        "mesh '{name}': its crack lines could not be cut into its surface \
                         ({err}); its cells are the surface's own pieces"
                    ));
                    Vec::new()
                }
            }
        };
        let s = cut_surface.unwrap_or(PatternInput {
            positions: self.welder.positions,
            triangles: self.surface,
            ..Default::default()
        });
        let base = s.positions.len() as u32;
        PatternInput {
            positions: [s.positions.as_slice(), &nodes].concat(),
            triangles: s.triangles,
            cracks: edges.iter().map(|e| e.map(|v| v + base)).collect(),
            cuts,
            border,
            notes,
        }
    }
}

/// The cuts of an opened surface (`on_edge`: its edges' faces, surface and
/// walls): the edges walls hang from, and those lying on `segs` within
/// `tol`: the network at rest (where a gap did not open) and the lines as
/// drawn (where a crack was shut off its rest position: its sides'
/// vertices moved together, and the line runs over them).
fn opened_cuts(
    surface: &[[f64; 3]],
    on_edge: &HashMap<(u32, u32), (u32, u32)>,
    segs: &[Seg],
    tol: f64,
) -> Vec<[u32; 2]> {
    let grid = Buckets::of_segments(segs, mean_length(segs).max(4.0 * tol));
    let on = |p| {
        grid.near(p, tol, |i| {
            dist(closest_on_segment(p, segs[i][0], segs[i][1]), p) <= tol
        })
    };
    let mut cuts: Vec<[u32; 2]> = on_edge
        .iter()
        .filter(|&(&(a, b), c)| {
            let (p, q) = (surface[a as usize], surface[b as usize]);
            c.0 > 0 && (c.1 > 0 || on(p) && on(q) && on(scale(add(p, q), 0.5)))
        })
        .map(|(e, _)| [e.0, e.1])
        .collect();
    cuts.sort_unstable();
    cuts
}

/// The segments of a LINES primitive's VEC3 attribute `semantic`.
fn line_segments(scene: &Scene, r: &crate::scene::RawGeometry, semantic: &str) -> Option<Vec<Seg>> {
    let decode = |i: usize| crate::io::accessor::decode_raw(scene.accessors.get(i)?);
    let pos = decode(*r.attributes.get(semantic)?)
        .filter(|(c, _)| *c == 3)?
        .1;
    let n = pos.len() / 3;
    let idx: Vec<usize> = match r.indices {
        Some(i) => match decode(i)? {
            (1, v) => v.into_iter().map(|x| x as usize).collect(),
            _ => return None,
        },
        None => (0..n).collect(),
    };
    let p = |i: usize| [pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]];
    let ok = |s: &&[usize]| s[0] < n && s[1] < n;
    Some(
        idx.chunks_exact(2)
            .filter(ok)
            .map(|s| [p(s[0]), p(s[1])])
            .collect(),
    )
}

/// The surface `positions`/`triangles` with the segments `segments` (on
/// it) cut in: [`crate::mesh::imprint::imprint`] with the surface as both
/// meshes, zero displacements and no times.
fn cut_in(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    segments: &[Seg],
) -> Result<PatternInput, crate::mesh::MeshError> {
    let input = MeshInput {
        positions: positions.to_vec(),
        triangles: triangles.to_vec(),
        ..Default::default()
    };
    let exact = WeldOptions {
        relative_tolerance: 0.0,
    };
    let (base, _) = SimMesh::build(&input, &exact)?;
    let (n, nan) = (base.n_vertices(), vec![f64::NAN; segments.len()]);
    let zero = vec![[0.0; 3]; n];
    let im = crate::mesh::imprint::imprint(
        &base,
        &base,
        segments,
        &nan,
        &zero,
        &vec![f64::NAN; n],
        &[],
    )?;
    Ok(PatternInput::from_sim_mesh(&im.mesh))
}

/// A cell: its area, whether a cut lies on its outline, and whether the
/// surface's border does.
type Cell = (f64, bool, bool);

/// The cells of `input` (above a billionth of the area), the surface's
/// area, and its border edges (with one face, not cut).
fn cells(input: &PatternInput) -> (Vec<Cell>, f64, Vec<Seg>) {
    let pos = &input.positions;
    let pair = |c: &[u32; 2]| (c[0].min(c[1]), c[0].max(c[1]));
    let cut: HashSet<(u32, u32)> = input.cracks.iter().chain(&input.cuts).map(pair).collect();
    let nf = input.triangles.len();
    let mut edges: Vec<((u32, u32), u32)> = Vec::with_capacity(3 * nf);
    for (f, t) in input.triangles.iter().enumerate() {
        edges.extend(edges_of(t).map(|e| (e, f as u32)));
    }
    edges.sort_unstable();
    let mut parent: Vec<u32> = (0..nf as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    let (mut on_cut, mut on_border, mut border) = (vec![false; nf], vec![false; nf], Vec::new());
    for run in edges.chunk_by(|x, y| x.0 == y.0) {
        let (a, b) = run[0].0;
        if cut.contains(&(a, b)) {
            run.iter().for_each(|e| on_cut[e.1 as usize] = true);
            continue;
        }
        if run.len() == 1 {
            on_border[run[0].1 as usize] = true;
            border.push([pos[a as usize], pos[b as usize]]);
        }
        for w in run.windows(2) {
            let (x, y) = (find(&mut parent, w[0].1), find(&mut parent, w[1].1));
            parent[x.max(y) as usize] = x.min(y);
        }
    }
    let mut cell: Vec<Cell> = vec![(0.0, false, false); nf];
    let mut area = 0.0;
    for (f, t) in input.triangles.iter().enumerate() {
        let p = t.map(|v| pos[v as usize]);
        let a = 0.5 * norm(cross(sub(p[1], p[0]), sub(p[2], p[0])));
        let c = &mut cell[find(&mut parent, f as u32) as usize];
        area += a;
        *c = (c.0 + a, c.1 | on_cut[f], c.2 | on_border[f]);
    }
    let roots = (0..nf).filter(|&f| parent[f] == f as u32 && cell[f].0 > 1e-9 * area);
    (roots.map(|f| cell[f]).collect(), area, border)
}

/// The statistics of `input`; see [`PatternStats`]. With `reference` (the
/// input's surface), the share of crack length along its edges, and open
/// tips off its border.
pub fn pattern_stats(input: &PatternInput, reference: Option<&ReferenceEdges>) -> PatternStats {
    let pos = &input.positions;
    let tol = TOLERANCE * diagonal(pos);
    let (cells, area, own_border) = cells(input);
    let mut sorted: Vec<f64> = cells.iter().map(|c| c.0).collect();
    sorted.sort_by(f64::total_cmp);
    let quantile = |q: f64| {
        let i = (q * sorted.len().saturating_sub(1) as f64).round() as usize;
        sorted.get(i).copied().unwrap_or(0.0)
    };
    let diameter = |a: &f64| (4.0 * a / std::f64::consts::PI).sqrt();
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); pos.len()];
    let mut crack_length = 0.0;
    for e in &input.cracks {
        adj[e[0] as usize].push(e[1]);
        adj[e[1] as usize].push(e[0]);
        crack_length += dist(pos[e[0] as usize], pos[e[1] as usize]);
    }
    let mut s = PatternStats {
        area,
        crack_length,
        crack_length_per_area: if area > 0.0 { crack_length / area } else { 0.0 },
        spacing: 2.0 * area / crack_length,
        cells: sorted.len(),
        mean_cell_diameter: sorted.iter().map(diameter).sum::<f64>() / sorted.len().max(1) as f64,
        cell_area_quantiles: [0.1, 0.25, 0.5, 0.75, 0.9].map(quantile),
        ..Default::default()
    };
    let border: &[Seg] = match reference {
        Some(r) => &r.boundary,
        None if !input.border.is_empty() => &input.border,
        None => &own_border,
    };
    let near = match reference {
        Some(_) => BORDER_SAG * diagonal(pos),
        None => tol,
    };
    let grid = Buckets::of_segments(border, mean_length(border).max(4.0 * near));
    let on_border = |p| {
        grid.near(p, near, |i| {
            dist(closest_on_segment(p, border[i][0], border[i][1]), p) <= near
        })
    };
    let normals = vertex_normals(input);
    for (v, near) in adj.iter().enumerate().filter(|(_, a)| !a.is_empty()) {
        s.max_degree = s.max_degree.max(near.len());
        s.degree[(near.len() - 1).min(3)] += 1;
        if near.len() == 1 && !on_border(pos[v]) {
            s.dangling_tips += 1;
        }
        if near.len() == 3 {
            junction(&mut s, pos, v, near, normals[v]);
        }
    }
    let threes = s.degree[2].max(1) as f64;
    (s.t_share, s.y_share) = (s.t_junctions as f64 / threes, s.y_junctions as f64 / threes);
    s.orientation = orientation(pos, &input.cracks, crack_length);
    let arm = 0.1 * s.mean_cell_diameter;
    // A node at rest finds the surface across its opened gap within a cell.
    let nn = sides::node_normals(pos, &normals, &adj, s.mean_cell_diameter.max(near));
    let min_area = 1e-4 * area;
    (s.mean_cell_sides, s.sided_cells) =
        sides::mean_cell_sides(pos, &adj, |v| nn[v], on_border, arm, min_area);
    s.along_reference_edges = reference.map(|r| r.share(pos, &input.cracks));
    // Pairs at a quarter of the cells' own size.
    let enclosed = |c: &&Cell| c.1 && !c.2;
    let mut own: Vec<f64> = if cells.iter().any(|c| enclosed(&c)) {
        cells.iter().filter(enclosed).map(|c| c.0).collect()
    } else if cells.len() > 1 {
        cells.iter().filter(|c| c.1).map(|c| c.0).collect()
    } else {
        Vec::new()
    };
    own.sort_by(f64::total_cmp);
    s.paired_distance = match own.get(own.len().saturating_sub(1) / 2) {
        Some(a) => 0.25 * diameter(a),
        None if s.spacing.is_finite() => 0.25 * s.spacing,
        None => 0.0,
    };
    s.paired = paired_share(pos, &input.cracks, &adj, s.paired_distance, crack_length);
    s
}

/// Each vertex's normal: the sum of its triangles' area-weighted normals
/// (zero at a vertex of no triangle).
fn vertex_normals(input: &PatternInput) -> Vec<[f64; 3]> {
    let pos = &input.positions;
    let mut normals = vec![[0.0; 3]; pos.len()];
    for t in &input.triangles {
        let p = t.map(|v| pos[v as usize]);
        let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        t.iter()
            .for_each(|&v| normals[v as usize] = add(normals[v as usize], n));
    }
    normals
}

/// Count the degree-3 junction at `v` (neighbours `adj`, surface normal
/// `nv`, or zero off the surface: then the plane of its crack directions)
/// into the angle histogram and the T / Y counts.
fn junction(s: &mut PatternStats, pos: &[[f64; 3]], v: usize, adj: &[u32], nv: [f64; 3]) {
    let dirs: Vec<[f64; 3]> = adj.iter().map(|&u| sub(pos[u as usize], pos[v])).collect();
    let planes = [(0, 1), (1, 2), (0, 2)].map(|(i, j)| cross(dirs[i], dirs[j]));
    let widest = planes
        .into_iter()
        .max_by(|a, b| norm(*a).total_cmp(&norm(*b)));
    let nv = if norm(nv) > 0.0 {
        nv
    } else {
        widest.unwrap_or([0.0; 3])
    };
    if norm(nv) == 0.0 {
        return;
    }
    let nv = scale(nv, 1.0 / norm(nv));
    // Directions in the tangent plane, sorted by angle about the normal.
    let t = sub(dirs[0], scale(nv, dot(dirs[0], nv)));
    let e1 = scale(t, 1.0 / norm(t).max(1e-300));
    let e2 = cross(nv, e1);
    let tau = std::f64::consts::TAU;
    let mut ang: Vec<f64> = dirs
        .iter()
        .map(|&d| dot(d, e2).atan2(dot(d, e1)).rem_euclid(tau))
        .collect();
    ang.sort_by(f64::total_cmp);
    let gaps = [ang[1] - ang[0], ang[2] - ang[1], tau - ang[2] + ang[0]].map(f64::to_degrees);
    for g in gaps {
        s.junction_angles[((g / 15.0) as usize).min(11)] += 1;
    }
    if gaps.iter().any(|&g| g > 150.0) {
        s.t_junctions += 1;
    } else if gaps.iter().all(|&g| (90.0..=150.0).contains(&g)) {
        s.y_junctions += 1;
    }
}

/// Crack length by orientation in the plane of the two largest extents.
fn orientation(pos: &[[f64; 3]], cracks: &[[u32; 2]], total: f64) -> [f64; 6] {
    let (lo, hi) = bbox(pos);
    let ext = sub(hi, lo);
    let mut axes = [0usize, 1, 2];
    axes.sort_by(|&a, &b| ext[b].total_cmp(&ext[a]));
    let mut bins = [0.0; 6];
    for c in cracks {
        let d = sub(pos[c[1] as usize], pos[c[0] as usize]);
        let (x, y) = (d[axes[0]], d[axes[1]]);
        if x != 0.0 || y != 0.0 {
            let a = y.atan2(x).to_degrees().rem_euclid(180.0);
            bins[((a / 30.0) as usize).min(5)] += norm(d) / total;
        }
    }
    bins
}

/// The share of crack length with a parallel crack (within 20 degrees)
/// closer than `r` to its middle, not counting cracks joined to it within
/// `2 r` along the crack graph (found by Dijkstra from its ends).
fn paired_share(
    pos: &[[f64; 3]],
    cracks: &[[u32; 2]],
    adj: &[Vec<u32>],
    r: f64,
    total: f64,
) -> f64 {
    if !(r.is_finite() && r > 0.0) || total <= 0.0 {
        return 0.0;
    }
    let segs: Vec<Seg> = cracks.iter().map(|c| c.map(|v| pos[v as usize])).collect();
    let grid = Buckets::of_segments(&segs, mean_length(&segs).max(r));
    let cos20 = 20f64.to_radians().cos();
    // Path lengths from the current segment's ends (the nodes set listed).
    let (mut best, mut touched) = (vec![f64::INFINITY; pos.len()], Vec::new());
    let mut paired = 0.0;
    for (i, &[a, b]) in segs.iter().enumerate() {
        let (d, l, m) = (sub(b, a), dist(a, b), scale(add(a, b), 0.5));
        let mut grown = false;
        let hit = grid.near(m, r, |j| {
            let [p, q] = segs[j];
            let parallel = dot(d, sub(q, p)).abs() >= cos20 * l * dist(p, q);
            if j == i || !parallel || dist(p, q) == 0.0 || dist(closest_on_segment(m, p, q), m) >= r
            {
                return false;
            }
            if !grown {
                for v in touched.drain(..) {
                    best[v as usize] = f64::INFINITY;
                }
                let mut heap: BinaryHeap<Reverse<(u64, u32)>> =
                    cracks[i].iter().map(|&s| Reverse((0u64, s))).collect();
                // Lengths are >= 0: their bits order as they do.
                while let Some(Reverse((bits, v))) = heap.pop() {
                    let dv = f64::from_bits(bits);
                    if best[v as usize] <= dv {
                        continue;
                    }
                    if best[v as usize].is_infinite() {
                        touched.push(v);
                    }
                    best[v as usize] = dv;
                    for &u in &adj[v as usize] {
                        let du = dv + dist(pos[v as usize], pos[u as usize]);
                        if du <= 2.0 * r && du < best[u as usize] {
                            heap.push(Reverse((du.to_bits(), u)));
                        }
                    }
                }
                grown = true;
            }
            cracks[j].iter().all(|&v| best[v as usize].is_infinite())
        });
        paired += if hit && l > 0.0 { l } else { 0.0 };
    }
    paired / total
}

/// The two ends of each edge of triangle `t`, smaller first.
fn edges_of(t: &[u32; 3]) -> impl Iterator<Item = (u32, u32)> + '_ {
    (0..3).map(|k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3])))
}
fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(sub(a, b))
}
fn mean_length(segs: &[Seg]) -> f64 {
    segs.iter().map(|s| dist(s[0], s[1])).sum::<f64>() / segs.len().max(1) as f64
}
/// The bounding-box diagonal of `p` (0 when empty).
fn diagonal(p: &[[f64; 3]]) -> f64 {
    let (lo, hi) = bbox(p);
    if p.is_empty() {
        0.0
    } else {
        dist(lo, hi)
    }
}

#[cfg(test)]
mod tests;
