//! The multigrid's coarsest level, solved directly.

use super::Level;

/// The coarsest level solved directly: a Cholesky factor over its
/// unknowns with a row (a pivot that vanishes drops its unknown).
pub(super) struct Dense {
    /// (node, component) of each unknown.
    dofs: Vec<(usize, usize)>,
    /// Lower factor, row-major `n x n`.
    l: Vec<f64>,
    /// Unknowns whose pivot vanished (left at zero).
    dropped: Vec<bool>,
}

impl Dense {
    pub(super) fn new(level: &Level) -> Dense {
        let n_nodes = level.smooth.len();
        let mut id = vec![[usize::MAX; 3]; n_nodes];
        let mut dofs = Vec::new();
        for (n, (ids, smooth)) in id.iter_mut().zip(&level.smooth).enumerate() {
            for k in 0..3 {
                if smooth[k] > 0.0 {
                    ids[k] = dofs.len();
                    dofs.push((n, k));
                }
            }
        }
        let m = dofs.len();
        let mut a = vec![0.0; m * m];
        for (row, &(n, k)) in dofs.iter().enumerate() {
            let stencil: &[super::Block] = if n < level.nodes() { level.row(n) } else { &[] };
            let grid = stencil
                .iter()
                .zip(&level.slots)
                .filter_map(|(blk, &s)| level.neighbour(n, s).map(|q| (q, blk)));
            let extra = level
                .extra
                .row(n)
                .map(|i| (level.extra.cols[i] as usize, &level.extra.blocks[i]));
            for (q, blk) in grid.chain(extra) {
                for l in 0..3 {
                    let col = id[q][l];
                    if col != usize::MAX {
                        a[row * m + col] = blk[3 * k + l];
                    }
                }
            }
        }
        // Symmetrise (the Galerkin sums differ in their last bits).
        for i in 0..m {
            for j in 0..i {
                let s = 0.5 * (a[i * m + j] + a[j * m + i]);
                a[i * m + j] = s;
                a[j * m + i] = s;
            }
        }
        let dropped = crate::math::cholesky_dropping(&mut a, m);
        Dense {
            dofs,
            l: a,
            dropped,
        }
    }

    pub(super) fn solve(&self, b: &[[f64; 3]], x: &mut [[f64; 3]]) {
        let m = self.dofs.len();
        let mut y: Vec<f64> = self.dofs.iter().map(|&(n, k)| b[n][k]).collect();
        for i in 0..m {
            if self.dropped[i] {
                y[i] = 0.0;
                continue;
            }
            for k in 0..i {
                y[i] -= self.l[i * m + k] * y[k];
            }
            y[i] /= self.l[i * m + i];
        }
        for i in (0..m).rev() {
            if self.dropped[i] {
                continue;
            }
            for k in i + 1..m {
                y[i] -= self.l[k * m + i] * y[k];
            }
            y[i] /= self.l[i * m + i];
        }
        for v in x.iter_mut() {
            *v = [0.0; 3];
        }
        for (&(n, k), v) in self.dofs.iter().zip(&y) {
            x[n][k] = *v;
        }
    }
}
