//! Geometry mode ([`Mode::Geometry`], `crackle diff --geometry`): b is a's
//! own mesh. Each mesh's triangle primitives (b's crack walls left out) are
//! concatenated and compared triangle by triangle, corner by corner, on a's
//! attributes; index buffers and vertex counts are summarised
//! ([`IndexSummary`]). The rules are in the documentation of
//! [`crate::compare`].

use super::geometry::{columns, worst_delta, Column};
use super::*;
use crate::io::accessor::decode_raw;
use crate::io::gltf_read::assemble_triangles;
use crate::scene::{RawGeometry, TriGeometry, VertexAttribute};
use std::borrow::Cow;

/// Material of the crack walls crackle adds: such primitives of b are left out.
const WALL_MATERIAL: &str = "crack_wall";

/// Vertex counts and kept indices of one mesh's triangle primitives.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshIndices {
    /// Mesh index.
    pub mesh: usize,
    /// Vertices of a's triangle primitives.
    pub vertices_a: usize,
    /// Vertices of b's triangle primitives (crack walls left out).
    pub vertices_b: usize,
    /// Triangles of a.
    pub triangles: usize,
    /// Triangles `t` whose vertex indices (in their primitive) are the same
    /// in a and b.
    pub triangles_same_indices: usize,
    /// a's k-th triangle primitive against b's k-th.
    pub primitives: Vec<PrimitiveIndices>,
}

/// The k-th triangle primitive of a mesh in a and in b.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PrimitiveIndices {
    /// Its index in a's mesh (None: b has more triangle primitives).
    pub a: Option<usize>,
    /// Its index in b's mesh (None: a has more triangle primitives).
    pub b: Option<usize>,
    /// Its vertices in a (0 when missing).
    pub vertices_a: usize,
    /// Its vertices in b (0 when missing).
    pub vertices_b: usize,
    /// Whether both exist with the same triangles (index triples, in order).
    pub same_indices: bool,
}

impl PrimitiveIndices {
    /// Same index buffer and vertex count.
    fn unchanged(&self) -> bool {
        self.same_indices && self.vertices_a == self.vertices_b
    }
}

/// Vertex counts and kept indices of every mesh compared in geometry mode.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct IndexSummary {
    /// Per mesh compared (both files have it).
    pub meshes: Vec<MeshIndices>,
}

impl IndexSummary {
    fn sum(&self, f: impl Fn(&MeshIndices) -> usize) -> usize {
        self.meshes.iter().map(f).sum()
    }

    /// Vertices of a's triangle primitives.
    pub fn vertices_a(&self) -> usize {
        self.sum(|m| m.vertices_a)
    }

    /// Vertices of b's triangle primitives (crack walls left out).
    pub fn vertices_b(&self) -> usize {
        self.sum(|m| m.vertices_b)
    }

    /// Whether every primitive kept its index buffer and vertex count.
    pub fn unchanged(&self) -> bool {
        self.meshes
            .iter()
            .all(|m| m.primitives.iter().all(PrimitiveIndices::unchanged))
    }

    fn primitives(&self) -> (usize, usize) {
        let all = || self.meshes.iter().flat_map(|m| &m.primitives);
        (all().filter(|p| p.same_indices).count(), all().count())
    }

    /// "238 split", "12 merged" or "none split".
    fn split_text(&self) -> String {
        let (a, b) = (self.vertices_a(), self.vertices_b());
        match b.cmp(&a) {
            std::cmp::Ordering::Greater => format!("{} split", b - a),
            std::cmp::Ordering::Less => format!("{} merged", a - b),
            std::cmp::Ordering::Equal => "none split".into(),
        }
    }

    /// One line: "vertices 2399 -> 2637 (238 split; indices identical on
    /// 3900 of 4212 triangles, 0 of 1 primitives)".
    pub fn line(&self) -> String {
        let (same, all) = self.primitives();
        format!(
            "vertices {} -> {} ({}; indices identical on {} of {} triangles, {same} of {all} primitives)",
            self.vertices_a(),
            self.vertices_b(),
            self.split_text(),
            self.sum(|m| m.triangles_same_indices),
            self.sum(|m| m.triangles),
        )
    }

    /// The summary as JSON (totals, then per mesh and primitive).
    pub fn json(&self) -> Value {
        let (same, all) = self.primitives();
        let meshes: Vec<Value> = self
            .meshes
            .iter()
            .map(|m| {
                json!({
                    "mesh": m.mesh,
                    "vertices_a": m.vertices_a,
                    "vertices_b": m.vertices_b,
                    "triangles": m.triangles,
                    "triangles_same_indices": m.triangles_same_indices,
                    "primitives": m.primitives.iter().map(|p| json!({
                        "a": p.a,
                        "b": p.b,
                        "vertices_a": p.vertices_a,
                        "vertices_b": p.vertices_b,
                        "same_indices": p.same_indices,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect();
        json!({
            "vertices_a": self.vertices_a(),
            "vertices_b": self.vertices_b(),
            "split_vertices": self.vertices_b() as i64 - self.vertices_a() as i64,
            "triangles": self.sum(|m| m.triangles),
            "triangles_same_indices": self.sum(|m| m.triangles_same_indices),
            "primitives": all,
            "primitives_same_indices": same,
            "indices_identical": same == all,
            "unchanged": self.unchanged(),
            "meshes": meshes,
        })
    }
}

/// Compare `b` with `a` in geometry mode; the differences go to `d`.
pub(super) fn compare_same_mesh(
    a: &Scene,
    b: &Scene,
    same_indices: bool,
    d: &mut Differences,
) -> IndexSummary {
    compare_nodes(a, b, d);
    let skin = |s: Option<usize>| s.map_or("none".to_string(), |s| s.to_string());
    for (i, (x, y)) in a.nodes.iter().zip(&b.nodes).enumerate() {
        d.ne(
            "node_skin",
            &node_place(a, i),
            "skin",
            skin(x.skin),
            skin(y.skin),
        );
    }
    compare_mesh_count(a, b, d);
    let mut meshes = Vec::new();
    for i in 0..a.meshes.len().min(b.meshes.len()) {
        compare_mesh_name(a, b, i, d);
        meshes.push(compare_mesh(a, b, i, same_indices, d));
    }
    compare_counts(a, b, d, false);
    IndexSummary { meshes }
}

/// One triangle primitive taking part: its index in the mesh, its geometry.
struct Part<'a> {
    index: usize,
    geo: Cow<'a, TriGeometry>,
}

/// The triangle primitives of mesh `m` taking part, in order; with
/// `skip_walls`, not those of the crack-wall material.
fn parts<'a>(
    s: &'a Scene,
    m: usize,
    skip_walls: bool,
    place: &str,
    d: &mut Differences,
) -> Vec<Part<'a>> {
    let mut out = Vec::new();
    for (j, p) in s.meshes[m].primitives.iter().enumerate() {
        let material = p.material.and_then(|i| s.materials.get(i));
        if skip_walls && material.and_then(|x| x.name()) == Some(WALL_MATERIAL) {
            continue;
        }
        let geo = match &p.geometry {
            Geometry::Triangles(t) => Cow::Borrowed(t),
            Geometry::Raw(r) if is_triangle_mode(r.mode) => match decode_triangles(s, r) {
                Some(t) => Cow::Owned(t),
                None => {
                    let which = if skip_walls { "b" } else { "a" };
                    let detail = format!("the triangles of {which} cannot be decoded");
                    d.push("geometry_data", format!("{place} primitive {j}"), detail);
                    continue;
                }
            },
            Geometry::Raw(_) => continue,
        };
        out.push(Part { index: j, geo });
    }
    out
}

fn is_triangle_mode(m: u32) -> bool {
    matches!(
        m,
        mode::TRIANGLES | mode::TRIANGLE_STRIP | mode::TRIANGLE_FAN
    )
}

/// A passed-through triangle primitive (skinned, say) decoded from its
/// accessors; None when any of them cannot be.
fn decode_triangles(s: &Scene, r: &RawGeometry) -> Option<TriGeometry> {
    let attr = |semantic: &str, acc: usize| -> Option<VertexAttribute> {
        let (components, v) = decode_raw(s.accessors.get(acc)?)?;
        Some(VertexAttribute {
            semantic: semantic.into(),
            components,
            data: v.into_iter().map(|x| x as f32).collect(),
        })
    };
    let pos = attr("POSITION", *r.attributes.get("POSITION")?)?;
    if pos.components != 3 {
        return None;
    }
    let n = pos.len();
    let positions = pos
        .data
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    // Every attribute but `skip` (a morph target's POSITION is a
    // displacement like the others).
    let map = |m: &std::collections::BTreeMap<String, usize>, skip: &str| {
        m.iter()
            .filter(|(k, _)| *k != skip)
            .map(|(k, &i)| attr(k, i))
            .collect::<Option<Vec<_>>>()
    };
    let attributes = map(&r.attributes, "POSITION")?;
    let targets = r
        .targets
        .iter()
        .map(|t| map(t, ""))
        .collect::<Option<Vec<_>>>()?;
    if attributes
        .iter()
        .chain(targets.iter().flatten())
        .any(|a| a.len() != n)
    {
        return None;
    }
    let ix: Vec<u32> = match r.indices {
        Some(i) => {
            let (c, v) = decode_raw(s.accessors.get(i)?)?;
            if c != 1 {
                return None;
            }
            v.into_iter().map(|x| x as u32).collect()
        }
        None => (0..n as u32).collect(),
    };
    if ix.iter().any(|&i| i as usize >= n) {
        return None;
    }
    Some(TriGeometry {
        positions,
        attributes,
        triangles: assemble_triangles(r.mode, &ix),
        targets,
        group: None,
    })
}

/// Compare mesh `i` of both files: triangle count, corners, and (with
/// `same_indices`) index buffers and vertex counts.
fn compare_mesh(
    a: &Scene,
    b: &Scene,
    i: usize,
    same_indices: bool,
    d: &mut Differences,
) -> MeshIndices {
    let place = mesh_place(a, i);
    let pa = parts(a, i, false, &place, d);
    let pb = parts(b, i, true, &place, d);
    let tris = |p: &[Part]| p.iter().map(|x| x.geo.triangles.len()).sum::<usize>();
    let verts = |p: &[Part]| p.iter().map(|x| x.geo.positions.len()).sum::<usize>();
    let (na, nb) = (tris(&pa), tris(&pb));
    d.ne("triangle_count", &place, "triangles", na, nb);
    if na == nb {
        compare_corners(&pa, &pb, &place, d);
    }
    let all = |p: &[Part]| {
        p.iter()
            .flat_map(|x| x.geo.triangles.iter().copied())
            .collect::<Vec<_>>()
    };
    let triangles_same_indices = all(&pa)
        .iter()
        .zip(&all(&pb))
        .filter(|(x, y)| x == y)
        .count();
    let primitives: Vec<PrimitiveIndices> = (0..pa.len().max(pb.len()))
        .map(|k| {
            let (x, y) = (pa.get(k), pb.get(k));
            PrimitiveIndices {
                a: x.map(|p| p.index),
                b: y.map(|p| p.index),
                vertices_a: x.map_or(0, |p| p.geo.positions.len()),
                vertices_b: y.map_or(0, |p| p.geo.positions.len()),
                same_indices: matches!((x, y), (Some(x), Some(y)) if x.geo.triangles == y.geo.triangles),
            }
        })
        .collect();
    if same_indices {
        report_indices(&pa, &pb, &primitives, &place, d);
    }
    MeshIndices {
        mesh: i,
        vertices_a: verts(&pa),
        vertices_b: verts(&pb),
        triangles: na,
        triangles_same_indices,
        primitives,
    }
}

/// With `--same-indices`: every change of a primitive's index buffer or
/// vertex count is a difference.
fn report_indices(
    pa: &[Part],
    pb: &[Part],
    primitives: &[PrimitiveIndices],
    place: &str,
    d: &mut Differences,
) {
    d.ne(
        "primitive_count",
        place,
        "triangle primitives",
        pa.len(),
        pb.len(),
    );
    for (x, y, p) in pa
        .iter()
        .zip(pb)
        .zip(primitives)
        .map(|((x, y), p)| (x, y, p))
    {
        let place = format!("{place} primitive {}", x.index);
        let (n, m) = (p.vertices_a, p.vertices_b);
        if n != m {
            let what = if m > n { "split" } else { "merged" };
            let detail = format!("vertices {n} vs {m} ({} {what})", n.abs_diff(m));
            d.push("vertex_count", place.clone(), detail);
        }
        if !p.same_indices {
            let (t, u) = (&x.geo.triangles, &y.geo.triangles);
            let off = t.iter().zip(u).filter(|(p, q)| p != q).count() + t.len().abs_diff(u.len());
            let first = t
                .iter()
                .zip(u)
                .position(|(p, q)| p != q)
                .unwrap_or(t.len().min(u.len()));
            let detail = format!(
                "indices differ on {off} of {} triangles (first at triangle {first})",
                t.len()
            );
            d.push("indices", place, detail);
        }
    }
}

/// Where the first differing corner of an attribute is.
struct Corner {
    /// a's primitive triangle and the mesh's triangle.
    triangle: usize,
    mesh_triangle: usize,
    corner: usize,
    vertex_a: usize,
    primitive_b: usize,
    vertex_b: usize,
}

/// Corners of one of a's attributes that differ, for one of a's primitives.
#[derive(Default)]
struct Tally {
    corners: usize,
    triangles: usize,
    worst: f64,
    first: Option<Corner>,
}

/// A stretch of triangles that lies in one primitive of each file:
/// `len` triangles from a's part `ka` triangle `ta` and b's part `kb`
/// triangle `tb`.
struct Run {
    ka: usize,
    ta: usize,
    kb: usize,
    tb: usize,
    len: usize,
}

/// The runs that pair a's concatenated triangles with b's (equal totals).
fn runs(pa: &[Part], pb: &[Part]) -> Vec<Run> {
    let mut out = Vec::new();
    let (mut ka, mut ta, mut kb, mut tb) = (0, 0, 0, 0);
    while ka < pa.len() && kb < pb.len() {
        let (la, lb) = (pa[ka].geo.triangles.len(), pb[kb].geo.triangles.len());
        let len = (la - ta).min(lb - tb);
        if len > 0 {
            out.push(Run {
                ka,
                ta,
                kb,
                tb,
                len,
            });
        }
        ta += len;
        tb += len;
        if ta == la {
            ka += 1;
            ta = 0;
        }
        if tb == lb {
            kb += 1;
            tb = 0;
        }
    }
    out
}

/// The values of vertex `v` of a column; None out of range.
fn vertex<'a>(col: &Column<'a>, v: u32) -> Option<&'a [f32]> {
    let c = col.components;
    col.data.get(v as usize * c..(v as usize + 1) * c)
}

/// Compare the concatenated triangles of a and b corner by corner on every
/// attribute of a (position and morph targets included).
fn compare_corners(pa: &[Part], pb: &[Part], place: &str, d: &mut Differences) {
    let cols: Vec<Vec<Column>> = pa.iter().map(|p| columns(&p.geo)).collect();
    let scales: Vec<Vec<f64>> = cols
        .iter()
        .map(|c| {
            c.iter()
                .map(|x| scale_of(x.data.iter().map(|&v| f64::from(v))))
                .collect()
        })
        .collect();
    let mut tallies: Vec<Vec<Tally>> = cols
        .iter()
        .map(|c| c.iter().map(|_| Tally::default()).collect())
        .collect();
    let mut offsets = vec![0; pa.len()];
    for k in 1..pa.len() {
        offsets[k] = offsets[k - 1] + pa[k - 1].geo.triangles.len();
    }
    for r in runs(pa, pb) {
        let (x, y) = (&pa[r.ka], &pb[r.kb]);
        let pplace = format!("{place} primitive {}", x.index);
        d.ne(
            "morph_targets",
            &pplace,
            "morph targets",
            x.geo.targets.len(),
            y.geo.targets.len(),
        );
        let cb = columns(&y.geo);
        for (ci, col) in cols[r.ka].iter().enumerate() {
            let other = match cb.iter().find(|c| c.name == col.name) {
                None => {
                    let detail = format!("{} missing in b primitive {}", col.name, y.index);
                    d.push("attributes", pplace.clone(), detail);
                    continue;
                }
                Some(c) if c.components != col.components => {
                    let detail = format!(
                        "{} has {} components vs {} in b primitive {}",
                        col.name, col.components, c.components, y.index
                    );
                    d.push("attribute_components", pplace.clone(), detail);
                    continue;
                }
                Some(c) => c,
            };
            let lim = d.tol * scales[r.ka][ci];
            let tally = &mut tallies[r.ka][ci];
            for i in 0..r.len {
                let (t, u) = (x.geo.triangles[r.ta + i], y.geo.triangles[r.tb + i]);
                let mut off = false;
                for k in 0..3 {
                    let w = match (vertex(col, t[k]), vertex(other, u[k])) {
                        (Some(p), Some(q)) => worst_delta(p, q),
                        _ => f64::INFINITY,
                    };
                    if w > lim {
                        off = true;
                        tally.corners += 1;
                        tally.worst = tally.worst.max(w);
                        tally.first.get_or_insert(Corner {
                            triangle: r.ta + i,
                            mesh_triangle: offsets[r.ka] + r.ta + i,
                            corner: k,
                            vertex_a: t[k] as usize,
                            primitive_b: y.index,
                            vertex_b: u[k] as usize,
                        });
                    }
                }
                tally.triangles += usize::from(off);
            }
        }
    }
    for ((x, c), (s, t)) in pa.iter().zip(&cols).zip(scales.iter().zip(&tallies)) {
        for ((col, &scale), tally) in c.iter().zip(s).zip(t) {
            report_tally(x, col, scale, tally, place, d);
        }
    }
}

/// One difference for an attribute of a's primitive `x` whose corners differ.
fn report_tally(
    x: &Part,
    col: &Column,
    scale: f64,
    tally: &Tally,
    place: &str,
    d: &mut Differences,
) {
    let Some(f) = &tally.first else {
        return;
    };
    let detail = format!(
        "{} differs at {} corners of {} of {} triangles by up to {} ({}); first at triangle {} (mesh triangle {}) corner {}: vertex {} of a vs vertex {} of b primitive {}",
        col.name,
        tally.corners,
        tally.triangles,
        x.geo.triangles.len(),
        amount(tally.worst),
        d.tol_text(scale),
        f.triangle,
        f.mesh_triangle,
        f.corner,
        f.vertex_a,
        f.vertex_b,
        f.primitive_b,
    );
    d.push(
        "attribute_values",
        format!("{place} primitive {}", x.index),
        detail,
    );
}
