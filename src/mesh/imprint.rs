//! Cutting a crack network into another triangulation of the same surface:
//! the cracks simulated on a remeshed copy of the input are carried onto
//! the input's own triangles, so that the surface away from the cracks is
//! the input's (its triangles, UVs, normals and seams), only cut.
//!
//! Each crack end is inserted into the input as a vertex exactly where it
//! lies (an input vertex or edge only when it lies on one, to a millionth
//! of the face); each crack segment is then walked across the input's
//! faces from one end to the other, every crossed edge split exactly where
//! the segment crosses it (an edge split joins the new vertex to the
//! opposite corners, so the walk always moves along an edge). So a crack
//! is a polyline on the input's surface, never moved onto the input's
//! vertices or edges, and the input's own vertices stay where they were.
//! The walked edges are opened into cracks.
//! Corner attributes follow the splits by interpolation within the input's
//! own faces, on each side of a seam.
//!
//! Per-vertex values of the cracked mesh (the relaxation displacement, the
//! crack time) are carried over: a new crack vertex takes them from the
//! cracked mesh's crack edge on its own side (the side whose faces lie
//! towards the vertex's own fan), any other vertex from the cracked mesh's
//! closest face.
//!
//! The work is about linear in the size of both meshes and the length of
//! the crack network: every search uses a uniform grid, and each segment's
//! walk visits only the faces it crosses.

use super::error::{EditFault, MeshError, SkippedSegment, WalkFault};
use super::halfedge::SimMesh;
use super::ids::{FaceId, HalfedgeId, VertexId};
use super::spatial::{
    add, bbox, closest_on_triangle, cross, dist2, dot, norm, position_key as key, scale, sub, Grid,
};
use std::collections::BTreeMap;

/// A point closer to a vertex than this barycentric distance is that
/// vertex; closer to an edge, a point of that edge: only rounding apart.
const SNAP_VERTEX: f64 = 1e-6;
const SNAP_EDGE: f64 = 1e-6;
/// A crossing this close (as a fraction of the edge) to an end of the
/// crossed edge is that end: only rounding apart.
const SNAP_CROSSING: f64 = 1e-6;
/// A crack point this close to an input vertex or edge, in mean edge
/// lengths of the cracked mesh, is that vertex or a point of that edge: a
/// hundredth of an edge of the simulation (a fraction of a crack's width),
/// so no sliver finer than single precision can hold is cut in beside it.
/// A walk crossing an edge this close to its own vertex or to its end
/// flips that edge instead (`Cutter::flip_beside`).
const SNAP_LENGTH: f64 = 1e-2;
/// Most edges one step of a walk flips before it crosses one.
const MAX_STEP_FLIPS: usize = 3;
/// Most crack segments, in percent, that may be left out of a cut.
const MAX_SKIPPED_PERCENT: usize = 1;
/// Most vertices the search along edges visits for one segment.
const MAX_SEARCH: usize = 20_000;

/// An `f64` ordered totally, for the search's heap.
#[derive(Clone, Copy, PartialEq)]
struct Key(f64);
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Key {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// The input mesh with the cracks cut in, and the per-vertex values
/// carried over from the cracked mesh.
#[derive(Clone, Debug)]
pub struct Imprinted {
    /// The cut mesh.
    pub mesh: SimMesh,
    /// Per vertex of [`Imprinted::mesh`]: the cracked mesh's displacement
    /// there, on the vertex's side of any crack.
    pub displacement: Vec<[f64; 3]>,
    /// Per vertex: the crack time there (NaN off the cracks).
    pub crack_time: Vec<f64>,
    /// Per array [`imprint`] was given to carry, per vertex: the array's
    /// value there, on the vertex's side of any crack.
    pub carried: Vec<Vec<[f64; 3]>>,
    /// The cut edges as segments at rest, with their times.
    pub segments: Vec<[[f64; 3]; 2]>,
    /// Per segment: the time of the crack segment it was cut for.
    pub segment_times: Vec<f64>,
    /// Crack ends within rounding of an input vertex or edge, and edge
    /// crossings within rounding of an end of the edge, taken to be there.
    pub snapped: usize,
    /// Segments a straight walk could not follow (across a crease or a
    /// seam), cut along the input's edges instead.
    pub along_edges: usize,
    /// Segments whose ends lie on two shells of the input that touch,
    /// cut on each shell up to its border.
    pub across_shells: usize,
    /// Edges leaving the cracks split near them
    /// (`refine_along_cracks`).
    pub refined: usize,
    /// Segments left out: their ends are not joined by the input nearby.
    pub skipped: usize,
    /// Edges next to the cut flipped so no needle lies along a crack
    /// (`settle`), or beside a walk so it cuts no sliver
    /// (`Cutter::flip_beside`).
    pub settled: usize,
}

/// Cut the crack segments `segments` (at rest, on the surface of
/// `cracked`; `times` per segment) into `base` (the same surface,
/// triangulated otherwise) and carry `displacement`, `crack_time` and each
/// array of `carry` (all per vertex of `cracked`: the gaps' moves, the
/// walls' bottom line) over.
///
/// # Errors
/// [`MeshError::InvalidEdit`] when a segment cannot be walked across
/// `base` (its ends lie on parts of the surface the input does not join),
/// naming the segment.
pub fn imprint(
    base: &SimMesh,
    cracked: &SimMesh,
    segments: &[[[f64; 3]; 2]],
    times: &[f64],
    displacement: &[[f64; 3]],
    crack_time: &[f64],
    carry: &[&[[f64; 3]]],
) -> Result<Imprinted, MeshError> {
    let mut cut = Cutter::new(base.clone(), SNAP_LENGTH * cracked.mean_edge_length());
    let normals = end_normals(cracked, segments);
    let edge = cracked.mean_edge_length();
    let mut ends = Ends {
        normals,
        at: BTreeMap::new(),
        first: BTreeMap::new(),
        reach: 0.1 * edge,
        shell_reach: 0.5 * edge,
    };
    let skipped = cut_segments(&mut cut, &mut ends, segments, times)?;
    let Cutter {
        mut mesh,
        marks,
        snapped,
        along_edges_used,
        across_shells,
        n_original,
        children,
        flipped,
        ..
    } = cut;
    // The faces the cut made or reshaped (and, below, those the
    // refinement adds): where the triangulation may settle.
    let reshaped: Vec<bool> = (0..n_original).map(|f| !children[f].is_empty()).collect();
    let (out_segments, out_times) = open_marks(&mut mesh, &marks)?;
    let refined = refine_along_cracks(&mut mesh, cracked.mean_edge_length())?;
    let settled = flipped + settle(&mut mesh, &reshaped);
    let sampler = Sampler::new(cracked);
    let on_crack = crack_flags(&mesh);
    let values = sampler.carry(&mesh, &on_crack, displacement, crack_time, carry);
    Ok(Imprinted {
        mesh,
        displacement: values.displacement,
        crack_time: values.crack_time,
        carried: values.carried,
        segments: out_segments,
        segment_times: out_times,
        snapped,
        along_edges: along_edges_used,
        across_shells,
        skipped,
        refined,
        settled,
    })
}

/// The cracked surface's normal (not normalised) at each crack end of
/// `segments`, by the end's exact position, to find the end's own shell.
fn end_normals(cracked: &SimMesh, segments: &[[[f64; 3]; 2]]) -> BTreeMap<[u64; 3], [f64; 3]> {
    // The crack ends, once each (by their exact position).
    let mut wanted: BTreeMap<[u64; 3], ()> = BTreeMap::new();
    for s in segments {
        for p in s {
            wanted.insert(key(*p), ());
        }
    }
    // The cracked surface's normal at each end, to find its own shell.
    let mut normals: BTreeMap<[u64; 3], [f64; 3]> = BTreeMap::new();
    for v in cracked.vertices() {
        if let Some(n) = normals.get_mut(&key(cracked.position(v))) {
            for f in cracked.vertex_faces(v) {
                let [a, b, c] = cracked.face_vertices(f).map(|u| cracked.position(u));
                *n = add(*n, cross(sub(b, a), sub(c, a)));
            }
        } else if wanted.contains_key(&key(cracked.position(v))) {
            let mut n = [0.0; 3];
            for f in cracked.vertex_faces(v) {
                let [a, b, c] = cracked.face_vertices(f).map(|u| cracked.position(u));
                n = add(n, cross(sub(b, a), sub(c, a)));
            }
            normals.insert(key(cracked.position(v)), n);
        }
    }
    normals
}

/// Walks every crack segment across the input from end to end; returns
/// how many were left out (an error when more than
/// [`MAX_SKIPPED_PERCENT`] percent were).
fn cut_segments(
    cut: &mut Cutter,
    ends: &mut Ends,
    segments: &[[[f64; 3]; 2]],
    times: &[f64],
) -> Result<usize, MeshError> {
    // A segment whose ends the input does not join nearby (the two sides
    // of a hole or of a repaired edge the remeshed surface bridged) is
    // left out; more than a few such, and the cut is refused.
    let mut skipped = 0usize;
    let mut first_skip = None;
    for (i, [a, b]) in segments.iter().enumerate() {
        let va = ends.vertex(cut, *a, None)?;
        let shell = cut.shell_of(va);
        let vb = ends.vertex(cut, *b, Some(shell))?;
        let time = times.get(i).copied().unwrap_or(f64::NAN);
        if let Err(why) = cut.walk(va, vb, time) {
            skipped += 1;
            first_skip.get_or_insert(SkippedSegment {
                index: i,
                from: *a,
                to: *b,
                why,
            });
        }
    }
    if skipped * 100 > segments.len() * MAX_SKIPPED_PERCENT {
        if let Some(example) = first_skip {
            return Err(EditFault::SkippedSegments {
                skipped,
                segments: segments.len(),
                example: Box::new(example),
            }
            .into());
        }
    }
    Ok(skipped)
}

/// The opened edges as segments at rest, and their times.
type Opened = (Vec<[[f64; 3]; 2]>, Vec<f64>);

/// Opens the walked edges `marks` into cracks; returns them as segments
/// at rest, with their times.
fn open_marks(mesh: &mut SimMesh, marks: &BTreeMap<(u32, u32), f64>) -> Result<Opened, MeshError> {
    // Open the walked edges (halfedge ids survive opening; vertices may be
    // copied).
    let mut opened: Vec<(HalfedgeId, f64)> = Vec::new();
    for (&(a, b), &time) in marks {
        let Some(h) = mesh.find_halfedge(VertexId(a), VertexId(b)) else {
            continue;
        };
        opened.push((h, time));
    }
    for &(h, _) in &opened {
        if mesh.twin(h).is_some() {
            mesh.open_edge(h)?;
        }
    }
    let mut out_segments = Vec::with_capacity(opened.len());
    let mut out_times = Vec::with_capacity(opened.len());
    for &(h, time) in &opened {
        out_segments.push([mesh.position(mesh.origin(h)), mesh.position(mesh.dest(h))]);
        out_times.push(time);
    }
    Ok((out_segments, out_times))
}

/// The crack ends inserted so far, per shell of the input.
struct Ends {
    /// The cracked surface's normal at each end (not normalised).
    normals: BTreeMap<[u64; 3], [f64; 3]>,
    /// Per end and shell: its vertex.
    at: BTreeMap<([u64; 3], u32), VertexId>,
    /// Per end: the shell it was first inserted in.
    first: BTreeMap<[u64; 3], u32>,
    /// How much farther than the closest face a face facing the end's
    /// normal may be.
    reach: f64,
    /// How far from `shell` an end may lie and still be put there.
    shell_reach: f64,
}

impl Ends {
    /// The vertex for the crack end `p`: in `shell` when it lies within
    /// [`Ends::shell_reach`] of it (so a crack stays on the shell it runs
    /// on where shells of the input touch or lie close), else where it was
    /// first put, else where it lies.
    fn vertex(
        &mut self,
        cut: &mut Cutter,
        p: [f64; 3],
        shell: Option<u32>,
    ) -> Result<VertexId, MeshError> {
        let k = key(p);
        let n = self.normals.get(&k).copied().unwrap_or([0.0; 3]);
        if let Some(sh) = shell {
            if let Some(&v) = self.at.get(&(k, sh)) {
                return Ok(v);
            }
            if let Some((f, bary)) = cut.locate(p, n, self.reach, Some((sh, self.shell_reach))) {
                let v = cut.insert_at(f, bary)?;
                self.at.insert((k, sh), v);
                self.first.entry(k).or_insert(sh);
                return Ok(v);
            }
        }
        if let Some(&sh) = self.first.get(&k) {
            return Ok(self.at[&(k, sh)]);
        }
        let Some((f, bary)) = cut.locate(p, n, self.reach, None) else {
            return Err(EditFault::NoFacesToCut.into());
        };
        let v = cut.insert_at(f, bary)?;
        let sh = cut.shell_of(v);
        self.at.insert((k, sh), v);
        self.first.insert(k, sh);
        Ok(v)
    }
}

fn value(d: &[[f64; 3]], i: usize) -> [f64; 3] {
    d.get(i)
        .copied()
        .filter(|x| x.iter().all(|c| c.is_finite()))
        .unwrap_or([0.0; 3])
}

/// The input mesh being cut: where each of its original faces went, and
/// the walked edges.
struct Cutter {
    mesh: SimMesh,
    /// The original faces, for locating points.
    grid: Grid,
    n_original: usize,
    /// Per face: the original face it is part of.
    original: Vec<u32>,
    /// Per original face: the faces split off it (and faces flipped
    /// across its edges, which lie partly over it).
    children: Vec<Vec<u32>>,
    /// Per face made by a flip (or split off one): the original faces it
    /// lies over besides its own.
    overlaps: BTreeMap<u32, Vec<u32>>,
    /// Per original face: its shell (the faces joined to it across edges).
    shells: Vec<u32>,
    /// The original faces' corners (a split face keeps its id but not its
    /// shape).
    originals: Vec<[[f64; 3]; 3]>,
    /// Walked edges (smaller vertex first) and their times.
    marks: BTreeMap<(u32, u32), f64>,
    snapped: usize,
    /// Segments cut along existing edges (the straight walk failed).
    along_edges_used: usize,
    /// Segments between two touching shells, cut on each up to its border.
    across_shells: usize,
    /// A crack point closer than this to a vertex or an edge lies there.
    snap: f64,
    /// Edges flipped so a walk does not cut a sliver.
    flipped: usize,
}

impl Cutter {
    fn new(mesh: SimMesh, snap: f64) -> Cutter {
        let n = mesh.n_faces();
        let cell = mesh.mean_edge_length().max(1e-12);
        let grid = Grid::new(
            mesh.faces()
                .map(|f| bbox(&mesh.face_vertices(f).map(|v| mesh.position(v)))),
            cell,
        );
        // A shell: the faces joined across edges.
        let (_, shells) = mesh.connected_components();
        let originals = mesh
            .faces()
            .map(|f| mesh.face_vertices(f).map(|v| mesh.position(v)))
            .collect();
        Cutter {
            grid,
            shells,
            originals,
            n_original: n,
            original: (0..n as u32).collect(),
            children: vec![Vec::new(); n],
            overlaps: BTreeMap::new(),
            marks: BTreeMap::new(),
            snapped: 0,
            along_edges_used: 0,
            across_shells: 0,
            snap,
            flipped: 0,
            mesh,
        }
    }

    fn triangle(&self, f: FaceId) -> [[f64; 3]; 3] {
        self.mesh.face_vertices(f).map(|v| self.mesh.position(v))
    }

    /// Record faces split off others.
    fn adopt(&mut self, pairs: &[(FaceId, FaceId)]) {
        for &(parent, child) in pairs {
            let o = self.original[parent.idx()];
            debug_assert_eq!(self.original.len(), child.idx());
            self.original.push(o);
            self.children[o as usize].push(child.0);
            // A piece of a flipped face lies over its other originals too.
            if let Some(also) = self.overlaps.get(&parent.0).cloned() {
                for &x in &also {
                    self.children[x as usize].push(child.0);
                }
                self.overlaps.insert(child.0, also);
            }
        }
    }

    /// The face of the cut mesh where `p` lies, with `p`'s barycentric
    /// coordinates in it: the closest of the original faces within
    /// `reach` of the closest distance that face the way of `normal` (where
    /// shells of the input touch or pass through each other, the one the
    /// point was simulated on), else the closest; then the closest of the
    /// faces split off it.
    fn locate(
        &self,
        p: [f64; 3],
        normal: [f64; 3],
        reach: f64,
        shell: Option<(u32, f64)>,
    ) -> Option<(FaceId, [f64; 3])> {
        let mut near: Vec<(f64, usize)> = Vec::new();
        let mut best = f64::INFINITY;
        self.grid.search(p, |f| {
            if f < self.n_original && shell.is_none_or(|(sh, _)| self.shells[f] == sh) {
                let (q, _) = closest_on_triangle(p, self.originals[f]);
                let d = dist2(p, q).sqrt();
                best = best.min(d);
                near.push((d, f));
            }
            Some((best + reach) * (best + reach))
        });
        if shell.is_some_and(|(_, r)| best > r) {
            return None;
        }
        near.sort_by_key(|x| x.1);
        near.dedup_by_key(|x| x.1);
        let facing = |f: usize| {
            let [a, b, c] = self.originals[f];
            let n = cross(sub(b, a), sub(c, a));
            let l = norm(n);
            l > 0.0 && dot(n, normal) > 0.5 * l * norm(normal)
        };
        let pick = |only_facing: bool| {
            near.iter()
                .filter(|(d, f)| *d <= best + reach && (!only_facing || facing(*f)))
                .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
                .map(|x| x.1)
        };
        let f0 = pick(true).or_else(|| pick(false))?;
        let mut found: Option<(f64, u32, [f64; 3])> = None;
        for f in std::iter::once(f0 as u32).chain(self.children[f0].iter().copied()) {
            let (q, bary) = closest_on_triangle(p, self.triangle(FaceId(f)));
            let d = dist2(p, q);
            if found.is_none_or(|b| d < b.0 || (d == b.0 && f < b.1)) {
                found = Some((d, f, bary));
            }
        }
        found.map(|(_, f, b)| (FaceId(f), b))
    }

    /// Split the edge of `h` at `t`, keeping the walked-edge marks on its
    /// halves. Returns the new vertex.
    fn split(&mut self, h: HalfedgeId, t: f64) -> Result<VertexId, MeshError> {
        let (a, b) = (self.mesh.origin(h).0, self.mesh.dest(h).0);
        let r = self.mesh.split_edge(h, t)?;
        self.adopt(&r.new_faces);
        let x = r.vertex.0;
        if let Some(time) = self.marks.remove(&(a.min(b), a.max(b))) {
            self.marks.insert((a.min(x), a.max(x)), time);
            self.marks.insert((x.min(b), x.max(b)), time);
        }
        Ok(r.vertex)
    }

    /// The shell (face-connected part of the input) of vertex `v`.
    fn shell_of(&self, v: VertexId) -> u32 {
        let f = self.mesh.face(self.mesh.vertex_halfedge(v));
        self.shells[self.original[f.idx()] as usize]
    }

    /// A vertex at the point of face `f` with barycentric coordinates
    /// `bary` (a corner or a point of an edge when within rounding of it).
    fn insert_at(&mut self, f: FaceId, bary: [f64; 3]) -> Result<VertexId, MeshError> {
        let vs = self.mesh.face_vertices(f);
        let hs = self.mesh.face_halfedges(f);
        let tri = self.triangle(f);
        let p = (0..3).fold([0.0; 3], |s, k| add(s, scale(tri[k], bary[k])));
        // Within the snapping distance of a corner: the closest corner.
        let near_corner = (0..3)
            .map(|k| (dist2(p, tri[k]), k))
            .filter(|&(d, _)| d <= self.snap * self.snap)
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        if let Some((d, k)) = near_corner {
            if d > 0.0 {
                self.snapped += 1;
            }
            return Ok(vs[k]);
        }
        let (kmax, &bmax) = bary
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &1.0));
        if bmax > 1.0 - SNAP_VERTEX {
            if bmax < 1.0 {
                self.snapped += 1;
            }
            return Ok(vs[kmax]);
        }
        let (kmin, &bmin) = bary
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &0.0));
        // The closest point of the edge opposite corner kmin (from corner
        // kmin + 1 to kmin + 2): the end lies there when that is within
        // the snapping distance (measured, not read off the barycentric
        // coordinates: in a needle the corner may lie far along the edge).
        let (i, j) = ((kmin + 1) % 3, (kmin + 2) % 3);
        let e = sub(tri[j], tri[i]);
        let ee = dot(e, e);
        let t = if ee > 0.0 {
            (dot(sub(p, tri[i]), e) / ee).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let on_edge = add(tri[i], scale(e, t));
        if (bmin < SNAP_EDGE || dist2(p, on_edge) <= self.snap * self.snap) && t > 0.0 && t < 1.0 {
            if bmin > 0.0 {
                self.snapped += 1;
            }
            return self.split(hs[i], t);
        }
        let r = self.mesh.split_face(f, bary)?;
        self.adopt(&r.new_faces);
        Ok(r.vertex)
    }

    /// Cut a path from `va` to `vb` and mark its edges: straight across
    /// the faces where the surface lets a straight walk reach `vb`, else
    /// (across a crease or a seam the walk cannot follow) the shortest
    /// path along the existing edges. Where the ends lie on two shells of
    /// the input that touch or pass through each other (panels modelled
    /// apart), each end is cut straight towards the other as far as it
    /// comes closer.
    fn walk(&mut self, va: VertexId, vb: VertexId, time: f64) -> Result<(), WalkFault> {
        let path = match self.straight(va, vb) {
            Ok(path) => path,
            Err(_) => match self.along_edges(va, vb) {
                Ok(path) => {
                    self.along_edges_used += 1;
                    path
                }
                Err(m) if self.shell_of(va) == self.shell_of(vb) => return Err(m),
                Err(_) => {
                    let (there, back) = (self.mesh.position(vb), self.mesh.position(va));
                    let p = self.straight_to(va, there);
                    let q = self.straight_to(vb, back);
                    self.across_shells += 1;
                    for w in p.windows(2).chain(q.windows(2)) {
                        self.mark(w[0], w[1], time);
                    }
                    return Ok(());
                }
            },
        };
        for w in path.windows(2) {
            self.mark(w[0], w[1], time);
        }
        Ok(())
    }

    /// The vertices of a straight walk from `va` to `vb`, crossed edges
    /// split. Fails when the walk comes back to a vertex or strays.
    fn straight(&mut self, va: VertexId, vb: VertexId) -> Result<Vec<VertexId>, WalkFault> {
        let target = self.mesh.position(vb);
        let start = norm(sub(target, self.mesh.position(va)));
        let mut path = vec![va];
        let mut v = va;
        while v != vb {
            if self.mesh.find_halfedge(v, vb).is_some() {
                path.push(vb);
                break;
            }
            if path.len() > 10_000 {
                return Err(WalkFault::NotReached);
            }
            let next = self.step(v, target)?;
            if norm(sub(target, self.mesh.position(next))) > 1.5 * start + 1e-12 {
                return Err(WalkFault::Strayed);
            }
            if path.contains(&next) {
                return Err(WalkFault::CameBack);
            }
            path.push(next);
            v = next;
        }
        Ok(path)
    }

    /// A straight walk from `va` towards the point `target` (on another
    /// shell), as long as it comes closer: up to its shell's border, or to
    /// where the two shells pass through each other.
    fn straight_to(&mut self, va: VertexId, target: [f64; 3]) -> Vec<VertexId> {
        let mut path = vec![va];
        let mut v = va;
        let mut d = norm(sub(target, self.mesh.position(va)));
        while path.len() <= 10_000 {
            let Ok(next) = self.step(v, target) else {
                break;
            };
            let dn = norm(sub(target, self.mesh.position(next)));
            if dn >= d || path.contains(&next) {
                break;
            }
            path.push(next);
            v = next;
            d = dn;
        }
        path
    }

    /// The shortest path from `va` to `vb` along the mesh's edges (A*
    /// with the straight distance), searching at most [`MAX_SEARCH`]
    /// vertices.
    fn along_edges(&self, va: VertexId, vb: VertexId) -> Result<Vec<VertexId>, WalkFault> {
        use std::cmp::Reverse;
        use std::collections::{BinaryHeap, HashMap};
        let target = self.mesh.position(vb);
        let h = |v: VertexId| norm(sub(target, self.mesh.position(v)));
        let mut dist: HashMap<u32, (f64, u32)> = HashMap::new();
        let mut heap = BinaryHeap::new();
        dist.insert(va.0, (0.0, va.0));
        heap.push(Reverse((Key(h(va)), va.0)));
        let mut done = 0usize;
        while let Some(Reverse((_, v))) = heap.pop() {
            if v == vb.0 {
                let mut path = vec![vb];
                let mut x = vb.0;
                while x != va.0 {
                    x = dist[&x].1;
                    path.push(VertexId(x));
                }
                path.reverse();
                return Ok(path);
            }
            done += 1;
            if done > MAX_SEARCH {
                break;
            }
            let dv = dist[&v].0;
            let pv = self.mesh.position(VertexId(v));
            for e in self.mesh.vertex_outgoing(VertexId(v)) {
                // Both neighbours: across the outgoing edge and, on a
                // border, the incoming one.
                for u in [self.mesh.dest(e), self.mesh.origin(self.mesh.prev(e))] {
                    let du = dv + norm(sub(self.mesh.position(u), pv));
                    if dist.get(&u.0).is_none_or(|x| du < x.0) {
                        dist.insert(u.0, (du, v));
                        heap.push(Reverse((Key(du + h(u)), u.0)));
                    }
                }
            }
        }
        Err(WalkFault::NotJoined)
    }

    fn mark(&mut self, a: VertexId, b: VertexId, time: f64) {
        let (a, b) = (a.0.min(b.0), a.0.max(b.0));
        if a != b {
            let e = self.marks.entry((a, b)).or_insert(time);
            if time < *e {
                *e = time;
            }
        }
    }

    /// One step of a walk from `v` towards `target`: the next vertex,
    /// where the straight way out of `v`'s fan crosses the opposite edge
    /// of the face it leaves through.
    fn step(&mut self, v: VertexId, target: [f64; 3]) -> Result<VertexId, WalkFault> {
        for attempt in 0..=MAX_STEP_FLIPS {
            let (g, t) = self.exit(v, target)?;
            let (a, b) = (self.mesh.origin(g), self.mesh.dest(g));
            let (pa, pb) = (self.mesh.position(a), self.mesh.position(b));
            let length = norm(sub(pb, pa));
            let near_end = t.min(1.0 - t) * length <= self.snap;
            if t <= SNAP_CROSSING || t >= 1.0 - SNAP_CROSSING || near_end {
                if t > 0.0 && t < 1.0 {
                    self.snapped += 1;
                }
                return Ok(if t < 0.5 { a } else { b });
            }
            // A crossing within the snapping distance of the walk's own
            // vertex or of its end (a sliver beside an earlier cut): the
            // crossed edge is flipped where it can be, and the walk goes on
            // through the faces that take its place.
            let q = add(scale(pa, 1.0 - t), scale(pb, t));
            let pv = self.mesh.position(v);
            let close = dist2(q, pv).min(dist2(q, target)) <= self.snap * self.snap;
            if close && attempt < MAX_STEP_FLIPS && self.flip_beside(g) {
                continue;
            }
            return Ok(self.split(g, t)?);
        }
        Err(WalkFault::NoEdgeToCross { vertex: v })
    }

    /// The edge a straight walk from `v` towards `target` leaves `v`'s fan
    /// through (the halfedge from `a` to `b`, in a face of `v`) and where it
    /// crosses it (`t` from `a`).
    fn exit(&self, v: VertexId, target: [f64; 3]) -> Result<(HalfedgeId, f64), WalkFault> {
        let pv = self.mesh.position(v);
        let d = sub(target, pv);
        let mut best: Option<(f64, HalfedgeId)> = None;
        for h in self.mesh.vertex_outgoing(v) {
            let a = self.mesh.position(self.mesh.dest(h));
            let b = self.mesh.position(self.mesh.dest(self.mesh.next(h)));
            let (ea, eb) = (sub(a, pv), sub(b, pv));
            let n = cross(ea, eb);
            let nn = norm(n);
            if nn <= 0.0 {
                continue;
            }
            let n = scale(n, 1.0 / nn);
            let dp = sub(d, scale(n, dot(d, n)));
            let ld = norm(dp);
            if ld <= 0.0 {
                continue;
            }
            let sa = dot(cross(ea, dp), n) / (norm(ea) * ld);
            let sb = dot(cross(dp, eb), n) / (norm(eb) * ld);
            // Facing the edge (a, b): its chord must lie ahead.
            let score = sa.min(sb);
            if best.is_none_or(|(s, _)| score > s) {
                best = Some((score, h));
            }
        }
        let Some((score, h)) = best else {
            return Err(WalkFault::NoFace { vertex: v });
        };
        if score < -0.05 {
            return Err(WalkFault::NoFaceFacing { vertex: v });
        }
        // The opposite edge, from a to b.
        let g = self.mesh.next(h);
        let (pa, pb) = (
            self.mesh.position(self.mesh.origin(g)),
            self.mesh.position(self.mesh.dest(g)),
        );
        let n = cross(sub(pa, pv), sub(pb, pv));
        let dp = sub(d, scale(n, dot(d, n) / dot(n, n)));
        let den = dot(cross(sub(pb, pa), dp), n);
        let t = if den != 0.0 {
            (dot(cross(sub(pv, pa), dp), n) / den).clamp(0.0, 1.0)
        } else {
            0.5
        };
        Ok((g, t))
    }

    /// Flip the edge of `g` (from `a` to `b` in face `(a, b, c)`, its twin
    /// in `(b, a, d)`) into `c`-`d` when that keeps the surface: no crack,
    /// border or seam, the two faces in one plane (within
    /// [`SETTLE_MAX_DEG`]) and both new faces facing their way. The two
    /// faces then count as split off both their original faces.
    fn flip_beside(&mut self, g: HalfedgeId) -> bool {
        let Some(tw) = self.mesh.twin(g) else {
            return false;
        };
        let (a, b) = (self.mesh.origin(g), self.mesh.dest(g));
        if self.marks.contains_key(&(a.0.min(b.0), a.0.max(b.0))) {
            return false;
        }
        if !tidy::flip_keeps_surface(&self.mesh, g) {
            return false;
        }
        let (f, h) = (self.mesh.face(g), self.mesh.face(tw));
        if self.mesh.flip_edge(g).is_err() {
            return false;
        }
        // Both faces now lie over every original face either lay over.
        let mut over: Vec<u32> = [f, h]
            .iter()
            .flat_map(|x| {
                let extra = self.overlaps.get(&x.0).cloned().unwrap_or_default();
                std::iter::once(self.original[x.idx()]).chain(extra)
            })
            .collect();
        over.sort_unstable();
        over.dedup();
        for x in [f, h] {
            for &o in &over {
                let kids = &mut self.children[o as usize];
                if !kids.contains(&x.0) {
                    kids.push(x.0);
                }
            }
            let own = self.original[x.idx()];
            self.overlaps
                .insert(x.0, over.iter().copied().filter(|&o| o != own).collect());
        }
        self.flipped += 1;
        true
    }
}

#[path = "imprint_sampler.rs"]
mod sampler;
use sampler::Sampler;
#[path = "imprint_tidy.rs"]
mod tidy;
use tidy::{crack_flags, refine_along_cracks, settle};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{build, grid_input, jittered_plate};

    /// A fine 16 x 16 grid over the plate [0, 4]^2, cracked along the
    /// vertex path `path` (grid indices), with displacement `+-0.01`
    /// away from the crack on each side (by the side's fan).
    type Cracked = (SimMesh, Vec<[[f64; 3]; 2]>, Vec<[f64; 3]>);

    fn cracked_grid(path: &[(usize, usize)]) -> Cracked {
        let mut input = grid_input(16, 16);
        for p in input.positions.iter_mut() {
            *p = p.map(|x| 0.25 * x);
        }
        let (mut m, _) = build(&input);
        let id = |(i, j): (usize, usize)| VertexId((j * 17 + i) as u32);
        let mut segments = Vec::new();
        for w in path.windows(2) {
            let h = m.find_halfedge(id(w[0]), id(w[1])).expect("grid edge");
            segments.push([m.position(id(w[0])), m.position(id(w[1]))]);
            m.open_edge(h).expect("open");
        }
        m.validate().expect("valid cracked grid");
        // Each side moves away from the crack: along its fan's middle at
        // a crack vertex, away from the crack line elsewhere.
        let normal_of_line = |p: [f64; 3]| {
            let (a, b) = (segments[0][0], segments[segments.len() - 1][1]);
            let d = sub(b, a);
            let n = [-d[1], d[0], 0.0];
            dot(sub(p, a), n)
        };
        let line_dir = {
            let (a, b) = (segments[0][0], segments[segments.len() - 1][1]);
            let d = sub(b, a);
            scale([-d[1], d[0], 0.0], 1.0 / norm(d))
        };
        let disp = m
            .vertices()
            .map(|v| {
                let p = m.position(v);
                let off = normal_of_line(p);
                let s = if off.abs() < 1e-12 {
                    m.fan_middle(v)
                        .map_or(0.0, |(_, d)| dot(d, line_dir).signum())
                } else {
                    off.signum()
                };
                scale(line_dir, 0.01 * s)
            })
            .collect();
        (m, segments, disp)
    }

    fn check_sides(im: &Imprinted, line_dir: [f64; 3], a: [f64; 3]) {
        let mut crack_vertices = 0;
        for v in im.mesh.vertices() {
            let on = im
                .mesh
                .vertex_outgoing(v)
                .any(|h| im.mesh.is_crack_halfedge(h))
                || im
                    .mesh
                    .halfedges()
                    .any(|h| im.mesh.is_crack_halfedge(h) && im.mesh.dest(h) == v);
            let d = dot(im.displacement[v.idx()], line_dir);
            let side = if on {
                crack_vertices += 1;
                let (_, m) = im.mesh.fan_middle(v).expect("fan");
                dot(m, line_dir)
            } else {
                dot(sub(im.mesh.position(v), a), line_dir)
            };
            if side.abs() > 1e-9 && !(on && side.abs() < 0.2) {
                assert!(
                    d * side > 0.0,
                    "vertex {v} at {:?} (crack {on}) moves {d} on side {side}",
                    im.mesh.position(v)
                );
            }
        }
        assert!(crack_vertices > 0);
    }

    #[test]
    fn a_crack_is_cut_into_a_coarser_input_and_each_side_keeps_its_move() {
        let base = jittered_plate(4, 0.2, 7);
        // A diagonal crack from (0.5, 0.5) to (3.5, 3.5): it crosses the
        // input's edges between its vertices.
        let path: Vec<(usize, usize)> = (2..=14).map(|k| (k, k)).collect();
        let (cracked, segments, disp) = cracked_grid(&path);
        let times: Vec<f64> = (0..segments.len()).map(|i| i as f64).collect();
        let time = vec![f64::NAN; cracked.n_vertices()];
        let im = imprint(&base, &cracked, &segments, &times, &disp, &time, &[]).expect("imprint");
        im.mesh.validate().expect("valid cut mesh");
        assert_eq!(im.skipped, 0);
        // The cut follows the crack: every cut point within the snapping
        // distance of the diagonal (a crack point that close to an input
        // vertex or edge is taken to be there), none moved farther onto an
        // input vertex.
        let snap = SNAP_LENGTH * cracked.mean_edge_length();
        let length: f64 = im.segments.iter().map(|[a, b]| norm(sub(*b, *a))).sum();
        let want = 3.0 * 2f64.sqrt();
        // (A segment walked on from a snapped point crosses the input's
        // edges on the line from there, so its crossings lie off the
        // diagonal by less than the snap.)
        for [a, b] in &im.segments {
            for p in [a, b] {
                let off = (p[0] - p[1]).abs() / 2f64.sqrt();
                assert!(off <= snap, "cut point {p:?} {off} off the diagonal");
            }
        }
        assert!(im.snapped <= 2, "{} points snapped", im.snapped);
        assert!(
            (length - want).abs() <= 2.0 * snap * im.snapped as f64 + 1e-9 * want,
            "cut length {length} vs {want}"
        );
        let line_dir = scale([-1.0, 1.0, 0.0], 1.0 / 2f64.sqrt());
        check_sides(&im, line_dir, [0.5, 0.5, 0.0]);
        // Open along the whole crack: every cut edge is a crack on both
        // sides, and the crack's inner vertices have two copies.
        let cut_halfedges = im
            .mesh
            .halfedges()
            .filter(|&h| im.mesh.is_crack_halfedge(h))
            .count();
        assert_eq!(cut_halfedges, 2 * im.segments.len());
        // The input's vertices stay where they were.
        for v in base.vertices() {
            assert_eq!(im.mesh.position(v), base.position(v));
        }
    }

    /// A crack end in a needle (a face whose third corner lies far along
    /// the line of its opposite edge) is put where it lies: on that edge
    /// when it is within the snapping distance of it, at its own closest
    /// point of the edge, not where dropping its barycentric coordinate
    /// would put it (a third of the needle's length away). And a point
    /// within the snapping distance of a corner is that corner.
    #[test]
    fn an_end_in_a_needle_stays_where_it_lies() {
        let input = crate::mesh::MeshInput {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [3.0, 1e-5, 0.0],
                [0.5, -1.0, 0.0],
            ],
            triangles: vec![[0, 1, 2], [1, 0, 3]],
            ..Default::default()
        };
        let (mesh, _) = build(&input);
        let snap = 1e-3;
        let mut cut = Cutter::new(mesh, snap);
        let f = FaceId(0);
        let tri = cut.triangle(f);
        // Barycentric (0.5, 0.2, 0.3): the point (1.1, 3e-6), 7e-7 from the
        // edge opposite corner 1 (from corner 2 to corner 0); dropping
        // corner 1's coordinate would put it at x = 1.125, 0.025 away.
        let bary = [0.5, 0.2, 0.3];
        let p = (0..3).fold([0.0; 3], |s, k| add(s, scale(tri[k], bary[k])));
        let v = cut.insert_at(f, bary).expect("insert");
        let q = cut.mesh.position(v);
        assert!(
            norm(sub(q, p)) <= snap,
            "inserted at {q:?}, {} from {p:?}",
            norm(sub(q, p))
        );
        cut.mesh.validate().expect("valid");
        // Within the snapping distance of corner 1: that corner.
        let near = [1.0 + 0.5 * snap, 0.0, 0.0];
        let (g, b) = cut
            .locate(near, [0.0, 0.0, 1.0], 0.0, None)
            .expect("a face");
        let w = cut.insert_at(g, b).expect("insert");
        assert_eq!(cut.mesh.position(w), [1.0, 0.0, 0.0]);
    }
}
