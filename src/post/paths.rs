//! Crack paths taken off the simulation surface's edges.
//!
//! The spring model and the snapping variant crack along edges the
//! simulation surface already has, so a crack zig-zags from edge to edge at
//! the scale of a triangle, and where the cracks are cut into the input the
//! zig-zag is cut with them. This moves each crack's points along the
//! crack (every copy of a point together, on the surface it lies on) toward
//! the mean of its two neighbours on the crack, a few passes: the zig-zag,
//! two edges long, goes; a crack's course over several cells stays.
//! Junctions, tips and points on the mesh's own border stay where they are,
//! and a point moves only as far as no face around it turns over or
//! shrinks below a tenth of its area.

use crate::math::v3;
use crate::mesh::spatial::{border_keys, position_key as key, Faces};
use crate::mesh::{MeshError, SimMesh, VertexId};
use std::collections::BTreeMap;

/// How far a pass moves a point toward its neighbours' mean.
const STEP: f64 = 0.5;
/// Least area a face around a moved point keeps, as a fraction of its area
/// before the smoothing.
const MIN_AREA_SHARE: f64 = 0.1;
/// Times a step is halved before the point stays for the pass.
const HALVINGS: usize = 4;
/// How far an open end of a line reaches for another crack to join, in
/// the surface's mean edge lengths.
pub const JOIN_EDGES: f64 = 1.0;
/// A line's end joins its own crack only farther along it than this many
/// segments.
pub const JOIN_HOPS: usize = 10;
/// Most segments of a loop of lines whose points stay (smoothing would
/// shrink it).
const SMALL_LOOP: usize = 12;
/// Longest loop of lines, in the surface's mean edge lengths, drawn in to
/// a point (a knot of joined dashes, smaller than any cell).
pub const KNOT_EDGES: f64 = 6.0;
/// Most segments of a spur: a crack from a tip this short is left out.
pub const SPUR_SEGMENTS: usize = 2;

/// What the smoothing did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathReport {
    /// Crack points (each once, however many copies) that may move: on a
    /// crack between two others, off the border.
    pub free: usize,
    /// Moves of a point taken short or left out to keep its faces.
    pub held: usize,
    /// Segments left out as spurs.
    pub spurs: usize,
    /// Open ends of lines joined to a crack nearby.
    pub joined: usize,
    /// Nodes whose springs all broke (or all but one), their ring of lines
    /// drawn in to them.
    pub rings: usize,
    /// Small loops of lines drawn in to a point (where dashes joined round
    /// a junction).
    pub knots: usize,
    /// Loops round a single triangle opened or left out.
    pub loops: usize,
    /// Their sides left out.
    pub loop_sides: usize,
    /// Crack length before and after (scene units).
    pub length: [f64; 2],
}

/// Smooth the crack paths of `mesh` over `passes` passes: its crack
/// vertices move (every copy of a point alike) and each end of `segments`
/// (ends at crack points' rest positions) follows its point. Spurs first
/// leave `segments` (and `times`, when it has one time per segment): a
/// crack of at most [`SPUR_SEGMENTS`] segments from a tip to a junction,
/// the border or another tip, the lattice's own noise at the scale of its
/// triangles; the crack it branched from then runs on through the junction.
/// So do loops round one triangle whose corners meet other cracks.
///
/// # Errors
/// A moved position that is not finite (never on a valid mesh).
pub fn smooth(
    mesh: &mut SimMesh,
    segments: &mut Vec<[[f64; 3]; 2]>,
    times: &mut Vec<f64>,
    passes: usize,
) -> Result<PathReport, MeshError> {
    let border = border_keys(mesh);
    let Some((mut report, g)) = prune(segments, times, passes, &border) else {
        return Ok(report_of(segments));
    };
    // Every vertex resting at a crack point (its copies along the crack).
    let mut copies: Vec<Vec<VertexId>> = vec![Vec::new(); g.rest.len()];
    for h in mesh.halfedges().filter(|&h| mesh.is_boundary_halfedge(h)) {
        for v in [mesh.origin(h), mesh.dest(h)] {
            if let Some(&i) = g.index.get(&key(mesh.position(v))) {
                if !copies[i].contains(&v) {
                    copies[i].push(v);
                }
            }
        }
    }
    // A tip's single vertex is on no boundary; it stays anyway.
    let free: Vec<usize> = (0..g.rest.len())
        .filter(|&i| {
            g.next[i].len() == 2 && !border.contains(&key(g.rest[i])) && !copies[i].is_empty()
        })
        .collect();
    let surface = Faces::of_mesh(mesh);
    let start: Vec<[f64; 3]> = mesh.positions().to_vec();
    let mut at = start.clone();
    let (point, held) = relax(&g, &free, passes, &surface, |i, to| {
        let fits = copies[i]
            .iter()
            .all(|&v| faces_keep(mesh, &start, &at, v, to));
        if fits {
            for &v in &copies[i] {
                at[v.idx()] = to;
            }
        }
        fits
    });
    mesh.set_positions(&at)?;
    for (s, e) in segments.iter_mut().zip(&g.ends) {
        *s = e.map(|i| point[i]);
    }
    report.free = free.len();
    report.held = held;
    report.length[1] = report_of(segments).length[1];
    Ok(report)
}

/// Smooth crack lines drawn over `surface` (not cut into it: the lines
/// across broken springs), as [`smooth`] does its cracks: first each open
/// end joins the nearest point of another crack (or of its own, farther
/// along it than [`JOIN_HOPS`] segments) within [`JOIN_EDGES`] of the
/// surface's edges (where the springs across a crack's path broke only
/// every other one, the dashes join into the crack); then spurs and loops
/// leave, and each point between two others moves toward their mean, kept
/// on the surface.
pub fn smooth_lines(
    surface: &SimMesh,
    broken: &[[[f64; 3]; 2]],
    lines: &mut Vec<[[f64; 3]; 2]>,
    times: &mut Vec<f64>,
    passes: usize,
) -> PathReport {
    if passes == 0 || lines.is_empty() {
        return report_of(lines);
    }
    let before = report_of(lines).length[0];
    let rings = ring_nodes(surface, broken, lines, times);
    let reach = JOIN_EDGES * surface.mean_edge_length();
    let joined = join_tips(lines, times, reach) + join_border(surface, lines, times, reach);
    let faces = Faces::of_mesh(surface);
    let knots = contract_knots(
        lines,
        times,
        KNOT_EDGES * surface.mean_edge_length(),
        &faces,
    );
    let Some((mut report, g)) = prune(lines, times, passes, &Default::default()) else {
        return report_of(lines);
    };
    report.joined = joined;
    report.rings = rings;
    report.knots = knots;
    report.length[0] = before;
    // A point on a small loop stays: smoothing would shrink the loop (a
    // line has no faces to hold it, as a cut crack has).
    let free: Vec<usize> = (0..g.rest.len())
        .filter(|&i| g.next[i].len() == 2 && !on_small_loop(&g, i))
        .collect();
    let (point, held) = relax(&g, &free, passes, &faces, |_, _| true);
    for (s, e) in lines.iter_mut().zip(&g.ends) {
        *s = e.map(|i| point[i]);
    }
    report.free = free.len();
    report.held = held;
    report.length[1] = report_of(lines).length[1];
    report
}

/// A node's neighbours (by position), its broken springs (indices), and
/// whether it is on the surface's own border.
type Around = (Vec<[u64; 3]>, Vec<usize>, bool);

/// A node whose springs all broke (or all but one) stands (nearly) alone,
/// and the lines across its springs ring it (`lines[k]` crosses
/// `broken[k]`, an edge of `surface` at rest): the cracks meet there. Each such ring's points move to the
/// node and its own lines (now of no length) leave. How many nodes.
fn ring_nodes(
    surface: &SimMesh,
    broken: &[[[f64; 3]; 2]],
    lines: &mut Vec<[[f64; 3]; 2]>,
    times: &mut Vec<f64>,
) -> usize {
    if broken.len() != lines.len() {
        return 0;
    }
    // Each position's neighbours on the surface, and its broken springs.
    let mut around: BTreeMap<[u64; 3], Around> = BTreeMap::new();
    for h in surface.halfedges() {
        let (a, b) = (
            surface.position(surface.origin(h)),
            surface.position(surface.dest(h)),
        );
        let e = around.entry(key(a)).or_default();
        if !e.0.contains(&key(b)) {
            e.0.push(key(b));
        }
        e.2 |= surface.is_boundary_halfedge(h) && !surface.is_crack_halfedge(h);
    }
    for (k, s) in broken.iter().enumerate() {
        for p in s {
            if let Some(e) = around.get_mut(&key(*p)) {
                e.1.push(k);
            }
        }
    }
    let mut to: BTreeMap<[u64; 3], [f64; 3]> = BTreeMap::new();
    let mut rings = 0;
    for (p, (next, springs, border)) in &around {
        if *border || next.len() < 3 || springs.len() + 1 < next.len() {
            continue;
        }
        let at = p.map(f64::from_bits);
        for &k in springs {
            for q in lines[k] {
                to.entry(key(q)).or_insert(at);
            }
        }
        rings += 1;
    }
    if rings == 0 {
        return 0;
    }
    for l in lines.iter_mut() {
        *l = l.map(|q| to.get(&key(q)).copied().unwrap_or(q));
    }
    let timed = times.len() == lines.len();
    let gone: Vec<bool> = lines.iter().map(|l| key(l[0]) == key(l[1])).collect();
    retain(lines, times, timed, &gone);
    rings
}

/// Every loop of `lines` of at most [`SMALL_LOOP`] segments and `perimeter`
/// in length is drawn in to its points' mean on `surface` (loops sharing a
/// point, to their points' mean together); its own lines (now of no
/// length) leave.
/// How many points' groups.
fn contract_knots(
    lines: &mut Vec<[[f64; 3]; 2]>,
    times: &mut Vec<f64>,
    perimeter: f64,
    surface: &Faces,
) -> usize {
    let g = Graph::of(lines);
    let n = g.rest.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let seg_len = |k: usize| {
        let [a, b] = g.ends[k];
        v3::norm(v3::sub(g.rest[a], g.rest[b]))
    };
    let mut any = false;
    for (k, &[a, b]) in g.ends.iter().enumerate() {
        if a == b {
            continue;
        }
        // The shortest way (in segments) from a to b without segment k,
        // within the loop's reach.
        let mut from: BTreeMap<usize, (usize, usize)> = BTreeMap::new();
        from.insert(a, (a, usize::MAX));
        let mut ring = vec![a];
        let mut found = false;
        for _ in 0..SMALL_LOOP - 1 {
            let mut next = Vec::new();
            for &p in &ring {
                for &(q, j) in &g.next[p] {
                    if j == k || from.contains_key(&q) {
                        continue;
                    }
                    from.insert(q, (p, j));
                    next.push(q);
                    found |= q == b;
                }
            }
            if found || next.is_empty() {
                break;
            }
            ring = next;
        }
        if !found {
            continue;
        }
        let mut cycle = vec![b];
        let mut length = seg_len(k);
        let mut at = b;
        while at != a {
            let (p, j) = from[&at];
            length += seg_len(j);
            cycle.push(p);
            at = p;
        }
        if length > perimeter {
            continue;
        }
        for w in cycle.windows(2) {
            let (x, y) = (root(&mut parent, w[0]), root(&mut parent, w[1]));
            if x != y {
                parent[x.max(y)] = x.min(y);
                any = true;
            }
        }
    }
    if !any {
        return 0;
    }
    let mut sum: BTreeMap<usize, ([f64; 3], f64)> = BTreeMap::new();
    for i in 0..n {
        let r = root(&mut parent, i);
        let e = sum.entry(r).or_insert(([0.0; 3], 0.0));
        e.0 = v3::add(e.0, g.rest[i]);
        e.1 += 1.0;
    }
    let groups = sum.values().filter(|e| e.1 > 1.0).count();
    let at: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let (p, c) = sum[&root(&mut parent, i)];
            if c > 1.0 {
                let m = v3::scale(p, 1.0 / c);
                surface.closest(m).map_or(m, |(_, _, q)| q)
            } else {
                g.rest[i]
            }
        })
        .collect();
    for (l, e) in lines.iter_mut().zip(&g.ends) {
        *l = e.map(|i| at[i]);
    }
    let timed = times.len() == lines.len();
    let gone: Vec<bool> = lines.iter().map(|l| key(l[0]) == key(l[1])).collect();
    retain(lines, times, timed, &gone);
    groups
}

/// Whether point `i` (between two others) lies on a loop of at most
/// [`SMALL_LOOP`] segments: its neighbours meet again without it.
fn on_small_loop(g: &Graph, i: usize) -> bool {
    let (a, b) = (g.next[i][0].0, g.next[i][1].0);
    let mut seen = vec![a];
    let mut ring = vec![a];
    for _ in 0..SMALL_LOOP - 2 {
        let mut next = Vec::new();
        for &p in &ring {
            for &(q, _) in &g.next[p] {
                if q == b {
                    return true;
                }
                if q != i && !seen.contains(&q) {
                    seen.push(q);
                    next.push(q);
                }
            }
        }
        ring = next;
    }
    false
}

/// Join each open end of `lines` (in the order of its points) to the
/// nearest point within `reach` that is not within [`JOIN_HOPS`] segments
/// along its own crack: a new segment, timed as the end's own. How many.
fn join_tips(lines: &mut Vec<[[f64; 3]; 2]>, times: &mut Vec<f64>, reach: f64) -> usize {
    let g = Graph::of(lines);
    let timed = times.len() == lines.len();
    let grid = crate::mesh::spatial::Grid::new(g.rest.iter().map(|&p| (p, p)), reach);
    let mut degree: Vec<usize> = g.next.iter().map(Vec::len).collect();
    let mut joined = 0;
    for tip in 0..g.rest.len() {
        if degree[tip] != 1 {
            continue;
        }
        // Its own crack's points near it.
        let mut near = vec![tip];
        let mut ring = vec![tip];
        for _ in 0..JOIN_HOPS {
            let mut next = Vec::new();
            for &i in &ring {
                for &(j, _) in &g.next[i] {
                    if !near.contains(&j) {
                        near.push(j);
                        next.push(j);
                    }
                }
            }
            ring = next;
        }
        let p = g.rest[tip];
        let mut best: Option<(f64, usize)> = None;
        grid.search(p, |j| {
            let d = crate::mesh::spatial::dist2(p, g.rest[j]);
            if d <= reach * reach
                && !near.contains(&j)
                && best.is_none_or(|b| d < b.0 || (d == b.0 && j < b.1))
            {
                best = Some((d, j));
            }
            Some(best.map_or(reach * reach, |b| b.0))
        });
        if let Some((_, j)) = best {
            lines.push([p, g.rest[j]]);
            if timed {
                times.push(times[g.next[tip][0].1]);
            }
            degree[tip] += 1;
            degree[j] += 1;
            joined += 1;
        }
    }
    joined
}

/// Run each open end of `lines` within `reach` of `surface`'s own border
/// on to its closest point there (a line across broken springs ends at a
/// triangle's centroid, short of the border the crack reached). How many.
fn join_border(
    surface: &SimMesh,
    lines: &mut Vec<[[f64; 3]; 2]>,
    times: &mut Vec<f64>,
    reach: f64,
) -> usize {
    use crate::mesh::spatial::{closest_on_segment, dist2, Grid};
    let border: Vec<[[f64; 3]; 2]> = surface
        .halfedges()
        .filter(|&h| surface.is_boundary_halfedge(h) && !surface.is_crack_halfedge(h))
        .map(|h| {
            [
                surface.position(surface.origin(h)),
                surface.position(surface.dest(h)),
            ]
        })
        .collect();
    if border.is_empty() {
        return 0;
    }
    let grid = Grid::new(border.iter().map(|s| crate::mesh::spatial::bbox(s)), reach);
    let g = Graph::of(lines);
    let timed = times.len() == lines.len();
    let mut joined = 0;
    for tip in (0..g.rest.len()).filter(|&i| g.next[i].len() == 1) {
        let p = g.rest[tip];
        let mut best: Option<(f64, [f64; 3])> = None;
        grid.search(p, |k| {
            let q = closest_on_segment(p, border[k][0], border[k][1]);
            let d = dist2(p, q);
            if d <= reach * reach && best.is_none_or(|b| d < b.0) {
                best = Some((d, q));
            }
            Some(best.map_or(reach * reach, |b| b.0))
        });
        if let Some((_, q)) = best.filter(|b| b.0 > 0.0) {
            lines.push([p, q]);
            if timed {
                times.push(times[g.next[tip][0].1]);
            }
            joined += 1;
        }
    }
    joined
}

/// A report of segments left as they are.
fn report_of(segments: &[[[f64; 3]; 2]]) -> PathReport {
    let length = segments
        .iter()
        .map(|[a, b]| v3::norm(v3::sub(*b, *a)))
        .sum();
    PathReport {
        length: [length; 2],
        ..PathReport::default()
    }
}

/// Loops, then spurs, out of `segments` (and `times`); the report so far
/// and the graph of what is left. None when there is nothing to smooth.
fn prune(
    segments: &mut Vec<[[f64; 3]; 2]>,
    times: &mut Vec<f64>,
    passes: usize,
    border: &std::collections::BTreeSet<[u64; 3]>,
) -> Option<(PathReport, Graph)> {
    if passes == 0 || segments.is_empty() {
        return None;
    }
    let before = report_of(segments).length[0];
    let timed = times.len() == segments.len();
    let mut knots = vec![false; segments.len()];
    let loops = open_loops(segments, &mut knots);
    let loop_sides = retain(segments, times, timed, &knots);
    let spur = spurs(segments, border);
    let spurs = retain(segments, times, timed, &spur);
    let report = PathReport {
        spurs,
        loops,
        loop_sides,
        length: [before, before],
        ..PathReport::default()
    };
    Some((report, Graph::of(segments)))
}

/// `passes` passes over the `free` points of `g`, in order, each moved
/// toward its two neighbours' mean and onto `surface`, where `place`
/// accepts it (its step halved up to [`HALVINGS`] times until it does).
/// Every point's place, and the moves taken short or left out.
fn relax(
    g: &Graph,
    free: &[usize],
    passes: usize,
    surface: &Faces,
    mut place: impl FnMut(usize, [f64; 3]) -> bool,
) -> (Vec<[f64; 3]>, usize) {
    let mut point = g.rest.clone();
    let mut held = 0;
    for _ in 0..passes {
        for &i in free {
            let [a, b] = [g.next[i][0].0, g.next[i][1].0];
            let mid = v3::scale(v3::add(point[a], point[b]), 0.5);
            let mut step = STEP;
            let mut moved = false;
            for _ in 0..=HALVINGS {
                let want = v3::add(point[i], v3::scale(v3::sub(mid, point[i]), step));
                let to = surface.closest(want).map_or(want, |(_, _, q)| q);
                if place(i, to) {
                    point[i] = to;
                    moved = true;
                    break;
                }
                step *= 0.5;
            }
            if !moved || step < STEP {
                held += 1;
            }
        }
    }
    (point, held)
}

/// Keep the segments (and their times when `timed`) not marked in `drop`;
/// how many left.
fn retain(
    segments: &mut Vec<[[f64; 3]; 2]>,
    times: &mut Vec<f64>,
    timed: bool,
    drop: &[bool],
) -> usize {
    let mut k = 0;
    segments.retain(|_| {
        k += 1;
        !drop[k - 1]
    });
    if timed {
        let mut k = 0;
        times.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
    }
    drop.iter().filter(|&&d| d).count()
}

/// The crack points of some segments, each once, and their neighbours.
struct Graph {
    /// Point of each position.
    index: BTreeMap<[u64; 3], usize>,
    /// Position of each point.
    rest: Vec<[f64; 3]>,
    /// Points of each segment.
    ends: Vec<[usize; 2]>,
    /// Per point: its neighbours, and the segments to them.
    next: Vec<Vec<(usize, usize)>>,
}

impl Graph {
    fn of(segments: &[[[f64; 3]; 2]]) -> Graph {
        let mut index: BTreeMap<[u64; 3], usize> = BTreeMap::new();
        let mut rest: Vec<[f64; 3]> = Vec::new();
        let mut id = |p: [f64; 3]| {
            *index.entry(key(p)).or_insert_with(|| {
                rest.push(p);
                rest.len() - 1
            })
        };
        let ends: Vec<[usize; 2]> = segments.iter().map(|s| s.map(&mut id)).collect();
        let mut next: Vec<Vec<(usize, usize)>> = vec![Vec::new(); rest.len()];
        for (k, &[a, b]) in ends.iter().enumerate() {
            if a != b {
                next[a].push((b, k));
                next[b].push((a, k));
            }
        }
        for n in &mut next {
            n.sort_unstable();
            n.dedup_by_key(|e| e.0);
        }
        Graph {
            index,
            rest,
            ends,
            next,
        }
    }
}

/// Loops of three crack segments round one triangle of the simulation
/// surface, where cracks meet at its corners (a knot the size of a
/// triangle): each loses the side whose ends both meet other cracks, so
/// the cracks run on through the triangle's corners. Marks the sides left
/// out in `out` (beside the spurs already there); how many loops.
fn open_loops(segments: &[[[f64; 3]; 2]], out: &mut [bool]) -> usize {
    let g = Graph::of(segments);
    let mut degree: Vec<usize> = (0..g.rest.len())
        .map(|i| g.next[i].iter().filter(|e| !out[e.1]).count())
        .collect();
    let mut opened = 0;
    for (k, &[a, b]) in g.ends.iter().enumerate() {
        if out[k] || a == b {
            continue;
        }
        for &(c, ka) in &g.next[a] {
            let Some(&(_, kb)) = g.next[b].iter().find(|e| e.0 == c) else {
                continue;
            };
            if out[ka] || out[kb] || out[k] {
                continue;
            }
            // The triangle (a, b, c): leave out the side whose ends have
            // the most other cracks, when both have one; with other cracks
            // at one corner or none, the whole loop (a cell of one
            // triangle, the lattice's noise).
            let sides = [(k, a, b), (ka, a, c), (kb, b, c)];
            let best = sides
                .iter()
                .filter(|s| degree[s.1] >= 3 && degree[s.2] >= 3)
                .max_by_key(|s| (degree[s.1] + degree[s.2], std::cmp::Reverse(s.0)));
            let leave: Vec<(usize, usize, usize)> = match best {
                Some(&side) => vec![side],
                None if [a, b, c].iter().filter(|&&p| degree[p] >= 3).count() <= 1 => {
                    sides.to_vec()
                }
                None => Vec::new(),
            };
            for &(side, p, q) in &leave {
                out[side] = true;
                degree[p] -= 1;
                degree[q] -= 1;
            }
            opened += usize::from(!leave.is_empty());
        }
    }
    opened
}

/// Per segment, whether it belongs to a spur (see [`smooth`]).
fn spurs(segments: &[[[f64; 3]; 2]], border: &std::collections::BTreeSet<[u64; 3]>) -> Vec<bool> {
    let g = Graph::of(segments);
    let stops = |i: usize| g.next[i].len() != 2 || border.contains(&key(g.rest[i]));
    let mut out = vec![false; segments.len()];
    for tip in 0..g.rest.len() {
        if g.next[tip].len() != 1 || border.contains(&key(g.rest[tip])) {
            continue;
        }
        let mut path = Vec::new();
        let (mut at, mut from) = (tip, usize::MAX);
        while path.len() <= SPUR_SEGMENTS {
            let Some(&(to, k)) = g.next[at].iter().find(|e| e.1 != from) else {
                break;
            };
            path.push(k);
            (at, from) = (to, k);
            if stops(at) {
                if path.len() <= SPUR_SEGMENTS {
                    for &k in &path {
                        out[k] = true;
                    }
                }
                break;
            }
        }
    }
    out
}

/// Whether every face around `v` keeps its side and a tenth of its area
/// (against `start`) with `v` at `to` and the others at `at`.
fn faces_keep(
    mesh: &SimMesh,
    start: &[[f64; 3]],
    at: &[[f64; 3]],
    v: VertexId,
    to: [f64; 3],
) -> bool {
    mesh.vertex_faces(v).all(|f| {
        let vs = mesh.face_vertices(f);
        let was = normal(vs.map(|u| start[u.idx()]));
        let now = normal(vs.map(|u| if u == v { to } else { at[u.idx()] }));
        let a0 = v3::dot(was, was).sqrt();
        a0 == 0.0 || v3::dot(now, was) >= MIN_AREA_SHARE * a0 * a0
    })
}

/// Twice the area vector of a triangle.
fn normal([a, b, c]: [[f64; 3]; 3]) -> [f64; 3] {
    v3::cross(v3::sub(b, a), v3::sub(c, a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::build;
    use crate::mesh::MeshInput;

    /// A flat n x n grid of unit squares, their diagonals alternating
    /// (square (i, j) split from (i, j) to (i + 1, j + 1) when i + j is odd),
    /// so a path of diagonals zig-zags.
    fn grid(n: usize) -> (SimMesh, Vec<Vec<VertexId>>) {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                positions.push([i as f64, j as f64, 0.0]);
            }
        }
        let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut triangles = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let [a, b, c, d] = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                if (i + j) % 2 == 1 {
                    triangles.extend([[a, b, c], [a, c, d]]);
                } else {
                    triangles.extend([[a, b, d], [b, c, d]]);
                }
            }
        }
        let input = MeshInput {
            positions: positions.clone(),
            triangles,
            face_groups: Vec::new(),
            wedge_channels: Vec::new(),
        };
        let (mesh, _) = build(&input);
        let ids = positions
            .chunks(n + 1)
            .map(|row| {
                row.iter()
                    .map(|p| mesh.vertices().find(|&v| mesh.position(v) == *p).unwrap())
                    .collect()
            })
            .collect();
        (mesh, ids)
    }

    /// Open the path through `points` (grid coordinates); its segments.
    fn open(
        mesh: &mut SimMesh,
        ids: &[Vec<VertexId>],
        points: &[(usize, usize)],
    ) -> Vec<[[f64; 3]; 2]> {
        let mut segments = Vec::new();
        for w in points.windows(2) {
            let (a, b) = (ids[w[0].1][w[0].0], ids[w[1].1][w[1].0]);
            let (pa, pb) = (mesh.position(a), mesh.position(b));
            // Find the edge between the points as they now are (opening
            // duplicates vertices).
            let h = mesh
                .halfedges()
                .find(|&h| {
                    !mesh.is_boundary_halfedge(h)
                        && mesh.position(mesh.origin(h)) == pa
                        && mesh.position(mesh.dest(h)) == pb
                })
                .expect("the edge is there");
            mesh.open_edge(h).unwrap();
            segments.push([pa, pb]);
        }
        segments
    }

    #[test]
    fn a_zigzag_crack_straightens_and_its_ends_stay() {
        // Across the grid from border to border along a staircase of
        // diagonals and horizontals: a zig-zag about y = 3.5.
        let (mut mesh, ids) = grid(8);
        let path: Vec<(usize, usize)> = (0..=8).map(|i| (i, 3 + (i % 2))).collect();
        let mut segments = open(&mut mesh, &ids, &path);
        let before = segments.clone();
        let report = smooth(&mut mesh, &mut segments, &mut Vec::new(), 4).unwrap();
        assert_eq!(report.free, 7);
        // Ends on the border stay.
        assert_eq!(segments[0][0], [0.0, 3.0, 0.0]);
        assert_eq!(segments[7][1], [8.0, 3.0, 0.0]);
        // The zig-zag is gone: each point lies within a tenth of the
        // zig-zag's height (1) of its neighbours' mean (it was 1 off it).
        let wobble = |s: &[[[f64; 3]; 2]]| {
            s.windows(2)
                .map(|w| (w[0][1][1] - 0.5 * (w[0][0][1] + w[1][1][1])).abs())
                .fold(0.0f64, f64::max)
        };
        assert_eq!(wobble(&before), 1.0);
        let after = wobble(&segments);
        assert!(after < 0.1, "{after} {report:?}");
        assert!(report.length[1] < report.length[0]);
        // Every copy of a point moved with it, and no face turned over.
        for f in mesh.faces() {
            assert!(mesh.face_area(f) > 0.0);
        }
        for s in &segments {
            for p in s {
                let n = mesh.positions().iter().filter(|q| *q == p).count();
                assert!(n >= 1, "a segment end at no vertex: {p:?}");
            }
        }
        assert!(report.held < report.free * 4);
    }

    #[test]
    fn a_tooth_round_one_triangle_keeps_a_tenth_of_it() {
        // The crack goes round one triangle's two sides: the point between
        // them may not flatten it.
        let (mut mesh, ids) = grid(6);
        let path = [
            (0, 3),
            (1, 3),
            (2, 3),
            (3, 4),
            (3, 3),
            (4, 3),
            (5, 3),
            (6, 3),
        ];
        let mut segments = open(&mut mesh, &ids, &path);
        let areas: Vec<f64> = mesh.faces().map(|f| mesh.face_area(f)).collect();
        smooth(&mut mesh, &mut segments, &mut Vec::new(), 6).unwrap();
        for (f, a0) in mesh.faces().zip(areas) {
            assert!(mesh.face_area(f) >= MIN_AREA_SHARE * a0 * 0.999, "{f:?}");
        }
    }

    #[test]
    fn junctions_and_tips_stay_and_spurs_go() {
        let (mut mesh, ids) = grid(8);
        // A crack from the border to a tip, a branch off it to another tip,
        // and a spur of one segment off it.
        let mut segments = open(
            &mut mesh,
            &ids,
            &[
                (0, 3),
                (1, 3),
                (2, 3),
                (3, 4),
                (4, 4),
                (5, 4),
                (6, 4),
                (7, 4),
            ],
        );
        segments.extend(open(&mut mesh, &ids, &[(2, 3), (2, 2), (2, 1), (3, 1)]));
        segments.extend(open(&mut mesh, &ids, &[(4, 4), (4, 3)]));
        let mut times: Vec<f64> = (0..segments.len()).map(|k| k as f64).collect();
        let report = smooth(&mut mesh, &mut segments, &mut times, 3).unwrap();
        assert_eq!(report.spurs, 1);
        assert_eq!(segments.len(), 10);
        // The spur's time left with it.
        assert_eq!(times, (0..10).map(f64::from).collect::<Vec<_>>());
        let kept = |p: [f64; 3]| segments.iter().any(|s| s.contains(&p));
        assert!(kept([2.0, 3.0, 0.0]), "the junction moved");
        assert!(kept([7.0, 4.0, 0.0]), "the tip moved");
        assert!(kept([3.0, 1.0, 0.0]), "the branch's tip moved");
        assert!(kept([0.0, 3.0, 0.0]), "the border end moved");
        assert!(!kept([4.0, 3.0, 0.0]), "the spur stayed");
        // The corner (3, 4) moved toward its neighbours' mean.
        assert!(!kept([3.0, 4.0, 0.0]), "nothing moved");
    }

    #[test]
    fn a_short_crack_of_its_own_is_a_spur_a_longer_one_is_not() {
        let (mut mesh, ids) = grid(8);
        let mut segments = open(&mut mesh, &ids, &[(1, 1), (2, 1), (3, 1)]);
        segments.extend(open(&mut mesh, &ids, &[(1, 5), (2, 5), (3, 5), (4, 5)]));
        let report = smooth(&mut mesh, &mut segments, &mut Vec::new(), 2).unwrap();
        assert_eq!(report.spurs, 2);
        assert_eq!(segments.len(), 3);
    }

    /// The lines' points and how many lines meet at each.
    fn degrees(lines: &[[[f64; 3]; 2]]) -> BTreeMap<[u64; 3], usize> {
        let mut d = BTreeMap::new();
        for l in lines {
            for p in l {
                *d.entry(key(*p)).or_insert(0) += 1;
            }
        }
        d
    }

    #[test]
    fn dashes_join_into_a_crack_from_border_to_border() {
        let (mesh, _) = grid(8);
        let at = |x: f64| [x, 3.0, 0.0];
        let mut lines: Vec<[[f64; 3]; 2]> = [0.5, 1.5, 2.5, 3.5]
            .windows(2)
            .chain([4.6, 5.5, 6.5, 7.5].windows(2))
            .map(|w| [at(w[0]), at(w[1])])
            .collect();
        let mut times = vec![0.0; lines.len()];
        let r = smooth_lines(&mesh, &[], &mut lines, &mut times, 2);
        // The gap between the dashes and both ends to the border.
        assert_eq!(r.joined, 3, "{r:?}");
        assert_eq!(times.len(), lines.len());
        let d = degrees(&lines);
        let tips: Vec<_> = d
            .iter()
            .filter(|e| *e.1 == 1)
            .map(|e| e.0.map(f64::from_bits))
            .collect();
        assert_eq!(tips.len(), 2, "{tips:?}");
        assert!(tips.iter().all(|p| p[0] == 0.0 || p[0] == 8.0), "{tips:?}");
    }

    #[test]
    fn a_small_loop_of_lines_draws_in_to_a_junction() {
        let (mesh, _) = grid(8);
        // A square 0.4 across round (4, 4), a crack off each corner.
        let c = [[3.8, 3.8], [4.2, 3.8], [4.2, 4.2], [3.8, 4.2]].map(|[x, y]| [x, y, 0.0]);
        let out = [[1.0, 1.0], [7.0, 1.0], [7.0, 7.0], [1.0, 7.0]].map(|[x, y]| [x, y, 0.0]);
        let mut lines = Vec::new();
        let along = |a: [f64; 3], b: [f64; 3], t: f64| v3::add(a, v3::scale(v3::sub(b, a), t));
        for k in 0..4 {
            lines.push([c[k], c[(k + 1) % 4]]);
            // Three segments out: not a spur.
            let (p, q) = (along(c[k], out[k], 0.33), along(c[k], out[k], 0.67));
            lines.extend([[c[k], p], [p, q], [q, out[k]]]);
        }
        let r = smooth_lines(&mesh, &[], &mut lines, &mut Vec::new(), 1);
        assert_eq!(r.knots, 1, "{r:?}");
        // The square's four sides left; each outer tip ran on to the border.
        assert_eq!(lines.len(), 12 + 4);
        let d = degrees(&lines);
        let centre = d
            .iter()
            .find(|e| *e.1 == 4)
            .map(|e| e.0.map(f64::from_bits));
        let centre = centre.expect("a four-way junction");
        assert!(
            v3::norm(v3::sub(centre, [4.0, 4.0, 0.0])) < 1e-9,
            "{centre:?}"
        );
    }
}
