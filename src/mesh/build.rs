//! Building a [`SimMesh`] from an indexed triangle soup: welding, dropping
//! degenerate triangles, and making the result manifold.

use super::attributes::{Channel, WedgeAttributes};
use super::defects::DefectReport;
use super::error::{MeshError, OptionFault};
use super::halfedge::{double_area, norm, sub, SimMesh};
use super::ids::INVALID;
use super::weld::{weld, Welded};

/// An indexed triangle mesh to build a [`SimMesh`] from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshInput {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Triangles as indices into `positions`, counter-clockwise.
    pub triangles: Vec<[u32; 3]>,
    /// Group (primitive / material) of each triangle; empty means all 0.
    pub face_groups: Vec<u32>,
    /// Per-vertex attributes (`positions.len()` values each); may be empty.
    /// Input vertex `i` becomes wedge `i`.
    pub wedge_channels: Vec<Channel>,
}

/// Options of `SimMesh::build`.
#[derive(Clone, Debug, PartialEq)]
pub struct WeldOptions {
    /// Vertices closer than this times the bounding-box diagonal are
    /// welded; 0 welds only identical positions.
    pub relative_tolerance: f64,
}

impl Default for WeldOptions {
    fn default() -> Self {
        WeldOptions {
            relative_tolerance: 1e-6,
        }
    }
}

/// Triangles with an area below this times the squared bounding-box
/// diagonal are dropped as degenerate.
const RELATIVE_AREA_EPSILON: f64 = 1e-12;

impl SimMesh {
    /// Builds a simulation mesh from `input`.
    ///
    /// Vertices are welded by position (see [`WeldOptions`]); the corner of
    /// input triangle `t` at slot `k` gets wedge `triangles[t][k]`.
    /// Degenerate triangles are dropped; non-manifold edges, inconsistently
    /// oriented edges and non-manifold vertices are split until the mesh is
    /// an oriented manifold. Everything found is counted in the returned
    /// [`DefectReport`]. Face `f` comes from input triangle
    /// [`face_source(f)`](SimMesh::face_source); faces keep the input order.
    ///
    /// # Errors
    /// Empty input, all triangles degenerate, an index out of range (naming
    /// the triangle), `face_groups` or a channel of the wrong length, or an
    /// invalid tolerance.
    pub fn build(
        input: &MeshInput,
        options: &WeldOptions,
    ) -> Result<(SimMesh, DefectReport), MeshError> {
        let rel = options.relative_tolerance;
        check_input(input, rel)?;
        let nv_in = input.positions.len();
        let nt_in = input.triangles.len();
        let wedges = WedgeAttributes::new(nv_in, input.wedge_channels.clone())
            .expect("channel lengths checked");

        let mut report = DefectReport {
            input_vertices: nv_in,
            input_triangles: nt_in,
            ..Default::default()
        };

        // References, finiteness, bounding box.
        let used = used_vertices(input)?;
        report.unreferenced_vertices = used.iter().filter(|&&u| !u).count();
        let (used, lo, hi) = finite_bounds(used, &input.positions);
        if lo[0] > hi[0] {
            return Err(MeshError::AllDegenerate { dropped: nt_in });
        }
        let diag = norm(sub(hi, lo));
        let welded = weld(&input.positions, &used, rel * diag, lo);
        report.welded_vertices = welded.reps.len();

        // Keep non-degenerate triangles, in welded ids.
        let (mut kept, kept_src) = non_degenerate(input, &welded, diag);
        report.degenerate_triangles_dropped = nt_in - kept.len();
        if kept.is_empty() {
            return Err(MeshError::AllDegenerate { dropped: nt_in });
        }

        // Compact the welded vertices to the ones still referenced.
        let vertex_source = compact_vertices(&mut kept, &welded.reps);
        let nv = vertex_source.len();
        report.duplicate_triangles = count_duplicate_triangles(&kept, nv);

        let mut mesh = SimMesh::unpaired(input, &kept, kept_src, vertex_source, wedges);

        // Pair halfedges into edges.
        let edges = EdgeTable::new(&mesh);
        let cut_groups = mesh.pair_halfedges(&edges, &mut report);

        // Split every vertex into its fans.
        let bowties_if_clean = mesh.split_fans();
        if cut_groups.is_empty() {
            report.non_manifold_vertices = bowties_if_clean;
        } else {
            report.non_manifold_vertices = count_non_manifold_vertices(&mesh, &edges, nv);
            if mesh.cut_shared_ends(&edges, &cut_groups) {
                mesh.split_fans();
            }
        }
        report.duplicated_vertices = mesh.n_vertices() - nv;
        report.vertices = mesh.n_vertices();
        report.faces = mesh.n_faces();
        report.boundary_edges = mesh.n_boundary_halfedges();
        report.boundary_loops = mesh.boundary_loops();
        report.components = mesh.connected_components().0;
        Ok((mesh, report))
    }

    /// The mesh of the `kept` triangles (in compacted vertex ids; from the
    /// input triangles `kept_src`) with no twins yet and one vertex per
    /// welded vertex (from the input vertices `vertex_source`).
    fn unpaired(
        input: &MeshInput,
        kept: &[[u32; 3]],
        kept_src: Vec<u32>,
        vertex_source: Vec<u32>,
        wedges: WedgeAttributes,
    ) -> SimMesh {
        let nv = vertex_source.len();
        let nf = kept.len();
        SimMesh {
            positions: vertex_source
                .iter()
                .map(|&s| input.positions[s as usize])
                .collect(),
            vertex_halfedge: vec![INVALID; nv],
            vertex_source,
            vertex_parent: (0..nv as u32).collect(),
            he_origin: kept.iter().flatten().copied().collect(),
            he_twin: vec![INVALID; 3 * nf],
            he_crack: vec![false; 3 * nf],
            he_wedge: kept_src
                .iter()
                .flat_map(|&t| input.triangles[t as usize])
                .collect(),
            face_groups: if input.face_groups.is_empty() {
                vec![0; nf]
            } else {
                kept_src
                    .iter()
                    .map(|&t| input.face_groups[t as usize])
                    .collect()
            },
            face_source: kept_src,
            wedges,
            generation: 0,
        }
    }

    /// Makes twins of the two opposite halfedges of each edge (of the
    /// first opposite pair on a non-manifold edge), counting inconsistent
    /// and non-manifold edges in `report`. Returns the edges to cut (their
    /// ranges in `edges`).
    fn pair_halfedges(
        &mut self,
        edges: &EdgeTable,
        report: &mut DefectReport,
    ) -> Vec<(usize, usize)> {
        let mut cut_groups: Vec<(usize, usize)> = Vec::new();
        for &(s, e) in &edges.groups {
            let g = &edges.halfedges[s..e];
            let opposite =
                |x: u32, y: u32| self.he_origin[x as usize] != self.he_origin[y as usize];
            match g.len() {
                1 => {}
                2 if opposite(g[0], g[1]) => {
                    self.he_twin[g[0] as usize] = g[1];
                    self.he_twin[g[1] as usize] = g[0];
                }
                2 => {
                    report.inconsistent_orientation_edges += 1;
                    cut_groups.push((s, e));
                }
                _ => {
                    report.non_manifold_edges += 1;
                    cut_groups.push((s, e));
                    // Pair the first opposite pair (lowest halfedges first).
                    // Every halfedge here starts at one of the edge's two
                    // ends, so that pair is the first with the other
                    // origin than the first, if any (linear, not the
                    // pairwise search: one edge of 100,000 duplicate faces).
                    work(g.len());
                    if let Some(&j) = g[1..].iter().find(|&&y| opposite(g[0], y)) {
                        self.he_twin[g[0] as usize] = j;
                        self.he_twin[j as usize] = g[0];
                    }
                }
            }
        }
        cut_groups
    }

    /// Unpairs the halfedges of the cut edges `cut_groups` that still share
    /// (origin, destination) with another halfedge in the same fan, so that
    /// each one starts its own fan. Returns whether any was unpaired.
    fn cut_shared_ends(&mut self, edges: &EdgeTable, cut_groups: &[(usize, usize)]) -> bool {
        // Sorting each group by (origin, destination) finds the
        // halfedges sharing them in n log n.
        let mut recut = false;
        let mut ends: Vec<(u32, u32, u32)> = Vec::new();
        for &(s, e) in cut_groups {
            ends.clear();
            ends.extend(edges.halfedges[s..e].iter().map(|&x| {
                let x = x as usize;
                (self.he_origin[x], self.he_origin[next_idx(x)], x as u32)
            }));
            ends.sort_unstable();
            work(ends.len());
            let mut i = 0;
            while i < ends.len() {
                let mut j = i + 1;
                while j < ends.len() && ends[j].0 == ends[i].0 && ends[j].1 == ends[i].1 {
                    j += 1;
                }
                if j - i > 1 {
                    for &(_, _, z) in &ends[i..j] {
                        let z = z as usize;
                        let t = self.he_twin[z];
                        if t != INVALID {
                            self.he_twin[t as usize] = INVALID;
                            self.he_twin[z] = INVALID;
                            recut = true;
                        }
                    }
                }
                i = j;
            }
        }
        recut
    }

    /// Gives every fan of every vertex its own vertex (duplicating vertices
    /// with more than one fan; the fan met first keeps the vertex) and sets
    /// every vertex's outgoing halfedge. Returns the number of vertices that
    /// had more than one fan.
    fn split_fans(&mut self) -> usize {
        let nh = self.n_halfedges();
        let nv0 = self.n_vertices();
        let mut visited = vec![false; nh];
        let mut seen = vec![0u8; nv0]; // 0 unseen, 1 one fan, 2 split
        let mut n_split = 0;
        for h0 in 0..nh {
            if visited[h0] {
                continue;
            }
            let v = self.he_origin[h0] as usize;
            // Walk clockwise to the start of the fan (or around a cycle).
            let mut s = h0;
            loop {
                let t = self.he_twin[s];
                if t == INVALID {
                    break;
                }
                let p = next_idx(t as usize);
                if p == h0 {
                    break;
                }
                s = p;
            }
            let target = if seen[v] == 0 {
                seen[v] = 1;
                v
            } else {
                if seen[v] == 1 {
                    seen[v] = 2;
                    n_split += 1;
                }
                let nvtx = self.positions.len();
                self.positions.push(self.positions[v]);
                self.vertex_source.push(self.vertex_source[v]);
                self.vertex_parent.push(self.vertex_parent[v]);
                self.vertex_halfedge.push(INVALID);
                nvtx
            };
            self.vertex_halfedge[target] = s as u32;
            let mut x = s;
            loop {
                visited[x] = true;
                self.he_origin[x] = target as u32;
                let t = self.he_twin[prev_idx(x)];
                if t == INVALID || t as usize == s {
                    break;
                }
                x = t as usize;
            }
        }
        n_split
    }
}

/// Checks `input` and the weld tolerance `rel` before building: a finite
/// tolerance, a non-empty mesh of a size the ids can hold, and
/// `face_groups` and wedge channels of the right lengths.
fn check_input(input: &MeshInput, rel: f64) -> Result<(), MeshError> {
    if !(rel.is_finite() && rel >= 0.0) {
        return Err(OptionFault::RelativeTolerance(rel).into());
    }
    let nv_in = input.positions.len();
    let nt_in = input.triangles.len();
    if nv_in == 0 || nt_in == 0 {
        return Err(MeshError::EmptyInput {
            vertices: nv_in,
            triangles: nt_in,
        });
    }
    if nv_in >= INVALID as usize || nt_in >= (INVALID / 3) as usize {
        return Err(OptionFault::TooLarge {
            vertices: nv_in,
            triangles: nt_in,
        }
        .into());
    }
    if !input.face_groups.is_empty() && input.face_groups.len() != nt_in {
        return Err(MeshError::LengthMismatch {
            what: "face_groups".into(),
            expected: nt_in,
            got: input.face_groups.len(),
        });
    }
    for ch in &input.wedge_channels {
        if ch.components == 0 || ch.data.len() != nv_in * ch.components {
            return Err(MeshError::LengthMismatch {
                what: format!(
                    "wedge channel \"{}\" ({} components)",
                    ch.name, ch.components
                ),
                expected: nv_in * ch.components.max(1),
                got: ch.data.len(),
            });
        }
    }
    Ok(())
}

/// Per input vertex: whether a triangle uses it (an index out of range is
/// an error naming the triangle).
fn used_vertices(input: &MeshInput) -> Result<Vec<bool>, MeshError> {
    let nv_in = input.positions.len();
    let mut used = vec![false; nv_in];
    for (t, tri) in input.triangles.iter().enumerate() {
        for &i in tri {
            if i as usize >= nv_in {
                return Err(MeshError::IndexOutOfRange {
                    triangle: t,
                    index: i,
                    vertices: nv_in,
                });
            }
            used[i as usize] = true;
        }
    }
    Ok(used)
}

/// The `used` vertices with a finite position (the others no longer
/// used), and their bounding box (empty, `lo > hi`, when there is none).
fn finite_bounds(mut used: Vec<bool>, positions: &[[f64; 3]]) -> (Vec<bool>, [f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (u, p) in used.iter_mut().zip(positions) {
        if *u {
            if p.iter().all(|x| x.is_finite()) {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            } else {
                *u = false;
            }
        }
    }
    (used, lo, hi)
}

/// The triangles that are not degenerate after welding (three distinct
/// welded vertices, an area above [`RELATIVE_AREA_EPSILON`] times `diag`
/// squared), in welded ids, with the input triangle each comes from.
fn non_degenerate(input: &MeshInput, welded: &Welded, diag: f64) -> (Vec<[u32; 3]>, Vec<u32>) {
    let nt_in = input.triangles.len();
    let min_double_area = 2.0 * RELATIVE_AREA_EPSILON * diag * diag;
    let mut kept: Vec<[u32; 3]> = Vec::with_capacity(nt_in);
    let mut kept_src: Vec<u32> = Vec::with_capacity(nt_in);
    for (t, tri) in input.triangles.iter().enumerate() {
        let w = tri.map(|i| welded.map[i as usize]);
        if w.contains(&INVALID) || w[0] == w[1] || w[1] == w[2] || w[0] == w[2] {
            continue;
        }
        let [a, b, c] = w.map(|x| input.positions[welded.reps[x as usize] as usize]);
        let da = double_area(a, b, c);
        if !(da >= min_double_area && da > 0.0) {
            continue;
        }
        kept.push(w);
        kept_src.push(t as u32);
    }
    (kept, kept_src)
}

/// Renumbers the welded vertices of the `kept` triangles to those still
/// referenced, in order; returns each one's input vertex (from `reps`).
fn compact_vertices(kept: &mut [[u32; 3]], reps: &[u32]) -> Vec<u32> {
    let mut compact = vec![INVALID; reps.len()];
    for tri in kept.iter() {
        for &w in tri {
            compact[w as usize] = 0;
        }
    }
    let mut vertex_source = Vec::new();
    for (w, c) in compact.iter_mut().enumerate() {
        if *c != INVALID {
            *c = vertex_source.len() as u32;
            vertex_source.push(reps[w]);
        }
    }
    for tri in kept.iter_mut() {
        *tri = tri.map(|w| compact[w as usize]);
    }
    vertex_source
}

#[cfg(test)]
thread_local! {
    /// Elements visited on the non-manifold paths (for the tests' bound on
    /// the work).
    static WORK: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

#[inline]
fn work(_n: usize) {
    #[cfg(test)]
    WORK.with(|w| w.set(w.get() + _n));
}

#[inline]
fn next_idx(h: usize) -> usize {
    if h % 3 == 2 {
        h - 2
    } else {
        h + 1
    }
}

#[inline]
fn prev_idx(h: usize) -> usize {
    if h % 3 == 0 {
        h + 2
    } else {
        h - 1
    }
}

/// Halfedges grouped by undirected edge: bucketed by lower vertex (counting
/// sort), each bucket sorted by (higher vertex, halfedge).
struct EdgeTable {
    /// Halfedge ids, grouped by edge.
    halfedges: Vec<u32>,
    /// Ranges `[s, e)` of `halfedges` sharing one undirected edge.
    groups: Vec<(usize, usize)>,
}

impl EdgeTable {
    fn new(mesh: &SimMesh) -> Self {
        let nh = mesh.n_halfedges();
        let nv = mesh.n_vertices();
        let ends = |h: usize| {
            let a = mesh.he_origin[h];
            let b = mesh.he_origin[next_idx(h)];
            (a.min(b), a.max(b))
        };
        let mut start = vec![0u32; nv + 1];
        for h in 0..nh {
            start[ends(h).0 as usize + 1] += 1;
        }
        for i in 0..nv {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut entries = vec![(0u32, 0u32); nh];
        for h in 0..nh {
            let (lo, hi) = ends(h);
            let slot = &mut fill[lo as usize];
            entries[*slot as usize] = (hi, h as u32);
            *slot += 1;
        }
        let mut groups = Vec::with_capacity(nh / 2 + 1);
        for i in 0..nv {
            let (b0, b1) = (start[i] as usize, start[i + 1] as usize);
            let bucket = &mut entries[b0..b1];
            bucket.sort_unstable();
            let mut s = 0;
            while s < bucket.len() {
                let mut e = s + 1;
                while e < bucket.len() && bucket[e].0 == bucket[s].0 {
                    e += 1;
                }
                groups.push((b0 + s, b0 + e));
                s = e;
            }
        }
        EdgeTable {
            halfedges: entries.iter().map(|e| e.1).collect(),
            groups,
        }
    }
}

/// Number of duplicate triangles (same vertex set as an earlier one).
fn count_duplicate_triangles(tris: &[[u32; 3]], nv: usize) -> usize {
    let mut start = vec![0u32; nv + 1];
    let sorted: Vec<[u32; 3]> = tris
        .iter()
        .map(|t| {
            let mut s = *t;
            s.sort_unstable();
            s
        })
        .collect();
    for s in &sorted {
        start[s[0] as usize + 1] += 1;
    }
    for i in 0..nv {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut entries = vec![(0u32, 0u32); sorted.len()];
    for s in &sorted {
        let slot = &mut fill[s[0] as usize];
        entries[*slot as usize] = (s[1], s[2]);
        *slot += 1;
    }
    let mut dups = 0;
    for i in 0..nv {
        let b = &mut entries[start[i] as usize..start[i + 1] as usize];
        b.sort_unstable();
        dups += b.windows(2).filter(|w| w[0] == w[1]).count();
    }
    dups
}

/// Number of vertices (of the welded input, ids `< nv`) whose incident
/// triangles, connected through shared edges incident to the vertex, form
/// more than one component. Uses the vertex parents to map split vertices
/// back.
fn count_non_manifold_vertices(mesh: &SimMesh, edges: &EdgeTable, nv: usize) -> usize {
    let nh = mesh.n_halfedges();
    // Union-find over corners (a corner is identified by its halfedge).
    let mut parent: Vec<u32> = (0..nh as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            let g = p[p[x as usize] as usize];
            p[x as usize] = g;
            x = g;
        }
        x
    }
    let welded = |h: usize| mesh.vertex_parent[mesh.he_origin[h] as usize];
    for &(s, e) in &edges.groups {
        let g = &edges.halfedges[s..e];
        if g.len() < 2 {
            continue;
        }
        // Corners at each endpoint (in welded ids) of the edge.
        let u = welded(g[0] as usize);
        let mut first_u = INVALID;
        let mut first_v = INVALID;
        for &x in g {
            let x = x as usize;
            let (cu, cv) = if welded(x) == u {
                (x, next_idx(x))
            } else {
                (next_idx(x), x)
            };
            for (first, c) in [(&mut first_u, cu), (&mut first_v, cv)] {
                if *first == INVALID {
                    *first = c as u32;
                } else {
                    let a = find(&mut parent, *first);
                    let b = find(&mut parent, c as u32);
                    if a != b {
                        parent[a.max(b) as usize] = a.min(b);
                    }
                }
            }
        }
    }
    let mut root = vec![INVALID; nv];
    let mut bad = vec![false; nv];
    for h in 0..nh {
        let v = welded(h) as usize;
        let r = find(&mut parent, h as u32);
        if root[v] == INVALID {
            root[v] = r;
        } else if root[v] != r {
            bad[v] = true;
        }
    }
    bad.iter().filter(|&&b| b).count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{build, cube24_input, grid_input, icosphere_input, Lcg};
    use crate::mesh::{ChannelKind, FaceId, VertexId};

    fn soup(positions: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> MeshInput {
        MeshInput {
            positions,
            triangles,
            ..Default::default()
        }
    }

    #[test]
    fn cube_24_vertices_welds_closed() {
        let input = cube24_input();
        let (m, r) = build(&input);
        assert_eq!(r.input_vertices, 24);
        assert_eq!(r.welded_vertices, 8);
        assert_eq!(m.n_vertices(), 8);
        assert_eq!(m.n_faces(), 12);
        assert_eq!(r.boundary_edges, 0);
        assert_eq!(r.boundary_loops, 0);
        assert_eq!(r.components, 1);
        assert!(r.is_clean(), "{r:?}");
        assert_eq!(m.n_wedges(), 24);
        assert!((m.total_area() - 6.0).abs() < 1e-12);
        let normals = m.wedges().channel("NORMAL").unwrap();
        assert_eq!(normals.kind, ChannelKind::UnitVector);
        for f in m.faces() {
            // Each corner keeps its own face's normal.
            let n = m.face_normal(f);
            for w in m.face_wedges(f) {
                let wn = normals.get(w);
                assert!((0..3).all(|k| (wn[k] - n[k]).abs() < 1e-12));
            }
            assert_eq!(m.face_group(f), m.face_source(f) / 2);
        }
        // Every welded vertex has 3 distinct wedges (3 hard-normal corners).
        for v in m.vertices() {
            let mut ws: Vec<_> = m.vertex_outgoing(v).map(|h| m.wedge(h)).collect::<Vec<_>>();
            ws.sort();
            ws.dedup();
            assert_eq!(ws.len(), 3);
            assert!(!m.is_boundary_vertex(v));
        }
        let corners: usize = m.vertices().map(|v| m.vertex_faces(v).count()).sum();
        assert_eq!(corners, 36);
    }

    #[test]
    fn uv_seamed_strip_has_no_internal_boundary() {
        // 4 quads along x; the vertices at x = 2 are duplicated with
        // different UVs (a seam).
        let mut positions = Vec::new();
        let mut uv = Vec::new();
        for (x0, x1) in [(0, 2), (2, 4)] {
            for x in x0..=x1 {
                for y in 0..=1 {
                    positions.push([x as f64, y as f64, 0.0]);
                    uv.extend_from_slice(&[(x - x0) as f64 / 2.0, y as f64]);
                }
            }
        }
        let mut triangles = Vec::new();
        for part in 0..2u32 {
            for q in 0..2u32 {
                let b = part * 6 + q * 2;
                triangles.push([b, b + 2, b + 3]);
                triangles.push([b, b + 3, b + 1]);
            }
        }
        let input = MeshInput {
            positions,
            triangles,
            face_groups: vec![],
            wedge_channels: vec![Channel::new("uv", 2, ChannelKind::Linear, uv)],
        };
        let (m, r) = build(&input);
        assert_eq!(r.welded_vertices, 10);
        assert_eq!(m.n_faces(), 8);
        assert_eq!(r.boundary_edges, 10);
        assert_eq!(r.boundary_loops, 1);
        assert_eq!(r.components, 1);
        assert!(r.is_clean());
        // The seam vertices carry two wedges each.
        let seam: Vec<VertexId> = m.vertices().filter(|&v| m.position(v)[0] == 2.0).collect();
        assert_eq!(seam.len(), 2);
        for v in seam {
            let mut ws: Vec<_> = m.vertex_outgoing(v).map(|h| m.wedge(h)).collect();
            ws.sort();
            ws.dedup();
            assert_eq!(ws.len(), 2);
        }
        // The interior edge on the seam is not a boundary.
        let a = m
            .vertices()
            .find(|&v| m.position(v) == [2.0, 0.0, 0.0])
            .unwrap();
        let b = m
            .vertices()
            .find(|&v| m.position(v) == [2.0, 1.0, 0.0])
            .unwrap();
        let h = m
            .find_halfedge(a, b)
            .or_else(|| m.find_halfedge(b, a))
            .unwrap();
        assert!(!m.is_boundary_halfedge(h));
    }

    #[test]
    fn bowtie_vertex_is_split() {
        let input = soup(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [-1.0, 0.0, 0.0],
                [-1.0, -1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 3, 4]],
        );
        let (m, r) = build(&input);
        assert_eq!(r.non_manifold_vertices, 1);
        assert_eq!(r.non_manifold_edges, 0);
        assert_eq!(r.duplicated_vertices, 1);
        assert_eq!(m.n_vertices(), 6);
        assert_eq!(r.components, 2);
        assert_eq!(r.boundary_loops, 2);
        assert!(!r.is_clean());
        let dup = VertexId(5);
        assert_eq!(m.vertex_parent(dup), VertexId(0));
        assert_eq!(m.vertex_source(dup), Some(0));
        assert_eq!(m.position(dup), m.position(VertexId(0)));
    }

    #[test]
    fn three_faces_on_one_edge_become_manifold() {
        let input = soup(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.5, 1.0, 0.0],
                [0.5, -1.0, 0.0],
                [0.5, 0.0, 1.0],
            ],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        );
        let (m, r) = build(&input);
        assert_eq!(r.non_manifold_edges, 1);
        assert_eq!(r.non_manifold_vertices, 0);
        assert_eq!(r.inconsistent_orientation_edges, 0);
        assert_eq!(m.n_faces(), 3);
        assert_eq!(m.n_vertices(), 7);
        assert_eq!(r.duplicated_vertices, 2);
        assert_eq!(r.boundary_edges, 7);
        assert_eq!(r.components, 2);
        // Five pages on one edge.
        let mut positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let mut triangles = Vec::new();
        for i in 0..5 {
            let a = i as f64 * 1.2;
            positions.push([0.5, a.cos(), a.sin()]);
            let k = 2 + i as u32;
            triangles.push(if i % 2 == 0 { [0, 1, k] } else { [1, 0, k] });
        }
        let (m, r) = build(&soup(positions, triangles));
        assert_eq!(r.non_manifold_edges, 1);
        assert_eq!(m.n_faces(), 5);
        assert_eq!(r.components, 4);
    }

    #[test]
    fn inconsistent_orientation_is_cut() {
        let input = soup(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.5, 1.0, 0.0],
                [0.5, -1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 1, 3]],
        );
        let (m, r) = build(&input);
        assert_eq!(r.inconsistent_orientation_edges, 1);
        assert_eq!(r.non_manifold_edges, 0);
        assert_eq!(m.n_vertices(), 6);
        assert_eq!(r.components, 2);
    }

    #[test]
    fn mobius_strip_is_made_orientable() {
        let n = 12u32;
        let mut positions = Vec::new();
        for i in 0..n {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            for s in [-0.3, 0.3] {
                let r = 1.0 + s * (a / 2.0).cos();
                positions.push([r * a.cos(), r * a.sin(), s * (a / 2.0).sin()]);
            }
        }
        let mut triangles = Vec::new();
        for i in 0..n {
            let (a0, a1) = (2 * i, 2 * i + 1);
            let (b0, b1) = if i + 1 < n {
                (2 * i + 2, 2 * i + 3)
            } else {
                (1, 0) // the twist
            };
            triangles.push([a0, b0, b1]);
            triangles.push([a0, b1, a1]);
        }
        let (m, r) = build(&soup(positions, triangles));
        assert!(r.inconsistent_orientation_edges >= 1, "{r:?}");
        assert_eq!(m.n_faces(), 2 * n as usize);
        assert_eq!(r.components, 1);
    }

    #[test]
    fn random_soups_build_valid_manifolds() {
        let mut rng = Lcg(12345);
        for round in 0..std::env::var("SOUP_ROUNDS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(300)
        {
            let nv = 4 + rng.below(6);
            let positions: Vec<[f64; 3]> = (0..nv)
                .map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()])
                .collect();
            let nt = 1 + rng.below(if round % 2 == 0 { 25 } else { 60 });
            let triangles: Vec<[u32; 3]> = (0..nt)
                .map(|_| std::array::from_fn(|_| rng.below(nv) as u32))
                .collect();
            let input = soup(positions, triangles);
            match SimMesh::build(&input, &WeldOptions::default()) {
                Ok((m, r)) => {
                    m.validate()
                        .unwrap_or_else(|e| panic!("round {round}: {e}\n{input:?}"));
                    assert_eq!(r.faces + r.degenerate_triangles_dropped, nt);
                    let (m2, r2) = SimMesh::build(&input, &WeldOptions::default()).unwrap();
                    assert_eq!(m, m2);
                    assert_eq!(r, r2);
                }
                Err(MeshError::AllDegenerate { .. }) => {}
                Err(e) => panic!("round {round}: {e}"),
            }
        }
    }

    #[test]
    fn degenerate_triangles_are_dropped() {
        let input = MeshInput {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [2.0, 0.0, 0.0],      // collinear with 0, 1
                [f64::NAN, 0.0, 0.0], // non-finite
                [1.0, 1e-9, 0.0],     // welds onto 1
                [5.0, 5.0, 5.0],      // unreferenced
            ],
            triangles: vec![
                [0, 1, 2],
                [0, 0, 2], // repeated index
                [0, 1, 3], // zero area
                [0, 4, 2], // NaN
                [1, 5, 2], // welded corners
            ],
            face_groups: vec![7, 8, 9, 10, 11],
            wedge_channels: vec![],
        };
        let (m, r) = build(&input);
        assert_eq!(r.degenerate_triangles_dropped, 4);
        assert_eq!(r.unreferenced_vertices, 1);
        assert_eq!(m.n_faces(), 1);
        assert_eq!(m.n_vertices(), 3);
        assert_eq!(m.face_source(FaceId(0)), 0);
        assert_eq!(m.face_group(FaceId(0)), 7);
        assert_eq!(m.n_wedges(), 7);
        assert!(!r.is_clean());
    }

    #[test]
    fn duplicate_triangles_are_reported_and_kept() {
        let mut input = grid_input(2, 1);
        input.triangles.push(input.triangles[0]);
        let t = input.triangles[1];
        input.triangles.push([t[0], t[2], t[1]]);
        let (m, r) = build(&input);
        assert_eq!(r.duplicate_triangles, 2);
        assert_eq!(m.n_faces(), 6);
        assert_eq!(r.degenerate_triangles_dropped, 0);
    }

    #[test]
    fn tolerance_is_relative() {
        let base = {
            let mut g = grid_input(3, 3);
            // Split the grid into two halves with duplicated vertices 1e-8
            // apart (welded) and one vertex moved 1e-3 away (not welded).
            let n = g.positions.len() as u32;
            g.positions.extend(
                g.positions
                    .clone()
                    .iter()
                    .map(|p| [p[0] + 1e-8, p[1], p[2]]),
            );
            if let Some(c) = g.wedge_channels.first_mut() {
                let d = c.data.clone();
                c.data.extend(d);
            }
            for t in g.triangles.iter_mut().skip(9) {
                *t = t.map(|i| i + n);
            }
            g.positions[(n + 5) as usize][1] += 1e-3 * 4.24;
            g
        };
        let mut results = Vec::new();
        for s in [1e-3, 1.0, 1e3] {
            let mut input = base.clone();
            for p in &mut input.positions {
                *p = p.map(|x| x * s);
            }
            let (m, r) = build(&input);
            let faces: Vec<_> = m.faces().map(|f| m.face_vertices(f)).collect();
            results.push((r.welded_vertices, r.boundary_edges, faces));
        }
        assert_eq!(results[0], results[1]);
        assert_eq!(results[1], results[2]);
        assert_eq!(results[1].0, 17);
    }

    /// One edge shared by many duplicate faces (an OBJ of 100,000 copies
    /// of one triangle) is handled in about linear work: the visits grow
    /// 10x for 10x the copies (a pairwise search: 100x; it took 31 s).
    #[test]
    fn many_duplicate_faces_take_linear_work() {
        let mut counts = Vec::new();
        for n in [1_000, 10_000] {
            let mut tris = vec![[0, 1, 2]; n];
            tris.push([1, 3, 2]);
            tris.extend(vec![[0, 2, 1]; n / 2]);
            let input = soup(
                vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
                tris,
            );
            WORK.with(|w| w.set(0));
            let (mesh, r) = SimMesh::build(&input, &WeldOptions::default()).unwrap();
            assert!(
                r.non_manifold_edges > 0 && r.duplicate_triangles > 0,
                "{r:?}"
            );
            assert_eq!(mesh.n_faces(), n + 1 + n / 2);
            counts.push(WORK.with(std::cell::Cell::get) as f64);
        }
        let ratio = counts[1] / counts[0];
        assert!(counts[0] > 0.0 && ratio < 12.0, "{counts:?}: {ratio:.1}x");
    }

    #[test]
    fn build_is_deterministic() {
        let input = icosphere_input(3);
        let (a, ra) = build(&input);
        let (b, rb) = build(&input);
        assert_eq!(a, b);
        assert_eq!(ra, rb);
        assert!(ra.is_clean());
        assert_eq!(ra.components, 1);
        assert_eq!(ra.boundary_edges, 0);
        assert_eq!(a.n_vertices() + a.n_faces(), a.n_halfedges() / 2 + 2);
    }

    #[test]
    fn errors_are_reported() {
        let e = SimMesh::build(&MeshInput::default(), &WeldOptions::default()).unwrap_err();
        assert!(matches!(e, MeshError::EmptyInput { .. }));
        let mut g = grid_input(1, 1);
        g.triangles[1][2] = 99;
        let e = SimMesh::build(&g, &WeldOptions::default()).unwrap_err();
        assert_eq!(
            e,
            MeshError::IndexOutOfRange {
                triangle: 1,
                index: 99,
                vertices: 4
            }
        );
        assert!(e.to_string().contains("triangle 1"));
        let all_degenerate = soup(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            vec![[0, 1, 2]],
        );
        let e = SimMesh::build(&all_degenerate, &WeldOptions::default()).unwrap_err();
        assert_eq!(e, MeshError::AllDegenerate { dropped: 1 });
        let mut g = grid_input(1, 1);
        g.face_groups = vec![0];
        assert!(matches!(
            SimMesh::build(&g, &WeldOptions::default()),
            Err(MeshError::LengthMismatch { .. })
        ));
        let mut g = grid_input(1, 1);
        g.wedge_channels[0].data.pop();
        assert!(matches!(
            SimMesh::build(&g, &WeldOptions::default()),
            Err(MeshError::LengthMismatch { .. })
        ));
        let g = grid_input(1, 1);
        let bad = WeldOptions {
            relative_tolerance: f64::NAN,
        };
        assert!(matches!(
            SimMesh::build(&g, &bad),
            Err(MeshError::InvalidOption { .. })
        ));
    }

    #[test]
    fn exact_welding_with_zero_tolerance() {
        let mut g = grid_input(2, 2);
        let n = g.positions.len();
        g.positions.push([1.0 + 1e-12, 1.0, 0.0]);
        g.wedge_channels.clear();
        for t in &mut g.triangles {
            if t[0] == 0 {
                *t = t.map(|i| if i == 4 { n as u32 } else { i });
            }
        }
        let opts = WeldOptions {
            relative_tolerance: 0.0,
        };
        let (_, r) = SimMesh::build(&g, &opts).unwrap();
        assert_eq!(r.welded_vertices, 10);
        let (_, r) = SimMesh::build(&g, &WeldOptions::default()).unwrap();
        assert_eq!(r.welded_vertices, 9);
    }

    /// An indexed grid and the same grid as a triangle soup weld to the same
    /// clean mesh (welding time is measured by `cargo bench --bench io`).
    #[test]
    fn indexed_and_soup_grids_agree() {
        let n = 120;
        let mut input = grid_input(n, n);
        input.wedge_channels.clear();
        for p in &mut input.positions {
            // Jitter far below the tolerance so welding is exercised.
            p[2] = 1e-9 * ((p[0] * 7.0 + p[1] * 13.0) % 3.0);
        }
        let (m, r) = SimMesh::build(&input, &WeldOptions::default()).unwrap();
        // The same grid as a triangle soup (3 input vertices per triangle).
        let soup = MeshInput {
            positions: input
                .triangles
                .iter()
                .flat_map(|t| t.map(|i| input.positions[i as usize]))
                .collect(),
            triangles: (0..input.triangles.len() as u32)
                .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
                .collect(),
            ..Default::default()
        };
        let (m2, r2) = SimMesh::build(&soup, &WeldOptions::default()).unwrap();
        m.validate().unwrap();
        m2.validate().unwrap();
        assert_eq!(r.vertices, r2.vertices);
        assert_eq!(m2.n_faces(), m.n_faces());
        assert!(r.is_clean() && r2.is_clean());
    }
}
