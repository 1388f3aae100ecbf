//! A geometric multigrid preconditioner for the implicit step's CG (as
//! McAdams et al. 2011 precondition theirs): the step's operator
//! `cm M + ck K` assembled on the grid's nodes as a 27-point stencil of
//! 3 x 3 blocks (fixed unknowns' rows and columns left out), coarsened by
//! Galerkin products `P^T A P` with trilinear interpolation `P` from every
//! other node, down to a few hundred nodes solved by a dense Cholesky
//! factorisation. One symmetric V-cycle is the preconditioner: a block
//! Gauss-Seidel sweep before each coarse correction (each node's 3 x 3
//! diagonal block solved, neighbours held) and one in the reverse order
//! after it. Gauss-Seidel converges on any SPD operator with no damping
//! factor to tune, and on the notched block it halves the CG's iterations
//! against the l1-Jacobi smoother it replaced. The CG needs a number of
//! iterations nearly independent of the grid's resolution.
//!
//! Virtual nodes (copies of a grid node the tear separated the material
//! around) are unknowns of the finest level beyond the grid's nodes: their
//! rows, and the blocks coupling a grid node to one, are sparse rows of
//! their own beside the stencil (`irregular.rs`); a copy is smoothed in its
//! grid node's colour and interpolated from the coarse levels as its grid
//! node is. The coarse levels are the grid's.
//!
//! Once the material has come apart, each piece gets coarse levels of its
//! own (the interpolation reaching only its fine nodes): a coarse node
//! straddling the tear would tie the pieces together, and on the torn
//! `tear` preset the CG needed about three times the iterations.
//!
//! The finest level is the step's operator itself (in double precision):
//! in a step that builds the cycle, the CG's products read its rows, a
//! sparse product cheaper than the matrix-free one. The cycle reads its own
//! copy of every level's rows, made exactly symmetric and rounded to single
//! precision: it only preconditions, and reading rows is most of its time.
//! [`Multigrid::refine`] assembles the finest level again and keeps the
//! coarser ones (a valid preconditioner still, built in a fraction of the
//! time).
//!
//! The sweep runs over eight colours (the parities of a node's three
//! coordinates): no two nodes of a colour share a stencil, so each colour
//! updates in parallel with the same result as one after the other. Every
//! pass writes each node's values from a fixed-order sum over its own
//! stencil, so the result does not depend on the thread count.

use rayon::prelude::*;

mod assemble;
mod dense;
mod irregular;
use assemble::assemble;
use dense::Dense;
use irregular::Irregular;

/// A 3 x 3 block, row-major.
type Block = [f64; 9];

/// A block as the cycle stores it: single precision (the cycle only
/// preconditions, and reading its rows is most of its time).
type CycleBlock = [f32; 9];

/// Gauss-Seidel sweeps before and after each coarse correction.
const SWEEPS: usize = 1;

/// The colours' order in a forward sweep, and in a backward one.
const FORWARD: [usize; 8] = [0, 1, 2, 3, 4, 5, 6, 7];
const BACKWARD: [usize; 8] = [7, 6, 5, 4, 3, 2, 1, 0];

/// Coarsening stops at this many nodes (then a dense solve).
const COARSEST_NODES: usize = 400;

/// Fewest nodes a thread takes in a pass (small levels run on one).
const MIN_LEN: usize = 1024;

/// The stencil slot of a neighbour at offset `d` (each component -1, 0, 1).
fn slot(d: [i64; 3]) -> usize {
    ((d[0] + 1) + 3 * (d[1] + 1) + 9 * (d[2] + 1)) as usize
}

/// The offset of stencil slot `s`.
fn offset(s: usize) -> [i64; 3] {
    [
        (s % 3) as i64 - 1,
        ((s / 3) % 3) as i64 - 1,
        (s / 9) as i64 - 1,
    ]
}

/// One level: the operator on a box of nodes.
struct Level {
    /// Nodes along each axis.
    dims: [usize; 3],
    /// Each unknown's l1-Jacobi factor: 1 over its row's absolute sum, 0
    /// for an unknown without a row (fixed, or no material near it).
    smooth: Vec<[f64; 3]>,
    /// The slots the rows use, ascending (the grid's tetrahedra couple a
    /// node to 14 of its 26 neighbours; coarse levels use all).
    slots: Vec<usize>,
    /// The rows, only the used slots' blocks, node after node (a node's
    /// row is `slots.len()` blocks from `n * slots.len()`). Kept for the
    /// finest level (the CG's products) and until the next level is built
    /// for the others.
    packed: Vec<Block>,
    /// The rows as the cycle reads them: made exactly symmetric (each
    /// block and its mirror averaged) and rounded to single precision.
    cycle_rows: Vec<CycleBlock>,
    /// Each used slot's offset in node indices.
    slot_steps: Vec<i64>,
    /// Each node's diagonal block inverted over its unknowns with a row
    /// (zero for the others): the Gauss-Seidel smoother's solve.
    diag_inv: Vec<Block>,
    /// The nodes of each of the eight colours (the parities of the three
    /// coordinates): no two nodes of a colour share a stencil, so a colour
    /// is updated at once, in any order, with the same result. A virtual
    /// node takes its home's colour: it is coupled only to nodes at other
    /// grid places.
    colours: Vec<Vec<usize>>,
    /// The finest level's virtual nodes and the blocks that involve them
    /// (empty on coarse levels).
    extra: Irregular,
}

impl Level {
    fn coords(&self, n: usize) -> [usize; 3] {
        let [nx, ny, _] = self.dims;
        [n % nx, (n / nx) % ny, n / (nx * ny)]
    }

    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Grid nodes on this level.
    fn nodes(&self) -> usize {
        self.dims.iter().product()
    }

    /// Unknowns (as 3-vectors) on this level: its grid nodes, then its
    /// virtual nodes.
    fn unknowns(&self) -> usize {
        self.nodes() + self.extra.home.len()
    }

    /// The grid node unknown `n` stands at.
    fn home(&self, n: usize) -> usize {
        let grid = self.nodes();
        if n < grid {
            n
        } else {
            self.extra.home[n - grid] as usize
        }
    }

    /// The unknowns at grid node `i`: itself, then its virtual nodes.
    fn at(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        std::iter::once(i).chain(self.extra.copies(i).iter().map(|&v| v as usize))
    }

    /// Node `n`'s row: its used slots' blocks.
    fn row(&self, n: usize) -> &[Block] {
        let ns = self.slots.len();
        &self.packed[n * ns..(n + 1) * ns]
    }

    /// The neighbour of `n` in slot `s`, if inside the box.
    fn neighbour(&self, n: usize, s: usize) -> Option<usize> {
        let c = self.coords(n);
        let d = offset(s);
        let mut m = [0usize; 3];
        for k in 0..3 {
            let x = c[k] as i64 + d[k];
            if x < 0 || x >= self.dims[k] as i64 {
                return None;
            }
            m[k] = x as usize;
        }
        Some(self.index(m))
    }

    /// A level of `dims` nodes whose rows use `slots` (ascending, with
    /// the centre), before its rows are set.
    fn empty(dims: [usize; 3], slots: Vec<usize>) -> Level {
        let [nx, ny, _] = dims;
        let slot_steps = slots
            .iter()
            .map(|&s| {
                let d = offset(s);
                d[0] + d[1] * nx as i64 + d[2] * (nx * ny) as i64
            })
            .collect();
        Level {
            dims,
            smooth: Vec::new(),
            slots,
            packed: Vec::new(),
            cycle_rows: Vec::new(),
            slot_steps,
            diag_inv: Vec::new(),
            colours: Vec::new(),
            extra: Irregular::default(),
        }
    }

    /// What the cycle reads: its symmetric single-precision rows, the
    /// l1-Jacobi factors (which unknowns have a row, and the fallback of a
    /// diagonal block that cannot be inverted), the inverted diagonal
    /// blocks and the colours.
    fn set_smoother(&mut self) {
        let ns = self.slots.len();
        let centre = self
            .slots
            .iter()
            .position(|&s| s == 13)
            .expect("the rows hold their diagonal block");
        // A_nm and A_mn^T differ in their last bits (sums in other orders):
        // their mean keeps the forward-backward sweep exactly symmetric
        // once rounded.
        let mut at = [usize::MAX; 27];
        for (i, &s) in self.slots.iter().enumerate() {
            at[s] = i;
        }
        let last = self.nodes() as i64 - 1;
        self.cycle_rows = (0..self.nodes() * ns)
            .into_par_iter()
            .with_min_len(MIN_LEN)
            .map(|i| {
                let (n, si) = (i / ns, i % ns);
                let blk = &self.packed[i];
                let mirror = at[26 - self.slots[si]];
                let m = n as i64 + self.slot_steps[si];
                if mirror == usize::MAX || m < 0 || m > last {
                    return blk.map(|x| x as f32);
                }
                let other = &self.packed[m as usize * ns + mirror];
                std::array::from_fn(|j| {
                    let (k, l) = (j / 3, j % 3);
                    (0.5 * (blk[j] + other[3 * l + k])) as f32
                })
            })
            .collect();
        let grid = self.nodes();
        let zero = [0.0; 9];
        let diagonal = |n: usize| -> &Block {
            if n < grid {
                &self.packed[n * ns + centre]
            } else {
                self.extra.diagonal(n).unwrap_or(&zero)
            }
        };
        let abs_sum = |b: &Block, k: usize| (0..3).map(|l| b[3 * k + l].abs()).sum::<f64>();
        self.smooth = (0..self.unknowns())
            .into_par_iter()
            .with_min_len(MIN_LEN)
            .map(|n| {
                let stencil: &[Block] = if n < grid {
                    &self.packed[n * ns..(n + 1) * ns]
                } else {
                    &[]
                };
                let extra = &self.extra.blocks[self.extra.row(n)];
                std::array::from_fn(|k| {
                    if diagonal(n)[4 * k] <= 0.0 {
                        return 0.0;
                    }
                    let sum: f64 = stencil.iter().map(|b| abs_sum(b, k)).sum::<f64>()
                        + extra.iter().map(|b| abs_sum(b, k)).sum::<f64>();
                    1.0 / sum
                })
            })
            .collect();
        self.diag_inv = (0..self.unknowns())
            .into_par_iter()
            .with_min_len(MIN_LEN)
            .map(|n| {
                let d = diagonal(n);
                let sym = std::array::from_fn(|j| {
                    let (k, l) = (j / 3, j % 3);
                    f64::from((0.5 * (d[j] + d[3 * l + k])) as f32)
                });
                block_inverse(&sym, &self.smooth[n])
            })
            .collect();
        // Nodes without a row (no material near them, or fixed) keep x = 0
        // in the smoother; they are left out of the colours.
        let mut colours = vec![Vec::new(); 8];
        for n in 0..self.smooth.len() {
            if self.smooth[n] == [0.0; 3] {
                continue;
            }
            let c = self.coords(self.home(n));
            colours[(c[0] % 2) + 2 * (c[1] % 2) + 4 * (c[2] % 2)].push(n);
        }
        self.colours = colours;
    }

    /// `b_n - sum_m A_nm x_m` over node `n`'s used slots in order, from the
    /// packed rows, leaving out its own block when `off_diagonal`. A node
    /// on the box's border has zero blocks towards the neighbours it lacks;
    /// they multiply any node's (finite) values.
    fn row_residual(
        &self,
        n: usize,
        b: &[[f64; 3]],
        x: &[[f64; 3]],
        off_diagonal: bool,
    ) -> [f64; 3] {
        let grid = self.nodes();
        let last = grid as i64 - 1;
        let mut acc = b[n];
        let ns = self.slots.len();
        let row: &[CycleBlock] = if n < grid {
            &self.cycle_rows[n * ns..(n + 1) * ns]
        } else {
            &[]
        };
        for (blk, &step) in row.iter().zip(&self.slot_steps) {
            if off_diagonal && step == 0 {
                continue;
            }
            let y = x[neighbour_index(n, step, last)];
            let blk = blk.map(f64::from);
            for k in 0..3 {
                acc[k] -= blk[3 * k] * y[0] + blk[3 * k + 1] * y[1] + blk[3 * k + 2] * y[2];
            }
        }
        for i in self.extra.row(n) {
            let m = self.extra.cols[i] as usize;
            if off_diagonal && m == n {
                continue;
            }
            let (y, blk) = (x[m], self.extra.cycle[i].map(f64::from));
            for k in 0..3 {
                acc[k] -= blk[3 * k] * y[0] + blk[3 * k + 1] * y[1] + blk[3 * k + 2] * y[2];
            }
        }
        acc
    }

    /// `sum_m A_nm x_m` over node `n`'s used slots in order.
    fn row_product(&self, n: usize, x: &[[f64; 3]]) -> [f64; 3] {
        let grid = self.nodes();
        let last = grid as i64 - 1;
        let mut acc = [0.0; 3];
        let row: &[Block] = if n < grid { self.row(n) } else { &[] };
        for (blk, &step) in row.iter().zip(&self.slot_steps) {
            let y = x[neighbour_index(n, step, last)];
            for k in 0..3 {
                acc[k] += blk[3 * k] * y[0] + blk[3 * k + 1] * y[1] + blk[3 * k + 2] * y[2];
            }
        }
        for i in self.extra.row(n) {
            let (y, blk) = (x[self.extra.cols[i] as usize], &self.extra.blocks[i]);
            for k in 0..3 {
                acc[k] += blk[3 * k] * y[0] + blk[3 * k + 1] * y[1] + blk[3 * k + 2] * y[2];
            }
        }
        acc
    }

    /// `r = b - A x` (a node without a row: `b`).
    fn residual(&self, b: &[[f64; 3]], x: &[[f64; 3]], r: &mut [[f64; 3]]) {
        r.par_iter_mut()
            .with_min_len(MIN_LEN)
            .enumerate()
            .for_each(|(n, out)| {
                *out = if self.smooth[n] == [0.0; 3] {
                    b[n]
                } else {
                    self.row_residual(n, b, x, false)
                }
            });
    }

    /// One block Gauss-Seidel sweep over the colours in `order`: each node
    /// of a colour solves its own unknowns with its neighbours held, `x_n =
    /// D_n^-1 (b_n - sum_{m != n} A_nm x_m)`. Forward then backward is
    /// symmetric, so the V-cycle stays a valid CG preconditioner.
    /// With `from_zero` (x is zero on entry) the first colour's
    /// neighbours are known to be zero and are not read.
    fn gauss_seidel(&self, b: &[[f64; 3]], x: &mut [[f64; 3]], order: &[usize], from_zero: bool) {
        for (i, &colour) in order.iter().enumerate() {
            let nodes = &self.colours[colour];
            let x_now: &[[f64; 3]] = x;
            let zero = from_zero && i == 0;
            let new: Vec<[f64; 3]> = nodes
                .par_iter()
                .with_min_len(MIN_LEN / 8)
                .map(|&n| {
                    let acc = if zero {
                        b[n]
                    } else {
                        self.row_residual(n, b, x_now, true)
                    };
                    let d = &self.diag_inv[n];
                    std::array::from_fn(|k| {
                        d[3 * k] * acc[0] + d[3 * k + 1] * acc[1] + d[3 * k + 2] * acc[2]
                    })
                })
                .collect();
            for (&n, v) in nodes.iter().zip(new) {
                x[n] = v;
            }
        }
    }
}

/// The index `step` nodes from `n`, kept inside `0..=last`: a slot that
/// leaves the box has a zero block, so any node's values serve.
fn neighbour_index(n: usize, step: i64, last: i64) -> usize {
    (n as i64 + step).clamp(0, last) as usize
}

/// The inverse of a diagonal block over the unknowns with a row
/// (`smooth[k] > 0`), zero elsewhere; a block that cannot be inverted falls
/// back to the l1-Jacobi factors.
fn block_inverse(d: &Block, smooth: &[f64; 3]) -> Block {
    let free: Vec<usize> = (0..3).filter(|&k| smooth[k] > 0.0).collect();
    let mut m = nalgebra::Matrix3::<f64>::identity();
    for &k in &free {
        for &l in &free {
            m[(k, l)] = d[3 * k + l];
        }
    }
    let mut out = [0.0; 9];
    match m.try_inverse() {
        Some(inv) if inv.iter().all(|v| v.is_finite()) => {
            for &k in &free {
                for &l in &free {
                    out[3 * k + l] = inv[(k, l)];
                }
            }
        }
        _ => {
            for &k in &free {
                out[4 * k] = smooth[k];
            }
        }
    }
    out
}

/// The coarse parents of fine index `i` along one axis, with weights.
fn parents(i: usize) -> ([(usize, f64); 2], usize) {
    if i % 2 == 0 {
        ([(i / 2, 1.0), (0, 0.0)], 1)
    } else {
        ([((i - 1) / 2, 0.5), (i.div_ceil(2), 0.5)], 2)
    }
}

/// `f(coarse node, weight)` over the coarse nodes that interpolate to the
/// fine node at `c`, in a fixed order.
fn for_parents(c: [usize; 3], mut f: impl FnMut([usize; 3], f64)) {
    let (px, nx) = parents(c[0]);
    let (py, ny) = parents(c[1]);
    let (pz, nz) = parents(c[2]);
    for &(z, wz) in &pz[..nz] {
        for &(y, wy) in &py[..ny] {
            for &(x, wx) in &px[..nx] {
                f([x, y, z], wx * wy * wz);
            }
        }
    }
}

/// The fine indices a coarse index `c` interpolates to along an axis of
/// `n` fine nodes, with weights.
fn children(c: usize, n: usize) -> impl Iterator<Item = (usize, f64)> {
    let centre = 2 * c;
    [
        (centre as i64 - 1, 0.5),
        (centre as i64, 1.0),
        (centre as i64 + 1, 0.5),
    ]
    .into_iter()
    .filter(move |&(i, _)| i >= 0 && (i as usize) < n)
    .map(|(i, w)| (i as usize, w))
}

/// `f(fine node, weight)` over the fine nodes coarse node `cn` interpolates
/// to, in a fixed order.
fn for_children(fine: &Level, cc: [usize; 3], mut f: impl FnMut(usize, f64)) {
    for (k, wk) in children(cc[2], fine.dims[2]) {
        for (j, wj) in children(cc[1], fine.dims[1]) {
            for (i, wi) in children(cc[0], fine.dims[0]) {
                f(fine.index([i, j, k]), wi * wj * wk);
            }
        }
    }
}

/// The Galerkin coarse level `P^T A P` of `fine`, with `P` interpolating
/// only to the fine nodes in `mask` (empty: all of them).
fn coarsen(fine: &Level, mask: &[bool]) -> Level {
    let dims = fine.dims.map(|n| n / 2 + 1);
    let scratch = Level::empty(dims, Vec::new());
    let n_coarse: usize = dims.iter().product();
    let a: Vec<[Block; 27]> = (0..n_coarse)
        .into_par_iter()
        .map(|cn| {
            let cc = scratch.coords(cn);
            let mut row = [[0.0; 9]; 27];
            let mut add = |wi: f64, j: usize, blk: &Block| {
                for_parents(fine.coords(fine.home(j)), |p, wp| {
                    let d = std::array::from_fn(|k| p[k] as i64 - cc[k] as i64);
                    let w = wi * wp;
                    let out = &mut row[slot(d)];
                    for (o, b) in out.iter_mut().zip(blk) {
                        *o += w * b;
                    }
                });
            };
            for_children(fine, cc, |i, wi| {
                for u in fine.at(i).filter(|&u| in_mask(mask, u)) {
                    let stencil: &[Block] = if u == i { fine.row(i) } else { &[] };
                    for (blk, &s) in stencil.iter().zip(&fine.slots) {
                        if blk.iter().all(|&x| x == 0.0) {
                            continue;
                        }
                        if let Some(j) = fine.neighbour(i, s).filter(|&j| in_mask(mask, j)) {
                            add(wi, j, blk);
                        }
                    }
                    for e in fine.extra.row(u) {
                        let (j, blk) = (fine.extra.cols[e] as usize, &fine.extra.blocks[e]);
                        if in_mask(mask, j) && blk.iter().any(|&x| x != 0.0) {
                            add(wi, j, blk);
                        }
                    }
                }
            });
            row
        })
        .collect();
    // The slots some row uses, and the centre whatever it holds.
    let slots: Vec<usize> = (0..27)
        .filter(|&s| s == 13 || a.iter().any(|row| row[s].iter().any(|&x| x != 0.0)))
        .collect();
    let mut coarse = Level::empty(dims, slots);
    coarse.packed = a
        .iter()
        .flat_map(|row| coarse.slots.iter().map(|&s| row[s]))
        .collect();
    coarse.set_smoother();
    coarse
}

/// The preconditioner: the finest level (the grid's nodes) and below it
/// either its own factor (a small grid) or one coarse hierarchy per piece
/// of material (one for all while the material is whole).
pub struct Multigrid {
    fine: Level,
    below: Below,
    /// How many pieces it was built for (at least one).
    pub pieces: usize,
}

/// What corrects the finest level's smooth error.
enum Below {
    /// The finest level is small: solved directly.
    Direct(Dense),
    /// Coarse hierarchies, one per piece (their fine nodes disjoint).
    Coarse(Vec<Hierarchy>),
}

/// The coarse levels of one piece: Galerkin products with the
/// interpolation to the piece's fine nodes only, so the coarse levels of
/// two pieces apart never tie them together (a coarse node straddling a
/// tear would; the CG then needs three times the iterations).
struct Hierarchy {
    /// The fine nodes it corrects (empty: all).
    mask: Vec<bool>,
    /// From the level below the finest down.
    levels: Vec<Level>,
    /// The coarsest level's factor.
    dense: Dense,
}

impl Hierarchy {
    fn new(fine: &Level, mask: Vec<bool>) -> Hierarchy {
        let mut levels = vec![coarsen(fine, &mask)];
        loop {
            let last = levels.last().expect("a level");
            if small(last) {
                break;
            }
            let next = coarsen(last, &[]);
            levels.push(next);
        }
        let dense = Dense::new(levels.last().expect("a level"));
        for level in &mut levels {
            level.packed = Vec::new();
        }
        Hierarchy {
            mask,
            levels,
            dense,
        }
    }

    /// Add to `x` the coarse correction of the fine residual `r`.
    fn correct(&self, fine: &Level, r: &[[f64; 3]], x: &mut [[f64; 3]]) {
        let coarse = &self.levels[0];
        let bc = restrict(fine, coarse, r, &self.mask);
        let mut xc = vec![[0.0; 3]; coarse.nodes()];
        v_cycle(&self.levels, &self.dense, &bc, &mut xc);
        interpolate(fine, coarse, &xc, x, &self.mask);
    }
}

/// Whether a level is solved directly.
fn small(level: &Level) -> bool {
    level.nodes() <= COARSEST_NODES || level.dims.iter().all(|&d| d <= 3)
}

/// The residual `r` of `level` restricted to `coarse` (`P^T r`), from the
/// nodes in `mask` only (empty: all).
fn restrict(level: &Level, coarse: &Level, r: &[[f64; 3]], mask: &[bool]) -> Vec<[f64; 3]> {
    (0..coarse.nodes())
        .into_par_iter()
        .with_min_len(MIN_LEN / 8)
        .map(|cn| {
            let mut acc = [0.0; 3];
            for_children(level, coarse.coords(cn), |i, w| {
                for u in level.at(i).filter(|&u| in_mask(mask, u)) {
                    for k in 0..3 {
                        acc[k] += w * r[u][k];
                    }
                }
            });
            std::array::from_fn(|k| {
                if coarse.smooth[cn][k] > 0.0 {
                    acc[k]
                } else {
                    0.0
                }
            })
        })
        .collect()
}

/// `x += P xc` on the nodes of `level` in `mask` (empty: all) with a row.
fn interpolate(level: &Level, coarse: &Level, xc: &[[f64; 3]], x: &mut [[f64; 3]], mask: &[bool]) {
    x.par_iter_mut()
        .with_min_len(MIN_LEN)
        .enumerate()
        .for_each(|(n, x)| {
            if !in_mask(mask, n) || level.smooth[n] == [0.0; 3] {
                return;
            }
            for_parents(level.coords(level.home(n)), |p, w| {
                let v = xc[coarse.index(p)];
                for k in 0..3 {
                    if level.smooth[n][k] > 0.0 {
                        x[k] += w * v[k];
                    }
                }
            });
        });
}

/// One V-cycle from zero on `levels` (the last solved by `dense`).
fn v_cycle(levels: &[Level], dense: &Dense, b: &[[f64; 3]], x: &mut [[f64; 3]]) {
    if levels.len() == 1 {
        dense.solve(b, x);
        return;
    }
    let (level, coarse) = (&levels[0], &levels[1]);
    smoothed(level, b, x, |r, x| {
        let bc = restrict(level, coarse, r, &[]);
        let mut xc = vec![[0.0; 3]; coarse.nodes()];
        v_cycle(&levels[1..], dense, &bc, &mut xc);
        interpolate(level, coarse, &xc, x, &[]);
    });
}

/// `x` from zero: Gauss-Seidel sweeps forward, `correct(r, x)` with their
/// residual `r`, sweeps backward (symmetric whatever `correct` does, when
/// it is symmetric itself).
fn smoothed(
    level: &Level,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    correct: impl FnOnce(&[[f64; 3]], &mut [[f64; 3]]),
) {
    for v in x.iter_mut() {
        *v = [0.0; 3];
    }
    for sweep in 0..SWEEPS {
        level.gauss_seidel(b, x, &FORWARD, sweep == 0);
    }
    let mut r = vec![[0.0; 3]; b.len()];
    level.residual(b, x, &mut r);
    correct(&r, x);
    for _ in 0..SWEEPS {
        level.gauss_seidel(b, x, &BACKWARD, false);
    }
}

/// Whether node `i` is in `mask` (empty: every node is; a node beyond it,
/// a virtual node made after it, is not).
fn in_mask(mask: &[bool], i: usize) -> bool {
    mask.is_empty() || mask.get(i).copied().unwrap_or(false)
}

/// What the fine level is assembled from.
pub struct Operator<'a> {
    /// Nodes along each axis.
    pub dims: [usize; 3],
    /// Tetrahedra (node indices: the grid's nodes, then virtual ones).
    pub tets: &'a [[u32; 4]],
    /// Each node's grid node (itself for the grid's).
    pub home: &'a [u32],
    /// The stiffness of tetrahedron `e` already times `ck`: block `[c][d]`
    /// couples corner `c`'s force to corner `d`'s displacement (zero for a
    /// tetrahedron without material).
    pub stiffness: &'a (dyn Fn(usize) -> [[Block; 4]; 4] + Sync),
    /// `cm` times each node's mass, added on the diagonal.
    pub mass: &'a [f64],
    /// Fixed unknowns (their rows and columns are left out).
    pub fixed: &'a [[bool; 3]],
    /// The nodes of each piece of material, when it is in more than one
    /// (each gets its own coarse levels; none or one: one for all).
    pub pieces: &'a [Vec<bool>],
}

impl Multigrid {
    /// Assemble the operator and build the levels.
    pub fn new(op: &Operator<'_>) -> Multigrid {
        let mut fine = assemble(op);
        fine.set_smoother();
        let below = if small(&fine) {
            Below::Direct(Dense::new(&fine))
        } else {
            // An empty mask: every node.
            let masks = if op.pieces.len() > 1 {
                op.pieces.to_vec()
            } else {
                vec![Vec::new()]
            };
            Below::Coarse(
                masks
                    .into_iter()
                    .map(|mask| Hierarchy::new(&fine, mask))
                    .collect(),
            )
        };
        Multigrid {
            fine,
            below,
            pieces: op.pieces.len().max(1),
        }
    }

    /// The finest level assembled again from `op`, the coarser ones kept.
    pub fn refine(&mut self, op: &Operator<'_>) {
        let mut fine = assemble(op);
        fine.set_smoother();
        self.fine = fine;
    }

    /// How many coarse hierarchies it has (one per piece).
    #[cfg(test)]
    pub fn hierarchies(&self) -> usize {
        match &self.below {
            Below::Direct(_) => 1,
            Below::Coarse(h) => h.len(),
        }
    }

    /// Unknowns (3-vectors) of the finest level: the grid's nodes and the
    /// virtual ones.
    pub fn unknowns(&self) -> usize {
        self.fine.unknowns()
    }

    /// `ap = A p` with the finest level's rows (the operator it was built
    /// from, fixed unknowns' rows and columns left out: zero there).
    pub fn product(&self, p: &[[f64; 3]], ap: &mut [[f64; 3]]) {
        let level = &self.fine;
        ap.par_iter_mut()
            .with_min_len(MIN_LEN)
            .enumerate()
            .for_each(|(n, out)| *out = level.row_product(n, p));
    }

    /// `z = B r`: one V-cycle from zero, each piece's coarse correction
    /// added between the finest level's sweeps (the pieces' fine nodes are
    /// disjoint, so the order of adding does not matter).
    pub fn apply(&self, r: &[[f64; 3]], z: &mut [[f64; 3]]) {
        let hierarchies = match &self.below {
            Below::Direct(dense) => return dense.solve(r, z),
            Below::Coarse(h) => h,
        };
        let fine = &self.fine;
        smoothed(fine, r, z, |res, z| {
            for h in hierarchies {
                h.correct(fine, res, z);
            }
        });
    }
}
