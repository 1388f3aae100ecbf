//! The multigrid's coarsest level, solved directly.

use super::{Rows, V2};

/// A Cholesky factor of the coarsest level over its unknowns (a pivot
/// that vanishes drops its unknown, left at zero).
pub(super) struct Dense {
    /// Lower factor, row-major `m x m` (`m` twice the nodes).
    l: Vec<f64>,
    dropped: Vec<bool>,
}

impl Dense {
    /// The factor of `a` (its lower triangle: the upper one is not read).
    pub(super) fn new(a: Rows<'_>) -> Dense {
        let m = 2 * a.n();
        let mut l = vec![0.0; m * m];
        for i in 0..a.n() {
            for k in a.range(i) {
                let j = a.cols[k] as usize;
                let b = &a.blocks[k];
                for (q, v) in b.iter().enumerate() {
                    l[(2 * i + q / 2) * m + 2 * j + q % 2] = *v;
                }
            }
        }
        let dropped = crate::math::cholesky_dropping(&mut l, m);
        Dense { l, dropped }
    }

    /// `x = A^-1 b`.
    pub(super) fn solve(&self, b: &[V2], x: &mut [V2]) {
        let m = self.dropped.len();
        let l = &self.l;
        let mut y: Vec<f64> = b.iter().flat_map(|v| *v).collect();
        for i in 0..m {
            if self.dropped[i] {
                y[i] = 0.0;
                continue;
            }
            for k in 0..i {
                y[i] -= l[i * m + k] * y[k];
            }
            y[i] /= l[i * m + i];
        }
        for i in (0..m).rev() {
            if self.dropped[i] {
                continue;
            }
            for k in i + 1..m {
                y[i] -= l[k * m + i] * y[k];
            }
            y[i] /= l[i * m + i];
        }
        for (n, v) in x.iter_mut().enumerate() {
            *v = [y[2 * n], y[2 * n + 1]];
        }
    }
}
