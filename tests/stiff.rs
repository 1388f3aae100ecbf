//! Stiff and extreme cases: each run must finish with finite values, a
//! valid mesh and a non-increasing energy while nothing loads it, or fail
//! with a clear error. Never NaN, a hang or a panic.

mod common;

use crackle::mesh::{MeshInput, SimMesh};
use crackle::sim::{run_with, Observer, SimParams, SimReport, Snapshot};
use crackle::stress::{StressField, Term, TermKind};

/// Energy and finiteness at every snapshot of a run.
#[derive(Default)]
struct Log {
    energy: Vec<f64>,
    non_finite: usize,
}

impl Observer for Log {
    fn wants_state(&self) -> bool {
        true
    }
    fn state(&mut self, s: &Snapshot) {
        self.energy.push(s.energy);
        self.non_finite += s
            .displacement
            .iter()
            .flatten()
            .filter(|x| !x.is_finite())
            .count();
    }
}

/// An `n` x `n` grid over the unit square (split along a diagonal), inner
/// vertices jittered by `jitter` cells.
fn plate(n: usize, jitter: f64, seed: u64) -> MeshInput {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut rnd = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (mut x, mut y) = (i as f64, j as f64);
            if i > 0 && i < n && j > 0 && j < n {
                x += jitter * rnd();
                y += jitter * rnd();
            }
            positions.push([x / n as f64, y / n as f64, 0.0]);
        }
    }
    MeshInput {
        positions,
        triangles: grid_triangles(n, n),
        ..Default::default()
    }
}

fn grid_triangles(nx: usize, ny: usize) -> Vec<[u32; 3]> {
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut t = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    t
}

/// A 12 x 12 plate with one extra row of triangles of aspect ratio
/// `aspect` (cell width over height) across its middle.
fn sliver_plate(aspect: f64) -> MeshInput {
    let n = 12;
    let mut ys: Vec<f64> = (0..=n).map(|j| j as f64 / n as f64).collect();
    ys.insert(n / 2 + 1, 0.5 + 1.0 / (n as f64 * aspect));
    let mut positions = Vec::new();
    for &y in &ys {
        for i in 0..=n {
            positions.push([i as f64 / n as f64, y, 0.0]);
        }
    }
    MeshInput {
        positions,
        triangles: grid_triangles(n, ys.len() - 1),
        ..Default::default()
    }
}

/// A disc of radius 1 whose rings grow geometrically from radius
/// `1 / ratio`: triangle sizes `ratio` apart, all of them well shaped.
fn graded_disc(ratio: f64) -> MeshInput {
    let n = 16usize;
    let q = 1.0 + 2.0 * std::f64::consts::PI / n as f64;
    let rings = (ratio.ln() / q.ln()).ceil() as usize;
    let mut positions = vec![[0.0, 0.0, 0.0]];
    for k in 0..=rings {
        let r = (q.powi(k as i32) / ratio).min(1.0);
        for a in 0..n {
            let t = 2.0 * std::f64::consts::PI * (a as f64 + 0.5 * (k % 2) as f64) / n as f64;
            positions.push([r * t.cos(), r * t.sin(), 0.0]);
        }
    }
    let id = |k: usize, a: usize| (1 + k * n + a % n) as u32;
    let mut triangles = Vec::new();
    for a in 0..n {
        triangles.push([0, id(0, a), id(0, a + 1)]);
    }
    for k in 0..rings {
        for a in 0..n {
            // Odd rings are turned half a step.
            let (b0, b1) = (id(k, a), id(k, a + 1));
            let (t0, t1) = if k % 2 == 0 {
                (id(k + 1, a), id(k + 1, a + 1))
            } else {
                (id(k + 1, a + 1), id(k + 1, a + 2))
            };
            triangles.push([b0, t0, b1]);
            triangles.push([b1, t0, t1]);
        }
    }
    MeshInput {
        positions,
        triangles,
        ..Default::default()
    }
}

fn build(input: &MeshInput) -> SimMesh {
    SimMesh::build(input, &Default::default()).unwrap().0
}

/// Uniform starting stress `init`, no load afterwards: relaxation and
/// cracking only, so the energy must never rise.
fn released(toughness: f64) -> SimParams {
    SimParams {
        toughness,
        shrink_rate: 0.0,
        load_time: 0.0,
        max_rounds: 40,
        ..Default::default()
    }
}

fn field(mesh: &SimMesh, init: f64) -> StressField {
    let terms = [Term {
        kind: TermKind::Uniform,
        init,
        evolve: 0.0,
        mask: None,
    }];
    StressField::build(mesh, &terms, 1).unwrap()
}

/// Run and check the invariants; returns the report.
fn check(name: &str, mesh: &mut SimMesh, params: &SimParams, init: f64) -> SimReport {
    let f = field(mesh, init);
    let mut log = Log::default();
    let r = run_with(mesh, params, Some(&f), &mut log)
        .unwrap_or_else(|e| panic!("{name}: the run failed: {e}"));
    mesh.validate()
        .unwrap_or_else(|e| panic!("{name}: invalid mesh: {e}"));
    assert_eq!(log.non_finite, 0, "{name}: non-finite displacement");
    assert!(
        mesh.positions().iter().flatten().all(|x| x.is_finite()),
        "{name}: non-finite position"
    );
    assert!(
        r.energy.iter().all(|e| e.is_finite()) && r.crack_length.is_finite(),
        "{name}: {:?}",
        r.energy
    );
    assert!(log.energy.len() >= 2, "{name}: no snapshots");
    eprintln!(
        "{name}: {} cracks, {} snapshots, energy {:.3e} -> {:.3e}, stopped: {}",
        r.cracks,
        log.energy.len(),
        log.energy[0],
        log.energy[log.energy.len() - 1],
        r.stopped
    );
    for (k, w) in log.energy.windows(2).enumerate() {
        assert!(
            w[1] <= w[0] * (1.0 + 1e-9) + 1e-300,
            "{name}: energy rose from {} to {} after round {k}",
            w[0],
            w[1]
        );
    }
    r
}

#[test]
fn slivers_up_to_aspect_1e6_stay_finite_and_stable() {
    for aspect in [1e2, 1e4, 1e6] {
        let mut m = build(&sliver_plate(aspect));
        let r = check(&format!("aspect {aspect:e}"), &mut m, &released(2.0), 3.0);
        assert!(r.cracks > 0, "aspect {aspect:e}: the plate cracks");
    }
}

#[test]
fn triangle_sizes_1e4_apart_stay_finite_and_stable() {
    let input = graded_disc(1e4);
    let areas: Vec<f64> = input
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| input.positions[i as usize]);
            0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs()
        })
        .collect();
    let (lo, hi) = areas
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), &a| (l.min(a), h.max(a)));
    assert!(
        (hi / lo).sqrt() > 5e3,
        "sizes are 1e4 apart: {}",
        (hi / lo).sqrt()
    );
    let mut m = build(&input);
    let r = check("graded disc", &mut m, &released(2.0), 3.0);
    assert!(r.cracks > 0);
}

#[test]
fn the_pattern_does_not_depend_on_the_scale() {
    let cracks = |s: f64| {
        let mut input = plate(14, 0.3, 5);
        for p in &mut input.positions {
            *p = p.map(|x| x * s);
        }
        let mut m = build(&input);
        check(&format!("scale {s:e}"), &mut m, &released(2.0), 3.0).cracks
    };
    let base = cracks(1.0);
    assert!(base > 5);
    for s in [1e-6, 1e6] {
        let c = cracks(s);
        let diff = (c as f64 - base as f64).abs() / base as f64;
        assert!(diff <= 0.05, "scale {s:e}: {c} cracks against {base}");
    }
}

#[test]
fn toughness_zero_and_above_any_stress_both_terminate() {
    // Above any stress: nothing cracks.
    let mut m = build(&plate(10, 0.3, 2));
    let r = check("toughness 1e30", &mut m, &released(1e30), 3.0);
    assert_eq!(r.cracks, 0);
    // Zero: everything that can crack does, and the run still ends (or the
    // value is refused with an error naming it).
    let mut m = build(&plate(10, 0.3, 2));
    let f = field(&m, 3.0);
    match run_with(&mut m, &released(0.0), Some(&f), &mut ()) {
        Ok(r) => {
            m.validate().unwrap();
            assert!(r.cracks > 0);
            assert!(r.energy.iter().all(|e| e.is_finite()));
        }
        Err(e) => assert!(e.to_string().contains("toughness"), "{e}"),
    }
}

#[test]
fn alpha_and_the_long_crack_constant_at_their_ends() {
    for (alpha, constant) in [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)] {
        let mut m = build(&plate(12, 0.3, 3));
        let p = SimParams {
            alpha,
            residual_constant: constant,
            ..released(2.0)
        };
        check(
            &format!("alpha {alpha} constant {constant}"),
            &mut m,
            &p,
            3.0,
        );
    }
}

#[test]
fn stress_magnitudes_1e_minus12_and_1e12() {
    let mut m = build(&plate(10, 0.3, 4));
    let r = check("stress 1e-12", &mut m, &released(2.0), 1e-12);
    assert_eq!(r.cracks, 0);
    let mut m = build(&plate(10, 0.3, 4));
    let r = check("stress 1e12", &mut m, &released(2.0), 1e12);
    assert!(r.cracks > 0);
}

#[test]
fn a_step_far_above_stability_is_handled() {
    let mut m = build(&plate(12, 0.3, 6));
    let els = crackle::sim::Elements::new(&m, f64::INFINITY);
    let stable = crackle::sim::stable_dt(&m, &els);
    assert!(stable.is_finite() && stable > 0.0);
    let p = SimParams {
        relax_dt: 100.0 * stable,
        ..released(2.0)
    };
    let r = check("dt 100x stable", &mut m, &p, 3.0);
    assert!(r.cracks > 0);
    // The report says so.
    assert!(r.dt_limited_rounds > 0 && r.stable_dt < p.relax_dt, "{r:?}");
    let mut m = build(&plate(12, 0.3, 6));
    let r = check("default dt", &mut m, &released(2.0), 3.0);
    assert_eq!(r.dt_limited_rounds, 0);
}

/// Two plates touching at one corner (a non-manifold vertex the mesh
/// builder splits); cracks reach the split vertex.
#[test]
fn cracks_reach_a_split_non_manifold_vertex() {
    let a = plate(6, 0.0, 1);
    let mut input = a.clone();
    let base = a.positions.len() as u32;
    // The second plate shares the first one's corner (1, 1).
    for p in &a.positions {
        input.positions.push([p[0] + 1.0, p[1] + 1.0, 0.0]);
    }
    let corner = a
        .positions
        .iter()
        .position(|p| *p == [1.0, 1.0, 0.0])
        .unwrap() as u32;
    let origin = a
        .positions
        .iter()
        .position(|p| *p == [0.0, 0.0, 0.0])
        .unwrap() as u32;
    for t in &a.triangles {
        input
            .triangles
            .push(t.map(|i| if i == origin { corner } else { i + base }));
    }
    let (mut m, report) = SimMesh::build(&input, &Default::default()).unwrap();
    assert_eq!(report.non_manifold_vertices, 1, "{report:?}");
    assert_eq!(report.components, 2, "{report:?}");
    let r = check("bow tie", &mut m, &released(1.0), 3.0);
    assert!(r.cracks > 0);
}

/// `eval-data` ogre: 44 open components and zero-area triangles.
#[test]
fn the_ogre_with_44_components_cracks() {
    let Some(ogre) = common::eval_data("obj/ogre/ogre.obj") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ogre.glb");
    let o = common::crack(&ogre, &out, &["--max-rounds", "6"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = common::report(&out);
    assert!(r["cracks"].as_u64().unwrap() > 0);
    let e = &r["energy"];
    assert!(e["start"].as_f64().unwrap().is_finite() && e["end"].as_f64().unwrap().is_finite());
    if let Some(v) = common::validator() {
        v.assert_clean(&out);
    }
}

#[test]
fn every_integrator_stays_stable_on_slivers_and_mixed_sizes() {
    use crackle::sim::Integrator;
    for integrator in [
        Integrator::Euler,
        Integrator::Rkl,
        Integrator::BackwardEuler,
    ] {
        let params = SimParams {
            integrator,
            max_rounds: 12,
            ..released(2.0)
        };
        let mut m = build(&sliver_plate(1e6));
        check(
            &format!("{} on aspect 1e6", integrator.name()),
            &mut m,
            &params,
            3.0,
        );
        let mut m = build(&graded_disc(1e4));
        check(
            &format!("{} on the graded disc", integrator.name()),
            &mut m,
            &params,
            3.0,
        );
        // Unclamped gradients: the slivers' full stiffness.
        let stiff = SimParams {
            clamp_factor: 1e9,
            ..params.clone()
        };
        let mut m = build(&sliver_plate(1e4));
        check(
            &format!("{} on aspect 1e4 unclamped", integrator.name()),
            &mut m,
            &stiff,
            3.0,
        );
    }
}

/// A plate of `nx` x `ny` cells, each `aspect` times wider than high:
/// every triangle a sliver (a strip when `ny` is 1).
fn all_slivers(nx: usize, ny: usize, aspect: f64) -> MeshInput {
    let mut positions = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            positions.push([i as f64, j as f64 / aspect, 0.0]);
        }
    }
    MeshInput {
        positions,
        triangles: grid_triangles(nx, ny),
        ..Default::default()
    }
}

/// With the default settings (integrator `auto`), no mesh of slivers makes
/// a round take more than the auto limit of steps: strips and plates of
/// aspect 1e2 to 1e6 at three sizes all finish, with finite values, under a
/// shrinkage load, and the report says which scheme ran and why.
#[test]
fn default_runs_on_slivers_take_a_bounded_number_of_steps() {
    for aspect in [1e2, 1e3, 1e4, 1e5, 1e6] {
        for (nx, ny) in [(40, 1), (10, 10), (20, 20), (40, 40)] {
            let input = all_slivers(nx, ny, aspect);
            // Weld only identical positions: the slivers are thinner than
            // the default weld tolerance.
            let (mut mesh, _) = SimMesh::build(
                &input,
                &crackle::mesh::WeldOptions {
                    relative_tolerance: 0.0,
                },
            )
            .unwrap();
            let params = SimParams {
                max_rounds: 30,
                ..Default::default()
            };
            let r = crackle::sim::run(&mut mesh, &params, &mut ()).unwrap();
            let name = format!("aspect {aspect:e}, {nx} x {ny}");
            assert!(r.rounds > 0, "{name}");
            let per_round = r.relax_steps as f64 / r.rounds as f64;
            assert!(
                per_round <= crackle::sim::AUTO_STEP_LIMIT,
                "{name}: {per_round} steps a round with {} ({})",
                r.integrator,
                r.integrator_reason
            );
            assert!(
                r.integrator_reason.starts_with("auto"),
                "{name}: {}",
                r.integrator_reason
            );
            if aspect >= 1e4 {
                assert_eq!(
                    r.integrator, "backward-euler",
                    "{name}: {}",
                    r.integrator_reason
                );
            }
            assert!(r.energy[1].is_finite(), "{name}");
            mesh.validate().unwrap();
        }
    }
}

/// Work linear in the input on repeated faces and non-manifold fans (a
/// cube's faces repeated 1, 2 and 4 times took 6.5, 16.1 and 44.1 s of
/// CPU; a 2,000-triangle fan round one edge 85 s and stopped at round 23):
/// four copies of the cube's faces simulate on four times the triangles in
/// about as many relaxation steps, and fans of 500 and 2,000 triangles
/// finish in the same number of steps.
#[test]
fn repeated_faces_and_non_manifold_fans_take_linear_work() {
    let dir = tempfile::tempdir().unwrap();
    let cube = std::fs::read_to_string(common::fixture("cube.obj")).unwrap();
    let positions: Vec<&str> = cube.lines().filter(|l| l.starts_with("v ")).collect();
    let faces: Vec<String> = cube
        .lines()
        .filter(|l| l.starts_with("f "))
        .map(|l| {
            let corners: Vec<&str> = l[2..]
                .split_whitespace()
                .map(|c| c.split('/').next().unwrap())
                .collect();
            format!("f {}", corners.join(" "))
        })
        .collect();
    let run = |name: &str, text: String, extra: &[&str]| -> serde_json::Value {
        let input = dir.path().join(name);
        std::fs::write(&input, text).unwrap();
        let out = dir.path().join("out.glb");
        let report = dir.path().join("report.json");
        let mut args: Vec<std::ffi::OsString> = vec![
            "crack".into(),
            input.into(),
            out.into(),
            "--report".into(),
            report.clone().into(),
        ];
        args.extend(extra.iter().map(|a| a.into()));
        let o = common::run(&args);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap()
    };
    let simulated = |r: &serde_json::Value| -> f64 {
        r["meshes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m["report"]["triangles"][0].as_f64().unwrap())
            .sum()
    };
    let steps = |r: &serde_json::Value| r["relaxation_steps"].as_f64().unwrap();
    let glaze = ["--preset", "glaze", "--cell-size-relative", "0.1"];
    let copies = |k: usize| {
        let mut t = positions.join("\n") + "\n";
        for _ in 0..k {
            t += &(faces.join("\n") + "\n");
        }
        t
    };
    let one = run("cube1.obj", copies(1), &glaze);
    let four = run("cube4.obj", copies(4), &glaze);
    let ratio = simulated(&four) / simulated(&one);
    assert!((3.5..=4.5).contains(&ratio), "simulated triangles x{ratio}");
    assert!(
        steps(&four) <= 1.5 * steps(&one) + 10.0,
        "relaxation steps {} -> {}",
        steps(&one),
        steps(&four)
    );
    let fan = |n: usize| {
        let mut t = String::from("v 0 0 0\nv 0 0 1\n");
        for i in 0..n {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            t += &format!("v {} {} 0.5\n", a.cos(), a.sin());
        }
        for i in 0..n {
            t += &format!("f 1 2 {}\n", i + 3);
        }
        t
    };
    let small = run("fan500.obj", fan(500), &[]);
    let large = run("fan2000.obj", fan(2000), &[]);
    assert!(
        steps(&large) <= 1.5 * steps(&small) + 10.0,
        "relaxation steps {} -> {}",
        steps(&small),
        steps(&large)
    );
    assert!(large["rounds"].as_f64().unwrap() > 0.0, "{large}");
}
