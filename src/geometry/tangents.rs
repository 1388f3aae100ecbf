//! MikkTSpace tangents for triangle geometry that has normals and UVs but no
//! `TANGENT`, so a normal-mapped material renders the same everywhere (glTF
//! asks clients to generate MikkTSpace tangents, and the Khronos validator
//! warns when a normal-mapped primitive lacks them).

use crate::scene::{TriGeometry, VertexAttribute};
use rayon::prelude::*;
use std::collections::HashMap;

/// The triangles `faces` of `geo`, as MikkTSpace sees them.
struct Corners<'a> {
    geo: &'a TriGeometry,
    faces: &'a [u32],
    normal: &'a VertexAttribute,
    uv: &'a VertexAttribute,
    out: Vec<[f32; 4]>,
}

impl Corners<'_> {
    fn vertex(&self, f: usize, v: usize) -> usize {
        self.geo.triangles[self.faces[f] as usize][v] as usize
    }
}

impl mikktspace::Geometry for Corners<'_> {
    fn num_faces(&self) -> usize {
        self.faces.len()
    }
    fn num_vertices_of_face(&self, _: usize) -> usize {
        3
    }
    fn position(&self, f: usize, v: usize) -> [f32; 3] {
        self.geo.positions[self.vertex(f, v)]
    }
    fn normal(&self, f: usize, v: usize) -> [f32; 3] {
        let n = self.normal.get(self.vertex(f, v));
        [n[0], n[1], n[2]]
    }
    fn tex_coord(&self, f: usize, v: usize) -> [f32; 2] {
        let t = self.uv.get(self.vertex(f, v));
        [t[0], t[1]]
    }
    fn set_tangent_encoded(&mut self, t: [f32; 4], f: usize, v: usize) {
        self.out[f * 3 + v] = t;
    }
}

/// Triangles per MikkTSpace call at least (smaller groups are merged).
const CHUNK_TRIANGLES: usize = 16384;

/// The triangles in groups MikkTSpace handles independently: vertices it
/// would weld (equal position, normal and UV) join their triangles, so no
/// tangent depends on a triangle of another group. Components in order of
/// their first triangle, triangles in index order, merged into chunks of at
/// least [`CHUNK_TRIANGLES`].
fn independent_groups(
    geo: &TriGeometry,
    normal: &VertexAttribute,
    uv: &VertexAttribute,
) -> Vec<Vec<u32>> {
    // Welded vertex ids.
    let mut id: HashMap<[u32; 8], u32> = HashMap::with_capacity(geo.positions.len());
    let canon: Vec<u32> = (0..geo.positions.len())
        .map(|v| {
            let p = geo.positions[v];
            let n = normal.get(v);
            let t = uv.get(v);
            let key = [p[0], p[1], p[2], n[0], n[1], n[2], t[0], t[1]].map(f32::to_bits);
            let next = id.len() as u32;
            *id.entry(key).or_insert(next)
        })
        .collect();
    // Union-find over welded vertices, joined by the triangles.
    let mut parent: Vec<u32> = (0..id.len() as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for t in &geo.triangles {
        let [a, b, c] = t.map(|v| canon[v as usize]);
        for (u, w) in [(a, b), (b, c)] {
            let (ru, rw) = (find(&mut parent, u), find(&mut parent, w));
            if ru != rw {
                parent[ru.max(rw) as usize] = ru.min(rw);
            }
        }
    }
    let mut component_of: HashMap<u32, usize> = HashMap::new();
    let mut components: Vec<Vec<u32>> = Vec::new();
    for (f, t) in geo.triangles.iter().enumerate() {
        let root = find(&mut parent, canon[t[0] as usize]);
        let k = *component_of.entry(root).or_insert_with(|| {
            components.push(Vec::new());
            components.len() - 1
        });
        components[k].push(f as u32);
    }
    let mut chunks: Vec<Vec<u32>> = Vec::new();
    for c in components {
        match chunks.last_mut() {
            Some(last) if last.len() < CHUNK_TRIANGLES => last.extend(c),
            _ => chunks.push(c),
        }
    }
    chunks
}

/// A copy of `geo` with a `TANGENT` attribute computed by MikkTSpace from
/// `NORMAL` and the UV set `uv_semantic`, in glTF's convention: the
/// bitangent `cross(normal, tangent) * w` points up the texture image
/// (towards smaller v), where a normal map's green channel points. Vertices whose corners get different
/// tangents are split. Returns `None` when the geometry lacks normals or that
/// UV set, already has tangents, or the tangents cannot be computed.
pub fn with_generated_tangents(geo: &TriGeometry, uv_semantic: &str) -> Option<TriGeometry> {
    if geo.attribute("TANGENT").is_some() || geo.triangles.is_empty() {
        return None;
    }
    let normal = geo.attribute("NORMAL").filter(|a| a.components == 3)?;
    let uv = geo.attribute(uv_semantic).filter(|a| a.components == 2)?;
    // MikkTSpace per independent group, in parallel; each corner's tangent
    // is what one call over the whole mesh gives.
    let groups = independent_groups(geo, normal, uv);
    let results: Vec<Option<Vec<[f32; 4]>>> = groups
        .par_iter()
        .map(|faces| {
            let mut c = Corners {
                geo,
                faces,
                normal,
                uv,
                out: vec![[1.0, 0.0, 0.0, 1.0]; faces.len() * 3],
            };
            mikktspace::generate_tangents(&mut c).then_some(c.out)
        })
        .collect();
    let mut out = vec![[1.0f32, 0.0, 0.0, 1.0]; geo.triangles.len() * 3];
    for (faces, r) in groups.iter().zip(results) {
        let r = r?;
        for (k, &f) in faces.iter().enumerate() {
            out[f as usize * 3..f as usize * 3 + 3].copy_from_slice(&r[k * 3..k * 3 + 3]);
        }
    }
    let tangents: Vec<f32> = out
        .iter()
        .enumerate()
        .flat_map(|(corner, &t)| {
            let mut t = t;
            let l = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
            if l.is_finite() && l > 1e-12 {
                t[0] /= l;
                t[1] /= l;
                t[2] /= l;
            } else {
                t = orthogonal(normal.get(geo.triangles[corner / 3][corner % 3] as usize));
            }
            // glTF's UVs run down the image while MikkTSpace takes v up:
            // the bitangent's sign flips (as three.js' `negateSign`).
            t[3] = if t[3] < 0.0 { 1.0 } else { -1.0 };
            t
        })
        .collect();
    Some(with_corner_attribute(geo, "TANGENT", 4, &tangents))
}

/// A copy of `geo` with one more attribute, `semantic`, given per triangle
/// corner (`components` values a corner, 1 to 4, corners in triangle order).
/// Every vertex keeps its index and takes the value of its first corner
/// (in triangle order); a corner with another value gets a copy of its
/// vertex (its other attributes and morph-target values), appended after
/// the input's vertices, one per distinct value. So only the triangles
/// that need a split vertex change, and a vertex no triangle uses stays
/// (with zeros). An attribute of that name already present is replaced.
pub fn with_corner_attribute(
    geo: &TriGeometry,
    semantic: &str,
    components: usize,
    corners: &[f32],
) -> TriGeometry {
    let kept: Vec<VertexAttribute> = geo
        .attributes
        .iter()
        .filter(|a| a.semantic != semantic)
        .cloned()
        .collect();
    let n = geo.positions.len();
    let mut out = TriGeometry {
        positions: geo.positions.clone(),
        attributes: kept,
        triangles: Vec::with_capacity(geo.triangles.len()),
        targets: geo.targets.clone(),
        group: geo.group.clone(),
    };
    let mut added = VertexAttribute {
        semantic: semantic.into(),
        components,
        data: vec![0.0; n * components],
    };
    // The value each vertex took first; copies by (vertex, value bits).
    let mut first: Vec<Option<[u32; 4]>> = vec![None; n];
    let mut copies: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    for (f, tri) in geo.triangles.iter().enumerate() {
        let mut new_tri = [0u32; 3];
        for k in 0..3 {
            let v = tri[k];
            let value = &corners[(f * 3 + k) * components..(f * 3 + k + 1) * components];
            let mut bits = [0u32; 4];
            for (b, x) in bits.iter_mut().zip(value) {
                *b = x.to_bits();
            }
            new_tri[k] = match first[v as usize] {
                None => {
                    first[v as usize] = Some(bits);
                    added.data[v as usize * components..(v as usize + 1) * components]
                        .copy_from_slice(value);
                    v
                }
                Some(b) if b == bits => v,
                Some(_) => *copies.entry((v, bits)).or_insert_with(|| {
                    let next = out.positions.len() as u32;
                    out.positions.push(geo.positions[v as usize]);
                    for a in out.attributes.iter_mut() {
                        let c = a.components;
                        a.data
                            .extend_from_within(v as usize * c..(v as usize + 1) * c);
                    }
                    for t in out.targets.iter_mut() {
                        for a in t.iter_mut() {
                            let c = a.components;
                            a.data
                                .extend_from_within(v as usize * c..(v as usize + 1) * c);
                        }
                    }
                    added.data.extend_from_slice(value);
                    next
                }),
            };
        }
        out.triangles.push(new_tri);
    }
    out.attributes.push(added);
    out
}

/// A unit vector orthogonal to `n` (w = 1), for corners MikkTSpace could not handle.
fn orthogonal(n: &[f32]) -> [f32; 4] {
    let a = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let d = a[0] * n[0] + a[1] * n[1] + a[2] * n[2];
    let t = [a[0] - d * n[0], a[1] - d * n[1], a[2] - d * n[2]];
    let l = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt().max(1e-20);
    [t[0] / l, t[1] / l, t[2] / l, 1.0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quad_gets_u_aligned_tangents() {
        // A quad in the XY plane, normal +Z, u along +X, the image upright
        // (v runs down it, along -Y).
        let geo = TriGeometry {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            attributes: vec![
                VertexAttribute {
                    semantic: "NORMAL".into(),
                    components: 3,
                    data: [0.0, 0.0, 1.0].repeat(4),
                },
                VertexAttribute {
                    semantic: "TEXCOORD_0".into(),
                    components: 2,
                    data: vec![0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0],
                },
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        };
        let out = with_generated_tangents(&geo, "TEXCOORD_0").unwrap();
        assert_eq!(out.positions.len(), 4);
        let t = out.attribute("TANGENT").unwrap();
        for v in 0..4 {
            let x = t.get(v);
            assert!(
                (x[0] - 1.0).abs() < 1e-5 && x[1].abs() < 1e-5 && x[2].abs() < 1e-5,
                "{x:?}"
            );
            // The bitangent cross(N, T) * w = +Y: up the image, where
            // glTF's normal maps point green.
            assert_eq!(x[3], 1.0, "{x:?}");
        }
        assert!(
            with_generated_tangents(&out, "TEXCOORD_0").is_none(),
            "already has tangents"
        );
    }
}
