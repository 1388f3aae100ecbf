//! Stress initialisers shape the crack pattern as the paper describes:
//! impacts crack radially near the point, wood grain cracks across the grain,
//! tree rings crack radially.

use crackle::mesh::{MeshInput, SimMesh};
use crackle::sim::{run_with, SimParams, SimReport};
use crackle::stress::{StressField, Term, TermKind};

/// An n x n plate of unit cells in z = 0, interior nodes jittered.
fn plate(n: usize, seed: u64) -> SimMesh {
    let mut state = seed;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (mut x, mut y) = (i as f64, j as f64);
            if i > 0 && i < n && j > 0 && j < n {
                x += 0.3 * (2.0 * rnd() - 1.0);
                y += 0.3 * (2.0 * rnd() - 1.0);
            }
            positions.push([x, y, 0.0]);
        }
    }
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = (j * (n + 1) + i) as u32;
            let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32 + 2);
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    let input = MeshInput {
        positions,
        triangles,
        ..Default::default()
    };
    SimMesh::build(&input, &Default::default()).unwrap().0
}

/// Crack segments as (midpoint, unit direction, length).
fn segments(r: &SimReport) -> Vec<([f64; 3], [f64; 3], f64)> {
    r.segments
        .iter()
        .filter_map(|[a, b]| {
            let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            (l > 0.0).then(|| {
                (
                    [
                        (a[0] + b[0]) / 2.0,
                        (a[1] + b[1]) / 2.0,
                        (a[2] + b[2]) / 2.0,
                    ],
                    [d[0] / l, d[1] / l, d[2] / l],
                    l,
                )
            })
        })
        .collect()
}

fn run(mesh: &mut SimMesh, terms: &[Term], params: &SimParams) -> SimReport {
    let field = StressField::build(mesh, terms, params.seed).unwrap();
    let r = run_with(mesh, params, Some(&field), &mut ()).unwrap();
    mesh.validate().unwrap();
    r
}

#[test]
fn impact_cracks_radially_near_the_point() {
    let n = 40;
    let mut mesh = plate(n, 3);
    let c = [20.0, 20.0, 0.0];
    let radius = 14.0;
    let terms = [Term {
        kind: TermKind::Impact {
            points: vec![[c[0], c[1], 2.0]],
            radius,
            concentric_factor: 1.25,
        },
        init: 6.0,
        evolve: 0.0,
    }];
    let params = SimParams {
        shrink_rate: 0.0,
        fixed_boundary: true,
        residual_constant: 0.0,
        alpha: 0.5,
        ..Default::default()
    };
    let r = run(&mut mesh, &terms, &params);
    let (mut near, mut near_radial, mut far, mut far_conc) = (0.0, 0.0, 0.0, 0.0);
    for (m, d, l) in segments(&r) {
        let rv = [m[0] - c[0], m[1] - c[1]];
        let dist = (rv[0] * rv[0] + rv[1] * rv[1]).sqrt();
        if dist < 1e-9 {
            continue;
        }
        let cos = ((rv[0] * d[0] + rv[1] * d[1]) / dist).abs();
        if dist < 0.5 * radius {
            near += l;
            if cos > 30f64.to_radians().cos() {
                near_radial += l;
            }
        } else {
            far += l;
            if cos < 60f64.to_radians().cos() {
                far_conc += l;
            }
        }
    }
    // Random directions would give 1/3 in both bins.
    assert!(
        near > 20.0 && far > 20.0,
        "cracks near {near} and far {far}"
    );
    assert!(
        near_radial / near > 0.55,
        "near the point cracks run radially: {:.2} of {near:.1}",
        near_radial / near
    );
    assert!(
        far_conc / far > 0.42,
        "further out cracks run around: {:.2} of {far:.1}",
        far_conc / far
    );
}

/// Fraction of crack length whose direction is within `deg` of `axis` (2D).
fn fraction_along(r: &SimReport, axis: [f64; 2], deg: f64) -> f64 {
    let (mut total, mut along) = (0.0, 0.0);
    for (_, d, l) in segments(r) {
        total += l;
        if (d[0] * axis[0] + d[1] * axis[1]).abs() > deg.to_radians().cos() {
            along += l;
        }
    }
    along / total
}

#[test]
fn wood_grain_cracks_across_the_stress() {
    let mut mesh = plate(40, 5);
    let terms = [Term {
        kind: TermKind::Directional {
            direction: [1.0, 0.0, 0.0],
        },
        init: 0.0,
        evolve: 0.05,
    }];
    let params = SimParams {
        shrink_rate: 0.0,
        ..Default::default()
    };
    let r = run(&mut mesh, &terms, &params);
    let across = fraction_along(&r, [0.0, 1.0], 30.0);
    let along = fraction_along(&r, [1.0, 0.0], 30.0);
    assert!(r.cracks > 20, "{r:?}");
    assert!(
        across > 0.8 && along < 0.1,
        "cracks run across the x stress: {across:.2} across, {along:.2} along"
    );
}

#[test]
fn tree_rings_crack_radially() {
    let mut mesh = plate(40, 7);
    let c = [20.0, 20.0];
    let terms = [Term {
        kind: TermKind::Concentric {
            center: [c[0], c[1], 0.0],
            axis: [0.0, 0.0, 1.0],
        },
        init: 0.0,
        evolve: 0.05,
    }];
    let params = SimParams {
        shrink_rate: 0.0,
        ..Default::default()
    };
    let r = run(&mut mesh, &terms, &params);
    let (mut total, mut radial) = (0.0, 0.0);
    for (m, d, l) in segments(&r) {
        let rv = [m[0] - c[0], m[1] - c[1]];
        let dist = (rv[0] * rv[0] + rv[1] * rv[1]).sqrt();
        if dist < 2.0 {
            continue;
        }
        total += l;
        if ((rv[0] * d[0] + rv[1] * d[1]) / dist).abs() > 30f64.to_radians().cos() {
            radial += l;
        }
    }
    assert!(r.cracks > 20, "{r:?}");
    assert!(
        radial / total > 0.8,
        "cracks run across the rings: {:.2} radial",
        radial / total
    );
}
