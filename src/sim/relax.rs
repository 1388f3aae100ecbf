//! Stress relaxation by forward Euler (Iben & O'Brien 2009, sec. 4.1).
//!
//! Each step computes the net node forces `g[n]` (zero at fixed nodes), moves
//! nodes virtually by `dp = dt g`, and adds the linearised strain of that
//! displacement to each element's stress:
//! `S_e += sum_i sym(g_i (P dp_i)^T)` with `P` the projection onto the
//! element's plane. The area-weighted energy `1/2 sum_e A_e |S_e|_F^2`
//! decreases by `dt |g|^2` to first order, and monotonically for
//! `dt <= 2 / lambda_max(K)`; [`stable_dt`] bounds `lambda_max` from above.

use crate::math::GrowGently;
use crate::geometry::element::Element;
use crate::math::{v3, Sym3};
use crate::mesh::SimMesh;
use crate::sim::forces::{element_corner_forces, element_strain, node_forces_fans, Elements, Fans};
use rayon::prelude::*;

/// What one relaxation step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RelaxStep {
    /// Energy before the step.
    pub energy_before: f64,
    /// Energy after the step.
    pub energy_after: f64,
    /// Euclidean norm of the residual node forces before the step.
    pub residual: f64,
}

/// Area-weighted stress energy `1/2 sum_e A_e |S_e|_F^2`, summed in face order.
pub fn energy(els: &Elements, stress: &[Sym3]) -> f64 {
    let parts: Vec<f64> = els
        .elements
        .par_chunks(ENERGY_CHUNK)
        .zip(stress.par_chunks(ENERGY_CHUNK))
        .map(|(els, stress)| chunk_energy(els, stress))
        .collect();
    parts.iter().fold(0.0, |a, b| a + b)
}

/// Faces per part of [`energy`]'s sum (parts summed in order, so the value
/// does not depend on the thread count).
const ENERGY_CHUNK: usize = 4096;

#[inline]
fn chunk_energy(els: &[Option<Element>], stress: &[Sym3]) -> f64 {
    let mut e = 0.0;
    for (el, s) in els.iter().zip(stress) {
        if let Some(el) = el {
            e += 0.5 * el.area * s.frobenius_sq();
        }
    }
    e
}

/// Per-node stiffness bound `b_n = sum_{e at n} A_e |g_n^e| sum_i |g_i^e|`,
/// which bounds the absolute row sum of the stiffness matrix `K` at node `n`.
/// So `K <= diag(b)`: a forward-Euler step that moves each node by
/// `dt_n g_n` with `dt_n < 2 / b_n` never increases the energy, whatever the
/// other nodes' steps (a sliver slows its own nodes down, not the whole mesh).
pub fn node_bounds(fans: &Fans, els: &Elements) -> Vec<f64> {
    let per_face: Vec<f64> = els
        .elements
        .iter()
        .map(|e| {
            e.as_ref().map_or(0.0, |e| {
                e.area * e.grads.iter().map(|g| v3::norm(*g)).sum::<f64>()
            })
        })
        .collect();
    (0..fans.n_vertices())
        .into_par_iter()
        .map(|v| {
            let mut s = 0.0;
            for &(f, k) in fans.fan(v) {
                if let Some(Some(el)) = els.elements.get(f as usize) {
                    s += per_face[f as usize] * v3::norm(el.grads[k as usize]);
                }
            }
            s
        })
        .collect()
}

/// A step size for which forward Euler with one step for all nodes is
/// energy-stable: `1.9 / max_n b_n` (see [`node_bounds`]).
/// Returns `f64::INFINITY` for a mesh without elements.
pub fn stable_dt(mesh: &SimMesh, els: &Elements) -> f64 {
    let bound = node_bounds(&Fans::new(mesh), els)
        .into_iter()
        .fold(0.0, f64::max);
    if bound > 0.0 {
        1.9 / bound
    } else {
        f64::INFINITY
    }
}

/// One forward-Euler relaxation step of length `dt`; nodes with `fixed[n]`
/// do not move. Updates `stress` in place.
pub fn relax_step(
    mesh: &SimMesh,
    els: &Elements,
    stress: &mut [Sym3],
    fixed: &[bool],
    dt: f64,
) -> RelaxStep {
    let energy_before = energy(els, stress);
    let fans = Fans::new(mesh);
    let mut g = node_forces_fans(&fans, els, stress);
    for (gn, &f) in g.iter_mut().zip(fixed) {
        if f {
            *gn = [0.0; 3];
        }
    }
    let residual = g.iter().map(|x| v3::dot(*x, *x)).sum::<f64>().sqrt();
    apply_virtual_displacement(&fans, els, stress, &g, dt, |_, _| Sym3::ZERO);
    RelaxStep {
        energy_before,
        energy_after: energy(els, stress),
        residual,
    }
}

/// Add to each element the linearised strain of the virtual displacement
/// `dt * g` (its tangential part), plus `load(f, element)` (the stress the
/// load adds to face `f` in this step).
pub fn apply_virtual_displacement(
    fans: &Fans,
    els: &Elements,
    stress: &mut [Sym3],
    g: &[[f64; 3]],
    dt: f64,
    load: impl Fn(usize, &Element) -> Sym3 + Sync,
) {
    stress
        .par_iter_mut()
        .enumerate()
        .with_min_len(512)
        .for_each(|(f, s)| {
            let Some(Some(el)) = els.elements.get(f) else {
                return;
            };
            *s += element_strain(el, fans.corners(f), g, dt, load(f, el));
        });
}

/// [`apply_virtual_displacement`] (no load), then each element's corner
/// forces at its new stress into `corner` (as
/// [`crate::sim::forces::corner_forces`]), returning the energy of the new
/// stress (the value of [`energy`]), all in one pass over the elements.
pub fn apply_virtual_displacement_energy(
    fans: &Fans,
    els: &Elements,
    stress: &mut [Sym3],
    corner: &mut Vec<[f64; 3]>,
    g: &[[f64; 3]],
) -> f64 {
    corner.resize_gently(3 * els.elements.len(), [0.0; 3]);
    let parts: Vec<f64> = stress
        .par_chunks_mut(ENERGY_CHUNK)
        .zip(corner.par_chunks_mut(3 * ENERGY_CHUNK))
        .zip(els.elements.par_chunks(ENERGY_CHUNK))
        .enumerate()
        .map(|(c, ((stress, corner), chunk))| {
            // The sum as `chunk_energy`'s, in the same order.
            let mut e = 0.0;
            for (i, ((s, el), cf)) in stress
                .iter_mut()
                .zip(chunk)
                .zip(corner.chunks_mut(3))
                .enumerate()
            {
                let f = c * ENERGY_CHUNK + i;
                prefetch_corners(fans, g, f + PREFETCH_AHEAD);
                match el {
                    Some(el) => {
                        *s += element_strain(el, fans.corners(f), g, 1.0, Sym3::ZERO);
                        element_corner_forces(el, s, cf);
                        e += 0.5 * el.area * s.frobenius_sq();
                    }
                    None => cf.fill([0.0; 3]),
                }
            }
            e
        })
        .collect();
    parts.iter().fold(0.0, |a, b| a + b)
}

/// [`apply_virtual_displacement`], then each element's corner forces at its
/// new stress into `corner` (as [`crate::sim::forces::corner_forces`]), in
/// the same pass over the elements: the next step's forces come without
/// reading the elements again. Bit for bit the same as the two calls.
pub fn apply_virtual_displacement_with_forces(
    fans: &Fans,
    els: &Elements,
    stress: &mut [Sym3],
    corner: &mut [[f64; 3]],
    g: &[[f64; 3]],
    dt: f64,
    load: impl Fn(usize, &Element) -> Sym3 + Sync,
) {
    stress
        .par_iter_mut()
        .zip(corner.par_chunks_mut(3))
        .enumerate()
        .with_min_len(512)
        .for_each(|(f, (s, c))| {
            prefetch_corners(fans, g, f + PREFETCH_AHEAD);
            let Some(Some(el)) = els.elements.get(f) else {
                c.fill([0.0; 3]);
                return;
            };
            *s += element_strain(el, fans.corners(f), g, dt, load(f, el));
            element_corner_forces(el, s, c);
        });
}

/// How many faces ahead the element loop asks for its corners' node values.
pub const PREFETCH_AHEAD: usize = 12;

/// Ask the cache for the node values `g` at face `f`'s corners (a hint
/// only: the node reads are scattered and otherwise stall the loop).
#[inline(always)]
pub fn prefetch_corners(fans: &Fans, g: &[[f64; 3]], f: usize) {
    #[cfg(target_arch = "x86_64")]
    if f < fans.n_faces() {
        for c in fans.corners(f) {
            if let Some(x) = g.get(c as usize) {
                // SAFETY: prefetching is a hint and never faults.
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                        x.as_ptr().cast(),
                    )
                }
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (fans, g, f);
}

/// Coefficients of one super-step of the second-order Runge-Kutta-Legendre
/// method (RKL2; Meyer, Balsara & Aslam 2014) with `s` stages: for
/// `y' = F(y)` and a super-step `tau`,
///
/// `Y1 = Y0 + mu_t[1] tau F(Y0)`,
/// `Yj = mu[j] Y(j-1) + nu[j] Y(j-2) + (1 - mu[j] - nu[j]) Y0
///       + mu_t[j] tau F(Y(j-1)) + gamma_t[j] tau F(Y0)`, `j = 2..s`,
///
/// and the result is `Ys`. It is stable (its amplification stays within
/// [-1, 1]) for `tau <= (s^2 + s - 2) / 4 * h` with `h` forward Euler's
/// limit `2 / lambda_max`: `s` force evaluations cover the time of about
/// `s^2 / 4` forward-Euler steps, and the result is second-order accurate.
#[derive(Clone, Debug, PartialEq)]
pub struct Rkl2 {
    /// Stages.
    pub s: usize,
    /// `mu[j]` (index 0 and 1 unused).
    pub mu: Vec<f64>,
    /// `nu[j]` (index 0 and 1 unused).
    pub nu: Vec<f64>,
    /// `mu_t[j]` (index 0 unused).
    pub mu_t: Vec<f64>,
    /// `gamma_t[j]` (index 0 and 1 unused).
    pub gamma_t: Vec<f64>,
    /// For a part of the state that does not feed back (the nodes'
    /// displacement, whose rate depends only on the stress): the
    /// super-step adds `tau sum_i weights[i] F(Y_i)`, `i = 0..s-1`.
    pub weights: Vec<f64>,
}

impl Rkl2 {
    /// The fewest stages (at least 2) whose super-step covers `ratio`
    /// forward-Euler stable steps: `(s^2 + s - 2) / 4 >= ratio`.
    pub fn stages_for(ratio: f64) -> usize {
        let mut s = 2usize;
        while Self::reach(s) < ratio && s < 1 << 20 {
            s += 1;
        }
        s
    }

    /// How many forward-Euler stable steps one super-step of `s` stages covers.
    pub fn reach(s: usize) -> f64 {
        (s * s + s - 2) as f64 / 4.0
    }

    /// The coefficients for `s >= 2` stages.
    pub fn new(s: usize) -> Rkl2 {
        let s = s.max(2);
        let w1 = 4.0 / (s * s + s - 2) as f64;
        let b = |j: usize| {
            if j < 2 {
                1.0 / 3.0
            } else {
                let j = j as f64;
                (j * j + j - 2.0) / (2.0 * j * (j + 1.0))
            }
        };
        let a = |j: usize| 1.0 - b(j);
        let mut mu = vec![0.0; s + 1];
        let mut nu = vec![0.0; s + 1];
        let mut mu_t = vec![0.0; s + 1];
        let mut gamma_t = vec![0.0; s + 1];
        mu_t[1] = b(1) * w1;
        for j in 2..=s {
            let jf = j as f64;
            mu[j] = (2.0 * jf - 1.0) / jf * b(j) / b(j - 1);
            nu[j] = -(jf - 1.0) / jf * b(j) / b(j - 2);
            mu_t[j] = mu[j] * w1;
            gamma_t[j] = -a(j - 1) * mu_t[j];
        }
        // The recurrence on the weights of F(Y_0..s-1) in Y_j - Y_0.
        let mut back = vec![0.0; s];
        let mut cur = vec![0.0; s];
        cur[0] = mu_t[1];
        for j in 2..=s {
            let mut next: Vec<f64> = cur
                .iter()
                .zip(&back)
                .map(|(c, b)| mu[j] * c + nu[j] * b)
                .collect();
            next[j - 1] += mu_t[j];
            next[0] += gamma_t[j];
            back = std::mem::replace(&mut cur, next);
        }
        Rkl2 {
            s,
            mu,
            nu,
            mu_t,
            gamma_t,
            weights: cur,
        }
    }

    /// The amplification `R(z)` of one super-step on `y' = lambda y`,
    /// `z = lambda tau`.
    pub fn amplification(&self, z: f64) -> f64 {
        let (y0, f0) = (1.0, z);
        let mut prev = y0;
        let mut cur = y0 + self.mu_t[1] * f0;
        for j in 2..=self.s {
            let next = self.mu[j] * cur
                + self.nu[j] * prev
                + (1.0 - self.mu[j] - self.nu[j]) * y0
                + self.mu_t[j] * z * cur
                + self.gamma_t[j] * f0;
            prev = cur;
            cur = next;
        }
        cur
    }

    /// The `z^3` coefficient of `R(z)` (the exponential's is 1/6): the
    /// leading local error of a super-step is `|c3 - 1/6| tau^3` times the
    /// solution's third derivative.
    pub fn cubic_coefficient(&self) -> f64 {
        // The recurrence on polynomials in z, truncated after z^3.
        type P = [f64; 4];
        let shift = |p: &P| [0.0, p[0], p[1], p[2]];
        let comb = |terms: &[(f64, &P)]| {
            let mut r = [0.0; 4];
            for (c, p) in terms {
                for (rk, pk) in r.iter_mut().zip(p.iter()) {
                    *rk += c * pk;
                }
            }
            r
        };
        let y0: P = [1.0, 0.0, 0.0, 0.0];
        let f0 = shift(&y0);
        let mut prev = y0;
        let mut cur = comb(&[(1.0, &y0), (self.mu_t[1], &f0)]);
        for j in 2..=self.s {
            let fc = shift(&cur);
            let next = comb(&[
                (self.mu[j], &cur),
                (self.nu[j], &prev),
                (1.0 - self.mu[j] - self.nu[j], &y0),
                (self.mu_t[j], &fc),
                (self.gamma_t[j], &f0),
            ]);
            prev = cur;
            cur = next;
        }
        cur[3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Sym2;
    use crate::mesh::shapes::jittered_plate;
    use crate::mesh::shapes::Lcg;

    /// A random in-plane tension in every face.
    fn random_tension(mesh: &SimMesh, els: &Elements, rng: &mut Lcg) -> Vec<Sym3> {
        mesh.faces()
            .map(|f| {
                let el = els.get(f).unwrap();
                let s = Sym2 {
                    xx: 1.0 + rng.next_f64(),
                    yy: 1.0 + rng.next_f64(),
                    xy: 0.5 * rng.next_f64(),
                };
                Sym3::from_frame(&s, el.e1, el.e2)
            })
            .collect()
    }

    /// The fused displacement, forces and energy pass equals the separate
    /// calls bit for bit, and the energy does not depend on the thread
    /// count.
    #[test]
    fn fused_pass_gives_the_energy_and_forces_of_the_displaced_stress() {
        // Enough faces for several chunks of the sum.
        let mesh = jittered_plate(70, 0.3, 8);
        assert!(mesh.n_faces() > 2 * ENERGY_CHUNK);
        let els = Elements::new(&mesh, f64::INFINITY);
        let fans = Fans::new(&mesh);
        let mut rng = Lcg(5);
        let stress = random_tension(&mesh, &els, &mut rng);
        let g: Vec<[f64; 3]> = (0..mesh.n_vertices())
            .map(|_| [rng.next_f64() - 0.5, rng.next_f64() - 0.5, 0.0])
            .collect();
        let mut a = stress.clone();
        apply_virtual_displacement(&fans, &els, &mut a, &g, 1.0, |_, _| Sym3::ZERO);
        let mut b = stress.clone();
        let mut corner = Vec::new();
        let e = apply_virtual_displacement_energy(&fans, &els, &mut b, &mut corner, &g);
        assert_eq!(a, b);
        let mut want = Vec::new();
        crate::sim::forces::corner_forces(&els, &a, &mut want);
        assert_eq!(corner, want);
        assert_eq!(e.to_bits(), energy(&els, &a).to_bits());
        assert!(e != energy(&els, &stress));
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| energy(&els, &a));
        assert_eq!(one.to_bits(), e.to_bits());
        let sequential: f64 = els
            .elements
            .iter()
            .zip(&a)
            .filter_map(|(el, s)| el.as_ref().map(|el| 0.5 * el.area * s.frobenius_sq()))
            .sum();
        assert!((sequential - e).abs() < 1e-12 * e, "{sequential} vs {e}");
    }

    #[test]
    fn stable_relaxation_never_increases_energy() {
        let mesh = jittered_plate(12, 0.35, 5);
        let els = Elements::new(&mesh, Elements::clamp_threshold(&mesh, 4.0));
        let mut rng = Lcg(9);
        let mut stress = random_tension(&mesh, &els, &mut rng);
        let dt = stable_dt(&mesh, &els);
        assert!(dt.is_finite() && dt > 0.0);
        let fixed = vec![false; mesh.n_vertices()];
        let e0 = energy(&els, &stress);
        let mut last = e0;
        for _ in 0..300 {
            let r = relax_step(&mesh, &els, &mut stress, &fixed, dt);
            assert!(r.energy_after <= r.energy_before * (1.0 + 1e-12), "{r:?}");
            assert!((r.energy_before - last).abs() <= 1e-12 * last);
            last = r.energy_after;
        }
        assert!(
            last < 0.5 * e0,
            "relaxation should release energy: {e0} -> {last}"
        );
        assert!(stress.iter().all(Sym3::is_finite));
    }

    #[test]
    fn per_node_steps_are_stable_next_to_slivers() {
        // Squash a few interior nodes almost onto a neighbour: tiny, stiff
        // triangles. Steps of 1.9 / b_n per node (most nodes at the median's
        // step) must still never increase the energy.
        let mut input = crate::mesh::shapes::grid_input(12, 12);
        let mut rng = Lcg(21);
        for (i, p) in input.positions.iter_mut().enumerate() {
            let interior = p[0] > 0.0 && p[0] < 12.0 && p[1] > 0.0 && p[1] < 12.0;
            if interior {
                if i % 17 == 0 {
                    p[0] += 0.93;
                    p[1] += 0.02;
                } else {
                    p[0] += 0.3 * (2.0 * rng.next_f64() - 1.0);
                    p[1] += 0.3 * (2.0 * rng.next_f64() - 1.0);
                }
            }
        }
        let (mesh, _) = SimMesh::build(&input, &Default::default()).unwrap();
        let els = Elements::new(&mesh, f64::INFINITY);
        let fans = Fans::new(&mesh);
        let bounds = node_bounds(&fans, &els);
        let mut sorted = bounds.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        let max = sorted[sorted.len() - 1];
        assert!(
            max > 3.0 * median,
            "the slivers are stiff: {max} vs {median}"
        );
        let dt = 1.9 / median;
        let mobility: Vec<f64> = bounds.iter().map(|&b| (median / b).min(1.0)).collect();
        let mut stress = random_tension(&mesh, &els, &mut rng);
        let e0 = energy(&els, &stress);
        let mut last = e0;
        for _ in 0..400 {
            let g: Vec<[f64; 3]> = node_forces_fans(&fans, &els, &stress)
                .iter()
                .zip(&mobility)
                .map(|(g, m)| v3::scale(*g, *m))
                .collect();
            apply_virtual_displacement(&fans, &els, &mut stress, &g, dt, |_, _| Sym3::ZERO);
            let e = energy(&els, &stress);
            assert!(e <= last * (1.0 + 1e-12), "energy rose: {last} -> {e}");
            last = e;
        }
        assert!(
            last < 0.5 * e0,
            "relaxation released energy: {e0} -> {last}"
        );
    }

    #[test]
    fn equilibrium_with_fixed_boundary_is_kept() {
        // Uniform in-plane tension is in equilibrium inside a flat plate: with the
        // boundary fixed, relaxation leaves it unchanged.
        let mesh = jittered_plate(8, 0.3, 2);
        let els = Elements::new(&mesh, f64::INFINITY);
        let mut stress: Vec<Sym3> = mesh
            .faces()
            .map(|f| Sym3::tangent_identity(els.get(f).unwrap().normal, 1.0))
            .collect();
        let before = stress.clone();
        let fixed: Vec<bool> = mesh
            .vertices()
            .map(|v| mesh.is_boundary_vertex(v))
            .collect();
        let dt = stable_dt(&mesh, &els);
        for _ in 0..50 {
            relax_step(&mesh, &els, &mut stress, &fixed, dt);
        }
        for (a, b) in stress.iter().zip(&before) {
            assert!((*a - *b).frobenius_sq() < 1e-20);
        }
    }

    #[test]
    fn free_plate_relaxes_towards_zero_stress() {
        let mesh = jittered_plate(6, 0.2, 4);
        let els = Elements::new(&mesh, f64::INFINITY);
        let mut stress: Vec<Sym3> = mesh
            .faces()
            .map(|f| Sym3::tangent_identity(els.get(f).unwrap().normal, 1.0))
            .collect();
        let fixed = vec![false; mesh.n_vertices()];
        let dt = stable_dt(&mesh, &els);
        let e0 = energy(&els, &stress);
        for _ in 0..3000 {
            relax_step(&mesh, &els, &mut stress, &fixed, dt);
        }
        let e1 = energy(&els, &stress);
        assert!(
            e1 < 1e-3 * e0,
            "a free plate sheds its stress: {e0} -> {e1}"
        );
    }

    #[test]
    fn rkl2_is_second_order_and_stable_over_its_reach() {
        for s in [2usize, 3, 5, 9, 17, 32] {
            let m = Rkl2::new(s);
            // Stable: |R(z)| <= 1 on [-2 reach, 0] (forward Euler: [-2, 0]).
            let reach = 2.0 * Rkl2::reach(s);
            for k in 0..=4000 {
                let z = -reach * k as f64 / 4000.0;
                let r = m.amplification(z);
                assert!(r.abs() <= 1.0 + 1e-9, "s {s} z {z}: R = {r}");
            }
            // Second order: R(z) = e^z + O(z^3), the local error falling
            // 8-fold when the step halves.
            let err = |z: f64| (m.amplification(z) - f64::exp(z)).abs();
            let ratio = err(-2e-2) / err(-1e-2);
            assert!((ratio - 8.0).abs() < 0.2, "s {s}: error ratio {ratio}");
            assert!(err(-1e-2) < 0.2e-6, "s {s}: {:e}", err(-1e-2));
            // The cubic coefficient matches the amplification.
            let z = -1e-3;
            let quad = 1.0 + z + z * z / 2.0;
            let c3 = (m.amplification(z) - quad) / z.powi(3);
            let c3_poly = m.cubic_coefficient();
            assert!((c3 - c3_poly).abs() < 1e-4, "{c3} vs {c3_poly}");
        }
        // A constant rate is integrated exactly: the weights sum to 1.
        for s in [2usize, 7, 30] {
            let w: f64 = Rkl2::new(s).weights.iter().sum();
            assert!((w - 1.0).abs() < 1e-12, "s {s}: {w}");
        }
        assert_eq!(Rkl2::stages_for(1.0), 2);
        assert_eq!(Rkl2::stages_for(75.0), 17);
        assert!(Rkl2::reach(Rkl2::stages_for(75.0)) >= 75.0);
        assert!(Rkl2::reach(Rkl2::stages_for(75.0) - 1) < 75.0);
    }
}
