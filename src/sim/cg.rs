//! The preconditioned conjugate-gradient iteration shared by the
//! matrix-free solve of [`crate::sim::implicit`] (three unknowns a node)
//! and the assembled tangent-plane solve of [`crate::sim::tangent`] (two).
//! Every pass works on fixed chunks of nodes and sums each chunk's part of
//! a dot product in order, so results do not depend on the thread count.

use rayon::prelude::*;

/// Chunk length of the deterministic dot products.
pub const CHUNK: usize = 4096;

/// What one solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct CgReport {
    /// Iterations used.
    pub iterations: usize,
    /// Final residual norm over the right-hand side's norm.
    pub relative_residual: f64,
    /// Whether it reached the tolerance.
    pub converged: bool,
}

/// A node's unknowns.
pub trait NodeVector: Copy + Send + Sync {
    /// `self + a p`.
    fn add_scaled(self, a: f64, p: Self) -> Self;
    /// `self - a p`.
    fn sub_scaled(self, a: f64, p: Self) -> Self;
    /// `self . o`.
    fn dot(self, o: Self) -> f64;
}

impl NodeVector for [f64; 3] {
    #[inline]
    fn add_scaled(self, a: f64, p: Self) -> Self {
        [self[0] + p[0] * a, self[1] + p[1] * a, self[2] + p[2] * a]
    }
    #[inline]
    fn sub_scaled(self, a: f64, p: Self) -> Self {
        [self[0] - p[0] * a, self[1] - p[1] * a, self[2] - p[2] * a]
    }
    #[inline]
    fn dot(self, o: Self) -> f64 {
        self[0] * o[0] + self[1] * o[1] + self[2] * o[2]
    }
}

impl NodeVector for [f64; 2] {
    #[inline]
    fn add_scaled(self, a: f64, p: Self) -> Self {
        [self[0] + p[0] * a, self[1] + p[1] * a]
    }
    #[inline]
    fn sub_scaled(self, a: f64, p: Self) -> Self {
        [self[0] - p[0] * a, self[1] - p[1] * a]
    }
    #[inline]
    fn dot(self, o: Self) -> f64 {
        self[0] * o[0] + self[1] * o[1]
    }
}

/// `sum_n a_n . b_n`, summed in fixed chunks combined in order.
pub fn dot<V: NodeVector>(a: &[V], b: &[V]) -> f64 {
    let parts: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p.dot(*q)).sum::<f64>())
        .collect();
    parts.iter().fold(0.0, |a, b| a + b)
}

/// The working vectors of one iteration (each one per node).
pub struct Vectors<'a, V> {
    /// The solution, updated in place.
    pub x: &'a mut [V],
    /// The residual on entry (for `x`), updated by the recurrence.
    pub r: &'a mut [V],
    /// Scratch: the preconditioned residual.
    pub z: &'a mut [V],
    /// Scratch: the search direction.
    pub p: &'a mut [V],
    /// Scratch: the product with the search direction.
    pub ap: &'a mut [V],
}

/// Conjugate gradients from the residual in `v.r` until the residual's norm
/// is `tol` times `norm_b` or `max_iter` iterations have run. `product(p,
/// ap)` writes `A p` into `ap` and returns `p . A p` (summed in fixed chunks);
/// `precondition(n, r)` is the preconditioner's block at node `n` applied to
/// `r`. The report's residual is the recurrence's.
pub fn iterate<V: NodeVector>(
    product: impl FnMut(&[V], &mut [V]) -> f64,
    precondition: impl Fn(usize, V) -> V + Sync,
    v: Vectors<'_, V>,
    norm_b: f64,
    tol: f64,
    max_iter: usize,
    report: &mut CgReport,
) {
    let whole = |r: &[V], z: &mut [V]| {
        z.par_chunks_mut(CHUNK)
            .zip(r.par_chunks(CHUNK))
            .enumerate()
            .for_each(|(c, (z, r))| {
                for i in 0..z.len() {
                    z[i] = precondition(c * CHUNK + i, r[i]);
                }
            });
    };
    iterate_with(product, whole, v, norm_b, tol, max_iter, report);
}

/// As [`iterate`], with a preconditioner that works on the whole vector:
/// `precondition(r, z)` writes `M^-1 r` into `z` (a multigrid cycle, say).
pub fn iterate_with<V: NodeVector>(
    mut product: impl FnMut(&[V], &mut [V]) -> f64,
    mut precondition: impl FnMut(&[V], &mut [V]),
    v: Vectors<'_, V>,
    norm_b: f64,
    tol: f64,
    max_iter: usize,
    report: &mut CgReport,
) {
    let Vectors { x, r, z, p, ap } = v;
    precondition(r, z);
    p.copy_from_slice(z);
    let mut rz = dot(r, z);
    for it in 0..max_iter {
        let pap = product(p, ap);
        if !(pap > 0.0 && pap.is_finite()) {
            report.iterations = it;
            break;
        }
        let alpha = rz / pap;
        // x += alpha p, r -= alpha ap; r . r.
        let parts: Vec<f64> = x
            .par_chunks_mut(CHUNK)
            .zip(r.par_chunks_mut(CHUNK))
            .zip(p.par_chunks(CHUNK).zip(ap.par_chunks(CHUNK)))
            .map(|((x, r), (p, ap))| {
                let mut rr = 0.0;
                for i in 0..x.len() {
                    x[i] = x[i].add_scaled(alpha, p[i]);
                    r[i] = r[i].sub_scaled(alpha, ap[i]);
                    rr += r[i].dot(r[i]);
                }
                rr
            })
            .collect();
        let rr: f64 = parts.iter().sum();
        let rel = rr.sqrt() / norm_b;
        report.iterations = it + 1;
        report.relative_residual = rel;
        if rel <= tol {
            report.converged = true;
            break;
        }
        precondition(r, z);
        let rz_new = dot(r, z);
        let beta = rz_new / rz;
        rz = rz_new;
        p.par_iter_mut()
            .zip(z.par_iter())
            .for_each(|(p, z)| *p = z.add_scaled(beta, *p));
    }
}
