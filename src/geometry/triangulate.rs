//! Triangulation of polygon faces (OBJ n-gons): ear clipping on the polygon
//! projected onto its best-fit plane, so concave polygons are triangulated
//! correctly and collinear vertices do not produce zero-area triangles.

use crate::math::v3::{cross, dot, sub};

/// Polygons up to this size pick the best-shaped ear in every step; larger
/// ones walk their ring and clip the valid ears they meet, with a grid for
/// the containment tests ([`ear_clip_large`]).
const EXHAUSTIVE_LIMIT: usize = 48;

/// Sine of the smallest turn angle taken as a convex corner; flatter corners
/// count as collinear (this absorbs `f32` rounding of straight edges).
const MIN_TURN_SINE: f64 = 1e-6;

/// The Newell normal of a polygon: a vector along the normal of its best-fit
/// plane, oriented by the winding (counter-clockwise seen from its tip), whose
/// length is twice the polygon's area (for a planar polygon).
pub fn newell_normal(points: &[[f64; 3]]) -> [f64; 3] {
    let n = points.len();
    if n < 3 {
        return [0.0; 3];
    }
    let c = centroid(points);
    let mut acc = [0.0; 3];
    for i in 0..n {
        let a = sub(points[i], c);
        let b = sub(points[(i + 1) % n], c);
        let x = cross(a, b);
        acc = [acc[0] + x[0], acc[1] + x[1], acc[2] + x[2]];
    }
    acc
}

/// Triangulate one polygon given by its vertices in order.
///
/// Returns triangles as indices into `points`, with the polygon's winding.
/// Concave polygons are handled (ear clipping in the polygon's best-fit plane,
/// found with the Newell normal); collinear and duplicate vertices are kept
/// (every vertex is used, so no T-junction appears with neighbouring faces) and
/// clipped only where they do not make a zero-area triangle, when that is
/// possible. Self-intersecting or degenerate polygons still get `n - 2`
/// triangles (the best remaining ear is clipped when no valid one exists).
/// Fewer than 3 points give no triangle. Never panics.
pub fn triangulate_polygon(points: &[[f64; 3]]) -> Vec<[u32; 3]> {
    let n = points.len();
    if n < 3 || n > u32::MAX as usize {
        return Vec::new();
    }
    if n == 3 {
        return vec![[0, 1, 2]];
    }
    let Some((p2, scale)) = project(points) else {
        return fan(n);
    };
    if n == 4 {
        return quad(&p2, scale);
    }
    if n > EXHAUSTIVE_LIMIT {
        return ear_clip_large(&p2, scale, &mut 0);
    }
    ear_clip(&p2, scale)
}

/// Fan triangulation, for polygons without any area (all points collinear).
fn fan(n: usize) -> Vec<[u32; 3]> {
    (1..n - 1).map(|i| [0, i as u32, (i + 1) as u32]).collect()
}

/// Project the polygon onto its best-fit plane so that its winding is
/// counter-clockwise in 2D. Returns the 2D points and the polygon's extent,
/// or `None` when the polygon has no area or non-finite coordinates.
fn project(points: &[[f64; 3]]) -> Option<(Vec<[f64; 2]>, f64)> {
    if points.iter().flatten().any(|c| !c.is_finite()) {
        return None;
    }
    let mut lo = points[0];
    let mut hi = points[0];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let scale = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let normal = newell_normal(points);
    let len = dot(normal, normal).sqrt();
    if !(len.is_finite() && scale > 0.0 && len > 1e-12 * scale * scale) {
        return None;
    }
    let nz = [normal[0] / len, normal[1] / len, normal[2] / len];
    // The axis least aligned with the normal gives a stable in-plane direction.
    let mut axis = [0.0; 3];
    let k = (0..3)
        .min_by(|&a, &b| nz[a].abs().total_cmp(&nz[b].abs()))
        .unwrap_or(0);
    axis[k] = 1.0;
    let along = dot(axis, nz);
    let u = sub(axis, [nz[0] * along, nz[1] * along, nz[2] * along]);
    let ul = dot(u, u).sqrt();
    let u = [u[0] / ul, u[1] / ul, u[2] / ul];
    let v = cross(nz, u); // u x v = nz: counter-clockwise in (u, v)
    let c = centroid(points);
    let p2 = points
        .iter()
        .map(|&p| {
            let d = sub(p, c);
            [dot(d, u), dot(d, v)]
        })
        .collect();
    Some((p2, scale))
}

/// A quad: split along the diagonal that keeps both triangles positively
/// oriented (0-2 when both do).
fn quad(p: &[[f64; 2]], scale: f64) -> Vec<[u32; 3]> {
    let a = |i: usize, j: usize, k: usize| cross2(p[i], p[j], p[k]);
    let m02 = a(0, 1, 2).min(a(0, 2, 3));
    let m13 = a(0, 1, 3).min(a(1, 2, 3));
    let tiny = 1e-12 * scale * scale;
    if m02 > tiny || m02 >= m13 {
        vec![[0, 1, 2], [0, 2, 3]]
    } else {
        vec![[0, 1, 3], [1, 2, 3]]
    }
}

/// Ear clipping of a counter-clockwise 2D polygon.
fn ear_clip(p: &[[f64; 2]], scale: f64) -> Vec<[u32; 3]> {
    let n = p.len();
    let mut rem: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    let exhaustive = n <= EXHAUSTIVE_LIMIT;
    let mut start = 0;
    while rem.len() > 3 {
        let m = rem.len();
        let k = find_ear(p, &rem, scale, exhaustive, start)
            .unwrap_or_else(|| fallback_ear(p, &rem, scale));
        let (a, b, c) = corner(&rem, k);
        out.push([a as u32, b as u32, c as u32]);
        rem.remove(k);
        start = if k >= m - 1 { 0 } else { k };
    }
    out.push([rem[0] as u32, rem[1] as u32, rem[2] as u32]);
    out
}

/// Ear clipping of a large counter-clockwise 2D polygon in about
/// `n log n` for the polygons faces are made of. The remaining vertices form
/// a ring, tested as ears in sweeps: first all of them, then the neighbours
/// of the ears the last sweep clipped (their corners changed); the
/// containment test asks a uniform grid of the vertices only for those
/// near the ear. When a sweep clips nothing, all remaining vertices are
/// tested again (a clip can uncover an ear elsewhere); a whole pass without
/// a clip means no ear is left (a self-intersecting or
/// degenerate polygon, which has no proper triangulation), and the rest is
/// clipped at convex corners without the containment test (at any corner
/// after a pass finds none), so hostile input costs no more. `ops` counts
/// the ear tests and the grid's point tests (for the tests' bound on the
/// work).
fn ear_clip_large(p: &[[f64; 2]], scale: f64, ops: &mut u64) -> Vec<[u32; 3]> {
    let n = p.len();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut alive = vec![true; n];
    let mut grid = PointTree::new(p);
    let mut out = Vec::with_capacity(n - 2);
    let mut remaining = n;
    // Sweeps: `now` is tested in order; a vertex whose neighbour was
    // clipped in this sweep waits for the next one (`later`), so a sweep
    // clips every other corner at most and its triangles stay small (no
    // fan of long slivers around one vertex).
    let mut now: Vec<usize> = (0..n).collect();
    let mut later: Vec<usize> = Vec::new();
    let mut in_later = vec![false; n];
    // 0: ears only; 1: convex corners; 2: any corner.
    let mut mode = 0;
    let mut full_pass = true;
    while remaining > 3 {
        let mut clipped = 0;
        for &v in &now {
            if !alive[v] || in_later[v] || remaining <= 3 {
                continue;
            }
            *ops += 1;
            let (a, c) = (prev[v], next[v]);
            let ear = match mode {
                0 => {
                    convex_turn(p, a, v, c).is_some()
                        && !grid.blocked(p, [a, v, c], &alive, scale, ops)
                }
                1 => convex_turn(p, a, v, c).is_some(),
                _ => true,
            };
            if !ear {
                continue;
            }
            out.push([a as u32, v as u32, c as u32]);
            alive[v] = false;
            grid.remove(v);
            next[a] = c;
            prev[c] = a;
            remaining -= 1;
            clipped += 1;
            for u in [a, c] {
                if !in_later[u] {
                    in_later[u] = true;
                    later.push(u);
                }
            }
        }
        if clipped == 0 && full_pass {
            // A whole pass over the remaining vertices found nothing.
            mode += 1;
        }
        now.clear();
        if later.is_empty() || (clipped == 0 && !full_pass) {
            // Test every remaining vertex again, in ring order.
            for &u in &later {
                in_later[u] = false;
            }
            later.clear();
            let start = (0..n).find(|&i| alive[i]).unwrap_or(0);
            let mut u = start;
            loop {
                now.push(u);
                u = next[u];
                if u == start {
                    break;
                }
            }
            full_pass = true;
        } else {
            std::mem::swap(&mut now, &mut later);
            for &u in &now {
                in_later[u] = false;
            }
            full_pass = false;
        }
    }
    let v = (0..n).find(|&i| alive[i]).unwrap_or(0);
    out.push([prev[v] as u32, v as u32, next[v] as u32]);
    out
}

/// A k-d tree over a polygon's 2D points with tight boxes and a count of
/// the points still in the polygon per node, for the ear test of
/// [`ear_clip_large`]: a query visits only nodes with remaining points whose
/// box meets the triangle, so a long thin ear beside a row of points (the
/// fans a comb-like face needs) costs about `log n`, not a scan of the row.
struct PointTree {
    nodes: Vec<TreeNode>,
    /// The points in tree order; node `i` holds `order[begin..end]`.
    order: Vec<u32>,
    /// Each point's leaf.
    leaf_of: Vec<u32>,
}

struct TreeNode {
    lo: [f64; 2],
    hi: [f64; 2],
    begin: u32,
    end: u32,
    /// Children, or `u32::MAX` for a leaf.
    left: u32,
    right: u32,
    parent: u32,
    alive: u32,
}

/// Points per leaf of [`PointTree`].
const TREE_LEAF: usize = 8;

impl PointTree {
    fn new(p: &[[f64; 2]]) -> Self {
        let mut tree = PointTree {
            nodes: Vec::with_capacity(2 * p.len() / TREE_LEAF + 2),
            order: (0..p.len() as u32).collect(),
            leaf_of: vec![0; p.len()],
        };
        // Build breadth-first with an explicit stack (no recursion depth).
        tree.nodes.push(tree.node(p, 0, p.len(), u32::MAX));
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let (begin, end) = (tree.nodes[i].begin as usize, tree.nodes[i].end as usize);
            if end - begin <= TREE_LEAF {
                for k in begin..end {
                    tree.leaf_of[tree.order[k] as usize] = i as u32;
                }
                continue;
            }
            let (lo, hi) = (tree.nodes[i].lo, tree.nodes[i].hi);
            let axis = usize::from(hi[1] - lo[1] > hi[0] - lo[0]);
            let mid = begin + (end - begin) / 2;
            tree.order[begin..end].select_nth_unstable_by(mid - begin, |&u, &v| {
                p[u as usize][axis]
                    .total_cmp(&p[v as usize][axis])
                    .then(u.cmp(&v))
            });
            for (range, right) in [((begin, mid), false), ((mid, end), true)] {
                let child = tree.nodes.len();
                let node = tree.node(p, range.0, range.1, i as u32);
                tree.nodes.push(node);
                if right {
                    tree.nodes[i].right = child as u32;
                } else {
                    tree.nodes[i].left = child as u32;
                }
                stack.push(child);
            }
        }
        tree
    }

    fn node(&self, p: &[[f64; 2]], begin: usize, end: usize, parent: u32) -> TreeNode {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for &q in &self.order[begin..end] {
            for k in 0..2 {
                lo[k] = lo[k].min(p[q as usize][k]);
                hi[k] = hi[k].max(p[q as usize][k]);
            }
        }
        TreeNode {
            lo,
            hi,
            begin: begin as u32,
            end: end as u32,
            left: u32::MAX,
            right: u32::MAX,
            parent,
            alive: (end - begin) as u32,
        }
    }

    /// Point `v` left the polygon.
    fn remove(&mut self, v: usize) {
        let mut i = self.leaf_of[v];
        while i != u32::MAX {
            let node = &mut self.nodes[i as usize];
            node.alive -= 1;
            i = node.parent;
        }
    }

    /// Whether a remaining vertex other than the triangle's own (or points
    /// coinciding with them) lies inside or on the triangle `t`: the test of
    /// [`blockers`].
    fn blocked(
        &self,
        p: &[[f64; 2]],
        t: [usize; 3],
        alive: &[bool],
        scale: f64,
        ops: &mut u64,
    ) -> bool {
        let [a, b, c] = t;
        let ear = EarTest::new([p[a], p[b], p[c]], scale);
        let (lo, hi, tol) = (ear.lo, ear.hi, ear.tol);
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            *ops += 1;
            let node = &self.nodes[i];
            if node.alive == 0
                || node.hi[0] < lo[0]
                || node.lo[0] > hi[0]
                || node.hi[1] < lo[1]
                || node.lo[1] > hi[1]
            {
                continue;
            }
            // The box lies wholly outside one edge's half-plane.
            let outside = ear.edges.iter().any(|&(u, w, l)| {
                let corners = [
                    [node.lo[0], node.lo[1]],
                    [node.hi[0], node.lo[1]],
                    [node.lo[0], node.hi[1]],
                    [node.hi[0], node.hi[1]],
                ];
                corners.iter().all(|&q| cross2(u, w, q) < -tol * l)
            });
            if outside {
                continue;
            }
            if node.left != u32::MAX {
                stack.push(node.left as usize);
                stack.push(node.right as usize);
                continue;
            }
            for &q in &self.order[node.begin as usize..node.end as usize] {
                let q = q as usize;
                *ops += 1;
                if alive[q] && q != a && q != b && q != c && ear.holds(p[q]) {
                    return true;
                }
            }
        }
        false
    }
}

/// The vertex at position `k` of `rem` with its neighbours.
fn corner(rem: &[usize], k: usize) -> (usize, usize, usize) {
    let m = rem.len();
    (rem[(k + m - 1) % m], rem[k], rem[(k + 1) % m])
}

/// The turn at `b` when it is strictly convex (twice the triangle's area), else `None`.
fn convex_turn(p: &[[f64; 2]], a: usize, b: usize, c: usize) -> Option<f64> {
    let t = cross2(p[a], p[b], p[c]);
    let e1 = dist(p[a], p[b]);
    let e2 = dist(p[b], p[c]);
    (t > MIN_TURN_SINE * e1 * e2 && t > 0.0).then_some(t)
}

/// Shape quality of a triangle with doubled area `t`: 0 for slivers, larger is rounder.
fn quality(p: &[[f64; 2]], a: usize, b: usize, c: usize, t: f64) -> f64 {
    let s = dist2(p[a], p[b]) + dist2(p[b], p[c]) + dist2(p[c], p[a]);
    if s > 0.0 {
        t / s
    } else {
        0.0
    }
}

/// Number of remaining vertices (other than the ear's own, or points
/// coinciding with them) inside or on the ear triangle at position `k`;
/// stops counting at 1 when `first_only`.
fn blockers(p: &[[f64; 2]], rem: &[usize], k: usize, scale: f64, first_only: bool) -> usize {
    let (a, b, c) = corner(rem, k);
    let ear = EarTest::new([p[a], p[b], p[c]], scale);
    let mut count = 0;
    for &q in rem {
        if q != a && q != b && q != c && ear.holds(p[q]) {
            count += 1;
            if first_only {
                break;
            }
        }
    }
    count
}

/// The containment test of an ear: a point inside or on the triangle, not
/// coinciding with one of its corners (within `1e-9` of the polygon's
/// extent).
struct EarTest {
    corners: [[f64; 2]; 3],
    tol: f64,
    /// The triangle's box, widened by `tol`.
    lo: [f64; 2],
    hi: [f64; 2],
    /// Each edge with its length.
    edges: [([f64; 2], [f64; 2], f64); 3],
}

impl EarTest {
    fn new(corners: [[f64; 2]; 3], scale: f64) -> Self {
        let [pa, pb, pc] = corners;
        let tol = 1e-9 * scale;
        EarTest {
            corners,
            tol,
            lo: [
                pa[0].min(pb[0]).min(pc[0]) - tol,
                pa[1].min(pb[1]).min(pc[1]) - tol,
            ],
            hi: [
                pa[0].max(pb[0]).max(pc[0]) + tol,
                pa[1].max(pb[1]).max(pc[1]) + tol,
            ],
            edges: [
                (pa, pb, dist(pa, pb)),
                (pb, pc, dist(pb, pc)),
                (pc, pa, dist(pc, pa)),
            ],
        }
    }

    fn holds(&self, q: [f64; 2]) -> bool {
        let (lo, hi, tol) = (self.lo, self.hi, self.tol);
        if q[0] < lo[0] || q[0] > hi[0] || q[1] < lo[1] || q[1] > hi[1] {
            return false;
        }
        if self.corners.iter().any(|&c| dist(q, c) <= tol) {
            return false;
        }
        self.edges
            .iter()
            .all(|&(u, w, l)| cross2(u, w, q) >= -tol * l)
    }
}

/// A valid ear (strictly convex, nothing inside): the best-shaped one when
/// `exhaustive`, else the first found from `start`.
fn find_ear(
    p: &[[f64; 2]],
    rem: &[usize],
    scale: f64,
    exhaustive: bool,
    start: usize,
) -> Option<usize> {
    let m = rem.len();
    let mut best: Option<(usize, f64)> = None;
    for step in 0..m {
        let k = (start + step) % m;
        let (a, b, c) = corner(rem, k);
        let Some(t) = convex_turn(p, a, b, c) else {
            continue;
        };
        let q = quality(p, a, b, c, t);
        if best.is_some_and(|(_, bq)| q <= bq) {
            continue;
        }
        if blockers(p, rem, k, scale, true) == 0 {
            if !exhaustive {
                return Some(k);
            }
            best = Some((k, q));
        }
    }
    best.map(|(k, _)| k)
}

/// When no valid ear exists (self-intersecting or degenerate polygon): prefer
/// convex corners, then the fewest vertices inside, then the largest turn.
fn fallback_ear(p: &[[f64; 2]], rem: &[usize], scale: f64) -> usize {
    let mut best = 0;
    let mut best_key = (false, usize::MAX, f64::NEG_INFINITY);
    for k in 0..rem.len() {
        let (a, b, c) = corner(rem, k);
        let t = cross2(p[a], p[b], p[c]);
        let convex = convex_turn(p, a, b, c).is_some();
        let inside = if convex {
            blockers(p, rem, k, scale, false)
        } else {
            usize::MAX
        };
        let better = match (convex, best_key.0) {
            (true, false) => true,
            (false, true) => false,
            _ => inside < best_key.1 || (inside == best_key.1 && t > best_key.2),
        };
        if better {
            best = k;
            best_key = (convex, inside, t);
        }
    }
    best
}

fn centroid(points: &[[f64; 3]]) -> [f64; 3] {
    let n = points.len().max(1) as f64;
    let mut c = [0.0; 3];
    for p in points {
        for k in 0..3 {
            c[k] += p[k];
        }
    }
    [c[0] / n, c[1] / n, c[2] / n]
}

/// Twice the signed area of the 2D triangle (o, a, b).
fn cross2(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    dist2(a, b).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri_normal(p: &[[f64; 3]], t: [u32; 3]) -> [f64; 3] {
        let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
        cross(sub(b, a), sub(c, a))
    }

    fn len(v: [f64; 3]) -> f64 {
        dot(v, v).sqrt()
    }

    /// Checks count, index validity, orientation, total area and that every
    /// vertex is used; returns the smallest triangle area.
    fn check(points: &[[f64; 3]]) -> f64 {
        let tris = triangulate_polygon(points);
        let n = points.len();
        assert_eq!(tris.len(), n - 2, "{tris:?}");
        let normal = newell_normal(points);
        let poly_area = len(normal) / 2.0;
        let mut sum = 0.0;
        let mut min_area = f64::INFINITY;
        let mut used = vec![false; n];
        for &t in &tris {
            for i in t {
                assert!((i as usize) < n);
                used[i as usize] = true;
            }
            let tn = tri_normal(points, t);
            assert!(
                dot(tn, normal) > 0.0,
                "triangle {t:?} is flipped or degenerate in {tris:?}"
            );
            sum += len(tn) / 2.0;
            min_area = min_area.min(len(tn) / 2.0);
        }
        assert!(
            (sum - poly_area).abs() <= 1e-9 * poly_area.max(1.0),
            "area {sum} != {poly_area}: {tris:?}"
        );
        assert!(used.iter().all(|&u| u), "a vertex is unused: {tris:?}");
        min_area
    }

    fn xy(points: &[[f64; 2]]) -> Vec<[f64; 3]> {
        points.iter().map(|p| [p[0], p[1], 0.0]).collect()
    }

    /// Shoelace area in the xy plane.
    fn shoelace(points: &[[f64; 2]]) -> f64 {
        let n = points.len();
        (0..n)
            .map(|i| cross2([0.0, 0.0], points[i], points[(i + 1) % n]))
            .sum::<f64>()
            / 2.0
    }

    #[test]
    fn small_polygons() {
        assert!(triangulate_polygon(&[]).is_empty());
        assert!(triangulate_polygon(&[[0.0; 3], [1.0, 0.0, 0.0]]).is_empty());
        assert_eq!(
            triangulate_polygon(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
            vec![[0, 1, 2]]
        );
    }

    #[test]
    fn convex_pentagon() {
        let pts: Vec<[f64; 2]> = (0..5)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 5.0;
                [a.cos(), a.sin()]
            })
            .collect();
        check(&xy(&pts));
        assert!((len(newell_normal(&xy(&pts))) / 2.0 - shoelace(&pts)).abs() < 1e-12);
    }

    #[test]
    fn concave_l_hexagon() {
        let pts = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
        ];
        assert!((shoelace(&pts) - 3.0).abs() < 1e-12);
        check(&xy(&pts));
        // Clockwise: the triangles follow the winding.
        let mut rev = pts;
        rev.reverse();
        check(&xy(&rev));
    }

    #[test]
    fn notched_square_where_a_fan_fails() {
        // A square with a deep notch at the top; the fan from vertex 0 would
        // make triangles outside the polygon.
        let pts = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 4.0],
            [3.0, 4.0],
            [2.0, 1.0],
            [1.0, 4.0],
            [0.0, 4.0],
            [0.0, 2.0],
        ];
        let fan_area: f64 = (1..pts.len() - 1)
            .map(|i| cross2(pts[0], pts[i], pts[i + 1]).abs() / 2.0)
            .sum();
        assert!(
            (fan_area - shoelace(&pts)).abs() > 0.1,
            "the fan should be wrong here"
        );
        let min = check(&xy(&pts));
        assert!(min > 1e-6);
        assert!((shoelace(&pts) - 13.0).abs() < 1e-12);
    }

    #[test]
    fn tilted_plane() {
        // The L hexagon rotated about two axes and moved away from the origin.
        let pts = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
        ];
        let (s1, c1) = 0.7f64.sin_cos();
        let (s2, c2) = 1.1f64.sin_cos();
        let p3: Vec<[f64; 3]> = pts
            .iter()
            .map(|p| {
                let (x, y, z) = (p[0], p[1] * c1, p[1] * s1);
                [x * c2 - z * s2 + 100.0, y - 50.0, x * s2 + z * c2 + 7.0]
            })
            .collect();
        check(&p3);
        assert!((len(newell_normal(&p3)) / 2.0 - 3.0).abs() < 1e-9);
    }

    #[test]
    fn collinear_points_make_no_zero_area_triangle() {
        // A square with a vertex in the middle of every side.
        let pts = [
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [2.0, 2.0],
            [1.0, 2.0],
            [0.0, 2.0],
            [0.0, 1.0],
        ];
        assert!(check(&xy(&pts)) > 0.1);
        // A triangle with many points on one side (only a fan from the apex works).
        let mut tri = vec![[0.0, 0.0]];
        tri.extend((1..=6).map(|i| [i as f64, 0.0]));
        tri.push([3.0, 5.0]);
        assert!(check(&xy(&tri)) > 0.1);
        // Quad with a collinear corner: the 0-2 split would be degenerate.
        let q = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [1.0, 1.0]];
        assert!(check(&xy(&q)) > 0.1);
        // Concave quads (darts), reflex at vertex 3, then at vertex 1.
        check(&xy(&[[0.0, 0.0], [2.0, -2.0], [4.0, 0.0], [2.0, -1.0]]));
        check(&xy(&[[4.0, 0.0], [2.0, -1.0], [0.0, 0.0], [2.0, -2.0]]));
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        // All collinear.
        let line: Vec<[f64; 3]> = (0..6).map(|i| [i as f64, 0.0, 0.0]).collect();
        assert_eq!(triangulate_polygon(&line).len(), 4);
        // All the same point.
        assert_eq!(triangulate_polygon(&[[1.0; 3]; 5]).len(), 3);
        // Duplicate consecutive points.
        let dup = xy(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        assert_eq!(triangulate_polygon(&dup).len(), 3);
        // Non-finite coordinates.
        let nan = [
            [0.0, 0.0, 0.0],
            [f64::NAN, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 0.0],
        ];
        assert_eq!(triangulate_polygon(&nan).len(), 3);
        // Self-intersecting (bow tie and star polygon).
        let bow = xy(&[[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0], [-1.0, 1.0]]);
        assert_eq!(triangulate_polygon(&bow).len(), 3);
        let star: Vec<[f64; 3]> = (0..7)
            .map(|i| {
                let a = (i * 3) as f64 * std::f64::consts::TAU / 7.0;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let t = triangulate_polygon(&star);
        assert_eq!(t.len(), 5);
        assert!(t.iter().flatten().all(|&i| i < 7));
    }

    /// Test polygons of `n` corners: a circle, a star, a comb, a thin
    /// spiral band and a random (self-intersecting) one.
    fn shapes(n: usize) -> Vec<(&'static str, Vec<[f64; 2]>)> {
        let tau = std::f64::consts::TAU;
        let circle = (0..n)
            .map(|i| {
                let a = tau * i as f64 / n as f64;
                [a.cos(), a.sin()]
            })
            .collect();
        let star = (0..n)
            .map(|i| {
                let a = tau * i as f64 / n as f64;
                let r = if i % 2 == 0 { 1.0 } else { 0.7 };
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        let mut comb = Vec::new();
        for i in 0..n / 4 - 1 {
            let x = i as f64;
            comb.extend([[x, 0.0], [x, 10.0], [x + 0.5, 10.0], [x + 0.5, 1.0]]);
        }
        let m = (n / 4 - 1) as f64;
        comb.extend([[m, 1.0], [m, -1.0], [0.0, -1.0]]);
        let half = n / 2;
        let arm = |i: usize, r0: f64| {
            let a = i as f64 * 0.05;
            [(r0 + a) * a.cos(), (r0 + a) * a.sin()]
        };
        let mut spiral: Vec<[f64; 2]> = (0..half).map(|i| arm(i, 1.0)).collect();
        spiral.extend((0..half).rev().map(|i| arm(i, 1.5)));
        let mut rng = crate::mesh::shapes::Lcg(5);
        let random = (0..n).map(|_| [rng.next_f64(), rng.next_f64()]).collect();
        let mut all = vec![
            ("circle", circle),
            ("star", star),
            ("comb", comb),
            ("spiral", spiral),
            ("random", random),
        ];
        // Counter-clockwise, as `project` gives them.
        for (_, p) in &mut all {
            if shoelace(p) < 0.0 {
                p.reverse();
            }
        }
        all
    }

    /// Large polygons take about `n log n` work, concave or hostile: the
    /// ear tests and point tests of a 16,000-corner polygon stay within
    /// 6 times those of a 4,000-corner one of the same shape (a quadratic
    /// method gives 16 times; the ear clipper before took 8.7 times the
    /// time from 500 to 1,000 random corners), and a simple polygon still
    /// gets a proper triangulation.
    #[test]
    fn large_polygons_take_about_n_log_n_work() {
        let small = shapes(4000);
        let large = shapes(16000);
        for ((name, p4), (_, p16)) in small.iter().zip(&large) {
            let mut counts = Vec::new();
            for p in [p4, p16] {
                let mut ops = 0;
                let tris = ear_clip_large(p, 1.0, &mut ops);
                assert_eq!(tris.len(), p.len() - 2, "{name}");
                if *name != "random" {
                    // Simple polygons: every triangle counter-clockwise and
                    // the areas add up to the polygon's.
                    let area: f64 = tris
                        .iter()
                        .map(|t| {
                            let a = cross2(p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
                            assert!(a > 0.0, "{name}: a flipped triangle {t:?}");
                            a / 2.0
                        })
                        .sum();
                    let want = shoelace(p);
                    assert!(
                        (area - want).abs() <= 1e-9 * want,
                        "{name}: {area} vs {want}"
                    );
                }
                counts.push(ops as f64);
            }
            let ratio = counts[1] / counts[0];
            eprintln!(
                "{name}: {} -> {} operations ({ratio:.2}x)",
                counts[0], counts[1]
            );
            assert!(
                ratio < 6.0,
                "{name}: {ratio:.2}x the work for 4x the corners"
            );
        }
    }

    #[test]
    fn large_concave_polygon() {
        // A comb with many teeth: exercises the non-exhaustive path.
        let mut pts = vec![[0.0, 0.0]];
        let teeth = 40;
        for i in 0..teeth {
            let x = i as f64 * 2.0;
            pts.push([x + 1.0, 0.0]);
            pts.push([x + 1.0, 5.0]);
            pts.push([x + 2.0, 5.0]);
            pts.push([x + 2.0, 0.0]);
        }
        pts.push([teeth as f64 * 2.0 + 1.0, 0.0]);
        pts.push([teeth as f64 * 2.0 + 1.0, -1.0]);
        pts.push([0.0, -1.0]);
        assert!(pts.len() > EXHAUSTIVE_LIMIT);
        check(&xy(&pts));
    }
}
