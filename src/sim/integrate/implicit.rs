//! Backward Euler and equilibrium: conjugate-gradient solves of `(I + dt K) du = dt f`.

use crate::math::GrowGently;
use crate::math::{v3, Sym3};
use crate::sim::forces::{gather, Fans};
use crate::sim::implicit::{History, Operator};
use crate::sim::integrate::region::Region;
use crate::sim::integrate::scheme::{Round, RoundEnd, Scheme, EQUILIBRIUM_DT};
use crate::sim::load::add_load;
use crate::sim::load::load_increment;
use crate::sim::load::Load;
use crate::sim::state::RoundCache;
use crate::sim::state::State;
use crate::sim::state::HISTORY;
use crate::sim::Integrator;
use crate::sim::Phase;
use crate::sim::SimReport;
use rayon::prelude::*;
use std::borrow::Cow;

/// Backward Euler and equilibrium: conjugate-gradient solves of `(I + dt K) du = dt f`.
pub(in crate::sim) struct Implicit;

impl Scheme for Implicit {
    fn relax(
        &self,
        r: &Round,
        st: &mut State,
        cache: &mut RoundCache,
        known_force: &mut Option<Vec<[f64; 3]>>,
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
            loading,
        } = *r;
        let mut out = RoundEnd::default();
        let (steps, dt, solve_dt) = step_plan(r);
        let fixed = held(&st.fixed, region);
        let op = crate::sim::implicit::Operator {
            fans,
            els: &st.els,
            normals,
            fixed: &fixed,
            interface: &[],
        };
        // The preconditioner, kept for the whole mesh's system.
        let pre = preconditioner(&op, solve_dt, region.is_some(), &mut cache.pre);
        let shifted = crate::sim::implicit::Shifted {
            op: &op,
            dt: solve_dt,
            pre: &pre,
            tol: params.tolerance,
            max_iter: 10_000,
        };
        // A global backward-Euler round carries the force from step to step
        // and round to round (each stress update writes the corner forces
        // at the new stress; one gather gives the force), builds each
        // right-hand side from it and the force of a unit of load, and
        // starts each solve from the best combination of the last
        // solutions, whose products `A x = x + rhs - dt f_new` are exact:
        // no product beyond the solver's own.
        let carry = region.is_none() && params.integrator == Integrator::BackwardEuler;
        let mut bufs = std::mem::take(&mut st.implicit);
        let mut stress = st.stress.take();
        // The force at the current stress, and the force of a unit of
        // load time.
        let wants_load = carry && loading && params.load_time > *loaded;
        let mut force = None;
        if carry {
            force = Some(
                known_force
                    .take()
                    .unwrap_or_else(|| op.forces(&stress, &mut bufs.cg.corner)),
            );
            if wants_load && cache.load_force.is_none() {
                let unit = Load {
                    dt: 1.0,
                    shrink_rate: params.shrink_rate,
                };
                let (scale, evolve) = (&st.shrink_scale, &st.evolve);
                cache.load_force = Some(op.forces_with(
                    |f, el| load_increment(scale, evolve, f, el, unit),
                    &mut bufs.cg.corner,
                ));
            }
        }
        let load_force: Option<&[[f64; 3]]> = if wants_load {
            cache.load_force.as_deref()
        } else {
            None
        };
        if carry && cache.history.as_ref().is_none_or(|(d, _)| *d != solve_dt) {
            cache.history = Some((solve_dt, Vec::new()));
        }
        // Start each solve from the last one's solution (new nodes at 0).
        let mut x = std::mem::take(&mut st.warm);
        for _ in 0..steps {
            let load = r.load_for(loaded, dt);
            add_load(&mut stress, &st.els, &st.shrink_scale, &st.evolve, load);
            right_hand_side(
                &mut bufs.rhs,
                force.as_deref(),
                load_force,
                load.dt,
                solve_dt,
                &op,
                &stress,
                &mut bufs.cg.corner,
            );
            let rhs = &bufs.rhs;
            let history = cache.history.as_mut().filter(|_| carry).map(|h| &mut h.1);
            let started = history.as_deref().is_some_and(|h| {
                crate::sim::implicit::subspace_start(h, rhs, &mut x, &mut bufs.ax)
            });
            let ax = started.then_some(&bufs.ax[..]);
            let cg = shifted.solve(rhs, &mut x, ax, &mut bufs.r, &mut bufs.cg);
            phase.cg_iterations += cg.iterations;
            if !cg.converged {
                report.cg_unconverged += 1;
            }
            phase.cg_residual = phase.cg_residual.max(cg.relative_residual);
            // The stress update also writes the corner forces at the new
            // stress into `st.corner` and gives the energy.
            out.end_energy = Some(crate::sim::relax::apply_virtual_displacement_energy(
                fans,
                &st.els,
                &mut stress,
                &mut st.corner,
                &x,
            ));
            advance(
                &mut st.displacement,
                &st.corner,
                st.unit,
                Step {
                    x: &x,
                    rhs,
                    solve_dt,
                },
                history,
                force.as_mut(),
                &op,
                fans,
            );
        }
        st.stress.replace(stress);
        st.warm = x;
        st.implicit = bufs;
        // `st.corner` holds the corner forces at the final stress (the last
        // stress update wrote them).
        if carry {
            out.end_force = force;
        }
        out.step_dt = if params.integrator == Integrator::Equilibrium {
            0.0
        } else {
            dt
        };
        report.time += steps as f64 * dt;
        report.relax_steps += steps;
        phase.steps = steps;
        out
    }
}

/// The right-hand side `dt f` of one step into `rhs`: the carried force
/// plus the force of the step's load (`load_dt` times a unit of load's),
/// or the force at `stress` gathered afresh when none is carried.
#[allow(clippy::too_many_arguments)]
fn right_hand_side(
    rhs: &mut Vec<[f64; 3]>,
    force: Option<&[[f64; 3]]>,
    load_force: Option<&[[f64; 3]]>,
    load_dt: f64,
    solve_dt: f64,
    op: &Operator,
    stress: &[Sym3],
    corner: &mut Vec<[f64; 3]>,
) {
    match (force, load_force) {
        (Some(f), Some(lf)) if load_dt > 0.0 => {
            rhs.resize_gently(f.len(), [0.0; 3]);
            rhs.par_iter_mut()
                .zip(f.par_iter().zip(lf.par_iter()))
                .for_each(|(b, (f, l))| {
                    *b = v3::scale(v3::add(*f, v3::scale(*l, load_dt)), solve_dt)
                });
        }
        (Some(f), _) => {
            rhs.resize_gently(f.len(), [0.0; 3]);
            rhs.par_iter_mut()
                .zip(f.par_iter())
                .for_each(|(b, f)| *b = v3::scale(*f, solve_dt));
        }
        (None, _) => {
            *rhs = op.forces(stress, corner);
            rhs.par_iter_mut()
                .for_each(|b| *b = v3::scale(*b, solve_dt));
        }
    }
}

/// One solved step: the solution, its right-hand side and the step.
struct Step<'a> {
    x: &'a [[f64; 3]],
    rhs: &'a [[f64; 3]],
    solve_dt: f64,
}

/// After a solve for `x`: move the displacement by `x`; with a carried
/// force and history, in the same pass over the nodes, the force at the
/// new stress (gathered afresh, never carried over from the solver's
/// residual, which drifts) and `(x, A x)` for the history, with
/// `A x = x + dt K x = x + rhs - dt f_new` exact (the oldest entry's
/// storage reused when the history is full).
#[allow(clippy::too_many_arguments)]
fn advance(
    displacement: &mut [[f64; 3]],
    corner: &[[f64; 3]],
    unit: f64,
    step: Step,
    history: Option<&mut History>,
    force: Option<&mut Vec<[f64; 3]>>,
    op: &Operator,
    fans: &Fans,
) {
    let Step { x, rhs, solve_dt } = step;
    match (history, force) {
        (Some(history), Some(f)) => {
            let (mut hx, mut hax) = if history.len() == HISTORY {
                history.remove(0)
            } else {
                (Vec::new(), Vec::new())
            };
            hx.resize_gently(x.len(), [0.0; 3]);
            hax.resize_gently(x.len(), [0.0; 3]);
            displacement
                .par_iter_mut()
                .zip(f.par_iter_mut())
                .zip(hx.par_iter_mut().zip(hax.par_iter_mut()))
                .zip(x.par_iter().zip(rhs.par_iter()))
                .enumerate()
                .with_min_len(512)
                .for_each(|(n, (((d, f), (hx, hax)), (x, b)))| {
                    *d = v3::add(*d, v3::scale(*x, unit));
                    *f = op.project(n, gather(fans, corner, n));
                    *hx = *x;
                    *hax = v3::add(*x, v3::sub(*b, v3::scale(*f, solve_dt)));
                });
            history.push((hx, hax));
        }
        _ => displacement
            .par_iter_mut()
            .zip(x.par_iter())
            .for_each(|(d, x)| *d = v3::add(*d, v3::scale(*x, unit))),
    }
}

/// The steps of a round, their length and the step each solve uses.
/// Equilibrium: one solve per round with a step so long that
/// `(I + dt K) du = dt f` is `K du = f` to working precision; the round's
/// load goes in at once.
fn step_plan(r: &Round) -> (usize, f64, f64) {
    let params = r.params;
    let dt_req = if params.relax_dt > 0.0 {
        params.relax_dt
    } else {
        params.relax_time
    };
    if params.integrator == Integrator::Equilibrium {
        (1, params.relax_time, EQUILIBRIUM_DT)
    } else {
        let (n, dt) = r.steps_for(dt_req);
        (n, dt, dt)
    }
}

/// The nodes held in a solve: the fixed ones and, in a local round, every
/// node outside the region.
fn held<'a>(fixed: &'a [bool], region: Option<&Region>) -> Cow<'a, [bool]> {
    match region {
        Some(r) => Cow::Owned(
            fixed
                .iter()
                .zip(&r.inside)
                .map(|(&f, &i)| f || !i)
                .collect(),
        ),
        None => Cow::Borrowed(fixed),
    }
}

/// The block preconditioner of `op` for step `solve_dt`: the whole mesh's
/// is kept in `kept` from round to round; a local round's is its own.
fn preconditioner<'a>(
    op: &Operator,
    solve_dt: f64,
    local: bool,
    kept: &'a mut Option<(f64, Vec<Sym3>)>,
) -> Cow<'a, [Sym3]> {
    if local {
        return Cow::Owned(op.block_preconditioner(solve_dt));
    }
    if kept.as_ref().is_none_or(|(d, _)| *d != solve_dt) {
        *kept = Some((solve_dt, op.block_preconditioner(solve_dt)));
    }
    Cow::Borrowed(&kept.as_ref().expect("set").1)
}
