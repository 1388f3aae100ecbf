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
use crate::mesh::spatial::Faces;
use crate::mesh::{MeshError, SimMesh, VertexId};
use std::collections::BTreeMap;

/// How far a pass moves a point toward its neighbours' mean.
const STEP: f64 = 0.5;
/// Least area a face around a moved point keeps, as a fraction of its area
/// before the smoothing.
const MIN_AREA_SHARE: f64 = 0.1;
/// Times a step is halved before the point stays for the pass.
const HALVINGS: usize = 4;
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
/// So do loops round one triangle ([`open_loops`]).
///
/// # Errors
/// A moved position that is not finite (never on a valid mesh).
pub fn smooth(
    mesh: &mut SimMesh,
    segments: &mut Vec<[[f64; 3]; 2]>,
    times: &mut Vec<f64>,
    passes: usize,
) -> Result<PathReport, MeshError> {
    let border: std::collections::BTreeSet<[u64; 3]> = mesh
        .halfedges()
        .filter(|&h| mesh.is_boundary_halfedge(h) && !mesh.is_crack_halfedge(h))
        .flat_map(|h| [mesh.origin(h), mesh.dest(h)])
        .map(|v| key(mesh.position(v)))
        .collect();
    let Some((mut report, g)) = prune(segments, times, passes, &border) else {
        return Ok(report_of(segments));
    };
    // Every vertex resting at a crack point (its copies along the crack).
    let mut copies: Vec<Vec<VertexId>> = vec![Vec::new(); g.rest.len()];
    let mut on_border = vec![false; g.rest.len()];
    for h in mesh.halfedges() {
        if !mesh.is_boundary_halfedge(h) {
            continue;
        }
        let border = !mesh.is_crack_halfedge(h);
        for v in [mesh.origin(h), mesh.dest(h)] {
            if let Some(&i) = g.index.get(&key(mesh.position(v))) {
                if !copies[i].contains(&v) {
                    copies[i].push(v);
                }
                on_border[i] |= border;
            }
        }
    }
    // A tip's single vertex is on no boundary; it stays anyway.
    let free: Vec<usize> = (0..g.rest.len())
        .filter(|&i| g.next[i].len() == 2 && !on_border[i] && !copies[i].is_empty())
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

fn key(p: [f64; 3]) -> [u64; 3] {
    p.map(|x| (x + 0.0).to_bits())
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
}
