//! Tests of the crack loop, the integrators and finishing (the snapping
//! variant's in `snapping_tests.rs`).

use super::*;
use crate::math::{v3, Sym3};
use crate::mesh::shapes::jittered_plate;
use crate::mesh::{SimMesh, VertexId};
use crate::sim::forces::{corner_forces, Fans};
use crate::sim::integrate::{explicit::*, region::*};
use crate::sim::load::*;
use crate::sim::{finish::*, observer::*, params::*, report::*, state::*};

#[test]
fn alpha_above_one_is_refused() {
    let mut mesh = jittered_plate(4, 0.1, 1);
    let p = SimParams {
        alpha: 1.5,
        ..Default::default()
    };
    let e = run(&mut mesh, &p, &mut ()).unwrap_err().to_string();
    assert!(e.contains("alpha"), "{e}");
}

#[test]
fn shrinking_plate_cracks_into_cells() {
    let mut mesh = jittered_plate(24, 0.3, 7);
    let area = mesh.total_area();
    let p = SimParams {
        max_rounds: 60,
        ..Default::default()
    };
    let r = run(&mut mesh, &p, &mut ()).unwrap();
    mesh.validate().unwrap();
    assert!(r.cracks > 10, "{r:?}");
    assert!(((mesh.total_area() - area) / area).abs() < 1e-12);
    let (pieces, _) = mesh.connected_components();
    assert!(
        pieces > 3,
        "cracks meet and cut the plate into cells: {pieces} pieces, {r:?}"
    );
    assert!(
        pieces * 20 < mesh.n_faces(),
        "cells, not shattered triangles: {pieces} pieces, {r:?}"
    );
    assert!(r.energy[1].is_finite());
}

/// Crack nodes (positions with at least one crack edge, off the plate's
/// border) and how many of them are dangling tips (one crack direction).
fn crack_tips(mesh: &SimMesh, n: f64) -> (usize, usize) {
    let on_border = |p: [f64; 3]| {
        p[0].abs() < 1e-9 || p[1].abs() < 1e-9 || (p[0] - n).abs() < 1e-9 || (p[1] - n).abs() < 1e-9
    };
    let mut dirs: std::collections::BTreeMap<[i64; 2], Vec<[f64; 3]>> = Default::default();
    for v in mesh.vertices() {
        let p = mesh.position(v);
        if on_border(p) || !mesh.is_boundary_vertex(v) {
            continue;
        }
        let key = [(p[0] * 1e6).round() as i64, (p[1] * 1e6).round() as i64];
        let e = dirs.entry(key).or_default();
        for d in crate::sim::crack::crack_directions(mesh, v) {
            if e.iter().all(|x| v3::dot(*x, d) < 1.0 - 1e-9) {
                e.push(d);
            }
        }
    }
    let tips = dirs.values().filter(|d| d.len() == 1).count();
    (dirs.len(), tips)
}

#[test]
fn plate_cracks_close_into_cells() {
    let mut mesh = jittered_plate(32, 0.3, 11);
    let r = run(&mut mesh, &SimParams::default(), &mut ()).unwrap();
    mesh.validate().unwrap();
    let (nodes, tips) = crack_tips(&mesh, 32.0);
    let (pieces, _) = mesh.connected_components();
    assert!(nodes > 50, "{nodes} crack nodes, {r:?}");
    assert!(
        tips * 10 <= nodes,
        "mostly closed cells: {tips} dangling tips among {nodes} crack nodes"
    );
    assert!(pieces >= 4, "{pieces} cells");
    assert_eq!(r.stopped, "nothing fails any more");
    assert_eq!(r.segments.len(), r.segment_times.len());
    assert!(r.segment_times.windows(2).all(|w| w[0] <= w[1]));
    assert_eq!(r.first_crack_time, r.segment_times.first().copied());
}

#[test]
fn fixed_nodes_hold_their_stress() {
    // No cracks (huge toughness), no noise: the energy left after loading
    // tells how much relaxation the fixed nodes allowed.
    let energy_with = |fixed_boundary: bool, fixed_groups: Vec<u32>| {
        let mut mesh = jittered_plate(10, 0.3, 2);
        let p = SimParams {
            toughness: 1e9,
            noise: 0.0,
            load_time: 10.0,
            shrink_rate: 0.1,
            max_rounds: 6,
            fixed_boundary,
            fixed_groups,
            ..Default::default()
        };
        let r = run(&mut mesh, &p, &mut ()).unwrap();
        assert_eq!(r.cracks, 0);
        // Area in normalised units times |shrinkage * I_2|^2 / 2.
        let full = 0.5 * mesh.total_area() / (r.length_unit * r.length_unit) * 2.0;
        r.energy[1] / full
    };
    let all = energy_with(false, vec![0]);
    let border = energy_with(true, vec![]);
    let free = energy_with(false, vec![]);
    assert!(
        (all - 1.0).abs() < 1e-9,
        "all nodes fixed: nothing relaxes ({all})"
    );
    assert!(
        free < border && border < all,
        "free {free} < fixed border {border} < all fixed {all}"
    );
}

/// Relaxation alone from a uniform starting stress: the paper's forward
/// Euler and backward Euler both converge to the same stress field as
/// their step shrinks (first order: halving the step about halves the
/// error), against forward Euler with a tiny step; every scheme lowers
/// the energy.
#[test]
fn integrators_converge_to_the_same_relaxation() {
    let mesh = jittered_plate(12, 0.3, 2);
    let terms = [crate::stress::Term {
        kind: crate::stress::TermKind::Uniform,
        init: 1.0,
        evolve: 0.0,
        mask: None,
    }];
    let field = StressField::build(&mesh, &terms, 1).unwrap();
    let base = SimParams {
        shrink_rate: 0.0,
        load_time: 0.0,
        noise: 0.0,
        relax_time: 2.0,
        ..Default::default()
    };
    let with = |integrator: Integrator, dt: f64| {
        let p = SimParams {
            integrator,
            relax_dt: dt,
            tolerance: 1e-12,
            ..base.clone()
        };
        relax_only(&mesh, &p, Some(&field), 1).unwrap()
    };
    let reference = with(Integrator::PaperEuler, 2.5e-4);
    assert!(reference.report.energy[1] < 0.9 * reference.report.energy[0]);
    for integrator in [Integrator::PaperEuler, Integrator::BackwardEuler] {
        let errors: Vec<f64> = [0.04, 0.02, 0.01]
            .iter()
            .map(|&dt| {
                let r = with(integrator, dt);
                assert!(r.report.energy[1] < r.report.energy[0]);
                let err = r.error_against(&reference);
                let est = r.report.phases[0].error_estimate;
                eprintln!("{integrator:?} dt {dt}: error {err:.3e}, estimate {est:.3e}");
                // The round's own estimate is of the right size.
                assert!(est > err / 2.0 && est < err * 2.0, "{err} vs {est}");
                err
            })
            .collect();
        eprintln!("{integrator:?}: relative stress errors at dt 0.04, 0.02, 0.01: {errors:?}");
        for w in errors.windows(2) {
            let ratio = w[0] / w[1];
            assert!(
                (1.6..2.6).contains(&ratio),
                "{integrator:?}: errors {errors:?} are not first order"
            );
        }
        assert!(errors[2] < 0.02, "{integrator:?}: {errors:?}");
    }
    // Backward Euler with one step for the whole round is stable but
    // further off; the Euler with the stable step is close.
    let one = with(Integrator::BackwardEuler, 0.0).error_against(&reference);
    let stable = with(Integrator::Euler, 0.0).error_against(&reference);
    let local = with(Integrator::LocalEuler, 0.0).error_against(&reference);
    eprintln!(
        "one backward-Euler step: {one}, euler at the stable step: {stable}, local-euler: {local}"
    );
    assert!(one.is_finite() && stable < one, "{stable} vs {one}");
}

/// `rounds` relaxation rounds from the start state (`fresh`: the
/// round cache dropped before each).
fn implicit_rounds(
    mesh: &SimMesh,
    field: &StressField,
    params: &SimParams,
    rounds: usize,
    fresh: bool,
) -> (State, SimReport) {
    let (mut st, mut report) = start(mesh, params, Some(field)).unwrap();
    let (mut loaded, mut g) = (0.0, Vec::new());
    for _ in 0..rounds {
        if fresh {
            st.cache = RoundCache::default();
        }
        relax_round(
            mesh,
            &mut st,
            params,
            &mut g,
            true,
            &mut loaded,
            &mut report,
            None,
        )
        .unwrap();
    }
    (st, report)
}

/// How far the force a backward-Euler round carried is from the force
/// of the state's stress, and that force's norm.
fn carried_force_error(st: &State) -> (f64, f64) {
    let fans = st.cache.fans();
    let op = crate::sim::implicit::Operator {
        fans: &fans,
        els: &st.els,
        normals: &st.cache.normals,
        fixed: &st.fixed,
        interface: &[],
    };
    let fresh = op.forces(&st.stress, &mut Vec::new());
    let carried = st.cache.force.clone().expect("a carried force");
    let diff: Vec<[f64; 3]> = carried
        .iter()
        .zip(&fresh)
        .map(|(a, b)| v3::sub(*a, *b))
        .collect();
    (
        crate::sim::implicit::dot(&diff, &diff).sqrt(),
        crate::sim::implicit::dot(&fresh, &fresh).sqrt(),
    )
}

/// The area-free L2 distance of two stress fields, and the second's norm.
fn stress_gap(a: &[Sym3], b: &[Sym3]) -> (f64, f64) {
    let gap = a
        .iter()
        .zip(b)
        .map(|(a, b)| (*a - *b).frobenius_sq())
        .sum::<f64>();
    let scale = b.iter().map(|s| s.frobenius_sq()).sum::<f64>();
    (gap.sqrt(), scale.sqrt())
}

/// Backward-Euler rounds carry the force from solve to solve (gathered
/// after each stress update, plus the force of the round's load): after
/// rounds with load, bonding and a fixed border it equals the force computed afresh from
/// the stress, and the stress equals that of rounds that compute
/// everything afresh (cache dropped before every round).
#[test]
fn carried_implicit_forces_match_fresh_ones() {
    let mesh = jittered_plate(14, 0.3, 6);
    let terms = [crate::stress::Term {
        kind: crate::stress::TermKind::Uniform,
        init: 0.5,
        evolve: 0.1,
        mask: None,
    }];
    let field = StressField::build(&mesh, &terms, 1).unwrap();
    let params = SimParams {
        integrator: Integrator::BackwardEuler,
        relax_dt: 0.5,
        tolerance: 1e-12,
        bonded: true,
        fixed_boundary: true,
        shrink_rate: 0.1,
        load_time: 3.0,
        relax_time: 1.0,
        ..Default::default()
    };
    let (st, report) = implicit_rounds(&mesh, &field, &params, 5, false);
    assert!(report.phases.iter().all(|p| p.cg_iterations > 0));
    assert!(!st.cache.normals.is_empty() && st.fixed.iter().any(|&f| f));
    let (off, norm) = carried_force_error(&st);
    assert!(norm > 1e-6, "{norm}");
    assert!(
        off < 1e-8 * norm,
        "carried force off by {off} (norm {norm})"
    );
    let last = report.phases.last().unwrap().residual;
    assert!((last - norm).abs() < 1e-8 * norm, "{last} vs {norm}");
    // The same stress as rounds that compute everything afresh.
    let (st2, _) = implicit_rounds(&mesh, &field, &params, 5, true);
    let (gap, scale) = stress_gap(&st.stress, &st2.stress);
    assert!(gap < 1e-8 * scale, "stress differs by {gap} (norm {scale})");
}

/// Many backward-Euler rounds on one mesh at a tight tolerance and
/// several steps a round (each solve starts from a combination of the
/// last solutions, which extrapolates): the force and the products kept
/// for the starts stay exact, so nothing drifts or blows up. The energy
/// never rises once the load has stopped, the last round's force is the
/// force of its stress, and the stress is that of rounds that keep
/// nothing.
#[test]
fn long_implicit_runs_on_one_mesh_stay_exact() {
    let mesh = jittered_plate(30, 0.3, 4);
    let field = StressField::build(
        &mesh,
        &[crate::stress::Term {
            kind: crate::stress::TermKind::Uniform,
            init: 0.5,
            evolve: 0.0,
            mask: None,
        }],
        1,
    )
    .unwrap();
    let params = SimParams {
        integrator: Integrator::BackwardEuler,
        relax_dt: 0.125,
        tolerance: 1e-6,
        bonded: true,
        fixed_boundary: true,
        shrink_rate: 0.1,
        load_time: 3.0,
        relax_time: 1.0,
        ..Default::default()
    };
    let rounds = 150;
    let (st, report) = implicit_rounds(&mesh, &field, &params, rounds, false);
    assert_eq!(report.cg_unconverged, 0);
    let energies: Vec<f64> = report.phases.iter().map(|p| p.energy).collect();
    for (k, w) in energies.windows(2).enumerate().skip(3) {
        assert!(
            w[1] <= w[0] * (1.0 + 1e-12),
            "round {k}: energy {} -> {}",
            w[0],
            w[1]
        );
    }
    let (off, norm) = carried_force_error(&st);
    assert!(
        off <= 1e-9 * norm.max(1e-300),
        "carried force off by {off} (norm {norm})"
    );
    let (st2, _) = implicit_rounds(&mesh, &field, &params, rounds, true);
    let (gap, scale) = stress_gap(&st.stress, &st2.stress);
    assert!(gap < 1e-5 * scale, "stress differs by {gap} (norm {scale})");
}

#[test]
fn rkl_is_second_order_and_estimates_its_error() {
    let mesh = jittered_plate(12, 0.3, 2);
    let terms = [crate::stress::Term {
        kind: crate::stress::TermKind::Uniform,
        init: 1.0,
        evolve: 0.0,
        mask: None,
    }];
    let field = StressField::build(&mesh, &terms, 1).unwrap();
    let base = SimParams {
        shrink_rate: 0.0,
        load_time: 0.0,
        noise: 0.0,
        relax_time: 2.0,
        ..Default::default()
    };
    let with = |integrator: Integrator, dt: f64| {
        let p = SimParams {
            integrator,
            relax_dt: dt,
            ..base.clone()
        };
        relax_only(&mesh, &p, Some(&field), 1).unwrap()
    };
    // Reference: forward Euler at two small steps, extrapolated.
    let (h, h2) = (
        with(Integrator::PaperEuler, 5e-4),
        with(Integrator::PaperEuler, 2.5e-4),
    );
    let reference = Relaxed {
        stress: h
            .stress
            .iter()
            .zip(&h2.stress)
            .map(|(a, b)| *b * 2.0 - *a)
            .collect(),
        areas: h2.areas.clone(),
        report: h2.report.clone(),
        seconds: 0.0,
    };
    let euler = with(Integrator::Euler, 0.0);
    let local = with(Integrator::LocalEuler, 0.0);
    eprintln!(
        "euler: error {:.3e}, {} steps; local-euler: error {:.3e}, {} steps",
        euler.error_against(&reference),
        euler.report.relax_steps,
        local.error_against(&reference),
        local.report.relax_steps
    );
    let mut errors = Vec::new();
    for supers in [1.0, 2.0, 4.0] {
        let r = with(Integrator::Rkl, 2.0 / supers);
        assert!(r.report.energy[1] < r.report.energy[0]);
        let err = r.error_against(&reference);
        let est = r.report.phases[0].error_estimate;
        eprintln!(
            "rkl, {supers} super-steps: error {err:.3e}, estimate {est:.3e}, {} evaluations (euler: {})",
            r.report.relax_steps, euler.report.relax_steps
        );
        assert!(est > err / 2.0 && est < err * 2.0, "{err} vs {est}");
        errors.push(err);
    }
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        // Second order or better (the stiffest modes, which one
        // super-step damps least, fade faster than that).
        assert!((3.0..10.0).contains(&ratio), "not second order: {errors:?}");
    }
    // Fewer force evaluations than forward Euler at its stable step.
    let one = with(Integrator::Rkl, 0.0);
    assert!(2 * one.report.relax_steps < euler.report.relax_steps);
}

#[test]
fn rkl_never_raises_the_energy_on_slivers() {
    // Stiff nodes beside soft ones: the stages are capped and the
    // stiffest nodes slowed; every super-step still lowers the energy.
    let mut input = crate::mesh::shapes::grid_input(12, 12);
    for (i, p) in input.positions.iter_mut().enumerate() {
        let interior = p[0] > 0.0 && p[0] < 12.0 && p[1] > 0.0 && p[1] < 12.0;
        if interior && i % 13 == 0 {
            p[0] += 0.999;
            p[1] += 1e-4;
        }
    }
    let (mesh, _) = SimMesh::build(&input, &Default::default()).unwrap();
    let terms = [crate::stress::Term {
        kind: crate::stress::TermKind::Uniform,
        init: 1.0,
        evolve: 0.0,
        mask: None,
    }];
    let field = StressField::build(&mesh, &terms, 1).unwrap();
    let p = SimParams {
        integrator: Integrator::Rkl,
        shrink_rate: 0.0,
        load_time: 0.0,
        relax_time: 50.0,
        clamp_factor: 1e6,
        ..Default::default()
    };
    let r = relax_only(&mesh, &p, Some(&field), 6).unwrap();
    let mut last = r.report.energy[0];
    for ph in &r.report.phases {
        assert!(
            ph.energy.is_finite() && ph.energy <= last * (1.0 + 1e-12),
            "{last} -> {}",
            ph.energy
        );
        last = ph.energy;
    }
    assert!(last < 0.9 * r.report.energy[0]);
    // Capped: at most RKL_MAX_STAGES evaluations per round.
    assert!(
        r.report.relax_steps <= 6 * RKL_MAX_STAGES,
        "{}",
        r.report.relax_steps
    );
}

/// An equilibrium round leaves (almost) no residual force, and no
/// finite backward-Euler step relaxes further.
#[test]
fn equilibrium_leaves_no_residual_force() {
    let mesh = jittered_plate(12, 0.3, 2);
    let terms = [crate::stress::Term {
        kind: crate::stress::TermKind::Uniform,
        init: 1.0,
        evolve: 0.0,
        mask: None,
    }];
    let field = StressField::build(&mesh, &terms, 1).unwrap();
    let p = |integrator, tolerance| SimParams {
        shrink_rate: 0.0,
        load_time: 0.0,
        integrator,
        tolerance,
        ..Default::default()
    };
    let eq = relax_only(&mesh, &p(Integrator::Equilibrium, 1e-8), Some(&field), 1).unwrap();
    let be = relax_only(&mesh, &p(Integrator::BackwardEuler, 1e-8), Some(&field), 1).unwrap();
    let start = relax_only(&mesh, &p(Integrator::BackwardEuler, 1e-8), Some(&field), 0).unwrap();
    let f0 = {
        let mut m = mesh.clone();
        let r = run_with(
            &mut m,
            &SimParams {
                max_rounds: 1,
                toughness: 1e30,
                ..p(Integrator::BackwardEuler, 1e-8)
            },
            Some(&field),
            &mut (),
        )
        .unwrap();
        r.phases[0].residual
    };
    let res = eq.report.phases[0].residual;
    assert!(
        res < 1e-6 * f0.max(1.0),
        "equilibrium residual {res} (one BE round: {f0})"
    );
    assert!(eq.report.energy[1] <= be.report.energy[1] * (1.0 + 1e-9));
    assert!(eq.report.energy[1] < start.report.energy[1]);
}

/// The paper's scheme with a step far above the stable one stops with an
/// error naming the integrator and the step, instead of blowing up.
#[test]
fn paper_euler_above_the_stable_step_is_an_error() {
    let mut mesh = jittered_plate(10, 0.3, 4);
    let p = SimParams {
        integrator: Integrator::PaperEuler,
        relax_dt: 50.0,
        ..Default::default()
    };
    let e = run(&mut mesh, &p, &mut ()).unwrap_err().to_string();
    assert!(e.contains("paper-euler") && e.contains("relax_dt"), "{e}");
    let p = SimParams {
        integrator: Integrator::PaperEuler,
        ..Default::default()
    };
    let e = run(&mut mesh, &p, &mut ()).unwrap_err().to_string();
    assert!(e.contains("relax_dt"), "{e}");
}

#[test]
fn same_result_at_any_scale() {
    let run_scaled = |s: f64| {
        let mut input = crate::mesh::shapes::grid_input(10, 10);
        let mut rng = crate::mesh::shapes::Lcg(3);
        for q in input.positions.iter_mut() {
            if q[0] > 0.0 && q[0] < 10.0 && q[1] > 0.0 && q[1] < 10.0 {
                q[0] += 0.3 * (2.0 * rng.next_f64() - 1.0);
                q[1] += 0.3 * (2.0 * rng.next_f64() - 1.0);
            }
            *q = q.map(|x| x * s);
        }
        let (mut m, _) = SimMesh::build(&input, &Default::default()).unwrap();
        let params = SimParams {
            toughness: 1.0,
            shrink_rate: 0.2,
            relax_time: 1.0,
            max_rounds: 20,
            ..Default::default()
        };
        let r = run(&mut m, &params, &mut ()).unwrap();
        (r.cracks, m.n_faces(), r.crack_length / s)
    };
    let (c1, f1, l1) = run_scaled(1.0);
    let (c2, f2, l2) = run_scaled(100.0);
    assert!(c1 > 0);
    assert_eq!(
        (c1, f1),
        (c2, f2),
        "a mesh in centimetres cracks like the same mesh in metres"
    );
    assert!((l1 - l2).abs() < 1e-6 * l1);
}

#[test]
fn a_region_of_every_node_is_the_global_step() {
    // One unloaded step restricted to a region holding every node is
    // the global step, bit for bit; a small region moves only its nodes
    // and changes only its faces.
    let mesh = jittered_plate(10, 0.3, 2);
    let params = SimParams::default();
    let (mut st, _) = start(&mesh, &params, None).unwrap();
    let fans = Fans::new(&mesh);
    // Some stress to relax.
    let mut rng = crate::mesh::shapes::Lcg(7);
    for (s, el) in st.stress.iter_mut().zip(&st.els.elements) {
        let n = el.as_ref().unwrap().normal;
        *s = Sym3::tangent_identity(n, 1.0 + rng.next_f64());
    }
    corner_forces(&st.els, &st.stress, &mut st.corner);
    let normals = node_normals(&fans, &st.els);
    let mobility = vec![1.0; fans.n_vertices()];
    let dt = 0.05;
    let unloaded = Load {
        dt: 0.0,
        shrink_rate: 0.0,
    };
    let before = (
        st.stress.to_vec(),
        st.displacement.to_vec(),
        st.corner.clone(),
    );
    let mut g = Vec::new();
    relax_and_evolve(&fans, &normals, &mobility, &mut st, dt, unloaded, &mut g);
    let global = (
        st.stress.to_vec(),
        st.displacement.to_vec(),
        st.corner.clone(),
    );
    let (stress, displacement, corner) = before.clone();
    st.stress.replace(stress);
    st.displacement.replace(displacement);
    st.corner = corner;
    let all: Vec<VertexId> = mesh.vertices().collect();
    let region = Region::around(&fans, &all, 0);
    let mut g = vec![[0.0; 3]; fans.n_vertices()];
    relax_region(&fans, &normals, &mobility, &mut st, dt, &region, &mut g);
    assert_eq!(*st.stress, *global.0);
    assert_eq!(*st.displacement, *global.1);
    assert_eq!(st.corner, global.2);
    // A region of two rings around one node.
    let (stress, displacement, corner) = before.clone();
    st.stress.replace(stress);
    st.displacement.replace(displacement);
    st.corner = corner;
    let small = Region::around(&fans, &[VertexId(55)], 2);
    let nodes = small.inside.iter().filter(|&&i| i).count();
    assert!(nodes > 7 && nodes < 40, "{nodes}");
    let mut g = vec![[0.0; 3]; fans.n_vertices()];
    relax_region(&fans, &normals, &mobility, &mut st, dt, &small, &mut g);
    for v in 0..fans.n_vertices() {
        if !small.inside[v] {
            assert_eq!(st.displacement[v], before.1[v], "node {v} moved");
        }
    }
    let mut changed = 0;
    for f in 0..fans.n_faces() {
        if st.stress[f] != before.0[f] {
            changed += 1;
            assert!(small.face_in[f], "face {f} changed");
        }
    }
    assert!(changed > 0);
    // The energy falls.
    assert!(energy(&st.els, &st.stress) < energy(&st.els, &before.0));
}

#[test]
fn local_finishing_relaxes_only_near_the_new_cracks() {
    // Snapshots of each finishing pass: energy and displacement.
    struct Keep(Vec<(f64, Vec<[f64; 3]>)>);
    impl Observer for Keep {
        fn state(&mut self, s: &Snapshot) {
            self.0.push((s.energy, s.displacement.to_vec()));
        }
        fn wants_state(&self) -> bool {
            true
        }
    }
    let params = SimParams {
        max_rounds: 12,
        residual_constant: 0.0,
        alpha: 0.3,
        finish: true,
        ..Default::default()
    };
    let run_rings = |rings: usize| {
        let mut mesh = jittered_plate(24, 0.3, 5);
        let mut keep = Keep(Vec::new());
        let p = SimParams {
            finish_rings: rings,
            ..params.clone()
        };
        let r = run_with(&mut mesh, &p, None, &mut keep).unwrap();
        mesh.validate().unwrap();
        (r, keep.0)
    };
    let (global, global_snaps) = run_rings(0);
    let (local, snaps) = run_rings(2);
    let fin = local.finish.clone().unwrap();
    assert!(fin.passes >= 2, "{fin:?}");
    assert_eq!(global.finish.as_ref().unwrap().passes, fin.passes);
    // The finishing passes are the last snapshots: the energy never
    // rises, and the local passes move far fewer nodes than global ones.
    let moved = |snaps: &[(f64, Vec<[f64; 3]>)]| {
        let passes = &snaps[snaps.len() - fin.passes - 1..];
        let mut moved = 0;
        for w in passes.windows(2) {
            let (e0, d0) = &w[0];
            let (e1, d1) = &w[1];
            assert!(*e1 <= *e0 * (1.0 + 1e-12), "energy rose: {e0} -> {e1}");
            moved += d1.iter().zip(d0).filter(|(a, b)| a != b).count();
        }
        moved
    };
    let (m_local, m_global) = (moved(&snaps), moved(&global_snaps));
    eprintln!("finishing moved {m_local} nodes locally, {m_global} globally");
    assert!(2 * m_local < m_global, "{m_local} vs {m_global}");
    assert!(local.displacement != global.displacement);
    assert_eq!(local.cracks, global.cracks);
}

#[test]
fn finishing_runs_open_tips_into_cracks_or_the_border() {
    // Stop early (few rounds, low residual constant) so cracks are left
    // open; finishing must run them on.
    let params = SimParams {
        max_rounds: 12,
        residual_constant: 0.0,
        alpha: 0.3,
        ..Default::default()
    };
    let mut open = jittered_plate(24, 0.3, 5);
    let r0 = run(&mut open, &params, &mut ()).unwrap();
    let st_tips = |mesh: &SimMesh, r: &SimReport| {
        // Tips as the finisher sees them (residuals do not matter for counting).
        let mut st = State::new(
            mesh,
            &SimParams::default(),
            [Vec::new(), Vec::new()],
            Vec::new(),
            None,
            Elements {
                elements: Vec::new(),
                clamp: 0.0,
            },
            r.length_unit,
        );
        st.grow(mesh);
        finish_tips(mesh, &st).len()
    };
    let before = st_tips(&open, &r0);
    assert!(before > 3, "the early stop leaves open tips: {before}");
    let mut done = jittered_plate(24, 0.3, 5);
    let r1 = run(
        &mut done,
        &SimParams {
            finish: true,
            ..params.clone()
        },
        &mut (),
    )
    .unwrap();
    done.validate().unwrap();
    let fin = r1.finish.clone().unwrap();
    assert_eq!(fin.tips, before, "{fin:?}");
    assert!(fin.cracks > 0 && fin.length > 0.0, "{fin:?}");
    let after = st_tips(&done, &r1);
    eprintln!("finishing: {before} tips before, {after} after: {fin:?}");
    assert_eq!(after, fin.stuck);
    assert!(
        after * 4 <= before,
        "finishing closes most tips: {before} before, {after} after ({fin:?})"
    );
    // The main run is the same up to finishing: its segments come first,
    // in order, each whole or in pieces where a finishing crack ends on it.
    let mut k = 0;
    for s in &r0.segments {
        assert_eq!(r1.segments[k][0], s[0], "segment {k}");
        while r1.segments[k][1] != s[1] {
            k += 1;
            assert_eq!(r1.segments[k][0], r1.segments[k - 1][1], "pieces of {s:?}");
        }
        k += 1;
    }
    // Every crack node has a crack time, within the run; others none.
    for v in done.vertices() {
        let on_crack = done
            .vertex_outgoing(v)
            .any(|h| done.is_crack_halfedge(h) || done.is_crack_halfedge(done.prev(h)));
        let t = r1.crack_time[v.idx()];
        assert_eq!(on_crack, !t.is_nan(), "vertex {v}");
        if on_crack {
            assert!(t >= 0.0 && t <= r1.time, "{t}");
        }
    }
    assert_eq!(r1.displacement.len(), done.n_vertices());
}

#[test]
fn duplicates_inherit_displacement_so_crack_sides_start_together() {
    let mut mesh = jittered_plate(16, 0.3, 9);
    let r = run(&mut mesh, &SimParams::default(), &mut ()).unwrap();
    assert!(r.cracks > 5);
    // The two sides of a crack moved apart (the gap opens): for crack
    // copies of one root, the displacement differs; for the whole mesh
    // the displacement is finite.
    assert!(r.displacement.iter().flatten().all(|x| x.is_finite()));
    let mut opened = 0;
    for v in mesh.vertices() {
        let p = mesh.vertex_parent(v);
        if p != v {
            let d = v3::norm(v3::sub(r.displacement[v.idx()], r.displacement[p.idx()]));
            if d > 1e-6 * r.length_unit {
                opened += 1;
            }
        }
    }
    assert!(opened > 0, "crack sides move apart");
}
