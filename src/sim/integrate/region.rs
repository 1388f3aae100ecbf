//! Local relaxation: the region of rings around new cracks, its corner
//! forces and its explicit steps.

use crate::math::GrowGently;
use crate::math::{v3, Sym3};
use crate::mesh::VertexId;
use crate::sim::forces::gather;
use crate::sim::forces::{element_corner_forces, element_strain, Elements, Fans};
use crate::sim::state::State;
use rayon::prelude::*;

/// The nodes within some rings of a set of seed nodes and the faces around
/// them: where a local relaxation moves nodes and changes stress.
pub(in crate::sim) struct Region {
    /// Per node: inside the region.
    pub(in crate::sim) inside: Vec<bool>,
    /// Per face: a corner is in the region.
    pub(in crate::sim) face_in: Vec<bool>,
}

impl Region {
    /// The nodes within `rings` edge rings of `seeds` (breadth first over
    /// the fans) and their faces.
    pub(in crate::sim) fn around(fans: &Fans, seeds: &[VertexId], rings: usize) -> Region {
        let n = fans.n_vertices();
        let mut inside = vec![false; n];
        let mut front: Vec<u32> = Vec::new();
        for s in seeds {
            if s.idx() < n && !inside[s.idx()] {
                inside[s.idx()] = true;
                front.push(s.0);
            }
        }
        for _ in 0..rings {
            let mut next = Vec::new();
            for &v in &front {
                for &(f, _) in fans.fan(v as usize) {
                    for c in fans.corners(f as usize) {
                        if !inside[c as usize] {
                            inside[c as usize] = true;
                            next.push(c);
                        }
                    }
                }
            }
            if next.is_empty() {
                break;
            }
            front = next;
        }
        let mut face_in = vec![false; fans.n_faces()];
        for (v, _) in inside.iter().enumerate().filter(|(_, &i)| i) {
            for &(f, _) in fans.fan(v) {
                face_in[f as usize] = true;
            }
        }
        Region { inside, face_in }
    }
}

/// [`corner_forces`] of the region's faces only (`corner` grown to every face).
pub(in crate::sim) fn region_corner_forces(
    els: &Elements,
    stress: &[Sym3],
    corner: &mut Vec<[f64; 3]>,
    r: &Region,
) {
    corner.resize_gently(3 * els.elements.len(), [0.0; 3]);
    corner
        .par_chunks_mut(3)
        .enumerate()
        .with_min_len(1024)
        .for_each(|(f, c)| {
            if r.face_in[f] {
                match els.elements.get(f) {
                    Some(Some(el)) => element_corner_forces(el, &stress[f], c),
                    _ => c.fill([0.0; 3]),
                }
            }
        });
}

/// One forward-Euler step without load restricted to `region`: its nodes
/// move (the others hold still) and its faces' stress and corner forces
/// change, with the same arithmetic as [`relax_and_evolve`]. `g` must be
/// zero outside the region. The loops run over every node and face and
/// skip those outside, which costs little next to the work inside.
pub(in crate::sim) fn relax_region(
    fans: &Fans,
    normals: &[[f64; 3]],
    mobility: &[f64],
    st: &mut State,
    dt: f64,
    region: &Region,
    g: &mut [[f64; 3]],
) {
    let (corner, fixed, unit) = (&st.corner, &st.fixed, st.unit);
    g.par_iter_mut()
        .zip(st.displacement.par_iter_mut())
        .enumerate()
        .with_min_len(512)
        .for_each(|(v, (gn, d))| {
            if !region.inside[v] {
                return;
            }
            let f_net = if fixed[v] {
                [0.0; 3]
            } else {
                node_velocity(fans, corner, normals, mobility, v)
            };
            *gn = f_net;
            *d = v3::add(*d, v3::scale(f_net, dt * unit));
        });
    let (els, g) = (&st.els, &*g);
    st.stress
        .par_iter_mut()
        .zip(st.corner.par_chunks_mut(3))
        .enumerate()
        .with_min_len(512)
        .for_each(|(f, (s, c))| {
            if !region.face_in[f] {
                return;
            }
            let Some(Some(el)) = els.elements.get(f) else {
                c.fill([0.0; 3]);
                return;
            };
            *s += element_strain(el, fans.corners(f), g, dt, Sym3::ZERO);
            element_corner_forces(el, s, c);
        });
}

/// Node `v`'s velocity in an explicit step: its net force from the corner
/// forces, without its normal part on a bonded surface, times its mobility.
#[inline]
pub(in crate::sim) fn node_velocity(
    fans: &Fans,
    corner: &[[f64; 3]],
    normals: &[[f64; 3]],
    mobility: &[f64],
    v: usize,
) -> [f64; 3] {
    let mut f = gather(fans, corner, v);
    if let Some(n) = normals.get(v) {
        f = v3::sub(f, v3::scale(*n, v3::dot(f, *n)));
    }
    v3::scale(f, mobility[v])
}
