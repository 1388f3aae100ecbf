//! Isotropic remeshing of a simulation mesh to a target edge length
//! (Botsch & Kobbelt 2004): split long edges, collapse short ones, flip
//! toward valence 6 (4 on feature lines), smooth tangentially and project
//! back onto the input surface, a few times over.
//!
//! Feature lines are kept as constrained edges: open boundaries, UV and
//! normal seams (edges whose two sides have different corner values),
//! material borders (different face groups) and sharp creases (dihedral
//! angle above [`RemeshOptions::crease_angle_deg`]). Feature edges are split
//! but never flipped; feature vertices move only along their line and are
//! projected onto the input's feature edges; vertices where features meet
//! or end never move.
//!
//! Every corner attribute is carried by projection: an output corner takes
//! the values of the input surface at its position, interpolated in the
//! input triangle found, on its own side of any seam (an output face lies
//! in one *chart*, a region of input faces joined across non-feature
//! edges, and its corners are evaluated there). The face group is the
//! chart's.
//!
//! The work is about linear in the output's size: each pass visits every
//! edge or vertex once, and projection uses a uniform grid over the input.

use super::build::WeldOptions;
use super::error::{MeshError, OptionFault};
use super::halfedge::SimMesh;
use super::hash::FxHashSet;
use rayon::prelude::*;
use super::ids::{FaceId, VertexId};
pub use super::sizing::{long_edge_area_share, FINE_ENOUGH_LONG_SHARE};
use super::spatial::{
    add, bbox, closest_on_segment, closest_on_triangle, cross, dist2, dot, norm, sub, Grid,
};

/// Options of [`remesh`].
#[derive(Clone, Debug, PartialEq)]
pub struct RemeshOptions {
    /// Target edge length in scene units.
    pub target_edge: f64,
    /// Split / collapse / flip / smooth iterations after the first
    /// refinement. Default 5.
    pub iterations: usize,
    /// Edges whose faces meet at a dihedral angle above this (degrees) are
    /// sharp creases, kept as feature lines. Default 40.
    pub crease_angle_deg: f64,
    /// Also remesh surfaces that are already fine enough everywhere
    /// (coarsening them). Default false: such a surface is left as it is.
    /// A surface is fine enough when at most [`FINE_ENOUGH_LONG_SHARE`] of
    /// its area lies in triangles with an edge longer than the remesher's
    /// split length (4/3 of the target). A graded asset (fine bolts, large
    /// flat panels) is remeshed even when its *mean* edge is below the
    /// target: its large triangles would otherwise set the crack pattern.
    pub coarsen: bool,
    /// How far an edge may stray from a curved input surface, as a
    /// fraction of `target_edge`: where the input bends tighter than the
    /// target edge can follow (a knob, a hose, a bevel), edges shorten to
    /// `sqrt(6 e r)` for a radius of curvature `r` and error `e` (Botsch &
    /// Kobbelt's adaptive sizing), down to `min_edge_fraction` of the
    /// target. Default 0.02; 0 keeps the edge length uniform.
    pub chord_error: f64,
    /// The shortest edge the curvature may ask for, as a fraction of
    /// `target_edge`. Default 0.25.
    pub min_edge_fraction: f64,
    /// How far each vertex is moved at random along the surface between
    /// the first passes, as a fraction of its edge length (0: no jitter).
    /// Local edits and smoothing keep a regular lattice as it is (a
    /// coarsened grid stays a grid, rows and all), and cracks follow its
    /// rows; jittered, the passes that follow settle into an irregular
    /// mesh with no direction of its own. An input already fine enough
    /// is jittered before every pass but the last two; a coarse one once,
    /// after the splits that refine it (refined, a regular grid is a
    /// lattice too). Default 0.3.
    pub jitter: f64,
    /// The seed of the jitter.
    pub seed: u64,
}

impl Default for RemeshOptions {
    fn default() -> Self {
        RemeshOptions {
            target_edge: 1.0,
            iterations: 5,
            crease_angle_deg: 40.0,
            coarsen: true,
            chord_error: 0.02,
            min_edge_fraction: 0.25,
            jitter: 0.3,
            seed: 0,
        }
    }
}

/// What `remesh` did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct RemeshReport {
    /// Whether the surface was remeshed (false: it was already fine enough).
    pub remeshed: bool,
    /// Triangles before and after.
    pub triangles: [usize; 2],
    /// Vertices before and after (welded positions).
    pub vertices: [usize; 2],
    /// Input edges kept as feature lines.
    pub feature_edges: usize,
    /// Mean edge length before and after.
    pub mean_edge: [f64; 2],
    /// Share of the input's area in triangles with an edge longer than
    /// 4/3 of the target (the split length).
    pub long_edge_area_share: f64,
}

/// About how many triangles a remesh of `mesh` to `target_edge` makes: the
/// area over that of an equilateral triangle of that edge.
pub fn estimate_triangles(mesh: &SimMesh, target_edge: f64) -> usize {
    let tri = 3f64.sqrt() / 4.0 * target_edge * target_edge;
    if tri.is_nan() || tri <= 0.0 {
        return usize::MAX;
    }
    let n = mesh.total_area() / tri;
    if n.is_finite() {
        n.ceil() as usize
    } else {
        usize::MAX
    }
}

/// Remesh `mesh` isotropically to `options.target_edge`; see the module
/// documentation. A surface that is already fine enough (see
/// [`RemeshOptions::coarsen`]) is returned as it is unless
/// `options.coarsen`.
///
/// # Errors
/// A target that is not a positive number, or a result that cannot be
/// built (it names the cause).
pub fn remesh(
    mesh: &SimMesh,
    options: &RemeshOptions,
) -> Result<(SimMesh, RemeshReport), MeshError> {
    let target = options.target_edge;
    if !(target.is_finite() && target > 0.0) {
        return Err(OptionFault::RemeshTarget(target).into());
    }
    let mean = mesh.mean_edge_length();
    let long_share = long_edge_area_share(mesh, 4.0 / 3.0 * target);
    let mut report = RemeshReport {
        triangles: [mesh.n_faces(), mesh.n_faces()],
        vertices: [mesh.n_vertices(), mesh.n_vertices()],
        mean_edge: [mean, mean],
        long_edge_area_share: long_share,
        ..Default::default()
    };
    if long_share <= FINE_ENOUGH_LONG_SHARE && !options.coarsen {
        return Ok((mesh.clone(), report));
    }
    let input = Input::new(mesh, options.crease_angle_deg, options.target_edge);
    report.feature_edges = input.n_features;
    let sizes = input.edge_sizes(options);
    let mut w = Work::from_input(mesh, &input, sizes);
    // Refine first: a coarse input needs several rounds of splits.
    for _ in 0..64 {
        if w.split_long() == 0 {
            break;
        }
    }
    // A fine input (one that would have been left as it is) is jittered
    // before the first collapses (a fine regular input would otherwise
    // coarsen into a regular lattice) and after every pass but the last
    // two, which settle the triangles' shapes. A coarse one is jittered
    // once, after its refining splits: midpoint splits of a regular grid
    // are a regular grid, which flips and smoothing turn into an
    // equilateral lattice (a 160x160 plate refined 3.5x: every edge
    // within 15 degrees of three directions, and cracks along them).
    // Once is enough to break it; every pass would cost a coarse input
    // many more splits (the teapot at 0.02: 284k vertices growing to 426k,
    // the remesh 3.6 s to 7.6 s).
    let fine = long_share <= FINE_ENOUGH_LONG_SHARE;
    let mut pass = 0u64;
    let mut jitter = |w: &mut Work| {
        if (fine || pass == 0) && options.jitter > 0.0 {
            w.jitter(&input, options.jitter, options.seed, pass);
        }
        pass += 1;
    };
    jitter(&mut w);
    for i in 0..options.iterations {
        w.split_long();
        w.collapse_short();
        w.flip_to_valence();
        w.smooth(&input);
        if i + 2 < options.iterations {
            jitter(&mut w);
        }
    }
    let out = w.to_input(mesh, &input);
    let (sim, _) = SimMesh::build(
        &out,
        &WeldOptions {
            relative_tolerance: 0.0,
        },
    )?;
    report.remeshed = true;
    report.triangles[1] = sim.n_faces();
    report.vertices[1] = sim.n_vertices();
    report.mean_edge[1] = sim.mean_edge_length();
    Ok((sim, report))
}

// ---------------------------------------------------------------- input

/// The input surface: features, charts and spatial grids for projection.
struct Input {
    /// Vertex positions (welded ids of the input mesh).
    pos: Vec<[f64; 3]>,
    /// Faces as vertex ids (dead input faces none).
    faces: Vec<[u32; 3]>,
    /// Chart of every face.
    chart: Vec<u32>,
    /// Feature edges as vertex pairs (sorted).
    features: FxHashSet<(u32, u32)>,
    n_features: usize,
    /// Cosine of the crease angle.
    cos_crease: f64,
    /// Each face's corners and bounding box, side by side for the
    /// projection's search.
    tris: Vec<BoxedTriangle>,
    face_grid: Grid,
    edge_grid: Grid,
    feature_list: Vec<(u32, u32)>,
}

/// A triangle's corners with its bounding box (low, high).
type BoxedTriangle = ([[f64; 3]; 3], [f64; 3], [f64; 3]);

/// A point's projection onto the input: face, barycentric coordinates,
/// point.
type Projection = (u32, [f64; 3], [f64; 3]);

/// Vertices per parallel part of [`Work::edges`].
const EDGE_CHUNK: usize = 8192;

fn key(a: u32, b: u32) -> (u32, u32) {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

impl Input {
    fn new(mesh: &SimMesh, crease_deg: f64, min_crease: f64) -> Input {
        let pos = mesh.positions().to_vec();
        let faces: Vec<[u32; 3]> = mesh
            .faces()
            .map(|f| mesh.face_vertices(f).map(|v| v.0))
            .collect();
        let cos_crease = crease_deg.to_radians().cos();
        let wedges = mesh.wedges();
        let same_corner = |fa: FaceId, fb: FaceId, v: VertexId| {
            let wa = corner_wedge(mesh, fa, v);
            let wb = corner_wedge(mesh, fb, v);
            wa == wb || wedges.channels().iter().all(|c| c.get(wa) == c.get(wb))
        };
        let mut features = FxHashSet::default();
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        fn join(p: &mut [u32], a: u32, b: u32) {
            let (ra, rb) = (find(p, a), find(p, b));
            if ra != rb {
                p[ra.max(rb) as usize] = ra.min(rb);
            }
        }
        // Inner edges: (a, b, face a, face b, a crease by its angle alone).
        let mut inner = Vec::new();
        for h in mesh.halfedges() {
            let (a, b) = (mesh.origin(h), mesh.dest(h));
            match mesh.twin(h) {
                None => {
                    features.insert(key(a.0, b.0));
                }
                Some(t) => {
                    if t.0 < h.0 {
                        continue;
                    }
                    let (fa, fb) = (mesh.face(h), mesh.face(t));
                    if mesh.face_group(fa) != mesh.face_group(fb)
                        || !same_corner(fa, fb, a)
                        || !same_corner(fa, fb, b)
                    {
                        features.insert(key(a.0, b.0));
                    } else {
                        let crease = dot(mesh.face_normal(fa), mesh.face_normal(fb)) < cos_crease;
                        inner.push((a.0, b.0, fa.0, fb.0, crease));
                    }
                }
            }
        }
        // A crease is a line of sharp edges at least `min_crease` long;
        // shorter runs of sharp edges are grain (a scan's noise, a rough
        // ground), which the remesher smooths over rather than pinning
        // a vertex at each.
        let mut run: Vec<u32> = (0..pos.len() as u32).collect();
        for &(a, b, _, _, crease) in &inner {
            if crease {
                join(&mut run, a, b);
            }
        }
        let mut run_length = vec![0.0f64; pos.len()];
        for &(a, b, _, _, crease) in &inner {
            if crease {
                let r = find(&mut run, a) as usize;
                run_length[r] += dist2(pos[a as usize], pos[b as usize]).sqrt();
            }
        }
        // Union-find over faces across non-feature edges.
        let mut parent: Vec<u32> = (0..faces.len() as u32).collect();
        for &(a, b, fa, fb, crease) in &inner {
            if crease && run_length[find(&mut run, a) as usize] >= min_crease {
                features.insert(key(a, b));
            } else {
                join(&mut parent, fa, fb);
            }
        }
        let chart: Vec<u32> = (0..faces.len() as u32)
            .map(|f| find(&mut parent, f))
            .collect();
        let mut feature_list: Vec<(u32, u32)> = features.iter().copied().collect();
        feature_list.sort_unstable();
        let mean = mesh.mean_edge_length().max(1e-300);
        let tris: Vec<BoxedTriangle> = faces
            .iter()
            .map(|t| {
                let c = t.map(|v| pos[v as usize]);
                let (lo, hi) = bbox(&c);
                (c, lo, hi)
            })
            .collect();
        let face_grid = Grid::new(tris.iter().map(|&(_, lo, hi)| (lo, hi)), mean);
        let edge_grid = Grid::new(
            feature_list
                .iter()
                .map(|&(a, b)| bbox(&[pos[a as usize], pos[b as usize]])),
            mean,
        );
        Input {
            n_features: feature_list.len(),
            cos_crease,
            pos,
            faces,
            chart,
            features,
            tris,
            face_grid,
            edge_grid,
            feature_list,
        }
    }

    /// The edge length each input vertex asks for ([`super::sizing`]).
    fn edge_sizes(&self, options: &RemeshOptions) -> Vec<f64> {
        super::sizing::edge_sizes(
            &self.pos,
            &self.faces,
            &self.features,
            options.target_edge,
            options.chord_error * options.target_edge,
            options.min_edge_fraction * options.target_edge,
        )
    }

    /// The closest point of the input faces of `chart` (any chart when
    /// `None`) to `p`: (face, barycentric coordinates, point).
    fn closest_face(&self, p: [f64; 3], chart: Option<u32>) -> Option<Projection> {
        let mut best: Option<(f64, u32, [f64; 3], [f64; 3])> = None;
        self.face_grid.search(p, |f| {
            let f = f as u32;
            if chart.is_some_and(|c| self.chart[f as usize] != c) {
                return None;
            }
            let (t, lo, hi) = &self.tris[f as usize];
            if let Some(b) = best {
                // No point of the face is nearer than its box (with a
                // margin for rounding, so the result is the full test's).
                let gap = (0..3)
                    .map(|k| {
                        let d = (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0);
                        d * d
                    })
                    .sum::<f64>();
                if gap > b.0 * (1.0 + 1e-9) {
                    return Some(b.0);
                }
            }
            let (q, bary) = closest_on_triangle(p, *t);
            let d = dist2(p, q);
            if best.is_none_or(|b| d < b.0) {
                best = Some((d, f, bary, q));
            }
            best.map(|b| b.0)
        });
        best.map(|(_, f, b, q)| (f, b, q))
    }

    /// The closest point on the input's feature edges to `p`.
    fn closest_feature(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        let mut best: Option<(f64, [f64; 3])> = None;
        self.edge_grid.search(p, |e| {
            let (a, b) = self.feature_list[e];
            let q = closest_on_segment(p, self.pos[a as usize], self.pos[b as usize]);
            let d = dist2(p, q);
            if best.is_none_or(|x| d < x.0) {
                best = Some((d, q));
            }
            best.map(|x| x.0)
        });
        best.map(|b| b.1)
    }
}

fn corner_wedge(mesh: &SimMesh, f: FaceId, v: VertexId) -> super::ids::WedgeId {
    let vs = mesh.face_vertices(f);
    let ws = mesh.face_wedges(f);
    let k = vs.iter().position(|&x| x == v).unwrap_or(0);
    ws[k]
}

// ---------------------------------------------------------------- work mesh

/// The mesh being remeshed: positions, faces with vertex-face incidence,
/// feature edges and each face's chart.
struct Work {
    pos: Vec<[f64; 3]>,
    faces: Vec<[u32; 3]>,
    alive: Vec<bool>,
    chart: Vec<u32>,
    vf: Vec<Vec<u32>>,
    features: FxHashSet<(u32, u32)>,
    /// Feature edges at each vertex.
    nfeat: Vec<u8>,
    /// Vertices that never move (feature corners and ends).
    corner: Vec<bool>,
    dead_vertex: Vec<bool>,
    /// The edge length each vertex asks for.
    size: Vec<f64>,
}

impl Work {
    fn from_input(mesh: &SimMesh, input: &Input, size: Vec<f64>) -> Work {
        let n = mesh.n_vertices();
        let mut vf = vec![Vec::new(); n];
        for (f, t) in input.faces.iter().enumerate() {
            for &v in t {
                vf[v as usize].push(f as u32);
            }
        }
        let mut w = Work {
            pos: input.pos.clone(),
            faces: input.faces.clone(),
            alive: vec![true; input.faces.len()],
            chart: input.chart.clone(),
            vf,
            features: input.features.clone(),
            nfeat: vec![0; n],
            corner: vec![false; n],
            dead_vertex: vec![false; n],
            size,
        };
        for &(a, b) in &input.feature_list {
            w.nfeat[a as usize] = w.nfeat[a as usize].saturating_add(1);
            w.nfeat[b as usize] = w.nfeat[b as usize].saturating_add(1);
        }
        // Feature lines end, branch or turn sharply at corners.
        let mut ends: Vec<Vec<u32>> = vec![Vec::new(); n];
        for &(a, b) in &input.feature_list {
            ends[a as usize].push(b);
            ends[b as usize].push(a);
        }
        let cos_turn = -(input.cos_crease);
        for (v, e) in ends.iter().enumerate() {
            w.corner[v] = w.nfeat[v] != 0 && w.nfeat[v] != 2;
            if w.nfeat[v] == 2 {
                let p = w.pos[v];
                let d1 = sub(w.pos[e[0] as usize], p);
                let d2 = sub(w.pos[e[1] as usize], p);
                let (l1, l2) = (norm(d1), norm(d2));
                // Straight on: the directions are opposite.
                if l1 > 0.0 && l2 > 0.0 && dot(d1, d2) > cos_turn * l1 * l2 {
                    w.corner[v] = true;
                }
            }
        }
        w
    }

    /// The faces holding edge `a b`, in `a`'s order.
    fn edge_faces_iter(&self, a: u32, b: u32) -> impl Iterator<Item = u32> + '_ {
        self.vf[a as usize]
            .iter()
            .copied()
            .filter(move |&f| self.faces[f as usize].contains(&b))
    }

    fn edge_faces(&self, a: u32, b: u32) -> Vec<u32> {
        self.edge_faces_iter(a, b).collect()
    }

    /// The two faces of interior edge `a b` (`None` for a border or
    /// non-manifold edge), without a list made for each edge.
    fn interior_faces(&self, a: u32, b: u32) -> Option<[u32; 2]> {
        let mut fs = self.edge_faces_iter(a, b);
        match (fs.next(), fs.next(), fs.next()) {
            (Some(f1), Some(f2), None) => Some([f1, f2]),
            _ => None,
        }
    }

    /// Every live edge once, in a fixed order: from its lower end, or from
    /// either end of a border edge (one face). Gathered vertex by vertex in
    /// order, each from its faces' half-edges to higher neighbours, so the
    /// list comes sorted without sorting it. (Testing each half-edge from
    /// the upper end by the faces around it read them out of order: a
    /// sixth of the remesh on the teapot at 1.9M faces.)
    fn edges(&self) -> Vec<(u32, u32)> {
        let n = self.vf.len();
        let parts: Vec<Vec<(u32, u32)>> = (0..n.div_ceil(EDGE_CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut out = Vec::new();
                // Per higher neighbour: whether a face holds the edge from
                // this end.
                let mut around: Vec<(u32, bool)> = Vec::new();
                for a in c * EDGE_CHUNK..((c + 1) * EDGE_CHUNK).min(n) {
                    around.clear();
                    let a32 = a as u32;
                    for &f in &self.vf[a] {
                        let t = self.faces[f as usize];
                        let Some(i) = t.iter().position(|&x| x == a32) else {
                            continue;
                        };
                        let (next, prev) = (t[(i + 1) % 3], t[(i + 2) % 3]);
                        if next > a32 {
                            around.push((next, true));
                        }
                        if prev > a32 {
                            around.push((prev, false));
                        }
                    }
                    around.sort_unstable();
                    let mut k = 0;
                    while k < around.len() {
                        let b = around[k].0;
                        let run = around[k..].iter().take_while(|x| x.0 == b).count();
                        // Sorted with `false` first: the run's last tells
                        // whether any face holds it from this end.
                        if run == 1 || around[k + run - 1].1 {
                            out.push((a32, b));
                        }
                        k += run;
                    }
                }
                out
            })
            .collect();
        parts.concat()
    }

    fn len(&self, a: u32, b: u32) -> f64 {
        dist2(self.pos[a as usize], self.pos[b as usize]).sqrt()
    }

    /// The length edge `a b` should have (the mean of its ends' sizes).
    fn target(&self, a: u32, b: u32) -> f64 {
        0.5 * (self.size[a as usize] + self.size[b as usize])
    }

    /// Longer than this, edge `a b` is split.
    fn hi(&self, a: u32, b: u32) -> f64 {
        4.0 / 3.0 * self.target(a, b)
    }

    fn is_feature(&self, a: u32, b: u32) -> bool {
        self.features.contains(&key(a, b))
    }

    /// Split every edge longer than 4/3 of its target at its midpoint;
    /// returns how many.
    fn split_long(&mut self) -> usize {
        let mut long: Vec<(u32, u32)> = self
            .edges()
            .into_iter()
            .filter(|&(a, b)| self.len(a, b) > self.hi(a, b))
            .collect();
        // Longest first, ties by id: a fixed order.
        long.sort_by(|x, y| {
            self.len(y.0, y.1)
                .total_cmp(&self.len(x.0, x.1))
                .then(x.cmp(y))
        });
        let mut n = 0;
        for (a, b) in long {
            let fs = self.edge_faces(a, b);
            if fs.is_empty() || self.len(a, b) <= self.hi(a, b) {
                continue;
            }
            self.split(a, b, &fs);
            n += 1;
        }
        n
    }

    fn split(&mut self, a: u32, b: u32, fs: &[u32]) {
        let m = self.pos.len() as u32;
        let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
        self.pos.push([0, 1, 2].map(|k| 0.5 * (pa[k] + pb[k])));
        self.size.push(self.target(a, b));
        self.vf.push(Vec::new());
        let feature = self.features.remove(&key(a, b));
        self.nfeat.push(if feature { 2 } else { 0 });
        self.corner.push(false);
        self.dead_vertex.push(false);
        if feature {
            self.features.insert(key(a, m));
            self.features.insert(key(m, b));
        }
        for &f in fs {
            let t = self.faces[f as usize];
            let i = (0..3)
                .find(|&i| {
                    let (x, y) = (t[i], t[(i + 1) % 3]);
                    (x == a && y == b) || (x == b && y == a)
                })
                .expect("edge in face");
            let (u, w, c) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
            self.faces[f as usize] = [u, m, c];
            let g = self.faces.len() as u32;
            self.faces.push([m, w, c]);
            self.alive.push(true);
            self.chart.push(self.chart[f as usize]);
            let wf = &mut self.vf[w as usize];
            if let Some(x) = wf.iter_mut().find(|x| **x == f) {
                *x = g;
            }
            self.vf[c as usize].push(g);
            self.vf[m as usize].push(f);
            self.vf[m as usize].push(g);
        }
    }

    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut n = Vec::new();
        self.neighbours_in(v, &mut n);
        n
    }

    /// [`Work::neighbours`] into `n` (a list reused from vertex to vertex).
    fn neighbours_in(&self, v: u32, n: &mut Vec<u32>) {
        n.clear();
        n.extend(
            self.vf[v as usize]
                .iter()
                .flat_map(|&f| self.faces[f as usize])
                .filter(|&u| u != v),
        );
        n.sort_unstable();
        n.dedup();
    }

    fn face_normal(&self, t: [u32; 3]) -> [f64; 3] {
        let p = t.map(|v| self.pos[v as usize]);
        cross(sub(p[1], p[0]), sub(p[2], p[0]))
    }

    /// Collapse edges shorter than `lo` where the rules allow.
    /// Collapse every edge shorter than 4/5 of its target where allowed.
    fn collapse_short(&mut self) {
        let lo = |w: &Work, a: u32, b: u32| 0.8 * w.target(a, b);
        let short: Vec<(u32, u32)> = self
            .edges()
            .into_iter()
            .filter(|&(a, b)| self.len(a, b) < lo(self, a, b))
            .collect();
        for (a, b) in short {
            if self.dead_vertex[a as usize] || self.dead_vertex[b as usize] {
                continue;
            }
            let fs = self.edge_faces(a, b);
            if fs.is_empty() || self.len(a, b) >= lo(self, a, b) {
                continue;
            }
            // Which end goes, and where the kept one ends up.
            let plan = self
                .collapse_plan(a, b)
                .or_else(|| self.collapse_plan(b, a));
            let Some((keep, gone, p)) = plan else {
                continue;
            };
            let hi = self.hi(a, b);
            if self.collapse_ok(keep, gone, p, &fs, hi) {
                self.collapse(keep, gone, p, &fs);
                let k = keep as usize;
                self.size[k] = self.size[k].min(self.size[gone as usize]);
            }
        }
    }

    /// Collapsing `gone` into `keep`: allowed by the feature rules? Where
    /// does `keep` go?
    fn collapse_plan(&self, keep: u32, gone: u32) -> Option<(u32, u32, [f64; 3])> {
        let (k, g) = (keep as usize, gone as usize);
        if self.corner[g] {
            return None;
        }
        let feature_edge = self.is_feature(keep, gone);
        if self.nfeat[g] > 0 {
            // A feature vertex slides along its own line only.
            if !feature_edge {
                return None;
            }
            return Some((keep, gone, self.pos[k]));
        }
        if self.nfeat[k] > 0 || self.corner[k] {
            return Some((keep, gone, self.pos[k]));
        }
        let (pa, pb) = (self.pos[k], self.pos[g]);
        Some((keep, gone, [0, 1, 2].map(|i| 0.5 * (pa[i] + pb[i]))))
    }

    fn collapse_ok(&self, keep: u32, gone: u32, p: [f64; 3], fs: &[u32], hi: f64) -> bool {
        // Link condition: the common neighbours are the opposite corners.
        let nk = self.neighbours(keep);
        let ng = self.neighbours(gone);
        let common = nk.iter().filter(|x| ng.binary_search(x).is_ok()).count();
        if common != fs.len() {
            return false;
        }
        // Two feature vertices joined by a non-feature edge, or a
        // boundary-only configuration, are refused by the plan already.
        for &u in ng.iter().chain(&nk) {
            if u != keep && u != gone && dist2(p, self.pos[u as usize]).sqrt() > hi {
                return false;
            }
        }
        // No face turns over.
        for &v in &[keep, gone] {
            for &f in &self.vf[v as usize] {
                if fs.contains(&f) {
                    continue;
                }
                let t = self.faces[f as usize];
                let before = self.face_normal(t);
                let moved = t.map(|x| if x == keep || x == gone { u32::MAX } else { x });
                let pts = [0, 1, 2].map(|i| {
                    if moved[i] == u32::MAX {
                        p
                    } else {
                        self.pos[t[i] as usize]
                    }
                });
                let after = cross(sub(pts[1], pts[0]), sub(pts[2], pts[0]));
                let (lb, la) = (norm(before), norm(after));
                if la <= 1e-12 * lb.max(1e-300) || dot(before, after) < 0.5 * lb * la {
                    return false;
                }
            }
        }
        // Keeps the mesh a surface: do not remove a vertex with too few faces.
        self.vf[gone as usize].len() > fs.len()
    }

    fn collapse(&mut self, keep: u32, gone: u32, p: [f64; 3], fs: &[u32]) {
        for &f in fs {
            self.alive[f as usize] = false;
            for &v in &self.faces[f as usize] {
                let list = &mut self.vf[v as usize];
                list.retain(|&x| x != f);
            }
        }
        let moved: Vec<u32> = std::mem::take(&mut self.vf[gone as usize]);
        for &f in &moved {
            for v in self.faces[f as usize].iter_mut() {
                if *v == gone {
                    *v = keep;
                }
            }
            self.vf[keep as usize].push(f);
        }
        // Feature edges of the removed vertex move to the kept one.
        if self.nfeat[gone as usize] > 0 {
            let joined = self.features.remove(&key(keep, gone));
            let gone_edges: Vec<(u32, u32)> = self
                .neighbours(keep)
                .into_iter()
                .filter(|&u| self.features.contains(&key(gone, u)))
                .map(|u| key(gone, u))
                .collect();
            for (a, b) in gone_edges {
                self.features.remove(&(a, b));
                let other = if a == gone { b } else { a };
                self.features.insert(key(keep, other));
            }
            if !joined {
                self.nfeat[keep as usize] += self.nfeat[gone as usize];
            }
        }
        self.pos[keep as usize] = p;
        self.dead_vertex[gone as usize] = true;
        self.nfeat[gone as usize] = 0;
    }

    /// Flip interior non-feature edges where that brings the four
    /// vertices' valences closer to their targets.
    fn flip_to_valence(&mut self) {
        let target = |w: &Work, v: u32| if w.nfeat[v as usize] > 0 { 4 } else { 6 };
        for (a, b) in self.edges() {
            if self.dead_vertex[a as usize] || self.dead_vertex[b as usize] || self.is_feature(a, b)
            {
                continue;
            }
            let Some([f1, f2]) = self.interior_faces(a, b) else {
                continue;
            };
            let opp = |t: [u32; 3]| t.into_iter().find(|&x| x != a && x != b).expect("triangle");
            let (t1, t2) = (self.faces[f1 as usize], self.faces[f2 as usize]);
            let (c, d) = (opp(t1), opp(t2));
            let val =
                |v: u32| self.vf[v as usize].len() as i64 + i64::from(self.nfeat[v as usize] > 0);
            let dev = |va: i64, vb: i64, vc: i64, vd: i64| {
                (va - target(self, a)).abs()
                    + (vb - target(self, b)).abs()
                    + (vc - target(self, c)).abs()
                    + (vd - target(self, d)).abs()
            };
            let (va, vb, vc, vd) = (val(a), val(b), val(c), val(d));
            if dev(va - 1, vb - 1, vc + 1, vd + 1) >= dev(va, vb, vc, vd) {
                continue;
            }
            // Not when `c d` is an edge already (asked only of the flips
            // that would help: the faces around `c` are read out of order).
            if c == d || self.edge_faces_iter(c, d).next().is_some() {
                continue;
            }
            // Orient: t1 runs a -> b.
            let (f1, f2, c, d) = if (0..3).any(|i| t1[i] == a && t1[(i + 1) % 3] == b) {
                (f1, f2, c, d)
            } else {
                (f2, f1, d, c)
            };
            let n1 = [c, a, d];
            let n2 = [d, b, c];
            let old = add(self.face_normal(t1), self.face_normal(t2));
            let (m1, m2) = (self.face_normal(n1), self.face_normal(n2));
            let ok = |m: [f64; 3]| {
                let (lm, lo) = (norm(m), norm(old));
                lm > 1e-12 * lo && dot(m, old) > 0.5 * lm * lo
            };
            if !(ok(m1) && ok(m2)) {
                continue;
            }
            self.faces[f1 as usize] = n1;
            self.faces[f2 as usize] = n2;
            self.vf[a as usize].retain(|&x| x != f2);
            self.vf[b as usize].retain(|&x| x != f1);
            self.vf[c as usize].push(f2);
            self.vf[d as usize].push(f1);
        }
    }
}

#[path = "remesh_moves.rs"]
mod moves;

#[path = "remesh_output.rs"]
mod output;

#[cfg(test)]
#[path = "remesh_tests.rs"]
mod tests;
