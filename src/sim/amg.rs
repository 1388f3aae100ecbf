//! Smoothed-aggregation algebraic multigrid for systems in compressed rows
//! of 2x2 blocks (the bonded film's tangent-plane system of
//! [`crate::sim::tangent`]), used as a conjugate-gradient preconditioner.
//!
//! Setup ([`Multigrid::new`], `setup.rs`), level by level until a few
//! hundred nodes remain:
//! - strong connections: `|A_ij|_F^2 > theta^2 |A_ii|_F |A_jj|_F`, with
//!   `theta` halved on each coarser level;
//! - greedy aggregation of the strong-connection graph in node order (a
//!   node whose strong neighbours are all free starts an aggregate with
//!   them; the rest join the neighbouring aggregate they are most strongly
//!   tied to, or group with each other): sequential, so deterministic;
//! - a tentative prolongator whose columns span, on each aggregate, the
//!   two translations in the tangent plane of its first node, expressed in
//!   every member's own tangent basis (the bases jump between neighbours,
//!   so the identity per aggregate would not be smooth) and orthonormalised
//!   on the aggregate; each coarse node carries the map from a translation
//!   in space to its coordinates on to the next level;
//! - one damped-Jacobi smoothing `P = (I - w D^-1 A) P_0`, `w = 4 / (3
//!   rho)` with `rho` the Gershgorin bound of `D^-1 A`;
//! - the Galerkin coarse operator `P^T A P`, made exactly symmetric.
//!
//! The preconditioner ([`Multigrid::apply`]) is one V-cycle from zero: on
//! each level one block Gauss-Seidel sweep forward, the coarse correction
//! of its residual, one sweep backward; the coarsest level is solved by a
//! dense Cholesky factor (or, when coarsening stalled above its size, by
//! symmetric sweeps). The sweeps are hybrid: Gauss-Seidel inside fixed
//! chunks of [`SMOOTH_CHUNK`] nodes, Jacobi between chunks, with each
//! node's couplings outside its chunk added to its diagonal (the l1
//! smoother of Baker, Falgout, Kolev and Yang 2011), which converges on
//! any symmetric positive definite matrix; the backward sweep is the
//! forward one's adjoint, so the cycle is symmetric positive definite, as
//! conjugate gradients need. The cycle reads its own copy of every level's
//! rows, made exactly symmetric and rounded to single precision (it only
//! preconditions; reading rows is most of its time).
//!
//! Every pass writes each node's (or coarse node's) values from a sum over
//! its own row in a fixed order, and the chunks are fixed, so the result
//! does not depend on the thread count.

use rayon::prelude::*;

mod dense;
mod setup;

use dense::Dense;

/// A node's two unknowns.
pub type V2 = [f64; 2];

/// A 2x2 block, row major.
pub type Block = [f64; 4];

/// Nodes per chunk of the hybrid Gauss-Seidel sweeps (fixed, so the
/// result does not depend on the thread count).
pub const SMOOTH_CHUNK: usize = 4096;

/// Coarsening stops at this many nodes (then a dense solve).
const COARSEST_NODES: usize = 200;

/// Most levels.
const MAX_LEVELS: usize = 12;

/// Symmetric sweep pairs of a coarsest level too large for a dense factor.
const COARSE_SWEEPS: usize = 4;

/// Fewest rows a thread takes in a pass.
const MIN_LEN: usize = 512;

/// Compressed rows of 2x2 blocks: row `n` is `offsets[n]..offsets[n + 1]`
/// of `cols` and `blocks`, its diagonal block first.
#[derive(Clone, Copy)]
pub struct Rows<'a> {
    /// Row starts, one more than the rows.
    pub offsets: &'a [u32],
    /// Column of each block.
    pub cols: &'a [u32],
    /// The blocks.
    pub blocks: &'a [Block],
}

impl Rows<'_> {
    /// Number of rows.
    pub fn n(&self) -> usize {
        self.offsets.len() - 1
    }

    #[inline]
    fn range(&self, n: usize) -> std::ops::Range<usize> {
        self.offsets[n] as usize..self.offsets[n + 1] as usize
    }
}

/// Owned compressed rows of 2x2 blocks of type `B`.
#[derive(Clone, Default)]
struct Owned<B> {
    offsets: Vec<u32>,
    cols: Vec<u32>,
    blocks: Vec<B>,
}

impl Owned<Block> {
    fn rows(&self) -> Rows<'_> {
        Rows {
            offsets: &self.offsets,
            cols: &self.cols,
            blocks: &self.blocks,
        }
    }
}

impl<B> Owned<B> {
    #[inline]
    fn range(&self, n: usize) -> std::ops::Range<usize> {
        self.offsets[n] as usize..self.offsets[n + 1] as usize
    }

    fn n(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    fn bytes(&self) -> usize {
        self.offsets.len() * 4 + self.cols.len() * 4 + self.blocks.len() * std::mem::size_of::<B>()
    }
}

#[inline]
fn mul(m: &Block, x: V2) -> V2 {
    [m[0] * x[0] + m[1] * x[1], m[2] * x[0] + m[3] * x[1]]
}

#[inline]
fn mul32(m: &[f32; 4], x: V2) -> V2 {
    let m = m.map(f64::from);
    [m[0] * x[0] + m[1] * x[1], m[2] * x[0] + m[3] * x[1]]
}

/// `m^T x`.
#[inline]
fn mul_t(m: &Block, x: V2) -> V2 {
    [m[0] * x[0] + m[2] * x[1], m[1] * x[0] + m[3] * x[1]]
}

#[inline]
fn mul_sym(m: &[f64; 3], x: V2) -> V2 {
    [m[0] * x[0] + m[1] * x[1], m[1] * x[0] + m[2] * x[1]]
}

/// The inverse of a symmetric 2x2 `[[a, b], [b, c]]` as `[a, b, c]` (the
/// identity when it is not positive definite).
fn sym_inverse(a: f64, b: f64, c: f64) -> [f64; 3] {
    let det = a * c - b * b;
    if !(det > 0.0 && det.is_finite() && a > 0.0) {
        return [1.0, 0.0, 1.0];
    }
    [c / det, -b / det, a / det]
}

/// One level of the cycle.
struct Level {
    /// The rows, exactly symmetric, in single precision.
    rows: Owned<[f32; 4]>,
    /// Per node: the inverse of its diagonal block plus its couplings
    /// outside its smoothing chunk (row sums of absolute values).
    smoother: Vec<[f64; 3]>,
}

/// Between a level and the next coarser one.
struct Transfer {
    /// The prolongator's rows (fine nodes; columns coarse nodes).
    p: Owned<Block>,
    /// Per coarse node, `rt_offsets[c]..rt_offsets[c + 1]` of `rt`: the
    /// (fine node, index into `p.blocks`) of its column, by fine node.
    rt_offsets: Vec<u32>,
    rt: Vec<(u32, u32)>,
}

/// The coarsest level's solve.
enum Coarsest {
    Dense(Dense),
    Sweeps,
}

/// What a hierarchy holds: nodes, blocks and bytes per level.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// Per level, finest first: (nodes, blocks of its rows, bytes it holds:
    /// its cycle rows, smoother, prolongator to the next level and vectors).
    pub levels: Vec<(usize, usize, usize)>,
}

/// The hierarchy and the cycle's working vectors.
pub struct Multigrid {
    levels: Vec<Level>,
    transfers: Vec<Transfer>,
    coarsest: Coarsest,
    /// Per level: right-hand side, solution, residual, the previous sweep's
    /// values (the first level's right-hand side and solution are the
    /// caller's).
    work: Vec<[Vec<V2>; 4]>,
}

impl Multigrid {
    /// The hierarchy of `a` (symmetric positive definite, diagonal block
    /// first in each row; a row without couplings is left to the smoother),
    /// with `basis[n]` node `n`'s tangent basis (the two unknowns' directions
    /// in space; zero for a fixed node).
    pub fn new(a: Rows<'_>, basis: &[[[f64; 3]; 2]]) -> Multigrid {
        // The finest level's rows are the caller's: the cycle's copy is
        // made symmetric as it is rounded, the setup reads them as they are.
        let mut levels = vec![level(a)];
        let mut transfers = Vec::new();
        let mut frames = setup::Frames {
            e: basis.to_vec(),
            t: basis.to_vec(),
        };
        let mut current: Option<Owned<Block>> = None;
        let mut theta = setup::THETA;
        loop {
            let rows = current.as_ref().map_or(a, |c| c.rows());
            if rows.n() <= COARSEST_NODES || levels.len() >= MAX_LEVELS {
                break;
            }
            let Some(c) = setup::coarsen(rows, &frames, theta) else {
                break;
            };
            if c.coarse.n() == 0 || c.coarse.n() * 10 > rows.n() * 9 {
                break;
            }
            levels.push(level(c.coarse.rows()));
            transfers.push(c.transfer);
            frames = c.frames;
            current = Some(c.coarse);
            theta *= 0.5;
        }
        // The factor reads only the lower triangle: symmetric by making.
        let rows = current.as_ref().map_or(a, |c| c.rows());
        let coarsest = if rows.n() <= COARSEST_NODES * 2 {
            Coarsest::Dense(Dense::new(rows))
        } else {
            Coarsest::Sweeps
        };
        // The finest level's right-hand side and solution are the caller's.
        let work = levels
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let n = l.rows.n();
                std::array::from_fn(|s| vec![[0.0; 2]; if i == 0 && s < 2 { 0 } else { n }])
            })
            .collect();
        Multigrid {
            levels,
            transfers,
            coarsest,
            work,
        }
    }

    /// Nodes, blocks and bytes per level.
    pub fn stats(&self) -> Stats {
        let levels = self
            .levels
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let n = l.rows.n();
                let transfer = self
                    .transfers
                    .get(i)
                    .map(|t| t.p.bytes() + t.rt_offsets.len() * 4 + t.rt.len() * 8)
                    .unwrap_or(0);
                let vectors: usize = self.work[i].iter().map(|v| v.len() * 16).sum();
                let bytes = l.rows.bytes() + n * 24 + transfer + vectors;
                (n, l.rows.blocks.len(), bytes)
            })
            .collect();
        Stats { levels }
    }

    /// `z = M^-1 r`: one V-cycle from zero.
    pub fn apply(&mut self, r: &[V2], z: &mut [V2]) {
        let Multigrid {
            levels,
            transfers,
            coarsest,
            work,
        } = self;
        cycle(levels, transfers, coarsest, work, r, z);
    }
}

/// A level's cycle rows (exactly symmetric, in single precision) and
/// smoother.
fn level(a: Rows<'_>) -> Level {
    let blocks = (0..a.n())
        .into_par_iter()
        .with_min_len(MIN_LEN)
        .flat_map_iter(|i| {
            a.range(i)
                .map(move |k| setup::mirrored(a, i, k).map(|v| v as f32))
        })
        .collect();
    let rows = Owned {
        offsets: a.offsets.to_vec(),
        cols: a.cols.to_vec(),
        blocks,
    };
    let smoother = (0..rows.n())
        .into_par_iter()
        .with_min_len(MIN_LEN)
        .map(|i| {
            let chunk = i / SMOOTH_CHUNK;
            let mut d = [0.0; 4];
            let mut l1 = [0.0; 2];
            for k in rows.range(i) {
                let j = rows.cols[k] as usize;
                let blk = rows.blocks[k].map(f64::from);
                if j == i {
                    d = blk;
                } else if j / SMOOTH_CHUNK != chunk {
                    l1[0] += blk[0].abs() + blk[1].abs();
                    l1[1] += blk[2].abs() + blk[3].abs();
                }
            }
            sym_inverse(d[0] + l1[0], 0.5 * (d[1] + d[2]), d[3] + l1[1])
        })
        .collect();
    Level { rows, smoother }
}

/// One V-cycle from zero on `levels` into `x`.
fn cycle(
    levels: &[Level],
    transfers: &[Transfer],
    coarsest: &Coarsest,
    work: &mut [[Vec<V2>; 4]],
    b: &[V2],
    x: &mut [V2],
) {
    let level = &levels[0];
    let ([_, _, r, old], rest) = work.split_first_mut().expect("a level");
    if levels.len() == 1 {
        match coarsest {
            Coarsest::Dense(d) => d.solve(b, x),
            Coarsest::Sweeps => {
                x.iter_mut().for_each(|v| *v = [0.0; 2]);
                for _ in 0..COARSE_SWEEPS {
                    sweep(level, b, x, old, false);
                    sweep(level, b, x, old, true);
                }
            }
        }
        return;
    }
    sweep_from_zero(level, b, x);
    residual(level, b, x, r);
    let t = &transfers[0];
    let [bc, xc, ..] = &mut rest[0];
    restrict(t, r, bc);
    let (bc, mut xc_owned) = (std::mem::take(bc), std::mem::take(xc));
    cycle(
        &levels[1..],
        &transfers[1..],
        coarsest,
        rest,
        &bc,
        &mut xc_owned,
    );
    interpolate(t, &xc_owned, x);
    (rest[0][0], rest[0][1]) = (bc, xc_owned);
    sweep(level, b, x, old, true);
}

/// One hybrid Gauss-Seidel sweep (forward, or `backward`): node after
/// node inside each chunk, `x_i += S_i (b - A x)_i` with the newest values
/// inside the chunk and the sweep's starting values outside it (`S_i` the
/// inverse of the diagonal block plus the couplings outside the chunk).
fn sweep(level: &Level, b: &[V2], x: &mut [V2], old: &mut Vec<V2>, backward: bool) {
    old.clear();
    old.extend_from_slice(x);
    sweep_from(level, b, x, old, backward);
}

/// [`sweep`] from `x` = 0: nothing outside a chunk to read.
fn sweep_from_zero(level: &Level, b: &[V2], x: &mut [V2]) {
    x.iter_mut().for_each(|v| *v = [0.0; 2]);
    sweep_from(level, b, x, &[], false);
}

/// [`sweep`] with the starting values `old` (empty: zero).
fn sweep_from(level: &Level, b: &[V2], x: &mut [V2], old: &[V2], backward: bool) {
    let rows = &level.rows;
    x.par_chunks_mut(SMOOTH_CHUNK)
        .enumerate()
        .for_each(|(c, xs)| {
            let start = c * SMOOTH_CHUNK;
            let end = start + xs.len();
            let mut node = |i: usize| {
                let mut acc = b[i];
                for k in rows.range(i) {
                    let j = rows.cols[k] as usize;
                    let y = if (start..end).contains(&j) {
                        xs[j - start]
                    } else {
                        old.get(j).copied().unwrap_or([0.0; 2])
                    };
                    let v = mul32(&rows.blocks[k], y);
                    acc = [acc[0] - v[0], acc[1] - v[1]];
                }
                let d = mul_sym(&level.smoother[i], acc);
                let x = &mut xs[i - start];
                *x = [x[0] + d[0], x[1] + d[1]];
            };
            if backward {
                (start..end).rev().for_each(&mut node);
            } else {
                (start..end).for_each(&mut node);
            }
        });
}

/// `r = b - A x`.
fn residual(level: &Level, b: &[V2], x: &[V2], r: &mut [V2]) {
    let rows = &level.rows;
    r.par_iter_mut()
        .with_min_len(MIN_LEN)
        .enumerate()
        .for_each(|(i, out)| {
            let mut acc = b[i];
            for k in rows.range(i) {
                let v = mul32(&rows.blocks[k], x[rows.cols[k] as usize]);
                acc = [acc[0] - v[0], acc[1] - v[1]];
            }
            *out = acc;
        });
}

/// `bc = P^T r`.
fn restrict(t: &Transfer, r: &[V2], bc: &mut [V2]) {
    bc.par_iter_mut()
        .with_min_len(MIN_LEN)
        .enumerate()
        .for_each(|(c, out)| {
            let mut acc = [0.0; 2];
            for &(i, k) in &t.rt[t.rt_offsets[c] as usize..t.rt_offsets[c + 1] as usize] {
                let v = mul_t(&t.p.blocks[k as usize], r[i as usize]);
                acc = [acc[0] + v[0], acc[1] + v[1]];
            }
            *out = acc;
        });
}

/// `x += P xc`.
fn interpolate(t: &Transfer, xc: &[V2], x: &mut [V2]) {
    let p = &t.p;
    x.par_iter_mut()
        .with_min_len(MIN_LEN)
        .enumerate()
        .for_each(|(i, out)| {
            for k in p.range(i) {
                let v = mul(&p.blocks[k], xc[p.cols[k] as usize]);
                *out = [out[0] + v[0], out[1] + v[1]];
            }
        });
}

#[cfg(test)]
mod tests;
