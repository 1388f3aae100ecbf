//! Runge-Kutta-Legendre super-steps (RKL2): the stage plan and one
//! super-step.

use crate::math::GrowGently;
use crate::geometry::element::Element;
use crate::math::{v3, Sym3};
use crate::sim::forces::{corner_forces, Fans};
use crate::sim::forces::{element_corner_forces, element_strain};
use crate::sim::integrate::region::node_velocity;
use crate::sim::integrate::region::region_corner_forces;
use crate::sim::integrate::region::Region;
use crate::sim::integrate::scheme::{Round, RoundEnd, Scheme};
use crate::sim::load::load_increment;
use crate::sim::load::Load;
use crate::sim::params::RKL_MAX_STAGES;
use crate::sim::relax::node_bounds;
use crate::sim::state::RoundCache;
use crate::sim::state::State;
use crate::sim::Phase;
use crate::sim::SimReport;
use rayon::prelude::*;

/// Rounds between two step-doubling error estimates of the RKL integrator
/// (each costs about 1.4 rounds).
pub(in crate::sim) const RKL_ESTIMATE_EVERY: usize = 16;

/// Stages of an RKL super-step of length `tau` and every node's mobility:
/// the fewest stages whose reach covers `tau` in forward-Euler steps
/// `dt_fe` of the stiffest node, or at most [`RKL_MAX_STAGES`], stretching
/// a longer step and slowing the nodes too stiff for it.
pub(in crate::sim) fn rkl_plan(bounds: &[f64], dt_fe: f64, tau: f64) -> (usize, Vec<f64>) {
    let mut stages = crate::sim::relax::Rkl2::stages_for(tau / dt_fe);
    let mut dt_e = dt_fe;
    if stages > RKL_MAX_STAGES {
        stages = RKL_MAX_STAGES;
        dt_e = tau / crate::sim::relax::Rkl2::reach(stages);
    }
    let mobility = bounds
        .iter()
        .map(|&b| {
            if b * dt_e > 1.9 {
                1.9 / (b * dt_e)
            } else {
                1.0
            }
        })
        .collect();
    (stages, mobility)
}

/// Buffers of an RKL super-step: the start stress and its rate, the stress
/// two stages back, and node velocities.
#[derive(Default)]
pub(in crate::sim) struct RklScratch {
    pub(in crate::sim) s0: Vec<Sym3>,
    pub(in crate::sim) s_back: Vec<Sym3>,
    pub(in crate::sim) r0: Vec<Sym3>,
    pub(in crate::sim) g0: Vec<[f64; 3]>,
    pub(in crate::sim) g: Vec<[f64; 3]>,
}

/// One RKL2 super-step of length `tau` (see [`crate::sim::relax::Rkl2`]) on
/// the stress: its rate is the stress of the virtual displacement at node
/// velocity `M g` plus the load's `rate`. The displacement's rate `M g`
/// does not feed back, so it gets the super-step's weights of the stages'
/// velocities. With a `region`, nodes and faces outside it are left alone
/// (as in [`relax_region`]). `st.corner` must hold the corner forces of the
/// current stress; it holds the new ones after.
#[allow(clippy::too_many_arguments)]
pub(in crate::sim) fn rkl_super_step(
    fans: &Fans,
    normals: &[[f64; 3]],
    mobility: &[f64],
    st: &mut State,
    tau: f64,
    c: &crate::sim::relax::Rkl2,
    rate: Load,
    region: Option<&Region>,
    k: &mut RklScratch,
) {
    let n_nodes = fans.n_vertices();
    let n_faces = st.stress.len();
    let node_in = |v: usize| region.is_none_or(|r| r.inside[v]);
    let face_in = |f: usize| region.is_none_or(|r| r.face_in[f]);
    // Node velocities `M P g` from the corner forces in `st.corner`, and
    // the displacement's share `w tau M P g` of them.
    let (fixed, unit) = (&st.fixed, st.unit);
    let velocities =
        |corner: &[[f64; 3]], disp: &mut [[f64; 3]], out: &mut Vec<[f64; 3]>, w: f64| {
            out.resize_gently(n_nodes, [0.0; 3]);
            out.par_iter_mut()
                .zip(disp.par_iter_mut())
                .enumerate()
                .with_min_len(512)
                .for_each(|(v, (o, d))| {
                    *o = [0.0; 3];
                    if fixed[v] || !node_in(v) {
                        return;
                    }
                    *o = node_velocity(fans, corner, normals, mobility, v);
                    *d = v3::add(*d, v3::scale(*o, w * tau * unit));
                });
        };
    let (scale, evolve) = (&st.shrink_scale, &st.evolve);
    let load = |f: usize, el: &Element| load_increment(scale, evolve, f, el, rate);
    // Stage 1: Y1 = Y0 + mu_t1 tau F(Y0).
    let mut g0 = std::mem::take(&mut k.g0);
    velocities(&st.corner, &mut st.displacement, &mut g0, c.weights[0]);
    k.s0.resize_gently(n_faces, Sym3::ZERO);
    k.s_back.resize_gently(n_faces, Sym3::ZERO);
    k.r0.resize_gently(n_faces, Sym3::ZERO);
    let h1 = c.mu_t[1] * tau;
    {
        let els = &st.els;
        let g0 = &g0;
        st.stress
            .par_iter_mut()
            .zip(st.corner.par_chunks_mut(3))
            .zip(k.r0.par_iter_mut().zip(k.s0.par_iter_mut()))
            .enumerate()
            .with_min_len(512)
            .for_each(|(f, ((s, cf), (r0, s0)))| {
                if !face_in(f) {
                    return;
                }
                let Some(Some(el)) = els.elements.get(f) else {
                    cf.fill([0.0; 3]);
                    return;
                };
                *s0 = *s;
                *r0 = element_strain(el, fans.corners(f), g0, 1.0, load(f, el));
                *s += *r0 * h1;
                element_corner_forces(el, s, cf);
            });
    }
    k.g0 = g0;
    // Stages 2..s. At stage 2 the state two back is Y0 itself.
    let mut g = std::mem::take(&mut k.g);
    for j in 2..=c.s {
        let (mu, nu) = (c.mu[j], c.nu[j]);
        let rest = 1.0 - mu - nu;
        let (a, b) = (c.mu_t[j] * tau, c.gamma_t[j] * tau);
        velocities(&st.corner, &mut st.displacement, &mut g, c.weights[j - 1]);
        let (s0, r0, gg) = (&k.s0, &k.r0, &g);
        let els = &st.els;
        st.stress
            .par_iter_mut()
            .zip(st.corner.par_chunks_mut(3))
            .zip(k.s_back.par_iter_mut())
            .enumerate()
            .with_min_len(512)
            .for_each(|(f, ((s, cf), back))| {
                if !face_in(f) {
                    return;
                }
                let Some(Some(el)) = els.elements.get(f) else {
                    cf.fill([0.0; 3]);
                    return;
                };
                crate::sim::relax::prefetch_corners(
                    fans,
                    gg,
                    f + crate::sim::relax::PREFETCH_AHEAD,
                );
                let r = element_strain(el, fans.corners(f), gg, 1.0, load(f, el));
                let two_back = if j == 2 { s0[f] } else { *back };
                let x = *s * mu + two_back * nu + s0[f] * rest + r * a + r0[f] * b;
                *back = *s;
                *s = x;
                element_corner_forces(el, s, cf);
            });
    }
    k.g = g;
}

/// Runge-Kutta-Legendre super-steps with a step-doubling error estimate.
pub(in crate::sim) struct Rkl;

impl Scheme for Rkl {
    fn relax(
        &self,
        r: &Round,
        st: &mut State,
        cache: &mut RoundCache,
        _known_force: &mut Option<Vec<[f64; 3]>>,
        loaded: &mut f64,
        _g: &mut Vec<[f64; 3]>,
        report: &mut SimReport,
        phase: &mut Phase,
    ) -> RoundEnd {
        let Round {
            mesh: _,
            params,
            fans,
            normals,
            region,
            ..
        } = *r;
        let mut out = RoundEnd::default();
        let bounds = cache
            .bounds
            .take()
            .unwrap_or_else(|| node_bounds(fans, &st.els));
        let stiffest = bounds.iter().copied().fold(0.0, f64::max);
        let dt_fe = if stiffest > 0.0 {
            1.9 / stiffest
        } else {
            f64::INFINITY
        };
        report.stable_dt = report.stable_dt.min(dt_fe);
        let supers = if params.relax_steps > 0 {
            params.relax_steps
        } else if params.relax_dt > 0.0 {
            ((params.relax_time / params.relax_dt).ceil() as usize).max(1)
        } else {
            1
        };
        let tau = params.relax_time / supers as f64;
        match region {
            Some(r) => region_corner_forces(&st.els, &st.stress, &mut st.corner, r),
            None => corner_forces(&st.els, &st.stress, &mut st.corner),
        }
        // Error estimate by step doubling on sampled rounds: the same
        // round again from the same start in super-steps of half the
        // length; for a second-order method the error of the result is
        // about 4/3 of the difference.
        let sampled = report.phases.len() % RKL_ESTIMATE_EVERY == 0;
        let start = sampled.then(|| {
            (
                st.stress.to_vec(),
                st.displacement.to_vec(),
                st.corner.clone(),
                *loaded,
            )
        });
        let mut scratch = RklScratch::default();
        let mut run = |st: &mut State, loaded: &mut f64, supers: usize, tau: f64| {
            let (stages, mobility) = rkl_plan(&bounds, dt_fe, tau);
            let coeffs = crate::sim::relax::Rkl2::new(stages);
            for _ in 0..supers {
                let load = r.load_for(loaded, tau);
                // The load as a constant rate over the super-step.
                let rate = Load {
                    dt: load.dt / tau,
                    shrink_rate: load.shrink_rate,
                };
                rkl_super_step(
                    fans,
                    normals,
                    &mobility,
                    st,
                    tau,
                    &coeffs,
                    rate,
                    region,
                    &mut scratch,
                );
            }
            stages
        };
        let stages = run(st, loaded, supers, tau);
        if let Some((stress, displacement, corner, mut half_loaded)) = start {
            let result = (
                st.stress.replace(stress),
                st.displacement.replace(displacement),
                std::mem::replace(&mut st.corner, corner),
            );
            run(st, &mut half_loaded, 2 * supers, tau / 2.0);
            let (mut diff, mut norm) = (0.0, 0.0);
            for ((el, a), b) in st.els.elements.iter().zip(&result.0).zip(&st.stress) {
                if let Some(el) = el {
                    diff += el.area * (*a - *b).frobenius_sq();
                    norm += el.area * a.frobenius_sq();
                }
            }
            out.rkl_estimate = Some(if norm > 0.0 {
                4.0 / 3.0 * (diff / norm).sqrt()
            } else {
                0.0
            });
            let (stress, displacement, corner) = result;
            st.stress.replace(stress);
            st.displacement.replace(displacement);
            st.corner = corner;
        }
        report.time += params.relax_time;
        report.relax_steps += supers * stages;
        phase.steps = supers * stages;
        out.step_dt = tau;
        cache.bounds = Some(bounds);
        out
    }
}
