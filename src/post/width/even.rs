//! Gaps that open evenly between junctions ([`super::displace`]): the
//! sides of the cracks walked from junction to junction, their openings
//! evened out and their outlines smoothed, and the corners where cracks
//! meet set to stand off both cracks.

use crate::math::v3;
use crate::mesh::{SimMesh, VertexId};

/// The largest factor by which a cell's corner opens beyond its sides
/// (`1 / sin(half its angle)`, capped here).
const MAX_CORNER_FACTOR: f64 = 2.0;

/// Even out the `opening` of the crack nodes (per copy, along its
/// direction away from the crack) side by side: along each side of a crack
/// between two junctions (a run of copies of two-copy crack nodes, from
/// one junction, T-junction or border to the next), every copy opens by the
/// run's mean. The relaxation displacement that sets the openings is an
/// elastic crack's: widest in the middle of a crack that was free while it
/// grew and small where it has since met another crack, so a cell's side
/// opened as a lens and the gap pinched shut at each junction; a dried
/// cell shrinks as a whole and its side stands off evenly. A run that ends
/// at a free tip keeps its own openings, which close towards the tip as a
/// crack's do. A corner copy (at a junction) then opens at least by its
/// sides' mean over `sin(half its angle)` (at most [`MAX_CORNER_FACTOR`]
/// times), so the corner stands off as far as its sides.
pub(super) fn even_openings(
    mesh: &SimMesh,
    groups: &[Vec<VertexId>],
    size: &[usize],
    runs: &[SideRun],
    opening: &mut [f64],
) {
    let mut evened = opening.to_vec();
    let mut in_run = vec![false; mesh.n_vertices()];
    for run in runs {
        for v in &run.nodes {
            in_run[v.idx()] = true;
        }
        if run.free_tip {
            continue;
        }
        let mean = run.nodes.iter().map(|v| opening[v.idx()]).sum::<f64>() / run.nodes.len() as f64;
        for v in &run.nodes {
            evened[v.idx()] = mean;
        }
    }
    let in_run = |v: VertexId| in_run[v.idx()];
    let beside = |v: VertexId| beside_on_crack(mesh, v);
    // Corners: at least their sides' mean, over sin(half the angle).
    for g in groups {
        for &v in g {
            if in_run(v) || size[v.idx()] < 2 {
                continue;
            }
            let sides: Vec<f64> = beside(v)
                .into_iter()
                .flatten()
                .filter(|&u| size[u.idx()] >= 2)
                .map(|u| evened[u.idx()])
                .collect();
            if sides.is_empty() {
                continue;
            }
            let side = sides.iter().sum::<f64>() / sides.len() as f64;
            let angle = mesh.fan_middle(v).map_or(std::f64::consts::PI, |(a, _)| a);
            let factor = (1.0 / (0.5 * angle).sin().max(1e-9)).min(MAX_CORNER_FACTOR);
            evened[v.idx()] = evened[v.idx()].max(side * factor);
        }
    }
    opening.copy_from_slice(&evened);
}

/// The move of T-junction copy `q` (a corner of a cell where its crack
/// ends on the side `edge` of another, whose move at `q` is `w`), evened:
/// off the other crack's far side as far as its own side there stands off
/// (the copy beside it along that side, else as far as the far side moved)
/// and off its own crack's side as far as the copy beside it along that
/// side. `None` without a direction into its faces.
pub(super) fn t_corner(
    mesh: &SimMesh,
    q: VertexId,
    edge: (VertexId, VertexId),
    w: [f64; 3],
    dirs: &[Option<[f64; 3]>],
    opening: &[f64],
) -> Option<[f64; 3]> {
    let along = v3::unit(v3::sub(mesh.position(edge.1), mesh.position(edge.0)))?;
    let dir = dirs[q.idx()]?;
    // Across the far side, towards `q`'s faces.
    let up = v3::unit(v3::sub(dir, v3::scale(along, v3::dot(dir, along))))?;
    let pq = mesh.position(q);
    // The copies beside `q`: along the other crack (its own side) or along
    // its own crack.
    let mut beside_along = None;
    let mut beside_own = None;
    for u in beside_on_crack(mesh, q).into_iter().flatten() {
        let (Some(n), Some(to)) = (dirs[u.idx()], v3::unit(v3::sub(mesh.position(u), pq))) else {
            continue;
        };
        if v3::dot(to, along).abs() > 0.7 {
            beside_along = Some(opening[u.idx()]);
        } else {
            beside_own = Some((n, opening[u.idx()]));
        }
    }
    let stand_off = beside_along.unwrap_or(-v3::dot(w, up)).max(0.0);
    let sideways = match beside_own {
        Some((n, o)) if v3::dot(along, n).abs() > 0.3 => {
            (o - stand_off * v3::dot(up, n)) / v3::dot(along, n)
        }
        _ => v3::dot(w, along),
    };
    Some(v3::add(
        v3::scale(up, stand_off),
        v3::scale(along, sideways),
    ))
}

/// One side of a crack between two junctions: copies of two-copy crack
/// nodes (not on a T-junction), in order along the side.
pub(super) struct SideRun {
    nodes: Vec<VertexId>,
    /// The copies beyond each end (a junction's copy, a tip, a T-junction
    /// node), `None` at the input's border.
    ends: [Option<VertexId>; 2],
    /// Whether an end is a free crack tip (a crack node with one copy).
    free_tip: bool,
}

/// How many copies each crack node's vertex has (0 off the cracks).
pub(super) fn group_sizes(mesh: &SimMesh, groups: &[Vec<VertexId>]) -> Vec<usize> {
    let mut size = vec![0usize; mesh.n_vertices()];
    for g in groups {
        for v in g {
            size[v.idx()] = g.len();
        }
    }
    size
}

/// The copies beside crack copy `v` along its side of the crack: ahead
/// (along its first outgoing halfedge) and behind.
fn beside_on_crack(mesh: &SimMesh, v: VertexId) -> [Option<VertexId>; 2] {
    let Some(first) = mesh.vertex_outgoing(v).next() else {
        return [None, None];
    };
    let Some(last) = mesh.vertex_outgoing(v).last().map(|h| mesh.prev(h)) else {
        return [None, None];
    };
    [
        mesh.is_crack_halfedge(first).then(|| mesh.dest(first)),
        mesh.is_crack_halfedge(last).then(|| mesh.origin(last)),
    ]
}

/// The [`SideRun`]s of `mesh`'s cracks, in order of their smallest copy.
pub(super) fn side_runs(
    mesh: &SimMesh,
    groups: &[Vec<VertexId>],
    size: &[usize],
    junctions: &[(VertexId, VertexId, VertexId, f64)],
) -> Vec<SideRun> {
    let n = mesh.n_vertices();
    let mut on_t = vec![false; n];
    for &(q, _, _, _) in junctions {
        on_t[q.idx()] = true;
    }
    let in_run = |v: VertexId| size[v.idx()] == 2 && !on_t[v.idx()];
    let mut seen = vec![false; n];
    let mut starts: Vec<VertexId> = groups.iter().flatten().copied().collect();
    starts.sort();
    let mut runs = Vec::new();
    for start in starts {
        if !in_run(start) || seen[start.idx()] {
            continue;
        }
        seen[start.idx()] = true;
        // Ahead from `start`, then behind it (reversed in front).
        let mut halves: [Vec<VertexId>; 2] = [Vec::new(), Vec::new()];
        let mut ends = [None, None];
        for (k, half) in halves.iter_mut().enumerate() {
            let mut v = start;
            loop {
                match beside_on_crack(mesh, v)[k] {
                    Some(u) if in_run(u) && !seen[u.idx()] => {
                        seen[u.idx()] = true;
                        half.push(u);
                        v = u;
                    }
                    Some(u) if in_run(u) => break, // a closed loop
                    end => {
                        ends[k] = end;
                        break;
                    }
                }
            }
        }
        let [ahead, behind] = halves;
        let nodes: Vec<VertexId> = behind
            .into_iter()
            .rev()
            .chain(std::iter::once(start))
            .chain(ahead)
            .collect();
        let free_tip = ends.iter().flatten().any(|u| size[u.idx()] < 2);
        runs.push(SideRun {
            nodes,
            ends: [ends[1], ends[0]],
            free_tip,
        });
    }
    runs
}

/// Passes of smoothing along a side of a crack over its opened outline.
const RUN_SMOOTHING: usize = 4;

/// Smooth each evened side's opened outline (the copies' rest positions
/// plus `open`, their openings) along the side, its ends held, each copy
/// moving off its opened position by at most its own opening: a crack
/// follows the simulation surface's edges and zig-zags at their scale, and
/// each copy opened straight away from its own bit of the crack, so in each
/// inner bend the openings ran into each other and, opened by more than an
/// edge, crossed (flipping the triangles there, whose shortening then
/// pinched the gap). An outline offset that far cuts across such bends, as
/// a shrinking cell's edge does. Shut sides do not move; runs that end at
/// a free tip keep their openings.
pub(super) fn smooth_runs(mesh: &SimMesh, runs: &[SideRun], open: &mut [[f64; 3]]) {
    let at = |v: VertexId, open: &[[f64; 3]]| v3::add(mesh.position(v), open[v.idx()]);
    for run in runs.iter().filter(|r| !r.free_tip && r.nodes.len() >= 2) {
        let given: Vec<[f64; 3]> = run.nodes.iter().map(|&v| at(v, open)).collect();
        let mut p = given.clone();
        let first = run.ends[0].map(|u| at(u, open));
        let last = run.ends[1].map(|u| at(u, open));
        for _ in 0..RUN_SMOOTHING {
            let q = p.clone();
            for i in 0..q.len() {
                // A side ending on the border keeps its end there.
                let before = if i == 0 { first } else { Some(q[i - 1]) };
                let after = if i + 1 == q.len() {
                    last
                } else {
                    Some(q[i + 1])
                };
                if let (Some(b), Some(a)) = (before, after) {
                    let mid = v3::scale(v3::add(b, a), 0.5);
                    p[i] = v3::add(q[i], v3::scale(v3::sub(mid, q[i]), 0.5));
                }
            }
        }
        for ((&v, g), s) in run.nodes.iter().zip(&given).zip(&p) {
            let d = v3::sub(*s, *g);
            let (l, reach) = (v3::norm(d), v3::norm(open[v.idx()]));
            let d = if l > reach {
                v3::scale(d, reach / l)
            } else {
                d
            };
            open[v.idx()] = v3::add(open[v.idx()], d);
        }
    }
}

/// How many copies along each side of a corner [`round_corners`] looks at
/// at most (the rounding reaches `2 r cot(angle / 2)` along a side: 3.5 r at
/// 60 degrees, many copies on a fine surface with wide gaps).
const CORNER_WALK: usize = 64;

/// Corners flatter than this (radians between their two sides) are left
/// as they are: their sides' offsets do not run into each other.
const FLAT_CORNER: f64 = 160.0 * std::f64::consts::PI / 180.0;

/// How far a rounded corner may move, in its sides' larger opening: a
/// right-angled corner moves 1.83 of it, one of 60 degrees 3; sharper
/// corners (slivers of cells between two nearly parallel cracks, or a
/// corner misread on a coarse or strongly curved surface) are not rounded.
const MAX_ROUNDING: f64 = 3.0;

/// Round the cells' corners where cracks meet (`[post] gap_band`): at a
/// junction's or T-junction's copy whose two sides meet at an angle below
/// [`FLAT_CORNER`], its sides offset straight by their openings would run
/// into each other wherever the gap is wider than a side's first edges
/// (a swallowtail: the triangles there turned over, and their shortening
/// pinched the gap shut at the junction, where mud's gaps are widest). The
/// corner's copies, and the side copies up to where the rounding meets the
/// straight offset, move instead onto a circle of radius `r` (the sides'
/// mean opening) touching both sides' offset lines: each to the circle's
/// point towards its rest position, so they keep their order along the
/// outline and the cell's corner shrinks as a dried one does. `mv` holds
/// each crack copy's move (its opening); `opening` the openings as
/// evened. Returns the number of copies moved onto a circle.
pub(super) fn round_corners(
    mesh: &SimMesh,
    size: &[usize],
    on_t: &[bool],
    opening: &[f64],
    mv: &mut [[f64; 3]],
) -> usize {
    let in_run = |v: VertexId| size[v.idx()] == 2 && !on_t[v.idx()];
    let mut targets: Vec<(VertexId, [f64; 3])> = Vec::new();
    let mut corners: Vec<VertexId> = (0..mesh.n_vertices() as u32)
        .map(VertexId)
        .filter(|&v| size[v.idx()] >= 3 || (on_t[v.idx()] && size[v.idx()] >= 1))
        .collect();
    corners.sort();
    for c in corners {
        let beside = beside_on_crack(mesh, c);
        let pc = mesh.position(c);
        // A reflex corner (a fan over half a turn) opens without running
        // into itself.
        let Some(b) = mesh
            .fan_middle(c)
            .filter(|&(angle, _)| angle < FLAT_CORNER)
            .map(|(_, m)| m)
        else {
            continue;
        };
        // Each side: its copies out from the corner, its direction, its
        // opening.
        let mut sides: Vec<(Vec<VertexId>, [f64; 3], f64)> = Vec::new();
        for (k, first) in beside.iter().enumerate() {
            let Some(mut u) = *first else { break };
            let mut walked = Vec::new();
            while in_run(u) && walked.len() < CORNER_WALK && u != c {
                walked.push(u);
                match beside_on_crack(mesh, u)[k] {
                    Some(next) => u = next,
                    None => break,
                }
            }
            let Some(&first) = walked.first() else { break };
            let o = opening[first.idx()];
            // The side's way from the corner: to its third copy, or as far
            // as it goes.
            let far = walked[walked.len().min(3) - 1];
            let Some(t) = v3::unit(v3::sub(mesh.position(far), pc)) else {
                break;
            };
            sides.push((walked, t, o));
        }
        let [(w1, t1, o1), (w2, t2, o2)] = match <[_; 2]>::try_from(sides) {
            Ok(s) => s,
            Err(_) => continue,
        };
        if v3::dot(t1, t2).clamp(-1.0, 1.0).acos() > FLAT_CORNER
            || v3::dot(b, v3::add(t1, t2)) <= 0.0
            || o1 <= 0.0
            || o2 <= 0.0
        {
            continue;
        }
        // Inward normals of the sides, in the corner's plane.
        let inward = |t: [f64; 3]| v3::unit(v3::sub(b, v3::scale(t, v3::dot(b, t))));
        let (Some(n1), Some(n2)) = (inward(t1), inward(t2)) else {
            continue;
        };
        let r = 0.5 * (o1 + o2);
        // The circle's centre: `o_k + r` off side k's line, for both.
        let c12 = v3::dot(n1, n2);
        let det = 1.0 - c12 * c12;
        if det < 1e-6 {
            continue;
        }
        let (d1, d2) = (o1 + r, o2 + r);
        let alpha = (d1 - c12 * d2) / det;
        let beta = (d2 - c12 * d1) / det;
        let x = v3::add(v3::scale(n1, alpha), v3::scale(n2, beta));
        // A corner sharper than the rounding may take keeps its straight
        // offsets (shortened where they turn a triangle over).
        if v3::norm(x) - r > MAX_ROUNDING * o1.max(o2) {
            continue;
        }
        let q = v3::add(pc, x);
        let onto = |p: [f64; 3]| -> Option<[f64; 3]> {
            let u = v3::unit(v3::sub(p, q))?;
            Some(v3::sub(v3::add(q, v3::scale(u, r)), p))
        };
        if let Some(m) = onto(pc) {
            targets.push((c, m));
        }
        for (walked, t) in [(&w1, t1), (&w2, t2)] {
            // Up to where the circle touches the side's offset line.
            let reach = v3::dot(x, t);
            for &p in walked {
                let pp = mesh.position(p);
                if v3::dot(v3::sub(pp, pc), t) >= reach {
                    break;
                }
                if let Some(m) = onto(pp) {
                    targets.push((p, m));
                }
            }
        }
    }
    // A copy near two corners keeps the larger move.
    targets.sort_by(|a, b| a.0.cmp(&b.0).then(v3::norm(b.1).total_cmp(&v3::norm(a.1))));
    targets.dedup_by_key(|t| t.0);
    for &(v, m) in &targets {
        mv[v.idx()] = m;
    }
    targets.len()
}
