//! Tests of the virtual nodes: pieces apart share no node and pass no
//! force, the copies carry their side's mass, and the solves stay fast.

use super::tests::{assert_cycle_symmetric_and_positive, notched_block, params};
use super::*;

/// The notched block at 8 cubes with the plane of grid nodes nearest its
/// middle (across y) torn: every node there a fifth of a cube outside, so
/// the material below and above is apart by a gap narrower than a cube,
/// slivers of it hanging on to the plane's nodes from both sides.
fn torn_across(virtual_nodes: bool) -> Ductile {
    let (p, t) = notched_block(0.4);
    let params = DuctileParams {
        virtual_nodes,
        ..params(8)
    };
    let mut d = Ductile::new(&p, &t, &params).unwrap();
    assert_eq!(d.virtual_nodes(), 0, "the block starts whole");
    let (lo, hi) = grid::bounds(&d.to_metres_all(&p));
    let middle = 0.5 * (lo[1] + hi[1]);
    let h = d.grid.h;
    let plane = ((middle - d.grid.origin[1]) / h).round();
    let y = d.grid.origin[1] + plane * h;
    let before = d.phi.clone();
    for n in 0..d.x.len() {
        if (d.rest_x[n][1] - y).abs() < 1e-6 * h {
            d.phi[n] = d.phi[n].max(0.2 * h);
        }
    }
    if virtual_nodes {
        let candidates = d.split_candidates(&before);
        d.split_nodes(&candidates);
    }
    d
}

impl Ductile {
    fn to_metres_all(&self, p: &[[f64; 3]]) -> Vec<[f64; 3]> {
        p.iter().map(|&q| self.to_metres(q)).collect()
    }

    /// Per node: how many pieces of material its tetrahedra with material
    /// are in.
    fn pieces_per_node(&self) -> Vec<usize> {
        let (roots, _) = self.piece_roots(f64::INFINITY);
        self.node_tets
            .iter()
            .map(|ts| {
                let mut r: Vec<u32> = ts
                    .iter()
                    .map(|&(e, _)| roots[e as usize])
                    .filter(|&r| r != u32::MAX)
                    .collect();
                r.sort_unstable();
                r.dedup();
                r.len()
            })
            .collect()
    }
}

/// Across a gap narrower than a cube the two pieces share no node with
/// virtual nodes (each node of the torn plane has a copy for the side
/// above), and moving one piece as a rigid body stores no energy in the
/// other; without them the plane's nodes are both pieces' and the move
/// stretches the slivers below.
#[test]
fn pieces_across_a_narrow_gap_share_no_node_and_pass_no_force() {
    let mut energies = Vec::new();
    for virtual_nodes in [true, false] {
        let mut d = torn_across(virtual_nodes);
        assert_eq!(d.fragments(), 2);
        let shared = d.pieces_per_node().iter().filter(|&&k| k > 1).count();
        if virtual_nodes {
            assert_eq!(shared, 0, "nodes in both pieces");
            assert!(d.virtual_nodes() > 0);
            // Each copy stands where its node does.
            for n in d.grid.n_nodes()..d.x.len() {
                assert_eq!(d.rest_x[n], d.rest_x[d.home(n)]);
            }
        } else {
            assert!(shared > 0, "the plane's nodes are both pieces'");
        }
        // The upper piece moves up by a tenth of a cube, rigidly: its
        // tetrahedra's nodes (all of them, without copies the torn plane's
        // too).
        let (roots, material) = d.piece_roots(f64::INFINITY);
        let upper = material
            .keys()
            .copied()
            .max_by(|&a, &b| {
                let y = |r: u32| {
                    let e = roots.iter().position(|&q| q == r).unwrap();
                    d.rest_x[d.tets[e][0] as usize][1]
                };
                y(a).total_cmp(&y(b))
            })
            .unwrap();
        let mut moved = vec![false; d.x.len()];
        for (e, t) in d.tets.iter().enumerate() {
            if roots[e] == upper {
                for &n in t {
                    moved[n as usize] = true;
                }
            }
        }
        let h = d.grid.h;
        for (x, m) in d.x.iter_mut().zip(&moved) {
            if *m {
                x[1] += 0.1 * h;
            }
        }
        energies.push(d.energy());
    }
    let (with, without) = (energies[0], energies[1]);
    eprintln!("energy after the move: {with:e} J with virtual nodes, {without:e} J without");
    assert!(without > 0.0);
    assert!(with <= 1e-9 * without, "{with} J against {without} J");
}

/// A copy carries its own side's mass: the masses at a torn plane's node
/// and its copies add up to the node's mass without copies, and the
/// multigrid cycle on the split nodes is symmetric and positive.
#[test]
fn copies_share_out_the_mass_and_the_cycle_stays_symmetric() {
    let mut with = torn_across(true);
    let without = torn_across(false);
    let (m_with, m_without) = (
        with.masses(&with.weights()),
        without.masses(&without.weights()),
    );
    let n_grid = with.grid.n_nodes();
    let mut total = m_with[..n_grid].to_vec();
    for n in n_grid..with.x.len() {
        assert!(m_with[n] > 0.0, "a copy without material");
        total[with.home(n)] += m_with[n];
    }
    for (a, b) in total.iter().zip(&m_without) {
        assert!(
            (a - b).abs() <= 1e-12 * b.abs().max(1e-30),
            "{a} against {b}"
        );
    }
    // A step builds the cycle over the grid's nodes and the copies.
    let s = with.step();
    assert!(s.converged, "{s:?}");
    assert_cycle_symmetric_and_positive(&with);
}
