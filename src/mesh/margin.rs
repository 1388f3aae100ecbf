//! A margin beyond an open surface's border, so a crack pattern can be
//! grown on more than the asset and the asset's border cuts through it.
//!
//! A ground patch, a wall or a tray of mud is a piece cut out of a larger
//! surface; its border is where the artist stopped modelling, not an edge
//! of the material. Cracked as it is, the film is free at the border: the
//! stress across it relaxes within about a cell, so the first cracks meet
//! the border at right angles, evenly spaced, and the cells along it line
//! up in a row (a comb along every edge). Grown on the surface extended by
//! a strip a cell or two wide, the border effect moves into the strip, and
//! the asset's border cuts through cells as a photograph's frame does.
//!
//! The strip continues each border edge outward in the plane of its face
//! (along its outward conormal), in rings; at a corner the two edges'
//! directions are averaged and lengthened so the strip keeps its width.
//! Where the strip would come back over the surface (a concave corner, a
//! hole narrower than twice the margin), its columns stop before they get
//! closer to the surface than they are far out. Each strip vertex carries
//! the corner values of the border vertex it grew from.

use super::attributes::Channel;
use super::build::{MeshInput, WeldOptions};
use super::error::{MeshError, OptionFault};
use super::halfedge::SimMesh;
use super::ids::HalfedgeId;
use super::spatial::{add, cross, dot, norm, scale, sub, Faces};
use crate::math::v3::unit;

/// What [`extend`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MarginReport {
    /// Border loops extended.
    pub loops: usize,
    /// Triangles added.
    pub triangles: usize,
    /// Strip vertices left out because the strip came back over the
    /// surface there.
    pub trimmed: usize,
    /// Border loops left free: shorter than a circle of the margin's
    /// radius (a small hole, a speck of a part), facing the surface too
    /// close by for a strip to fit along most of it, or every loop when the
    /// strip would have more than [`MAX_STRIP_SHARE`] times the mesh's
    /// triangles (a soup of loose triangles).
    pub left_free: usize,
}

/// Most triangles a strip may add, as a multiple of the mesh's (plus
/// 100,000): a mesh of many small loose parts keeps its free borders
/// instead of growing a strip round every part.
pub const MAX_STRIP_SHARE: usize = 4;

/// A strip vertex is kept only while the surface is at least this share of
/// its distance out away from it.
const KEEP_DISTANCE: f64 = 0.8;

/// A loop whose strip reaches its full width from fewer than this share of
/// its vertices is left free: its border faces the surface close by (a
/// lid's rim inside a pot's), where no strip fits.
const MIN_FULL_SHARE: f64 = 0.75;

/// `mesh` with a strip `width` wide (scene units) around every border
/// loop, in rings at most `spacing` apart. Faces of the mesh come first, in
/// their order and with their groups; the strip's faces follow, each in
/// its border face's group. A closed mesh comes back as it is.
///
/// # Errors
/// [`MeshError::InvalidOption`] for a width or spacing that is not a
/// positive number, or a strip of more rings than the mesh has vertices;
/// an error of [`SimMesh::build`] on the extended surface.
pub fn extend(
    mesh: &SimMesh,
    width: f64,
    spacing: f64,
) -> Result<(SimMesh, MarginReport), MeshError> {
    if !(width.is_finite() && width > 0.0 && spacing.is_finite() && spacing > 0.0) {
        return Err(OptionFault::MarginSize { width, spacing }.into());
    }
    let mut report = MarginReport::default();
    let rings = (width / spacing).ceil().max(1.0) as usize;
    if rings > 1000 {
        return Err(OptionFault::MarginRings {
            width,
            spacing,
            rings,
        }
        .into());
    }
    let mut loops = border_loops(mesh);
    let all = loops.len();
    let perimeter = |lp: &Vec<HalfedgeId>| lp.iter().map(|&h| mesh.edge_length(h)).sum::<f64>();
    loops.retain(|lp| perimeter(lp) >= std::f64::consts::TAU * width);
    let strip: usize = loops.iter().map(|lp| 2 * lp.len() * rings).sum();
    if strip > MAX_STRIP_SHARE * mesh.n_faces() + 100_000 {
        loops.clear();
    }
    report.left_free += all - loops.len();
    if loops.is_empty() {
        return Ok((mesh.clone(), report));
    }
    // The mesh as an input: one input vertex per wedge.
    let channels = mesh.wedges().channels();
    let wedge_of_corner: Vec<[u32; 3]> = mesh
        .faces()
        .map(|f| mesh.face_wedges(f).map(|w| w.0))
        .collect();
    let mut wedge_pos = vec![[0.0; 3]; mesh.n_wedges()];
    for f in mesh.faces() {
        for (v, w) in mesh.face_vertices(f).iter().zip(mesh.face_wedges(f)) {
            wedge_pos[w.idx()] = mesh.position(*v);
        }
    }
    let mut positions = wedge_pos;
    let mut values: Vec<Vec<f64>> = channels.iter().map(|c| c.data.clone()).collect();
    let mut triangles = wedge_of_corner;
    let mut groups: Vec<u32> = mesh.faces().map(|f| mesh.face_group(f)).collect();
    let surface = Faces::of_mesh(mesh);
    for lp in &loops {
        let n = lp.len();
        // Each border edge's outward conormal (unit, in its face's plane).
        let conormal: Vec<[f64; 3]> = lp
            .iter()
            .map(|&h| {
                let a = mesh.position(mesh.origin(h));
                let b = mesh.position(mesh.dest(h));
                unit(cross(sub(b, a), mesh.face_normal(mesh.face(h)))).unwrap_or([0.0; 3])
            })
            .collect();
        // Per border vertex (the origin of lp[i]): its direction out.
        let mut column: Vec<Vec<u32>> = Vec::with_capacity(n);
        let (n_positions, n_trimmed) = (positions.len(), report.trimmed);
        for i in 0..n {
            let h = lp[i];
            let v = mesh.origin(h);
            let c_in = conormal[(i + n - 1) % n];
            let c_out = conormal[i];
            let mid = unit(add(c_in, c_out)).unwrap_or([0.0; 3]);
            let d = if norm(mid) > 0.0 {
                let cos_half = dot(mid, c_out).max(0.5);
                scale(mid, 1.0 / cos_half)
            } else {
                c_out
            };
            let p = mesh.position(v);
            let w = mesh.wedge(h).idx();
            let mut ids = vec![w as u32];
            for k in 1..=rings {
                let s = width * k as f64 / rings as f64;
                let q = add(p, scale(d, s));
                if surface.distance(q) < KEEP_DISTANCE * s {
                    report.trimmed += rings + 1 - k;
                    break;
                }
                ids.push(positions.len() as u32);
                positions.push(q);
                for (vals, ch) in values.iter_mut().zip(channels) {
                    let c = ch.components;
                    vals.extend_from_slice(&ch.data[w * c..(w + 1) * c]);
                }
            }
            column.push(ids);
        }
        let full = column.iter().filter(|c| c.len() == rings + 1).count();
        if (full as f64) < MIN_FULL_SHARE * n as f64 {
            positions.truncate(n_positions);
            for (vals, ch) in values.iter_mut().zip(channels) {
                vals.truncate(n_positions * ch.components);
            }
            report.trimmed = n_trimmed;
            report.left_free += 1;
            continue;
        }
        // Faces between neighbouring columns, ring by ring, as far as both
        // reach; each border edge's strip faces in its face's group.
        let before = triangles.len();
        for i in 0..n {
            let j = (i + 1) % n;
            let group = mesh.face_group(mesh.face(lp[i]));
            let (a, b) = (&column[i], &column[j]);
            for k in 0..a.len().max(b.len()).saturating_sub(1) {
                // Columns are prefixes: once one ends, the band ends.
                let (Some(&ak), Some(&bk)) = (a.get(k), b.get(k)) else {
                    break;
                };
                // The diagonals alternate so the strip has no grain.
                let band: &[[u32; 3]] = match (a.get(k + 1).copied(), b.get(k + 1).copied()) {
                    (Some(ak1), Some(bk1)) if (i + k) % 2 == 0 => &[[bk, ak, ak1], [bk, ak1, bk1]],
                    (Some(ak1), Some(bk1)) => &[[bk, ak, bk1], [ak, ak1, bk1]],
                    (Some(ak1), None) => &[[bk, ak, ak1]],
                    (None, Some(bk1)) => &[[bk, ak, bk1]],
                    (None, None) => &[],
                };
                triangles.extend_from_slice(band);
                groups.extend(band.iter().map(|_| group));
            }
        }
        report.triangles += triangles.len() - before;
        report.loops += 1;
    }
    let wedge_channels = channels
        .iter()
        .zip(values)
        .map(|(ch, data)| Channel::new(&ch.name, ch.components, ch.kind, data))
        .collect();
    let input = MeshInput {
        positions,
        triangles,
        face_groups: groups,
        wedge_channels,
    };
    // Identical positions only: the input's own welding is already done.
    let (out, _) = SimMesh::build(
        &input,
        &WeldOptions {
            relative_tolerance: 0.0,
        },
    )?;
    Ok((out, report))
}

/// The border loops of `mesh`: each its boundary halfedges in order (the
/// face on the left, so the outside on the right).
fn border_loops(mesh: &SimMesh) -> Vec<Vec<HalfedgeId>> {
    let mut seen = vec![false; mesh.n_halfedges()];
    let mut loops = Vec::new();
    for h in mesh.halfedges() {
        if seen[h.idx()] || !mesh.is_boundary_halfedge(h) || mesh.is_crack_halfedge(h) {
            continue;
        }
        let mut lp = Vec::new();
        let mut g = h;
        loop {
            seen[g.idx()] = true;
            lp.push(g);
            match next_border(mesh, g) {
                Some(n) if n == h => break,
                Some(n) if !seen[n.idx()] => g = n,
                // A pinched or broken loop: stop at what was walked.
                _ => break,
            }
        }
        loops.push(lp);
    }
    loops
}

/// The boundary halfedge leaving the end of boundary halfedge `h`.
fn next_border(mesh: &SimMesh, h: HalfedgeId) -> Option<HalfedgeId> {
    let mut g = mesh.next(h);
    for _ in 0..mesh.n_halfedges() {
        match mesh.twin(g) {
            None => return Some(g),
            Some(t) => g = mesh.next(t),
        }
        if g == mesh.next(h) {
            return None;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::grid_input;

    fn plate(n: usize) -> SimMesh {
        SimMesh::build(&grid_input(n, n), &WeldOptions::default())
            .unwrap()
            .0
    }

    #[test]
    fn a_plate_grows_a_strip_of_the_width_asked() {
        let m = plate(10);
        let (lo, hi) = m.bounding_box();
        let (e, r) = extend(&m, 3.0, 1.0).unwrap();
        e.validate().unwrap();
        assert_eq!(r.loops, 1);
        assert_eq!(e.boundary_loops(), 1);
        let (elo, ehi) = e.bounding_box();
        for k in 0..3 {
            if hi[k] > lo[k] {
                assert!((lo[k] - elo[k] - 3.0).abs() < 1e-9, "{k}: {elo:?}");
                assert!((ehi[k] - hi[k] - 3.0).abs() < 1e-9, "{k}: {ehi:?}");
            }
        }
        // The plate's own faces first, unchanged.
        for f in m.faces() {
            let a = m.face_vertices(f).map(|v| m.position(v));
            let b = e.face_vertices(f).map(|v| e.position(v));
            assert_eq!(a, b);
        }
        // The strip's area: the frame around the square.
        let w = hi[0] - lo[0];
        let want = (w + 6.0) * (w + 6.0) - w * w;
        let got = e.total_area() - m.total_area();
        assert!((got - want).abs() < 1e-9 * want.max(1.0), "{got} {want}");
        assert_eq!(r.trimmed, 0);
    }

    #[test]
    fn a_closed_mesh_is_left_alone() {
        let m = SimMesh::build(
            &crate::mesh::shapes::icosphere_input(1),
            &WeldOptions::default(),
        )
        .unwrap()
        .0;
        let (e, r) = extend(&m, 0.3, 0.1).unwrap();
        assert_eq!((r.loops, r.left_free), (0, 0));
        assert_eq!(e, m);
    }

    /// A 20 x 20 plate with a square hole from `lo` to `hi`.
    fn holed(lo: f64, hi: f64) -> SimMesh {
        let input = grid_input(20, 20);
        let triangles = input
            .triangles
            .iter()
            .filter(|t| {
                let c = t.map(|i| input.positions[i as usize]);
                let mid: [f64; 3] = std::array::from_fn(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0);
                !((lo..hi).contains(&mid[0]) && (lo..hi).contains(&mid[1]))
            })
            .copied()
            .collect();
        let holed = MeshInput { triangles, ..input };
        SimMesh::build(&holed, &WeldOptions::default()).unwrap().0
    }

    #[test]
    fn a_strip_into_a_hole_stops_before_it_comes_back_over_the_surface() {
        // A 10 x 10 hole and a margin of 1.5: next to the hole's corners
        // the strip from one side would run over the plate beside the next.
        let m = holed(5.0, 15.0);
        let (e, r) = extend(&m, 1.5, 0.25).unwrap();
        e.validate().unwrap();
        assert_eq!((r.loops, r.left_free), (2, 0));
        assert!(r.trimmed > 0);
        let s = Faces::of_mesh(&m);
        let mut in_hole = 0;
        for v in e.vertices() {
            let p = e.position(v);
            if m.positions().contains(&p) {
                continue;
            }
            assert!(s.distance(p) > 0.2, "{p:?} lies on the plate");
            in_hole += usize::from((5.0..=15.0).contains(&p[0]) && (5.0..=15.0).contains(&p[1]));
        }
        assert!(in_hole > 0, "the hole got no strip");
    }

    #[test]
    fn a_loop_facing_the_surface_close_by_keeps_its_free_border() {
        // A 4 x 4 hole (16 round, more than a circle of radius 1.5) is too
        // narrow for a strip 1.5 wide along most of its sides.
        let m = holed(8.0, 12.0);
        let (e, r) = extend(&m, 1.5, 0.25).unwrap();
        e.validate().unwrap();
        assert_eq!((r.loops, r.left_free, r.trimmed), (1, 1, 0));
        assert_eq!(e.boundary_loops(), 2);
    }

    #[test]
    fn a_small_hole_keeps_its_free_border() {
        // A 2 x 2 hole is shorter round than a circle of the margin's
        // radius: only the outer border grows a strip.
        let m = holed(9.0, 11.0);
        let (e, r) = extend(&m, 3.0, 0.5).unwrap();
        e.validate().unwrap();
        assert_eq!((r.loops, r.left_free), (1, 1));
        assert_eq!(e.boundary_loops(), 2);
    }
}
