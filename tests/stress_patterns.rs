//! Stress initialisers shape the crack pattern as the paper describes:
//! impacts crack radially near the point, wood grain cracks across the grain,
//! tree rings crack radially; the texture-mask preset cracks where its image
//! is dark and the curvature preset where the surface bends.

mod common;

use crackle::mesh::SimMesh;
use crackle::pipeline::{machinery, Bounds, Pipeline, Placement};
use crackle::sim::{run_with, SimParams, SimReport};
use crackle::stress::{StressField, Term, TermKind};

/// The shared jittered plate: `n` x `n` cells, interior nodes jittered by
/// up to 0.3 of a cell.
fn plate(n: usize, seed: u64) -> SimMesh {
    crackle::mesh::shapes::jittered_plate(n, 0.3, seed)
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
            radial_cracks: 0,
            in_turn: false,
        },
        init: 6.0,
        evolve: 0.0,
        mask: None,
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
            checks: None,
        },
        init: 0.0,
        evolve: 0.05,
        mask: None,
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
        mask: None,
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

/// A preset run through the library on a fixture: the simulation mesh
/// before and after, and the report.
fn run_preset(fixture: &str, preset: &str) -> (SimMesh, SimMesh, SimReport, Pipeline) {
    let path = common::fixture(fixture);
    let scene = crackle::io::read(&path).unwrap();
    let (entries, _) = crackle::bridge::build_sim_meshes(&scene, &Default::default());
    let mut p = Pipeline::preset(preset, &[]).unwrap();
    p.load_images(None).unwrap();
    let masks = machinery::masks_for(&p, &scene, path.parent().unwrap()).unwrap();
    let before = entries[0].sim.clone();
    let mut mesh = before.clone();
    let b = Bounds::of(mesh.vertices().map(|v| mesh.position(v)));
    let terms = machinery::terms(&p, &Placement::local(b), &masks).unwrap();
    let params = p.params(&[]);
    let field = StressField::build(&mesh, &terms, params.seed).unwrap();
    let r = run_with(&mut mesh, &params, Some(&field), &mut ()).unwrap();
    mesh.validate().unwrap();
    (before, mesh, r, p)
}

/// The affine map from (x, z) to TEXCOORD_0 of a flat plate in y = 0,
/// fitted on one of its faces.
fn plate_uv_map(mesh: &SimMesh) -> impl Fn([f64; 3]) -> [f64; 2] {
    let ch = mesh.wedges().channel("TEXCOORD_0").unwrap().clone();
    let f = mesh.faces().next().unwrap();
    let p = mesh.face_vertices(f).map(|v| mesh.position(v));
    let t = mesh.face_wedges(f).map(|w| [ch.get(w)[0], ch.get(w)[1]]);
    // Solve [dx1 dz1; dx2 dz2] A = [du1 dv1; du2 dv2].
    let (a, b) = (
        [p[1][0] - p[0][0], p[1][2] - p[0][2]],
        [p[2][0] - p[0][0], p[2][2] - p[0][2]],
    );
    let det = a[0] * b[1] - a[1] * b[0];
    let inv = [[b[1] / det, -a[1] / det], [-b[0] / det, a[0] / det]];
    let du = [t[1][0] - t[0][0], t[2][0] - t[0][0]];
    let dv = [t[1][1] - t[0][1], t[2][1] - t[0][1]];
    let gu = [
        inv[0][0] * du[0] + inv[0][1] * du[1],
        inv[1][0] * du[0] + inv[1][1] * du[1],
    ];
    let gv = [
        inv[0][0] * dv[0] + inv[0][1] * dv[1],
        inv[1][0] * dv[0] + inv[1][1] * dv[1],
    ];
    let (o, t0) = (p[0], t[0]);
    move |q: [f64; 3]| {
        let (dx, dz) = (q[0] - o[0], q[2] - o[2]);
        [
            t0[0] + gu[0] * dx + gu[1] * dz,
            t0[1] + gv[0] * dx + gv[1] * dz,
        ]
    }
}

#[test]
fn texture_mask_preset_cracks_only_where_the_mask_is_dark() {
    let (before, _, r, p) = run_preset("plate_jittered.obj", "texture-mask");
    let mask = machinery::image_mask(&p, 0).unwrap();
    let uv = plate_uv_map(&before);
    // The map is right: it reproduces every vertex's UV.
    let ch = before.wedges().channel("TEXCOORD_0").unwrap();
    for f in before.faces() {
        for (v, w) in before
            .face_vertices(f)
            .into_iter()
            .zip(before.face_wedges(f))
        {
            let m = uv(before.position(v));
            assert!((m[0] - ch.get(w)[0]).abs() < 1e-5 && (m[1] - ch.get(w)[1]).abs() < 1e-5);
        }
    }
    let weight = |m: [f64; 3]| mask.weight(uv(m));
    let (dark, white) = mask_shares(&r, &weight, 0.5);
    let mut quadrants = [0.0; 4];
    for (m, _, l) in segments(&r) {
        if weight(m) >= 0.5 {
            let q = uv(m);
            quadrants[usize::from(q[0] > 0.5) + 2 * usize::from(q[1] > 0.5)] += l;
        }
    }
    eprintln!(
        "texture-mask: {} cracks, {dark:.3} of the length dark, {white:.3} white, per quadrant {quadrants:.3?}",
        r.cracks
    );
    assert!(r.cracks > 20, "{r:?}");
    assert!(
        dark > 0.9 && white < 0.02,
        "cracks where the mask is dark: {dark:.3} of the length, where it is white: {white:.3}"
    );
    // Every blotch cracks (they lie in three different UV quadrants).
    assert!(
        quadrants.iter().filter(|&&x| x > 0.1).count() >= 3,
        "{quadrants:?}"
    );
}

#[test]
fn curvature_preset_gathers_cracks_where_curvature_is_high() {
    let (before, _, r, _) = run_preset("bumps.obj", "curvature");
    let k = crackle::geometry::curvature::estimate(&before);
    // Split the faces by the median curvature; crack length per area in each half.
    let faces: Vec<_> = before.faces().collect();
    let mut order: Vec<f64> = faces
        .iter()
        .map(|f| k.per_face[f.idx()].frobenius())
        .collect();
    order.sort_by(f64::total_cmp);
    let median = order[order.len() / 2];
    let centroid = |f| {
        let [a, b, c] = before.face_vertices(f).map(|v| before.position(v));
        [
            (a[0] + b[0] + c[0]) / 3.0,
            (a[1] + b[1] + c[1]) / 3.0,
            (a[2] + b[2] + c[2]) / 3.0,
        ]
    };
    let cents: Vec<[f64; 3]> = faces.iter().map(|&f| centroid(f)).collect();
    let high: Vec<bool> = faces
        .iter()
        .map(|f| k.per_face[f.idx()].frobenius() > median)
        .collect();
    let mut area = [0.0; 2];
    for (i, f) in faces.iter().enumerate() {
        area[usize::from(high[i])] += before.face_area(*f);
    }
    let mut length = [0.0; 2];
    for (m, _, l) in segments(&r) {
        let d2 = |c: &[f64; 3]| (0..3).map(|k| (c[k] - m[k]).powi(2)).sum::<f64>();
        let i = (0..cents.len())
            .min_by(|&a, &b| d2(&cents[a]).total_cmp(&d2(&cents[b])))
            .unwrap();
        length[usize::from(high[i])] += l;
    }
    let density = [length[0] / area[0], length[1] / area[1]];
    eprintln!(
        "curvature: {} cracks, crack length per area high {:.2} low {:.2}",
        r.cracks, density[1], density[0]
    );
    assert!(r.cracks > 20, "{r:?}");
    assert!(
        density[1] > 3.0 * density[0],
        "crack length per area: high-curvature half {:.2}, low half {:.2}",
        density[1],
        density[0]
    );
}

#[test]
fn texture_mask_on_a_mesh_without_uvs_cracks_where_the_projected_mask_is_dark() {
    // The icosphere has no UV set: the mask is projected along the three
    // axes over the box (triplanar, blended by the normal to the fourth
    // power), as the README says; the same projection here, by hand.
    let (before, _, r, p) = run_preset("icosphere.obj", "texture-mask");
    let mask = machinery::image_mask(&p, 0).unwrap();
    let pts: Vec<[f64; 3]> = before.vertices().map(|v| before.position(v)).collect();
    let lo = [0, 1, 2].map(|k| pts.iter().map(|q| q[k]).fold(f64::INFINITY, f64::min));
    let hi = [0, 1, 2].map(|k| pts.iter().map(|q| q[k]).fold(f64::NEG_INFINITY, f64::max));
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let weight = |m: [f64; 3]| {
        let d: Vec<f64> = (0..3).map(|k| m[k] - centre[k]).collect();
        let l = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        let (mut sum, mut total) = (0.0, 0.0);
        for (axis, [a, b]) in [(0, [1, 2]), (1, [0, 2]), (2, [0, 1])] {
            let w = (d[axis] / l).powi(4);
            sum += w * mask.weight([(m[a] - lo[a]) / size, (m[b] - lo[b]) / size]);
            total += w;
        }
        sum / total
    };
    let (dark, white) = mask_shares(&r, &weight, 0.3);
    eprintln!(
        "texture-mask without UVs: {} cracks, {dark:.3} of the length where the projected mask is dark, {white:.3} white",
        r.cracks
    );
    assert!(r.cracks > 20, "{r:?}");
    assert!(
        dark > 0.8 && white < 0.05,
        "{dark:.3} dark, {white:.3} white"
    );
}

/// The shares of `r`'s crack length (by segment middle) where the mask's
/// `weight` is at least `dark_at`, and where it is below 0.05 (white).
fn mask_shares(r: &SimReport, weight: &dyn Fn([f64; 3]) -> f64, dark_at: f64) -> (f64, f64) {
    let (mut total, mut dark, mut white) = (0.0, 0.0, 0.0);
    for (m, _, l) in segments(r) {
        let w = weight(m);
        total += l;
        if w >= dark_at {
            dark += l;
        }
        if w < 0.05 {
            white += l;
        }
    }
    (dark / total, white / total)
}
