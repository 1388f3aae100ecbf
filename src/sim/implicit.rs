//! Backward-Euler relaxation by preconditioned conjugate gradients.
//!
//! Relaxation is the gradient flow `du/dt = f(u)` of the area-weighted
//! stress energy `E = 1/2 sum_e A_e |S_e|^2`, where `u` are the nodes'
//! virtual displacements, `S_e = S_e0 + B_e u` (the linearised strain of the
//! tangential part of `u`) and `f = -B^T A S` the node forces. With the
//! bonded projection `P` (node tangent planes; zero at fixed nodes) the
//! stiffness `K = P B^T A B P` is symmetric and positive semi-definite, and
//! one backward-Euler step of length `dt` solves
//!
//! `(I + dt K) du = dt f(S_n + dt L)`, then `S_{n+1} = S_n + dt L + B du`,
//!
//! with `L` the load added per unit time. It is stable for every `dt`; the
//! energy never rises when nothing loads. The system is solved matrix-free
//! (`K v` costs one pass over the elements and one over the nodes, as an
//! explicit step) by conjugate gradients with the Jacobi preconditioner
//! `1 + dt d_n`, `d_n = sum_e A_e |g_n^e|^2`. Every dot product sums fixed
//! chunks in order, so results do not depend on the thread count.

use crate::sim::forces::{element_corner_forces, element_strain, gather, Elements, Fans};
use crate::stress::tensor::{v3, Sym3};
use rayon::prelude::*;

/// Chunk length of the deterministic dot products.
const CHUNK: usize = 4096;

/// `sum_n a_n . b_n`, summed in fixed chunks combined in order.
pub fn dot(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let parts: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| v3::dot(*p, *q)).sum::<f64>())
        .collect();
    parts.iter().sum()
}

/// The projected stiffness `K = P B^T A B P` of a mesh state.
pub struct Operator<'a> {
    /// Node fans and face corners.
    pub fans: &'a Fans,
    /// The elements.
    pub els: &'a Elements,
    /// Unit node normals when the surface is bonded (empty: free).
    pub normals: &'a [[f64; 3]],
    /// Fixed nodes.
    pub fixed: &'a [bool],
}

impl Operator<'_> {
    /// `x` projected onto node `n`'s allowed motion (zero when fixed, the
    /// tangent plane when bonded).
    #[inline]
    pub fn project(&self, n: usize, x: [f64; 3]) -> [f64; 3] {
        if self.fixed[n] {
            return [0.0; 3];
        }
        match self.normals.get(n) {
            Some(&nrm) => v3::sub(x, v3::scale(nrm, v3::dot(x, nrm))),
            None => x,
        }
    }

    /// `out = K v`; `corner` is scratch (3 per face).
    pub fn apply(&self, v: &[[f64; 3]], corner: &mut Vec<[f64; 3]>, out: &mut [[f64; 3]]) {
        corner.resize(3 * self.els.elements.len(), [0.0; 3]);
        let fans = self.fans;
        corner
            .par_chunks_mut(3)
            .zip(self.els.elements.par_iter())
            .enumerate()
            .with_min_len(1024)
            .for_each(|(f, (c, el))| {
                crate::sim::relax::prefetch_corners(fans, v, f + crate::sim::relax::PREFETCH_AHEAD);
                let Some(el) = el else {
                    c.fill([0.0; 3]);
                    return;
                };
                let s = element_strain(el, fans.corners(f), v, 1.0, Sym3::ZERO);
                element_corner_forces(el, &s, c);
            });
        // K v = B^T A (B v): the force of the strain B v, negated.
        let corner = &*corner;
        out.par_iter_mut()
            .enumerate()
            .with_min_len(512)
            .for_each(|(n, o)| *o = self.project(n, v3::scale(gather(fans, corner, n), -1.0)));
    }

    /// The Jacobi scale `d_n = sum_e A_e |g_n^e|^2` of every node.
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.fans.n_vertices())
            .into_par_iter()
            .map(|n| {
                let mut d = 0.0;
                for &(f, k) in self.fans.fan(n) {
                    if let Some(Some(el)) = self.els.elements.get(f as usize) {
                        d += el.area * v3::dot(el.grads[k as usize], el.grads[k as usize]);
                    }
                }
                d
            })
            .collect()
    }
}

/// What a solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct CgReport {
    /// Iterations used.
    pub iterations: usize,
    /// Final residual norm over the right-hand side's norm.
    pub relative_residual: f64,
    /// Whether it reached the tolerance.
    pub converged: bool,
}

/// Solve `(I + dt K) x = rhs` to relative residual `tol` (at most
/// `max_iter` iterations) by Jacobi-preconditioned conjugate gradients,
/// starting from `x` as given (projected onto the allowed motion, and
/// padded with zeros to the system's size): pass an empty vector for a
/// cold start, or the last solution of a similar system to save
/// iterations. `diag` is [`Operator::diagonal`].
pub fn solve_shifted(
    op: &Operator,
    dt: f64,
    rhs: &[[f64; 3]],
    diag: &[f64],
    tol: f64,
    max_iter: usize,
    x: &mut Vec<[f64; 3]>,
) -> CgReport {
    let n = rhs.len();
    x.resize(n, [0.0; 3]);
    let warm = x.iter().any(|v| *v != [0.0; 3]);
    if warm {
        x.par_iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = op.project(i, *v));
    }
    let norm_b = dot(rhs, rhs).sqrt();
    if !(norm_b > 0.0 && norm_b.is_finite()) {
        return CgReport {
            iterations: 0,
            relative_residual: 0.0,
            converged: norm_b == 0.0,
        };
    }
    // Every pass below works on fixed chunks and sums each chunk's part of
    // a dot product in order, so the sums are those of [`dot`].
    let inv: Vec<f64> = diag.par_iter().map(|d| 1.0 / (1.0 + dt * d)).collect();
    let mut corner = Vec::new();
    let mut r: Vec<[f64; 3]> = rhs.to_vec();
    if warm {
        // r = rhs - (I + dt K) x.
        let mut kx = vec![[0.0; 3]; n];
        op.apply(x, &mut corner, &mut kx);
        r.par_iter_mut()
            .zip(x.par_iter().zip(kx.par_iter()))
            .for_each(|(r, (x, kx))| *r = v3::sub(*r, v3::add(*x, v3::scale(*kx, dt))));
    }
    let mut z: Vec<[f64; 3]> = r.iter().zip(&inv).map(|(r, i)| v3::scale(*r, *i)).collect();
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut kp = vec![[0.0; 3]; n];
    let mut report = CgReport::default();
    if warm {
        // The start may already be good enough.
        let rel = dot(&r, &r).sqrt() / norm_b;
        report.relative_residual = rel;
        if rel <= tol {
            report.converged = true;
            return report;
        }
    }
    let sum = |parts: Vec<f64>| parts.iter().sum::<f64>();
    for it in 0..max_iter {
        op.apply(&p, &mut corner, &mut kp);
        // kp = (I + dt K) p, and p . kp.
        let pap = sum(kp
            .par_chunks_mut(CHUNK)
            .zip(p.par_chunks(CHUNK))
            .map(|(a, p)| {
                let mut s = 0.0;
                for (a, p) in a.iter_mut().zip(p) {
                    *a = v3::add(*p, v3::scale(*a, dt));
                    s += v3::dot(*p, *a);
                }
                s
            })
            .collect());
        if !(pap > 0.0 && pap.is_finite()) {
            report.iterations = it;
            break;
        }
        let alpha = rz / pap;
        // x += alpha p, r -= alpha kp, z = M^-1 r; r . r and r . z.
        let parts: Vec<(f64, f64)> = x
            .par_chunks_mut(CHUNK)
            .zip(r.par_chunks_mut(CHUNK))
            .zip(z.par_chunks_mut(CHUNK))
            .zip(p.par_chunks(CHUNK).zip(kp.par_chunks(CHUNK)))
            .zip(inv.par_chunks(CHUNK))
            .map(|((((x, r), z), (p, kp)), inv)| {
                let (mut rr, mut rz) = (0.0, 0.0);
                for i in 0..x.len() {
                    x[i] = v3::add(x[i], v3::scale(p[i], alpha));
                    r[i] = v3::sub(r[i], v3::scale(kp[i], alpha));
                    z[i] = v3::scale(r[i], inv[i]);
                    rr += v3::dot(r[i], r[i]);
                    rz += v3::dot(r[i], z[i]);
                }
                (rr, rz)
            })
            .collect();
        let rr: f64 = parts.iter().map(|x| x.0).sum();
        let rel = rr.sqrt() / norm_b;
        report.iterations = it + 1;
        report.relative_residual = rel;
        if rel <= tol {
            report.converged = true;
            break;
        }
        let rz_new: f64 = parts.iter().map(|x| x.1).sum();
        let beta = rz_new / rz;
        rz = rz_new;
        p.par_iter_mut()
            .zip(z.par_iter())
            .for_each(|(p, z)| *p = v3::add(*z, v3::scale(*p, beta)));
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::forces::node_forces_fans;
    use crate::sim::forces::tests::jittered_plate;
    use crate::sim::relax::{apply_virtual_displacement, energy};
    use crate::stress::Sym2;

    /// A plate with random in-plane stress.
    fn stressed() -> (crate::mesh::SimMesh, Elements, Vec<Sym3>) {
        let mesh = jittered_plate(10, 0.3, 3);
        let els = Elements::new(&mesh, f64::INFINITY);
        let mut rng = crate::mesh::test_util::Lcg(9);
        let stress = mesh
            .faces()
            .map(|f| {
                let el = els.get(f).unwrap();
                let s = Sym2 {
                    xx: 1.0 + rng.next_f64(),
                    yy: 1.0 + rng.next_f64(),
                    xy: rng.next_f64() - 0.5,
                };
                Sym3::from_frame(&s, el.e1, el.e2)
            })
            .collect();
        (mesh, els, stress)
    }

    /// `K` is symmetric and positive semi-definite, and `K u` is minus the
    /// force of the strain `B u`.
    #[test]
    fn the_operator_is_symmetric_and_matches_the_forces() {
        let (mesh, els, _) = stressed();
        let fans = Fans::new(&mesh);
        let fixed = vec![false; mesh.n_vertices()];
        let op = Operator {
            fans: &fans,
            els: &els,
            normals: &[],
            fixed: &fixed,
        };
        let mut rng = crate::mesh::test_util::Lcg(4);
        let mut rand = || -> Vec<[f64; 3]> {
            (0..mesh.n_vertices())
                .map(|_| [rng.next_f64() - 0.5, rng.next_f64() - 0.5, 0.0])
                .collect()
        };
        let (u, v) = (rand(), rand());
        let mut scratch = Vec::new();
        let mut ku = vec![[0.0; 3]; u.len()];
        let mut kv = vec![[0.0; 3]; u.len()];
        op.apply(&u, &mut scratch, &mut ku);
        op.apply(&v, &mut scratch, &mut kv);
        let (a, b) = (dot(&v, &ku), dot(&u, &kv));
        assert!((a - b).abs() <= 1e-10 * a.abs().max(1.0), "{a} vs {b}");
        assert!(dot(&u, &ku) >= 0.0);
        // Against the explicit machinery: strain of u from zero stress.
        let mut s = vec![Sym3::ZERO; mesh.n_faces()];
        apply_virtual_displacement(&fans, &els, &mut s, &u, 1.0, |_, _| Sym3::ZERO);
        let f = node_forces_fans(&fans, &els, &s);
        for (k, fk) in ku.iter().zip(&f) {
            for c in 0..3 {
                assert!((k[c] + fk[c]).abs() < 1e-9, "{k:?} vs {fk:?}");
            }
        }
    }

    /// A backward-Euler step solves its system to the tolerance, lowers the
    /// energy, and for a small step agrees with forward Euler to first
    /// order.
    #[test]
    fn a_backward_euler_step_lowers_the_energy() {
        let (mesh, els, stress0) = stressed();
        let fans = Fans::new(&mesh);
        let fixed = vec![false; mesh.n_vertices()];
        let op = Operator {
            fans: &fans,
            els: &els,
            normals: &[],
            fixed: &fixed,
        };
        let diag = op.diagonal();
        let f0 = node_forces_fans(&fans, &els, &stress0);
        let e0 = energy(&els, &stress0);
        for dt in [1e-4, 1e-1, 10.0, 1e4] {
            let rhs: Vec<[f64; 3]> = f0.iter().map(|f| v3::scale(*f, dt)).collect();
            let mut x = Vec::new();
            let rep = solve_shifted(&op, dt, &rhs, &diag, 1e-10, 2000, &mut x);
            assert!(rep.converged, "dt {dt}: {rep:?}");
            let mut s = stress0.clone();
            apply_virtual_displacement(&fans, &els, &mut s, &x, 1.0, |_, _| Sym3::ZERO);
            let e1 = energy(&els, &s);
            assert!(e1 < e0, "dt {dt}: {e1} >= {e0}");
            if dt == 1e-4 {
                // Forward Euler: dE = -dt |f|^2 to first order.
                let expect = e0 - dt * dot(&f0, &f0);
                assert!(
                    (e1 - expect).abs() < 1e-3 * (e0 - expect),
                    "{e1} vs {expect}"
                );
            }
        }
    }

    #[test]
    fn a_warm_start_saves_iterations_and_reaches_the_same_solution() {
        let (mesh, els, stress0) = stressed();
        let fans = Fans::new(&mesh);
        let fixed = vec![false; mesh.n_vertices()];
        let op = Operator {
            fans: &fans,
            els: &els,
            normals: &[],
            fixed: &fixed,
        };
        let diag = op.diagonal();
        let dt = 10.0;
        let rhs: Vec<[f64; 3]> = node_forces_fans(&fans, &els, &stress0)
            .iter()
            .map(|f| v3::scale(*f, dt))
            .collect();
        let mut cold = Vec::new();
        let c = solve_shifted(&op, dt, &rhs, &diag, 1e-10, 2000, &mut cold);
        assert!(c.converged && c.iterations > 5, "{c:?}");
        // From the solution itself: nothing to do.
        let mut same = cold.clone();
        let s = solve_shifted(&op, dt, &rhs, &diag, 1e-8, 2000, &mut same);
        assert!(s.converged && s.iterations == 0, "{s:?}");
        // From a nearby start (a slightly different right-hand side's
        // solution): fewer iterations, the same solution.
        let rhs2: Vec<[f64; 3]> = rhs.iter().map(|r| v3::scale(*r, 1.05)).collect();
        let mut warm = cold.clone();
        let w = solve_shifted(&op, dt, &rhs2, &diag, 1e-10, 2000, &mut warm);
        let mut fresh = Vec::new();
        let f = solve_shifted(&op, dt, &rhs2, &diag, 1e-10, 2000, &mut fresh);
        assert!(w.converged && w.iterations < f.iterations, "{w:?} vs {f:?}");
        let diff: Vec<[f64; 3]> = warm
            .iter()
            .zip(&fresh)
            .map(|(a, b)| v3::sub(*a, *b))
            .collect();
        assert!(dot(&diff, &diff).sqrt() < 1e-8 * dot(&fresh, &fresh).sqrt());
    }

    #[test]
    fn dot_products_do_not_depend_on_the_thread_count() {
        let a: Vec<[f64; 3]> = (0..20_000)
            .map(|i| [(i as f64).sin(), (i as f64 * 0.7).cos(), 1e-3 * i as f64])
            .collect();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| dot(&a, &a));
        let many = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap()
            .install(|| dot(&a, &a));
        assert_eq!(one.to_bits(), many.to_bits());
    }
}
