//! The statistics of a crack pattern: cells, their size, crack density,
//! junctions and their angles, open tips, crack orientations, cracks along
//! the input's edges and paired parallel cracks. `crackle stats` prints
//! them for an output file; tests use them to check patterns.
//!
//! A pattern is a welded triangle surface (a crack's two sides share their
//! vertices) and its crack edges as vertex pairs. Lengths are in the
//! surface's units.

use crate::math::v3::{add, cross, dot, norm, scale, sub};
use crate::mesh::spatial::{closest_on_segment, Grid};
use crate::mesh::SimMesh;
use crate::scene::{Geometry, Scene};
use std::collections::{HashMap, HashSet};

/// A surface and its cracks; see the module documentation.
#[derive(Clone, Debug, Default)]
pub struct PatternInput {
    /// Welded vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Triangles (indices into `positions`).
    pub triangles: Vec<[u32; 3]>,
    /// Crack edges (indices into `positions`).
    pub cracks: Vec<[u32; 2]>,
}

/// Edges of an input surface, for the share of crack length along them.
pub struct ReferenceEdges {
    segments: Vec<[[f64; 3]; 2]>,
    grid: Grid,
    eps: f64,
}

impl ReferenceEdges {
    /// The edges of the triangles `triangles` over `positions`.
    pub fn new(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> ReferenceEdges {
        let mut set: HashSet<(u32, u32)> = HashSet::new();
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                set.insert((a.min(b), a.max(b)));
            }
        }
        let mut edges: Vec<(u32, u32)> = set.into_iter().collect();
        edges.sort_unstable();
        let segments: Vec<[[f64; 3]; 2]> = edges
            .iter()
            .map(|&(a, b)| [positions[a as usize], positions[b as usize]])
            .collect();
        let mean =
            segments.iter().map(|s| dist(s[0], s[1])).sum::<f64>() / segments.len().max(1) as f64;
        let (lo, hi) = bounds(positions);
        let eps = 1e-6 * dist(lo, hi);
        let grid = Grid::new(segments.iter().map(|s| bbox2(s[0], s[1])), mean.max(1e-300));
        ReferenceEdges {
            segments,
            grid,
            eps,
        }
    }

    /// Whether segment `a`-`b` lies along one of the edges.
    fn holds(&self, a: [f64; 3], b: [f64; 3]) -> bool {
        let mid = scale(add(a, b), 0.5);
        let mut found = false;
        self.grid.search(mid, |i| {
            let s = self.segments[i];
            if dist(closest_on_segment(a, s[0], s[1]), a) <= self.eps
                && dist(closest_on_segment(b, s[0], s[1]), b) <= self.eps
            {
                found = true;
                return Some(0.0);
            }
            None
        });
        found
    }
}

/// The statistics of a pattern.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct PatternStats {
    /// Surface area.
    pub area: f64,
    /// Total crack length.
    pub crack_length: f64,
    /// Crack length per area.
    pub crack_length_per_area: f64,
    /// `2 * area / crack_length`: the spacing of parallel cracks that would
    /// give this density.
    pub spacing: f64,
    /// Pieces of the surface the cracks (and the surface's own border)
    /// separate.
    pub cells: usize,
    /// Mean equivalent-circle diameter `sqrt(4 A / pi)` of the cells.
    pub mean_cell_diameter: f64,
    /// Cell areas at the 10, 25, 50, 75 and 90 percentiles.
    pub cell_area_quantiles: [f64; 5],
    /// Junctions by crack degree: vertices where 1, 2, 3 and 4 or more
    /// crack edges meet.
    pub degree: [usize; 4],
    /// Open crack ends off the surface's border (degree 1).
    pub dangling_tips: usize,
    /// Degree-3 junctions with one angle above 150 degrees.
    pub t_junctions: usize,
    /// Degree-3 junctions with every angle within 90..150 degrees.
    pub y_junctions: usize,
    /// Angles at degree-3 junctions, histogram of 12 bins of 15 degrees
    /// over 0..180.
    pub junction_angles: [usize; 12],
    /// The most crack edges meeting at one vertex.
    pub max_degree: usize,
    /// Crack length by orientation in the plane of the two largest
    /// bounding-box extents: 6 bins of 30 degrees over 0..180, as
    /// fractions of the crack length.
    pub orientation: [f64; 6],
    /// The share of crack length along the reference edges, when given.
    pub along_reference_edges: Option<f64>,
    /// The share of crack length with another crack parallel to it (within
    /// 20 degrees) closer than `paired_distance`.
    pub paired: f64,
    /// The distance `paired` used (a quarter of `spacing`).
    pub paired_distance: f64,
}

impl PatternInput {
    /// A cracked simulation mesh's pattern (its vertices welded by position).
    pub fn from_sim_mesh(mesh: &SimMesh) -> PatternInput {
        let mut w = Welder::default();
        let ids: Vec<u32> = mesh.positions().iter().map(|p| w.id(*p)).collect();
        let triangles = mesh
            .faces()
            .map(|f| mesh.face_vertices(f).map(|v| ids[v.idx()]))
            .collect();
        let mut cracks = Vec::new();
        for h in mesh.halfedges() {
            if mesh.is_crack_halfedge(h) {
                let (a, b) = (ids[mesh.origin(h).idx()], ids[mesh.dest(h).idx()]);
                cracks.push([a.min(b), a.max(b)]);
            }
        }
        cracks.sort_unstable();
        cracks.dedup();
        PatternInput {
            positions: w.positions,
            triangles,
            cracks,
        }
    }

    /// The pattern of a crackle output: every mesh's triangles (mesh-local
    /// coordinates; faces of a `crack_wall` material left out) welded by
    /// position, and the crack lines of its LINES primitives.
    pub fn from_scene(scene: &Scene) -> PatternInput {
        let mut out = PatternInput::default();
        for mesh in &scene.meshes {
            let mut w = Welder::default();
            let mut tris = Vec::new();
            let mut cracks = Vec::new();
            for p in &mesh.primitives {
                let wall = p
                    .material
                    .and_then(|m| scene.materials.get(m))
                    .and_then(|m| m.json.get("name"))
                    .and_then(|n| n.as_str())
                    .is_some_and(|n| n == "crack_wall");
                match &p.geometry {
                    Geometry::Triangles(t) if !wall => {
                        let ids: Vec<u32> =
                            t.positions.iter().map(|q| w.id(q.map(f64::from))).collect();
                        tris.extend(t.triangles.iter().map(|x| x.map(|v| ids[v as usize])));
                    }
                    Geometry::Raw(r) if r.mode == crate::scene::mode::LINES => {
                        let Some(pos) = r
                            .attributes
                            .get("POSITION")
                            .and_then(|&i| scene.accessors.get(i))
                            .and_then(crate::io::accessor::decode_raw)
                            .filter(|(c, _)| *c == 3)
                            .map(|(_, v)| v)
                        else {
                            continue;
                        };
                        let n = pos.len() / 3;
                        let idx: Vec<usize> = match r.indices.and_then(|i| scene.accessors.get(i)) {
                            Some(a) => match crate::io::accessor::decode_raw(a) {
                                Some((1, v)) => v.into_iter().map(|x| x as usize).collect(),
                                _ => continue,
                            },
                            None => (0..n).collect(),
                        };
                        for s in idx.chunks_exact(2) {
                            if s[0] < n && s[1] < n {
                                let p = |i: usize| [pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]];
                                cracks.push((p(s[0]), p(s[1])));
                            }
                        }
                    }
                    _ => {}
                }
            }
            let base = out.positions.len() as u32;
            let crack_ids: Vec<[u32; 2]> = cracks
                .into_iter()
                .map(|(a, b)| {
                    let (x, y) = (w.id(a) + base, w.id(b) + base);
                    [x.min(y), x.max(y)]
                })
                .collect();
            out.triangles
                .extend(tris.into_iter().map(|t| t.map(|v| v + base)));
            out.positions.extend(w.positions);
            out.cracks.extend(crack_ids);
        }
        out.cracks = split_at_junctions(&out.positions, out.cracks);
        out.cracks.sort_unstable();
        out.cracks.dedup();
        out.cracks.retain(|c| c[0] != c[1]);
        out
    }
}

/// Split every crack segment at the crack ends lying inside it. A crack
/// that runs into an earlier one ends on it, but the earlier crack's line
/// segment may have been written whole: without the split that junction
/// is an open end, and the earlier crack's two halves there are not crack
/// edges of the surface. "On it" is within a millionth of the pattern's
/// size (line positions are stored in single precision).
fn split_at_junctions(positions: &[[f64; 3]], cracks: Vec<[u32; 2]>) -> Vec<[u32; 2]> {
    let mut count = vec![0u32; positions.len()];
    for c in &cracks {
        count[c[0] as usize] += 1;
        count[c[1] as usize] += 1;
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut total = 0.0;
    for c in &cracks {
        let (a, b) = (positions[c[0] as usize], positions[c[1] as usize]);
        total += dist(a, b);
        for k in 0..3 {
            lo[k] = lo[k].min(a[k]).min(b[k]);
            hi[k] = hi[k].max(a[k]).max(b[k]);
        }
    }
    if cracks.is_empty() || total <= 0.0 {
        return cracks;
    }
    let eps = 1e-6 * dist(lo, hi);
    let boxes = cracks.iter().map(|c| {
        let (a, b) = (positions[c[0] as usize], positions[c[1] as usize]);
        (
            [0, 1, 2].map(|k| a[k].min(b[k]) - eps),
            [0, 1, 2].map(|k| a[k].max(b[k]) + eps),
        )
    });
    let grid = Grid::new(boxes, total / cracks.len() as f64);
    // Per segment: the ends inside it, with their parameter along it.
    let mut cuts: HashMap<usize, Vec<(f64, u32)>> = HashMap::new();
    for (v, _) in count.iter().enumerate().filter(|(_, &n)| n == 1) {
        let p = positions[v];
        let mut best: Option<(f64, usize)> = None;
        grid.search(p, |i| {
            let c = cracks[i];
            if c[0] as usize != v && c[1] as usize != v {
                let (a, b) = (positions[c[0] as usize], positions[c[1] as usize]);
                let d = dist(closest_on_segment(p, a, b), p);
                if d <= eps
                    && (dist(p, a) > eps && dist(p, b) > eps)
                    && best.is_none_or(|x| d < x.0)
                {
                    best = Some((d, i));
                }
            }
            Some(best.map_or(eps * eps, |b| b.0 * b.0).max(eps * eps))
        });
        if let Some((_, i)) = best {
            let c = cracks[i];
            let (a, b) = (positions[c[0] as usize], positions[c[1] as usize]);
            let t = dot(sub(p, a), sub(b, a)) / dot(sub(b, a), sub(b, a));
            cuts.entry(i).or_default().push((t, v as u32));
        }
    }
    let mut out = Vec::with_capacity(cracks.len() + cuts.len());
    for (i, c) in cracks.into_iter().enumerate() {
        match cuts.get_mut(&i) {
            None => out.push(c),
            Some(inner) => {
                inner.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                let mut prev = c[0];
                for &(_, v) in inner.iter() {
                    out.push([prev.min(v), prev.max(v)]);
                    prev = v;
                }
                out.push([prev.min(c[1]), prev.max(c[1])]);
            }
        }
    }
    out
}

/// Welds points by their exact position.
#[derive(Default)]
struct Welder {
    map: HashMap<[u64; 3], u32>,
    positions: Vec<[f64; 3]>,
}

impl Welder {
    fn id(&mut self, p: [f64; 3]) -> u32 {
        let key = p.map(|x| (x + 0.0).to_bits());
        let next = self.positions.len() as u32;
        let id = *self.map.entry(key).or_insert(next);
        if id == next {
            self.positions.push(p);
        }
        id
    }
}

/// The statistics of `input`; see [`PatternStats`].
pub fn pattern_stats(input: &PatternInput, reference: Option<&ReferenceEdges>) -> PatternStats {
    let pos = &input.positions;
    let n = pos.len();
    let crack_set: HashSet<(u32, u32)> = input.cracks.iter().map(|c| (c[0], c[1])).collect();
    // Faces across each edge; cells by union-find across non-crack edges.
    let mut edge_faces: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (f, t) in input.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edge_faces
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(f as u32);
        }
    }
    let mut parent: Vec<u32> = (0..input.triangles.len() as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    let mut border: HashSet<u32> = HashSet::new();
    let mut keys: Vec<&(u32, u32)> = edge_faces.keys().collect();
    keys.sort_unstable();
    for e in keys {
        let fs = &edge_faces[e];
        if fs.len() == 1 && !crack_set.contains(e) {
            border.insert(e.0);
            border.insert(e.1);
        }
        if crack_set.contains(e) {
            continue;
        }
        for w in fs.windows(2) {
            let (a, b) = (find(&mut parent, w[0]), find(&mut parent, w[1]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let face_area = |t: &[u32; 3]| {
        let p = t.map(|v| pos[v as usize]);
        0.5 * norm(cross(sub(p[1], p[0]), sub(p[2], p[0])))
    };
    let mut cell_area: HashMap<u32, f64> = HashMap::new();
    let mut area = 0.0;
    for (f, t) in input.triangles.iter().enumerate() {
        let a = face_area(t);
        area += a;
        *cell_area.entry(find(&mut parent, f as u32)).or_default() += a;
    }
    let mut cells: Vec<f64> = cell_area
        .into_values()
        .filter(|&a| a > 1e-9 * area)
        .collect();
    cells.sort_by(f64::total_cmp);
    let quantile = |q: f64| {
        if cells.is_empty() {
            0.0
        } else {
            cells[((q * (cells.len() - 1) as f64).round() as usize).min(cells.len() - 1)]
        }
    };
    let mean_cell_diameter = if cells.is_empty() {
        0.0
    } else {
        cells
            .iter()
            .map(|a| (4.0 * a / std::f64::consts::PI).sqrt())
            .sum::<f64>()
            / cells.len() as f64
    };
    // Crack graph.
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut crack_length = 0.0;
    for c in &input.cracks {
        adj[c[0] as usize].push(c[1]);
        adj[c[1] as usize].push(c[0]);
        crack_length += dist(pos[c[0] as usize], pos[c[1] as usize]);
    }
    // Vertex normals for junction angles.
    let mut normal = vec![[0.0; 3]; n];
    for t in &input.triangles {
        let p = t.map(|v| pos[v as usize]);
        let nn = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        for &v in t {
            normal[v as usize] = add(normal[v as usize], nn);
        }
    }
    let mut s = PatternStats {
        area,
        crack_length,
        crack_length_per_area: if area > 0.0 { crack_length / area } else { 0.0 },
        spacing: if crack_length > 0.0 {
            2.0 * area / crack_length
        } else {
            f64::INFINITY
        },
        cells: cells.len(),
        mean_cell_diameter,
        cell_area_quantiles: [0.1, 0.25, 0.5, 0.75, 0.9].map(quantile),
        ..Default::default()
    };
    for v in 0..n {
        let d = adj[v].len();
        if d == 0 {
            continue;
        }
        s.max_degree = s.max_degree.max(d);
        s.degree[(d - 1).min(3)] += 1;
        if d == 1 && !border.contains(&(v as u32)) {
            s.dangling_tips += 1;
        }
        if d == 3 {
            let mut nv = normal[v];
            if norm(nv) == 0.0 {
                // A crack vertex off the triangles (an opened crack's line):
                // the plane of its crack directions.
                let d: Vec<[f64; 3]> = adj[v]
                    .iter()
                    .map(|&u| sub(pos[u as usize], pos[v]))
                    .collect();
                nv = [(0, 1), (1, 2), (0, 2)]
                    .map(|(i, j)| cross(d[i], d[j]))
                    .into_iter()
                    .max_by(|a, b| norm(*a).total_cmp(&norm(*b)))
                    .unwrap_or([0.0; 3]);
            }
            let ln = norm(nv);
            if ln == 0.0 {
                continue;
            }
            let nv = scale(nv, 1.0 / ln);
            // Directions in the tangent plane, sorted by angle about the normal.
            let e1 = {
                let d0 = sub(pos[adj[v][0] as usize], pos[v]);
                let t = sub(d0, scale(nv, dot(d0, nv)));
                scale(t, 1.0 / norm(t).max(1e-300))
            };
            let e2 = cross(nv, e1);
            let mut ang: Vec<f64> = adj[v]
                .iter()
                .map(|&u| {
                    let d = sub(pos[u as usize], pos[v]);
                    dot(d, e2)
                        .atan2(dot(d, e1))
                        .rem_euclid(std::f64::consts::TAU)
                })
                .collect();
            ang.sort_by(f64::total_cmp);
            let gaps = [
                ang[1] - ang[0],
                ang[2] - ang[1],
                std::f64::consts::TAU - ang[2] + ang[0],
            ]
            .map(f64::to_degrees);
            for g in gaps {
                s.junction_angles[((g / 15.0) as usize).min(11)] += 1;
            }
            if gaps.iter().any(|&g| g > 150.0) {
                s.t_junctions += 1;
            } else if gaps.iter().all(|&g| (90.0..=150.0).contains(&g)) {
                s.y_junctions += 1;
            }
        }
    }
    // Orientation in the plane of the two largest extents.
    let (lo, hi) = bounds(pos);
    let ext = sub(hi, lo);
    let mut axes = [0usize, 1, 2];
    axes.sort_by(|&a, &b| ext[b].total_cmp(&ext[a]));
    for c in &input.cracks {
        let d = sub(pos[c[1] as usize], pos[c[0] as usize]);
        let l = norm(d);
        let (x, y) = (d[axes[0]], d[axes[1]]);
        if x == 0.0 && y == 0.0 {
            continue;
        }
        let a = y.atan2(x).to_degrees().rem_euclid(180.0);
        s.orientation[((a / 30.0) as usize).min(5)] += l / crack_length;
    }
    s.along_reference_edges = reference.map(|r| {
        let along: f64 = input
            .cracks
            .iter()
            .filter(|c| r.holds(pos[c[0] as usize], pos[c[1] as usize]))
            .map(|c| dist(pos[c[0] as usize], pos[c[1] as usize]))
            .sum();
        if crack_length > 0.0 {
            along / crack_length
        } else {
            0.0
        }
    });
    s.paired_distance = 0.25 * s.spacing;
    s.paired = paired_share(input, &adj, s.paired_distance, crack_length);
    s
}

/// The share of crack length with a parallel crack (within 20 degrees)
/// closer than `r`, not counting cracks joined to it within `2 r` along
/// the crack graph.
fn paired_share(input: &PatternInput, adj: &[Vec<u32>], r: f64, total: f64) -> f64 {
    if !(r.is_finite() && r > 0.0) || total <= 0.0 {
        return 0.0;
    }
    let pos = &input.positions;
    let segs = &input.cracks;
    let mids: Vec<[f64; 3]> = segs
        .iter()
        .map(|c| scale(add(pos[c[0] as usize], pos[c[1] as usize]), 0.5))
        .collect();
    let grid = Grid::new(mids.iter().map(|m| (*m, *m)), r);
    let cos20 = 20f64.to_radians().cos();
    let mut paired = 0.0;
    for (i, c) in segs.iter().enumerate() {
        let (a, b) = (pos[c[0] as usize], pos[c[1] as usize]);
        let d = sub(b, a);
        let l = norm(d);
        if l == 0.0 {
            continue;
        }
        // Vertices within 2 r of this segment along the cracks.
        let near = graph_ball(adj, pos, [c[0], c[1]], 2.0 * r);
        let mut hit = false;
        grid.search(mids[i], |j| {
            if hit || j == i {
                return None;
            }
            let o = segs[j];
            if near.contains(&o[0]) && near.contains(&o[1]) {
                return None;
            }
            let (p, q) = (pos[o[0] as usize], pos[o[1] as usize]);
            let e = sub(q, p);
            let le = norm(e);
            if le == 0.0 || (dot(d, e) / (l * le)).abs() < cos20 {
                return None;
            }
            let m = mids[j];
            let gap = dist(closest_on_segment(m, a, b), m);
            if gap < r {
                hit = true;
                return Some(0.0);
            }
            None
        });
        if hit {
            paired += l;
        }
    }
    paired / total
}

/// Crack-graph vertices within path length `r` of `seeds`.
fn graph_ball(adj: &[Vec<u32>], pos: &[[f64; 3]], seeds: [u32; 2], r: f64) -> HashSet<u32> {
    let mut best: HashMap<u32, f64> = HashMap::new();
    let mut stack: Vec<(u32, f64)> = seeds.iter().map(|&s| (s, 0.0)).collect();
    while let Some((v, d)) = stack.pop() {
        if best.get(&v).is_some_and(|&b| b <= d) {
            continue;
        }
        best.insert(v, d);
        for &u in &adj[v as usize] {
            let nd = d + dist(pos[v as usize], pos[u as usize]);
            if nd <= r {
                stack.push((u, nd));
            }
        }
    }
    best.into_keys().collect()
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(sub(a, b))
}
fn bounds(p: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for q in p {
        for k in 0..3 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    if p.is_empty() {
        return ([0.0; 3], [0.0; 3]);
    }
    (lo, hi)
}
fn bbox2(a: [f64; 3], b: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    bounds(&[a, b])
}

#[cfg(test)]
#[path = "stats_tests.rs"]
mod tests;
