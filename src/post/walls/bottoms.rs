//! The walls' bottom line: one bottom vertex per root of a crack vertex,
//! hung below its rest position along the surface normal smoothed along
//! the crack (see the module docs of [`super`]), or from a bottom line
//! given per crack vertex.
//!
//! Given bottoms: the cut input's
//! walls follow the simulation surface's bottom line, carried across.
//!
//! A coarse input cut along the cracks turns under them at its own
//! facets, and a narrow gap's walls hung from its normals cross below the
//! surface (on spot, `mud` cut: 1,065 crossing pairs against 70 on the
//! simulation surface). The simulation surface's bottom line is the one
//! its walls were made (and uncrossed) with; the cut's crack vertices lie
//! on its cracks, so its walls hang from that line where it passes.

use super::*;

/// The bottom vertices: one slot per root vertex of a crack vertex, in
/// increasing root id, except that roots with exactly the same rest position
/// share a slot (see the module docs).
#[derive(Clone, Debug)]
pub(super) struct Bottoms {
    /// Slot of each vertex id that is the root of a crack vertex, else
    /// [`NONE`]. Several roots map to one slot when their rest positions
    /// are equal.
    pub(super) slot_of_root: Vec<usize>,
    /// Rest position of each slot's root.
    pub(super) rest: Vec<P3>,
    /// Bottom position of each slot: `rest - depth * n`, with `n` the
    /// slot's outward unit (or, failing every fallback, zero) normal from
    /// [`bottom_normals`], later moved along the surface by
    /// [`Bottoms::follow_the_surface`].
    pub(super) position: Vec<P3>,
    /// Each slot's outward unit (or zero) normal.
    pub(super) normal: Vec<P3>,
}

impl Bottoms {
    pub(super) fn new(mesh: &SimMesh, roots: &[u32], crack: &[HalfedgeId], depth: f64) -> Self {
        let mut list: Vec<u32> = crack
            .iter()
            .flat_map(|&h| [mesh.origin(h), mesh.dest(h)])
            .map(|v| roots[v.idx()])
            .collect();
        list.sort_unstable();
        list.dedup();
        // One slot per distinct rest position, in increasing root id.
        let mut slot_of_root = vec![NONE; mesh.n_vertices()];
        let mut slot_at: BTreeMap<[u64; 3], usize> = BTreeMap::new();
        let mut rest: Vec<P3> = Vec::new();
        for &r in &list {
            let p = mesh.position(VertexId(r));
            let key = p.map(|x| (x + 0.0).to_bits()); // -0.0 and 0.0 alike
            let next = rest.len();
            let s = *slot_at.entry(key).or_insert(next);
            if s == next {
                rest.push(p);
            }
            slot_of_root[r as usize] = s;
        }
        let mut normal = bottom_normals(mesh, roots, &slot_of_root, crack, rest.len());
        smooth_along_cracks(mesh, roots, &slot_of_root, crack, &mut normal, depth);
        let position = rest
            .iter()
            .zip(&normal)
            .map(|(&p, &n)| v3::sub(p, v3::scale(n, depth)))
            .collect();
        Bottoms {
            slot_of_root,
            rest,
            position,
            normal,
        }
    }

    /// Move every bottom vertex along the surface with the crack line: by
    /// the tangential part (perpendicular to the slot's normal) of the mean
    /// move `top - rest` of the crack vertices of the slot, or, at a
    /// T-junction, of the spanning sides' edges at the junction's parameter
    /// alone (`lines`, one per crack side): the split side's copies there
    /// open into the branch, and a bottom pulled after them slants the
    /// spanning side's wall under the split side's.
    pub(super) fn follow_the_surface(
        &mut self,
        mesh: &SimMesh,
        roots: &[u32],
        crack: &[HalfedgeId],
        lines: &[Vec<(f64, usize)>],
        top: &[P3],
    ) {
        let n = self.rest.len();
        let mut sum = vec![[0.0; 3]; n];
        let mut count = vec![0.0f64; n];
        // At T-junctions: the spanning sides' moves alone.
        let mut span_sum = vec![[0.0; 3]; n];
        let mut span_count = vec![0.0f64; n];
        let mut seen = vec![false; mesh.n_vertices()];
        let moved = |v: VertexId| v3::sub(top[v.idx()], mesh.position(v));
        for (&h, line) in crack.iter().zip(lines) {
            let (u, v) = (mesh.origin(h), mesh.dest(h));
            for w in [u, v] {
                if !seen[w.idx()] {
                    seen[w.idx()] = true;
                    let s = self.slot_of(roots, w);
                    sum[s] = v3::add(sum[s], moved(w));
                    count[s] += 1.0;
                }
            }
            let (mu, mv) = (moved(u), moved(v));
            for &(t, s) in &line[1..line.len() - 1] {
                let m = v3::add(v3::scale(mu, 1.0 - t), v3::scale(mv, t));
                span_sum[s] = v3::add(span_sum[s], m);
                span_count[s] += 1.0;
            }
        }
        for s in 0..n {
            if span_count[s] > 0.0 {
                sum[s] = span_sum[s];
                count[s] = span_count[s];
            }
        }
        for s in 0..n {
            if count[s] == 0.0 {
                continue;
            }
            let mean = v3::scale(sum[s], 1.0 / count[s]);
            if !mean.iter().all(|x| x.is_finite()) {
                continue;
            }
            let nrm = self.normal[s];
            let along = v3::sub(mean, v3::scale(nrm, v3::dot(mean, nrm)));
            self.position[s] = v3::add(self.position[s], along);
        }
    }

    /// The bottom slot of crack vertex `v`.
    pub(super) fn slot_of(&self, roots: &[u32], v: VertexId) -> usize {
        self.slot_of_root[roots[v.idx()] as usize]
    }
}

/// `v / |v|`, or zero when `|v|` is not finite or not above `1e-12 * mag`,
/// where `mag` is the sum of the magnitudes added up into `v` (so that
/// cancellation noise counts as zero).
pub(super) fn unit_or_zero(v: P3, mag: f64) -> P3 {
    let l = v3::norm(v);
    if l.is_finite() && l > 0.0 && l > 1e-12 * mag {
        v3::scale(v, 1.0 / l)
    } else {
        [0.0; 3]
    }
}

/// Whether `v` is exactly the zero vector (the "no normal" marker).
pub(super) fn is_zero(v: P3) -> bool {
    v == [0.0; 3]
}

/// Most passes of [`smooth_along_cracks`].
const MAX_SMOOTHING_PASSES: usize = 200;

/// Smooth the bottom normals along the cracks over about the walls'
/// `depth`: passes of averaging each slot's normal with its neighbours'
/// along crack edges, as many as a diffusion needs to reach `depth` (the
/// square of `depth` over the mean crack edge length). A wall hangs
/// `depth` below its crack, so a bottom line that follows the normals of
/// single faces zigzags wherever a coarse faceted surface (an input cut
/// along the cracks, its large faces meeting at a few degrees) turns
/// under it, and the walls of a narrow gap cross below the surface; the
/// walls of a fine surface hang as before.
fn smooth_along_cracks(
    mesh: &SimMesh,
    roots: &[u32],
    slot_of_root: &[usize],
    crack: &[HalfedgeId],
    normal: &mut [P3],
    depth: f64,
) {
    let slot = |v: VertexId| slot_of_root[roots[v.idx()] as usize];
    let mut pairs: Vec<(usize, usize)> = Vec::new();
    let mut length = 0.0;
    for &h in crack {
        let (a, b) = (slot(mesh.origin(h)), slot(mesh.dest(h)));
        if a != b && a != NONE && b != NONE {
            pairs.push((a.min(b), a.max(b)));
            length += v3::norm(v3::sub(
                mesh.position(mesh.dest(h)),
                mesh.position(mesh.origin(h)),
            ));
        }
    }
    if pairs.is_empty() || depth.is_nan() || depth <= 0.0 {
        return;
    }
    let spacing = length / pairs.len() as f64;
    pairs.sort_unstable();
    pairs.dedup();
    let passes = ((depth / spacing).powi(2).ceil() as usize).min(MAX_SMOOTHING_PASSES);
    for _ in 0..passes {
        let mut sum: Vec<P3> = normal.to_vec();
        for &(a, b) in &pairs {
            if !is_zero(normal[a]) && !is_zero(normal[b]) {
                sum[a] = v3::add(sum[a], normal[b]);
                sum[b] = v3::add(sum[b], normal[a]);
            }
        }
        for (n, s) in normal.iter_mut().zip(&sum) {
            if !is_zero(*n) {
                let l = v3::norm(*s);
                if l > 0.0 {
                    *n = v3::scale(*s, 1.0 / l);
                }
            }
        }
    }
}

/// The outward unit normal of every bottom slot (see the module docs for the
/// fallbacks).
pub(super) fn bottom_normals(
    mesh: &SimMesh,
    roots: &[u32],
    slot_of_root: &[usize],
    crack: &[HalfedgeId],
    n_slots: usize,
) -> Vec<P3> {
    let slot = |v: VertexId| slot_of_root[roots[v.idx()] as usize];
    // Area-weighted sum over the faces around every copy of each root; a
    // face counts once per root even if two of its corners share it.
    let mut sum = vec![[0.0; 3]; n_slots];
    let mut mag = vec![0.0; n_slots];
    for f in mesh.faces() {
        let vs = mesh.face_vertices(f);
        let [a, b, c] = vs.map(|v| mesh.position(v));
        let w = v3::cross(v3::sub(b, a), v3::sub(c, a));
        let mut seen = [NONE; 3];
        for (k, &v) in vs.iter().enumerate() {
            let s = slot(v);
            if s == NONE || seen.contains(&s) {
                continue;
            }
            seen[k] = s;
            sum[s] = v3::add(sum[s], w);
            mag[s] += v3::norm(w);
        }
    }
    let mut normal: Vec<P3> = sum
        .iter()
        .zip(&mag)
        .map(|(&s, &m)| unit_or_zero(s, m))
        .collect();

    // Fallback 1: mean of the neighbouring (along crack edges) normals.
    let first = normal.clone();
    let mut nsum = vec![[0.0; 3]; n_slots];
    let mut ncount = vec![0.0; n_slots];
    for &h in crack {
        let (a, b) = (slot(mesh.origin(h)), slot(mesh.dest(h)));
        for (x, y) in [(a, b), (b, a)] {
            if x != y && is_zero(first[x]) && !is_zero(first[y]) {
                nsum[x] = v3::add(nsum[x], first[y]);
                ncount[x] += 1.0;
            }
        }
    }
    for ((n, &s), &c) in normal.iter_mut().zip(&nsum).zip(&ncount) {
        if is_zero(*n) {
            *n = unit_or_zero(s, c);
        }
    }

    // Fallback 2: the normal of the face of the first crack side (in id
    // order) at the slot. Otherwise it stays zero.
    for &h in crack {
        for v in [mesh.origin(h), mesh.dest(h)] {
            let s = slot(v);
            if is_zero(normal[s]) {
                let n = mesh.face_normal(mesh.face(h));
                if n.iter().all(|x| x.is_finite()) {
                    normal[s] = n;
                }
            }
        }
    }
    normal
}

/// Per vertex of `mesh`: where its wall's bottom lies, as an offset from
/// its rest position, and the unit normal it hangs along, for the
/// displaced positions `top` ([`build_walls`]' bottom line, moved along
/// with the crack); zero off the cracks (and everywhere when there are no
/// walls to build).
pub fn bottom_offsets(
    mesh: &SimMesh,
    top: &[[f64; 3]],
    opts: &WallOptions,
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let mut offsets = vec![[0.0; 3]; mesh.n_vertices()];
    let mut normals = offsets.clone();
    let Some((roots, crack, bottoms, _)) = bottom_line(mesh, top, opts, None) else {
        return (offsets, normals);
    };
    for &h in &crack {
        for v in [mesh.origin(h), mesh.dest(h)] {
            let s = bottoms.slot_of(&roots, v);
            offsets[v.idx()] = v3::sub(bottoms.position[s], mesh.position(v));
            normals[v.idx()] = bottoms.normal[s];
        }
    }
    (offsets, normals)
}

impl Bottoms {
    /// Put every bottom vertex at the mean of the given bottoms (offsets
    /// from rest) of the crack vertices of its slot, along the mean of
    /// their normals (renormalised; the slot keeps its own where they
    /// cancel).
    pub(super) fn hang_from(
        &mut self,
        mesh: &SimMesh,
        roots: &[u32],
        crack: &[HalfedgeId],
        hang: Hang,
    ) {
        let n = self.rest.len();
        let mut sum = vec![[0.0; 3]; n];
        let mut nsum = vec![[0.0; 3]; n];
        let mut count = vec![0.0f64; n];
        let mut seen = vec![false; mesh.n_vertices()];
        for &h in crack {
            for v in [mesh.origin(h), mesh.dest(h)] {
                let (Some(o), Some(nv)) = (hang.offsets.get(v.idx()), hang.normals.get(v.idx()))
                else {
                    continue;
                };
                if seen[v.idx()] || !o.iter().chain(nv).all(|x| x.is_finite()) {
                    continue;
                }
                seen[v.idx()] = true;
                let s = self.slot_of(roots, v);
                sum[s] = v3::add(sum[s], v3::add(mesh.position(v), *o));
                nsum[s] = v3::add(nsum[s], *nv);
                count[s] += 1.0;
            }
        }
        for s in 0..n {
            if count[s] == 0.0 {
                continue;
            }
            self.position[s] = v3::scale(sum[s], 1.0 / count[s]);
            let nrm = unit_or_zero(nsum[s], count[s]);
            if !is_zero(nrm) {
                self.normal[s] = nrm;
            }
        }
    }
}
