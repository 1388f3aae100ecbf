//! The band a gap's moves spread over ([`super::displace`] with
//! `[post] gap_band`), solved as one smooth deformation instead of node by
//! node.

use crate::geometry::curvature::cotangent_weights;
use crate::math::v3;
use crate::mesh::{SimMesh, VertexId};
use crate::post::distance::{crack_vertices, distance_field};

/// Gauss-Seidel sweeps at most.
const MAX_SWEEPS: usize = 400;

/// The sweeps stop when no node moved by more than this fraction of the
/// largest crack move.
const TOLERANCE: f64 = 1e-4;

/// Spread the crack nodes' moves `mv` over the band beside them: a node off
/// the cracks lies in the band when its distance `d` over the surface to
/// the nearest crack node is below `band` times that node's move `m`. The
/// band's nodes take the harmonic blend (cotangent weights, negative ones
/// dropped) of the crack nodes' moves and, just beyond the band, of the
/// linear fade `m (1 - d / (band |m|))` carried on past zero; every node
/// outside the band stays. Along a straight side that is the move fading
/// linearly to nothing over the band, as when each node followed its
/// nearest crack node alone; where a cell's corner rounds off, the moves
/// turn smoothly round it instead of jumping where the nearest crack node
/// changes (which turned the triangles there over). The two sides of a
/// crack share no face, so each side's band follows its own side. Sweeps
/// run in vertex order: the same moves whatever the thread count.
pub(super) fn spread_over_band(mesh: &SimMesh, mv: &mut [[f64; 3]], band: f64) {
    let nodes = crack_vertices(mesh);
    let sources: Vec<(VertexId, f64)> = nodes.iter().map(|&v| (v, v.idx() as f64)).collect();
    let (distance, nearest) = distance_field(mesh, mesh.positions(), &sources);
    let n = mesh.n_vertices();
    let mut on_crack = vec![false; n];
    for v in &nodes {
        on_crack[v.idx()] = true;
    }
    let mut inside = vec![false; n];
    let mut largest: f64 = 0.0;
    for v in &nodes {
        largest = largest.max(v3::norm(mv[v.idx()]));
    }
    // Each node's nearest crack node's move, faded (past zero beyond the
    // band): the band's first guess and the values just beyond it.
    for i in 0..n {
        if on_crack[i] {
            continue;
        }
        let (d, c) = (distance[i], nearest[i]);
        mv[i] = [0.0; 3];
        if d.is_finite() && c.is_finite() {
            // `unit(m) (|m| - d / band)`: the same as `m (1 - d / (band
            // |m|))` without dividing by a tiny move, and no more than `|m|`
            // back past zero beyond the band.
            let m = mv[c as usize];
            let size = v3::norm(m);
            if let Some(u) = v3::unit(m).filter(|_| band > 0.0) {
                mv[i] = v3::scale(u, (size - d / band).max(-size));
                inside[i] = d < band * size;
            }
        }
    }
    if largest > 0.0 {
        blend(mesh, mv, &inside, largest);
    }
    for i in 0..n {
        if !inside[i] && !on_crack[i] {
            mv[i] = [0.0; 3];
        }
    }
}

/// The harmonic blend over the nodes `inside` of the moves `mv` of their
/// neighbours (every node not inside fixed at its value), by Gauss-Seidel
/// sweeps in vertex order from `mv` as given, until no node moves by more
/// than [`TOLERANCE`] times `largest`.
fn blend(mesh: &SimMesh, mv: &mut [[f64; 3]], inside: &[bool], largest: f64) {
    let n = mesh.n_vertices();
    // Cotangent weights of the edges at the band's nodes.
    let faces = mesh
        .faces()
        .map(|f| mesh.face_vertices(f).map(|v| v.0))
        .filter(|f| f.iter().any(|&v| inside[v as usize]));
    let mut neighbours: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
    for (a, b, w) in cotangent_weights(mesh.positions(), faces, n) {
        if w > 0.0 && inside[a as usize] {
            neighbours[a as usize].push((b, w));
        }
    }
    let band_nodes: Vec<usize> = (0..n).filter(|&i| inside[i]).collect();
    for _ in 0..MAX_SWEEPS {
        let mut change: f64 = 0.0;
        for &i in &band_nodes {
            let (mut sum, mut weight) = ([0.0; 3], 0.0);
            for &(j, w) in &neighbours[i] {
                sum = v3::add(sum, v3::scale(mv[j as usize], w));
                weight += w;
            }
            if weight <= 0.0 {
                continue;
            }
            let new = v3::scale(sum, 1.0 / weight);
            change = change.max(v3::norm(v3::sub(new, mv[i])));
            mv[i] = new;
        }
        if change <= TOLERANCE * largest {
            break;
        }
    }
}
