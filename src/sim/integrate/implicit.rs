//! Backward Euler and equilibrium: conjugate-gradient solves of `(I + dt K) du = dt f`.

use crate::math::{v3, Sym3};
use crate::sim::forces::gather;
use crate::sim::integrate::{Round, RoundEnd, Scheme, EQUILIBRIUM_DT};
use crate::sim::{load::*, params::*, report::*, state::*};
use rayon::prelude::*;

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
        let dt_req = if params.relax_dt > 0.0 {
            params.relax_dt
        } else {
            params.relax_time
        };
        // Equilibrium: one solve per round with a step so long that
        // `(I + dt K) du = dt f` is `K du = f` to working precision; the
        // round's load goes in at once.
        let (steps, dt, solve_dt) = if params.integrator == Integrator::Equilibrium {
            (1, params.relax_time, EQUILIBRIUM_DT)
        } else {
            let (n, dt) = r.steps_for(dt_req);
            (n, dt, dt)
        };
        // Outside a local region every node is held.
        let held: Vec<bool>;
        let fixed: &[bool] = match region {
            Some(r) => {
                held = st
                    .fixed
                    .iter()
                    .zip(&r.inside)
                    .map(|(&f, &i)| f || !i)
                    .collect();
                &held
            }
            None => &st.fixed,
        };
        let op = crate::sim::implicit::Operator {
            fans,
            els: &st.els,
            normals,
            fixed,
            interface: &[],
        };
        // The preconditioner, kept for the whole mesh's system.
        let local_pre: Vec<Sym3>;
        let pre: &[Sym3] = if region.is_some() {
            local_pre = op.block_preconditioner(solve_dt);
            &local_pre
        } else {
            if cache.pre.as_ref().is_none_or(|(d, _)| *d != solve_dt) {
                cache.pre = Some((solve_dt, op.block_preconditioner(solve_dt)));
            }
            &cache.pre.as_ref().expect("set").1
        };
        let shifted = crate::sim::implicit::Shifted {
            op: &op,
            dt: solve_dt,
            pre,
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
        let mut stress = std::mem::take(&mut st.stress);
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
            let rhs = &mut bufs.rhs;
            match (&force, load_force) {
                (Some(f), Some(lf)) if load.dt > 0.0 => {
                    rhs.resize(f.len(), [0.0; 3]);
                    rhs.par_iter_mut()
                        .zip(f.par_iter().zip(lf.par_iter()))
                        .for_each(|(b, (f, l))| {
                            *b = v3::scale(v3::add(*f, v3::scale(*l, load.dt)), solve_dt)
                        });
                }
                (Some(f), _) => {
                    rhs.resize(f.len(), [0.0; 3]);
                    rhs.par_iter_mut()
                        .zip(f.par_iter())
                        .for_each(|(b, f)| *b = v3::scale(*f, solve_dt));
                }
                (None, _) => {
                    *rhs = op.forces(&stress, &mut bufs.cg.corner);
                    rhs.par_iter_mut()
                        .for_each(|b| *b = v3::scale(*b, solve_dt));
                }
            }
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
            let unit = st.unit;
            match (history, &mut force) {
                (Some(history), Some(f)) => {
                    // One pass over the nodes: the displacement, the force
                    // at the new stress (gathered afresh, never carried
                    // over from the solver's residual, which drifts), and
                    // `(x, A x)` for the history, with `A x = x + dt K x =
                    // x + rhs - dt f_new` exact (the oldest entry's storage
                    // reused when the history is full).
                    let (mut hx, mut hax) = if history.len() == HISTORY {
                        history.remove(0)
                    } else {
                        (Vec::new(), Vec::new())
                    };
                    hx.resize(x.len(), [0.0; 3]);
                    hax.resize(x.len(), [0.0; 3]);
                    let corner = &st.corner;
                    st.displacement
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
                _ => st
                    .displacement
                    .par_iter_mut()
                    .zip(x.par_iter())
                    .for_each(|(d, x)| *d = v3::add(*d, v3::scale(*x, unit))),
            }
        }
        st.stress = stress;
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
