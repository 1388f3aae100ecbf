//! One relaxation round, by the integrator the parameters name (or the
//! automatic choice): the round's common start and end (cache, region,
//! phase, error estimate, divergence check) around one [`Scheme`] per
//! integrator family.

pub(in crate::sim) mod explicit;
pub(in crate::sim) mod film;
pub(in crate::sim) mod frozen;
pub(in crate::sim) mod implicit;
pub(in crate::sim) mod region;
pub(in crate::sim) mod rkl;

use crate::math::v3;
use crate::mesh::{SimMesh, VertexId};
use crate::sim::forces::{gather, Fans};
use crate::sim::integrate::region::*;
use crate::sim::relax::{energy, node_bounds};
use crate::sim::{error::*, load::*, params::*, report::*, state::*};
use rayon::prelude::*;
use std::sync::Arc;

/// The integrator `auto` stands for on this state, and why.
pub(in crate::sim) fn resolve_integrator(
    mesh: &SimMesh,
    st: &State,
    params: &SimParams,
) -> (Integrator, String) {
    if params.integrator != Integrator::Auto {
        return (params.integrator, "asked for".into());
    }
    let bounds = node_bounds(&Fans::new(mesh), &st.els);
    let mut positive: Vec<f64> = bounds.into_iter().filter(|b| *b > 0.0).collect();
    if positive.is_empty() {
        return (Integrator::LocalEuler, "nothing to relax".into());
    }
    let mid = positive.len() / 2;
    let median = *positive.select_nth_unstable_by(mid, f64::total_cmp).1;
    let steps = params.relax_time * median / 1.9;
    if steps > AUTO_STEP_LIMIT {
        (
            Integrator::BackwardEuler,
            format!(
                "auto: the mesh is stiff (a local-euler round would take {steps:.0} steps, above {AUTO_STEP_LIMIT:.0})"
            ),
        )
    } else {
        (
            Integrator::LocalEuler,
            format!("auto: {steps:.0} local-euler steps a round"),
        )
    }
}

/// The step of an equilibrium solve: long enough that `I` is negligible
/// beside `dt K` (stiffness is of order 1 in normalised units).
pub(in crate::sim) const EQUILIBRIUM_DT: f64 = 1e12;

/// Rounds between two error estimates of the time integration.
pub(in crate::sim) const ESTIMATE_EVERY: usize = 8;

/// One relaxation round of `params.relax_time` (or `relax_steps` steps),
/// with the load acting while `loading` (and `loaded` below the load time),
/// by `params.integrator`. Records the round's [`Phase`].
#[allow(clippy::too_many_arguments)]
pub(in crate::sim) fn relax_round(
    mesh: &SimMesh,
    st: &mut State,
    params: &SimParams,
    g: &mut Vec<[f64; 3]>,
    loading: bool,
    loaded: &mut f64,
    report: &mut SimReport,
    seeds: Option<&[VertexId]>,
) -> Result<Arc<Fans>, SimError> {
    let mut cache = std::mem::take(&mut st.cache);
    cache.refresh(mesh, &st.els, params.bonded);
    let fans = cache.fans();
    // Local relaxation (no load): only the region around `seeds` moves.
    let region = match seeds {
        Some(seeds) if !loading && params.finish_rings > 0 => {
            Some(Region::around(&fans, seeds, params.finish_rings))
        }
        _ => None,
    };
    // The force at the current stress is known only after a global
    // backward-Euler round, for the next one.
    let mut known_force = cache.force.take();
    let normals = std::mem::take(&mut cache.normals);
    // Only the paper's scheme is checked for divergence against it.
    let energy_before = if params.integrator == Integrator::PaperEuler {
        energy(&st.els, &st.stress)
    } else {
        0.0
    };
    let mut phase = Phase::default();

    let round = Round {
        mesh,
        params,
        fans: &fans,
        normals: &normals,
        region: region.as_ref(),
        loading,
    };
    let scheme: &dyn Scheme = if st.film.is_some() {
        &film::Film
    } else if params.relaxation == Relaxation::EigenDiffusion {
        &frozen::Frozen
    } else if matches!(
        params.integrator,
        Integrator::BackwardEuler | Integrator::Equilibrium
    ) {
        &implicit::Implicit
    } else if params.integrator == Integrator::Rkl {
        &rkl::Rkl
    } else {
        &explicit::Explicit
    };
    let RoundEnd {
        end_force,
        end_energy,
        step_dt,
        step_mobility,
        rkl_estimate,
    } = scheme.relax(
        &round,
        st,
        &mut cache,
        &mut known_force,
        loaded,
        g,
        report,
        &mut phase,
    );
    // The round's phase: energy and residual force at its end (`st.corner`
    // holds the corner forces at the final stress: the explicit steps'
    // fused update leaves them there, the implicit branch computes them;
    // a global backward-Euler round has the force from its solves).
    let op = crate::sim::implicit::Operator {
        fans: &fans,
        els: &st.els,
        normals: &normals,
        fixed: &st.fixed,
        interface: &[],
    };
    let carried = end_force.is_some();
    let force: Vec<[f64; 3]> = end_force.unwrap_or_else(|| {
        let corner = &st.corner;
        (0..fans.n_vertices())
            .into_par_iter()
            .map(|n| op.project(n, gather(&fans, corner, n)))
            .collect()
    });
    phase.residual = crate::sim::implicit::dot(&force, &force).sqrt();
    phase.energy = end_energy.unwrap_or_else(|| energy(&st.els, &st.stress));
    // Error estimate of the round (relative, like the study's error): a
    // first-order step of `dt` errs by `dt^2 / 2 |u''|` with `u'' = M K M f`
    // (M the mobility), which moves the stress by `B u''`; the round's
    // steps add up. Its stress norm is `sqrt(u''^T K u'')` against
    // `|S| = sqrt(2 E)`. Equilibrium rounds report their solve's residual.
    // It costs two stiffness products, so it is sampled: the first round
    // and every `ESTIMATE_EVERY`-th after it (NaN, `null` in JSON, between).
    let sampled = report.phases.len() % ESTIMATE_EVERY == 0;
    phase.error_estimate = if params.integrator == Integrator::Rkl {
        rkl_estimate.unwrap_or(f64::NAN)
    } else if !sampled {
        f64::NAN
    } else if step_dt > 0.0 && phase.energy > 0.0 {
        let mob = |n: usize| step_mobility.get(n).copied().unwrap_or(1.0);
        // The implicit rounds' working memory (kept only by them).
        let mut bufs = std::mem::take(&mut st.implicit);
        let ImplicitScratch {
            cg, rhs: mf, r: w, ..
        } = &mut bufs;
        let n = force.len();
        mf.clear();
        mf.extend(force.iter().enumerate().map(|(n, f)| v3::scale(*f, mob(n))));
        w.resize(n, [0.0; 3]);
        op.apply(mf, &mut cg.corner, w);
        w.iter_mut()
            .enumerate()
            .for_each(|(n, x)| *x = v3::scale(*x, mob(n)));
        // `w . K w` from the strain of `w`: no second product.
        let stress_norm = op.energy_norm_sq(w).max(0.0).sqrt();
        if matches!(
            params.integrator,
            Integrator::BackwardEuler | Integrator::Equilibrium
        ) {
            st.implicit = bufs;
        }
        phase.steps as f64 * 0.5 * step_dt * step_dt * stress_norm / (2.0 * phase.energy).sqrt()
    } else {
        phase.cg_residual
    };
    phase.time = report.time;
    report.phases.push(phase);
    cache.force = carried.then_some(force);
    cache.normals = normals;
    st.cache = cache;
    if !phase.energy.is_finite()
        || (params.integrator == Integrator::PaperEuler
            && !loading
            && phase.energy > energy_before * (1.0 + 1e-6) + 1e-300)
    {
        return Err(SimError::Diverged(format!(
            "relaxation diverged with integrator {} (energy {:.3e} -> {:.3e}); relax_dt {} is above the stable step {:.3e}: use a smaller relax_dt or another integrator",
            params.integrator.name(),
            energy_before,
            phase.energy,
            params.relax_dt,
            report.stable_dt
        )));
    }
    Ok(fans)
}

/// What a round's scheme works with besides the state.
pub(in crate::sim) struct Round<'a> {
    pub(in crate::sim) mesh: &'a SimMesh,
    pub(in crate::sim) params: &'a SimParams,
    pub(in crate::sim) fans: &'a Fans,
    pub(in crate::sim) normals: &'a [[f64; 3]],
    /// Local relaxation: only this region moves.
    pub(in crate::sim) region: Option<&'a Region>,
    /// Whether the load acts in this round.
    pub(in crate::sim) loading: bool,
}

impl Round<'_> {
    /// The load of a step of `dt`: while loading, what is left of the load
    /// time, at most `dt` (added to `loaded`).
    pub(in crate::sim) fn load_for(&self, loaded: &mut f64, dt: f64) -> Load {
        let load_dt = if self.loading {
            dt.min(self.params.load_time - *loaded).max(0.0)
        } else {
            0.0
        };
        *loaded += load_dt;
        Load {
            dt: load_dt,
            shrink_rate: self.params.shrink_rate,
        }
    }

    /// The steps of a round and their length for a largest step `dt`:
    /// `relax_steps` of `dt`, or as many as `relax_time` needs.
    pub(in crate::sim) fn steps_for(&self, dt: f64) -> (usize, f64) {
        let params = self.params;
        if params.relax_steps > 0 {
            (params.relax_steps, dt)
        } else {
            let n = ((params.relax_time / dt).ceil() as usize).max(1);
            (n, params.relax_time / n as f64)
        }
    }
}

/// What a scheme's round leaves for the round's common end.
#[derive(Default)]
pub(in crate::sim) struct RoundEnd {
    /// The force at the end of the round, when the scheme gives it.
    pub(in crate::sim) end_force: Option<Vec<[f64; 3]>>,
    /// The energy at the end of the round, when the last pass gave it.
    pub(in crate::sim) end_energy: Option<f64>,
    /// The step the error estimate assumes (0: none).
    pub(in crate::sim) step_dt: f64,
    /// The mobility of each node in the steps (empty: 1 everywhere).
    pub(in crate::sim) step_mobility: Vec<f64>,
    /// RKL: the round's step-doubling error estimate, when sampled.
    pub(in crate::sim) rkl_estimate: Option<f64>,
}

/// One integrator family's relaxation round: moves the state on by the
/// round's relaxation time (and load), counting time, steps and solver
/// work in `report` and `phase`.
pub(in crate::sim) trait Scheme {
    #[allow(clippy::too_many_arguments)]
    fn relax(
        &self,
        r: &Round,
        st: &mut State,
        cache: &mut RoundCache,
        known_force: &mut Option<Vec<[f64; 3]>>,
        loaded: &mut f64,
        g: &mut Vec<[f64; 3]>,
        report: &mut SimReport,
        phase: &mut Phase,
    ) -> RoundEnd;
}
