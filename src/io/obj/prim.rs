//! The OBJ reader's primitives: each (group, material) section's faces,
//! its unique (v, vt, vn) corners becoming the primitive's vertices.

use super::*;
use crate::mesh::hash::FxHashMap;

/// Most vertices a position's chain holds (see [`PrimBuilder::spill`]).
const CHAIN: usize = 8;

/// What [`PrimBuilder::add_face`] reuses from face to face.
pub(super) struct Scratch {
    /// The face's vertex ids.
    polygon: Vec<u32>,
    /// Per file position: the builder (its `key`) that last used it and
    /// the first of that builder's vertices with it (the head of its
    /// chain, [`PrimBuilder::same_position`]): a corner is found among the
    /// few vertices of its own position, with no hash map.
    head: Vec<(u32, u32)>,
    /// Chain heads of builders another builder took a position over from,
    /// by (builder key, position): a builder met again (its group and
    /// material recur later in the file) finds its vertices there.
    evicted: FxHashMap<(u32, u32), u32>,
    /// Keys given to builders so far.
    builders: u32,
}

impl Scratch {
    pub(super) fn new(positions: usize) -> Self {
        Scratch {
            polygon: Vec::new(),
            head: vec![(u32::MAX, 0); positions],
            evicted: FxHashMap::default(),
            builders: 0,
        }
    }

    /// The number of positions no face given to a builder used.
    pub(super) fn unused_positions(&self) -> usize {
        self.head.iter().filter(|l| l.0 == u32::MAX).count()
    }
}

/// A primitive being built: unique (v, vt, vn) corners become its vertices.
#[derive(Clone)]
pub(super) struct PrimBuilder {
    pub(super) group: Option<String>,
    pub(super) material: Option<usize>,
    /// This builder's key in [`Scratch::head`].
    key: u32,
    vertices: Vec<Corner>,
    /// Per vertex: the builder's next vertex with the same position, in
    /// order of making (`u32::MAX` at a chain's end). A chain holds a
    /// position's first [`CHAIN`] vertices; any more are in `spill`.
    same_position: Vec<u32>,
    /// The vertices of positions with more than [`CHAIN`] corners (a
    /// pole's fan of texture coordinates), by corner: the lookup stays
    /// bounded however many corners share a position.
    spill: FxHashMap<Corner, u32>,
    triangles: Vec<[u32; 3]>,
    some_vt: bool,
    missing_vt: bool,
    some_vn: bool,
    missing_vn: bool,
}

impl PrimBuilder {
    pub(super) fn new(
        group: Option<String>,
        material: Option<usize>,
        scratch: &mut Scratch,
    ) -> Self {
        scratch.builders += 1;
        PrimBuilder {
            group,
            material,
            key: scratch.builders - 1,
            vertices: Vec::new(),
            same_position: Vec::new(),
            spill: FxHashMap::default(),
            triangles: Vec::new(),
            some_vt: false,
            missing_vt: false,
            some_vn: false,
            missing_vn: false,
        }
    }

    pub(super) fn add_face(
        &mut self,
        corners: &[Corner],
        positions: &[[f32; 3]],
        scratch: &mut Scratch,
    ) {
        let Scratch {
            polygon,
            head,
            evicted,
            ..
        } = scratch;
        polygon.clear();
        for &c in corners {
            if c.vt == ABSENT {
                self.missing_vt = true;
            } else {
                self.some_vt = true;
            }
            if c.vn == ABSENT {
                self.missing_vn = true;
            } else {
                self.some_vn = true;
            }
            let (key, first) = head[c.v as usize];
            let chain = if key == self.key {
                first
            } else {
                // Take the position over, keeping its owner's chain.
                if key != u32::MAX {
                    evicted.insert((key, c.v), first);
                }
                let own = evicted.get(&(self.key, c.v)).copied();
                own.unwrap_or(u32::MAX)
            };
            head[c.v as usize] = (self.key, chain);
            let (mut found, mut at, mut prev, mut steps) = (u32::MAX, chain, u32::MAX, 0);
            while at != u32::MAX {
                if self.vertices[at as usize] == c {
                    found = at;
                    break;
                }
                (prev, at, steps) = (at, self.same_position[at as usize], steps + 1);
            }
            if found == u32::MAX && steps == CHAIN {
                found = self.spill.get(&c).copied().unwrap_or(u32::MAX);
            }
            if found == u32::MAX {
                // A new vertex, numbered in order of first use.
                found = self.vertices.len() as u32;
                self.vertices.push(c);
                self.same_position.push(u32::MAX);
                if prev == u32::MAX {
                    head[c.v as usize].1 = found;
                } else if steps < CHAIN {
                    self.same_position[prev as usize] = found;
                } else {
                    self.spill.insert(c, found);
                }
            }
            polygon.push(found);
        }
        if polygon.len() == 3 {
            self.triangles.push([polygon[0], polygon[1], polygon[2]]);
            return;
        }
        let points: Vec<[f64; 3]> = corners
            .iter()
            .map(|c| {
                let p = positions[c.v as usize];
                [p[0] as f64, p[1] as f64, p[2] as f64]
            })
            .collect();
        for t in triangulate_polygon(&points) {
            self.triangles.push([
                polygon[t[0] as usize],
                polygon[t[1] as usize],
                polygon[t[2] as usize],
            ]);
        }
    }

    pub(super) fn finish(
        self,
        data: &Data,
        has_colors: bool,
        object: &str,
        scene: &mut Scene,
    ) -> Primitive {
        let label = || {
            let mut s = format!("object '{object}'");
            if let Some(g) = &self.group {
                s.push_str(&format!(", group '{g}'"));
            }
            if let Some(m) = self
                .material
                .and_then(|m| scene.materials.get(m))
                .and_then(Material::name)
            {
                s.push_str(&format!(", material '{m}'"));
            }
            s
        };
        let mut warnings = Vec::new();
        let positions = self
            .vertices
            .iter()
            .map(|c| data.positions[c.v as usize])
            .collect();
        let mut attributes = Vec::new();
        if self.some_vn {
            if self.missing_vn {
                warnings.push(format!(
                    "{}: only some face corners have a normal; NORMAL left out",
                    label()
                ));
            } else {
                let mut normals = Vec::with_capacity(self.vertices.len() * 3);
                let mut ok = true;
                for c in &self.vertices {
                    let n = data.normals[c.vn as usize];
                    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                    if !len.is_finite() || len <= 1e-12 {
                        ok = false;
                        break;
                    }
                    normals.extend([n[0] / len, n[1] / len, n[2] / len]);
                }
                if ok {
                    attributes.push(VertexAttribute {
                        semantic: "NORMAL".into(),
                        components: 3,
                        data: normals,
                    });
                } else {
                    warnings.push(format!(
                        "{}: a normal is zero or invalid; NORMAL left out",
                        label()
                    ));
                }
            }
        }
        if self.some_vt {
            if self.missing_vt {
                warnings.push(format!(
                    "{}: only some face corners have texture coordinates; TEXCOORD_0 left out",
                    label()
                ));
            } else {
                let uv = self
                    .vertices
                    .iter()
                    .flat_map(|c| {
                        let t = data.texcoords[c.vt as usize];
                        [t[0], 1.0 - t[1]]
                    })
                    .collect();
                attributes.push(VertexAttribute {
                    semantic: "TEXCOORD_0".into(),
                    components: 2,
                    data: uv,
                });
            }
        }
        if has_colors {
            let colors = self
                .vertices
                .iter()
                .flat_map(|c| data.colors[c.v as usize].map(|x| x.clamp(0.0, 1.0)))
                .collect();
            attributes.push(VertexAttribute {
                semantic: "COLOR_0".into(),
                components: 3,
                data: colors,
            });
        }
        scene.warnings.extend(warnings);
        Primitive {
            material: self.material,
            geometry: Geometry::Triangles(TriGeometry {
                positions,
                attributes,
                triangles: self.triangles,
                group: self.group,
                ..Default::default()
            }),
            rest: Map::new(),
        }
    }
}

// ---------------------------------------------------------------------------
// Material libraries
