//! Curvature-adapted edge lengths for remeshing (Botsch & Kobbelt's
//! adaptive sizing): where a surface bends tighter than the target edge can
//! follow, as on a knob, a hose or a bevel, edges shorten so that a chord
//! strays at most a given distance from the surface.

use super::halfedge::SimMesh;
use super::hash::FxHashSet;
use super::spatial::{add, cross, dist2, dot, norm, scale, sub};
use std::collections::BTreeMap;

/// A surface with at most this share of its area in triangles that have an
/// edge above the split length is fine enough to simulate as it is.
pub const FINE_ENOUGH_LONG_SHARE: f64 = 0.1;

/// Share of `mesh`'s area in triangles with an edge longer than `limit`
/// (0 for a surface without area).
pub fn long_edge_area_share(mesh: &SimMesh, limit: f64) -> f64 {
    let mut long = 0.0;
    let mut total = 0.0;
    for f in mesh.faces() {
        let [a, b, c] = mesh.face_vertices(f).map(|v| mesh.position(v));
        let area = mesh.face_area(f);
        total += area;
        let longest = dist2(a, b).max(dist2(b, c)).max(dist2(c, a)).sqrt();
        if longest > limit {
            long += area;
        }
    }
    if total > 0.0 {
        long / total
    } else {
        0.0
    }
}

/// The edge length each vertex asks for: `target`, shortened to the
/// length whose chord strays `chord_error` from a circle of the surface's
/// radius of curvature there (`2 sqrt(2 e r - e^2)`), but not below
/// `shortest` nor below the mean length of the input's own edges at the
/// vertex (a flat input facet gains nothing from more vertices: only
/// detail finer than the target is kept). The curvature across an edge is the angle between its two
/// faces' normals over their mean height above it; a vertex
/// takes the tightest of its edges'. `features` (sorted vertex pairs) are
/// kept as lines by the remesher and ask for nothing; nor do open edges.
/// A `chord_error` of 0 gives `target` everywhere.
pub(crate) fn edge_sizes(
    pos: &[[f64; 3]],
    faces: &[[u32; 3]],
    features: &FxHashSet<(u32, u32)>,
    target: f64,
    chord_error: f64,
    shortest: f64,
) -> Vec<f64> {
    let mut size = vec![target; pos.len()];
    let e = chord_error;
    if e.is_nan() || e <= 0.0 {
        return size;
    }
    let floor = shortest.min(target);
    // Ordered: the sums below take the edges in one order every run.
    let mut faces_of: BTreeMap<(u32, u32), Vec<u32>> = BTreeMap::new();
    for (f, t) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            faces_of
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(f as u32);
        }
    }
    // The input's own edge length at each vertex: refining a flat input
    // facet adds nothing, so no edge is asked to be shorter than the
    // input's edges around it (only finer input detail is kept).
    let mut own = vec![(0.0f64, 0u32); pos.len()];
    for &(a, b) in faces_of.keys() {
        let l = norm(sub(pos[b as usize], pos[a as usize]));
        for v in [a, b] {
            own[v as usize].0 += l;
            own[v as usize].1 += 1;
        }
    }
    let own: Vec<f64> = own
        .iter()
        .map(|&(sum, n)| if n > 0 { sum / f64::from(n) } else { 0.0 })
        .collect();
    // The bend is judged at the target's scale: grain finer than the
    // target (a scan's noise, a sculpted ground's roughness) cancels out.
    let smooth = at_target_scale(pos, &faces_of, features, &own, target);
    let pos = smooth.as_slice();
    let normal = |t: [u32; 3]| {
        let [a, b, c] = t.map(|v| pos[v as usize]);
        let n = cross(sub(b, a), sub(c, a));
        let l = norm(n);
        (l > 0.0).then(|| scale(n, 1.0 / l))
    };
    let area = |t: [u32; 3]| {
        let [a, b, c] = t.map(|v| pos[v as usize]);
        0.5 * norm(cross(sub(b, a), sub(c, a)))
    };
    // Each vertex takes a minimum: the order of the edges does not matter.
    for (&(a, b), fs) in &faces_of {
        if fs.len() != 2 || features.contains(&(a, b)) {
            continue;
        }
        let (ta, tb) = (faces[fs[0] as usize], faces[fs[1] as usize]);
        let (Some(na), Some(nb)) = (normal(ta), normal(tb)) else {
            continue;
        };
        // Across the edge the surface turns by `angle` over the faces'
        // mean height above it.
        let length = norm(sub(pos[b as usize], pos[a as usize]));
        let d = if length > 0.0 {
            (area(ta) + area(tb)) / length
        } else {
            0.0
        };
        let angle = dot(na, nb).clamp(-1.0, 1.0).acos();
        if d <= 0.0 || angle <= 0.0 {
            continue;
        }
        let radius = d / angle;
        // Chord error e of an edge h on a circle of radius r:
        // e = r - sqrt(r^2 - h^2 / 4), so h = 2 sqrt(2 e r - e^2).
        let h = if e < radius {
            2.0 * (2.0 * e * radius - e * e).sqrt()
        } else {
            target
        };
        for v in [a, b] {
            let h = h.max(own[v as usize]).clamp(floor, target);
            size[v as usize] = size[v as usize].min(h);
        }
    }
    size
}

/// Vertices whose own edges are below this fraction of the target are
/// smoothed before their bend is measured ([`at_target_scale`]).
const FINE_FRACTION: f64 = 1.0 / 3.0;

/// Most smoothing passes before the bend is measured.
const MAX_SMOOTHING_PASSES: usize = 100;

/// `pos` with the detail finer than `target` smoothed away where the input
/// is fine (its own edges under a third of the target): Taubin's
/// lambda/mu passes (lambda 0.5, mu -0.53), which damp a wavelength of a
/// few edges and keep bends longer than about twenty edges without
/// shrinking them, `2 (target / h)^2` passes for the fine vertices' mean
/// edge `h` (at most [`MAX_SMOOTHING_PASSES`]). A vertex on a line (open
/// edges, `features`) moves along its line only; one where lines meet,
/// end or turn by more than 60 degrees, or with coarse edges, holds
/// still, so creases, borders and coarse facets keep their bends. A 200x200 ground with a height grain
/// of a third of its edges, remeshed to edges six times its own, then
/// asks for about the target, not for a quarter of it: the simulation
/// surface follows the shape, not its roughness.
fn at_target_scale(
    pos: &[[f64; 3]],
    faces_of: &BTreeMap<(u32, u32), Vec<u32>>,
    features: &FxHashSet<(u32, u32)>,
    own: &[f64],
    target: f64,
) -> Vec<[f64; 3]> {
    let fine = |v: usize| own[v] > 0.0 && own[v] < FINE_FRACTION * target;
    // Each vertex's neighbours in a fixed order (the map's), so every run
    // sums alike; a vertex on a line (open edges, features) only those on
    // its line, and one where lines meet or end none (it holds still).
    // A line's corner (it turns by more than 60 degrees) holds still: the
    // unit vectors to its two neighbours sum to more than 1.
    let mut on_line = vec![0u32; pos.len()];
    let mut turn = vec![[0.0; 3]; pos.len()];
    let line = |a: u32, b: u32, fs: &Vec<u32>| fs.len() != 2 || features.contains(&(a, b));
    for (&(a, b), fs) in faces_of {
        if line(a, b, fs) {
            on_line[a as usize] += 1;
            on_line[b as usize] += 1;
            let d = sub(pos[b as usize], pos[a as usize]);
            let d = scale(d, 1.0 / norm(d).max(1e-300));
            turn[a as usize] = add(turn[a as usize], d);
            turn[b as usize] = sub(turn[b as usize], d);
        }
    }
    let keeps = |v: u32, a: u32, b: u32, fs: &Vec<u32>| {
        let n = on_line[v as usize];
        fine(v as usize) && (n == 0 || (n == 2 && line(a, b, fs) && norm(turn[v as usize]) <= 1.0))
    };
    let mut start = vec![0usize; pos.len() + 1];
    for (&(a, b), fs) in faces_of {
        for v in [a, b] {
            if keeps(v, a, b, fs) {
                start[v as usize + 1] += 1;
            }
        }
    }
    for v in 0..pos.len() {
        start[v + 1] += start[v];
    }
    if start[pos.len()] == 0 {
        return pos.to_vec();
    }
    let mut next = start.clone();
    let mut nbr = vec![0u32; start[pos.len()]];
    for (&(a, b), fs) in faces_of {
        for (v, u) in [(a, b), (b, a)] {
            if keeps(v, a, b, fs) {
                nbr[next[v as usize]] = u;
                next[v as usize] += 1;
            }
        }
    }
    let (sum, n) = (0..pos.len())
        .filter(|&v| start[v + 1] > start[v])
        .fold((0.0, 0usize), |(s, n), v| (s + own[v], n + 1));
    let h = sum / n as f64;
    let passes = ((2.0 * (target / h).powi(2)).ceil() as usize).min(MAX_SMOOTHING_PASSES);
    let mut p = pos.to_vec();
    let mut q = p.clone();
    for _ in 0..passes {
        for factor in [0.5, -0.53] {
            for v in 0..p.len() {
                let ns = &nbr[start[v]..start[v + 1]];
                if ns.is_empty() {
                    q[v] = p[v];
                    continue;
                }
                let mut mean = [0.0; 3];
                for &u in ns {
                    mean = add(mean, p[u as usize]);
                }
                let mean = scale(mean, 1.0 / ns.len() as f64);
                q[v] = add(p[v], scale(sub(mean, p[v]), factor));
            }
            std::mem::swap(&mut p, &mut q);
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An open cylinder of radius `r`, `n` facets round, `rows` rows of
    /// quads of height `h`.
    fn cylinder(r: f64, n: u32, rows: u32, h: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let mut pos = Vec::new();
        for j in 0..=rows {
            for i in 0..n {
                let a = std::f64::consts::TAU * f64::from(i) / f64::from(n);
                pos.push([r * a.cos(), r * a.sin(), h * f64::from(j)]);
            }
        }
        let mut faces = Vec::new();
        for j in 0..rows {
            for i in 0..n {
                let (a, b) = (j * n + i, j * n + (i + 1) % n);
                let (c, d) = (a + n, b + n);
                faces.push([a, b, d]);
                faces.push([a, d, c]);
            }
        }
        (pos, faces)
    }

    #[test]
    fn a_tight_cylinder_asks_for_the_chord_length_a_flat_plate_for_the_target() {
        let (r, e, target) = (0.5, 0.01, 1.0);
        let (pos, faces) = cylinder(r, 48, 4, 0.05);
        let sizes = edge_sizes(&pos, &faces, &FxHashSet::default(), target, e, 0.01);
        let want = 2.0 * (2.0 * e * r - e * e).sqrt();
        // The curvature across the ring edges is 1/r; along the axis, none.
        for (v, s) in sizes.iter().enumerate() {
            assert!(
                (s / want - 1.0).abs() < 0.05,
                "vertex {v}: {s} against {want}"
            );
        }
        // Scaling the scene scales the sizes.
        let big: Vec<[f64; 3]> = pos.iter().map(|p| p.map(|x| 1000.0 * x)).collect();
        let sizes_big = edge_sizes(
            &big,
            &faces,
            &FxHashSet::default(),
            1e3 * target,
            1e3 * e,
            10.0,
        );
        for (s, b) in sizes.iter().zip(&sizes_big) {
            assert!((b / (1e3 * s) - 1.0).abs() < 1e-9);
        }
        // No chord error: the target.
        let off = edge_sizes(&pos, &faces, &FxHashSet::default(), target, 0.0, 0.01);
        assert!(off.iter().all(|&s| s == target));
        // Never below the floor.
        let tight = edge_sizes(&pos, &faces, &FxHashSet::default(), target, 1e-9, 0.3);
        assert!(tight.iter().all(|&s| (s - 0.3).abs() < 1e-12));
    }

    #[test]
    fn features_and_flat_surfaces_ask_for_nothing() {
        // Two squares folded at 90 degrees along x = 0: a crease.
        let pos = vec![
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 1.0],
        ];
        let faces = vec![[0, 2, 3], [0, 3, 1], [0, 1, 5], [0, 5, 4]];
        // A target four times the squares' side: the fold asks for less,
        // but not less than the input's own edges there.
        let free = edge_sizes(&pos, &faces, &FxHashSet::default(), 4.0, 0.08, 0.25);
        assert!(free[0] < 4.0 && free[1] < 4.0, "{free:?}");
        assert!(free[0] >= 1.0 && free[1] >= 1.0, "{free:?}");
        assert_eq!(free[2], 4.0, "the flat square's far corner");
        let kept: FxHashSet<(u32, u32)> = [(0, 1)].into_iter().collect();
        let sizes = edge_sizes(&pos, &faces, &kept, 4.0, 0.08, 0.25);
        assert!(sizes.iter().all(|&s| s == 4.0), "{sizes:?}");
    }
}
