//! The finest level assembled from the step's tetrahedra.

use super::{slot, Block, Irregular, Level, Operator};
use rayon::prelude::*;

/// The finest level: the tetrahedra's stiffness added into each node's
/// row, the mass on the diagonal, the fixed unknowns' rows and columns left
/// out. A tetrahedron adds only to the rows of its two planes of nodes
/// (its cube's layer along z): the layers of one parity touch disjoint
/// planes and are added in parallel, the even ones first, each in the
/// tetrahedra's order, so every row's sum runs in a fixed order.
pub(super) fn assemble(op: &Operator<'_>) -> Level {
    let [nx, ny, nz] = op.dims;
    let plane = nx * ny;
    let n_grid = plane * nz;
    // A virtual node stands at its home.
    let coords = |n: u32| {
        let n = op.home[n as usize] as usize;
        [n % nx, (n / nx) % ny, n / plane].map(|c| c as i64)
    };
    // Slot of corner `d` in corner `c`'s row, for corners at `cs`.
    let corner_slot =
        |cs: &[[i64; 3]; 4], c: usize, d: usize| slot(std::array::from_fn(|a| cs[d][a] - cs[c][a]));
    let used = op
        .tets
        .par_iter()
        .fold(
            || [false; 27],
            |mut used, t| {
                let cs = t.map(coords);
                for c in 0..4 {
                    for d in 0..4 {
                        used[corner_slot(&cs, c, d)] = true;
                    }
                }
                used
            },
        )
        .reduce(|| [false; 27], |a, b| std::array::from_fn(|s| a[s] || b[s]));
    let slots: Vec<usize> = (0..27).filter(|&s| used[s] || s == 13).collect();
    let mut at = [usize::MAX; 27];
    for (i, &s) in slots.iter().enumerate() {
        at[s] = i;
    }
    let ns = slots.len();
    // The tetrahedra of each layer, in their order.
    let n_layers = nz.saturating_sub(1).max(1);
    let mut layers: Vec<Vec<usize>> = vec![Vec::new(); n_layers];
    let plane_u32 = plane as u32;
    for (e, t) in op.tets.iter().enumerate() {
        let z = t
            .iter()
            .map(|&n| op.home[n as usize] / plane_u32)
            .min()
            .unwrap_or(0) as usize;
        layers[z.min(n_layers - 1)].push(e);
    }
    let mut level = Level::empty(op.dims, slots);
    let mut packed = vec![[0.0; 9]; plane * nz * ns];
    let add_layer = |z: usize, rows: &mut [Block]| {
        let first = z * plane;
        for &e in &layers[z] {
            let t = &op.tets[e];
            let k = (op.stiffness)(e);
            let cs = t.map(coords);
            // Blocks with a virtual node are the irregular part's.
            for (c, &n) in t.iter().enumerate() {
                if n as usize >= n_grid {
                    continue;
                }
                for d in (0..4).filter(|&d| (t[d] as usize) < n_grid) {
                    let s = at[corner_slot(&cs, c, d)];
                    let out = &mut rows[(n as usize - first) * ns + s];
                    for (o, x) in out.iter_mut().zip(&k[c][d]) {
                        *o += x;
                    }
                }
            }
        }
    };
    // Even layers: planes (2i, 2i + 1); odd ones: (2i + 1, 2i + 2).
    packed
        .par_chunks_mut(2 * plane * ns)
        .enumerate()
        .for_each(|(i, rows)| {
            if 2 * i < layers.len() {
                add_layer(2 * i, rows);
            }
        });
    if plane * ns < packed.len() {
        packed[plane * ns..]
            .par_chunks_mut(2 * plane * ns)
            .enumerate()
            .for_each(|(i, rows)| {
                if 2 * i + 1 < layers.len() {
                    add_layer(2 * i + 1, rows);
                }
            });
    }
    // The mass on the diagonal; the fixed unknowns' rows and columns left
    // out.
    let centre = at[13];
    packed.par_chunks_mut(ns).enumerate().for_each(|(n, row)| {
        for k in 0..3 {
            row[centre][4 * k] += op.mass[n];
        }
        for (blk, &s) in row.iter_mut().zip(&level.slots) {
            let m = level.neighbour(n, s);
            for k in 0..3 {
                for l in 0..3 {
                    let off = m.is_none_or(|m| op.fixed[m][l]);
                    if op.fixed[n][k] || off {
                        blk[3 * k + l] = 0.0;
                    }
                }
            }
        }
    });
    level.packed = packed;
    level.extra = Irregular::assemble(op, n_grid);
    level
}
