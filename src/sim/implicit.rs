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
//! explicit step) by conjugate gradients with the block-Jacobi
//! preconditioner `(I + dt K_nn)^-1` (each node's own 3x3 block, inverted
//! in the tangent plane when bonded; the loop is [`crate::sim::cg`]). A
//! bonded film's equilibrium is solved on an assembled system instead
//! ([`crate::sim::tangent`]). A solve
//! can start from the best combination of earlier solutions of the same
//! system ([`subspace_start`]), and leaves its residual `r` (as the
//! iteration updated it: it drifts from `rhs - A x` by rounding, so callers
//! that keep products for later starts compute them exactly). Every
//! dot product sums fixed chunks in order, so results do not depend on the
//! thread count.

use crate::math::GrowGently;
use crate::geometry::element::Element;
use crate::math::{v3, Sym3};
use crate::sim::forces::{element_corner_forces, element_strain, gather, Elements, Fans};
use rayon::prelude::*;

pub use crate::sim::cg::CgReport;
use crate::sim::cg::CHUNK;

/// What one face contributes to `K v`, packed for the solver's inner loop
/// (104 of an [`Element`]'s 168 bytes, and the face's corners beside
/// them): the product is bound by memory traffic, so a solve copies the
/// elements into this form once and reads only it in every iteration.
#[derive(Clone, Copy, Default)]
pub struct Packed {
    grads: [[f64; 3]; 3],
    normal: [f64; 3],
    /// Area; negative for a face without an element.
    area: f64,
    corners: [u32; 3],
}

impl Packed {
    fn new(el: Option<&Element>, corners: [u32; 3]) -> Self {
        match el {
            Some(el) => Packed {
                grads: el.grads,
                normal: el.normal,
                area: el.area,
                corners,
            },
            None => Packed {
                area: -1.0,
                corners,
                ..Packed::default()
            },
        }
    }

    /// The corner forces of the strain `B v` of this face, into `c`: the
    /// arithmetic of [`element_strain`] and [`element_corner_forces`]
    /// (the same values).
    #[inline]
    fn corner_forces(&self, v: &[[f64; 3]], c: &mut [[f64; 3]]) {
        if self.area < 0.0 {
            c.fill([0.0; 3]);
            return;
        }
        let mut s = Sym3::ZERO;
        for k in 0..3 {
            let dp = v3::scale(v[self.corners[k] as usize], 1.0);
            let d = v3::sub(dp, v3::scale(self.normal, v3::dot(dp, self.normal)));
            s += Sym3::sym_outer(self.grads[k], d);
        }
        for (ck, gk) in c.iter_mut().zip(&self.grads) {
            *ck = v3::scale(s.mul_vec(*gk), -self.area);
        }
    }
}

/// `sum_n a_n . b_n`, summed in fixed chunks combined in order.
pub fn dot(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    crate::sim::cg::dot(a, b)
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
    /// Per-node interface stiffness times the node's area (a bonded film's
    /// tie to its rest position, [`crate::sim::film`]); empty: none. It adds
    /// `k_n P v_n` to `K v`, which makes the system positive definite.
    pub interface: &'a [f64],
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

    /// Node `n`'s row of `K v` from the gathered corner forces of the strain
    /// `B v` (`gathered`) and `v`'s own value there.
    #[inline]
    fn node_product(&self, n: usize, gathered: [f64; 3], v_n: [f64; 3]) -> [f64; 3] {
        let k = v3::scale(gathered, -1.0);
        match self.interface.get(n) {
            Some(&a) => self.project(n, v3::add(k, v3::scale(v_n, a))),
            None => self.project(n, k),
        }
    }

    /// The projected node forces of `stress`; `corner` is scratch.
    pub fn forces(&self, stress: &[Sym3], corner: &mut Vec<[f64; 3]>) -> Vec<[f64; 3]> {
        self.forces_with(|f, _| stress[f], corner)
    }

    /// The projected node forces of the stress `stress(f, element)` of
    /// every face with an element; `corner` is scratch.
    pub fn forces_with(
        &self,
        stress: impl Fn(usize, &Element) -> Sym3 + Sync,
        corner: &mut Vec<[f64; 3]>,
    ) -> Vec<[f64; 3]> {
        crate::sim::forces::corner_forces_with(self.els, stress, corner);
        let corner = &*corner;
        (0..self.fans.n_vertices())
            .into_par_iter()
            .map(|n| self.project(n, gather(self.fans, corner, n)))
            .collect()
    }

    /// `v . K v` for an allowed motion `v` (projected, as `apply`'s
    /// output), as the area-weighted squared norm of its strain: one pass
    /// over the elements, no node pass. Summed in fixed chunks.
    pub fn energy_norm_sq(&self, v: &[[f64; 3]]) -> f64 {
        let fans = self.fans;
        let parts: Vec<f64> = self
            .els
            .elements
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(c, chunk)| {
                let mut sum = 0.0;
                for (i, el) in chunk.iter().enumerate() {
                    if let Some(el) = el {
                        let f = c * CHUNK + i;
                        let s = element_strain(el, fans.corners(f), v, 1.0, Sym3::ZERO);
                        sum += el.area * s.frobenius_sq();
                    }
                }
                sum
            })
            .collect();
        let elastic = parts.iter().fold(0.0, |a, b| a + b);
        if self.interface.is_empty() {
            return elastic;
        }
        let tie: Vec<f64> = v
            .par_chunks(CHUNK)
            .zip(self.interface.par_chunks(CHUNK))
            .map(|(v, k)| {
                v.iter()
                    .zip(k)
                    .map(|(v, k)| k * v3::dot(*v, *v))
                    .sum::<f64>()
            })
            .collect();
        elastic + tie.iter().fold(0.0, |a, b| a + b)
    }

    /// `out = K v`; `corner` is scratch (3 per face).
    pub fn apply(&self, v: &[[f64; 3]], corner: &mut Vec<[f64; 3]>, out: &mut [[f64; 3]]) {
        self.strain_forces(v, corner);
        // K v = B^T A (B v): the force of the strain B v, negated.
        let corner = &*corner;
        out.par_iter_mut()
            .enumerate()
            .with_min_len(512)
            .for_each(|(n, o)| *o = self.node_product(n, gather(self.fans, corner, n), v[n]));
    }

    /// The corner forces of the strain `B v` (from zero stress).
    fn strain_forces(&self, v: &[[f64; 3]], corner: &mut Vec<[f64; 3]>) {
        corner.resize_gently(3 * self.els.elements.len(), [0.0; 3]);
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
    }

    /// [`strain_forces`](Self::strain_forces) from the packed faces
    /// ([`pack`](Self::pack)); the same values.
    fn packed_strain_forces(&self, packed: &[Packed], v: &[[f64; 3]], corner: &mut Vec<[f64; 3]>) {
        corner.resize_gently(3 * packed.len(), [0.0; 3]);
        corner
            .par_chunks_mut(3)
            .zip(packed.par_iter())
            .enumerate()
            .with_min_len(1024)
            .for_each(|(f, (c, el))| {
                if let Some(next) = packed.get(f + crate::sim::relax::PREFETCH_AHEAD) {
                    prefetch_nodes(v, next.corners);
                }
                el.corner_forces(v, c);
            });
    }

    /// The faces packed for [`packed_strain_forces`](Self::packed_strain_forces), into `out`.
    fn pack(&self, out: &mut Vec<Packed>) {
        let fans = self.fans;
        out.clear();
        self.els
            .elements
            .par_iter()
            .enumerate()
            .map(|(f, el)| Packed::new(el.as_ref(), fans.corners(f)))
            .collect_into_vec(out);
    }

    /// The 3x3 diagonal blocks `K_nn = P_n (sum_e A_e / 2 (|g|^2 T_e +
    /// g g^T)) P_n` of the stiffness (`g` node `n`'s gradient in face `e`,
    /// `T_e` the face's tangent projector): node `n`'s own stiffness with
    /// every other node held. Zero at fixed nodes.
    pub fn blocks(&self) -> Vec<Sym3> {
        (0..self.fans.n_vertices())
            .into_par_iter()
            .map(|n| self.block(n))
            .collect()
    }

    /// [`preconditioner`] of the [`blocks`](Self::blocks) for step `dt`, in
    /// one pass (the same values).
    pub fn block_preconditioner(&self, dt: f64) -> Vec<Sym3> {
        (0..self.fans.n_vertices())
            .into_par_iter()
            .map(|n| self.inverse_block(n, dt))
            .collect()
    }

    /// `(I + dt K_nn)^-1` of node `n`. A bonded node's block is inverted in
    /// its tangent plane: `I + dt K_nn` has the eigenvalue 1 along the
    /// normal and about `dt |K_nn|` in the plane, and a 3x3 inverse by
    /// cofactors loses the plane's digits to that spread when `dt` is long
    /// (four of them at the equilibrium step of 1e12).
    fn inverse_block(&self, n: usize, dt: f64) -> Sym3 {
        let b = self.block(n);
        match self.normals.get(n) {
            Some(&nrm) if !self.fixed[n] => {
                let [t1, t2] = v3::plane_basis(nrm);
                let (b1, b2) = (b.mul_vec(t1), b.mul_vec(t2));
                let (a, c, d) = (
                    1.0 + dt * v3::dot(t1, b1),
                    dt * 0.5 * (v3::dot(t1, b2) + v3::dot(t2, b1)),
                    1.0 + dt * v3::dot(t2, b2),
                );
                let det = a * d - c * c;
                if !(det > 0.0 && det.is_finite()) {
                    return Sym3::IDENTITY;
                }
                // T M^-1 T^T: zero along the normal, so preconditioned
                // residuals keep to the allowed motion even where rounding
                // left a normal part in the residual.
                Sym3::outer(t1) * (d / det)
                    + Sym3::outer(t2) * (a / det)
                    + Sym3::sym_outer(t1, t2) * (-2.0 * c / det)
            }
            _ => sym_inverse(Sym3::IDENTITY + b * dt),
        }
    }

    /// Node `n`'s block of [`blocks`](Self::blocks).
    fn block(&self, n: usize) -> Sym3 {
        if self.fixed[n] {
            return Sym3::ZERO;
        }
        let mut b = Sym3::ZERO;
        for &(f, k) in self.fans.fan(n) {
            if let Some(Some(el)) = self.els.elements.get(f as usize) {
                let g = el.grads[k as usize];
                let t = Sym3::tangent_identity(el.normal, v3::dot(g, g));
                b += (t + Sym3::outer(g)) * (0.5 * el.area);
            }
        }
        if let Some(&a) = self.interface.get(n) {
            b += Sym3::IDENTITY * a;
        }
        match self.normals.get(n) {
            Some(&nrm) => {
                // P B P with P = I - n n^T.
                let p = Sym3::tangent_identity(nrm, 1.0);
                let bp = [
                    b.mul_vec([p.xx, p.xy, p.xz]),
                    b.mul_vec([p.xy, p.yy, p.yz]),
                    b.mul_vec([p.xz, p.yz, p.zz]),
                ];
                let col = |j: usize| p.mul_vec(bp[j]);
                let (c0, c1, c2) = (col(0), col(1), col(2));
                Sym3 {
                    xx: c0[0],
                    yy: c1[1],
                    zz: c2[2],
                    xy: 0.5 * (c1[0] + c0[1]),
                    xz: 0.5 * (c2[0] + c0[2]),
                    yz: 0.5 * (c2[1] + c1[2]),
                }
            }
            None => b,
        }
    }
}

/// The plain 3x3 inverses of `I + dt K_nn` per node (`blocks` from
/// [`Operator::blocks`]): the block-Jacobi preconditioner of a free surface.
/// A bonded one takes [`Operator::block_preconditioner`], which inverts in
/// the tangent planes and keeps residuals to the allowed motion.
pub fn preconditioner(blocks: &[Sym3], dt: f64) -> Vec<Sym3> {
    blocks
        .par_iter()
        .map(|b| sym_inverse(Sym3::IDENTITY + *b * dt))
        .collect()
}

/// The inverse of a symmetric positive definite 3x3 matrix (by cofactors;
/// the identity when it is not invertible).
fn sym_inverse(m: Sym3) -> Sym3 {
    let c_xx = m.yy * m.zz - m.yz * m.yz;
    let c_xy = m.xz * m.yz - m.xy * m.zz;
    let c_xz = m.xy * m.yz - m.xz * m.yy;
    let det = m.xx * c_xx + m.xy * c_xy + m.xz * c_xz;
    if !(det > 0.0 && det.is_finite()) {
        return Sym3::IDENTITY;
    }
    let inv = 1.0 / det;
    Sym3 {
        xx: c_xx * inv,
        xy: c_xy * inv,
        xz: c_xz * inv,
        yy: (m.xx * m.zz - m.xz * m.xz) * inv,
        yz: (m.xy * m.xz - m.xx * m.yz) * inv,
        zz: (m.xx * m.yy - m.xy * m.xy) * inv,
    }
}

/// A shifted system `(I + dt K) x = rhs` and how to solve it: conjugate
/// gradients preconditioned by `pre` ([`Operator::block_preconditioner`]), to relative
/// residual `tol`, in at most `max_iter` iterations.
pub struct Shifted<'a> {
    /// The stiffness.
    pub op: &'a Operator<'a>,
    /// The step.
    pub dt: f64,
    /// Per-node inverse blocks from [`Operator::block_preconditioner`] for this `dt`.
    pub pre: &'a [Sym3],
    /// Relative residual to reach.
    pub tol: f64,
    /// Iteration limit.
    pub max_iter: usize,
}

impl Shifted<'_> {
    /// `out = (I + dt K) v`; `corner` is scratch.
    pub fn apply(&self, v: &[[f64; 3]], corner: &mut Vec<[f64; 3]>, out: &mut [[f64; 3]]) {
        self.op.apply(v, corner, out);
        out.par_iter_mut()
            .zip(v.par_iter())
            .for_each(|(o, v)| *o = v3::add(*v, v3::scale(*o, self.dt)));
    }

    /// Solve from `x` as given (projected onto the allowed motion and
    /// padded with zeros to the system's size; empty for a cold start).
    /// `ax`, when known, is `(I + dt K) x` for that start (it saves a
    /// product); otherwise a non-zero start costs one. On return `r` holds
    /// the residual `rhs - (I + dt K) x` as the iteration updated it.
    /// `scratch` is working memory (kept between solves, so fresh memory
    /// is not paged in for every solve).
    pub fn solve(
        &self,
        rhs: &[[f64; 3]],
        x: &mut Vec<[f64; 3]>,
        ax: Option<&[[f64; 3]]>,
        r: &mut Vec<[f64; 3]>,
        scratch: &mut CgScratch,
    ) -> CgReport {
        let (op, dt, tol) = (self.op, self.dt, self.tol);
        let n = rhs.len();
        x.resize_gently(n, [0.0; 3]);
        r.clear();
        r.extend_from_slice(rhs);
        let CgScratch {
            corner,
            packed,
            z,
            p,
            kp,
        } = scratch;
        for v in [&mut *z, &mut *p, &mut *kp] {
            v.resize_gently(n, [0.0; 3]);
        }
        let mut report = CgReport::default();
        let norm_b = dot(rhs, rhs).sqrt();
        match ax {
            Some(ax) => r
                .par_iter_mut()
                .zip(ax.par_iter())
                .for_each(|(r, ax)| *r = v3::sub(*r, *ax)),
            None => {
                if x.iter().any(|v| *v != [0.0; 3]) {
                    x.par_iter_mut()
                        .enumerate()
                        .for_each(|(i, v)| *v = op.project(i, *v));
                    self.apply(x, corner, kp);
                    r.par_iter_mut()
                        .zip(kp.par_iter())
                        .for_each(|(r, kx)| *r = v3::sub(*r, *kx));
                }
            }
        }
        if !(norm_b > 0.0 && norm_b.is_finite()) {
            report.converged = norm_b == 0.0;
            if report.converged {
                x.iter_mut().for_each(|v| *v = [0.0; 3]);
                r.iter_mut().for_each(|v| *v = [0.0; 3]);
            }
            return report;
        }
        let rel = dot(r, r).sqrt() / norm_b;
        report.relative_residual = rel;
        if rel <= tol {
            // The start is good enough.
            report.converged = true;
            return report;
        }
        // The products read the faces packed once for the solve.
        let pre = self.pre;
        op.pack(packed);
        let packed = &*packed;
        let product = |p: &[[f64; 3]], kp: &mut [[f64; 3]]| {
            // kp = (I + dt K) p, and p . kp, in one pass over the nodes
            // after the elements'.
            op.packed_strain_forces(packed, p, corner);
            let cf = &*corner;
            let parts: Vec<f64> = kp
                .par_chunks_mut(CHUNK)
                .zip(p.par_chunks(CHUNK))
                .enumerate()
                .map(|(c, (a, p))| {
                    let mut s = 0.0;
                    for (i, (a, p)) in a.iter_mut().zip(p).enumerate() {
                        let n = c * CHUNK + i;
                        let k = op.node_product(n, gather(op.fans, cf, n), *p);
                        *a = v3::add(*p, v3::scale(k, dt));
                        s += v3::dot(*p, *a);
                    }
                    s
                })
                .collect();
            parts.iter().sum::<f64>()
        };
        let vectors = crate::sim::cg::Vectors { x, r, z, p, ap: kp };
        crate::sim::cg::iterate(
            product,
            |n, r| pre[n].mul_vec(r),
            vectors,
            norm_b,
            tol,
            self.max_iter,
            &mut report,
        );
        report
    }
}

/// A solution `x` of a system with its product `A x`.
pub type Solution = (Vec<[f64; 3]>, Vec<[f64; 3]>);

/// Working memory of [`Shifted::solve`].
#[derive(Default)]
pub struct CgScratch {
    /// Per-corner forces (3 per face).
    pub corner: Vec<[f64; 3]>,
    packed: Vec<Packed>,
    z: Vec<[f64; 3]>,
    p: Vec<[f64; 3]>,
    kp: Vec<[f64; 3]>,
}

impl CgScratch {
    /// Size (and page in) the memory for a mesh of `n_faces` faces and
    /// `n_nodes` nodes.
    pub fn reserve(&mut self, n_faces: usize, n_nodes: usize) {
        touch(&mut self.corner, 3 * n_faces);
        for v in [&mut self.z, &mut self.p, &mut self.kp] {
            touch(v, n_nodes);
        }
    }
}

/// Prefetch the values of `v` at `nodes` (a hint; never faults).
#[inline]
fn prefetch_nodes(v: &[[f64; 3]], nodes: [u32; 3]) {
    #[cfg(target_arch = "x86_64")]
    for c in nodes {
        if let Some(x) = v.get(c as usize) {
            // SAFETY: prefetching is a hint and never faults.
            unsafe {
                std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                    x.as_ptr().cast(),
                )
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (v, nodes);
}

/// Resize `v` to `n` zeros, writing every element (so its memory is paged
/// in now rather than at first use).
pub fn touch(v: &mut Vec<[f64; 3]>, n: usize) {
    v.clear();
    v.resize_gently(n, [0.0; 3]);
}

/// Earlier solutions `x_i` of one system with their products `A x_i`.
pub type History = Vec<Solution>;

/// The best start for `A x = rhs` in the span of earlier solutions of the
/// same system (the Galerkin projection: the smallest error in the energy
/// norm over that span), into `x` with its product into `ax`; `false`
/// (both untouched) when the span gives nothing. It costs dot products
/// only, since every `A x_i` is known. Directions that are (nearly)
/// dependent on earlier ones are dropped.
pub fn subspace_start(
    history: &History,
    rhs: &[[f64; 3]],
    x: &mut Vec<[f64; 3]>,
    ax: &mut Vec<[f64; 3]>,
) -> bool {
    let m = history.len();
    if m == 0 {
        return false;
    }
    // G_ij = x_i . A x_j (symmetrised), c_i = x_i . rhs: every product in
    // one pass over fixed chunks, the chunks' parts summed in order.
    let parts: Vec<Vec<f64>> = (0..rhs.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let range = c * CHUNK..((c + 1) * CHUNK).min(rhs.len());
            let mut out = vec![0.0; m * m + m];
            for i in 0..m {
                let xi = &history[i].0[range.clone()];
                for j in 0..m {
                    let axj = &history[j].1[range.clone()];
                    out[i * m + j] = xi.iter().zip(axj).map(|(p, q)| v3::dot(*p, *q)).sum();
                }
                out[m * m + i] = xi
                    .iter()
                    .zip(&rhs[range.clone()])
                    .map(|(p, q)| v3::dot(*p, *q))
                    .sum();
            }
            out
        })
        .collect();
    let mut sums = vec![0.0; m * m + m];
    for part in &parts {
        for (s, p) in sums.iter_mut().zip(part) {
            *s += p;
        }
    }
    let mut g = vec![vec![0.0; m]; m];
    for i in 0..m {
        for j in 0..m {
            g[i][j] = 0.5 * (sums[i * m + j] + sums[j * m + i]);
        }
    }
    let c: Vec<f64> = sums[m * m..].to_vec();
    // Cholesky with dropped pivots: G = L L^T over the kept directions.
    let mut l = vec![vec![0.0; m]; m];
    let mut keep = vec![false; m];
    for j in 0..m {
        let mut d = g[j][j];
        for k in 0..j {
            if keep[k] {
                d -= l[j][k] * l[j][k];
            }
        }
        if !(d > 1e-10 * g[j][j] && d.is_finite()) {
            continue;
        }
        keep[j] = true;
        let dj = d.sqrt();
        l[j][j] = dj;
        for i in j + 1..m {
            let mut v = g[i][j];
            for k in 0..j {
                if keep[k] {
                    v -= l[i][k] * l[j][k];
                }
            }
            l[i][j] = v / dj;
        }
    }
    if !keep.iter().any(|&k| k) {
        return false;
    }
    // Solve L L^T y = c over the kept directions.
    let mut w = vec![0.0; m];
    for i in 0..m {
        if keep[i] {
            let mut v = c[i];
            for k in 0..i {
                if keep[k] {
                    v -= l[i][k] * w[k];
                }
            }
            w[i] = v / l[i][i];
        }
    }
    let mut y = vec![0.0; m];
    for i in (0..m).rev() {
        if keep[i] {
            let mut v = w[i];
            for k in i + 1..m {
                if keep[k] {
                    v -= l[k][i] * y[k];
                }
            }
            y[i] = v / l[i][i];
        }
    }
    let n = rhs.len();
    x.clear();
    x.resize_gently(n, [0.0; 3]);
    ax.clear();
    ax.resize_gently(n, [0.0; 3]);
    x.par_iter_mut()
        .zip(ax.par_iter_mut())
        .enumerate()
        .with_min_len(1024)
        .for_each(|(k, (x, ax))| {
            for (h, &yi) in history.iter().zip(&y) {
                if yi != 0.0 {
                    *x = v3::add(*x, v3::scale(h.0[k], yi));
                    *ax = v3::add(*ax, v3::scale(h.1[k], yi));
                }
            }
        });
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Sym2;
    use crate::mesh::shapes::jittered_plate;
    use crate::sim::forces::node_forces_fans;
    use crate::sim::relax::{apply_virtual_displacement, energy};

    /// Solve `(I + dt K) x = rhs` with the block-Jacobi preconditioner.
    fn solve(
        op: &Operator,
        dt: f64,
        rhs: &[[f64; 3]],
        tol: f64,
        x: &mut Vec<[f64; 3]>,
    ) -> CgReport {
        let pre = preconditioner(&op.blocks(), dt);
        let shifted = Shifted {
            op,
            dt,
            pre: &pre,
            tol,
            max_iter: 2000,
        };
        shifted.solve(rhs, x, None, &mut Vec::new(), &mut CgScratch::default())
    }

    /// A plate with random in-plane stress.
    fn stressed() -> (crate::mesh::SimMesh, Elements, Vec<Sym3>) {
        let mesh = jittered_plate(10, 0.3, 3);
        let els = Elements::new(&mesh, f64::INFINITY);
        let mut rng = crate::mesh::shapes::Lcg(9);
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
    fn packed_faces_give_the_same_corner_forces_bit_for_bit() {
        let (mesh, mut els, _) = stressed();
        // A face without an element (a degenerate one) gives no force.
        els.elements[7] = None;
        let fans = Fans::new(&mesh);
        let fixed = vec![false; mesh.n_vertices()];
        let op = Operator {
            fans: &fans,
            els: &els,
            normals: &[],
            fixed: &fixed,
            interface: &[],
        };
        let mut rng = crate::mesh::shapes::Lcg(21);
        let v: Vec<[f64; 3]> = (0..mesh.n_vertices())
            .map(|_| {
                [
                    rng.next_f64() - 0.5,
                    rng.next_f64() - 0.5,
                    rng.next_f64() - 0.5,
                ]
            })
            .collect();
        let (mut plain, mut packed_out, mut packed) = (Vec::new(), Vec::new(), Vec::new());
        op.strain_forces(&v, &mut plain);
        op.pack(&mut packed);
        op.packed_strain_forces(&packed, &v, &mut packed_out);
        assert_eq!(plain.len(), packed_out.len());
        assert!(plain[21..24].iter().all(|c| *c == [0.0; 3]));
        assert!(plain.iter().any(|c| *c != [0.0; 3]));
        for (a, b) in plain.iter().zip(&packed_out) {
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
        }
    }

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
            interface: &[],
        };
        let mut rng = crate::mesh::shapes::Lcg(4);
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
        let (uku, norm) = (dot(&u, &ku), op.energy_norm_sq(&u));
        assert!((uku - norm).abs() <= 1e-10 * norm, "{uku} vs {norm}");
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
            interface: &[],
        };
        let f0 = node_forces_fans(&fans, &els, &stress0);
        let e0 = energy(&els, &stress0);
        for dt in [1e-4, 1e-1, 10.0, 1e4] {
            let rhs: Vec<[f64; 3]> = f0.iter().map(|f| v3::scale(*f, dt)).collect();
            let mut x = Vec::new();
            let rep = solve(&op, dt, &rhs, 1e-10, &mut x);
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
            interface: &[],
        };
        let dt = 10.0;
        let rhs: Vec<[f64; 3]> = node_forces_fans(&fans, &els, &stress0)
            .iter()
            .map(|f| v3::scale(*f, dt))
            .collect();
        let mut cold = Vec::new();
        let c = solve(&op, dt, &rhs, 1e-10, &mut cold);
        assert!(c.converged && c.iterations > 5, "{c:?}");
        // From the solution itself: nothing to do.
        let mut same = cold.clone();
        let s = solve(&op, dt, &rhs, 1e-8, &mut same);
        assert!(s.converged && s.iterations == 0, "{s:?}");
        // From a nearby start (a slightly different right-hand side's
        // solution): fewer iterations, the same solution.
        let rhs2: Vec<[f64; 3]> = rhs.iter().map(|r| v3::scale(*r, 1.05)).collect();
        let mut warm = cold.clone();
        let w = solve(&op, dt, &rhs2, 1e-10, &mut warm);
        let mut fresh = Vec::new();
        let f = solve(&op, dt, &rhs2, 1e-10, &mut fresh);
        assert!(w.converged && w.iterations < f.iterations, "{w:?} vs {f:?}");
        let diff: Vec<[f64; 3]> = warm
            .iter()
            .zip(&fresh)
            .map(|(a, b)| v3::sub(*a, *b))
            .collect();
        assert!(dot(&diff, &diff).sqrt() < 1e-8 * dot(&fresh, &fresh).sqrt());
    }

    /// A curved, partly fixed, bonded setting: unit normals tilted from
    /// the plate's, every seventh node fixed.
    fn bonded(mesh: &crate::mesh::SimMesh) -> (Vec<[f64; 3]>, Vec<bool>) {
        let normals = (0..mesh.n_vertices())
            .map(|n| {
                let a = 0.3 * (n as f64).sin();
                let b = 0.2 * (n as f64 * 0.7).cos();
                let v = [a, b, 1.0];
                v3::scale(v, 1.0 / v3::norm(v))
            })
            .collect();
        let fixed = (0..mesh.n_vertices()).map(|n| n % 7 == 3).collect();
        (normals, fixed)
    }

    /// `blocks` are the operator's own 3x3 diagonal blocks: `K` applied to
    /// an allowed unit motion of one node, read at that node.
    #[test]
    fn blocks_are_the_diagonal_blocks_of_the_operator() {
        let (mesh, els, _) = stressed();
        let fans = Fans::new(&mesh);
        let (normals, fixed) = bonded(&mesh);
        let op = Operator {
            fans: &fans,
            els: &els,
            normals: &normals,
            fixed: &fixed,
            interface: &[],
        };
        let blocks = op.blocks();
        let mut scratch = Vec::new();
        let mut checked = 0;
        for n in (0..mesh.n_vertices()).step_by(5) {
            for j in 0..3 {
                let mut e = [0.0; 3];
                e[j] = 1.0;
                let mut v = vec![[0.0; 3]; mesh.n_vertices()];
                v[n] = op.project(n, e);
                let mut kv = vec![[0.0; 3]; v.len()];
                op.apply(&v, &mut scratch, &mut kv);
                let want = blocks[n].mul_vec(e);
                for c in 0..3 {
                    assert!(
                        (kv[n][c] - want[c]).abs() < 1e-12 * (1.0 + want[c].abs()),
                        "node {n} e{j}: {:?} vs {want:?}",
                        kv[n]
                    );
                }
                checked += 1;
            }
            if fixed[n] {
                assert_eq!(blocks[n], Sym3::ZERO);
            }
        }
        assert!(checked > 30);
        // The preconditioner inverts I + dt K_nn on each node's allowed
        // motion and maps onto it (zero along a bonded node's normal), at
        // a short step and at the equilibrium's.
        for dt in [2.5, 1e12] {
            let pre = op.block_preconditioner(dt);
            for (n, (b, p)) in blocks.iter().zip(&pre).enumerate() {
                let m = Sym3::IDENTITY + *b * dt;
                for e in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
                    let want = if fixed[n] { e } else { op.project(n, e) };
                    let back = p.mul_vec(m.mul_vec(want));
                    for c in 0..3 {
                        assert!((back[c] - want[c]).abs() < 1e-12, "{back:?} vs {want:?}");
                    }
                    if !fixed[n] {
                        assert!(v3::dot(p.mul_vec(e), normals[n]).abs() < 1e-12);
                    }
                }
            }
        }
        // Free nodes: the plain inverse of the blocks.
        let free = Operator { normals: &[], ..op };
        assert_eq!(
            free.block_preconditioner(2.5),
            preconditioner(&free.blocks(), 2.5)
        );
    }

    /// The block-Jacobi preconditioner needs fewer iterations than none on
    /// a bonded, partly fixed system, and both reach the same solution.
    #[test]
    fn block_jacobi_saves_iterations() {
        let (mesh, els, stress) = stressed();
        let fans = Fans::new(&mesh);
        let (normals, fixed) = bonded(&mesh);
        let op = Operator {
            fans: &fans,
            els: &els,
            normals: &normals,
            fixed: &fixed,
            interface: &[],
        };
        let dt = 20.0;
        let rhs: Vec<[f64; 3]> = op
            .forces(&stress, &mut Vec::new())
            .iter()
            .map(|f| v3::scale(*f, dt))
            .collect();
        let identity = vec![Sym3::IDENTITY; rhs.len()];
        let plain = Shifted {
            op: &op,
            dt,
            pre: &identity,
            tol: 1e-10,
            max_iter: 2000,
        };
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let p = plain.solve(
            &rhs,
            &mut a,
            None,
            &mut Vec::new(),
            &mut CgScratch::default(),
        );
        let j = solve(&op, dt, &rhs, 1e-10, &mut b);
        assert!(p.converged && j.converged, "{p:?} {j:?}");
        assert!(j.iterations < p.iterations, "{j:?} vs {p:?}");
        let diff: Vec<[f64; 3]> = a.iter().zip(&b).map(|(a, b)| v3::sub(*a, *b)).collect();
        assert!(dot(&diff, &diff).sqrt() < 1e-8 * dot(&b, &b).sqrt());
        // Fixed nodes do not move; the others move in their tangent plane.
        for (n, x) in b.iter().enumerate() {
            if fixed[n] {
                assert_eq!(*x, [0.0; 3]);
            } else {
                assert!(v3::dot(*x, normals[n]).abs() < 1e-12 * (1.0 + v3::norm(*x)));
            }
        }
    }

    /// The subspace start is exact for a right-hand side in the span of
    /// earlier ones, beats the last solution as a start otherwise, ignores
    /// repeated directions, and its product is `A x0`.
    #[test]
    fn subspace_start_is_the_best_combination_of_earlier_solutions() {
        let (mesh, els, stress) = stressed();
        let fans = Fans::new(&mesh);
        let (normals, fixed) = bonded(&mesh);
        let op = Operator {
            fans: &fans,
            els: &els,
            normals: &normals,
            fixed: &fixed,
            interface: &[],
        };
        let dt = 5.0;
        let pre = preconditioner(&op.blocks(), dt);
        let sys = Shifted {
            op: &op,
            dt,
            pre: &pre,
            tol: 1e-12,
            max_iter: 2000,
        };
        let f = op.forces(&stress, &mut Vec::new());
        let mut rng = crate::mesh::shapes::Lcg(11);
        let mut rhs_k = |k: f64| -> Vec<[f64; 3]> {
            f.iter()
                .enumerate()
                .map(|(n, f)| {
                    let w = [
                        rng.next_f64() - 0.5,
                        rng.next_f64() - 0.5,
                        rng.next_f64() - 0.5,
                    ];
                    op.project(n, v3::add(v3::scale(*f, dt), v3::scale(w, k)))
                })
                .collect()
        };
        let bs: Vec<Vec<[f64; 3]>> = (0..3).map(|_| rhs_k(0.3)).collect();
        let mut history: History = Vec::new();
        let mut corner = Vec::new();
        for b in &bs {
            let mut x = Vec::new();
            let mut r = Vec::new();
            assert!(
                sys.solve(b, &mut x, None, &mut r, &mut CgScratch::default())
                    .converged
            );
            let ax: Vec<[f64; 3]> = b.iter().zip(&r).map(|(b, r)| v3::sub(*b, *r)).collect();
            history.push((x, ax));
        }
        // A repeated direction changes nothing and breaks nothing.
        history.push(history[1].clone());
        // In the span: the start is the solution.
        let mix: Vec<[f64; 3]> = (0..bs[0].len())
            .map(|n| v3::add(v3::scale(bs[0][n], 0.5), v3::scale(bs[2][n], -1.5)))
            .collect();
        let (mut x0, mut ax0) = (Vec::new(), Vec::new());
        assert!(subspace_start(&history, &mix, &mut x0, &mut ax0));
        let mut check = vec![[0.0; 3]; x0.len()];
        sys.apply(&x0, &mut corner, &mut check);
        for (a, b) in check.iter().zip(&ax0) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() < 1e-9 * (1.0 + b[c].abs()));
            }
        }
        let res = |x: &[[f64; 3]], ax: &[[f64; 3]], b: &[[f64; 3]]| {
            let _ = x;
            let r: Vec<[f64; 3]> = b.iter().zip(ax).map(|(b, a)| v3::sub(*b, *a)).collect();
            dot(&r, &r).sqrt() / dot(b, b).sqrt()
        };
        assert!(res(&x0, &ax0, &mix) < 1e-9, "{}", res(&x0, &ax0, &mix));
        // Out of the span: never worse (in the energy norm of the error)
        // than the last solution, and fewer iterations from it.
        let fresh = rhs_k(0.3);
        let (mut x1, mut ax1) = (Vec::new(), Vec::new());
        assert!(subspace_start(&history, &fresh, &mut x1, &mut ax1));
        let mut exact = Vec::new();
        let mut scratch = CgScratch::default();
        sys.solve(&fresh, &mut exact, None, &mut Vec::new(), &mut scratch);
        let err_a = |x: &[[f64; 3]]| {
            let e: Vec<[f64; 3]> = x.iter().zip(&exact).map(|(a, b)| v3::sub(*a, *b)).collect();
            let mut ae = vec![[0.0; 3]; e.len()];
            sys.apply(&e, &mut Vec::new(), &mut ae);
            dot(&e, &ae)
        };
        let last = &history[2].0;
        assert!(
            err_a(&x1) <= err_a(last) * (1.0 + 1e-9),
            "{} vs {}",
            err_a(&x1),
            err_a(last)
        );
        let loose = Shifted { tol: 1e-6, ..sys };
        let mut from_sub = x1.clone();
        let s = loose.solve(
            &fresh,
            &mut from_sub,
            Some(&ax1),
            &mut Vec::new(),
            &mut scratch,
        );
        let mut from_last = last.clone();
        let l = loose.solve(&fresh, &mut from_last, None, &mut Vec::new(), &mut scratch);
        assert!(s.converged && l.converged);
        assert!(s.iterations <= l.iterations, "{s:?} vs {l:?}");
        assert!(!subspace_start(&Vec::new(), &fresh, &mut x1, &mut ax1));
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
