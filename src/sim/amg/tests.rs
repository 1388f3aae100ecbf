use super::*;
use crate::mesh::shapes::Lcg;
use crate::sim::cg::{dot, iterate, iterate_with, CgReport, Vectors};

/// A screened vector Laplacian on an `n x n` grid of nodes in the plane,
/// each node's unknowns in its own basis turned by a seeded angle (the
/// bases jump between neighbours, as the film's do), every node tied to
/// its rest position with `k`, the nodes of `fixed` held (identity rows).
struct Grid {
    offsets: Vec<u32>,
    cols: Vec<u32>,
    blocks: Vec<Block>,
    basis: Vec<[[f64; 3]; 2]>,
}

impl Grid {
    fn new(n: usize, k: f64, fixed: impl Fn(usize) -> bool) -> Grid {
        let mut rng = Lcg(3);
        let basis: Vec<[[f64; 3]; 2]> = (0..n * n)
            .map(|i| {
                if fixed(i) {
                    return [[0.0; 3]; 2];
                }
                let a = rng.next_f64() * 6.0;
                [[a.cos(), a.sin(), 0.0], [-a.sin(), a.cos(), 0.0]]
            })
            .collect();
        let (mut offsets, mut cols, mut blocks) = (vec![0u32], Vec::new(), Vec::new());
        for i in 0..n * n {
            let (x, y) = (i % n, i / n);
            cols.push(i as u32);
            blocks.push([1.0, 0.0, 0.0, 1.0]);
            if !fixed(i) {
                let d = blocks.len() - 1;
                blocks[d] = [k, 0.0, 0.0, k];
                let nbrs = [
                    (x > 0).then(|| i - 1),
                    (x + 1 < n).then(|| i + 1),
                    (y > 0).then(|| i - n),
                    (y + 1 < n).then(|| i + n),
                ];
                for j in nbrs.into_iter().flatten() {
                    blocks[d][0] += 1.0;
                    blocks[d][3] += 1.0;
                    if fixed(j) {
                        continue;
                    }
                    // -T_i^T T_j.
                    let (bi, bj) = (basis[i], basis[j]);
                    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
                    cols.push(j as u32);
                    blocks.push([
                        -dot(bi[0], bj[0]),
                        -dot(bi[0], bj[1]),
                        -dot(bi[1], bj[0]),
                        -dot(bi[1], bj[1]),
                    ]);
                }
            }
            offsets.push(cols.len() as u32);
        }
        Grid {
            offsets,
            cols,
            blocks,
            basis,
        }
    }

    fn rows(&self) -> Rows<'_> {
        Rows {
            offsets: &self.offsets,
            cols: &self.cols,
            blocks: &self.blocks,
        }
    }

    fn apply(&self, x: &[V2]) -> Vec<V2> {
        let a = self.rows();
        (0..a.n())
            .map(|i| {
                a.range(i).fold([0.0; 2], |acc, k| {
                    let v = mul(&a.blocks[k], x[a.cols[k] as usize]);
                    [acc[0] + v[0], acc[1] + v[1]]
                })
            })
            .collect()
    }

    /// CG iterations to 1e-8 from zero, with the multigrid or the block
    /// Jacobi preconditioner, and the solution.
    fn solve(&self, b: &[V2], multigrid: bool) -> (CgReport, Vec<V2>) {
        let n = b.len();
        let (mut x, mut r) = (vec![[0.0; 2]; n], b.to_vec());
        let (mut z, mut p, mut ap) = (vec![[0.0; 2]; n], vec![[0.0; 2]; n], vec![[0.0; 2]; n]);
        let v = Vectors {
            x: &mut x,
            r: &mut r,
            z: &mut z,
            p: &mut p,
            ap: &mut ap,
        };
        let product = |p: &[V2], ap: &mut [V2]| {
            ap.copy_from_slice(&self.apply(p));
            dot(p, ap)
        };
        let mut report = CgReport::default();
        let norm_b = dot(b, b).sqrt();
        if multigrid {
            let mut mg = Multigrid::new(self.rows(), &self.basis);
            iterate_with(
                product,
                |r, z| mg.apply(r, z),
                v,
                norm_b,
                1e-8,
                5000,
                &mut report,
            );
        } else {
            let a = self.rows();
            let pre: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let d = a.blocks[a.offsets[i] as usize];
                    sym_inverse(d[0], 0.5 * (d[1] + d[2]), d[3])
                })
                .collect();
            iterate(
                product,
                |i, r| mul_sym(&pre[i], r),
                v,
                norm_b,
                1e-8,
                5000,
                &mut report,
            );
        }
        (report, x)
    }
}

fn random(n: usize, seed: u64) -> Vec<V2> {
    let mut rng = Lcg(seed);
    (0..n)
        .map(|_| [rng.next_f64() - 0.5, rng.next_f64() - 0.5])
        .collect()
}

fn dot_plain(a: &[V2], b: &[V2]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| x[0] * y[0] + x[1] * y[1])
        .sum()
}

/// The cycle is a symmetric positive definite operator: `x . M y = y . M
/// x` to rounding, `x . M x > 0`, on a grid with fixed nodes and chunks.
#[test]
fn the_cycle_is_symmetric_and_positive() {
    let g = Grid::new(90, 1e-3, |i| i % 37 == 5);
    let mut mg = Multigrid::new(g.rows(), &g.basis);
    assert!(mg.stats().levels.len() >= 3, "{:?}", mg.stats());
    let n = g.basis.len();
    let apply = |mg: &mut Multigrid, r: &[V2]| {
        let mut z = vec![[0.0; 2]; n];
        mg.apply(r, &mut z);
        z
    };
    for seed in 0..4 {
        let (x, y) = (random(n, 10 + seed), random(n, 20 + seed));
        let (mx, my) = (apply(&mut mg, &x), apply(&mut mg, &y));
        let (a, b) = (dot_plain(&y, &mx), dot_plain(&x, &my));
        let scale = dot_plain(&x, &mx).abs().max(dot_plain(&y, &my).abs());
        assert!((a - b).abs() <= 1e-9 * scale, "{a} vs {b}");
        assert!(dot_plain(&x, &mx) > 0.0 && dot_plain(&y, &my) > 0.0);
    }
}

/// With the cycle, CG reaches the Jacobi-preconditioned solution; its
/// iterations barely grow with the grid while Jacobi's double.
#[test]
fn multigrid_cg_solves_in_iterations_that_barely_grow() {
    let mut its = Vec::new();
    for n in [32, 128] {
        let g = Grid::new(n, 1e-4, |i| i == 0);
        let b = random(n * n, 7);
        let (jac, xj) = g.solve(&b, false);
        let (mg, xm) = g.solve(&b, true);
        assert!(jac.converged && mg.converged, "{jac:?} {mg:?}");
        let diff: Vec<V2> = xj
            .iter()
            .zip(&xm)
            .map(|(a, b)| [a[0] - b[0], a[1] - b[1]])
            .collect();
        assert!(dot_plain(&diff, &diff).sqrt() < 1e-6 * dot_plain(&xj, &xj).sqrt());
        its.push((jac.iterations, mg.iterations));
    }
    let (small, large) = (its[0], its[1]);
    // Jacobi's grow about fourfold for 16 times the nodes (188 -> 728),
    // the cycle's by half (10 -> 15).
    assert!(large.0 as f64 > 3.0 * small.0 as f64, "{its:?}");
    assert!(
        (large.1 as f64) < 2.0 * small.1 as f64 && large.1 * 20 < large.0,
        "{its:?}"
    );
}

/// The cycle gives the same numbers at any thread count.
#[test]
fn the_cycle_does_not_depend_on_the_thread_count() {
    let g = Grid::new(150, 1e-3, |i| i % 101 == 3);
    let r = random(g.basis.len(), 5);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let mut mg = Multigrid::new(g.rows(), &g.basis);
                let mut z = vec![[0.0; 2]; r.len()];
                mg.apply(&r, &mut z);
                (mg.stats(), z)
            })
    };
    assert_eq!(run(1), run(3));
}
