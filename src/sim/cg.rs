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
///
/// A node's preconditioned residual needs only that node's residual, so one
/// pass over the nodes updates the solution and the residual, sums `r . r`,
/// applies the preconditioner and sums `r . z` (each sum in the order
/// [`dot`] takes: the same numbers as separate passes, read once).
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
    let fused = |alpha: f64, v: &mut Vectors<'_, V>| {
        let parts: Vec<(f64, f64)> =
            v.x.par_chunks_mut(CHUNK)
                .zip(v.r.par_chunks_mut(CHUNK))
                .zip(v.z.par_chunks_mut(CHUNK))
                .zip(v.p.par_chunks(CHUNK).zip(v.ap.par_chunks(CHUNK)))
                .enumerate()
                .map(|(c, (((x, r), z), (p, ap)))| {
                    // `rz` starts as `Iterator::sum` does, as in `dot`.
                    let (mut rr, mut rz) = (0.0, -0.0);
                    for i in 0..x.len() {
                        x[i] = x[i].add_scaled(alpha, p[i]);
                        r[i] = r[i].sub_scaled(alpha, ap[i]);
                        rr += r[i].dot(r[i]);
                        z[i] = precondition(c * CHUNK + i, r[i]);
                        rz += r[i].dot(z[i]);
                    }
                    (rr, rz)
                })
                .collect();
        let rr: f64 = parts.iter().map(|p| p.0).sum();
        let rz = parts.iter().fold(0.0, |a, p| a + p.1);
        (rr, Some(rz))
    };
    run(product, whole, fused, v, norm_b, tol, max_iter, report);
}

/// As [`iterate`], with a preconditioner that works on the whole vector:
/// `precondition(r, z)` writes `M^-1 r` into `z` (a multigrid cycle, say).
pub fn iterate_with<V: NodeVector>(
    product: impl FnMut(&[V], &mut [V]) -> f64,
    precondition: impl FnMut(&[V], &mut [V]),
    v: Vectors<'_, V>,
    norm_b: f64,
    tol: f64,
    max_iter: usize,
    report: &mut CgReport,
) {
    let update = |alpha: f64, v: &mut Vectors<'_, V>| (update(alpha, v), None);
    run(
        product,
        precondition,
        update,
        v,
        norm_b,
        tol,
        max_iter,
        report,
    );
}

/// `x += alpha p`, `r -= alpha ap`; returns `r . r` (summed in fixed chunks).
fn update<V: NodeVector>(alpha: f64, v: &mut Vectors<'_, V>) -> f64 {
    let parts: Vec<f64> =
        v.x.par_chunks_mut(CHUNK)
            .zip(v.r.par_chunks_mut(CHUNK))
            .zip(v.p.par_chunks(CHUNK).zip(v.ap.par_chunks(CHUNK)))
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
    parts.iter().sum()
}

/// The iteration: `step(alpha, v)` updates `x` and `r` and returns `r . r`,
/// and `r . z` when it has also preconditioned the new residual into `z`
/// (else `precondition` and [`dot`] follow, if the iteration goes on).
#[allow(clippy::too_many_arguments)]
fn run<V: NodeVector>(
    mut product: impl FnMut(&[V], &mut [V]) -> f64,
    mut precondition: impl FnMut(&[V], &mut [V]),
    mut step: impl FnMut(f64, &mut Vectors<'_, V>) -> (f64, Option<f64>),
    mut v: Vectors<'_, V>,
    norm_b: f64,
    tol: f64,
    max_iter: usize,
    report: &mut CgReport,
) {
    precondition(v.r, v.z);
    v.p.copy_from_slice(v.z);
    let mut rz = dot(v.r, v.z);
    for it in 0..max_iter {
        let pap = product(v.p, v.ap);
        if !(pap > 0.0 && pap.is_finite()) {
            report.iterations = it;
            break;
        }
        let alpha = rz / pap;
        let (rr, rz_next) = step(alpha, &mut v);
        let rel = rr.sqrt() / norm_b;
        report.iterations = it + 1;
        report.relative_residual = rel;
        if rel <= tol {
            report.converged = true;
            break;
        }
        let rz_new = rz_next.unwrap_or_else(|| {
            precondition(v.r, v.z);
            dot(v.r, v.z)
        });
        let beta = rz_new / rz;
        rz = rz_new;
        v.p.par_iter_mut()
            .zip(v.z.par_iter())
            .for_each(|(p, z)| *p = z.add_scaled(beta, *p));
    }
}
