//! The solid `model = "ductile"` tears: a mesh's surface, closed across
//! its holes, and what the torn surface measures.

use crate::bridge::SimEntry;
use crate::sim::ductile::surface::TornSurface;
use std::path::Path;

/// A closed surface: positions and triangles.
pub(super) type Solid = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// `e`'s surface as a closed solid for the tearing: its own positions and
/// triangles, each hole closed by a fan (the output keeps the holes).
///
/// # Errors
/// A surface that is open and encloses no volume closed (a sheet), or
/// whose holes are not simple loops.
pub(super) fn solid_of(e: &SimEntry, input: &Path) -> crate::Result<Solid> {
    let mut positions = e.sim.positions().to_vec();
    let mut triangles: Vec<[u32; 3]> = e
        .sim
        .faces()
        .map(|f| e.sim.face_vertices(f).map(|v| v.0))
        .collect();
    // An open surface (a scan with holes in its base) is closed for the
    // solid by a fan across each hole; the output keeps its holes.
    match close_holes(e, &mut positions, &mut triangles) {
        Ok(0) => {}
        Ok(holes) if !encloses_volume(&positions, &triangles) => {
            return Err(crate::Error::mesh(
                input,
                &e.label,
                format!("model = \"ductile\" tears solids; this surface is open along {holes} boundary loop(s) and closed across them it encloses no volume (a sheet)"),
            ))
        }
        Ok(holes) => log::warn!(
            "{}: {}: the surface is open along {holes} boundary loop(s); the solid closes each with a fan across it (the output keeps the holes)",
            input.display(),
            e.label
        ),
        Err(loops) => {
            return Err(crate::Error::mesh(
                input,
                &e.label,
                format!("model = \"ductile\" tears closed solids; this surface is open along {loops} boundary loop(s) after welding, and they do not close as simple loops"),
            ))
        }
    }
    Ok((positions, triangles))
}

/// The torn surface's torn triangles: how many, and their area in the
/// scene's units (`to_scene` maps the solid's metres to them).
pub(super) fn torn_area(
    surface: &TornSurface,
    to_scene: impl Fn([f64; 3]) -> [f64; 3],
) -> (usize, f64) {
    let torn_triangles = surface.torn.iter().filter(|&&t| t).count();
    let torn_area: f64 = surface
        .triangles
        .iter()
        .zip(&surface.torn)
        .filter(|(_, &torn)| torn)
        .map(|(t, _)| {
            let [a, b, c] = t.map(|v| to_scene(surface.positions[v as usize]));
            0.5 * crate::math::v3::norm(crate::math::v3::cross(
                crate::math::v3::sub(b, a),
                crate::math::v3::sub(c, a),
            ))
        })
        .sum();
    (torn_triangles, torn_area)
}

/// Whether the closed surface `positions` / `triangles` encloses a volume
/// of at least a millionth of its bounding box's diagonal cubed (a sheet
/// closed across its border encloses none).
fn encloses_volume(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> bool {
    let (lo, hi) = crate::sim::ductile::grid::bounds(positions);
    let c: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let volume: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, p] = t.map(|v| {
                let q = positions[v as usize];
                [q[0] - c[0], q[1] - c[1], q[2] - c[2]]
            });
            crate::math::v3::dot(a, crate::math::v3::cross(b, p)) / 6.0
        })
        .sum();
    let diagonal = crate::math::v3::norm(crate::math::v3::sub(hi, lo));
    volume.abs() > 1e-6 * diagonal.powi(3)
}

/// Closes each boundary loop of `e`'s surface (added to `positions` /
/// `triangles`, which start as its own) with a fan from the loop's
/// centroid, oriented with the faces beside it. Returns the loops closed,
/// or the number of boundary loops when they are not simple cycles (a
/// vertex on two of them).
fn close_holes(
    e: &SimEntry,
    positions: &mut Vec<[f64; 3]>,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<usize, usize> {
    let mut next: std::collections::BTreeMap<u32, u32> = Default::default();
    let mut simple = true;
    for h in e.sim.halfedges() {
        if e.sim.twin(h).is_none() {
            simple &= next.insert(e.sim.origin(h).0, e.sim.dest(h).0).is_none();
        }
    }
    let mut seen = std::collections::HashSet::new();
    let mut loops: Vec<Vec<u32>> = Vec::new();
    for &s in next.keys() {
        if seen.contains(&s) {
            continue;
        }
        let mut cycle = Vec::new();
        let mut v = s;
        while seen.insert(v) {
            cycle.push(v);
            match next.get(&v) {
                Some(&w) => v = w,
                None => {
                    simple = false;
                    break;
                }
            }
        }
        simple &= v == s && cycle.len() >= 3;
        loops.push(cycle);
    }
    if !simple {
        return Err(loops.len());
    }
    for cycle in &loops {
        let n = cycle.len() as f64;
        let c = cycle.iter().fold([0.0; 3], |acc, &v| {
            let p = positions[v as usize];
            std::array::from_fn(|k| acc[k] + p[k] / n)
        });
        let centre = positions.len() as u32;
        positions.push(c);
        for (k, &a) in cycle.iter().enumerate() {
            // The surface's face has a -> b; the cap's has b -> a.
            let b = cycle[(k + 1) % cycle.len()];
            triangles.push([b, a, centre]);
        }
    }
    Ok(loops.len())
}
