//! The failure measure of each node: its separation tensor (film,
//! frozen or element form), scaled, and its value in the failure queue.

use crate::math::Sym3;
use crate::mesh::{SimMesh, VertexId};
use crate::sim::forces::{separation_tensor, separation_tensor_split, tensile_splits, Fans};
use crate::sim::state::State;
use rayon::prelude::*;

/// Separation tensor of node `v`: the force-based tensor (eq. 3) plus the
/// node's residual, times the mean separation factor of the node's faces
/// when the field scales it (a factor `f` acts as toughness `tau / f`).
pub(in crate::sim) fn node_separation(mesh: &SimMesh, st: &State, v: VertexId) -> Sym3 {
    if let Some(film) = &st.film {
        return film_separation(mesh, st, film, v);
    }
    let s = match &st.frozen {
        Some(fz) => fz.get(v.idx()).copied().unwrap_or(Sym3::ZERO),
        None => separation_tensor(mesh, &st.els, &st.stress, v),
    };
    scaled_separation(mesh, st, v, s)
}

/// A film's failure tensor at node `v`: the stress averaged over a disc of
/// world radius (see [`crate::sim::film`]) plus the node's residual, scaled
/// as [`scaled_separation`] does; zero for a node off the cracks that may
/// not start one (near a crack, or shadowed this round).
pub(in crate::sim) fn film_separation(
    mesh: &SimMesh,
    st: &State,
    film: &crate::sim::film::Film,
    v: VertexId,
) -> Sym3 {
    // Only a crack's open end runs on; anywhere else (a node beside a
    // crack included) a crack would be a new one.
    let tip = !st.crack_time[v.idx()].is_nan()
        && !mesh.is_boundary_vertex(v) | (crate::sim::crack::crack_directions(mesh, v).len() == 1);
    if if tip {
        !film.tip_may_run(v)
    } else {
        !film.may_start(v)
    } {
        return Sym3::ZERO;
    }
    let s = crate::sim::film::averaged_stress(
        mesh,
        &st.els,
        &st.stress,
        st.unit,
        film.average_radius(),
        v,
    ) + st.residual[v.idx()];
    // The least separation factor of the node's faces: a crack does not
    // enter a face where the field forbids it (a confining mask's white).
    if st.sep_scale.is_empty() {
        return s;
    }
    let factor = mesh
        .vertex_faces(v)
        .map(|f| st.sep_scale[f.idx()])
        .fold(f64::INFINITY, f64::min);
    if factor.is_finite() {
        s * factor
    } else {
        s
    }
}

/// The residual and the separation factor on node `v`'s force-based
/// separation tensor `s` (see [`node_separation`]).
pub(in crate::sim) fn scaled_separation(mesh: &SimMesh, st: &State, v: VertexId, s: Sym3) -> Sym3 {
    let s = s + st.residual[v.idx()];
    if st.sep_scale.is_empty() {
        return s;
    }
    s * separation_factor(mesh, st, v)
}

/// Largest separation eigenvalue and its direction at every node.
/// `fans` must be those of `mesh` as it is.
pub(in crate::sim) fn separations(
    mesh: &SimMesh,
    fans: &Fans,
    st: &State,
    threshold: f64,
) -> Vec<f64> {
    if st.frozen.is_some() || st.film.is_some() {
        return (0..mesh.n_vertices())
            .into_par_iter()
            .map(|v| queue_value(node_separation(mesh, st, VertexId(v as u32)), threshold))
            .collect();
    }
    let splits = tensile_splits(&st.els, &st.stress);
    (0..mesh.n_vertices())
        .into_par_iter()
        .map(|v| {
            let s = separation_tensor_split(fans, &st.els, &splits, v);
            queue_value(
                scaled_separation(mesh, st, VertexId(v as u32), s),
                threshold,
            )
        })
        .collect()
}

/// The value to queue a node with: its largest separation eigenvalue, or,
/// when the Gershgorin bound already shows that it cannot exceed
/// `threshold`, that bound (the queue drops both alike, and the bound
/// saves the eigen-decomposition for the many nodes far from failing).
pub(in crate::sim) fn queue_value(s: Sym3, threshold: f64) -> f64 {
    let bound = (s.xx + s.xy.abs() + s.xz.abs())
        .max(s.yy + s.xy.abs() + s.yz.abs())
        .max(s.zz + s.xz.abs() + s.yz.abs());
    if bound <= threshold {
        bound
    } else {
        s.max_eigen().0
    }
}

/// The mean separation factor of the faces around `v` (1 without one).
pub(in crate::sim) fn separation_factor(mesh: &SimMesh, st: &State, v: VertexId) -> f64 {
    if st.sep_scale.is_empty() {
        return 1.0;
    }
    let (mut sum, mut n) = (0.0, 0usize);
    for f in mesh.vertex_faces(v) {
        sum += st.sep_scale[f.idx()];
        n += 1;
    }
    if n > 0 {
        sum / n as f64
    } else {
        1.0
    }
}
