//! The multigrid's setup: strength, aggregation, prolongator, Galerkin
//! coarse operator.

use super::{sym_inverse, Block, Owned, Rows, Transfer, MIN_LEN};
use rayon::prelude::*;

/// Strength threshold on the finest level (halved on each coarser one).
pub(super) const THETA: f64 = 0.08;

/// Rows per part of the parallel row builds (joined in order).
const PART: usize = 4096;

/// No aggregate yet.
const NONE: u32 = u32::MAX;

/// Per node of a level: `e[n]`, the rows of the 2x3 map from a
/// translation in space to the node's unknowns; `t[n]`, the tangent plane
/// (two unit vectors) its aggregate's translations are taken in.
pub(super) struct Frames {
    pub(super) e: Vec<[[f64; 3]; 2]>,
    pub(super) t: Vec<[[f64; 3]; 2]>,
}

/// Two rows of three: a node's map from space, or its plane.
type Frame = [[f64; 3]; 2];

/// One coarsening step's result.
pub(super) struct Coarsened {
    pub(super) transfer: Transfer,
    pub(super) coarse: Owned<Block>,
    pub(super) frames: Frames,
}

fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn fro2(b: &Block) -> f64 {
    b.iter().map(|v| v * v).sum()
}

fn transpose(b: &Block) -> Block {
    [b[0], b[2], b[1], b[3]]
}

/// `a b`.
fn mul_blocks(a: &Block, b: &Block) -> Block {
    [
        a[0] * b[0] + a[1] * b[2],
        a[0] * b[1] + a[1] * b[3],
        a[2] * b[0] + a[3] * b[2],
        a[2] * b[1] + a[3] * b[3],
    ]
}

fn add_into(o: &mut Block, b: &Block) {
    for (o, v) in o.iter_mut().zip(b) {
        *o += v;
    }
}

/// Rows built part by part in parallel by `row(n, cols, blocks)`, joined
/// in order.
fn build_rows<B: Send + Copy>(
    n: usize,
    row: impl Fn(usize, &mut Vec<u32>, &mut Vec<B>) + Sync,
) -> Owned<B> {
    let parts: Vec<(Vec<u32>, Vec<u32>, Vec<B>)> = (0..n.div_ceil(PART))
        .into_par_iter()
        .map(|c| {
            let range = c * PART..((c + 1) * PART).min(n);
            let mut ends = Vec::with_capacity(range.len());
            let mut cols = Vec::new();
            let mut blocks = Vec::new();
            for i in range {
                row(i, &mut cols, &mut blocks);
                ends.push(cols.len() as u32);
            }
            (ends, cols, blocks)
        })
        .collect();
    let mut out = Owned {
        offsets: Vec::with_capacity(n + 1),
        cols: Vec::new(),
        blocks: Vec::new(),
    };
    out.offsets.push(0);
    for (ends, cols, blocks) in parts {
        let base = out.cols.len() as u32;
        out.offsets.extend(ends.iter().map(|e| base + e));
        out.cols.extend_from_slice(&cols);
        out.blocks.extend_from_slice(&blocks);
    }
    out
}

/// Block `k` (in row `i`) averaged with its mirror's transpose (kept as
/// it is without a mirror): the same numbers, bit for bit, as the mirror's
/// own average transposed.
pub(super) fn mirrored(a: Rows<'_>, i: usize, k: usize) -> Block {
    let j = a.cols[k] as usize;
    let blk = &a.blocks[k];
    match a.range(j).find(|&m| a.cols[m] as usize == i) {
        Some(m) => {
            let t = transpose(&a.blocks[m]);
            std::array::from_fn(|q| 0.5 * (blk[q] + t[q]))
        }
        None => *blk,
    }
}

/// `a` made exactly symmetric (each block [`mirrored`]).
pub(super) fn symmetric(a: Rows<'_>) -> Owned<Block> {
    let blocks = (0..a.n())
        .into_par_iter()
        .with_min_len(MIN_LEN)
        .flat_map_iter(|i| a.range(i).map(move |k| mirrored(a, i, k)))
        .collect();
    Owned {
        offsets: a.offsets.to_vec(),
        cols: a.cols.to_vec(),
        blocks,
    }
}

/// Each node's strong neighbours, as rows of node indices.
fn strong(a: Rows<'_>, theta: f64) -> Owned<()> {
    let diag: Vec<f64> = (0..a.n())
        .into_par_iter()
        .with_min_len(MIN_LEN)
        .map(|i| fro2(&a.blocks[a.offsets[i] as usize]).sqrt())
        .collect();
    let t2 = theta * theta;
    build_rows(a.n(), |i, cols, blocks: &mut Vec<()>| {
        for k in a.range(i) {
            let j = a.cols[k] as usize;
            if j != i && fro2(&a.blocks[k]) > t2 * diag[i] * diag[j] {
                cols.push(j as u32);
                blocks.push(());
            }
        }
    })
}

/// Greedy aggregation of the strong graph in node order: each node's
/// aggregate ([`NONE`] for a node without strong neighbours) and the
/// number of aggregates.
fn aggregate(s: &Owned<()>) -> (Vec<u32>, usize) {
    let n = s.n();
    let mut agg = vec![NONE; n];
    let mut count = 0u32;
    let nbrs = |i: usize| &s.cols[s.range(i)];
    // Roots: a node whose strong neighbours are all free, with them.
    for i in 0..n {
        let nb = nbrs(i);
        if agg[i] != NONE || nb.is_empty() || nb.iter().any(|&j| agg[j as usize] != NONE) {
            continue;
        }
        agg[i] = count;
        for &j in nb {
            agg[j as usize] = count;
        }
        count += 1;
    }
    // The rest join a first-pass aggregate of a strong neighbour.
    let first = agg.clone();
    for (i, a) in agg.iter_mut().enumerate() {
        if *a != NONE {
            continue;
        }
        if let Some(&j) = nbrs(i).iter().find(|&&j| first[j as usize] != NONE) {
            *a = first[j as usize];
        }
    }
    // What is left groups with its free strong neighbours.
    for i in 0..n {
        let nb = nbrs(i);
        if agg[i] != NONE || nb.is_empty() {
            continue;
        }
        agg[i] = count;
        for &j in nb {
            if agg[j as usize] == NONE {
                agg[j as usize] = count;
            }
        }
        count += 1;
    }
    (agg, count as usize)
}

/// The tentative prolongator's block per node (zero outside the
/// aggregates) and each aggregate's coarse frames: per aggregate the two
/// translations in its first node's tangent plane, in each member's
/// unknowns, orthonormalised over the aggregate (`B = Q R`).
fn tentative(agg: &[u32], count: usize, frames: &Frames) -> (Vec<Block>, Frames) {
    // Members of each aggregate, by node.
    let mut start = vec![0u32; count + 1];
    for &g in agg.iter().filter(|&&g| g != NONE) {
        start[g as usize + 1] += 1;
    }
    for g in 0..count {
        start[g + 1] += start[g];
    }
    let mut fill = start.clone();
    let mut members = vec![0u32; start[count] as usize];
    for (i, &g) in agg.iter().enumerate().filter(|(_, &g)| g != NONE) {
        members[fill[g as usize] as usize] = i as u32;
        fill[g as usize] += 1;
    }
    let per: Vec<(Vec<Block>, Frame, Frame)> = (0..count)
        .into_par_iter()
        .with_min_len(64)
        .map(|g| {
            let mem = &members[start[g] as usize..start[g + 1] as usize];
            let t = frames.t[mem[0] as usize];
            // Column c of B at node i: translation t[c] in i's unknowns.
            let b: Vec<[[f64; 2]; 2]> = mem
                .iter()
                .map(|&i| {
                    let e = &frames.e[i as usize];
                    std::array::from_fn(|c| [dot3(e[0], t[c]), dot3(e[1], t[c])])
                })
                .collect();
            let norm = |c: &dyn Fn(&[[f64; 2]; 2]) -> [f64; 2]| {
                b.iter()
                    .map(|x| {
                        let v = c(x);
                        v[0] * v[0] + v[1] * v[1]
                    })
                    .sum::<f64>()
                    .sqrt()
            };
            let mut r11 = norm(&|x| x[0]);
            let q1: Vec<[f64; 2]> = if r11 > 0.0 && r11.is_finite() {
                b.iter().map(|x| [x[0][0] / r11, x[0][1] / r11]).collect()
            } else {
                r11 = 0.0;
                let s = 1.0 / (mem.len() as f64).sqrt();
                b.iter().map(|_| [s, 0.0]).collect()
            };
            let r12: f64 = b
                .iter()
                .zip(&q1)
                .map(|(x, q)| x[1][0] * q[0] + x[1][1] * q[1])
                .sum();
            let w: Vec<[f64; 2]> = b
                .iter()
                .zip(&q1)
                .map(|(x, q)| [x[1][0] - r12 * q[0], x[1][1] - r12 * q[1]])
                .collect();
            let mut r22 = w
                .iter()
                .map(|v| v[0] * v[0] + v[1] * v[1])
                .sum::<f64>()
                .sqrt();
            let q2: Vec<[f64; 2]> = if r22 > 1e-8 * (r11 + r12.abs()) && r22.is_finite() {
                w.iter().map(|v| [v[0] / r22, v[1] / r22]).collect()
            } else {
                // The first column turned a quarter in every node's plane:
                // orthogonal to it, of unit length.
                r22 = 0.0;
                q1.iter().map(|q| [-q[1], q[0]]).collect()
            };
            let blocks = q1
                .iter()
                .zip(&q2)
                .map(|(a, b)| [a[0], b[0], a[1], b[1]])
                .collect();
            // E = R T^T.
            let e = [
                std::array::from_fn(|k| r11 * t[0][k] + r12 * t[1][k]),
                std::array::from_fn(|k| r22 * t[1][k]),
            ];
            (blocks, e, t)
        })
        .collect();
    let mut p0 = vec![[0.0; 4]; agg.len()];
    let mut coarse = Frames {
        e: Vec::with_capacity(count),
        t: Vec::with_capacity(count),
    };
    for (g, (blocks, e, t)) in per.into_iter().enumerate() {
        let mem = &members[start[g] as usize..start[g + 1] as usize];
        for (&i, blk) in mem.iter().zip(blocks) {
            p0[i as usize] = blk;
        }
        coarse.e.push(e);
        coarse.t.push(t);
    }
    (p0, coarse)
}

/// The Gershgorin bound of `D^-1 A` and the inverse diagonal blocks.
fn jacobi_bound(a: Rows<'_>) -> (f64, Vec<Block>) {
    let dinv: Vec<Block> = (0..a.n())
        .into_par_iter()
        .with_min_len(MIN_LEN)
        .map(|i| {
            let d = &a.blocks[a.offsets[i] as usize];
            let s = sym_inverse(d[0], 0.5 * (d[1] + d[2]), d[3]);
            [s[0], s[1], s[1], s[2]]
        })
        .collect();
    let rho = (0..a.n())
        .into_par_iter()
        .with_min_len(MIN_LEN)
        .map(|i| {
            let mut sum = [0.0; 2];
            for k in a.range(i) {
                let m = mul_blocks(&dinv[i], &a.blocks[k]);
                sum[0] += m[0].abs() + m[1].abs();
                sum[1] += m[2].abs() + m[3].abs();
            }
            sum[0].max(sum[1])
        })
        .reduce(|| 0.0, f64::max);
    (rho, dinv)
}

/// One coarsening step of `a` (symmetric, diagonal first), or `None` when
/// no node has a strong neighbour.
pub(super) fn coarsen(a: Rows<'_>, frames: &Frames, theta: f64) -> Option<Coarsened> {
    let s = strong(a, theta);
    let (agg, count) = aggregate(&s);
    drop(s);
    if count == 0 {
        return None;
    }
    let (p0, coarse_frames) = tentative(&agg, count, frames);
    let (rho, dinv) = jacobi_bound(a);
    let omega = if rho > 0.0 && rho.is_finite() {
        4.0 / (3.0 * rho)
    } else {
        0.0
    };
    // P = (I - w D^-1 A) P0, row by row.
    let p = build_rows(a.n(), |i, cols: &mut Vec<u32>, blocks: &mut Vec<Block>| {
        let start = cols.len();
        let wd = dinv[i].map(|v| -omega * v);
        for k in a.range(i) {
            let j = a.cols[k] as usize;
            if agg[j] == NONE {
                continue;
            }
            let mut m = mul_blocks(&wd, &a.blocks[k]);
            if j == i {
                m[0] += 1.0;
                m[3] += 1.0;
            }
            let c = mul_blocks(&m, &p0[j]);
            match cols[start..].iter().position(|&x| x == agg[j]) {
                Some(s) => add_into(&mut blocks[start + s], &c),
                None => {
                    cols.push(agg[j]);
                    blocks.push(c);
                }
            }
        }
    });
    drop(p0);
    // P's columns as rows: (fine node, block index) by fine node.
    let mut rt_offsets = vec![0u32; count + 1];
    for &c in &p.cols {
        rt_offsets[c as usize + 1] += 1;
    }
    for c in 0..count {
        rt_offsets[c + 1] += rt_offsets[c];
    }
    let mut fill = rt_offsets.clone();
    let mut rt = vec![(0u32, 0u32); p.cols.len()];
    for i in 0..p.n() {
        for k in p.range(i) {
            let c = p.cols[k] as usize;
            rt[fill[c] as usize] = (i as u32, k as u32);
            fill[c] += 1;
        }
    }
    drop(fill);
    let transfer = Transfer { p, rt_offsets, rt };
    let coarse = galerkin(a, &transfer, count);
    let coarse = symmetric(coarse.rows());
    Some(Coarsened {
        transfer,
        coarse,
        frames: coarse_frames,
    })
}

/// `P^T A P`, row by coarse row, the diagonal block first.
fn galerkin(a: Rows<'_>, t: &Transfer, count: usize) -> Owned<Block> {
    let p = &t.p;
    let parts: Vec<Owned<Block>> = (0..count.div_ceil(PART))
        .into_par_iter()
        .map(|part| {
            let range = part * PART..((part + 1) * PART).min(count);
            let mut pos = vec![NONE; count];
            let mut out = Owned {
                offsets: Vec::with_capacity(range.len()),
                cols: Vec::new(),
                blocks: Vec::new(),
            };
            for c in range {
                let start = out.cols.len();
                out.cols.push(c as u32);
                out.blocks.push([0.0; 4]);
                pos[c] = start as u32;
                for &(i, k) in &t.rt[t.rt_offsets[c] as usize..t.rt_offsets[c + 1] as usize] {
                    let ri = transpose(&p.blocks[k as usize]);
                    for ka in a.range(i as usize) {
                        let j = a.cols[ka] as usize;
                        let m = mul_blocks(&ri, &a.blocks[ka]);
                        for kp in p.range(j) {
                            let d = p.cols[kp] as usize;
                            let v = mul_blocks(&m, &p.blocks[kp]);
                            if pos[d] == NONE {
                                pos[d] = out.cols.len() as u32;
                                out.cols.push(d as u32);
                                out.blocks.push([0.0; 4]);
                            }
                            add_into(&mut out.blocks[pos[d] as usize], &v);
                        }
                    }
                }
                for &d in &out.cols[start..] {
                    pos[d as usize] = NONE;
                }
                out.offsets.push(out.cols.len() as u32);
            }
            out
        })
        .collect();
    let mut out = Owned {
        offsets: vec![0],
        cols: Vec::new(),
        blocks: Vec::new(),
    };
    for part in parts {
        let base = out.cols.len() as u32;
        out.offsets.extend(part.offsets.iter().map(|e| base + e));
        out.cols.extend_from_slice(&part.cols);
        out.blocks.extend_from_slice(&part.blocks);
    }
    out
}
