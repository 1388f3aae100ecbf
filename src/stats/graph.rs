//! The crack graph of line segments (ends welded, segments split where
//! an end lies on them) and the uniform grid its searches use.

use super::{dist, mean_length, Seg};
use crate::math::v3::{add, dot, scale, sub};
use crate::mesh::spatial::{closest_on_segment, position_key as key};
use std::collections::HashMap;

/// The crack graph of the line segments `points` (consecutive pairs): the
/// ends welded within `tol` (each node at its first point), each segment
/// split at the ends lying on it within `tol`. Its nodes, edges, and each
/// node's first point.
pub(super) fn line_graph(
    points: &[[f64; 3]],
    tol: f64,
) -> (Vec<[f64; 3]>, Vec<[u32; 2]>, Vec<usize>) {
    let mut parent: Vec<usize> = (0..points.len()).collect();
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut grid = Buckets::new(4.0 * tol);
    for (i, &p) in points.iter().enumerate() {
        grid.near(p, tol, |j| {
            if dist(points[j], p) <= tol {
                let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                parent[a.max(b)] = a.min(b);
            }
            false
        });
        grid.map.entry(grid.at(p)).or_default().push(i as u32);
    }
    let (mut node_of, mut nodes, mut first) =
        (vec![u32::MAX; points.len()], Vec::new(), Vec::new());
    let mut map = Vec::with_capacity(points.len());
    for i in 0..points.len() {
        let r = root(&mut parent, i);
        if node_of[r] == u32::MAX {
            node_of[r] = nodes.len() as u32;
            nodes.push(points[r]);
            first.push(r);
        }
        map.push(node_of[r]);
    }
    let pairs = map
        .chunks_exact(2)
        .map(|e| [e[0].min(e[1]), e[0].max(e[1])]);
    let mut edges: Vec<[u32; 2]> = pairs.filter(|e| e[0] != e[1]).collect();
    edges.sort_unstable();
    edges.dedup();
    let mut edges = split_within(&nodes, edges, tol);
    edges.sort_unstable();
    edges.dedup();
    edges.retain(|e| e[0] != e[1]);
    (nodes, edges, first)
}

/// Split every crack segment at the crack ends lying inside it, within
/// `eps`. A crack that runs into an earlier one ends on it, but the
/// earlier crack's line segment may have been written whole: without the
/// split that junction is an open end.
pub(super) fn split_within(
    positions: &[[f64; 3]],
    cracks: Vec<[u32; 2]>,
    eps: f64,
) -> Vec<[u32; 2]> {
    let mut count = vec![0u32; positions.len()];
    cracks
        .iter()
        .flatten()
        .for_each(|&v| count[v as usize] += 1);
    let segs: Vec<Seg> = cracks
        .iter()
        .map(|c| c.map(|v| positions[v as usize]))
        .collect();
    let grid = Buckets::of_segments(&segs, mean_length(&segs).max(4.0 * eps));
    // Per segment: the ends inside it, with their parameter along it.
    let mut cuts: HashMap<usize, Vec<(f64, u32)>> = HashMap::new();
    for v in (0..positions.len()).filter(|&v| count[v] == 1) {
        let p = positions[v];
        let mut best: Option<(f64, usize)> = None;
        grid.near(p, eps, |i| {
            let [a, b] = segs[i];
            let d = dist(closest_on_segment(p, a, b), p);
            let inside = !cracks[i].contains(&(v as u32)) && dist(p, a) > eps && dist(p, b) > eps;
            if inside && d <= eps && best.is_none_or(|x| (d, i) < x) {
                best = Some((d, i));
            }
            false
        });
        if let Some((_, i)) = best {
            let [a, b] = segs[i];
            let t = dot(sub(p, a), sub(b, a)) / dot(sub(b, a), sub(b, a));
            cuts.entry(i).or_default().push((t, v as u32));
        }
    }
    let mut out = Vec::with_capacity(cracks.len() + cuts.len());
    for (i, c) in cracks.into_iter().enumerate() {
        let mut inner = cuts.remove(&i).unwrap_or_default();
        inner.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let mut prev = c[0];
        for v in inner.into_iter().map(|x| x.1).chain([c[1]]) {
            out.push([prev.min(v), prev.max(v)]);
            prev = v;
        }
    }
    out
}

/// Welds points by their exact position.
#[derive(Default)]
pub(super) struct Welder {
    pub(super) map: HashMap<[u64; 3], u32>,
    pub(super) positions: Vec<[f64; 3]>,
}

impl Welder {
    pub(super) fn id(&mut self, p: [f64; 3]) -> u32 {
        let next = self.positions.len() as u32;
        let id = *self.map.entry(key(p)).or_insert(next);
        if id == next {
            self.positions.push(p);
        }
        id
    }
}

/// Items by the cells of a uniform grid (a segment in the cells of points
/// at most half a cell apart along it); only looked up, never iterated, so
/// results do not depend on hashing.
pub(super) struct Buckets {
    cell: f64,
    map: HashMap<[i64; 3], Vec<u32>>,
}

impl Buckets {
    pub(super) fn new(cell: f64) -> Buckets {
        let cell = [1.0, cell][(cell.is_finite() && cell > 0.0) as usize];
        Buckets {
            cell,
            map: HashMap::new(),
        }
    }

    pub(super) fn of_segments(segs: &[Seg], cell: f64) -> Buckets {
        let mut b = Buckets::new(cell);
        for (i, [p, q]) in segs.iter().enumerate() {
            let n = (dist(*p, *q) / (0.5 * b.cell)).ceil().clamp(1.0, 1e6) as usize;
            let mut last = None;
            for k in 0..=n {
                let c = b.at(add(*p, scale(sub(*q, *p), k as f64 / n as f64)));
                if last.replace(c) != Some(c) {
                    b.map.entry(c).or_default().push(i as u32);
                }
            }
        }
        b
    }

    pub(super) fn at(&self, p: [f64; 3]) -> [i64; 3] {
        p.map(|x| (x / self.cell).floor() as i64)
    }

    /// Call `f` on every item that may lie within `r` of `p` (some more
    /// than once) until it returns true; whether it did.
    pub(super) fn near(&self, p: [f64; 3], r: f64, mut f: impl FnMut(usize) -> bool) -> bool {
        // A segment's closest point lies within a quarter cell of a sample.
        let r = r + 0.25 * self.cell;
        let (a, b) = (self.at(p.map(|x| x - r)), self.at(p.map(|x| x + r)));
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    let items = self.map.get(&[x, y, z]).map_or(&[][..], |v| &v[..]);
                    if items.iter().any(|&i| f(i as usize)) {
                        return true;
                    }
                }
            }
        }
        false
    }
}
