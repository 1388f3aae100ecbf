//! The pieces of material: tetrahedra tied through nodes inside, for
//! counting fragments and for the multigrid's coarse levels.

use super::{Ductile, BRIDGE, SLIVER};

/// Most pieces with coarse levels of their own (the smaller ones share a
/// set): each set spans the grid's box.
const OWN_LEVELS: usize = 6;
use std::collections::HashMap;

impl Ductile {
    /// Each tetrahedron's piece (the root of its union; `u32::MAX` for
    /// one without a node inside) and the material each piece holds.
    /// Tetrahedra sharing a node inside are one piece; with `bridge` < 1,
    /// so are those sharing a node outside whose inside fractions are
    /// both at least `bridge` (material there holds the pieces together
    /// through that node).
    pub(super) fn piece_roots(&self, bridge: f64) -> (Vec<u32>, HashMap<u32, f64>) {
        let inside: Vec<bool> = self.phi.iter().map(|&p| p < 0.0).collect();
        let mut parent: Vec<u32> = (0..self.tets.len() as u32).collect();
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        // The material in a tetrahedron is convex (phi is linear in it):
        // tetrahedra sharing an inside node are one piece.
        let mut joined: Vec<u32> = Vec::new();
        for (n, ts) in self.node_tets.iter().enumerate() {
            joined.clear();
            if inside[n] {
                joined.extend(ts.iter().map(|&(e, _)| e));
            } else if bridge < 1.0 {
                joined.extend(
                    ts.iter()
                        .map(|&(e, _)| e)
                        .filter(|&e| self.inside(e as usize) >= bridge),
                );
            }
            for w in joined.windows(2) {
                let (a, b) = (find(&mut parent, w[0]), find(&mut parent, w[1]));
                if a != b {
                    parent[a.max(b) as usize] = a.min(b);
                }
            }
        }
        let mut roots = vec![u32::MAX; self.tets.len()];
        let mut material: HashMap<u32, f64> = HashMap::new();
        for e in 0..self.tets.len() as u32 {
            if self.tets[e as usize].iter().any(|&n| inside[n as usize]) {
                let r = find(&mut parent, e);
                roots[e as usize] = r;
                *material.entry(r).or_insert(0.0) +=
                    self.rest[e as usize].volume * self.inside(e as usize);
            }
        }
        (roots, material)
    }

    /// Pieces of material.
    pub fn fragments(&self) -> usize {
        // A piece counts when it holds at least a thousandth of a cube of
        // material: nodes on the surface whose sign is rounding make
        // slivers of nothing.
        let least = SLIVER * self.grid.h.powi(3);
        let (_, material) = self.piece_roots(f64::INFINITY);
        material.values().filter(|&&v| v >= least).count()
    }

    /// For the multigrid: the nodes of each piece holding at least
    /// [`SLIVER`] of a cube of material, the largest [`OWN_LEVELS`] of
    /// them, and one more set with the rest (smaller pieces), when the
    /// material is in more than one such piece; none while it is whole. A
    /// chip that came off gets coarse levels apart from the body it left:
    /// spot at 24 cubes, whose three chips of under 3 cubes shared the
    /// body's coarse levels (only pieces of a twentieth of the material or
    /// more had their own), took 76 CG iterations a step once they were
    /// off against 13 before (50 with the chips' coarse levels shared among
    /// them, 18 with one set each). Pieces here are held together also
    /// through a node outside whose tetrahedra on both sides hold a tenth
    /// of their volume of material or more (a cut plane of nodes between
    /// two sizeable slices of material still ties them; slivers hanging on
    /// to a node in the gap do not). A node goes with the piece of its
    /// first tetrahedron (in index order) that has one.
    pub(super) fn piece_nodes(&self) -> Vec<Vec<bool>> {
        let (roots, material) = self.piece_roots(BRIDGE);
        let least = SLIVER * self.grid.h.powi(3);
        let mut sized: Vec<(f64, u32)> = material
            .iter()
            .filter(|(_, &v)| v >= least)
            .map(|(&r, &v)| (v, r))
            .collect();
        if sized.len() < 2 {
            return Vec::new();
        }
        // The largest first (ties by root).
        sized.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut big: Vec<u32> = sized.iter().take(OWN_LEVELS).map(|&(_, r)| r).collect();
        big.sort_unstable();
        let n = self.x.len();
        let mut masks = vec![vec![false; n]; big.len() + 1];
        let mut rest = false;
        for (node, ts) in self.node_tets.iter().enumerate() {
            let Some(r) = ts
                .iter()
                .map(|&(e, _)| roots[e as usize])
                .find(|&r| r != u32::MAX)
            else {
                continue;
            };
            let k = big.binary_search(&r).unwrap_or(big.len());
            rest |= k == big.len();
            masks[k][node] = true;
        }
        if !rest {
            masks.pop();
        }
        masks
    }
}
