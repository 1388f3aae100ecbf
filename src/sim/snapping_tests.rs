//! Tests of the snapping variant's crack loop: cracks that follow the
//! existing edges, runs to the end, eigenvalue diffusion (kept local).

use super::*;
use crate::math::Sym3;
use crate::mesh::shapes::jittered_plate;
use crate::mesh::VertexId;
use crate::sim::{diffusion::*, params::*};

fn impact_params() -> (SimParams, Vec<crate::stress::Term>) {
    let params = SimParams {
        shrink_rate: 0.0,
        alpha: 0.5,
        residual_constant: 0.0,
        fixed_boundary: true,
        ..Default::default()
    };
    let terms = vec![crate::stress::Term {
        kind: crate::stress::TermKind::Impact {
            points: vec![[12.0, 12.0, 0.0]],
            radius: 7.0,
            concentric_factor: 1.25,
            radial_cracks: 0,
            in_turn: false,
        },
        init: 3.0,
        evolve: 0.0,
        mask: None,
    }];
    (params, terms)
}

#[test]
fn without_remeshing_cracks_follow_existing_edges() {
    let (base, terms) = impact_params();
    let mut mesh = jittered_plate(24, 0.3, 5);
    let original: Vec<[f64; 3]> = mesh.positions().to_vec();
    let field = StressField::build(&mesh, &terms, 1).unwrap();
    let params = SimParams {
        remesh: false,
        ..base
    };
    let r = run_with(&mut mesh, &params, Some(&field), &mut ()).unwrap();
    mesh.validate().unwrap();
    assert!(r.cracks > 5, "{}", r.cracks);
    assert_eq!(r.triangles[0], r.triangles[1], "no triangle split");
    // Every crack segment joins two input vertices.
    let is_input = |p: [f64; 3]| original.contains(&p);
    for s in &r.segments {
        assert!(is_input(s[0]) && is_input(s[1]), "{s:?}");
    }
}

#[test]
fn to_end_propagation_runs_each_crack_on_from_its_tip() {
    let (base, terms) = impact_params();
    let chained = |propagation| {
        let mut mesh = jittered_plate(24, 0.3, 5);
        let field = StressField::build(&mesh, &terms, 1).unwrap();
        let params = SimParams {
            propagation,
            ..base.clone()
        };
        let r = run_with(&mut mesh, &params, Some(&field), &mut ()).unwrap();
        mesh.validate().unwrap();
        // Segments that start where the one before ended.
        let follow = r
            .segments
            .windows(2)
            .filter(|w| w[1][0] == w[0][1] || w[1][1] == w[0][1])
            .count();
        (follow as f64 / r.segments.len().max(1) as f64, r.cracks)
    };
    let (queue, n_queue) = chained(Propagation::Queue);
    let (to_end, n_to_end) = chained(Propagation::ToEnd);
    eprintln!("segments continuing the previous one: queue {queue:.2} ({n_queue} cracks), to-end {to_end:.2} ({n_to_end})");
    assert!(n_to_end > 5);
    assert!(to_end > 0.5 && to_end > queue + 0.1, "{to_end} vs {queue}");
}

#[test]
fn eigen_diffusion_spreads_and_conserves_the_eigenvalues() {
    let (base, terms) = impact_params();
    let mesh = jittered_plate(12, 0.3, 5);
    let field = StressField::build(&mesh, &terms, 1).unwrap();
    let params = SimParams {
        relaxation: Relaxation::EigenDiffusion,
        diffusion_passes: 1,
        diffusion_fraction: 0.05,
        ..base
    };
    let (mut st, _) = start(&mesh, &params, Some(&field)).unwrap();
    // A peak on one node, a flat positive field elsewhere.
    let mut fz = vec![Sym3::outer([1.0, 0.0, 0.0]) * 1.0; mesh.n_vertices()];
    fz[60] = Sym3::outer([0.0, 1.0, 0.0]) * 10.0;
    st.freeze(fz);
    let eig = |st: &State| -> Vec<f64> {
        (0..mesh.n_vertices())
            .map(|v| node_separation(&mesh, st, VertexId(v as u32)).max_eigen().0)
            .collect()
    };
    let before = eig(&st);
    eigen_diffusion(&mesh, &mut st, &params);
    let after = eig(&st);
    let (s0, s1): (f64, f64) = (before.iter().sum(), after.iter().sum());
    assert!((s0 - s1).abs() < 1e-9 * s0, "{s0} -> {s1}");
    // The peak gives 5% (0.5) and takes back its neighbours' small shares.
    assert!(after[60] > 9.5 && after[60] < 9.6, "{}", after[60]);
    let gained = (0..mesh.n_vertices())
        .filter(|&v| after[v] > before[v] + 1e-3)
        .count();
    assert!(gained >= 4, "the peak's neighbours gain: {gained}");
    // Its direction stays: the peak's largest eigenvector is still y.
    let (_, dir) = node_separation(&mesh, &st, VertexId(60)).max_eigen();
    assert!(dir[1].abs() > 0.999, "{dir:?}");
    // The run with diffusion differs from the one without.
    let run = |passes| {
        let mut m = jittered_plate(24, 0.3, 5);
        let f = StressField::build(&m, &terms, 1).unwrap();
        let p = SimParams {
            relaxation: Relaxation::EigenDiffusion,
            remesh: false,
            propagation: Propagation::ToEnd,
            diffusion_passes: passes,
            ..params.clone()
        };
        let r = run_with(&mut m, &p, Some(&f), &mut ()).unwrap();
        m.validate().unwrap();
        r
    };
    let (plain, diffused) = (run(0), run(30));
    assert!(plain.cracks > 0 && diffused.cracks > 0);
    assert_ne!(plain.segments, diffused.segments);
    assert_eq!(plain.relax_steps, 0, "no tensor relaxation");
    // A load that builds up over the rounds (shrinkage, no starting
    // stress) reaches the frozen separations too.
    let mut m = jittered_plate(16, 0.3, 5);
    let p = SimParams {
        relaxation: Relaxation::EigenDiffusion,
        max_rounds: 60,
        ..Default::default()
    };
    let r = run_with(&mut m, &p, None, &mut ()).unwrap();
    m.validate().unwrap();
    assert!(r.cracks > 0, "shrinkage cracks under eigen-diffusion too");
}

/// Eigen-diffusion stays local: the same impact (same element size,
/// same hit) on a plate with 4 times the elements costs about the same
/// diffusion work per crack (a sweep of the whole mesh after every
/// crack run cost 4 times as much: 5.5 s at 5.8k triangles, 427 s at
/// 28.8k), and the mesh stays valid.
#[test]
fn eigen_diffusion_work_does_not_grow_with_the_mesh() {
    let (base, terms) = impact_params();
    let params = SimParams {
        relaxation: Relaxation::EigenDiffusion,
        remesh: false,
        propagation: Propagation::ToEnd,
        diffusion_passes: 10,
        diffusion_fraction: 0.05,
        ..base
    };
    let per_crack = |n: usize| {
        let mut m = jittered_plate(n, 0.3, 5);
        let f = StressField::build(&m, &terms, 1).unwrap();
        let r = run_with(&mut m, &params, Some(&f), &mut ()).unwrap();
        m.validate().unwrap();
        assert!(r.cracks > 10 && r.diffusion_work > 0, "{}", r.cracks);
        eprintln!(
            "{n}x{n}: {} triangles, {} cracks, {} diffusion visits",
            m.n_faces(),
            r.cracks,
            r.diffusion_work
        );
        r.diffusion_work as f64 / r.cracks as f64
    };
    let (small, large) = (per_crack(24), per_crack(48));
    assert!(
        large < 1.5 * small,
        "{small:.0} -> {large:.0} visits per crack"
    );
}
