//! Node forces (eq. 1) and the separation tensor (eq. 3).
//!
//! Every per-node quantity is a gather over the node's fan in the mesh's fan
//! order, so results do not depend on thread count or scheduling.

use crate::math::GrowGently;
use crate::geometry::element::{basis_norm, Element};
use crate::math::{v3, Sym3};
use crate::mesh::{FaceId, SimMesh, VertexId};
use rayon::prelude::*;

/// Element geometry for every face of a mesh (`None` for a degenerate face).
#[derive(Clone, Debug, Default)]
pub struct Elements {
    /// Per face.
    pub elements: Vec<Option<Element>>,
    /// The clamp applied to the barycentric bases' singular values.
    pub clamp: f64,
}

impl Elements {
    /// The clamp threshold: `factor` times the mean over faces of the largest
    /// singular value of the barycentric basis (about `1 / height`).
    pub fn clamp_threshold(mesh: &SimMesh, factor: f64) -> f64 {
        let (mut sum, mut n) = (0.0, 0usize);
        for f in mesh.faces() {
            if let Some(s) = basis_norm(face_points(mesh, f)) {
                sum += s;
                n += 1;
            }
        }
        if n == 0 {
            f64::INFINITY
        } else {
            factor * sum / n as f64
        }
    }

    /// Compute every face's element with singular values clamped at `clamp`.
    pub fn new(mesh: &SimMesh, clamp: f64) -> Elements {
        let elements = (0..mesh.n_faces())
            .into_par_iter()
            .map(|f| Element::new(face_points(mesh, FaceId(f as u32)), clamp))
            .collect();
        Elements { elements, clamp }
    }

    /// The element of face `f`.
    pub fn get(&self, f: FaceId) -> Option<&Element> {
        self.elements.get(f.idx()).and_then(Option::as_ref)
    }
}

/// Corner positions of a face.
pub fn face_points(mesh: &SimMesh, f: FaceId) -> [[f64; 3]; 3] {
    mesh.face_vertices(f).map(|v| mesh.position(v))
}

/// Forces of an element with stress `s` on its three corners:
/// `f_i = -A S g_i`. They sum to zero.
pub fn element_forces(el: &Element, s: &Sym3) -> [[f64; 3]; 3] {
    el.grads.map(|g| v3::scale(s.mul_vec(g), -el.area))
}

/// Tensile and compressive parts of an element's in-plane stress:
/// `S+ = sum max(0, v) n n^T`, `S- = sum min(0, v) n n^T` over the in-plane
/// eigenpairs.
pub fn split_tensile(el: &Element, s: &Sym3) -> (Sym3, Sym3) {
    let (vals, vecs) = s.to_frame(el.e1, el.e2).eigen();
    let mut plus = Sym3::ZERO;
    let mut minus = Sym3::ZERO;
    for k in 0..2 {
        let n = v3::add(v3::scale(el.e1, vecs[k][0]), v3::scale(el.e2, vecs[k][1]));
        let t = Sym3::outer(n) * vals[k];
        if vals[k] > 0.0 {
            plus += t;
        } else {
            minus += t;
        }
    }
    (plus, minus)
}

/// Which corner of face `f` is vertex `v`.
pub(crate) fn corner_of(mesh: &SimMesh, f: FaceId, v: VertexId) -> usize {
    mesh.face_vertices(f)
        .iter()
        .position(|&x| x == v)
        .unwrap_or(0)
}

/// Net force on every node, `g[n] = sum_e f_e[n]`, gathered per node in fan order.
pub fn node_forces(mesh: &SimMesh, els: &Elements, stress: &[Sym3]) -> Vec<[f64; 3]> {
    node_forces_fans(&Fans::new(mesh), els, stress)
}

/// Every node's fan as flat arrays (face, corner), in the mesh's fan order,
/// plus every face's corners: the relaxation loop's view of a mesh that does
/// not change between crack events. Rebuild after any edit.
#[derive(Clone, Debug, Default)]
pub struct Fans {
    offsets: Vec<u32>,
    entries: Vec<(u32, u8)>,
    corners: Vec<[u32; 3]>,
}

impl Fans {
    /// Fans of every node of `mesh`. Blocks of nodes are walked in
    /// parallel and joined in node order, so the result is the sequential
    /// walk's whatever the thread count.
    pub fn new(mesh: &SimMesh) -> Fans {
        const BLOCK: usize = 2048;
        let nv = mesh.n_vertices();
        // Per block: each node's end offset within the block, the entries.
        type Part = (Vec<u32>, Vec<(u32, u8)>);
        let parts: Vec<Part> = (0..nv.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let range = b * BLOCK..((b + 1) * BLOCK).min(nv);
                let mut ends = Vec::with_capacity(range.len());
                let mut entries = Vec::with_capacity(range.len() * 7);
                for v in range {
                    let v = VertexId(v as u32);
                    for f in mesh.vertex_faces(v) {
                        entries.push((f.0, corner_of(mesh, f, v) as u8));
                    }
                    ends.push(entries.len() as u32);
                }
                (ends, entries)
            })
            .collect();
        let mut offsets = Vec::with_capacity(nv + 1);
        let mut entries = Vec::with_capacity(parts.iter().map(|p| p.1.len()).sum());
        offsets.push(0);
        for (ends, part) in parts {
            let base = entries.len() as u32;
            offsets.extend(ends.iter().map(|e| base + e));
            entries.extend_from_slice(&part);
        }
        let corners = (0..mesh.n_faces())
            .into_par_iter()
            .map(|f| mesh.face_vertices(FaceId(f as u32)).map(|v| v.0))
            .collect();
        Fans {
            offsets,
            entries,
            corners,
        }
    }

    /// Number of nodes.
    pub fn n_vertices(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.corners.len()
    }

    /// The (face, corner) pairs around node `v`.
    pub fn fan(&self, v: usize) -> &[(u32, u8)] {
        &self.entries[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }

    /// The corner nodes of face `f`.
    pub fn corners(&self, f: usize) -> [u32; 3] {
        self.corners[f]
    }
}

/// Net force on node `v`, `sum_e -A_e S_e g_v^e`, summed in fan order.
#[inline]
pub fn node_force(fans: &Fans, els: &Elements, stress: &[Sym3], v: usize) -> [f64; 3] {
    let mut g = [0.0; 3];
    for &(f, k) in fans.fan(v) {
        if let Some(Some(el)) = els.elements.get(f as usize) {
            let sg = stress[f as usize].mul_vec(el.grads[k as usize]);
            g = v3::add(g, v3::scale(sg, -el.area));
        }
    }
    g
}

/// Every element's force on each of its corners, `-A_e S_e g_k^e` at
/// `3 f + k` (zero for a face without element), into `out`. Summing these
/// over a node's fan in fan order ([`gather`]) gives exactly
/// [`node_force`]; computing them face by face first reads the elements
/// and stresses in order instead of once per corner at random.
pub fn corner_forces(els: &Elements, stress: &[Sym3], out: &mut Vec<[f64; 3]>) {
    corner_forces_with(els, |f, _| stress[f], out);
}

/// [`corner_forces`] of the stress `stress(f, element)` of every face with
/// an element.
pub fn corner_forces_with(
    els: &Elements,
    stress: impl Fn(usize, &Element) -> Sym3 + Sync,
    out: &mut Vec<[f64; 3]>,
) {
    out.resize_gently(3 * els.elements.len(), [0.0; 3]);
    out.par_chunks_mut(3)
        .zip(els.elements.par_iter())
        .enumerate()
        .with_min_len(1024)
        .for_each(|(f, (c, el))| match el {
            Some(el) => element_corner_forces(el, &stress(f, el), c),
            None => c.fill([0.0; 3]),
        });
}

/// The linearised strain `start + sum_k sym(g_k (P d_k)^T)` of moving an
/// element's corners by `d_k = scale * g[corners[k]]`, `P` projecting onto
/// the element's plane (the virtual displacement of eq. 15).
#[inline]
pub fn element_strain(
    el: &Element,
    corners: [u32; 3],
    g: &[[f64; 3]],
    scale: f64,
    start: Sym3,
) -> Sym3 {
    let mut ds = start;
    for k in 0..3 {
        let dp = v3::scale(g[corners[k] as usize], scale);
        // Tangential part of the virtual displacement.
        let d = v3::sub(dp, v3::scale(el.normal, v3::dot(dp, el.normal)));
        ds += Sym3::sym_outer(el.grads[k], d);
    }
    ds
}

/// The element's force `-A S g_k` on each of its corners, into `out`.
#[inline]
pub fn element_corner_forces(el: &Element, s: &Sym3, out: &mut [[f64; 3]]) {
    for (ck, gk) in out.iter_mut().zip(&el.grads) {
        *ck = v3::scale(s.mul_vec(*gk), -el.area);
    }
}

/// Net force on node `v` from [`corner_forces`], summed in fan order.
#[inline]
pub fn gather(fans: &Fans, corner: &[[f64; 3]], v: usize) -> [f64; 3] {
    let mut g = [0.0; 3];
    for &(f, k) in fans.fan(v) {
        g = v3::add(g, corner[3 * f as usize + k as usize]);
    }
    g
}

/// [`node_forces`] on precomputed fans.
pub fn node_forces_fans(fans: &Fans, els: &Elements, stress: &[Sym3]) -> Vec<[f64; 3]> {
    (0..fans.n_vertices())
        .into_par_iter()
        .map(|v| node_force(fans, els, stress, v))
        .collect()
}

/// The separation tensor of node `v` (eq. 3):
/// `S = 1/2 (-m(f+) + sum_e m(f+_e) + m(f-) - sum_e m(f-_e))`.
pub fn separation_tensor(mesh: &SimMesh, els: &Elements, stress: &[Sym3], v: VertexId) -> Sym3 {
    let fan = mesh
        .vertex_faces(v)
        .map(|f| (f.idx(), corner_of(mesh, f, v)));
    separation_with(els, fan, |f, el| split_tensile(el, &stress[f]))
}

/// Every face's [`split_tensile`] (zero for a face without element): the
/// separation tensors of all nodes then share them instead of splitting
/// each face once per corner.
pub fn tensile_splits(els: &Elements, stress: &[Sym3]) -> Vec<(Sym3, Sym3)> {
    els.elements
        .par_iter()
        .zip(stress.par_iter())
        .with_min_len(1024)
        .map(|(el, s)| match el {
            Some(el) => split_tensile(el, s),
            None => (Sym3::ZERO, Sym3::ZERO),
        })
        .collect()
}

/// [`separation_tensor`] of node `v` from the mesh's [`Fans`] and
/// precomputed [`tensile_splits`] (the same value, bit for bit).
pub fn separation_tensor_split(
    fans: &Fans,
    els: &Elements,
    splits: &[(Sym3, Sym3)],
    v: usize,
) -> Sym3 {
    let fan = fans.fan(v).iter().map(|&(f, k)| (f as usize, k as usize));
    separation_with(els, fan, |f, _| splits[f])
}

/// Eq. 3 over a node's fan of (face, corner) pairs.
fn separation_with(
    els: &Elements,
    fan: impl Iterator<Item = (usize, usize)>,
    split: impl Fn(usize, &Element) -> (Sym3, Sym3),
) -> Sym3 {
    let mut fp = [0.0; 3];
    let mut fm = [0.0; 3];
    let mut acc = Sym3::ZERO;
    for (f, k) in fan {
        let Some(Some(el)) = els.elements.get(f) else {
            continue;
        };
        let (sp, sm) = split(f, el);
        let fpe = v3::scale(sp.mul_vec(el.grads[k]), -el.area);
        let fme = v3::scale(sm.mul_vec(el.grads[k]), -el.area);
        fp = v3::add(fp, fpe);
        fm = v3::add(fm, fme);
        acc += Sym3::m(fpe) - Sym3::m(fme);
    }
    (acc - Sym3::m(fp) + Sym3::m(fm)) * 0.5
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::mesh::shapes::{jittered_plate, Lcg};

    /// An n x n plate of unit cells, interior nodes jittered by up to `jitter` cells.
    fn uniform(mesh: &SimMesh, els: &Elements, c: f64) -> Vec<Sym3> {
        mesh.faces()
            .map(|f| Sym3::tangent_identity(els.get(f).unwrap().normal, c))
            .collect()
    }

    #[test]
    fn fans_give_the_same_forces() {
        let mesh = jittered_plate(7, 0.3, 3);
        let els = Elements::new(&mesh, Elements::clamp_threshold(&mesh, 4.0));
        let mut rng = Lcg(4);
        let stress: Vec<Sym3> = mesh
            .faces()
            .map(|f| Sym3::tangent_identity(els.get(f).unwrap().normal, rng.next_f64()))
            .collect();
        let a = node_forces(&mesh, &els, &stress);
        let b = node_forces_fans(&Fans::new(&mesh), &els, &stress);
        assert_eq!(a, b);
    }

    #[test]
    fn element_forces_sum_to_zero() {
        let mut rng = Lcg(3);
        for _ in 0..200 {
            let mut p = [[0.0; 3]; 3];
            for q in p.iter_mut() {
                *q = [rng.next_f64(), rng.next_f64(), rng.next_f64()];
            }
            let Some(el) = Element::new(p, f64::INFINITY) else {
                continue;
            };
            let s2 = crate::math::Sym2 {
                xx: rng.next_f64(),
                yy: rng.next_f64(),
                xy: rng.next_f64(),
            };
            let s = Sym3::from_frame(&s2, el.e1, el.e2);
            let f = element_forces(&el, &s);
            let sum = v3::add(v3::add(f[0], f[1]), f[2]);
            assert!(v3::norm(sum) < 1e-12 * (1.0 + v3::norm(f[0])), "{sum:?}");
        }
    }

    #[test]
    fn uniform_tension_balances_inside_and_pulls_boundary_inward() {
        let n = 8;
        let mesh = jittered_plate(n, 0.3, 1);
        let els = Elements::new(&mesh, f64::INFINITY);
        let stress = uniform(&mesh, &els, 1.0);
        let g = node_forces(&mesh, &els, &stress);
        let centre = [n as f64 / 2.0, n as f64 / 2.0, 0.0];
        for v in mesh.vertices() {
            let f = g[v.idx()];
            if mesh.is_boundary_vertex(v) {
                // Inward: towards the plate's centre, with a clear magnitude.
                let to_centre = v3::sub(centre, mesh.position(v));
                assert!(
                    v3::dot(f, to_centre) > 0.0,
                    "boundary node {v:?} force {f:?} is not inward"
                );
                assert!(v3::norm(f) > 0.1);
            } else {
                assert!(
                    v3::norm(f) < 1e-12,
                    "interior node {v:?} has net force {f:?}"
                );
            }
        }
    }

    #[test]
    fn separation_tensor_at_free_boundary_under_uniaxial_tension() {
        let n = 8;
        let mesh = jittered_plate(n, 0.0, 1);
        let els = Elements::new(&mesh, f64::INFINITY);
        // Tension along x only.
        let stress = vec![Sym3::outer([1.0, 0.0, 0.0]); mesh.n_faces()];
        let node_at = |x: f64, y: f64| {
            mesh.vertices().find(|&v| {
                let p = mesh.position(v);
                (p[0] - x).abs() < 1e-9 && (p[1] - y).abs() < 1e-9
            })
        };
        // A node on the bottom edge (y = 0): the crack plane's normal is the tension axis.
        let bottom = node_at(4.0, 0.0).unwrap();
        let (val, vec) = separation_tensor(&mesh, &els, &stress, bottom).max_eigen();
        assert!(val > 0.1, "eigenvalue {val}");
        assert!(vec[0].abs() > 0.999, "eigenvector {vec:?} should be +-x");
        // A node on the left edge (x = 0) is pulled along the tension: nothing separates.
        let left = node_at(0.0, 4.0).unwrap();
        let (val_left, _) = separation_tensor(&mesh, &els, &stress, left).max_eigen();
        assert!(
            val_left < 1e-9 * val.max(1.0),
            "left edge eigenvalue {val_left}"
        );
        // Pure compression never separates.
        let comp = vec![Sym3::outer([1.0, 0.0, 0.0]) * -1.0; mesh.n_faces()];
        let (vc, _) = separation_tensor(&mesh, &els, &comp, bottom).max_eigen();
        assert!(vc < 1e-9, "compression gave {vc}");
    }
}
