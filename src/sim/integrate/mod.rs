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
pub(in crate::sim) mod scheme;

use crate::math::GrowGently;
use crate::math::v3;
use crate::mesh::{SimMesh, VertexId};
use crate::sim::forces::{gather, Fans};
use crate::sim::integrate::region::Region;
use crate::sim::integrate::scheme::{Round, RoundEnd, Scheme};
use crate::sim::relax::{energy, node_bounds};
use crate::sim::state::ImplicitScratch;
use crate::sim::state::State;
use crate::sim::Integrator;
use crate::sim::Phase;
use crate::sim::Relaxation;
use crate::sim::SimError;
use crate::sim::SimParams;
use crate::sim::SimReport;
use crate::sim::AUTO_STEP_LIMIT;
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
        w.resize_gently(n, [0.0; 3]);
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
        return Err(crate::sim::error::Divergence::Relaxation {
            integrator: params.integrator.name(),
            before: energy_before,
            after: phase.energy,
            relax_dt: params.relax_dt,
            stable_dt: report.stable_dt,
        }
        .into());
    }
    Ok(fans)
}
