//! The bonded film's system assembled in the nodes' tangent planes.
//!
//! A bonded node moves only in its tangent plane, so each has two unknowns
//! in an orthonormal basis `T_n = [t1 t2]` of that plane (none when it is
//! fixed). The shifted system `(I + dt K) x = b` of [`crate::sim::implicit`]
//! restricted to those coordinates is `(I + dt T^T K T) y = T^T b`, with the
//! same solution `x = T y`. Its 2x2 node blocks are assembled for each
//! solve into compressed rows (a row whose inputs did not change since the
//! last solve is kept, not computed again: see `tangent_rows.rs`): face `e`
//! couples its corners `a` and `b` by
//!
//! `K_ab = A_e / 2 (g_b g_a^T + (g_a . g_b) P_e)`
//!
//! (`g` the corners' barycentric gradients, `P_e` the face's tangent
//! projector; the derivative of [`crate::sim::forces::element_strain`]'s
//! corner forces), plus the interface term `k_n I` on the diagonal. One
//! product is then a single pass over the rows with two-vectors: about a
//! third of the memory traffic of the matrix-free product's two passes over
//! faces and nodes, which bounds the film's solves. Conjugate gradients
//! ([`crate::sim::cg::iterate`]) with the inverse diagonal blocks as
//! preconditioner (the block-Jacobi preconditioner of
//! [`Operator::block_preconditioner`] in these coordinates) sum every dot
//! product in fixed chunks in order, and each row is assembled on its own,
//! so the result does not depend on the thread count.

use crate::math::GrowGently;
use crate::geometry::element::Element;
use crate::math::v3;
use crate::sim::amg::{Multigrid, Rows};
use crate::sim::cg::{dot, iterate, iterate_with, CgReport, Vectors, CHUNK};
use crate::sim::implicit::Operator;
use rayon::prelude::*;

#[path = "tangent_rows.rs"]
mod rows;

/// A node's two tangent coordinates.
pub type V2 = [f64; 2];

/// A 2x2 block, row major.
type Block = [f64; 4];

/// The shifted system in tangent coordinates, with its working memory (kept
/// between solves so its memory is not paged in anew).
#[derive(Default)]
pub struct TangentSystem {
    /// Per node: its tangent basis (zero for a fixed node).
    basis: Vec<[[f64; 3]; 2]>,
    /// Row `n`'s entries are `offsets[n]..offsets[n + 1]`.
    offsets: Vec<u32>,
    cols: Vec<u32>,
    blocks: Vec<Block>,
    /// Per node: the inverse of its diagonal block (`[a, b, c]` for
    /// `[[a, b], [b, c]]`).
    pre: Vec<[f64; 3]>,
    b: Vec<V2>,
    y: Vec<V2>,
    r: Vec<V2>,
    z: Vec<V2>,
    p: Vec<V2>,
    ap: Vec<V2>,
    /// Precondition by the multigrid cycle instead of the diagonal blocks.
    use_multigrid: bool,
    /// The multigrid hierarchy and the fingerprint of the rows it was
    /// built for (rebuilt only when the rows change).
    multigrid: Option<(u64, Multigrid)>,
    /// Seconds spent building hierarchies, and solving, since made.
    pub seconds: [f64; 2],
    /// Hierarchies built since made.
    pub builds: usize,
    /// Per row: the key of the inputs it was assembled from.
    row_keys: Vec<u64>,
    /// Rows the last assembly computed (the others it kept).
    pub reassembled: usize,
}

/// A fingerprint of the rows (hashed in fixed chunks, combined in order).
fn fingerprint(offsets: &[u32], cols: &[u32], blocks: &[Block]) -> u64 {
    const K: u64 = 0x9e37_79b9_7f4a_7c15;
    let mix = |h: u64, w: u64| (h ^ w).wrapping_mul(K).rotate_left(29);
    let words = |s: &[u32]| {
        s.par_chunks(CHUNK)
            .map(|c| c.iter().fold(0u64, |h, &w| mix(h, u64::from(w))))
            .collect::<Vec<u64>>()
    };
    let floats: Vec<u64> = blocks
        .par_chunks(CHUNK)
        .map(|c| c.iter().flatten().fold(0u64, |h, &v| mix(h, v.to_bits())))
        .collect();
    words(offsets)
        .into_iter()
        .chain(words(cols))
        .chain(floats)
        .fold(cols.len() as u64, mix)
}

/// The inverse of the symmetric part of a 2x2 block (the identity when it
/// is not positive definite).
fn sym_inverse2(m: Block) -> [f64; 3] {
    let (a, b, c) = (m[0], 0.5 * (m[1] + m[2]), m[3]);
    let det = a * c - b * b;
    if !(det > 0.0 && det.is_finite() && a > 0.0) {
        return [1.0, 0.0, 1.0];
    }
    [c / det, -b / det, a / det]
}

#[inline]
fn mul_block(m: &Block, x: V2) -> V2 {
    [m[0] * x[0] + m[1] * x[1], m[2] * x[0] + m[3] * x[1]]
}

#[inline]
fn mul_pre(m: &[f64; 3], x: V2) -> V2 {
    [m[0] * x[0] + m[1] * x[1], m[1] * x[0] + m[2] * x[1]]
}

#[inline]
fn dot2(a: V2, b: V2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// Face `el`'s coupling `T_a^T K_ab T_b` of its corners `a` and `b` (their
/// gradients `ga`, `gb` and tangent bases `ba`, `bb`), before the step.
#[inline]
fn face_block(
    el: &Element,
    ga: [f64; 3],
    ba: [[f64; 3]; 2],
    gb: [f64; 3],
    bb: [[f64; 3]; 2],
) -> Block {
    let ne = el.normal;
    let half = 0.5 * el.area;
    let an = [v3::dot(ba[0], ne), v3::dot(ba[1], ne)];
    let gab = v3::dot(ga, gb);
    let agb = [v3::dot(ba[0], gb), v3::dot(ba[1], gb)];
    let bga = [v3::dot(bb[0], ga), v3::dot(bb[1], ga)];
    let bn = [v3::dot(bb[0], ne), v3::dot(bb[1], ne)];
    let mut blk = [0.0; 4];
    for i in 0..2 {
        for m in 0..2 {
            let proj = v3::dot(ba[i], bb[m]) - an[i] * bn[m];
            blk[2 * i + m] = half * (agb[i] * bga[m] + gab * proj);
        }
    }
    blk
}

/// Append node `a`'s row of `I + dt K` to `cols` and `blocks`: the
/// diagonal block first, then each other free corner of its fan once, in
/// the order the fan meets them. A fixed node's row is the identity alone.
fn push_row(
    op: &Operator,
    basis: &[[[f64; 3]; 2]],
    a: usize,
    dt: f64,
    cols: &mut Vec<u32>,
    blocks: &mut Vec<Block>,
) {
    let start = cols.len();
    cols.push(a as u32);
    blocks.push([0.0; 4]);
    if !op.fixed[a] {
        for &(f, k) in op.fans.fan(a) {
            let Some(Some(el)) = op.els.elements.get(f as usize) else {
                continue;
            };
            let ga = el.grads[k as usize];
            for (j, &b) in op.fans.corners(f as usize).iter().enumerate() {
                let b = b as usize;
                if op.fixed[b] {
                    continue;
                }
                let blk = face_block(el, ga, basis[a], el.grads[j], basis[b]);
                let slot = match cols[start..].iter().position(|&c| c as usize == b) {
                    Some(s) => start + s,
                    None => {
                        cols.push(b as u32);
                        blocks.push([0.0; 4]);
                        cols.len() - 1
                    }
                };
                for (o, v) in blocks[slot].iter_mut().zip(blk) {
                    *o += v;
                }
            }
        }
        if let Some(&k) = op.interface.get(a) {
            blocks[start][0] += k;
            blocks[start][3] += k;
        }
        for blk in &mut blocks[start..] {
            for v in blk.iter_mut() {
                *v *= dt;
            }
        }
    }
    blocks[start][0] += 1.0;
    blocks[start][3] += 1.0;
}

/// The length of node `a`'s row as [`push_row`] writes it: the node and
/// each other free corner of its fan's faces with elements, once.
fn row_len(op: &Operator, a: usize) -> u32 {
    if op.fixed[a] {
        return 1;
    }
    let mut seen: [u32; 32] = [0; 32];
    let mut extra: Vec<u32> = Vec::new();
    let mut n = 1usize;
    seen[0] = a as u32;
    for &(f, _) in op.fans.fan(a) {
        if !matches!(op.els.elements.get(f as usize), Some(Some(_))) {
            continue;
        }
        for &b in &op.fans.corners(f as usize) {
            if op.fixed[b as usize] || seen[..n.min(32)].contains(&b) || extra.contains(&b) {
                continue;
            }
            if n < 32 {
                seen[n] = b;
            } else {
                extra.push(b);
            }
            n += 1;
        }
    }
    n as u32
}

impl TangentSystem {
    /// Assemble `I + dt K` of `op` (a bonded operator: its node normals
    /// given) in tangent coordinates, reusing this system's memory.
    pub fn assemble(&mut self, op: &Operator, dt: f64) {
        let n_nodes = op.fans.n_vertices();
        assert_eq!(op.normals.len(), n_nodes, "a bonded operator");
        op.normals
            .par_iter()
            .enumerate()
            .map(|(n, &nrm)| {
                if op.fixed[n] {
                    [[0.0; 3]; 2]
                } else {
                    v3::plane_basis(nrm)
                }
            })
            .collect_into_vec(&mut self.basis);
        let basis = &self.basis;
        // Which rows change: those whose inputs' key is not the last
        // assembly's (see [`rows`]); all of them the first time.
        let keys = {
            let (mut nodes, mut faces, mut keys) = (Vec::new(), Vec::new(), Vec::new());
            rows::node_keys(op, basis, &mut nodes);
            rows::face_keys(op, &mut faces);
            rows::row_keys(op, &nodes, &faces, dt, &mut keys);
            keys
        };
        // The old keys are taken now and the new ones stored only once
        // every row is written: rows left half made (a panic) are never
        // kept.
        let old_keys = std::mem::take(&mut self.row_keys);
        let n_old = if self.offsets.len() == old_keys.len() + 1 {
            old_keys.len().min(n_nodes)
        } else {
            0
        };
        // Per row: kept (only old rows can be).
        let mut keep = vec![false; n_nodes];
        keep[..n_old]
            .par_iter_mut()
            .zip(&keys[..n_old])
            .zip(&old_keys[..n_old])
            .for_each(|((k, new), old)| *k = new == old);
        drop(old_keys);
        self.reassembled = n_nodes - keep.iter().filter(|&&k| k).count();
        // The rows are written in place: each node's length first (the
        // node itself and its fan's other free corners once; a kept row's
        // as it was), their offsets, the kept rows moved to theirs, then
        // every other row into its own slice. Gathering the rows in blocks
        // and joining them held the system twice, and more while the
        // joined arrays doubled (a fifth of the peak at 1.9M nodes).
        let old_offsets = std::mem::take(&mut self.offsets);
        let mut lens: Vec<u32> = Vec::new();
        (0..n_nodes)
            .into_par_iter()
            .map(|a| {
                if keep[a] {
                    old_offsets[a + 1] - old_offsets[a]
                } else {
                    row_len(op, a)
                }
            })
            .collect_into_vec(&mut lens);
        self.offsets.reserve_gently(n_nodes + 1);
        self.offsets.push(0);
        let mut end = 0u32;
        for &l in &lens {
            end += l;
            self.offsets.push(end);
        }
        drop(lens);
        let total = end as usize;
        self.cols.reserve_gently(total);
        self.blocks.reserve_gently(total);
        rows::move_kept_rows(
            &old_offsets,
            &self.offsets,
            &keep,
            &mut self.cols,
            &mut self.blocks,
        );
        drop(old_offsets);
        let offsets = &self.offsets;
        let mut slices = Vec::with_capacity(n_nodes.div_ceil(CHUNK));
        let (mut cols, mut blocks) = (&mut self.cols[..], &mut self.blocks[..]);
        for c in 0..n_nodes.div_ceil(CHUNK) {
            let (from, to) = (c * CHUNK, ((c + 1) * CHUNK).min(n_nodes));
            let len = (offsets[to] - offsets[from]) as usize;
            let (head, rest) = std::mem::take(&mut cols).split_at_mut(len);
            let (bhead, brest) = std::mem::take(&mut blocks).split_at_mut(len);
            slices.push((from..to, head, bhead));
            (cols, blocks) = (rest, brest);
        }
        let keep = &keep;
        slices.into_par_iter().for_each(|(range, cols, blocks)| {
            let base = offsets[range.start] as usize;
            let mut row_cols = Vec::new();
            let mut row_blocks = Vec::new();
            for a in range {
                if keep[a] {
                    continue;
                }
                row_cols.clear();
                row_blocks.clear();
                push_row(op, basis, a, dt, &mut row_cols, &mut row_blocks);
                let at = offsets[a] as usize - base;
                debug_assert_eq!(row_cols.len() as u32, offsets[a + 1] - offsets[a]);
                cols[at..at + row_cols.len()].copy_from_slice(&row_cols);
                blocks[at..at + row_blocks.len()].copy_from_slice(&row_blocks);
            }
        });
        self.row_keys = keys;
        // In the unit tests every kept row is checked against the row
        // computed anew (so every film run they make checks its cracks').
        #[cfg(test)]
        for a in (0..n_nodes).filter(|&a| keep[a]) {
            let (mut cols, mut blocks) = (Vec::new(), Vec::new());
            push_row(op, basis, a, dt, &mut cols, &mut blocks);
            let r = self.offsets[a] as usize..self.offsets[a + 1] as usize;
            assert!(
                self.cols[r.clone()] == cols[..] && self.blocks[r] == blocks[..],
                "kept row {a} is not the row computed anew"
            );
        }
        // The diagonal block is each row's first.
        let (offsets, blocks) = (&self.offsets, &self.blocks);
        (0..n_nodes)
            .into_par_iter()
            .map(|n| sym_inverse2(blocks[offsets[n] as usize]))
            .collect_into_vec(&mut self.pre);
    }

    /// Precondition the solves by the multigrid cycle (`true`) or by the
    /// inverse diagonal blocks (`false`, the default).
    pub fn set_multigrid(&mut self, on: bool) {
        self.use_multigrid = on;
        if !on {
            self.multigrid = None;
        }
    }

    /// The multigrid hierarchy of the last solve, if any.
    pub fn multigrid(&self) -> Option<&Multigrid> {
        self.multigrid.as_ref().map(|m| &m.1)
    }

    /// The hierarchy for the current rows, built when they changed.
    fn ensure_multigrid(&mut self) {
        let key = fingerprint(&self.offsets, &self.cols, &self.blocks);
        if self.multigrid.as_ref().is_some_and(|m| m.0 == key) {
            return;
        }
        self.multigrid = None;
        let rows = Rows {
            offsets: &self.offsets,
            cols: &self.cols,
            blocks: &self.blocks,
        };
        self.multigrid = Some((key, Multigrid::new(rows, &self.basis)));
        self.builds += 1;
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.basis.len()
    }

    /// `T^T f`: a node vector in tangent coordinates (zero at fixed nodes).
    pub fn restrict(&self, f: &[[f64; 3]], out: &mut Vec<V2>) {
        f.par_iter()
            .zip(self.basis.par_iter())
            .map(|(f, b)| [v3::dot(b[0], *f), v3::dot(b[1], *f)])
            .collect_into_vec(out);
    }

    /// `T y`: tangent coordinates back to node vectors.
    pub fn extend(&self, y: &[V2], out: &mut Vec<[f64; 3]>) {
        y.par_iter()
            .zip(self.basis.par_iter())
            .map(|(y, b)| v3::add(v3::scale(b[0], y[0]), v3::scale(b[1], y[1])))
            .collect_into_vec(out);
    }

    /// Row `n` of the product with `x`.
    #[inline]
    fn row(&self, n: usize, x: &[V2]) -> V2 {
        let (s, e) = (self.offsets[n] as usize, self.offsets[n + 1] as usize);
        let mut y = [0.0; 2];
        for (c, m) in self.cols[s..e].iter().zip(&self.blocks[s..e]) {
            let v = mul_block(m, x[*c as usize]);
            y = [y[0] + v[0], y[1] + v[1]];
        }
        y
    }

    /// `out = (I + dt K) x` in tangent coordinates.
    pub fn apply(&self, x: &[V2], out: &mut Vec<V2>) {
        (0..self.n_nodes())
            .into_par_iter()
            .with_min_len(512)
            .map(|n| self.row(n, x))
            .collect_into_vec(out);
    }

    /// [`solve`](Self::solve) for node vectors: `x = T y` with `(I + dt K)
    /// y = T^T rhs` (the right-hand side and the coordinates kept in this
    /// system's memory).
    pub fn solve_nodes(
        &mut self,
        rhs: &[[f64; 3]],
        x: &mut Vec<[f64; 3]>,
        tol: f64,
        max_iter: usize,
    ) -> CgReport {
        let (mut b, mut y) = (std::mem::take(&mut self.b), std::mem::take(&mut self.y));
        self.restrict(rhs, &mut b);
        let report = self.solve(&b, &mut y, tol, max_iter);
        self.extend(&y, x);
        (self.b, self.y) = (b, y);
        report
    }

    /// Solve `(I + dt K) y = rhs` from zero by preconditioned conjugate
    /// gradients to relative residual `tol` in at most `max_iter`
    /// iterations, into `y`.
    pub fn solve(&mut self, rhs: &[V2], y: &mut Vec<V2>, tol: f64, max_iter: usize) -> CgReport {
        let n = self.n_nodes();
        assert_eq!(rhs.len(), n, "one right-hand side per node");
        let mut r = std::mem::take(&mut self.r);
        let mut z = std::mem::take(&mut self.z);
        let mut p = std::mem::take(&mut self.p);
        let mut ap = std::mem::take(&mut self.ap);
        y.clear();
        y.resize_gently(n, [0.0; 2]);
        r.clear();
        r.extend_from_slice(rhs);
        for v in [&mut z, &mut p, &mut ap] {
            v.clear();
            v.resize_gently(n, [0.0; 2]);
        }
        let mut report = CgReport::default();
        let clock = std::time::Instant::now();
        if self.use_multigrid {
            self.ensure_multigrid();
        }
        let built = clock.elapsed().as_secs_f64();
        let mut multigrid = self.multigrid.take();
        let norm_b = dot(rhs, rhs).sqrt();
        if norm_b > 0.0 && norm_b.is_finite() {
            report.relative_residual = 1.0;
            let product = |p: &[V2], ap: &mut [V2]| {
                // ap = A p and p . ap in one pass over the rows.
                let parts: Vec<f64> = ap
                    .par_chunks_mut(CHUNK)
                    .enumerate()
                    .map(|(c, a)| {
                        let mut s = 0.0;
                        for (i, a) in a.iter_mut().enumerate() {
                            let n = c * CHUNK + i;
                            *a = self.row(n, p);
                            s += dot2(p[n], *a);
                        }
                        s
                    })
                    .collect();
                parts.iter().sum::<f64>()
            };
            let vectors = Vectors {
                x: y,
                r: &mut r,
                z: &mut z,
                p: &mut p,
                ap: &mut ap,
            };
            match multigrid.as_mut() {
                Some((_, mg)) => iterate_with(
                    product,
                    |r, z| mg.apply(r, z),
                    vectors,
                    norm_b,
                    tol,
                    max_iter,
                    &mut report,
                ),
                None => {
                    let pre = &self.pre;
                    iterate(
                        product,
                        |n, r| mul_pre(&pre[n], r),
                        vectors,
                        norm_b,
                        tol,
                        max_iter,
                        &mut report,
                    )
                }
            }
        } else {
            report.converged = norm_b == 0.0;
        }
        (self.r, self.z, self.p, self.ap) = (r, z, p, ap);
        self.multigrid = multigrid;
        self.seconds[0] += built;
        self.seconds[1] += clock.elapsed().as_secs_f64() - built;
        report
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Sym3;
    use crate::mesh::shapes::{jittered_plate, jittered_plate_input, Lcg};
    use crate::sim::forces::{Elements, Fans};
    use crate::sim::implicit::{preconditioner, CgScratch, Shifted};

    /// A curved, partly fixed film on a jittered plate: tilted unit
    /// normals, every seventh node fixed, a face without an element, an
    /// interface term at every node.
    struct Setting {
        fans: Fans,
        els: Elements,
        normals: Vec<[f64; 3]>,
        fixed: Vec<bool>,
        interface: Vec<f64>,
    }

    fn setting() -> Setting {
        let mesh = jittered_plate(12, 0.3, 5);
        let mut els = Elements::new(&mesh, f64::INFINITY);
        els.elements[11] = None;
        let n = mesh.n_vertices();
        let normals = (0..n)
            .map(|i| {
                let v = [0.3 * (i as f64).sin(), 0.2 * (i as f64 * 0.7).cos(), 1.0];
                v3::scale(v, 1.0 / v3::norm(v))
            })
            .collect();
        Setting {
            fans: Fans::new(&mesh),
            els,
            normals,
            fixed: (0..n).map(|i| i % 7 == 3).collect(),
            interface: (0..n).map(|i| 0.002 * (1.0 + (i % 5) as f64)).collect(),
        }
    }

    impl Setting {
        fn op(&self) -> Operator<'_> {
            Operator {
                fans: &self.fans,
                els: &self.els,
                normals: &self.normals,
                fixed: &self.fixed,
                interface: &self.interface,
            }
        }
    }

    /// The rows written in place over several chunks are each node's row
    /// as `push_row` makes it alone, with `row_len`'s lengths.
    #[test]
    fn rows_in_place_are_each_nodes_own_row() {
        let mesh = jittered_plate(100, 0.3, 9);
        assert!(mesh.n_vertices() > 2 * CHUNK, "several chunks");
        let mut els = Elements::new(&mesh, f64::INFINITY);
        els.elements[5000] = None;
        let n = mesh.n_vertices();
        let setting = Setting {
            fans: Fans::new(&mesh),
            els,
            normals: vec![[0.0, 0.0, 1.0]; n],
            fixed: (0..n).map(|i| i % 11 == 4).collect(),
            interface: vec![0.001; n],
        };
        let op = setting.op();
        let mut sys = TangentSystem::default();
        sys.assemble(&op, 0.3);
        assert_eq!(sys.offsets.len(), n + 1);
        for a in 0..n {
            let (mut cols, mut blocks) = (Vec::new(), Vec::new());
            push_row(&op, &sys.basis, a, 0.3, &mut cols, &mut blocks);
            let r = sys.offsets[a] as usize..sys.offsets[a + 1] as usize;
            assert_eq!(cols.len() as u32, row_len(&op, a), "node {a}");
            assert_eq!(sys.cols[r.clone()], cols[..], "node {a}");
            assert_eq!(sys.blocks[r], blocks[..], "node {a}");
        }
    }

    /// A system assembled again after a change computes only the rows
    /// whose inputs changed and is, bit for bit, the system assembled anew:
    /// a cut through the plate (its nodes above the cut copied to new
    /// nodes, a little apart), then one node's normal, another's fixed flag,
    /// a third's interface term and a face's element, then the step.
    #[test]
    fn assembling_again_computes_the_changed_rows_only() {
        let n = 100;
        let plate = jittered_plate_input(n, 0.3, 9);
        let mut cut = plate.clone();
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let (row, from, to) = (50, 20, 70);
        for i in from..=to {
            let mut p = cut.positions[id(i, row) as usize];
            p[1] += 0.05;
            let copy = cut.positions.len() as u32;
            cut.positions.push(p);
            for ch in cut.wedge_channels.iter_mut() {
                let w = ch.components;
                let v = ch.data[id(i, row) as usize * w..][..w].to_vec();
                ch.data.extend_from_slice(&v);
            }
            // The faces of the row of squares above the cut take the copy.
            for tri in cut.triangles[2 * n * row..2 * n * (row + 1)].iter_mut() {
                for c in tri.iter_mut() {
                    if *c == id(i, row) {
                        *c = copy;
                    }
                }
            }
        }
        let setting = |input: &crate::mesh::MeshInput| {
            let (mesh, _) = crate::mesh::shapes::build(input);
            let nv = mesh.n_vertices();
            Setting {
                fans: Fans::new(&mesh),
                els: Elements::new(&mesh, f64::INFINITY),
                normals: (0..nv)
                    .map(|i| {
                        let v = [0.1 * (i as f64).sin(), 0.1 * (i as f64 * 0.7).cos(), 1.0];
                        v3::scale(v, 1.0 / v3::norm(v))
                    })
                    .collect(),
                fixed: (0..nv).map(|i| i % 13 == 6).collect(),
                interface: vec![0.001; nv],
            }
        };
        let (before, mut after) = (setting(&plate), setting(&cut));
        assert!(after.fans.n_vertices() > before.fans.n_vertices());
        fn first_difference<T: PartialEq>(a: &[T], b: &[T]) -> Option<usize> {
            (0..a.len().max(b.len())).find(|&i| a.get(i) != b.get(i))
        }
        let same = |a: &TangentSystem, b: &TangentSystem| {
            let found = [
                ("offsets", first_difference(&a.offsets, &b.offsets)),
                ("cols", first_difference(&a.cols, &b.cols)),
                ("blocks", first_difference(&a.blocks, &b.blocks)),
                ("pre", first_difference(&a.pre, &b.pre)),
                ("basis", first_difference(&a.basis, &b.basis)),
            ];
            for (name, at) in found {
                assert!(at.is_none(), "{name} differ first at {at:?}");
            }
        };
        let anew = |s: &Setting, dt: f64| {
            let mut sys = TangentSystem::default();
            sys.assemble(&s.op(), dt);
            assert_eq!(sys.reassembled, sys.n_nodes());
            sys
        };
        let mut sys = TangentSystem::default();
        sys.assemble(&before.op(), 0.3);
        sys.assemble(&before.op(), 0.3);
        assert_eq!(sys.reassembled, 0, "nothing changed");
        sys.assemble(&after.op(), 0.3);
        same(&sys, &anew(&after, 0.3));
        let n_after = sys.n_nodes();
        // The cut's nodes, their copies and their neighbours: a few hundred.
        assert!(
            (60..n_after / 10).contains(&sys.reassembled),
            "{} of {n_after} rows computed after the cut",
            sys.reassembled
        );
        after.normals[300] = [0.0, 0.6, 0.8];
        after.fixed[7001] = !after.fixed[7001];
        after.interface[4321] = 0.002;
        after.els.elements[9000] = None;
        sys.assemble(&after.op(), 0.3);
        same(&sys, &anew(&after, 0.3));
        assert!(
            (4..80).contains(&sys.reassembled),
            "{} rows computed after four small changes",
            sys.reassembled
        );
        sys.assemble(&before.op(), 0.3);
        same(&sys, &anew(&before, 0.3));
        sys.assemble(&before.op(), 0.5);
        assert_eq!(sys.reassembled, sys.n_nodes(), "a new step changes every row");
        same(&sys, &anew(&before, 0.5));
    }

    fn random(n: usize, seed: u64) -> Vec<V2> {
        let mut rng = Lcg(seed);
        (0..n)
            .map(|_| [rng.next_f64() - 0.5, rng.next_f64() - 0.5])
            .collect()
    }

    fn norm(v: &[[f64; 3]]) -> f64 {
        v.iter().map(|x| v3::dot(*x, *x)).sum::<f64>().sqrt()
    }

    /// The assembled product is the matrix-free operator's `T^T (I + dt K) T`.
    #[test]
    fn the_assembled_product_is_the_operators_in_tangent_coordinates() {
        let s = setting();
        let op = s.op();
        let dt = 1e6;
        let mut sys = TangentSystem::default();
        sys.assemble(&op, dt);
        let y = random(sys.n_nodes(), 4);
        let mut ay = Vec::new();
        sys.apply(&y, &mut ay);
        // The same through the matrix-free operator.
        let mut x = Vec::new();
        sys.extend(&y, &mut x);
        let pre = preconditioner(&op.blocks(), dt);
        let shifted = Shifted {
            op: &op,
            dt,
            pre: &pre,
            tol: 1e-12,
            max_iter: 1,
        };
        let mut ax = vec![[0.0; 3]; x.len()];
        shifted.apply(&x, &mut Vec::new(), &mut ax);
        let mut want = Vec::new();
        sys.restrict(&ax, &mut want);
        let scale = want.iter().map(|v| dot2(*v, *v)).sum::<f64>().sqrt();
        assert!(scale > 1.0);
        for (n, (a, w)) in ay.iter().zip(&want).enumerate() {
            if s.fixed[n] {
                // A fixed node keeps its (zero) coordinates: the identity row.
                assert_eq!(*a, y[n]);
                continue;
            }
            for c in 0..2 {
                assert!(
                    (a[c] - w[c]).abs() < 1e-12 * scale,
                    "node {n}: {a:?} vs {w:?}"
                );
            }
        }
        // A tangent vector round-trips, and the normal part is dropped.
        let mut back = Vec::new();
        sys.restrict(&x, &mut back);
        for (n, (b, y)) in back.iter().zip(&y).enumerate() {
            if !s.fixed[n] {
                assert!((b[0] - y[0]).abs() < 1e-14 && (b[1] - y[1]).abs() < 1e-14);
                assert!(v3::dot(x[n], s.normals[n]).abs() < 1e-14);
            }
        }
    }

    /// The tangent solve reaches the matrix-free solve's solution, in about
    /// as many iterations (the same preconditioner), bit for bit the same at
    /// any thread count, at a film's step (1e12: the equilibrium).
    #[test]
    fn the_tangent_solve_matches_the_matrix_free_solve() {
        let s = setting();
        let op = s.op();
        let dt = 1e12;
        let mut rng = Lcg(8);
        let stress: Vec<Sym3> = (0..s.els.elements.len())
            .map(|_| Sym3 {
                xx: 1.0 + rng.next_f64(),
                yy: 1.0 + rng.next_f64(),
                xy: rng.next_f64() - 0.5,
                ..Sym3::ZERO
            })
            .collect();
        let rhs: Vec<[f64; 3]> = op
            .forces(&stress, &mut Vec::new())
            .iter()
            .map(|f| v3::scale(*f, dt))
            .collect();
        let pre = op.block_preconditioner(dt);
        let shifted = Shifted {
            op: &op,
            dt,
            pre: &pre,
            tol: 1e-10,
            max_iter: 2000,
        };
        let mut want = Vec::new();
        let free = shifted.solve(
            &rhs,
            &mut want,
            None,
            &mut Vec::new(),
            &mut CgScratch::default(),
        );
        assert!(free.converged);
        let solve = || {
            let mut sys = TangentSystem::default();
            sys.assemble(&op, dt);
            let mut x = Vec::new();
            let report = sys.solve_nodes(&rhs, &mut x, 1e-10, 2000);
            (report, x)
        };
        let (report, x) = solve();
        assert!(report.converged && report.relative_residual <= 1e-10);
        assert!(
            report.iterations.abs_diff(free.iterations) <= 2,
            "{} vs {} iterations",
            report.iterations,
            free.iterations
        );
        let diff: Vec<[f64; 3]> = x.iter().zip(&want).map(|(a, b)| v3::sub(*a, *b)).collect();
        assert!(norm(&want) > 0.0);
        assert!(
            norm(&diff) < 1e-8 * norm(&want),
            "{}",
            norm(&diff) / norm(&want)
        );
        for (n, x) in x.iter().enumerate() {
            if s.fixed[n] {
                assert_eq!(*x, [0.0; 3]);
            }
        }
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(solve)
        };
        let (one, many) = (run(1), run(4));
        assert_eq!(one.0, many.0);
        assert_eq!(one.1, many.1);
    }

    /// At a film's step (1e12, which makes the system the equilibrium's)
    /// the solve's own residual is the true one: `A y - b` by the assembled
    /// product is within the tolerance.
    #[test]
    fn solve_at_a_films_step() {
        let s = setting();
        let op = s.op();
        let dt = 1e12;
        let mut sys = TangentSystem::default();
        sys.assemble(&op, dt);
        let mut b = random(sys.n_nodes(), 12);
        for (n, b) in b.iter_mut().enumerate() {
            if s.fixed[n] {
                *b = [0.0; 2];
            } else {
                *b = [b[0] * dt, b[1] * dt];
            }
        }
        let mut y = Vec::new();
        let report = sys.solve(&b, &mut y, 1e-10, 2000);
        assert!(report.converged, "{report:?}");
        let mut ay = Vec::new();
        sys.apply(&y, &mut ay);
        let r: Vec<V2> = ay
            .iter()
            .zip(&b)
            .map(|(a, b)| [a[0] - b[0], a[1] - b[1]])
            .collect();
        let true_residual = dot(&r, &r).sqrt() / dot(&b, &b).sqrt();
        assert!(true_residual < 1e-9, "{true_residual}");
    }

    /// With the multigrid cycle the solve reaches the block-Jacobi solve's
    /// solution on a refined film in far fewer iterations, the same bits at
    /// any thread count, and a second solve of the same rows reuses the
    /// hierarchy.
    #[test]
    fn the_multigrid_solve_matches_the_jacobi_solve() {
        let mesh = jittered_plate(70, 0.3, 9);
        let n = mesh.n_vertices();
        let els = Elements::new(&mesh, f64::INFINITY);
        let fans = Fans::new(&mesh);
        let normals: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let v = [0.2 * (i as f64 * 0.1).sin(), 0.1, 1.0];
                v3::scale(v, 1.0 / v3::norm(v))
            })
            .collect();
        let fixed: Vec<bool> = (0..n).map(|i| i % 97 == 1).collect();
        // A shear-lag length of a few edges, as a film's.
        let interface = vec![1e-3; n];
        let op = Operator {
            fans: &fans,
            els: &els,
            normals: &normals,
            fixed: &fixed,
            interface: &interface,
        };
        let dt = 1e12;
        let mut b = random(n, 31);
        for (i, b) in b.iter_mut().enumerate() {
            *b = if fixed[i] {
                [0.0; 2]
            } else {
                [b[0] * dt, b[1] * dt]
            };
        }
        let solve = |multigrid: bool| {
            let mut sys = TangentSystem::default();
            sys.assemble(&op, dt);
            sys.set_multigrid(multigrid);
            let mut y = Vec::new();
            let report = sys.solve(&b, &mut y, 1e-10, 5000);
            (report, y, sys)
        };
        let (jac, yj, _) = solve(false);
        let (mg, ym, mut sys) = solve(true);
        assert!(jac.converged && mg.converged, "{jac:?} {mg:?}");
        assert!(mg.iterations * 3 < jac.iterations, "{jac:?} {mg:?}");
        let diff: Vec<V2> = yj
            .iter()
            .zip(&ym)
            .map(|(a, b)| [a[0] - b[0], a[1] - b[1]])
            .collect();
        assert!(dot(&diff, &diff).sqrt() < 1e-8 * dot(&yj, &yj).sqrt());
        assert!(sys.multigrid().unwrap().stats().levels.len() >= 2);
        sys.assemble(&op, dt);
        let mut again = Vec::new();
        assert_eq!(sys.solve(&b, &mut again, 1e-10, 5000), mg);
        assert_eq!((sys.builds, again), (1, ym.clone()));
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    let (r, y, _) = solve(true);
                    (r, y)
                })
        };
        assert_eq!(run(1), run(2));
        assert_eq!(run(1), (mg, ym));
    }
}
