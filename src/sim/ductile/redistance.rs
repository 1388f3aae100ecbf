//! Keeping the level set a distance where the material tore (the text's
//! step 4, "update level set using rest-state mesh"): a node inside keeps
//! at most its distance, in rest space, to the torn surface.
//!
//! The level set starts as the signed distance to the input surface and
//! the tearing moves it only where it is near zero (`delta_eps`, a band of
//! a fraction of a cube). Without this, a node just ahead of a crack tip
//! keeps its depth below the *input's* surface: a node in the middle of a
//! thick section, `D` deep, needs a time growing as `D^3 / eps^2` to tear,
//! and since `eps` is a fraction of the grid spacing a crack crossed a
//! section more slowly the finer the grid. With the distance to the torn
//! surface, the node next to a tip is about one cube from it on any grid:
//! the crack runs at a speed set by the material, not by the grid.
//!
//! Only values inside rise (to minus the distance), so material is still
//! only lost; nodes outside and away from the tear keep theirs. The
//! distances come from the torn tetrahedra's cut polygons, exact at their
//! corners and carried to the nodes beyond by closest-point propagation
//! (each node takes a neighbour's closest point, nearest first), in a
//! fixed order.

use super::grid::cut_edges;
use super::Ductile;
use crate::math::v3::dist2;
use crate::mesh::spatial::closest_on_triangle;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

impl Ductile {
    /// Lower every node inside to minus its rest-space distance to the
    /// torn surface, where that is nearer than its value says. Returns how
    /// many nodes changed.
    pub(super) fn redistance(&mut self) -> usize {
        let n = self.phi.len();
        let mut best = vec![f64::INFINITY; n];
        let mut closest = vec![[0.0f64; 3]; n];
        let mut heap: BinaryHeap<Reverse<(u64, u32)>> = BinaryHeap::new();
        let dist = |a: [f64; 3], b: [f64; 3]| dist2(a, b).sqrt();
        // Seeds: the corners inside of every cut tetrahedron with a node
        // the tear moved, at their exact distance to its cut polygon.
        for t in &self.tets {
            let phi = t.map(|v| self.phi[v as usize]);
            let torn = t
                .iter()
                .any(|&v| self.phi[v as usize] > self.phi0[v as usize]);
            if !torn {
                continue;
            }
            // Empty for a tetrahedron all on one side.
            let polygon = self.cut_polygon(t, phi);
            for (c, &v) in t.iter().enumerate() {
                if phi[c] >= 0.0 {
                    continue;
                }
                let p = self.rest_x[v as usize];
                for tri in triangles(&polygon) {
                    let (q, _) = closest_on_triangle(p, tri);
                    let d = dist(p, q);
                    if d > 0.0 && d < -phi[c] && d < best[v as usize] {
                        best[v as usize] = d;
                        closest[v as usize] = q;
                        heap.push(Reverse((d.to_bits(), v)));
                    }
                }
            }
        }
        // Nearest first: each node offers its closest point to its
        // neighbours inside.
        while let Some(Reverse((bits, v))) = heap.pop() {
            let v = v as usize;
            if f64::from_bits(bits) > best[v] {
                continue;
            }
            let q = closest[v];
            for &(e, _) in &self.node_tets[v] {
                for &m in &self.tets[e as usize] {
                    let m = m as usize;
                    if self.phi[m] >= 0.0 {
                        continue;
                    }
                    let d = dist(self.rest_x[m], q);
                    if d > 0.0 && d < -self.phi[m] && d < best[m] {
                        best[m] = d;
                        closest[m] = q;
                        heap.push(Reverse((d.to_bits(), m as u32)));
                    }
                }
            }
        }
        let mut changed = 0;
        for (phi, &d) in self.phi.iter_mut().zip(&best) {
            if d < -*phi {
                *phi = -d;
                changed += 1;
            }
        }
        changed
    }

    /// The polygon where the level set `phi` crosses zero in tetrahedron
    /// `t` (rest space; 3 or 4 corners in order around it; none for a
    /// tetrahedron all on one side).
    fn cut_polygon(&self, t: &[u32; 4], phi: [f64; 4]) -> Vec<[f64; 3]> {
        let cross = |a: usize, b: usize| {
            let w = phi[a] / (phi[a] - phi[b]);
            let (p, q) = (self.rest_x[t[a] as usize], self.rest_x[t[b] as usize]);
            [0, 1, 2].map(|k| p[k] + w * (q[k] - p[k]))
        };
        cut_edges(phi).iter().map(|&(a, b)| cross(a, b)).collect()
    }
}

/// A convex polygon's fan of triangles.
fn triangles(polygon: &[[f64; 3]]) -> impl Iterator<Item = [[f64; 3]; 3]> + '_ {
    (1..polygon.len().saturating_sub(1)).map(|i| [polygon[0], polygon[i], polygon[i + 1]])
}
