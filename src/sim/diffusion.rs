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
