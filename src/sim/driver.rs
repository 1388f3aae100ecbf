//! The quasistatic crack loop: relax (with stress evolution), compute
//! separation tensors, crack while the top of the failure queue exceeds the
//! toughness, repeat until nothing fails or a budget is reached.
//!
//! Units: lengths are normalised by the input mesh's mean edge length, so
//! every parameter means the same whatever the asset's scale or unit. Stress
//! is dimensionless (the material's stiffness is 1); the toughness is compared
//! with the separation tensor's eigenvalue in those units.

use crate::math::v3;
use crate::math::Sym3;
use crate::mesh::{FaceId, SimMesh, VertexId};
use crate::sim::crack::{crack_node_avoiding, CrackRules};
use crate::sim::diffusion::{eigen_diffusion_around, relieve_beside};
use crate::sim::error::Misfit;
use crate::sim::finish::crowded_junction;
use crate::sim::finish::finish_cracks;
use crate::sim::forces::{separation_tensor, Elements};
use crate::sim::integrate::relax_round;
use crate::sim::integrate::resolve_integrator;
use crate::sim::observer::Observer;
use crate::sim::params::crack_rules;
use crate::sim::queue::FailureQueue;
use crate::sim::relax::energy;
use crate::sim::separation::node_separation;
use crate::sim::separation::queue_value;
use crate::sim::separation::separations;
use crate::sim::state::apply_event;
use crate::sim::state::observe;
use crate::sim::state::touched_nodes;
use crate::sim::state::State;
use crate::sim::Integrator;
use crate::sim::Model;
use crate::sim::Propagation;
use crate::sim::Relaxation;
use crate::sim::Relaxed;
use crate::sim::SimError;
use crate::sim::SimParams;
use crate::sim::SimReport;
use crate::stress::field::StressField;
use rayon::prelude::*;

/// Run the crack simulation on `mesh` (edited in place) under uniform
/// shrinkage only.
///
/// # Errors
/// An invalid parameter (message names it), or a broken mesh invariant.
pub fn run(
    mesh: &mut SimMesh,
    params: &SimParams,
    observer: &mut dyn Observer,
) -> Result<SimReport, SimError> {
    run_with(mesh, params, None, observer)
}

/// Run the crack simulation on `mesh` (edited in place), with a stress
/// field's initial stress and evolution (per face of `mesh` as given) on top
/// of the parameters' uniform shrinkage.
///
/// # Errors
/// An invalid parameter (message names it), a field that does not fit the
/// mesh, or a broken mesh invariant.
pub fn run_with(
    mesh: &mut SimMesh,
    params: &SimParams,
    field: Option<&StressField>,
    observer: &mut dyn Observer,
) -> Result<SimReport, SimError> {
    if params.model == Model::Springs {
        if field.is_some() {
            return Err(Misfit::FieldOnSprings.into());
        }
        return crate::sim::springs::run(mesh, params, observer);
    }
    if params.cycles > 1 {
        return run_cycles(mesh, params, field, observer);
    }
    run_once(mesh, params, field, observer)
}

/// Several drying cycles ([`crate::sim::ageing`]): the first dried as
/// [`run_with`] does, its crack network aged by the further cycles and cut
/// into `mesh` as given (the gaps carried over from the first drying). The
/// observer sees the first drying.
fn run_cycles(
    mesh: &mut SimMesh,
    params: &SimParams,
    field: Option<&StressField>,
    observer: &mut dyn Observer,
) -> Result<SimReport, SimError> {
    use crate::sim::ageing::{Ageing, CrackNetwork};
    let fresh = mesh.clone();
    // The run checks the parameters: cycles above 1 only with a cell size.
    let mut report = run_once(mesh, params, field, observer)?;
    let Some(cell) = params.cell_size_for(&fresh) else {
        return Err(Misfit::CyclesWithoutCell.into());
    };
    let ageing = Ageing::for_cell(cell);
    let mut net = CrackNetwork::of_cracks(mesh);
    for _ in 1..params.cycles {
        net = net.aged(&ageing);
    }
    let segments = net.segments();
    let times = nearest_times(&report, &segments);
    let cut = crate::mesh::imprint::imprint(
        &fresh,
        mesh,
        &segments,
        &times,
        &report.displacement,
        &report.crack_time,
        &[],
    )
    .map_err(SimError::Mesh)?;
    *mesh = cut.mesh;
    report.crack_length = cut
        .segments
        .iter()
        .map(|s| v3::norm(v3::sub(s[1], s[0])))
        .sum();
    report.segments = cut.segments;
    report.segment_times = cut.segment_times;
    report.displacement = cut.displacement;
    report.crack_time = cut.crack_time;
    report.triangles[1] = mesh.n_faces();
    report.nodes[1] = mesh.n_vertices();
    Ok(report)
}

/// For each of `segments`, the time the first drying's crack segment
/// nearest its middle formed.
fn nearest_times(report: &SimReport, segments: &[[[f64; 3]; 2]]) -> Vec<f64> {
    let old = &report.segments;
    let grid = crate::mesh::spatial::Grid::new(
        old.iter().map(|s| crate::mesh::spatial::bbox(s)),
        old.first().map_or(1.0, |[p, q]| v3::norm(v3::sub(*q, *p))),
    );
    segments
        .iter()
        .map(|[p, q]| {
            let mid = v3::scale(v3::add(*p, *q), 0.5);
            let mut best: Option<(f64, usize)> = None;
            grid.search(mid, |i| {
                let [a, b] = old[i];
                let d2 = v3::dist2(mid, crate::mesh::spatial::closest_on_segment(mid, a, b));
                if best.is_none_or(|(bd, bi)| d2 < bd || (d2 == bd && i < bi)) {
                    best = Some((d2, i));
                }
                best.map(|b| b.0)
            });
            best.and_then(|(_, i)| report.segment_times.get(i).copied())
                .unwrap_or(report.time)
        })
        .collect()
}

/// One drying of `mesh` (see [`run_with`]).
fn run_once(
    mesh: &mut SimMesh,
    params: &SimParams,
    field: Option<&StressField>,
    observer: &mut dyn Observer,
) -> Result<SimReport, SimError> {
    let (mut st, mut report) = start(mesh, params, field)?;
    let resolved;
    let params = if st.film.is_none() && params.integrator == Integrator::Auto {
        let (integrator, why) = resolve_integrator(mesh, &st, params);
        report.integrator = integrator.name();
        report.integrator_reason = why;
        resolved = SimParams {
            integrator,
            ..params.clone()
        };
        &resolved
    } else {
        report.integrator_reason = if st.film.is_some() {
            "a film (cell size) is always solved for equilibrium".into()
        } else {
            "asked for".into()
        };
        params
    };
    let per_round_cap = if params.max_cracks_per_round > 0 {
        params.max_cracks_per_round
    } else if st.film.is_some() {
        // A film's shadows keep new cracks apart within a round, so it
        // can take more of them between two solves.
        (mesh.n_vertices() / 50).max(16)
    } else {
        (mesh.n_vertices() / 100).max(16)
    };
    report.energy[0] = energy(&st.els, &st.stress);
    observe(observer, mesh, &st, &report);
    let mut queue = FailureQueue::new();
    let mut loaded = 0.0; // time the load has acted so far
    let mut hold = false; // hold the load this round (the last one hit the cap)
    let mut g: Vec<[f64; 3]> = Vec::new();
    let rules = crack_rules(params);
    // Hits that land once the cracks before them have come to rest.
    let mut later = field.map_or(&[][..], |f| &f.later[..]).iter();
    report.stopped = format!("reached max_rounds ({})", params.max_rounds);
    for round in 0..params.max_rounds {
        // ---- relax, with the load increasing unless held or complete
        let loading = !hold && loaded < params.load_time;
        let fans = relax_round(
            mesh,
            &mut st,
            params,
            &mut g,
            loading,
            &mut loaded,
            &mut report,
            None,
        )?;
        report.rounds = round + 1;
        if let Some(film) = &mut st.film {
            film.new_round();
        }
        if params.relaxation == Relaxation::EigenDiffusion && st.frozen.is_none() {
            let fz: Vec<Sym3> = (0..mesh.n_vertices())
                .into_par_iter()
                .map(|v| separation_tensor(mesh, &st.els, &st.stress, VertexId(v as u32)))
                .collect();
            st.freeze(fz);
        }
        // ---- queue every failing node
        let sep = separations(mesh, &fans, &st, params.toughness);
        for (v, val) in sep.iter().enumerate() {
            queue.set(v as u32, *val, params.toughness);
        }
        // ---- crack while the top fails
        let cracked_this_round = crack_while_failing(
            mesh,
            &mut st,
            params,
            &mut report,
            &mut queue,
            &rules,
            per_round_cap,
        )?;
        hold = cracked_this_round >= per_round_cap;
        observer.round(
            round + 1,
            params.max_rounds,
            report.cracks,
            report.relax_steps,
        );
        observe(observer, mesh, &st, &report);
        if report.cracks >= params.max_cracks {
            report.stopped = format!("reached max_cracks ({})", params.max_cracks);
            break;
        }
        let load_done = loaded >= params.load_time;
        if cracked_this_round == 0 && load_done {
            if let Some(hit) = later.next() {
                // The earlier hits' pattern is finished before the next
                // lands, so its load stops at their finished cracks.
                if params.finish {
                    finish_into(mesh, &mut st, params, &mut g, &mut report, observer)?;
                }
                land(mesh, &mut st, hit);
                report.hit_times.push(report.time);
                continue;
            }
            report.stopped = "nothing fails any more".into();
            break;
        }
    }
    if params.finish {
        finish_into(mesh, &mut st, params, &mut g, &mut report, observer)?;
    }
    st.segment_at.in_record_order(&mut report);
    report.energy[1] = energy(&st.els, &st.stress);
    report.triangles[1] = mesh.n_faces();
    report.nodes[1] = mesh.n_vertices();
    report.displacement = st.displacement.into_values();
    report.crack_time = st.crack_time.into_values();
    report.diffusion_work = st.diffusion_work;
    Ok(report)
}

/// Finish the cracks' tips ([`finish_cracks`]), adding what it did to the
/// report's finishing (a run with later hits finishes before each lands).
fn finish_into(
    mesh: &mut SimMesh,
    st: &mut State,
    params: &SimParams,
    g: &mut Vec<[f64; 3]>,
    report: &mut SimReport,
    observer: &mut dyn Observer,
) -> Result<(), SimError> {
    let t = std::time::Instant::now();
    let mut fin = finish_cracks(mesh, st, params, g, report, observer)?;
    fin.seconds = t.elapsed().as_secs_f64();
    if let Some(before) = report.finish.take() {
        fin.tips += before.tips;
        fin.cracks += before.cracks;
        fin.length += before.length;
        fin.passes += before.passes;
        fin.stuck += before.stuck;
        fin.confined += before.confined;
        fin.seconds += before.seconds;
    }
    report.finish = Some(fin);
    Ok(())
}

/// Add a later hit's load, built on the surface as cracked now, to the
/// stress of every face that carries stress.
fn land(mesh: &SimMesh, st: &mut State, hit: &crate::stress::field::LaterHit) {
    let added = hit.stress(mesh);
    for ((s, a), el) in st.stress.iter_mut().zip(added).zip(&st.els.elements) {
        if el.is_some() {
            *s += a;
        }
    }
    // What was known at the old stress is stale.
    st.cache.force = None;
    st.frozen = None;
}

/// Crack while the top of the failure queue fails: each crack event is
/// applied to the state, its tips get the residual, and the nodes it
/// touched are queued again. Ends when nothing fails, at `max_cracks`, or
/// (between crack runs) at `per_round_cap` cracks; returns the cracks made.
#[allow(clippy::too_many_arguments)]
fn crack_while_failing(
    mesh: &mut SimMesh,
    st: &mut State,
    params: &SimParams,
    report: &mut SimReport,
    queue: &mut FailureQueue,
    rules: &CrackRules,
    per_round_cap: usize,
) -> Result<usize, SimError> {
    let mut cracked_this_round = 0;
    // With `to-end`, the tips of the crack being run come first.
    let mut follow: Vec<VertexId> = Vec::new();
    let mut chain = false;
    // The nodes the current crack run touched (eigen-diffusion).
    let mut run_nodes: Vec<VertexId> = Vec::new();
    // Its crack segments, as end points (the shadow beside it).
    let mut run_segments: Vec<([f64; 3], [f64; 3])> = Vec::new();
    loop {
        if follow.is_empty() {
            // A crack run ended: diffuse before the next one.
            if chain && params.relaxation == Relaxation::EigenDiffusion {
                let mut changed = relieve_beside(mesh, st, &run_segments, &run_nodes);
                changed.extend(eigen_diffusion_around(
                    mesh,
                    st,
                    params,
                    &run_nodes,
                    params.diffusion_passes,
                ));
                changed.sort_unstable();
                changed.dedup();
                for u in changed {
                    let s = node_separation(mesh, st, VertexId(u));
                    queue.set(u, queue_value(s, params.toughness), params.toughness);
                }
            }
            run_nodes.clear();
            run_segments.clear();
            chain = false;
        }
        // The round's cap ends a round between crack runs, never
        // inside one.
        if report.cracks >= params.max_cracks
            || (follow.is_empty() && cracked_this_round >= per_round_cap)
        {
            break;
        }
        let v = match follow.pop() {
            Some(v) => v,
            None => match queue.pop() {
                Some((v, _)) => VertexId(v),
                None => break,
            },
        };
        let (val, dir) = node_separation(mesh, st, v).max_eigen();
        if val.is_nan() || val <= params.toughness {
            continue;
        }
        let run = st.film.as_mut().map_or(0, |film| film.run_at(v));
        let ev = crack_node_avoiding(mesh, v, dir, rules, &|m, w| {
            crowded_junction(m, &st.crack_degree, w)
        })
        .map_err(SimError::Mesh)?;
        st.residual[v.idx()] = Sym3::ZERO;
        if let Some(fz) = &mut st.frozen {
            // The crack releases the node's failing component.
            let raw = fz[v.idx()];
            let (l, e) = raw.max_eigen();
            if l > 0.0 {
                fz[v.idx()] = raw - Sym3::m(e) * l;
            }
        }
        if !apply_event(mesh, st, report, &ev) {
            continue;
        }
        if let Some(film) = &mut st.film {
            let ends: Vec<VertexId> = ev.segments.iter().flat_map(|&(a, b)| [a, b]).collect();
            film.mark_around(mesh, &ends, run);
        }
        cracked_this_round += 1;
        chain = true;
        if params.propagation == Propagation::ToEnd {
            follow.extend(ev.segments.iter().map(|&(_, tip)| tip).filter(|&tip| {
                !mesh.is_boundary_vertex(tip)
                    || crate::sim::crack::crack_directions(mesh, tip).len() == 1
            }));
        } else if params.relaxation == Relaxation::EigenDiffusion {
            // Each crack is its own run.
            follow.clear();
        }
        // Residual propagation to the new crack tips.
        let residual = val - params.toughness + params.residual_constant;
        for &(_, tip) in &ev.segments {
            if !mesh.is_boundary_vertex(tip)
                || crate::sim::crack::crack_directions(mesh, tip).len() == 1
            {
                st.residual[tip.idx()] += Sym3::m(dir) * (params.alpha * residual);
            }
        }
        if params.relaxation == Relaxation::EigenDiffusion {
            run_segments.extend(
                ev.segments
                    .iter()
                    .map(|&(a, b)| (mesh.position(a), mesh.position(b))),
            );
        }
        // New and nearby nodes get their separation immediately.
        for n in touched_nodes(mesh, &ev) {
            if params.relaxation == Relaxation::EigenDiffusion {
                run_nodes.push(n);
            }
            let s = node_separation(mesh, st, n);
            queue.set(n.0, queue_value(s, params.toughness), params.toughness);
        }
    }
    Ok(cracked_this_round)
}

/// The start state of a run: parameters and field checked, elements
/// built, the report begun.
pub(in crate::sim) fn start(
    mesh: &SimMesh,
    params: &SimParams,
    field: Option<&StressField>,
) -> Result<(State, SimReport), SimError> {
    params.validate()?;
    if let Some(f) = field {
        if f.init.len() != mesh.n_faces()
            || f.evolve.len() != mesh.n_faces()
            || !(f.separation_scale.is_empty() || f.separation_scale.len() == mesh.n_faces())
        {
            return Err(Misfit::FieldFaces {
                field: f.init.len(),
                mesh: mesh.n_faces(),
            }
            .into());
        }
    }
    let film = params
        .is_film()
        .then(|| params.cell_size_for(mesh))
        .flatten()
        .map(crate::sim::film::Film::new);
    let unit = match &film {
        Some(f) => f.length,
        None => mesh.mean_edge_length(),
    };
    if !(unit.is_finite() && unit > 0.0) {
        return Err(Misfit::NoEdgeLength.into());
    }
    let mut report = SimReport {
        triangles: [mesh.n_faces(), 0],
        nodes: [mesh.n_vertices(), 0],
        length_unit: unit,
        cell_size: film.as_ref().map(|f| f.cell),
        stable_dt: f64::INFINITY,
        integrator: if film.is_some() {
            "film-equilibrium"
        } else {
            params.integrator.name()
        },
        ..Default::default()
    };
    // Elements in normalised units.
    let clamp = Elements::clamp_threshold(mesh, params.clamp_factor) * unit;
    let mut st = State::new(
        mesh,
        params,
        [
            field.map(|f| f.init.clone()).unwrap_or_default(),
            field.map(|f| f.evolve.clone()).unwrap_or_default(),
        ],
        field
            .map(|f| f.separation_scale.clone())
            .unwrap_or_default(),
        film,
        Elements {
            elements: Vec::new(),
            clamp,
        },
        unit,
    );
    st.els.elements = (0..mesh.n_faces())
        .into_par_iter()
        .map(|f| st.element(mesh, FaceId(f as u32)))
        .collect();
    st.grow(mesh);
    // The rounds' working memory, paged in with the rest of the state (it
    // lives as long as the state; a fresh allocation would otherwise be
    // paged in during the first round).
    let (nf, nv) = (mesh.n_faces(), mesh.n_vertices());
    crate::sim::implicit::touch(&mut st.corner, 3 * nf);
    if st.film.is_some()
        || matches!(
            params.integrator,
            Integrator::BackwardEuler | Integrator::Equilibrium
        )
    {
        let b = &mut st.implicit;
        b.cg.reserve(nf, nv);
        for v in [&mut b.rhs, &mut b.r, &mut b.ax] {
            crate::sim::implicit::touch(v, nv);
        }
    }
    report.energy[0] = energy(&st.els, &st.stress);
    Ok((st, report))
}

/// Relaxation alone, no cracking: `rounds` rounds of `params.relax_time`
/// from the start state (the load acting for `params.load_time`), by
/// `params.integrator`. For comparing integrators at the same relaxation
/// time.
pub fn relax_only(
    mesh: &SimMesh,
    params: &SimParams,
    field: Option<&StressField>,
    rounds: usize,
) -> Result<Relaxed, SimError> {
    let (mut st, mut report) = start(mesh, params, field)?;
    let (integrator, why) = resolve_integrator(mesh, &st, params);
    report.integrator = integrator.name();
    report.integrator_reason = why;
    let params = &SimParams {
        integrator,
        ..params.clone()
    };
    let mut loaded = 0.0;
    let mut g = Vec::new();
    crate::sim::implicit::touch(&mut g, mesh.n_vertices());
    let clock = std::time::Instant::now();
    for round in 0..rounds {
        relax_round(
            mesh,
            &mut st,
            params,
            &mut g,
            true,
            &mut loaded,
            &mut report,
            None,
        )?;
        report.rounds = round + 1;
    }
    let seconds = clock.elapsed().as_secs_f64();
    report.energy[1] = energy(&st.els, &st.stress);
    let areas = st
        .els
        .elements
        .iter()
        .map(|e| e.as_ref().map_or(0.0, |e| e.area))
        .collect();
    Ok(Relaxed {
        stress: st.stress.into_values(),
        areas,
        report,
        seconds,
    })
}

#[cfg(test)]
#[path = "driver_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "snapping_tests.rs"]
mod snapping_tests;
