//! Geometry of two primitives compared: triangle attributes in order or by a canonical vertex matching, and raw LINES by segment count and length.

use super::*;
use crate::io::accessor::decode_raw as decode;
use crate::scene::{mode, RawGeometry, Scene, TriGeometry};
use std::collections::HashMap;

/// One per-vertex attribute of a triangle primitive, flat.
pub(super) struct Column<'a> {
    pub(super) name: String,
    pub(super) components: usize,
    pub(super) data: &'a [f32],
}

pub(super) fn columns(t: &TriGeometry) -> Vec<Column<'_>> {
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
pub(super) struct Pair<'a> {
    pub(super) a: &'a Column<'a>,
    pub(super) b: &'a Column<'a>,
    pub(super) scale: f64,
}

/// Per column: vertices that differ and the largest difference, plus the
/// triangles of a with no counterpart in b (None: triangle counts differ).
pub(super) struct Eval {
    pub(super) differing: Vec<(usize, f64)>,
    pub(super) triangles_off: Option<usize>,
}

impl Eval {
    pub(super) fn vertices_off(&self) -> usize {
        self.differing.iter().map(|x| x.0).sum()
    }
    pub(super) fn clean(&self) -> bool {
        self.vertices_off() == 0 && self.triangles_off.unwrap_or(0) == 0
    }
    pub(super) fn badness(&self) -> (usize, usize) {
        (self.vertices_off(), self.triangles_off.unwrap_or(0))
    }
}

pub(super) fn compare_triangles(
    t: &TriGeometry,
    u: &TriGeometry,
    place: &str,
    d: &mut Differences,
) {
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
pub(super) fn evaluate(
    pairs: &[Pair],
    pairing: &[usize],
    triangles_off: Option<usize>,
    tol: f64,
) -> Eval {
    let differing = pairs
        .iter()
        .map(|p| {
            let c = p.a.components;
            let lim = tol * p.scale;
            let (mut count, mut worst) = (0, 0.0_f64);
            for (i, &j) in pairing.iter().enumerate() {
                let w = worst_delta(&p.a.data[i * c..(i + 1) * c], &p.b.data[j * c..(j + 1) * c]);
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

/// The largest [`delta`] of two vertices' components.
pub(super) fn worst_delta(x: &[f32], y: &[f32]) -> f64 {
    x.iter()
        .zip(y)
        .map(|(&x, &y)| delta(f64::from(x), f64::from(y)))
        .fold(0.0, f64::max)
}

/// Quantised values of every vertex (`stride` per vertex), position first.
/// Cells are `tol * scale` wide (scale of file a); with tolerance 0 the exact
/// values are used.
pub(super) fn keys(pairs: &[Pair], n: usize, tol: f64, side_a: bool) -> Vec<i64> {
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

pub(super) fn quantise(v: f64, cell: f64) -> i64 {
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
pub(super) fn pair_vertices(
    ca: &[u32],
    cb: &[u32],
    ka: &[i64],
    kb: &[i64],
    stride: usize,
) -> Vec<usize> {
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
pub(super) fn refine(
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
pub(super) fn canonical(tris: &[[u32; 3]], label: impl Fn(u32) -> u32) -> Vec<[u32; 3]> {
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
pub(super) fn multiset_off(a: Vec<[u32; 3]>, b: Vec<[u32; 3]>) -> usize {
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
pub(super) fn tris_off_paired(t: &TriGeometry, u: &TriGeometry, pairing: &[usize]) -> usize {
    let map = |i: u32| pairing.get(i as usize).map_or(u32::MAX, |&j| j as u32);
    multiset_off(canonical(&t.triangles, map), canonical(&u.triangles, |i| i))
}

/// Element count of a raw primitive: indices if any, else POSITION's count.
pub(super) fn raw_elements(s: &Scene, r: &RawGeometry) -> Option<usize> {
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
pub(super) fn line_stats(s: &Scene, r: &RawGeometry) -> Option<(usize, f64)> {
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

pub(super) fn compare_raw(
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
