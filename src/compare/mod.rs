//! Compare two assets (`crackle diff`) (glTF, GLB or OBJ) structurally and
//! geometrically, e.g. a run's output against a golden file.
//!
//! What is compared:
//! - structure: scenes and their root nodes; node count, names, children
//!   lists, meshes and local transforms; mesh count, names, primitive count;
//!   per primitive its kind (triangles or raw mode), material (by name),
//!   attribute semantics and morph target count; material count and names;
//!   texture, image, sampler, camera, skin and animation counts;
//! - geometry of triangle primitives: vertex and triangle counts, then every
//!   vertex attribute (POSITION, the others, morph target displacements);
//! - raw LINES primitives (the crack network): segment count and total length.
//!
//! **Tolerance.** Two values `x` (file a) and `y` (file b) of one attribute
//! agree when `|x - y| <= tolerance * s`, where `s` is the larger of 1 and the
//! largest absolute value of that attribute (all its components, all
//! vertices of that primitive) in file a. So the tolerance is absolute for
//! attributes in [-1, 1] (normals, UVs, colours) and relative for large
//! coordinates. Crack lengths and node transforms use the same rule (`s` =
//! max(1, length in a), max(1, largest matrix entry in a)).
//!
//! **Vertex order.** Vertices are first compared in order. When that fails
//! but the vertex counts match, vertices are matched by a canonical order:
//! each vertex's values (position first, then the other attributes) are
//! quantised to cells of `tolerance * s`; vertices with equal quantised
//! values are the same vertex. Vertices that are identical in every attribute
//! (as crack splits make them) are told apart by their triangles (colour
//! refinement on the triangle mesh), and triangles are compared as multisets
//! of index triples up to rotation (orientation is kept) after the matching.
//! Files equal up to vertex order (and triangle order and rotation) are thus
//! equivalent. Quantisation can separate two values that are within the
//! tolerance but fall on either side of a cell boundary: in-order comparison
//! has no such limit, and reordered files that differ by noise close to the
//! tolerance can be reported as differing.
//!
//! **Geometry mode** ([`Mode::Geometry`], `crackle diff --geometry`): "b is
//! a's own mesh", i.e. an output kept the input's triangles, vertex
//! positions, indices and attributes, whatever crackle added on top.
//! - Per mesh (matched by index; mesh counts and names must match), the
//!   triangle primitives in order are taken, leaving out every primitive
//!   that is not triangles (LINES, POINTS...) in both files and, in b, those
//!   whose material is named `crack_wall`. Their triangles are concatenated
//!   (each primitive's triangles in order); skinned and other passed-through
//!   triangle primitives are decoded from their accessors (strips and fans
//!   as glTF assembles them).
//! - Triangle counts per mesh must match. Triangle `t` of a and triangle `t`
//!   of b are compared corner by corner in the same corner order (a rotated
//!   triangle differs): the position and every attribute a's primitive has
//!   (same semantic, same component count; missing in b is a difference),
//!   morph target displacements included, within the tolerance above (`s`
//!   from a's primitive). Attributes only b has (`_CRACK_DISTANCE`,
//!   `_CRACK_TIME`, `TANGENT`, a new `TEXCOORD_n`...) are ignored.
//! - Indices: per primitive (a's k-th triangle primitive against b's), whether
//!   b's triangles have the same indices as a's, and per mesh how many
//!   vertices b has beyond a's (split vertices: a new UV set for baked maps
//!   duplicates vertices on its seams) or fewer (merged). Neither is a
//!   difference unless `same_indices` (`--same-indices`) is asked for; both
//!   are in the summary ([`IndexSummary`]).
//! - Still compared: scenes and their root nodes, node names, children,
//!   meshes, local transforms and skin index, the skin, camera and animation
//!   counts, and the number of morph targets of each pair of primitives that
//!   share triangles. Not compared: materials, textures, images, samplers,
//!   left-out primitives, primitive counts and b's extra attributes.

use crate::scene::{mode, Geometry, Primitive, Scene};
use crate::{Error, Result};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

mod geometry;
mod same_mesh;
use geometry::*;
pub use same_mesh::{IndexSummary, MeshIndices, PrimitiveIndices};

/// Most differences listed in the text output.
const MAX_LINES: usize = 20;

/// What [`compare_with`] looks at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// Everything: structure, appearance, every primitive (`crackle diff`).
    #[default]
    Full,
    /// "B is A's own mesh" (`crackle diff --geometry`): the triangles of
    /// each mesh corner by corner, nodes, skins and morph target counts;
    /// not materials, textures, images, samplers, added primitives or added
    /// attributes (see the module documentation).
    Geometry {
        /// Any change of a primitive's indices or vertex count is a
        /// difference (`--same-indices`).
        same_indices: bool,
    },
}

/// The comparison of two scenes.
pub struct Comparison {
    /// The tolerance used.
    pub tolerance: f64,
    /// Every difference found, in the order found.
    pub differences: Vec<Difference>,
    /// With [`Mode::Geometry`]: vertex counts and how many triangles kept
    /// their indices.
    pub indices: Option<IndexSummary>,
    /// Whether `--same-indices` was asked for.
    same_indices: bool,
    a: Totals,
    b: Totals,
}

impl Comparison {
    /// Whether no difference was found.
    pub fn equivalent(&self) -> bool {
        self.differences.is_empty()
    }

    /// The comparison as one JSON object; `a` and `b` name the files.
    /// With [`Mode::Geometry`] it also has `"mode": "geometry"`,
    /// `"same_indices"` and `summary.geometry` ([`IndexSummary::json`]).
    pub fn to_json(&self, a: &Path, b: &Path) -> Value {
        let mut v = json!({
            "equivalent": self.equivalent(),
            "tolerance": self.tolerance,
            "a": a.display().to_string(),
            "b": b.display().to_string(),
            "differences": self.differences.iter().map(|x| json!({
                "kind": x.kind,
                "where": x.place,
                "detail": x.detail,
            })).collect::<Vec<_>>(),
            "summary": {"a": self.a.json(), "b": self.b.json()},
        });
        if let Some(ix) = &self.indices {
            v["mode"] = json!("geometry");
            v["same_indices"] = json!(self.same_indices);
            v["summary"]["geometry"] = ix.json();
        }
        v
    }

    /// The comparison as text: the verdict, at most 20 differences, and a
    /// summary line per file (with [`Mode::Geometry`] first a `geometry:`
    /// line of vertex counts and kept indices).
    pub fn to_text(&self, a: &Path, b: &Path) -> String {
        let tol = self.tolerance;
        let what = match (&self.indices, self.same_indices) {
            (None, _) => String::new(),
            (Some(_), false) => "geometry; ".into(),
            (Some(_), true) => "geometry, same indices; ".into(),
        };
        let mut s = String::new();
        if self.equivalent() {
            let _ = writeln!(s, "equivalent ({what}tolerance {tol:e})");
        } else {
            let n = self.differences.len();
            let _ = writeln!(
                s,
                "differ: {n} difference{} ({what}tolerance {tol:e})",
                if n == 1 { "" } else { "s" }
            );
            for x in self.differences.iter().take(MAX_LINES) {
                let _ = writeln!(s, "  {}: {}", x.place, x.detail);
            }
            if n > MAX_LINES {
                let _ = writeln!(s, "  ... and {} more", n - MAX_LINES);
            }
        }
        if let Some(ix) = &self.indices {
            let _ = writeln!(s, "geometry: {}", ix.line());
        }
        let _ = writeln!(s, "a: {}", self.a.line(a));
        let _ = writeln!(s, "b: {}", self.b.line(b));
        s
    }
}

/// Compare scene `b` with scene `a` (the reference: tolerances scale with
/// its values).
pub fn compare(sa: &Scene, sb: &Scene, tolerance: f64) -> Comparison {
    compare_with(sa, sb, tolerance, Mode::Full)
}

/// [`compare`] looking at what `mode` says.
pub fn compare_with(sa: &Scene, sb: &Scene, tolerance: f64, mode: Mode) -> Comparison {
    let mut d = Differences {
        tol: tolerance,
        list: Vec::new(),
    };
    let (indices, same_indices) = match mode {
        Mode::Full => {
            compare_structure(sa, sb, &mut d);
            (None, false)
        }
        Mode::Geometry { same_indices } => (
            Some(same_mesh::compare_same_mesh(sa, sb, same_indices, &mut d)),
            same_indices,
        ),
    };
    Comparison {
        tolerance,
        differences: d.list,
        indices,
        same_indices,
        a: Totals::of(sa),
        b: Totals::of(sb),
    }
}

/// Read and compare two files.
///
/// # Errors
/// [`Error::Usage`] ([`UsageError::Tolerance`](crate::error::UsageError::Tolerance))
/// for a tolerance that is not a finite number >= 0, and
/// an unreadable file (the message names it).
pub fn compare_files(
    a: &Path,
    b: &Path,
    tolerance: f64,
    options: &crate::io::ReadOptions,
) -> Result<Comparison> {
    compare_files_with(a, b, tolerance, Mode::Full, options)
}

/// [`compare_files`] looking at what `mode` says.
///
/// # Errors
/// Those of [`compare_files`].
pub fn compare_files_with(
    a: &Path,
    b: &Path,
    tolerance: f64,
    mode: Mode,
    options: &crate::io::ReadOptions,
) -> Result<Comparison> {
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(crate::error::UsageError::Tolerance { tolerance }.into());
    }
    let sa = read(a, options)?;
    let sb = read(b, options)?;
    Ok(compare_with(&sa, &sb, tolerance, mode))
}

/// Read an asset; the error names the file.
fn read(path: &Path, options: &crate::io::ReadOptions) -> Result<Scene> {
    crate::io::read_with(path, options).map_err(|e| {
        if e.to_string().contains(&path.display().to_string()) {
            Error::File(e)
        } else {
            Error::File(crate::io::IoError::Asset {
                path: path.to_path_buf(),
                error: Box::new(e),
            })
        }
    })
}

/// One difference: what kind, where, and what.
pub struct Difference {
    /// The kind (`node`, `mesh`, `geometry`...).
    pub kind: &'static str,
    /// Where: the node, mesh, primitive or attribute.
    pub place: String,
    /// What differs, with both values.
    pub detail: String,
}

/// The differences found so far.
struct Differences {
    tol: f64,
    list: Vec<Difference>,
}

impl Differences {
    fn push(&mut self, kind: &'static str, place: impl Into<String>, detail: String) {
        self.list.push(Difference {
            kind,
            place: place.into(),
            detail,
        });
    }

    /// Push `kind` when the two values differ (`what`: "a vs b" detail prefix).
    fn ne<T: PartialEq + std::fmt::Display>(
        &mut self,
        kind: &'static str,
        place: &str,
        what: &str,
        a: T,
        b: T,
    ) {
        if a != b {
            self.push(kind, place, format!("{what} {a} vs {b}"));
        }
    }

    /// The tolerance text for scale `s`.
    fn tol_text(&self, s: f64) -> String {
        if s > 1.0 {
            format!("tolerance {:e} scaled by {}", self.tol, short(s))
        } else {
            format!("tolerance {:e}", self.tol)
        }
    }
}

/// A difference: 3 decimals from 0.1 on, else 2 significant digits.
fn amount(x: f64) -> String {
    if x == 0.0 || x.is_infinite() {
        format!("{x}")
    } else if (0.1..1e5).contains(&x.abs()) {
        let s = format!("{x:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{x:.1e}")
    }
}

/// A number in a few significant digits.
fn short(x: f64) -> String {
    if x == 0.0 || (1e-3..1e5).contains(&x.abs()) {
        let s = format!("{x:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{x:.3e}")
    }
}

fn quoted(name: Option<&str>) -> String {
    match name {
        Some(n) => format!(" '{n}'"),
        None => String::new(),
    }
}

fn node_place(s: &Scene, i: usize) -> String {
    format!("node {i}{}", quoted(s.nodes[i].name.as_deref()))
}

fn mesh_place(s: &Scene, i: usize) -> String {
    format!("mesh {i}{}", quoted(s.meshes[i].name.as_deref()))
}

fn opt_name(n: Option<&str>) -> String {
    match n {
        Some(n) => format!("'{n}'"),
        None => "(unnamed)".into(),
    }
}

fn list(v: &[usize]) -> String {
    format!(
        "[{}]",
        v.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// The name a primitive's material is compared by.
fn material_label(s: &Scene, m: Option<usize>) -> String {
    match m {
        None => "none".into(),
        Some(i) => match s.materials.get(i).and_then(|m| m.name()) {
            Some(n) => format!("'{n}'"),
            None => format!("#{i} (unnamed)"),
        },
    }
}

fn kind_label(g: &Geometry) -> String {
    match g {
        Geometry::Triangles(_) => "triangles".into(),
        Geometry::Raw(r) => match r.mode {
            mode::POINTS => "points".into(),
            mode::LINES => "lines".into(),
            mode::LINE_LOOP => "line loop".into(),
            mode::LINE_STRIP => "line strip".into(),
            mode::TRIANGLES => "raw triangles".into(),
            mode::TRIANGLE_STRIP => "triangle strip".into(),
            mode::TRIANGLE_FAN => "triangle fan".into(),
            m => format!("mode {m}"),
        },
    }
}

/// Attribute semantics of a primitive, sorted.
fn semantics(g: &Geometry) -> Vec<String> {
    let mut v: Vec<String> = match g {
        Geometry::Triangles(t) => std::iter::once("POSITION".to_string())
            .chain(t.attributes.iter().map(|a| a.semantic.clone()))
            .collect(),
        Geometry::Raw(r) => r.attributes.keys().cloned().collect(),
    };
    v.sort();
    v
}

fn target_count(g: &Geometry) -> usize {
    match g {
        Geometry::Triangles(t) => t.targets.len(),
        Geometry::Raw(r) => r.targets.len(),
    }
}

/// Largest absolute finite value, at least 1.
fn scale_of(values: impl Iterator<Item = f64>) -> f64 {
    values
        .filter(|x| x.is_finite())
        .fold(1.0_f64, |m, x| m.max(x.abs()))
}

/// |x - y|, 0 for equal values (also infinities and two NaNs), infinite when only one is NaN.
fn delta(x: f64, y: f64) -> f64 {
    if x == y || (x.is_nan() && y.is_nan()) {
        0.0
    } else {
        let d = (x - y).abs();
        if d.is_nan() {
            f64::INFINITY
        } else {
            d
        }
    }
}

// ---------------------------------------------------------------- structure

/// Compare everything; primitives' geometry right after their structure.
fn compare_structure(a: &Scene, b: &Scene, d: &mut Differences) {
    compare_nodes(a, b, d);
    compare_meshes(a, b, d);
    compare_counts(a, b, d, true);
}

/// Scenes and their root nodes; nodes' names, children, meshes and transforms.
fn compare_nodes(a: &Scene, b: &Scene, d: &mut Differences) {
    // Scenes and their roots.
    d.ne(
        "scene_count",
        "scenes",
        "count",
        a.scenes.len(),
        b.scenes.len(),
    );
    let default = |s: &Scene| s.default_scene.map_or("none".into(), |i| i.to_string());
    d.ne("scenes", "scenes", "default scene", default(a), default(b));
    for (i, (x, y)) in a.scenes.iter().zip(&b.scenes).enumerate() {
        d.ne(
            "scenes",
            &format!("scene {i}"),
            "root nodes",
            list(&x.nodes),
            list(&y.nodes),
        );
    }

    // Nodes: names, hierarchy, meshes, transforms.
    d.ne("node_count", "nodes", "count", a.nodes.len(), b.nodes.len());
    for (i, (x, y)) in a.nodes.iter().zip(&b.nodes).enumerate() {
        let place = node_place(a, i);
        d.ne(
            "node_name",
            &place,
            "name",
            opt_name(x.name.as_deref()),
            opt_name(y.name.as_deref()),
        );
        d.ne(
            "node_children",
            &place,
            "children",
            list(&x.children),
            list(&y.children),
        );
        let mesh = |s: &Scene, m: Option<usize>| match m {
            None => "none".to_string(),
            Some(m) => format!(
                "{m}{}",
                quoted(s.meshes.get(m).and_then(|m| m.name.as_deref()))
            ),
        };
        d.ne(
            "node_mesh",
            &place,
            "mesh",
            mesh(a, x.mesh),
            mesh(b, y.mesh),
        );
        let (ma, mb) = (x.transform.matrix(), y.transform.matrix());
        let s = scale_of(ma.iter().copied());
        let worst = ma
            .iter()
            .zip(&mb)
            .map(|(&p, &q)| delta(p, q))
            .fold(0.0, f64::max);
        if worst > d.tol * s {
            let detail = format!(
                "transform differs by up to {} ({})",
                amount(worst),
                d.tol_text(s)
            );
            d.push("node_transform", place, detail);
        }
    }
}

/// The mesh count, compared.
fn compare_mesh_count(a: &Scene, b: &Scene, d: &mut Differences) {
    d.ne(
        "mesh_count",
        "meshes",
        "count",
        a.meshes.len(),
        b.meshes.len(),
    );
}

/// The names of mesh `i` of both files, compared.
fn compare_mesh_name(a: &Scene, b: &Scene, i: usize, d: &mut Differences) {
    d.ne(
        "mesh_name",
        &mesh_place(a, i),
        "name",
        opt_name(a.meshes[i].name.as_deref()),
        opt_name(b.meshes[i].name.as_deref()),
    );
}

/// Meshes: names, primitives and their material, attributes, targets.
fn compare_meshes(a: &Scene, b: &Scene, d: &mut Differences) {
    compare_mesh_count(a, b, d);
    for (i, (x, y)) in a.meshes.iter().zip(&b.meshes).enumerate() {
        let place = mesh_place(a, i);
        compare_mesh_name(a, b, i, d);
        d.ne(
            "primitive_count",
            &place,
            "primitives",
            x.primitives.len(),
            y.primitives.len(),
        );
        for (j, (p, q)) in x.primitives.iter().zip(&y.primitives).enumerate() {
            let place = format!("{place} primitive {j}");
            d.ne(
                "primitive_kind",
                &place,
                "kind",
                kind_label(&p.geometry),
                kind_label(&q.geometry),
            );
            d.ne(
                "primitive_material",
                &place,
                "material",
                material_label(a, p.material),
                material_label(b, q.material),
            );
            let (sp, sq) = (semantics(&p.geometry), semantics(&q.geometry));
            if sp != sq {
                let only = |u: &[String], v: &[String]| {
                    u.iter()
                        .filter(|s| !v.contains(s))
                        .cloned()
                        .collect::<Vec<_>>()
                        .join(", ")
                };
                let (oa, ob) = (only(&sp, &sq), only(&sq, &sp));
                let mut detail = String::from("attributes differ:");
                if !oa.is_empty() {
                    detail.push_str(&format!(" only in a: {oa};"));
                }
                if !ob.is_empty() {
                    detail.push_str(&format!(" only in b: {ob};"));
                }
                detail.pop();
                d.push("attributes", place.clone(), detail);
            }
            d.ne(
                "morph_targets",
                &place,
                "morph targets",
                target_count(&p.geometry),
                target_count(&q.geometry),
            );
            match (&p.geometry, &q.geometry) {
                (Geometry::Triangles(t), Geometry::Triangles(u)) => {
                    compare_triangles(t, u, &place, d)
                }
                (Geometry::Raw(r), Geometry::Raw(s)) if r.mode == s.mode => {
                    compare_raw(a, r, b, s, &place, d)
                }
                _ => {} // the kinds differ (reported above)
            }
        }
    }
}

/// Materials (count and names), images, textures and samplers (with
/// `appearance`), cameras, skins and animations, by count.
fn compare_counts(a: &Scene, b: &Scene, d: &mut Differences, appearance: bool) {
    if appearance {
        compare_appearance(a, b, d);
    }
    let counts = [
        ("cameras", a.cameras.len(), b.cameras.len()),
        ("skins", a.skins.len(), b.skins.len()),
        ("animations", a.animations.len(), b.animations.len()),
    ];
    for (what, x, y) in counts {
        d.ne("count", what, "count", x, y);
    }
}

/// Materials by count and name; images, textures and samplers by count.
fn compare_appearance(a: &Scene, b: &Scene, d: &mut Differences) {
    d.ne(
        "material_count",
        "materials",
        "count",
        a.materials.len(),
        b.materials.len(),
    );
    for (i, (x, y)) in a.materials.iter().zip(&b.materials).enumerate() {
        d.ne(
            "material_name",
            &format!("material {i}"),
            "name",
            opt_name(x.name()),
            opt_name(y.name()),
        );
    }
    d.ne(
        "image_count",
        "images",
        "count",
        a.images.len(),
        b.images.len(),
    );
    let counts = [
        ("textures", a.textures.len(), b.textures.len()),
        ("samplers", a.samplers.len(), b.samplers.len()),
    ];
    for (what, x, y) in counts {
        d.ne("count", what, "count", x, y);
    }
}

// ----------------------------------------------------------------- geometry

// ---------------------------------------------------------------------- raw

// ------------------------------------------------------------------- totals

/// Counts of one file for the summary.
struct Totals {
    nodes: usize,
    meshes: usize,
    primitives: usize,
    materials: usize,
    images: usize,
    vertices: usize,
    triangles: usize,
    crack_segments: usize,
    crack_length: f64,
}

fn is_crack_lines(s: &Scene, p: &Primitive) -> bool {
    matches!(&p.geometry, Geometry::Raw(r) if r.mode == mode::LINES)
        && p.material
            .and_then(|m| s.materials.get(m))
            .and_then(|m| m.name())
            == Some("crack_lines")
}

impl Totals {
    fn of(s: &Scene) -> Totals {
        let prims = || s.meshes.iter().flat_map(|m| &m.primitives);
        let (mut vertices, mut crack_segments, mut crack_length) = (0, 0, 0.0);
        for p in prims() {
            match &p.geometry {
                Geometry::Triangles(t) => vertices += t.positions.len(),
                Geometry::Raw(r) if is_crack_lines(s, p) => {
                    if let Some((n, l)) = line_stats(s, r) {
                        crack_segments += n;
                        crack_length += l;
                    }
                }
                Geometry::Raw(_) => {}
            }
        }
        Totals {
            nodes: s.nodes.len(),
            meshes: s.meshes.len(),
            primitives: prims().count(),
            materials: s.materials.len(),
            images: s.images.len(),
            vertices,
            triangles: s.triangle_count(),
            crack_segments,
            crack_length,
        }
    }

    fn json(&self) -> Value {
        json!({
            "nodes": self.nodes,
            "meshes": self.meshes,
            "primitives": self.primitives,
            "materials": self.materials,
            "images": self.images,
            "vertices": self.vertices,
            "triangles": self.triangles,
            "crack_segments": self.crack_segments,
            "crack_length": self.crack_length,
        })
    }

    fn line(&self, path: &Path) -> String {
        format!(
            "{}: {} triangles, {} crack segments, crack length {} ({} nodes, {} meshes, {} primitives, {} materials, {} images, {} vertices)",
            path.display(),
            self.triangles,
            self.crack_segments,
            short(self.crack_length),
            self.nodes,
            self.meshes,
            self.primitives,
            self.materials,
            self.images,
            self.vertices
        )
    }
}
