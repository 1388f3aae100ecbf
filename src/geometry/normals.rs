//! Smooth normals by angle for triangle geometry that has none, as a DCC
//! tool shades such a mesh (Blender's auto smooth): around each vertex the
//! triangles are smooth across an edge whose two triangles' normals differ
//! by at most the crease angle, and each smooth fan takes the corner-angle
//! weighted mean of its triangles' normals. Vertices at the same position
//! are one vertex here (a UV seam is not a crease); a vertex whose corners
//! fall in different fans is split ([`with_corner_attribute`]).

use crate::geometry::adjacency::{neighbours, weld};
use crate::geometry::tangents::with_corner_attribute;
use crate::math::v3;
use crate::scene::TriGeometry;

/// Blender's default auto smooth angle, degrees.
pub const DEFAULT_CREASE_DEGREES: f64 = 30.0;

/// A copy of `geo` with `NORMAL` smooth by angle (crease at
/// `crease_degrees`), or `None` when it has normals already or no
/// triangles.
pub fn with_smooth_normals(geo: &TriGeometry, crease_degrees: f64) -> Option<TriGeometry> {
    with_smooth_normals_together(&[geo], crease_degrees).pop()?
}

/// [`with_smooth_normals`] of several primitives of one mesh at once, so
/// the surface is smooth across their shared edges (a material border is
/// not a crease): per geometry its copy with `NORMAL`, `None` for one that
/// has normals or no triangles (it takes no part).
pub fn with_smooth_normals_together(
    geos: &[&TriGeometry],
    crease_degrees: f64,
) -> Vec<Option<TriGeometry>> {
    let takes_part = |g: &TriGeometry| g.attribute("NORMAL").is_none() && !g.triangles.is_empty();
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for g in geos.iter().filter(|g| takes_part(g)) {
        let base = positions.len() as u32;
        positions.extend_from_slice(&g.positions);
        triangles.extend(g.triangles.iter().map(|t| t.map(|v| v + base)));
    }
    let corners = smooth_corner_normals(&positions, &triangles, crease_degrees);
    let mut at = 0;
    geos.iter()
        .map(|g| {
            if !takes_part(g) {
                return None;
            }
            let n = g.triangles.len() * 9;
            let out = with_corner_attribute(g, "NORMAL", 3, &corners[at..at + n]);
            at += n;
            Some(out)
        })
        .collect()
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = p;
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    // The smaller index is the root: the result does not depend on the
    // order the edges are visited in.
    match ra.cmp(&rb) {
        std::cmp::Ordering::Less => parent[rb as usize] = ra,
        std::cmp::Ordering::Greater => parent[ra as usize] = rb,
        std::cmp::Ordering::Equal => {}
    }
}

/// Per triangle corner (corners in triangle order, 3 values each), the
/// unit normal of its smooth fan. A degenerate triangle's corners take
/// the mean of every triangle at their position (+z where that is zero
/// too).
pub fn smooth_corner_normals(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    crease_degrees: f64,
) -> Vec<f32> {
    // Vertices at one position are one.
    let positions: Vec<[f64; 3]> = positions.iter().map(|p| p.map(f64::from)).collect();
    let pid = weld(&positions);
    let n_pos = pid.iter().max().map_or(0, |&m| m as usize + 1);
    // Face normals and corner angles.
    let mut normal = Vec::with_capacity(triangles.len());
    let mut angle = Vec::with_capacity(triangles.len());
    for t in triangles {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        normal.push(v3::unit(v3::cross(v3::sub(b, a), v3::sub(c, a))));
        let corner = |p: [f64; 3], q: [f64; 3], r: [f64; 3]| {
            let (u, w) = (v3::sub(q, p), v3::sub(r, p));
            v3::norm(v3::cross(u, w)).atan2(v3::dot(u, w))
        };
        angle.push([corner(a, b, c), corner(b, c, a), corner(c, a, b)]);
    }
    // Smooth only across an edge of exactly two triangles whose normals
    // differ by at most the crease: their corners at its two ends join.
    let cos_crease = crease_degrees.to_radians().cos();
    let mut parent: Vec<u32> = (0..triangles.len() as u32 * 3).collect();
    let corner_at = |f: usize, p: u32| -> Option<u32> {
        (0..3)
            .find(|&k| pid[triangles[f][k] as usize] == p)
            .map(|k| (f * 3 + k) as u32)
    };
    for (f, across) in neighbours(&pid, triangles).iter().enumerate() {
        for (k, &g) in across.iter().enumerate() {
            let g = g as usize;
            if g == u32::MAX as usize || g <= f {
                continue;
            }
            if let (Some(nf), Some(ng)) = (normal[f], normal[g]) {
                if v3::dot(nf, ng) >= cos_crease {
                    let t = triangles[f];
                    for v in [t[k], t[(k + 1) % 3]] {
                        let p = pid[v as usize];
                        if let (Some(a), Some(b)) = (corner_at(f, p), corner_at(g, p)) {
                            union(&mut parent, a, b);
                        }
                    }
                }
            }
        }
    }
    // Sum each fan in corner order; the fallback per position likewise.
    let n_corners = triangles.len() * 3;
    let mut sum = vec![[0.0f64; 3]; n_corners];
    let mut at_pos = vec![[0.0f64; 3]; n_pos];
    for c in 0..n_corners {
        let f = c / 3;
        if let Some(n) = normal[f] {
            let w = v3::scale(n, angle[f][c % 3]);
            let r = find(&mut parent, c as u32) as usize;
            sum[r] = v3::add(sum[r], w);
            let p = pid[triangles[f][c % 3] as usize] as usize;
            at_pos[p] = v3::add(at_pos[p], w);
        }
    }
    let mut out = Vec::with_capacity(n_corners * 3);
    for c in 0..n_corners {
        let f = c / 3;
        let r = find(&mut parent, c as u32) as usize;
        let p = pid[triangles[f][c % 3] as usize] as usize;
        let n = normal[f]
            .and(v3::unit(sum[r]))
            .or_else(|| v3::unit(at_pos[p]))
            .unwrap_or([0.0, 0.0, 1.0]);
        out.extend(n.map(|x| x as f32));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attr(geo: &TriGeometry, s: &str) -> Vec<[f32; 3]> {
        let a = geo.attribute(s).unwrap();
        (0..a.len())
            .map(|i| [a.get(i)[0], a.get(i)[1], a.get(i)[2]])
            .collect()
    }

    /// A cube's faces stay flat (90 degrees is a crease): 24 vertices,
    /// each with its face's normal; a finely divided cylinder's side is
    /// smooth (each vertex the radial direction) and its caps flat.
    #[test]
    fn creases_stay_sharp_and_smooth_surfaces_smooth() {
        let geo = TriGeometry {
            positions: crate::mesh::shapes::cube24_input()
                .positions
                .iter()
                .map(|p| p.map(|x| x as f32))
                .collect(),
            triangles: crate::mesh::shapes::cube24_input().triangles,
            ..Default::default()
        };
        let out = with_smooth_normals(&geo, DEFAULT_CREASE_DEGREES).unwrap();
        let n = attr(&out, "NORMAL");
        for t in &out.triangles {
            let [a, b, c] = t.map(|v| out.positions[v as usize].map(f64::from));
            let face = v3::unit(v3::cross(v3::sub(b, a), v3::sub(c, a))).unwrap();
            for &v in t {
                let d = v3::dot(face, n[v as usize].map(f64::from));
                assert!(d > 0.9999, "a cube corner's normal {:?}", n[v as usize]);
            }
        }
        // A 48-sided cylinder (7.5 degrees between sides), capped.
        let (k, mut positions, mut triangles) = (48u32, Vec::new(), Vec::new());
        for i in 0..k {
            let a = f64::from(i) * std::f64::consts::TAU / f64::from(k);
            positions.push([a.cos() as f32, 0.0, a.sin() as f32]);
            positions.push([a.cos() as f32, 1.0, a.sin() as f32]);
        }
        positions.push([0.0, 0.0, 0.0]);
        positions.push([0.0, 1.0, 0.0]);
        for i in 0..k {
            let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * ((i + 1) % k), 2 * ((i + 1) % k) + 1);
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
            triangles.push([2 * k, a, c]);
            triangles.push([2 * k + 1, d, b]);
        }
        let geo = TriGeometry {
            positions,
            triangles,
            ..Default::default()
        };
        let out = with_smooth_normals(&geo, DEFAULT_CREASE_DEGREES).unwrap();
        let n = attr(&out, "NORMAL");
        let mut side = 0;
        for t in &out.triangles {
            let [a, b, c] = t.map(|v| out.positions[v as usize].map(f64::from));
            let face = v3::unit(v3::cross(v3::sub(b, a), v3::sub(c, a))).unwrap();
            for &v in t {
                let p = out.positions[v as usize].map(f64::from);
                let nv = n[v as usize].map(f64::from);
                if face[1].abs() > 0.99 {
                    assert!(v3::dot(face, nv) > 0.9999, "cap {p:?}: {nv:?}");
                } else {
                    let radial = v3::unit([p[0], 0.0, p[2]]).unwrap();
                    assert!(v3::dot(radial, nv) > 0.9999, "side {p:?}: {nv:?}");
                    side += 1;
                }
            }
        }
        assert_eq!(side, 48 * 6);
        // Rim vertices are split between the side and the caps.
        assert_eq!(out.positions.len(), 2 * 48 * 2 + 2);
        // Nothing to do where normals are given.
        assert!(with_smooth_normals(&out, 30.0).is_none());
    }
}
