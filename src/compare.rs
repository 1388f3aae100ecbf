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

use crate::io::accessor::decode_raw as decode;
use crate::scene::{mode, Geometry, Primitive, RawGeometry, Scene, TriGeometry};
use crate::{Error, Result};
use serde_json::{json, Value};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

/// Most differences listed in the text output.
const MAX_LINES: usize = 20;

/// The comparison of two scenes.
pub struct Comparison {
    /// The tolerance used.
    pub tolerance: f64,
    /// Every difference found, in the order found.
    pub differences: Vec<Difference>,
    a: Totals,
    b: Totals,
}

impl Comparison {
    /// Whether no difference was found.
    pub fn equivalent(&self) -> bool {
        self.differences.is_empty()
    }

    /// The comparison as one JSON object; `a` and `b` name the files.
    pub fn to_json(&self, a: &Path, b: &Path) -> Value {
        json!({
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
        })
    }

    /// The comparison as text: the verdict, at most 20 differences, and a
    /// summary line per file.
    pub fn to_text(&self, a: &Path, b: &Path) -> String {
        let tol = self.tolerance;
        let mut s = String::new();
        if self.equivalent() {
            let _ = writeln!(s, "equivalent (tolerance {tol:e})");
        } else {
            let n = self.differences.len();
            let _ = writeln!(
                s,
                "differ: {n} difference{} (tolerance {tol:e})",
                if n == 1 { "" } else { "s" }
            );
            for x in self.differences.iter().take(MAX_LINES) {
                let _ = writeln!(s, "  {}: {}", x.place, x.detail);
            }
            if n > MAX_LINES {
                let _ = writeln!(s, "  ... and {} more", n - MAX_LINES);
            }
        }
        let _ = writeln!(s, "a: {}", self.a.line(a));
        let _ = writeln!(s, "b: {}", self.b.line(b));
        s
    }
}

/// Compare scene `b` with scene `a` (the reference: tolerances scale with
/// its values).
pub fn compare(sa: &Scene, sb: &Scene, tolerance: f64) -> Comparison {
    let mut d = Differences {
        tol: tolerance,
        list: Vec::new(),
    };
    compare_structure(sa, sb, &mut d);
    Comparison {
        tolerance,
        differences: d.list,
        a: Totals::of(sa),
        b: Totals::of(sb),
    }
}

/// Read and compare two files.
///
/// # Errors
/// [`Error::Usage`] for a tolerance that is not a finite number >= 0, and
/// an unreadable file (the message names it).
pub fn compare_files(a: &Path, b: &Path, tolerance: f64) -> Result<Comparison> {
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(Error::Usage(format!(
            "--tolerance {tolerance} must be a finite number >= 0"
        )));
    }
    let sa = read(a)?;
    let sb = read(b)?;
    Ok(compare(&sa, &sb, tolerance))
}

/// Read an asset; the error names the file.
fn read(path: &Path) -> Result<Scene> {
    crate::io::read(path).map_err(|e| {
        let msg = e.to_string();
        if msg.contains(&path.display().to_string()) {
            e
        } else {
            Error::input(path, msg)
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

    // Meshes: names, primitives and their material, attributes, targets.
    d.ne(
        "mesh_count",
        "meshes",
        "count",
        a.meshes.len(),
        b.meshes.len(),
    );
    for (i, (x, y)) in a.meshes.iter().zip(&b.meshes).enumerate() {
        let place = mesh_place(a, i);
        d.ne(
            "mesh_name",
            &place,
            "name",
            opt_name(x.name.as_deref()),
            opt_name(y.name.as_deref()),
        );
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

    // Materials and the rest, by count (materials also by name).
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
        ("cameras", a.cameras.len(), b.cameras.len()),
        ("skins", a.skins.len(), b.skins.len()),
        ("animations", a.animations.len(), b.animations.len()),
    ];
    for (what, x, y) in counts {
        d.ne("count", what, "count", x, y);
    }
}

// ----------------------------------------------------------------- geometry

/// One per-vertex attribute of a triangle primitive, flat.
struct Column<'a> {
    name: String,
    components: usize,
    data: &'a [f32],
}

fn columns(t: &TriGeometry) -> Vec<Column<'_>> {
    let mut v = vec![Column {
        name: "POSITION".into(),
        components: 3,
        data: t.positions.as_flattened(),
    }];
    for a in &t.attributes {
        v.push(Column {
            name: a.semantic.clone(),
            components: a.components,
            data: &a.data,
        });
    }
    for (k, target) in t.targets.iter().enumerate() {
        for a in target {
            v.push(Column {
                name: format!("morph target {k} {}", a.semantic),
                components: a.components,
                data: &a.data,
            });
        }
    }
    v
}

/// A pair of columns to compare, with the scale of a's values.
struct Pair<'a> {
    a: &'a Column<'a>,
    b: &'a Column<'a>,
    scale: f64,
}

/// Per column: vertices that differ and the largest difference, plus the
/// triangles of a with no counterpart in b (None: triangle counts differ).
struct Eval {
    differing: Vec<(usize, f64)>,
    triangles_off: Option<usize>,
}

impl Eval {
    fn vertices_off(&self) -> usize {
        self.differing.iter().map(|x| x.0).sum()
    }
    fn clean(&self) -> bool {
        self.vertices_off() == 0 && self.triangles_off.unwrap_or(0) == 0
    }
    fn badness(&self) -> (usize, usize) {
        (self.vertices_off(), self.triangles_off.unwrap_or(0))
    }
}

fn compare_triangles(t: &TriGeometry, u: &TriGeometry, place: &str, d: &mut Differences) {
    let (n, m) = (t.positions.len(), u.positions.len());
    let (nt, mt) = (t.triangles.len(), u.triangles.len());
    d.ne("vertex_count", place, "vertices", n, m);
    d.ne("triangle_count", place, "triangles", nt, mt);
    let (ca, cb) = (columns(t), columns(u));
    // Columns present in both with the same size; target columns missing on
    // one side are reported here (plain attributes are by the structure).
    let mut pairs = Vec::new();
    for x in &ca {
        match cb.iter().find(|y| y.name == x.name) {
            Some(y) if x.components != y.components => d.push(
                "attribute_components",
                place,
                format!(
                    "{} has {} components vs {}",
                    x.name, x.components, y.components
                ),
            ),
            Some(y) if x.data.len() == n * x.components && y.data.len() == m * y.components => {
                let scale = scale_of(x.data.iter().map(|&v| f64::from(v)));
                pairs.push(Pair { a: x, b: y, scale });
            }
            Some(_) => {} // malformed lengths: the reader does not make these
            None if x.name.starts_with("morph target") => {
                d.push("attributes", place, format!("{} only in a", x.name))
            }
            None => {}
        }
    }
    for y in &cb {
        if y.name.starts_with("morph target") && !ca.iter().any(|x| x.name == y.name) {
            d.push("attributes", place, format!("{} only in b", y.name));
        }
    }
    if n != m {
        return;
    }
    let same_tris = nt == mt;

    // In order.
    let identity: Vec<usize> = (0..n).collect();
    let in_order = evaluate(
        &pairs,
        &identity,
        same_tris.then(|| tris_off_paired(t, u, &identity)),
        d.tol,
    );
    if in_order.clean() {
        return;
    }

    // Up to vertex order.
    let (ka, kb) = (keys(&pairs, n, d.tol, true), keys(&pairs, n, d.tol, false));
    let stride: usize = pairs.iter().map(|p| p.a.components).sum();
    let mut class: HashMap<&[i64], u32> = HashMap::new();
    let mut cla = Vec::with_capacity(n);
    let mut clb = Vec::with_capacity(n);
    for (keys, out) in [(&ka, &mut cla), (&kb, &mut clb)] {
        for i in 0..n {
            let next = class.len() as u32;
            out.push(
                *class
                    .entry(&keys[i * stride..(i + 1) * stride])
                    .or_insert(next),
            );
        }
    }
    let classes = class.len();
    let mut hist = vec![0i64; classes];
    for &c in &cla {
        hist[c as usize] += 1;
    }
    for &c in &clb {
        hist[c as usize] -= 1;
    }
    let matched = hist.iter().all(|&h| h == 0);
    let reordered = if matched {
        // Every vertex of b has its own counterpart in a: tell identical
        // vertices apart by their triangles, compare triangles by colours.
        let (ra, rb) = if same_tris && classes < n {
            refine(cla, &t.triangles, clb, &u.triangles)
        } else {
            (cla, clb)
        };
        let pairing = pair_vertices(&ra, &rb, &ka, &kb, stride);
        let off = same_tris.then(|| {
            multiset_off(
                canonical(&t.triangles, |i| ra[i as usize]),
                canonical(&u.triangles, |i| rb[i as usize]),
            )
        });
        evaluate(&pairs, &pairing, off, d.tol)
    } else {
        // Some vertices moved: pair the others by their values, the moved
        // ones by their order, to say how much they moved.
        let pairing = pair_vertices(&cla, &clb, &ka, &kb, stride);
        let off = same_tris.then(|| tris_off_paired(t, u, &pairing));
        evaluate(&pairs, &pairing, off, d.tol)
    };
    let (e, note) = if reordered.badness() < in_order.badness() {
        (reordered, " (vertices matched up to order)")
    } else {
        (in_order, "")
    };
    for (p, &(count, worst)) in pairs.iter().zip(&e.differing) {
        if count > 0 {
            d.push(
                "attribute_values",
                place,
                format!(
                    "{count} of {n} vertices differ in {} by up to {} ({}){note}",
                    p.a.name,
                    amount(worst),
                    d.tol_text(p.scale)
                ),
            );
        }
    }
    if let Some(off) = e.triangles_off.filter(|&o| o > 0) {
        d.push(
            "triangles",
            place,
            format!("{off} of {nt} triangles differ in their vertices{note}"),
        );
    }
}

/// Compare the columns with a's vertex `i` paired to b's vertex `pairing[i]`.
fn evaluate(pairs: &[Pair], pairing: &[usize], triangles_off: Option<usize>, tol: f64) -> Eval {
    let differing = pairs
        .iter()
        .map(|p| {
            let c = p.a.components;
            let lim = tol * p.scale;
            let (mut count, mut worst) = (0, 0.0_f64);
            for (i, &j) in pairing.iter().enumerate() {
                let x = &p.a.data[i * c..(i + 1) * c];
                let y = &p.b.data[j * c..(j + 1) * c];
                let w = x
                    .iter()
                    .zip(y)
                    .map(|(&x, &y)| delta(f64::from(x), f64::from(y)))
                    .fold(0.0, f64::max);
                if w > lim {
                    count += 1;
                }
                worst = worst.max(w);
            }
            (count, if count > 0 { worst } else { 0.0 })
        })
        .collect();
    Eval {
        differing,
        triangles_off,
    }
}

/// Quantised values of every vertex (`stride` per vertex), position first.
/// Cells are `tol * scale` wide (scale of file a); with tolerance 0 the exact
/// values are used.
fn keys(pairs: &[Pair], n: usize, tol: f64, side_a: bool) -> Vec<i64> {
    let stride: usize = pairs.iter().map(|p| p.a.components).sum();
    let mut out = Vec::with_capacity(n * stride);
    for i in 0..n {
        for p in pairs {
            let col = if side_a { p.a } else { p.b };
            let c = col.components;
            let cell = tol * p.scale;
            for &v in &col.data[i * c..(i + 1) * c] {
                out.push(quantise(f64::from(v), cell));
            }
        }
    }
    out
}

fn quantise(v: f64, cell: f64) -> i64 {
    if v.is_nan() {
        i64::MAX
    } else if v.is_infinite() {
        if v > 0.0 {
            i64::MAX - 1
        } else {
            i64::MIN + 1
        }
    } else if cell > 0.0 {
        // Saturates for values beyond i64 cells.
        (v / cell).round() as i64
    } else {
        // Exact: an order-preserving integer of the value (-0 as 0).
        let v = if v == 0.0 { 0.0 } else { v };
        let bits = v.to_bits() as i64;
        if bits < 0 {
            bits ^ i64::MAX
        } else {
            bits
        }
    }
}

/// Pair a's vertices with b's: first those with the same colour (a joint id:
/// same quantised values, or a refinement of them), in index order within a
/// colour; then the rest by rank in the order of their quantised values, so
/// that a few moved vertices do not shift the pairing of all the others.
/// `pairing[i]` is the partner in b of a's vertex `i`.
fn pair_vertices(ca: &[u32], cb: &[u32], ka: &[i64], kb: &[i64], stride: usize) -> Vec<usize> {
    let by_colour = |c: &[u32]| {
        let mut o: Vec<usize> = (0..c.len()).collect();
        o.sort_unstable_by_key(|&i| (c[i], i));
        o
    };
    let (oa, ob) = (by_colour(ca), by_colour(cb));
    let mut pairing = vec![0; ca.len()];
    let (mut rest_a, mut rest_b) = (Vec::new(), Vec::new());
    let (mut i, mut j) = (0, 0);
    while i < oa.len() && j < ob.len() {
        let (x, y) = (oa[i], ob[j]);
        match ca[x].cmp(&cb[y]) {
            std::cmp::Ordering::Equal => {
                pairing[x] = y;
                i += 1;
                j += 1;
            }
            std::cmp::Ordering::Less => {
                rest_a.push(x);
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                rest_b.push(y);
                j += 1;
            }
        }
    }
    rest_a.extend(&oa[i..]);
    rest_b.extend(&ob[j..]);
    let by_key = |rest: &mut Vec<usize>, k: &[i64]| {
        rest.sort_by(|&i, &j| {
            k[i * stride..(i + 1) * stride]
                .cmp(&k[j * stride..(j + 1) * stride])
                .then(i.cmp(&j))
        })
    };
    by_key(&mut rest_a, ka);
    by_key(&mut rest_b, kb);
    for (&x, &y) in rest_a.iter().zip(&rest_b) {
        pairing[x] = y;
    }
    pairing
}

/// Colour refinement (1-dimensional Weisfeiler-Leman) of the vertices of
/// both meshes at once: a vertex's new colour is its colour with the sorted
/// colours of its triangles' other corners (in winding order). Vertices
/// identical in every attribute get different colours when their triangles
/// differ. Stops when the number of colours stops growing.
fn refine(
    mut ca: Vec<u32>,
    ta: &[[u32; 3]],
    mut cb: Vec<u32>,
    tb: &[[u32; 3]],
) -> (Vec<u32>, Vec<u32>) {
    let corners = |n: usize, tris: &[[u32; 3]]| {
        let mut v: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
        for t in tris {
            if t.iter().all(|&i| (i as usize) < n) {
                for k in 0..3 {
                    v[t[k] as usize].push((t[(k + 1) % 3], t[(k + 2) % 3]));
                }
            }
        }
        v
    };
    let (na, nb) = (corners(ca.len(), ta), corners(cb.len(), tb));
    let mut count = ca
        .iter()
        .chain(&cb)
        .collect::<std::collections::HashSet<_>>()
        .len();
    for _ in 0..64 {
        let mut dict: HashMap<(u32, Vec<(u32, u32)>), u32> = HashMap::new();
        let mut step = |c: &[u32], nbr: &[Vec<(u32, u32)>]| -> Vec<u32> {
            (0..c.len())
                .map(|i| {
                    let mut s: Vec<(u32, u32)> = nbr[i]
                        .iter()
                        .map(|&(p, q)| (c[p as usize], c[q as usize]))
                        .collect();
                    s.sort_unstable();
                    let next = dict.len() as u32;
                    *dict.entry((c[i], s)).or_insert(next)
                })
                .collect()
        };
        let new_a = step(&ca, &na);
        let new_b = step(&cb, &nb);
        let new_count = dict.len();
        ca = new_a;
        cb = new_b;
        if new_count <= count {
            break;
        }
        count = new_count;
    }
    (ca, cb)
}

/// Triangles as sorted labels, each rotated to its least rotation (winding kept).
fn canonical(tris: &[[u32; 3]], label: impl Fn(u32) -> u32) -> Vec<[u32; 3]> {
    let mut v: Vec<[u32; 3]> = tris
        .iter()
        .map(|t| {
            let l = t.map(&label);
            [l, [l[1], l[2], l[0]], [l[2], l[0], l[1]]]
                .into_iter()
                .min()
                .unwrap_or(l)
        })
        .collect();
    v.sort_unstable();
    v
}

/// Elements of sorted `a` with no counterpart in sorted `b` (multisets).
fn multiset_off(a: Vec<[u32; 3]>, b: Vec<[u32; 3]>) -> usize {
    let (mut i, mut j, mut off) = (0, 0, 0);
    while i < a.len() {
        if j >= b.len() || a[i] < b[j] {
            off += 1;
            i += 1;
        } else if a[i] > b[j] {
            j += 1;
        } else {
            i += 1;
            j += 1;
        }
    }
    off
}

/// Triangles of `t` with no counterpart in `u` when a's vertex `i` is b's `pairing[i]`.
fn tris_off_paired(t: &TriGeometry, u: &TriGeometry, pairing: &[usize]) -> usize {
    let map = |i: u32| pairing.get(i as usize).map_or(u32::MAX, |&j| j as u32);
    multiset_off(canonical(&t.triangles, map), canonical(&u.triangles, |i| i))
}

// ---------------------------------------------------------------------- raw

/// Element count of a raw primitive: indices if any, else POSITION's count.
fn raw_elements(s: &Scene, r: &RawGeometry) -> Option<usize> {
    match r.indices {
        Some(i) => s.accessors.get(i).map(|a| a.count),
        None => r
            .attributes
            .get("POSITION")
            .and_then(|&i| s.accessors.get(i))
            .map(|a| a.count),
    }
}

/// Segments and total length of a LINES primitive; None when its data cannot be decoded.
fn line_stats(s: &Scene, r: &RawGeometry) -> Option<(usize, f64)> {
    let (comps, pos) = decode(s.accessors.get(*r.attributes.get("POSITION")?)?)?;
    if comps != 3 {
        return None;
    }
    let n = pos.len() / 3;
    let idx: Vec<usize> = match r.indices {
        Some(i) => {
            let (c, v) = decode(s.accessors.get(i)?)?;
            if c != 1 {
                return None;
            }
            v.into_iter().map(|x| x as usize).collect()
        }
        None => (0..n).collect(),
    };
    let mut length = 0.0;
    for seg in idx.chunks_exact(2) {
        if seg[0] >= n || seg[1] >= n {
            return None;
        }
        let (p, q) = (
            &pos[seg[0] * 3..seg[0] * 3 + 3],
            &pos[seg[1] * 3..seg[1] * 3 + 3],
        );
        length += ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
    }
    Some((idx.len() / 2, length))
}

fn compare_raw(
    a: &Scene,
    r: &RawGeometry,
    b: &Scene,
    s: &RawGeometry,
    place: &str,
    d: &mut Differences,
) {
    let count = |x: Option<usize>| x.map_or("?".to_string(), |c| c.to_string());
    if r.mode != mode::LINES {
        d.ne(
            "element_count",
            place,
            "elements",
            count(raw_elements(a, r)),
            count(raw_elements(b, s)),
        );
        return;
    }
    match (line_stats(a, r), line_stats(b, s)) {
        (Some((sa, la)), Some((sb, lb))) => {
            d.ne("segment_count", place, "segments", sa, sb);
            let scale = la.abs().max(1.0);
            let diff = delta(la, lb);
            if diff > d.tol * scale {
                let detail = format!(
                    "crack length {} vs {} differs by {} ({})",
                    short(la),
                    short(lb),
                    amount(diff),
                    d.tol_text(scale)
                );
                d.push("line_length", place, detail);
            }
        }
        (x, y) if x.is_none() || y.is_none() => {
            let which = if x.is_none() { "a" } else { "b" };
            d.push(
                "line_data",
                place,
                format!("the lines of {which} cannot be decoded"),
            );
        }
        _ => {}
    }
}

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
