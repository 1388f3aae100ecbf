//! The sides of the cells the crack graph encloses: each face of the graph
//! as it lies on the surface (walked with the cell on the left, the arms
//! at every node in order around the surface's normal there), its corners
//! the junctions where its inside angle is below [`CORNER_DEG`], the angle
//! taken between the points an arm's length back and ahead along its
//! outline (so a T-junction's straight side is no corner of the cell on
//! that side, and a crack's small wiggles are not either).
//!
//! A face counts as a cell when it turns once about its inside (the outer
//! outline of a network on an open surface turns the other way) and no node
//! of it lies on the surface's border (cells the border cuts have sides the
//! cracks do not make).

use crate::math::v3::{add, cross, dot, norm, scale, sub};
use std::f64::consts::{PI, TAU};

/// A junction is a corner of a cell when the cell's inside angle there is
/// below this (degrees): a T-junction's straight side (about 180) is not.
pub const CORNER_DEG: f64 = 150.0;

/// The mean number of sides of the cells of the crack graph (`adj`: each
/// node's neighbours at `pos`; `normal`: the surface's normal at a node),
/// and how many cells it is over. `arm` (world units) is how far along the
/// outline the angle at a corner is taken; `on_border` tells a node on the
/// surface's border; faces with a vector area below `min_area` are left out.
pub fn mean_cell_sides(
    pos: &[[f64; 3]],
    adj: &[Vec<u32>],
    normal: impl Fn(usize) -> [f64; 3],
    on_border: impl Fn([f64; 3]) -> bool,
    arm: f64,
    min_area: f64,
) -> (f64, usize) {
    // Half-edges: `start[v]..start[v + 1]` leave `v`, in order around its
    // normal (counter-clockwise); `to[h]` is where `h` goes.
    let mut start = vec![0usize; pos.len() + 1];
    for (v, a) in adj.iter().enumerate() {
        start[v + 1] = start[v] + a.len();
    }
    let mut to = vec![0u32; start[pos.len()]];
    let mut normals = vec![[0.0; 3]; pos.len()];
    for (v, a) in adj.iter().enumerate().filter(|(_, a)| !a.is_empty()) {
        let n = normal(v);
        normals[v] = n;
        let out = &mut to[start[v]..start[v + 1]];
        out.copy_from_slice(a);
        if a.len() > 2 {
            let frame = tangent_frame(n, sub(pos[a[0] as usize], pos[v]));
            let angle = |u: &u32| {
                let d = sub(pos[*u as usize], pos[v]);
                dot(d, frame.1).atan2(dot(d, frame.0))
            };
            out.sort_by(|x, y| angle(x).total_cmp(&angle(y)).then(x.cmp(y)));
        }
    }
    let from = |h: usize| start.partition_point(|&s| s <= h) - 1;
    // The half-edge from `v` to `u` (the first, if the graph repeats it).
    let find = |v: usize, u: u32| (start[v]..start[v + 1]).find(|&h| to[h] == u);
    let mut seen = vec![false; to.len()];
    let (mut sides, mut cells) = (0usize, 0usize);
    for first in 0..to.len() {
        if seen[first] {
            continue;
        }
        // Walk the face with its inside on the left: at each node take the
        // arm just clockwise of the way back.
        let mut cycle = Vec::new();
        let mut h = first;
        while !seen[h] {
            seen[h] = true;
            cycle.push(h);
            let v = to[h] as usize;
            let Some(back) = find(v, from(h) as u32) else {
                break;
            };
            let deg = start[v + 1] - start[v];
            h = start[v] + (back - start[v] + deg - 1) % deg;
        }
        if h != first || !is_cell(pos, &normals, &cycle, &to, from, min_area) {
            continue;
        }
        let nodes: Vec<usize> = cycle.iter().map(|&h| from(h)).collect();
        if nodes.iter().any(|&v| on_border(pos[v])) {
            continue;
        }
        cells += 1;
        sides += corners(pos, &normals, &nodes, adj, arm);
    }
    let mean = if cells > 0 {
        sides as f64 / cells as f64
    } else {
        0.0
    };
    (mean, cells)
}

/// Two unit vectors spanning the plane normal to `n`, the first along `d`
/// (in the plane) when it can be.
fn tangent_frame(n: [f64; 3], d: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let n = scale(n, 1.0 / norm(n).max(1e-300));
    let t = sub(d, scale(n, dot(d, n)));
    let e1 = scale(t, 1.0 / norm(t).max(1e-300));
    (e1, cross(n, e1))
}

/// Whether the closed walk `cycle` bounds a cell: it turns once about its
/// inside (counter-clockwise about the normals, +2 pi, not the outer
/// outline's -2 pi; a U-turn at an open tip counts as -pi) and its vector
/// area is at least `min_area`.
fn is_cell(
    pos: &[[f64; 3]],
    normals: &[[f64; 3]],
    cycle: &[usize],
    to: &[u32],
    from: impl Fn(usize) -> usize,
    min_area: f64,
) -> bool {
    let (mut turning, mut area) = (0.0, [0.0; 3]);
    let o = pos[from(cycle[0])];
    for (i, &h) in cycle.iter().enumerate() {
        let next = cycle[(i + 1) % cycle.len()];
        let (a, v, b) = (pos[from(h)], pos[to[h] as usize], pos[to[next] as usize]);
        let (din, dout) = (sub(v, a), sub(b, v));
        let n = normals[to[h] as usize];
        let s = dot(n, cross(din, dout));
        let c = dot(din, dout);
        turning += if s == 0.0 && c < 0.0 {
            -PI
        } else {
            s.atan2(c * norm(n))
        };
        area = add(area, cross(sub(a, o), sub(v, o)));
    }
    turning > PI && 0.5 * norm(area) >= min_area
}

/// The corners of the cell whose outline passes `nodes` in order.
fn corners(
    pos: &[[f64; 3]],
    normals: &[[f64; 3]],
    nodes: &[usize],
    adj: &[Vec<u32>],
    arm: f64,
) -> usize {
    let n = nodes.len();
    // The point `arm` from node i walking forward (+1) or back (-1).
    let reach = |i: usize, forward: bool| {
        let v = pos[nodes[i]];
        for step in 1..=n {
            let k = if forward {
                (i + step) % n
            } else {
                (i + n - step) % n
            };
            if norm(sub(pos[nodes[k]], v)) >= arm || step == n {
                return pos[nodes[k]];
            }
        }
        v
    };
    (0..n)
        .filter(|&i| adj[nodes[i]].len() >= 3)
        .filter(|&i| {
            let v = pos[nodes[i]];
            let (f, b) = (sub(reach(i, true), v), sub(reach(i, false), v));
            let (e1, e2) = tangent_frame(normals[nodes[i]], f);
            // Inside on the left: from the way ahead to the way back,
            // counter-clockwise.
            let inside = dot(b, e2).atan2(dot(b, e1)).rem_euclid(TAU);
            inside.to_degrees() < CORNER_DEG
        })
        .count()
}

/// Each crack node's surface normal (`normals`: per vertex of `pos`, zero
/// off the surface): its own, else the nearest surface vertex's within
/// `reach` (a crack line's node beside the surface cut along it), else the
/// plane of its first two arms.
pub fn node_normals(
    pos: &[[f64; 3]],
    normals: &[[f64; 3]],
    adj: &[Vec<u32>],
    reach: f64,
) -> Vec<[f64; 3]> {
    let off = |v: usize| norm(normals[v]) == 0.0 && !adj[v].is_empty();
    if !(0..pos.len()).any(off) {
        // Every crack node is a vertex of the surface (cracks cut in place).
        return normals.to_vec();
    }
    let surface: Vec<usize> = (0..pos.len()).filter(|&v| norm(normals[v]) > 0.0).collect();
    let points: Vec<super::Seg> = surface.iter().map(|&v| [pos[v]; 2]).collect();
    let grid = super::Buckets::of_segments(&points, reach);
    (0..pos.len())
        .map(|v| {
            if !off(v) {
                return normals[v];
            }
            let mut best = (f64::INFINITY, usize::MAX);
            grid.near(pos[v], reach, |i| {
                let d = norm(sub(points[i][0], pos[v]));
                if d <= reach && (d, surface[i]) < best {
                    best = (d, surface[i]);
                }
                false
            });
            match (best.1, adj[v].as_slice()) {
                (u, _) if u != usize::MAX => normals[u],
                (_, [a, b, ..]) => {
                    cross(sub(pos[*a as usize], pos[v]), sub(pos[*b as usize], pos[v]))
                }
                _ => [0.0, 0.0, 1.0],
            }
        })
        .collect()
}
