//! Explicit steps (local-euler, euler, paper-euler): node velocities from
//! the forces and one fused update of displacement and stress.

use crate::math::GrowGently;
use crate::math::v3;
use crate::sim::forces::{corner_forces, Fans};
use crate::sim::integrate::region::node_velocity;
use crate::sim::integrate::region::region_corner_forces;
use crate::sim::integrate::region::relax_region;
use crate::sim::integrate::scheme::{Round, RoundEnd, Scheme};
use crate::sim::load::load_increment;
use crate::sim::load::Load;
use crate::sim::relax::apply_virtual_displacement_with_forces;
use crate::sim::relax::node_bounds;
use crate::sim::state::RoundCache;
use crate::sim::state::State;
use crate::sim::Integrator;
use crate::sim::Phase;
use crate::sim::SimReport;
use rayon::prelude::*;

/// One forward-Euler relaxation step plus the load: in each face,
/// `load.dt * shrink_scale[f] * (shrink_rate (I - n n^T) + evolve[f])`,
/// in two parallel passes (nodes, then faces). Node `n` moves
/// by `dt * mobility[n] * g_n`. With `normals`
/// (a bonded surface), the normal part of each node force is carried by the
/// body under the surface and removed. `g` is scratch space.
pub(in crate::sim) fn relax_and_evolve(
    fans: &Fans,
    normals: &[[f64; 3]],
    mobility: &[f64],
    st: &mut State,
    dt: f64,
    load: Load,
    g: &mut Vec<[f64; 3]>,
) {
    g.resize_gently(fans.n_vertices(), [0.0; 3]);
    // `st.corner` holds the forces at the current stress (set by the
    // caller before the first step, then by the fused update below).
    let (corner, fixed, unit) = (&st.corner, &st.fixed, st.unit);
    g.par_iter_mut()
        .zip(st.displacement.par_iter_mut())
        .enumerate()
        .with_min_len(512)
        .for_each(|(v, (gn, d))| {
            let f_net = if fixed[v] {
                [0.0; 3]
            } else {
                node_velocity(fans, corner, normals, mobility, v)
            };
            *gn = f_net;
            *d = v3::add(*d, v3::scale(f_net, dt * unit));
        });
    let (scale, evolve) = (&st.shrink_scale, &st.evolve);
    apply_virtual_displacement_with_forces(
        fans,
        &st.els,
        &mut st.stress,
        &mut st.corner,
        g,
        dt,
        |f, el| load_increment(scale, evolve, f, el, load),
    );
}

/// Explicit steps (local-euler, euler, paper-euler), globally or in a region.
pub(in crate::sim) struct Explicit;

impl Scheme for Explicit {
    fn relax(
        &self,
        r: &Round,
        st: &mut State,
        cache: &mut RoundCache,
        _known_force: &mut Option<Vec<[f64; 3]>>,
        loaded: &mut f64,
        g: &mut Vec<[f64; 3]>,
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
        let stable = |b: f64| if b > 0.0 { 1.9 / b } else { f64::INFINITY };
        let mut dt_max = match params.integrator {
            Integrator::LocalEuler => {
                // The median bound (selection gives the sorted order's value).
                let mut sorted: Vec<f64> = bounds.iter().copied().filter(|b| *b > 0.0).collect();
                let mid = sorted.len() / 2;
                if sorted.is_empty() {
                    f64::INFINITY
                } else {
                    stable(*sorted.select_nth_unstable_by(mid, f64::total_cmp).1)
                }
            }
            _ => stable(bounds.iter().copied().fold(0.0, f64::max)),
        };
        report.stable_dt = report.stable_dt.min(dt_max);
        if params.integrator == Integrator::PaperEuler {
            dt_max = params.relax_dt;
        } else if params.relax_dt > 0.0 {
            if params.relax_dt > dt_max {
                report.dt_limited_rounds += 1;
            }
            dt_max = dt_max.min(params.relax_dt);
        }
        if !dt_max.is_finite() {
            dt_max = params.relax_time; // no element: nothing to relax
        }
        let mobility: Vec<f64> = match params.integrator {
            Integrator::LocalEuler => bounds
                .iter()
                .map(|&b| {
                    if b * dt_max > 1.9 {
                        1.9 / (b * dt_max)
                    } else {
                        1.0
                    }
                })
                .collect(),
            _ => vec![1.0; bounds.len()],
        };
        let (steps, dt) = r.steps_for(dt_max);
        match region {
            // Outside the region the corner forces are still those of the
            // last round (stress there has not changed since; faces that
            // cracks split or added are in the region).
            Some(r) => region_corner_forces(&st.els, &st.stress, &mut st.corner, r),
            None => corner_forces(&st.els, &st.stress, &mut st.corner),
        }
        if let Some(r) = region {
            g.clear();
            g.resize_gently(fans.n_vertices(), [0.0; 3]);
            for _ in 0..steps {
                relax_region(fans, normals, &mobility, st, dt, r, g);
            }
        } else {
            for _ in 0..steps {
                let load = r.load_for(loaded, dt);
                relax_and_evolve(fans, normals, &mobility, st, dt, load, g);
            }
        }
        report.time += steps as f64 * dt;
        report.relax_steps += steps;
        phase.steps = steps;
        out.step_dt = dt;
        out.step_mobility = mobility;
        cache.bounds = Some(bounds);
        out
    }
}
