//! Drying cycles (`simulation.cycles`): how a crack network ages when the
//! surface is wetted and dried again.
//!
//! Mud that dries, is wetted and dries again re-opens its old cracks, but
//! not in the order they first formed (Goehring et al. 2010, repeated
//! drying cycles of mud): in the first drying a later crack runs into an
//! earlier one and stops on it at a right angle (a T-junction); on
//! re-drying the cracks open again from their junctions, and a crack that
//! grows out of a junction whose other two arms are already open runs into
//! the widest gap between them. Junction by junction and cycle by cycle the
//! angles move from 90/90/180 toward 120/120/120 (Y-junctions) and the
//! cells toward hexagons, while the cracks stay where they were elsewhere.
//!
//! Here the first drying is simulated; each further cycle ages its crack
//! network ([`CrackNetwork::of_cracks`], [`CrackNetwork::aged`]): every
//! junction moves part of the way toward the point where its arms meet at
//! equal angles and the arms near it re-route straight to it; kinks
//! elsewhere even out. The aged network is then cut into the surface as it
//! was before the first drying ([`crate::mesh::imprint`]), the gaps carried
//! over from the first drying's opening. The junctions' move is a rule
//! for the evolution observed over cycles, not an outcome of a new stress
//! solve (re-simulating each cycle on the old cracks as weak planes
//! re-forms T-junctions: the film cracks in the order its stress dictates).

use crate::math::v3;
use crate::mesh::SimMesh;
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// A crack network: points (scene units) and the crack segments between
/// them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CrackNetwork {
    /// Points.
    pub nodes: Vec<[f64; 3]>,
    /// Segments as indices into `nodes`, each once, smaller index first.
    pub edges: Vec<[u32; 2]>,
    /// Nodes that stay where they are (on the surface's border), per node
    /// (shorter: the rest are free).
    pub pinned: Vec<bool>,
}

/// How one drying cycle ages a network (lengths in scene units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ageing {
    /// How far along each arm a junction's re-routing reaches.
    pub reach: f64,
    /// The part of the way to equal angles a junction moves per cycle, in (0, 1].
    pub rate: f64,
    /// The part of the way to its neighbours' midpoint a kink moves per cycle, in [0, 1).
    pub smoothing: f64,
}

/// How far along each arm a junction re-routes, in cell sizes.
pub const REACH: f64 = 0.25;
/// Segments shorter than this fraction of the reach are joined with their
/// neighbours after re-routing.
pub const SHORTEST: f64 = 0.2;
/// The part of the way to equal angles a junction moves per cycle.
pub const RATE: f64 = 0.4;
/// The part of the way to its neighbours' midpoint a kink moves per cycle.
pub const SMOOTHING: f64 = 0.3;
impl Ageing {
    /// The ageing of a film of cell size `cell` (scene units).
    pub fn for_cell(cell: f64) -> Ageing {
        Ageing {
            reach: REACH * cell,
            rate: RATE,
            smoothing: SMOOTHING,
        }
    }
}

impl CrackNetwork {
    /// The crack edges of `mesh` (both sides of an opened crack count once),
    /// their ends merged where their positions are equal.
    pub fn of_cracks(mesh: &SimMesh) -> CrackNetwork {
        let mut net = CrackNetwork::default();
        let mut index: HashMap<[u64; 3], u32> = HashMap::new();
        let mut node = |p: [f64; 3], net: &mut CrackNetwork| -> u32 {
            let key = p.map(|x| (x + 0.0).to_bits());
            *index.entry(key).or_insert_with(|| {
                net.nodes.push(p);
                (net.nodes.len() - 1) as u32
            })
        };
        let mut edges = BTreeSet::new();
        for h in mesh.halfedges() {
            if !mesh.is_crack_halfedge(h) {
                continue;
            }
            let a = node(mesh.position(mesh.origin(h)), &mut net);
            let b = node(mesh.position(mesh.dest(h)), &mut net);
            if a != b {
                edges.insert([a.min(b), a.max(b)]);
            }
        }
        net.edges = edges.into_iter().collect();
        // Crack points on the surface's own border stay on it.
        net.pinned = vec![false; net.nodes.len()];
        for h in mesh.halfedges() {
            if mesh.is_boundary_halfedge(h) && !mesh.is_crack_halfedge(h) {
                for v in [mesh.origin(h), mesh.dest(h)] {
                    let key = mesh.position(v).map(|x| (x + 0.0).to_bits());
                    if let Some(&i) = index.get(&key) {
                        net.pinned[i as usize] = true;
                    }
                }
            }
        }
        // A crack edge split by a crack running into it is split on that
        // side only: the other side still spans the split as one edge.
        net.without_spanned_edges()
    }

    /// The network without the segments that a path of shorter segments
    /// through points on them (to rounding) also joins.
    pub fn without_spanned_edges(mut self) -> CrackNetwork {
        let adj = self.adjacency();
        self.edges = self
            .edges
            .iter()
            .copied()
            .filter(|&e| !self.spans(&adj, e))
            .collect();
        self
    }

    /// Whether a path of two or more segments through points on segment
    /// `e` (to rounding) joins its ends.
    fn spans(&self, adj: &[Vec<u32>], e: [u32; 2]) -> bool {
        let (a, b) = (self.nodes[e[0] as usize], self.nodes[e[1] as usize]);
        let ab = v3::sub(b, a);
        let len2 = v3::dot(ab, ab);
        if len2 <= 0.0 {
            return false;
        }
        // The parameter along the segment of a point lying on it.
        let along = |c: u32| -> Option<f64> {
            let ac = v3::sub(self.nodes[c as usize], a);
            let t = v3::dot(ac, ab) / len2;
            let off = v3::sub(ac, v3::scale(ab, t));
            (t > 0.0 && t < 1.0 && v3::dot(off, off) <= 1e-18 * len2).then_some(t)
        };
        let (mut cur, mut t_cur) = (e[0], 0.0);
        for _ in 0..adj.len() {
            let mut next: Option<(f64, u32)> = None;
            for &c in &adj[cur as usize] {
                if c == e[1] {
                    if cur != e[0] {
                        return true;
                    }
                    continue;
                }
                if let Some(t) = along(c) {
                    if t > t_cur && next.is_none_or(|(tn, _)| t < tn) {
                        next = Some((t, c));
                    }
                }
            }
            match next {
                Some((t, c)) => (cur, t_cur) = (c, t),
                None => return false,
            }
        }
        false
    }

    fn is_pinned(&self, v: usize) -> bool {
        self.pinned.get(v).copied().unwrap_or(false)
    }

    /// Each node's neighbours, in increasing order.
    pub fn adjacency(&self) -> Vec<Vec<u32>> {
        let mut adj = vec![Vec::new(); self.nodes.len()];
        for &[a, b] in &self.edges {
            adj[a as usize].push(b);
            adj[b as usize].push(a);
        }
        for a in &mut adj {
            a.sort_unstable();
            a.dedup();
        }
        adj
    }

    /// The segments as their end points.
    pub fn segments(&self) -> Vec<[[f64; 3]; 2]> {
        self.edges
            .iter()
            .map(|&[a, b]| [self.nodes[a as usize], self.nodes[b as usize]])
            .collect()
    }

    /// Total length of the segments.
    pub fn length(&self) -> f64 {
        self.edges
            .iter()
            .map(|&[a, b]| v3::norm(v3::sub(self.nodes[b as usize], self.nodes[a as usize])))
            .sum()
    }

    /// The network after one more drying cycle (see the module
    /// documentation): every node where three or more cracks meet moves
    /// `rate` of the way to the point whose summed distance to its arms'
    /// points at `reach` is least (for three arms the point where they meet
    /// at 120 degrees), the arms within `reach` re-route straight to it,
    /// and every other node moves `smoothing` of the way to its two
    /// neighbours' midpoint. Ends (cracks meeting the border, open tips)
    /// stay.
    pub fn aged(&self, a: &Ageing) -> CrackNetwork {
        let adj = self.adjacency();
        let mut pos = self.nodes.clone();
        let mut moved = vec![false; pos.len()];
        let mut removed: BTreeSet<[u32; 2]> = BTreeSet::new();
        let mut added: Vec<[u32; 2]> = Vec::new();
        // Cuts per original segment: (parameter from its smaller end, the
        // new node, whether the junction lies on the smaller end's side).
        let mut cuts: BTreeMap<[u32; 2], Vec<(f64, u32, bool)>> = BTreeMap::new();
        for j in 0..self.nodes.len() {
            if adj[j].len() < 3 || self.is_pinned(j) {
                continue;
            }
            let arms: Vec<Arm> = adj[j]
                .iter()
                .map(|&n| Arm::walk(&self.nodes, &adj, j as u32, n))
                .collect();
            let points: Vec<([f64; 3], usize, f64)> = arms
                .iter()
                .map(|arm| arm.point_at(&self.nodes, arm.window(a.reach)))
                .collect();
            let targets: Vec<[f64; 3]> = points.iter().map(|p| p.0).collect();
            let f = geometric_median(&targets, self.nodes[j]);
            pos[j] = v3::add(self.nodes[j], v3::scale(v3::sub(f, self.nodes[j]), a.rate));
            moved[j] = true;
            for (arm, (p, k, t)) in arms.iter().zip(points) {
                // The arm's path up to the cut goes; the junction joins the
                // cut point straight.
                for w in arm.path.windows(2).take(k) {
                    removed.insert(key(w[0], w[1]));
                }
                for &n in &arm.path[1..=k] {
                    moved[n as usize] = true;
                }
                pos.push(p);
                let q = (pos.len() - 1) as u32;
                let (near, far) = (arm.path[k], arm.path[k + 1]);
                let near_is_lo = near < far;
                let t_lo = if near_is_lo { t } else { 1.0 - t };
                cuts.entry(key(near, far))
                    .or_default()
                    .push((t_lo, q, near_is_lo));
                added.push(key(j as u32, q));
            }
        }
        // Split every cut segment at its cuts; the piece between a cut and
        // its junction's side goes.
        for (e, mut list) in cuts {
            list.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            removed.insert(e);
            let mut chain = vec![e[0]];
            chain.extend(list.iter().map(|c| c.1));
            chain.push(e[1]);
            for (i, w) in chain.windows(2).enumerate() {
                // Piece i lies between chain[i] and chain[i + 1]: it goes
                // when the cut at its upper end faces the smaller end, or
                // the cut at its lower end faces the larger one.
                let upper_faces_lo = i < list.len() && list[i].2;
                let lower_faces_hi = i > 0 && !list[i - 1].2;
                if !(upper_faces_lo || lower_faces_hi) {
                    added.push(key(w[0], w[1]));
                }
            }
        }
        // Kinks even out (from the positions before this pass).
        let before = pos.clone();
        for (v, nb) in adj.iter().enumerate() {
            if nb.len() == 2 && !moved[v] && !self.is_pinned(v) {
                let mid = v3::scale(v3::add(before[nb[0] as usize], before[nb[1] as usize]), 0.5);
                pos[v] = v3::add(before[v], v3::scale(v3::sub(mid, before[v]), a.smoothing));
            }
        }
        let kept = self.edges.iter().copied().filter(|e| !removed.contains(e));
        let edges = kept.chain(added.into_iter().filter(|e| e[0] != e[1]));
        self.compacted(&pos, edges)
            .without_short_links(SHORTEST * a.reach)
    }

    /// The network of `edges` over the points `pos` (this network's nodes
    /// first, new points after them): the points no segment uses left out,
    /// the rest kept in order, pinned as they were here.
    fn compacted(&self, pos: &[[f64; 3]], edges: impl Iterator<Item = [u32; 2]>) -> CrackNetwork {
        let edges: BTreeSet<[u32; 2]> = edges.map(|[a, b]| key(a, b)).collect();
        let mut used = vec![false; pos.len()];
        for e in &edges {
            used[e[0] as usize] = true;
            used[e[1] as usize] = true;
        }
        let mut new_index = vec![u32::MAX; pos.len()];
        let mut out = CrackNetwork::default();
        for (v, p) in pos.iter().enumerate() {
            if used[v] {
                new_index[v] = out.nodes.len() as u32;
                out.nodes.push(*p);
                out.pinned.push(self.is_pinned(v));
            }
        }
        out.edges = edges
            .into_iter()
            .map(|[a, b]| key(new_index[a as usize], new_index[b as usize]))
            .collect();
        out
    }

    /// The network with every node where two cracks meet and one of its
    /// segments is shorter than `min_len` taken out (its neighbours
    /// joined), unless that would join two nodes already joined: re-routing
    /// leaves cut points close to old nodes, which the cut into the
    /// surface would merge.
    fn without_short_links(self, min_len: f64) -> CrackNetwork {
        let mut adj = self.adjacency();
        for v in 0..self.nodes.len() {
            if adj[v].len() != 2 || self.is_pinned(v) {
                continue;
            }
            let (a, b) = (adj[v][0], adj[v][1]);
            let short =
                dist(&self.nodes, v as u32, a).min(dist(&self.nodes, v as u32, b)) < min_len;
            if !short || adj[a as usize].contains(&b) {
                continue;
            }
            adj[v].clear();
            for (x, y) in [(a, b), (b, a)] {
                let list = &mut adj[x as usize];
                list.retain(|&u| u != v as u32);
                list.push(y);
                list.sort_unstable();
            }
        }
        let edges = adj
            .iter()
            .enumerate()
            .flat_map(|(v, list)| list.iter().map(move |&u| [v as u32, u]))
            .filter(|e| e[0] < e[1]);
        self.compacted(&self.nodes, edges)
    }
}

fn key(a: u32, b: u32) -> [u32; 2] {
    [a.min(b), a.max(b)]
}

/// One arm of a junction: the path from the junction through nodes where
/// two cracks meet, to the next junction or end.
struct Arm {
    /// Node indices, the junction first.
    path: Vec<u32>,
    /// Cumulative length at each node of `path`.
    at: Vec<f64>,
    /// Whether the path ends at another junction (or comes back to this one).
    ends_at_junction: bool,
}

impl Arm {
    fn walk(nodes: &[[f64; 3]], adj: &[Vec<u32>], j: u32, first: u32) -> Arm {
        let mut path = vec![j, first];
        let mut at = vec![0.0, dist(nodes, j, first)];
        let (mut prev, mut cur) = (j, first);
        while adj[cur as usize].len() == 2 && cur != j && path.len() <= nodes.len() {
            let next = if adj[cur as usize][0] == prev {
                adj[cur as usize][1]
            } else {
                adj[cur as usize][0]
            };
            at.push(at[at.len() - 1] + dist(nodes, cur, next));
            path.push(next);
            prev = cur;
            cur = next;
        }
        let ends_at_junction = adj[cur as usize].len() >= 3;
        Arm {
            path,
            at,
            ends_at_junction,
        }
    }

    /// The length of the arm this junction may re-route: `reach`, at most
    /// 0.45 of an arm between two junctions (the other junction re-routes
    /// the rest) or 0.9 of an arm to an end.
    fn window(&self, reach: f64) -> f64 {
        let total = self.at[self.at.len() - 1];
        reach.min(if self.ends_at_junction { 0.45 } else { 0.9 } * total)
    }

    /// The point at arc length `s` along the arm, the segment of the path
    /// it lies in (`k`: from `path[k]` to `path[k + 1]`) and its parameter
    /// along that segment.
    fn point_at(&self, nodes: &[[f64; 3]], s: f64) -> ([f64; 3], usize, f64) {
        let n = self.path.len();
        let mut k = 0;
        while k + 2 < n && self.at[k + 1] < s {
            k += 1;
        }
        let (a, b) = (
            nodes[self.path[k] as usize],
            nodes[self.path[k + 1] as usize],
        );
        let len = self.at[k + 1] - self.at[k];
        let t = if len > 0.0 {
            ((s - self.at[k]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (v3::add(a, v3::scale(v3::sub(b, a), t)), k, t)
    }
}

fn dist(nodes: &[[f64; 3]], a: u32, b: u32) -> f64 {
    v3::norm(v3::sub(nodes[b as usize], nodes[a as usize]))
}

/// The point whose summed distance to `points` is least (Weiszfeld's
/// iteration from `start`, a fixed number of steps: deterministic).
fn geometric_median(points: &[[f64; 3]], start: [f64; 3]) -> [f64; 3] {
    let mut x = start;
    for _ in 0..100 {
        let mut num = [0.0; 3];
        let mut den = 0.0;
        for &p in points {
            let d = v3::norm(v3::sub(p, x));
            if d < 1e-12 {
                // At a point: the median is there when the pull of the
                // others does not exceed 1; for the few arms here stay.
                return x;
            }
            num = v3::add(num, v3::scale(p, 1.0 / d));
            den += 1.0 / d;
        }
        let next = v3::scale(num, 1.0 / den);
        if v3::norm(v3::sub(next, x)) < 1e-12 * (1.0 + v3::norm(x)) {
            return next;
        }
        x = next;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    fn angles_at(net: &CrackNetwork, v: usize) -> Vec<f64> {
        let adj = net.adjacency();
        let mut a: Vec<f64> = adj[v]
            .iter()
            .map(|&u| {
                let d = v3::sub(net.nodes[u as usize], net.nodes[v]);
                d[1].atan2(d[0]).to_degrees().rem_euclid(360.0)
            })
            .collect();
        a.sort_by(f64::total_cmp);
        let n = a.len();
        (0..n)
            .map(|i| {
                if i + 1 < n {
                    a[i + 1] - a[i]
                } else {
                    360.0 - a[n - 1] + a[0]
                }
            })
            .collect()
    }

    /// A T: a bar from (-1, 0) to (1, 0) in 20 pieces, a stem from (0, 0)
    /// up to (0, 1) in 10.
    fn tee() -> CrackNetwork {
        let mut net = CrackNetwork::default();
        for i in 0..=20 {
            net.nodes.push([-1.0 + 0.1 * i as f64, 0.0, 0.0]);
        }
        for i in 0..20 {
            net.edges.push([i, i + 1]);
        }
        for i in 1..=10 {
            net.nodes.push([0.0, 0.1 * i as f64, 0.0]);
        }
        net.edges.push([10, 21]);
        for i in 21..30 {
            net.edges.push([i, i + 1]);
        }
        net.edges.sort_unstable();
        net
    }

    fn junction(net: &CrackNetwork) -> usize {
        let adj = net.adjacency();
        let js: Vec<usize> = (0..adj.len()).filter(|&v| adj[v].len() == 3).collect();
        assert_eq!(js.len(), 1, "one junction");
        js[0]
    }

    #[test]
    fn a_tee_ages_toward_equal_angles_and_keeps_its_ends() {
        let ageing = Ageing {
            reach: 0.3,
            rate: 0.5,
            smoothing: 0.0,
        };
        let mut net = tee();
        let mut widest = vec![180.0];
        for _ in 0..6 {
            net = net.aged(&ageing);
            let j = junction(&net);
            let angles = angles_at(&net, j);
            assert_eq!(angles.len(), 3);
            widest.push(angles.iter().copied().fold(0.0, f64::max));
            // Ends stay: the bar's ends and the stem's top are still nodes of degree 1.
            let adj = net.adjacency();
            for end in [[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
                let v = net.nodes.iter().position(|p| *p == end).expect("end kept");
                assert_eq!(adj[v].len(), 1);
            }
        }
        // The widest angle falls every cycle and ends near 120 degrees.
        for w in widest.windows(2) {
            assert!(w[1] < w[0] - 1e-9, "widest angles {widest:?}");
        }
        assert!(widest[6] < 125.0, "widest angles {widest:?}");
        // The junction moved up the stem, not sideways.
        let p = net.nodes[junction(&net)];
        assert!(p[0].abs() < 1e-9 && p[1] > 0.1 && p[1] < 0.3 * 0.6, "{p:?}");
    }

    #[test]
    fn a_y_stays_and_a_straight_crack_stays_straight() {
        let mut net = CrackNetwork::default();
        net.nodes.push([0.0; 3]);
        for k in 0..3 {
            let a = (90.0 + 120.0 * k as f64).to_radians();
            for i in 1..=10 {
                net.nodes
                    .push([0.1 * i as f64 * a.cos(), 0.1 * i as f64 * a.sin(), 0.0]);
                let v = net.nodes.len() as u32 - 1;
                net.edges.push([if i == 1 { 0 } else { v - 1 }, v]);
            }
        }
        net.edges.sort_unstable();
        let ageing = Ageing {
            reach: 0.25,
            rate: 0.5,
            smoothing: 0.5,
        };
        let aged = net.aged(&ageing);
        let j = junction(&aged);
        assert!(v3::norm(aged.nodes[j]) < 1e-9);
        for a in angles_at(&aged, j) {
            assert!((a - 120.0).abs() < 1e-6, "{a}");
        }
        assert!((aged.length() - net.length()).abs() < 1e-9);
    }

    #[test]
    fn a_crack_edge_split_on_one_side_only_counts_once() {
        // A -- B spanned by A -- J1 -- J2 -- B (J1, J2 on it), and a stem at J1.
        let net = CrackNetwork {
            nodes: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.3, 0.0, 0.0],
                [0.7, 0.0, 0.0],
                [0.3, 1.0, 0.0],
            ],
            edges: vec![[0, 1], [0, 2], [1, 3], [2, 3], [2, 4]],
            ..Default::default()
        };
        let net = net.without_spanned_edges();
        assert_eq!(net.edges, vec![[0, 2], [1, 3], [2, 3], [2, 4]]);
        // A bent path does not span.
        let bent = CrackNetwork {
            nodes: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.1, 0.0]],
            edges: vec![[0, 1], [0, 2], [1, 2]],
            ..Default::default()
        };
        assert_eq!(bent.clone().without_spanned_edges(), bent);
    }

    #[test]
    fn short_links_are_joined_but_not_into_a_loop() {
        let net = CrackNetwork {
            nodes: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.01, 0.0, 0.0],
                [2.0, 0.0, 0.0],
            ],
            edges: vec![[0, 1], [1, 2], [2, 3]],
            ..Default::default()
        };
        let out = net.without_short_links(0.05);
        assert_eq!(out.edges.len(), 2, "{out:?}");
        assert!((out.length() - 2.0).abs() < 0.02);
        // A triangle of short sides stays a triangle.
        let tri = CrackNetwork {
            nodes: vec![[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0]],
            edges: vec![[0, 1], [0, 2], [1, 2]],
            ..Default::default()
        };
        let kept = tri.clone().without_short_links(0.05);
        assert_eq!((kept.nodes, kept.edges), (tri.nodes, tri.edges));
    }

    #[test]
    fn a_network_is_read_from_the_cracks_of_a_mesh_once_per_crack() {
        let (mut mesh, _) = crate::mesh::shapes::build(&crate::mesh::shapes::grid_input(4, 4));
        // Open the middle row's edges from one border to the other.
        let row: Vec<_> = mesh
            .halfedges()
            .filter(|&h| {
                let (p, q) = (mesh.position(mesh.origin(h)), mesh.position(mesh.dest(h)));
                p[1] == 2.0 && q[1] == 2.0 && mesh.twin(h).is_some()
            })
            .collect();
        let mut opened = 0;
        for h in row {
            if mesh.twin(h).is_some() && mesh.open_edge(h).is_ok() {
                opened += 1;
            }
        }
        assert!(opened >= 4, "{opened}");
        let net = CrackNetwork::of_cracks(&mesh);
        assert_eq!(net.edges.len(), 4, "{net:?}");
        assert!((net.length() - 4.0).abs() < 1e-12);
        // Its ends lie on the plate's border: pinned; the rest are free.
        let pinned: Vec<[f64; 3]> = (0..net.nodes.len())
            .filter(|&v| net.pinned[v])
            .map(|v| net.nodes[v])
            .collect();
        assert_eq!(pinned, vec![[0.0, 2.0, 0.0], [4.0, 2.0, 0.0]]);
        // A kink pinned to the border does not even out.
        let vee = CrackNetwork {
            nodes: vec![[0.0, 0.0, 0.0], [1.0, -1.0, 0.0], [2.0, 0.0, 0.0]],
            edges: vec![[0, 1], [1, 2]],
            pinned: vec![false, true, false],
        };
        let ageing = Ageing {
            reach: 0.3,
            rate: 0.5,
            smoothing: 0.5,
        };
        assert_eq!(vee.aged(&ageing).nodes, vee.nodes);
    }
}
