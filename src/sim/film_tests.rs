//! Film runs: the shear-lag length, and patterns that follow the cell size
//! instead of the triangles.

use crate::mesh::shapes::jittered_plate;
use crate::mesh::SimMesh;
use crate::sim::{relax_only, run, SimParams};

/// A jittered plate `size` units across made of `n x n` cells.
fn plate(size: f64, n: usize, seed: u64) -> SimMesh {
    let mut m = jittered_plate(n, 0.3, seed);
    let s = size / n as f64;
    let p: Vec<[f64; 3]> = m.positions().iter().map(|q| q.map(|x| x * s)).collect();
    m.set_positions(&p).unwrap();
    m
}

fn film(cell: f64) -> SimParams {
    SimParams {
        cell_size: Some(cell),
        finish: true,
        ..SimParams::default()
    }
}

/// Crack length per area of a finished film run.
fn crack_density(mesh: &mut SimMesh, params: &SimParams) -> (f64, usize) {
    let area = mesh.total_area();
    let r = run(mesh, params, &mut ()).unwrap();
    assert_eq!(r.integrator, "film-equilibrium");
    (r.crack_length / area, r.cracks)
}

/// Under a uniform load the stress across a free edge recovers as
/// `s (1 - exp(-x / l))`, `l = cell_size / CELL_PER_LENGTH`, whatever the
/// triangles.
#[test]
fn stress_recovers_from_a_free_edge_over_the_shear_lag_length() {
    let l = 4.0;
    let cell = l * super::CELL_PER_LENGTH;
    for n in [40, 80] {
        let mesh = plate(40.0, n, 3);
        let params = SimParams {
            noise: 0.0,
            load_time: 1.0,
            relax_time: 1.0,
            shrink_rate: 1.0,
            ..film(cell)
        };
        let relaxed = relax_only(&mesh, &params, None, 1).unwrap();
        let at = |x0: f64| {
            let (mut sum, mut area) = (0.0, 0.0);
            for f in mesh.faces() {
                let c = mesh
                    .face_vertices(f)
                    .iter()
                    .fold([0.0; 3], |a, &v| crate::math::v3::add(a, mesh.position(v)));
                let (x, y) = (c[0] / 3.0, c[1] / 3.0);
                if (x - x0).abs() < 0.75 && (14.0..26.0).contains(&y) {
                    sum += relaxed.stress[f.idx()].xx * relaxed.areas[f.idx()];
                    area += relaxed.areas[f.idx()];
                }
            }
            sum / area
        };
        for x in [l, 2.0 * l] {
            let want = 1.0 - (-x / l).exp();
            let got = at(x);
            assert!(
                (got - want).abs() < 0.08,
                "{n} x {n}: stress {got:.3} at {x} from the edge, shear lag gives {want:.3}"
            );
        }
        // Far from every edge the film carries the whole load.
        assert!((at(20.0) - 1.0).abs() < 0.03, "{n}: middle {}", at(20.0));
    }
}

/// The same plate at two tessellations cracks alike.
#[test]
fn crack_density_does_not_follow_the_triangles() {
    let (coarse, nc) = crack_density(&mut plate(24.0, 24, 5), &film(4.0));
    let (fine, nf) = crack_density(&mut plate(24.0, 48, 5), &film(4.0));
    assert!(nc > 50 && nf > nc, "cracks {nc} / {nf}");
    let ratio = fine / coarse;
    assert!(
        (0.85..1.15).contains(&ratio),
        "crack length per area {coarse:.4} (24 x 24) vs {fine:.4} (48 x 48): ratio {ratio:.3}"
    );
}

/// Halving the cell size about doubles the crack length per area.
#[test]
fn the_cell_size_sets_the_crack_spacing() {
    let (big, _) = crack_density(&mut plate(24.0, 72, 7), &film(6.0));
    let (small, _) = crack_density(&mut plate(24.0, 72, 7), &film(3.0));
    let ratio = small / big;
    assert!(
        (1.6..2.5).contains(&ratio),
        "cell 6: {big:.4}, cell 3: {small:.4}, ratio {ratio:.3}"
    );
    // The spacing 2 A / L is near the cell size asked for.
    for (density, cell) in [(big, 6.0), (small, 3.0)] {
        let spacing = 2.0 / density;
        assert!(
            (0.6..1.4).contains(&(spacing / cell)),
            "cell {cell}: spacing {spacing:.3}"
        );
    }
}

/// The pattern is the same in any unit: exactly so for power-of-two scales
/// (every number scales exactly), and nearly so for 1e-6 and 1e6.
#[test]
fn a_film_is_scale_invariant() {
    let base = {
        let mut m = plate(24.0, 24, 9);
        let r = run(&mut m, &film(4.0), &mut ()).unwrap();
        (r.cracks, r.crack_length)
    };
    for scale in [2f64.powi(-20), 2f64.powi(20), 1e-6, 1e6] {
        let mut m = plate(24.0 * scale, 24, 9);
        let r = run(&mut m, &film(4.0 * scale), &mut ()).unwrap();
        let exact = scale.log2().fract() == 0.0;
        if exact {
            assert_eq!(r.cracks, base.0, "scale {scale}");
            assert!(((r.crack_length / scale) - base.1).abs() < 1e-9 * base.1);
        } else {
            let dc = (r.cracks as f64 - base.0 as f64).abs() / base.0 as f64;
            let dl = ((r.crack_length / scale) - base.1).abs() / base.1;
            assert!(
                dc < 0.03 && dl < 0.03,
                "scale {scale}: {} cracks, length {} vs {:?}",
                r.cracks,
                r.crack_length / scale,
                base
            );
        }
    }
}

/// Cells close: finishing leaves no open tip.
#[test]
fn film_cells_close() {
    let mut m = plate(24.0, 48, 11);
    let r = run(&mut m, &film(4.0), &mut ()).unwrap();
    let fin = r.finish.expect("finished");
    assert!(r.cracks > 100);
    assert!(
        fin.stuck * 50 <= r.cracks.max(1) / 10,
        "{} tips left open of {} cracks",
        fin.stuck,
        r.cracks
    );
}

/// A film run assembles its system whole once and then only the rows its
/// cracks changed: over a run that cracks a plate into cells, more than the
/// first assembly's rows but fewer than a fifth of the rows summed over its
/// solves are computed (6.0% measured). That the kept rows are the ones a
/// new assembly would compute, bit for bit, the assembly itself checks in
/// the unit tests, this run's included (and `sim::tangent`'s
/// `assembling_again_computes_the_changed_rows_only`).
#[test]
fn a_film_run_computes_only_the_rows_its_cracks_change() {
    let mut m = plate(24.0, 48, 11);
    let n = m.n_vertices();
    let r = run(&mut m, &film(4.0), &mut ()).unwrap();
    let s = &r.film_solves;
    assert!(r.cracks > 100 && s.solves > 5, "{} cracks, {} solves", r.cracks, s.solves);
    assert!(s.rows >= s.solves * n, "{} rows over {} solves", s.rows, s.solves);
    assert!(
        s.rows_assembled > n && s.rows_assembled * 5 < s.rows,
        "{} of {} rows computed",
        s.rows_assembled,
        s.rows
    );
}

/// Both cell-size keys together are refused by name.
#[test]
fn both_cell_sizes_are_refused() {
    let p = SimParams {
        cell_size: Some(1.0),
        cell_size_relative: Some(0.1),
        ..SimParams::default()
    };
    let e = p.validate().unwrap_err().to_string();
    assert!(e.contains("cell_size") && e.contains("not both"), "{e}");
}
