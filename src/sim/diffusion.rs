//! Eigenvalue diffusion of the snapping variant: after a crack, its
//! nodes' separation spreads to their neighbours, locally.

use crate::math::Sym3;
use crate::mesh::{SimMesh, VertexId};
use crate::sim::separation::node_separation;
use crate::sim::state::State;
use crate::sim::SimParams;
use rayon::prelude::*;

/// Eigen-diffusion passes (see [`Relaxation::EigenDiffusion`]): each node
/// keeps `1 - f` of its largest separation eigenvalue (when positive) and
/// shares `f` equally among its neighbours; the change is added to the
/// node's residual along its eigenvector, so the crack directions stay.
#[cfg(test)]
pub(in crate::sim) fn eigen_diffusion(mesh: &SimMesh, st: &mut State, params: &SimParams) {
    let all: Vec<VertexId> = mesh.vertices().collect();
    eigen_diffusion_around(mesh, st, params, &all, 0);
}

/// The neighbours of `v` (sorted, without `v`).
pub(in crate::sim) fn vertex_neighbours(mesh: &SimMesh, v: u32) -> Vec<u32> {
    let mut nb: Vec<u32> = mesh
        .vertex_faces(VertexId(v))
        .flat_map(|fc| mesh.face_vertices(fc))
        .map(|u| u.0)
        .filter(|&u| u != v)
        .collect();
    nb.sort_unstable();
    nb.dedup();
    nb
}

/// Eigen-diffusion after a crack run, kept local: the nodes within
/// `rings` rings of `seeds` (the nodes the run touched) share, as
/// [`eigen_diffusion`] describes, and their neighbours receive; the rest of
/// the mesh is left as it is, so the work per run does not grow with the
/// mesh (a sweep of the whole mesh after every run made the snapping
/// variant quadratic). Returns the nodes whose separation changed, sorted.
pub(in crate::sim) fn eigen_diffusion_around(
    mesh: &SimMesh,
    st: &mut State,
    params: &SimParams,
    seeds: &[VertexId],
    rings: usize,
) -> Vec<u32> {
    let f = params.diffusion_fraction;
    if f <= 0.0 || seeds.is_empty() {
        return Vec::new();
    }
    // The sharing region: `rings` rings around the seeds.
    let mut sources: Vec<u32> = seeds.iter().map(|v| v.0).collect();
    sources.sort_unstable();
    sources.dedup();
    let mut inside: std::collections::HashSet<u32> = sources.iter().copied().collect();
    let mut frontier = sources.clone();
    for _ in 0..rings {
        let mut next = Vec::new();
        for &v in &frontier {
            for u in vertex_neighbours(mesh, v) {
                if inside.insert(u) {
                    next.push(u);
                }
            }
        }
        if next.is_empty() {
            break;
        }
        sources.extend_from_slice(&next);
        frontier = next;
    }
    sources.sort_unstable();
    let neighbours: Vec<Vec<u32>> = sources
        .iter()
        .map(|&v| vertex_neighbours(mesh, v))
        .collect();
    // Every node that may change: the sources and their neighbours.
    let mut nodes: Vec<u32> = sources
        .iter()
        .copied()
        .chain(neighbours.iter().flatten().copied())
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    let at: std::collections::HashMap<u32, usize> =
        nodes.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    st.diffusion_work += params.diffusion_passes * nodes.len();
    for _ in 0..params.diffusion_passes {
        let eig: Vec<(f64, [f64; 3])> = nodes
            .par_iter()
            .map(|&v| node_separation(mesh, st, VertexId(v)).max_eigen())
            .collect();
        let mut next: Vec<f64> = eig.iter().map(|(l, _)| *l).collect();
        for (k, &v) in sources.iter().enumerate() {
            let (l, _) = eig[at[&v]];
            if l.is_nan() || l <= 0.0 || neighbours[k].is_empty() {
                continue;
            }
            let share = f * l;
            next[at[&v]] -= share;
            let each = share / neighbours[k].len() as f64;
            for &u in &neighbours[k] {
                next[at[&u]] += each;
            }
        }
        for (i, &v) in nodes.iter().enumerate() {
            let (l, dir) = eig[i];
            let d = next[i] - l;
            if d != 0.0 && l.is_finite() {
                st.residual[v as usize] += Sym3::m(dir) * d;
            }
        }
    }
    nodes
}

/// How far beside a crack run its stress shadow reaches, in half-lengths
/// of the run (see [`relieve_beside`]): beyond it the tension across a
/// straight crack is back to the remote one.
const SHADOW_REACH: f64 = 0.8;

/// Where `p` lies from the segment `(p0, p1)`: distance, the way across
/// the segment to `p` (not normalised) and `sin^2` of the angle between
/// the segment and the way from its nearest point to `p`.
fn beside(p: [f64; 3], (p0, p1): ([f64; 3], [f64; 3])) -> (f64, [f64; 3], f64) {
    use crate::math::v3;
    let q = v3::sub(p, crate::mesh::spatial::closest_on_segment(p, p0, p1));
    let dist = v3::norm(q);
    let u = v3::unit(v3::sub(p1, p0)).unwrap_or([0.0; 3]);
    let n = v3::sub(q, v3::scale(u, v3::dot(q, u)));
    let sin2 = if dist > 0.0 {
        (v3::dot(n, n) / (dist * dist)).min(1.0)
    } else {
        0.0
    };
    (dist, n, sin2)
}

/// The stress shadow of a crack run that has just ended: a crack's faces
/// carry no traction, so the tension across it is relieved beside it, the
/// more the nearer, out to [`SHADOW_REACH`] half-lengths of the run (a
/// longer crack relieves a wider band; no mesh unit enters). Each node
/// within that width of the run's `segments` has its separation (frozen
/// part and residual) taken through `P S P`, `P = I - g n n^T`, with `n`
/// the way across the nearest segment at distance `d`: `(1 - g)^2` is
/// what a straight crack leaves of the tension across it at `d` beside
/// its middle, times `sin^2` of the angle between the segment and the way
/// to the node (none straight ahead of a tip, where the stress is
/// concentrated, not relieved). Without it the nodes beside a crack keep
/// all their separation, and the next crack starts beside the last and
/// runs parallel to it: bundles instead of a star.
///
/// The nearest segment is carried outward from `seeds` (the nodes the run
/// touched) node to node, nearest first (closest-point propagation), so
/// the work is the band's nodes, not the band's nodes times the run's
/// segments. Returns the nodes changed, sorted.
pub(in crate::sim) fn relieve_beside(
    mesh: &SimMesh,
    st: &mut State,
    segments: &[([f64; 3], [f64; 3])],
    seeds: &[VertexId],
) -> Vec<u32> {
    use crate::math::v3;
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;
    let length: f64 = segments.iter().map(|&(a, b)| v3::norm(v3::sub(b, a))).sum();
    // Half the run's length: a straight crack's half-length.
    let a = 0.5 * length;
    let w = SHADOW_REACH * a;
    if !w.is_finite() || w <= 0.0 || seeds.is_empty() {
        return Vec::new();
    }
    // (distance, node, segment), smallest first; f64 bits order as the
    // values do for non-negative distances.
    let mut heap: BinaryHeap<Reverse<(u64, u32, usize)>> = BinaryHeap::new();
    let mut seeds: Vec<u32> = seeds.iter().map(|v| v.0).collect();
    seeds.sort_unstable();
    seeds.dedup();
    for &v in &seeds {
        let p = mesh.position(VertexId(v));
        let nearest = (0..segments.len())
            .map(|k| (beside(p, segments[k]).0, k))
            .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        if let Some((d, k)) = nearest {
            heap.push(Reverse((d.to_bits(), v, k)));
        }
    }
    let mut settled: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
    let mut changed = Vec::new();
    while let Some(Reverse((bits, v, k))) = heap.pop() {
        if settled.contains_key(&v) {
            continue;
        }
        settled.insert(v, k);
        let d = f64::from_bits(bits);
        if d > w {
            continue;
        }
        for u in vertex_neighbours(mesh, v) {
            if !settled.contains_key(&u) {
                let du = beside(mesh.position(VertexId(u)), segments[k]).0;
                heap.push(Reverse((du.to_bits(), u, k)));
            }
        }
        let (_, n, sin2) = beside(mesh.position(VertexId(v)), segments[k]);
        // The tension across a straight crack of half-length `a` under a
        // uniform remote tension, at `y` beside its middle, is
        // `y (y^2 + 2 a^2) / (y^2 + a^2)^1.5` of the remote one
        // (Westergaard); `P S P` scales it by `(1 - g)^2`.
        let y = d / a;
        let kept = (y * (y * y + 2.0) / (y * y + 1.0).powf(1.5)).min(1.0);
        let g = (1.0 - kept.sqrt()) * sin2;
        let Some(n) = v3::unit(n) else { continue };
        if g <= 0.0 {
            continue;
        }
        let project = |s: Sym3| {
            let sn = s.mul_vec(n);
            s - Sym3::sym_outer(n, sn) * (2.0 * g) + Sym3::outer(n) * (g * g * s.quad(n, n))
        };
        if let Some(fz) = &mut st.frozen {
            fz[v as usize] = project(fz[v as usize]);
        }
        st.residual[v as usize] = project(st.residual[v as usize]);
        changed.push(v);
    }
    changed.sort_unstable();
    changed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::jittered_plate;

    /// A straight crack in a plate under equal tension both ways relieves
    /// the tension across it beside its middle as Westergaard's crack
    /// does, keeps the tension along it, and leaves alone what lies ahead
    /// of its tips and beyond its reach.
    #[test]
    fn a_cracks_shadow_relieves_the_tension_across_it_beside_it() {
        // A regular 24 x 24 grid of unit quads; the crack along x = 12
        // from y = 8 to 16 (half-length 4).
        let mesh = jittered_plate(24, 0.0, 1);
        let params = SimParams {
            relaxation: crate::sim::Relaxation::EigenDiffusion,
            ..Default::default()
        };
        let (mut st, _) = crate::sim::driver::start(&mesh, &params, None).unwrap();
        let tension = Sym3::outer([1.0, 0.0, 0.0]) + Sym3::outer([0.0, 1.0, 0.0]);
        st.freeze(vec![tension; mesh.n_vertices()]);
        let at = |x: f64, y: f64| {
            mesh.vertices()
                .find(|&v| {
                    let p = mesh.position(v);
                    (p[0] - x).abs() < 1e-9 && (p[1] - y).abs() < 1e-9
                })
                .unwrap()
        };
        let segments: Vec<_> = (8..16)
            .map(|k| ([12.0, f64::from(k), 0.0], [12.0, f64::from(k + 1), 0.0]))
            .collect();
        let seeds: Vec<VertexId> = (8..=16).map(|k| at(12.0, f64::from(k))).collect();
        let changed = relieve_beside(&mesh, &mut st, &segments, &seeds);
        let fz = st.frozen.as_ref().unwrap();
        let across = |v: VertexId| fz[v.idx()].quad([1.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
        let along = |v: VertexId| fz[v.idx()].quad([0.0, 1.0, 0.0], [0.0, 1.0, 0.0]);
        // Westergaard: y (y^2 + 2) / (y^2 + 1)^1.5 at y = d / a beside the
        // middle, computed here on its own.
        let kept = |d: f64| {
            let y: f64 = d / 4.0;
            y * (y * y + 2.0) / (y * y + 1.0).powf(1.5)
        };
        for d in [1.0, 2.0, 3.0] {
            for x in [12.0 - d, 12.0 + d] {
                let v = at(x, 12.0);
                assert!(
                    (across(v) - kept(d)).abs() < 1e-9,
                    "at {d} beside: {} against {}",
                    across(v),
                    kept(d)
                );
                assert!((along(v) - 1.0).abs() < 1e-9, "along: {}", along(v));
                assert!(changed.contains(&v.0));
            }
        }
        assert!(
            kept(1.0) < 0.5,
            "the nearest nodes lose half: {}",
            kept(1.0)
        );
        // Beyond the reach (3.2), on the crack, and ahead of a tip: as before.
        for (x, y) in [
            (16.0, 12.0),
            (8.0, 12.0),
            (12.0, 12.0),
            (12.0, 18.0),
            (12.0, 6.0),
        ] {
            let v = at(x, y);
            assert_eq!(fz[v.idx()], tension, "at ({x}, {y})");
            assert!(!changed.contains(&v.0), "at ({x}, {y})");
        }
        // A run of no length relieves nothing.
        assert!(relieve_beside(&mesh, &mut st, &[], &seeds).is_empty());
    }
}
