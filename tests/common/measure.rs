//! An independent measure of crack patterns in crackle's output files: it shares no code
//! with `src/stats.rs` and calls nothing in the `crackle` crate (GLB / glTF / OBJ are read
//! here with `serde_json` and `base64`). Include with `#[path = "common/measure.rs"] mod measure;`.
//! Lengths are in the file's world units (node transforms applied), numerics f64, results
//! deterministic (hash maps are only looked up, never iterated).
#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

use serde_json::Value;

/// A point or direction.
pub type P3 = [f64; 3];
/// A line segment (two end points).
pub type Seg = [P3; 2];
/// A triangle (three corners).
pub type Tri = [P3; 3];

/// Default tolerance of `edge_share`, relative to the reference's bounding-box diagonal.
pub const DEFAULT_TOL_REL: f64 = 1e-6;
/// Default weld distance of `crack_graph`, relative to the lines' bounding-box diagonal.
pub const DEFAULT_WELD_REL: f64 = 1e-7;

fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: P3, b: P3) -> P3 {
    let c = |i: usize, j: usize| a[i] * b[j] - a[j] * b[i];
    [c(1, 2), c(2, 0), c(0, 1)]
}

/// A triangle's area.
pub fn triangle_area(t: &Tri) -> f64 {
    let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
    0.5 * norm(n)
}
fn norm(a: P3) -> f64 {
    dot(a, a).sqrt()
}
fn unit(a: P3) -> P3 {
    let n = norm(a);
    a.map(|x| if n > 0.0 { x / n } else { x })
}
fn lerp(a: P3, b: P3, t: f64) -> P3 {
    [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * t)
}
fn dist(a: P3, b: P3) -> f64 {
    norm(sub(a, b))
}
fn seg_len(s: &Seg) -> f64 {
    dist(s[0], s[1])
}
fn mid(s: &Seg) -> P3 {
    lerp(s[0], s[1], 0.5)
}
fn ratio(part: f64, total: f64) -> f64 {
    part / total.max(f64::MIN_POSITIVE)
}
/// The two axes other than `flat`, ascending.
fn plane_axes(flat: usize) -> (usize, usize) {
    [(1, 2), (0, 2), (0, 1)][flat]
}

/// Distance from `p` to the finite segment `s` and the parameter of the foot point in [0, 1].
fn seg_dist(p: P3, s: &Seg) -> (f64, f64) {
    let d = sub(s[1], s[0]);
    let t = ratio(dot(sub(p, s[0]), d), dot(d, d)).clamp(0.0, 1.0);
    (dist(p, lerp(s[0], s[1], t)), t)
}

/// Bounding box (min, max) of the points, world units; (+inf, -inf) when empty.
pub fn bounds<'a>(points: impl IntoIterator<Item = &'a P3>) -> (P3, P3) {
    let init = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let grow = |(lo, hi): (P3, P3), p: &P3| {
        let f = |k: usize| (lo[k].min(p[k]), hi[k].max(p[k]));
        let [x, y, z] = [0, 1, 2].map(f);
        ([x.0, y.0, z.0], [x.1, y.1, z.1])
    };
    points.into_iter().fold(init, grow)
}

fn diagonal(lo: P3, hi: P3) -> f64 {
    let d = dist(lo, hi);
    [d, 0.0][d.is_infinite() as usize]
}

/// Total length of the segments, world units.
pub fn crack_length(lines: &[Seg]) -> f64 {
    lines.iter().map(seg_len).sum()
}

// ---- Reading files ----

/// One primitive of a mesh instance, in world coordinates.
#[derive(Debug, Clone, Default)]
pub struct Primitive {
    pub material: String,
    pub triangles: Vec<Tri>,
    pub segments: Vec<Seg>,
    /// The segments at rest (`_CRACK_REST`), where the lines carry it.
    pub rest: Vec<Seg>,
    /// Each segment's time: the later of its ends' `_CRACK_TIME`, where
    /// the lines carry it.
    pub times: Vec<f64>,
}

/// One node's instance of a mesh.
#[derive(Debug, Clone, Default)]
pub struct Instance {
    pub node: String,
    pub mesh: String,
    pub primitives: Vec<Primitive>,
}

/// The mesh instances of a file's scene.
#[derive(Debug, Clone, Default)]
pub struct Model {
    pub instances: Vec<Instance>,
}

impl Model {
    fn prims(&self) -> impl Iterator<Item = &Primitive> {
        self.instances.iter().flat_map(|i| i.primitives.iter())
    }
    /// Line segments of every primitive whose material is named `material`, world units.
    pub fn lines(&self, material: &str) -> Vec<Seg> {
        let sel = self.prims().filter(|p| p.material == material);
        sel.flat_map(|p| p.segments.clone()).collect()
    }
    /// The lines of `material` at rest: `_CRACK_REST` where a primitive has it,
    /// else its segments, world units.
    pub fn rest_lines(&self, material: &str) -> Vec<Seg> {
        let sel = self.prims().filter(|p| p.material == material);
        sel.flat_map(|p| {
            if p.rest.is_empty() {
                p.segments.clone()
            } else {
                p.rest.clone()
            }
        })
        .collect()
    }
    /// [`Model::rest_lines`] with each segment's time (the later of its
    /// ends' `_CRACK_TIME`; NaN where the lines carry none).
    pub fn timed_rest_lines(&self, material: &str) -> Vec<(Seg, f64)> {
        let sel = self.prims().filter(|p| p.material == material);
        sel.flat_map(|p| {
            let segs = if p.rest.is_empty() {
                &p.segments
            } else {
                &p.rest
            };
            let time = |k: usize| p.times.get(k).copied().unwrap_or(f64::NAN);
            segs.iter().enumerate().map(move |(k, s)| (*s, time(k)))
        })
        .collect()
    }
    /// Triangles of every primitive whose material name passes `keep`, world units.
    pub fn triangles(&self, keep: impl Fn(&str) -> bool) -> Vec<Tri> {
        let sel = self.prims().filter(|p| keep(&p.material));
        sel.flat_map(|p| p.triangles.clone()).collect()
    }
}

/// Reads a .glb, .gltf (external or data-URI buffers) or .obj file into world-space meshes.
pub fn read_model(path: &Path) -> Model {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    match ext.to_ascii_lowercase().as_str() {
        "glb" => parse_glb(&bytes, path.parent()),
        "gltf" => parse_gltf(&bytes, None, path.parent()),
        "obj" => {
            let triangles = parse_obj(&String::from_utf8_lossy(&bytes));
            let (material, segments) = (String::new(), vec![]);
            let primitives = vec![Primitive {
                material,
                triangles,
                segments,
                rest: Vec::new(),
                times: Vec::new(),
            }];
            let (node, mesh) = (String::new(), String::new());
            let instances = vec![Instance {
                node,
                mesh,
                primitives,
            }];
            Model { instances }
        }
        _ => panic!("{}: unknown extension (glb, gltf, obj)", path.display()),
    }
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    let s = b.get(at..at + 4).expect("GLB truncated");
    u32::from_le_bytes([s[0], s[1], s[2], s[3]])
}

/// Parses GLB bytes (header, JSON chunk, optional BIN chunk); `dir` resolves external URIs.
pub fn parse_glb(bytes: &[u8], dir: Option<&Path>) -> Model {
    let word = |at: usize| u32_at(bytes, at);
    let ok = word(0) == 0x4654_6C67 && word(4) == 2;
    assert!(ok, "not a GLB file of version 2");
    let (mut json, mut bin, mut at) = (None, None, 12);
    while at + 8 <= (word(8) as usize).min(bytes.len()) {
        let (len, kind) = (word(at) as usize, word(at + 4));
        let data = &bytes[at + 8..(at + 8 + len).min(bytes.len())];
        match kind {
            0x4E4F_534A if json.is_none() => json = Some(data),
            0x004E_4942 if bin.is_none() => bin = Some(data.to_vec()),
            _ => {}
        }
        at += 8 + len;
    }
    parse_gltf(json.expect("GLB has no JSON chunk"), bin, dir)
}

/// Parses glTF JSON bytes; `bin` is a GLB's BIN chunk, `dir` resolves external URIs.
pub fn parse_gltf(json: &[u8], mut bin: Option<Vec<u8>>, dir: Option<&Path>) -> Model {
    let j: Value = serde_json::from_slice(json).unwrap_or_else(|e| panic!("glTF JSON: {e}"));
    let list = j["buffers"].as_array().cloned().unwrap_or_default();
    let bufs: Vec<Vec<u8>> = list.iter().map(|b| load_buffer(b, &mut bin, dir)).collect();
    model_from_json(&j, &bufs)
}

fn load_buffer(b: &Value, bin: &mut Option<Vec<u8>>, dir: Option<&Path>) -> Vec<u8> {
    use base64::Engine as _;
    let Some(uri) = b["uri"].as_str() else {
        return bin.take().expect("buffer without uri nor BIN");
    };
    if let (true, Some((_, b64))) = (uri.starts_with("data:"), uri.split_once(";base64,")) {
        let engine = base64::engine::general_purpose::STANDARD;
        return engine.decode(b64).expect("bad base64 buffer");
    }
    let path = dir.unwrap_or(Path::new(".")).join(uri.replace("%20", " "));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn as_index(v: &Value, what: &str) -> usize {
    let i = v.as_u64().unwrap_or_else(|| panic!("bad {what}: {v}"));
    i as usize
}

/// Reads an accessor as f64 components: FLOAT VEC3 when `vec3`, else an unsigned SCALAR.
fn read_accessor(j: &Value, bufs: &[Vec<u8>], idx: usize, vec3: bool) -> Vec<f64> {
    let a = &j["accessors"][idx];
    assert!(a.is_object(), "accessor {idx} does not exist");
    let sparse = "sparse accessors are not supported by this reader";
    let dense = a.get("sparse").is_none();
    assert!(dense, "accessor {idx} is sparse: {sparse}");
    let count = as_index(&a["count"], "accessor count");
    let ty = a["type"].as_str().unwrap_or("");
    let ct = a["componentType"].as_u64();
    let (ncomp, size) = match (vec3, ty, ct) {
        (true, "VEC3", Some(5126)) => (3, 4),
        (false, "SCALAR", Some(5126)) => (1, 4),
        (false, "SCALAR", Some(5121)) => (1, 1),
        (false, "SCALAR", Some(5123)) => (1, 2),
        (false, "SCALAR", Some(5125)) => (1, 4),
        _ => panic!("accessor {idx}: {ty} of component type {ct:?} is not supported here"),
    };
    let Some(view) = a["bufferView"].as_u64() else {
        return vec![0.0; count * ncomp];
    };
    let bv = &j["bufferViews"][view as usize];
    let buf = &bufs[as_index(&bv["buffer"], "bufferView.buffer")];
    let offset = |v: &Value| v["byteOffset"].as_u64().unwrap_or(0) as usize;
    let (start, elem) = (offset(bv) + offset(a), ncomp * size);
    let stride = bv["byteStride"].as_u64().map_or(elem, |s| s as usize);
    let end = start + (stride * count + elem).saturating_sub(stride);
    let view_end = offset(bv) + as_index(&bv["byteLength"], "byteLength");
    let fits = end <= view_end && view_end <= buf.len();
    assert!(fits, "accessor {idx} runs past its bufferView or buffer");
    let value = |k: usize| {
        let at = start + (k / ncomp) * stride + (k % ncomp) * size;
        let b = &buf[at..at + size];
        match (vec3 || ct == Some(5126), size) {
            (true, _) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            (false, 1) => b[0] as f64,
            (false, 2) => u16::from_le_bytes([b[0], b[1]]) as f64,
            _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        }
    };
    (0..count * ncomp).map(value).collect()
}

/// An affine map: the images of the three axes, then the image of the origin.
type Affine = [P3; 4];
const IDENTITY: Affine = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0; 3]];

fn apply(m: &Affine, p: P3) -> P3 {
    [0, 1, 2].map(|k| m[3][k] + p[0] * m[0][k] + p[1] * m[1][k] + p[2] * m[2][k])
}

fn compose(a: &Affine, b: &Affine) -> Affine {
    let lin = |v: P3| sub(apply(a, v), a[3]);
    [lin(b[0]), lin(b[1]), lin(b[2]), apply(a, b[3])]
}

fn numbers(v: &Value, n: usize, default: &[f64]) -> Vec<f64> {
    match v.as_array() {
        Some(a) if a.len() == n => a.iter().map(|x| x.as_f64().expect("number")).collect(),
        _ => default.to_vec(),
    }
}

/// A node's local transform: `matrix` (column-major) or translation * rotation * scale.
fn local_transform(n: &Value) -> Affine {
    if n.get("matrix").is_some() {
        let m = numbers(&n["matrix"], 16, &[]);
        assert!(m.len() == 16, "node matrix must have 16 numbers");
        return [0, 1, 2, 3].map(|c| [m[4 * c], m[4 * c + 1], m[4 * c + 2]]);
    }
    let t = numbers(&n["translation"], 3, &[0.0; 3]);
    let q = numbers(&n["rotation"], 4, &[0.0, 0.0, 0.0, 1.0]);
    let s = numbers(&n["scale"], 3, &[1.0; 3]);
    let u = [q[0], q[1], q[2]];
    // A unit quaternion rotates v to v + 2 w (u x v) + 2 u x (u x v).
    let rotate = |v: P3| {
        let c = cross(u, v);
        let cc = cross(u, c);
        [0, 1, 2].map(|k| v[k] + 2.0 * (q[3] * c[k] + cc[k]))
    };
    let axis = |k: usize| rotate([0, 1, 2].map(|c| if c == k { s[k] } else { 0.0 }));
    [axis(0), axis(1), axis(2), [t[0], t[1], t[2]]]
}

fn model_from_json(j: &Value, bufs: &[Vec<u8>]) -> Model {
    let nodes = j["nodes"].as_array().cloned().unwrap_or_default();
    let kids = |n: &Value| n["children"].as_array().cloned().unwrap_or_default();
    let roots: Vec<usize> = match j["scenes"].as_array() {
        Some(scenes) if !scenes.is_empty() => {
            let list = &scenes[j["scene"].as_u64().unwrap_or(0) as usize]["nodes"];
            let list = list.as_array().cloned().unwrap_or_default();
            list.iter().map(|v| as_index(v, "scene node")).collect()
        }
        _ => {
            let children = nodes.iter().flat_map(kids);
            let set: BTreeSet<usize> = children.map(|v| as_index(&v, "child")).collect();
            (0..nodes.len()).filter(|i| !set.contains(i)).collect()
        }
    };
    let mut out = Model::default();
    let mut stack: Vec<_> = roots.iter().rev().map(|&r| (r, IDENTITY, 0)).collect();
    while let Some((ni, parent, depth)) = stack.pop() {
        assert!(depth <= nodes.len(), "node hierarchy has a cycle");
        let n = nodes.get(ni).expect("node index out of range");
        let world = compose(&parent, &local_transform(n));
        if let Some(mi) = n["mesh"].as_u64() {
            let inst = instance(j, bufs, n, mi as usize, &world);
            out.instances.push(inst);
        }
        for k in kids(n).iter().rev() {
            stack.push((as_index(k, "child"), world, depth + 1));
        }
    }
    out
}

fn instance(j: &Value, bufs: &[Vec<u8>], node: &Value, mi: usize, world: &Affine) -> Instance {
    let mesh = &j["meshes"][mi];
    assert!(mesh.is_object(), "mesh {mi} does not exist");
    let name = |v: &Value| v["name"].as_str().unwrap_or("").to_string();
    let (node, mesh_name) = (name(node), name(mesh));
    let mut primitives = Vec::new();
    for prim in mesh["primitives"].as_array().cloned().unwrap_or_default() {
        let material = match prim["material"].as_u64() {
            Some(m) => name(&j["materials"][m as usize]),
            None => String::new(),
        };
        let pa = as_index(&prim["attributes"]["POSITION"], "POSITION");
        let raw = read_accessor(j, bufs, pa, true);
        let to_world = |c: &[f64]| apply(world, [c[0], c[1], c[2]]);
        let pos: Vec<P3> = raw.chunks(3).map(to_world).collect();
        let idx: Vec<f64> = match prim["indices"].as_u64() {
            Some(ia) => read_accessor(j, bufs, ia as usize, false),
            None => (0..pos.len()).map(|i| i as f64).collect(),
        };
        let p = |i: usize| *pos.get(idx[i] as usize).expect("vertex index out of range");
        let (n, mode) = (idx.len(), prim["mode"].as_u64().unwrap_or(4));
        let unsupported = "is not supported (POINTS, LINES, TRIANGLES only)";
        assert!(matches!(mode, 0 | 1 | 4), "mode {mode} {unsupported}");
        let count = |m: u64, per: usize| if mode == m { n / per } else { 0 };
        let seg = |k: usize| [p(2 * k), p(2 * k + 1)];
        let tri = |k: usize| [p(3 * k), p(3 * k + 1), p(3 * k + 2)];
        let segments = (0..count(1, 2)).map(seg).collect();
        let triangles = (0..count(4, 3)).map(tri).collect();
        let rest = match prim["attributes"]["_CRACK_REST"].as_u64() {
            Some(ra) if mode == 1 => {
                let raw = read_accessor(j, bufs, ra as usize, true);
                let at: Vec<P3> = raw.chunks(3).map(to_world).collect();
                let q = |i: usize| *at.get(idx[i] as usize).expect("vertex index out of range");
                (0..count(1, 2)).map(|k| [q(2 * k), q(2 * k + 1)]).collect()
            }
            _ => Vec::new(),
        };
        let times = match prim["attributes"]["_CRACK_TIME"].as_u64() {
            Some(ta) if mode == 1 => {
                let t = read_accessor(j, bufs, ta as usize, false);
                let at = |i: usize| *t.get(idx[i] as usize).expect("vertex index out of range");
                (0..count(1, 2))
                    .map(|k| at(2 * k).max(at(2 * k + 1)))
                    .collect()
            }
            _ => Vec::new(),
        };
        primitives.push(Primitive {
            material,
            triangles,
            segments,
            rest,
            times,
        });
    }
    let mesh = mesh_name;
    Instance {
        node,
        mesh,
        primitives,
    }
}

/// Parses OBJ text (`v` and `f` only; polygons fan-triangulated) into triangles.
pub fn parse_obj(text: &str) -> Vec<Tri> {
    let (mut verts, mut tris): (Vec<P3>, Vec<Tri>) = (Vec::new(), Vec::new());
    for (ln, line) in text.lines().enumerate() {
        let mut it = line.split('#').next().unwrap_or("").split_whitespace();
        let bad = |what: &str| -> ! { panic!("OBJ line {}: bad {what}", ln + 1) };
        let num = |t: &str| t.parse::<f64>().unwrap_or_else(|_| bad("number"));
        match it.next() {
            Some("v") => {
                let c: Vec<f64> = it.take(3).map(num).collect();
                verts.push(c.try_into().unwrap_or_else(|_| bad("v")));
            }
            Some("f") => {
                let index = |t: &str| {
                    let i = num(t.split('/').next().unwrap_or("")) as i64;
                    let r = if i < 0 { verts.len() as i64 + i } else { i - 1 };
                    let r = usize::try_from(r).unwrap_or(usize::MAX);
                    *verts.get(r).unwrap_or_else(|| bad("index"))
                };
                let f: Vec<P3> = it.map(index).collect();
                tris.extend((2..f.len()).map(|k| [f[0], f[k - 1], f[k]]));
            }
            _ => {}
        }
    }
    tris
}

// ---- A uniform spatial hash grid ----

type Cell = (i64, i64, i64);

/// Points or segments by cell. Only looked up, never iterated, so results are deterministic.
struct Grid {
    cell: f64,
    map: HashMap<Cell, Vec<u32>>,
}

impl Grid {
    fn new(cell: f64) -> Self {
        let cell = [1.0, cell][(cell.is_finite() && cell > 0.0) as usize];
        let map = HashMap::new();
        Grid { cell, map }
    }
    fn key(&self, p: P3) -> Cell {
        let f = |x: f64| (x / self.cell).floor() as i64;
        (f(p[0]), f(p[1]), f(p[2]))
    }
    fn insert_point(&mut self, p: P3, id: usize) {
        self.map.entry(self.key(p)).or_default().push(id as u32);
    }
    /// Registers a segment in the cells of samples spaced at most half a cell apart.
    fn insert_segment(&mut self, s: &Seg, id: usize) {
        let n = ((seg_len(s) / (0.5 * self.cell)).ceil() as usize).max(1);
        for k in 0..=n {
            let key = self.key(lerp(s[0], s[1], k as f64 / n as f64));
            let v = self.map.entry(key).or_default();
            if v.last() != Some(&(id as u32)) {
                v.push(id as u32);
            }
        }
    }
    /// Calls `f` on every item that may lie within `r` of `p` (some twice); stops at `true`.
    fn near(&self, p: P3, r: f64, mut f: impl FnMut(usize) -> bool) -> bool {
        let k = ((r + 0.5 * self.cell) / self.cell).ceil() as i64;
        let (w, (x, y, z)) = (2 * k + 1, self.key(p));
        (0..w * w * w).any(|i| {
            let cell = (x + i % w - k, y + i / w % w - k, z + i / (w * w) - k);
            let ids = self.map.get(&cell).map_or(&[][..], |v| &v[..]);
            ids.iter().any(|&id| f(id as usize))
        })
    }
}

fn segment_grid(segs: &[Seg], cell: f64) -> Grid {
    let mut g = Grid::new(cell);
    for (i, s) in segs.iter().enumerate() {
        g.insert_segment(s, i);
    }
    g
}

fn mean_len(segs: &[Seg]) -> f64 {
    crack_length(segs) / segs.len().max(1) as f64
}

// ---- Edge share and orientation ----

/// The distinct edges of the triangles (by exact position), world units.
pub fn triangle_edges(tris: &[Tri]) -> Vec<Seg> {
    let key = |p: P3| p.map(|x| (x + 0.0).to_bits());
    let mut set = BTreeMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (ka, kb) = (key(a), key(b));
            let e = [((ka, kb), [a, b]), ((kb, ka), [b, a])][(kb < ka) as usize];
            set.entry(e.0).or_insert(e.1);
        }
    }
    set.into_values().collect()
}

/// Share (0..1) of the lines' length lying along edges of the reference triangles.
pub fn edge_share(lines: &[Seg], reference: &[Tri], tol_rel: f64) -> f64 {
    let edges = triangle_edges(reference);
    let (lo, hi) = bounds(reference.iter().flatten());
    let tol = tol_rel * diagonal(lo, hi);
    let grid = segment_grid(&edges, mean_len(&edges));
    let dirs: Vec<P3> = edges.iter().map(|e| unit(sub(e[1], e[0]))).collect();
    let (mut on, mut total) = (0.0, 0.0);
    for s in lines {
        let len = seg_len(s);
        total += len;
        let d = unit(sub(s[1], s[0]));
        let on_edge = |k: &usize| {
            let p = lerp(s[0], s[1], (*k as f64 + 0.5) / 16.0);
            let parallel = |e: usize| dot(d, dirs[e]).abs() > 1.0 - 1e-6;
            grid.near(p, tol, |e| parallel(e) && seg_dist(p, &edges[e]).0 <= tol)
        };
        on += len * (0..16).filter(on_edge).count() as f64 / 16.0;
    }
    ratio(on, total)
}

/// Length shares of segment angles in six 30-degree bins centred on 0, 30, ..., 150
/// degrees (so a bin holds each axis whole), and the share within 5 degrees of the axes.
pub fn orientation_bins(lines: &[Seg], frame: impl Fn(P3) -> Option<(P3, P3)>) -> ([f64; 6], f64) {
    let (mut bins, mut axis, mut total) = ([0.0; 6], 0.0, 0.0);
    for s in lines {
        let (d, frame) = (sub(s[1], s[0]), frame(mid(s)));
        let (Some((e1, e2)), len) = (frame, norm(d)) else {
            continue;
        };
        let a = dot(d, e2).atan2(dot(d, e1)).to_degrees().rem_euclid(180.0);
        bins[(((a + 15.0) % 180.0 / 30.0) as usize).min(5)] += len;
        let off = (a - 90.0 * (a / 90.0).round()).abs();
        axis += [0.0, len][(off <= 5.0) as usize];
        total += len;
    }
    (bins.map(|b| ratio(b, total)), ratio(axis, total))
}

/// Orientation at the pattern's scale: the crack graph's chains (runs
/// between nodes that are not of degree 2) cut into chords `chord` long
/// along their length, and the share of the chords' length within 15
/// degrees of the frame's axes (a random orientation gives 1/3). Chords
/// the frame leaves out (`None`, e.g. near a plate's border) do not count.
/// Each segment's own angle follows the simulation surface's triangles;
/// a chord a third of a cell long sees where the crack goes (rows along
/// the axes, or not).
pub fn chord_axis_share(
    graph: &CrackGraph,
    chord: f64,
    frame: impl Fn(P3) -> Option<(P3, P3)>,
) -> f64 {
    let (mut axis, mut total) = (0.0, 0.0);
    let mut used = vec![false; graph.edges.len()];
    let mut add = |d: P3, m: P3, len: f64| {
        if let Some((e1, e2)) = frame(m) {
            let a = dot(d, e2).atan2(dot(d, e1)).to_degrees().rem_euclid(90.0);
            total += len;
            if a.min(90.0 - a) <= 15.0 {
                axis += len;
            }
        }
    };
    // Chain starts: junctions and tips first, then any node of a closed loop.
    let starts = (0..graph.nodes.len())
        .filter(|&n| graph.degree[n] != 2)
        .chain((0..graph.nodes.len()).filter(|&n| graph.degree[n] == 2));
    for start in starts {
        for &(first, e0) in &graph.adjacency[start] {
            if used[e0] {
                continue;
            }
            used[e0] = true;
            let mut chain = vec![graph.nodes[start], graph.nodes[first]];
            let mut cur = first;
            while graph.degree[cur] == 2 && cur != start {
                let Some(&(next, e)) = graph.adjacency[cur].iter().find(|&&(_, e)| !used[e]) else {
                    break;
                };
                used[e] = true;
                chain.push(graph.nodes[next]);
                cur = next;
            }
            // Points every `chord` along the chain; the remainder is a short chord.
            let mut last = chain[0];
            let mut left = chord;
            for w in chain.windows(2) {
                let (mut a, b) = (w[0], w[1]);
                let mut l = dist(a, b);
                while l >= left {
                    let p = lerp(a, b, left / l);
                    add(sub(p, last), lerp(last, p, 0.5), chord);
                    last = p;
                    a = p;
                    l -= left;
                    left = chord;
                }
                left -= l;
            }
            let rest = chord - left;
            if rest > 0.0 {
                let end = *chain.last().unwrap();
                add(sub(end, last), lerp(last, end, 0.5), rest);
            }
        }
    }
    ratio(axis, total)
}

/// Frame for a disc in a plate's plane: the plane's two axes, `None` farther than
/// `radius - margin` from `center` (world units).
pub fn disc_frame(min: P3, max: P3, margin: f64) -> impl Fn(P3) -> Option<(P3, P3)> {
    let center = [0, 1, 2].map(|k| 0.5 * (min[k] + max[k]));
    let flat = flat_axis(min, max);
    let radius = 0.5
        * (0..3)
            .filter(|&k| k != flat)
            .map(|k| max[k] - min[k])
            .fold(0.0, f64::max);
    let frame = plate_frame(min, max, 0.0);
    move |p: P3| {
        let mut d = sub(p, center);
        d[flat] = 0.0;
        (norm(d) <= radius - margin).then(|| frame(p)).flatten()
    }
}

/// The flat axis (0, 1, 2) of a plate's bounding box: the one of smallest extent.
pub fn flat_axis(min: P3, max: P3) -> usize {
    let e = sub(max, min);
    (0..3).fold(0, |best, k| if e[k] < e[best] { k } else { best })
}

/// Frame for a plate: its two in-plane axes, `None` within `margin` (world units) of its border.
pub fn plate_frame(min: P3, max: P3, margin: f64) -> impl Fn(P3) -> Option<(P3, P3)> {
    let (i, j) = plane_axes(flat_axis(min, max));
    let axis = |k: usize| [0, 1, 2].map(|c| if c == k { 1.0 } else { 0.0 });
    let (e1, e2) = (axis(i), axis(j));
    move |m: P3| {
        let inside = |k: usize| m[k] >= min[k] + margin && m[k] <= max[k] - margin;
        (inside(i) && inside(j)).then_some((e1, e2))
    }
}

/// Frame for a sphere with poles on `axis`: (east, north), `None` where |cos polar angle| > `cap`.
pub fn latlong_frame(center: P3, axis: P3, cap: f64) -> impl Fn(P3) -> Option<(P3, P3)> {
    let axis = unit(axis);
    move |m: P3| {
        let r = unit(sub(m, center));
        if dot(r, axis).abs() > cap {
            return None;
        }
        let east = unit(cross(axis, r));
        Some((east, cross(r, east)))
    }
}

// ---- The crack graph ----

/// Welds points closer than `tol` (union-find over a grid); nodes in order of first appearance.
fn weld_points(points: &[P3], tol: f64) -> (Vec<P3>, Vec<usize>) {
    let mut parent: Vec<usize> = (0..points.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    if tol > 0.0 {
        let mut grid = Grid::new(2.0 * tol);
        for (i, &p) in points.iter().enumerate() {
            grid.near(p, tol, |j| {
                if dist(p, points[j]) <= tol {
                    let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                    parent[a.max(b)] = a.min(b);
                }
                false
            });
            grid.insert_point(p, i);
        }
    } else {
        let mut seen: BTreeMap<[u64; 3], usize> = BTreeMap::new();
        for (i, p) in points.iter().enumerate() {
            parent[i] = *seen.entry(p.map(|x| (x + 0.0).to_bits())).or_insert(i);
        }
    }
    let (mut nodes, mut map, mut id_of) = (Vec::new(), Vec::new(), BTreeMap::new());
    for i in 0..points.len() {
        let r = root(&mut parent, i);
        let id = *id_of.entry(r).or_insert_with(|| {
            nodes.push(points[r]);
            nodes.len() - 1
        });
        map.push(id);
    }
    (nodes, map)
}

/// Splits each edge at the nodes lying on its interior within `tol` plus `sag_rel` of its length.
fn split_at_nodes(nodes: &[P3], edges: &[[usize; 2]], tol: f64, sag_rel: f64) -> Vec<[usize; 2]> {
    let segs: Vec<Seg> = edges.iter().map(|&[a, b]| [nodes[a], nodes[b]]).collect();
    let cell = mean_len(&segs).max(4.0 * tol);
    let mut grid = Grid::new(cell);
    for (i, &p) in nodes.iter().enumerate() {
        grid.insert_point(p, i);
    }
    let mut out = Vec::with_capacity(edges.len());
    for (s, &[u, v]) in segs.iter().zip(edges) {
        let n = ((seg_len(s) / (0.5 * grid.cell)).ceil() as usize).max(1);
        let reach = tol + sag_rel * seg_len(s);
        let mut on: BTreeSet<(u64, usize)> = BTreeSet::new();
        for k in 0..=n {
            let q = lerp(s[0], s[1], k as f64 / n as f64);
            grid.near(q, reach + 0.25 * grid.cell, |w| {
                let (d, t) = seg_dist(nodes[w], s);
                let inner = dist(nodes[w], s[0]) > tol && dist(nodes[w], s[1]) > tol;
                if w != u && w != v && d <= reach && inner && t > 0.0 && t < 1.0 {
                    on.insert((t.to_bits(), w));
                }
                false
            });
        }
        let mut prev = u;
        for &(_, w) in &on {
            out.push([prev, w]);
            prev = w;
        }
        out.push([prev, v]);
    }
    out
}

/// Nodes and undirected edges of welded crack lines.
#[derive(Debug, Clone)]
pub struct CrackGraph {
    pub nodes: Vec<P3>,
    pub edges: Vec<[usize; 2]>,
    pub degree: Vec<usize>,
    /// The weld distance, world units.
    pub weld: f64,
    adjacency: Vec<Vec<(usize, usize)>>,
}

impl CrackGraph {
    fn from_parts(nodes: Vec<P3>, edges: &[[usize; 2]], weld: f64) -> Self {
        let sorted = edges.iter().map(|&[a, b]| [a.min(b), a.max(b)]);
        let set: BTreeSet<[usize; 2]> = sorted.filter(|e| e[0] != e[1]).collect();
        let edges: Vec<[usize; 2]> = set.into_iter().collect();
        let mut adjacency = vec![Vec::new(); nodes.len()];
        for (e, &[a, b]) in edges.iter().enumerate() {
            adjacency[a].push((b, e));
            adjacency[b].push((a, e));
        }
        let degree = adjacency.iter().map(Vec::len).collect();
        let adj = adjacency;
        CrackGraph {
            nodes,
            edges,
            degree,
            weld,
            adjacency: adj,
        }
    }
    /// Edge `e` as a segment, world units.
    pub fn segment(&self, e: usize) -> Seg {
        [self.nodes[self.edges[e][0]], self.nodes[self.edges[e][1]]]
    }
    /// All edges as segments, world units.
    pub fn segments(&self) -> Vec<Seg> {
        (0..self.edges.len()).map(|e| self.segment(e)).collect()
    }
    /// Walking from open end `end` along the crack (through nodes of degree 2) until `length`
    /// (world units) or a junction or another end: the node reached.
    pub fn walk_from_end(&self, end: usize, length: f64) -> usize {
        let (mut prev, mut at, mut walked) = (usize::MAX, end, 0.0);
        loop {
            let next = self.adjacency[at].iter().find(|&&(m, _)| m != prev);
            let Some(&(m, _)) = next else { return at };
            walked += dist(self.nodes[at], self.nodes[m]);
            (prev, at) = (at, m);
            if walked >= length || self.degree[at] != 2 {
                return at;
            }
        }
    }
    /// The connected pieces of the graph, each as its edges.
    pub fn pieces(&self) -> Vec<Vec<usize>> {
        let mut seen = vec![false; self.nodes.len()];
        let mut pieces = Vec::new();
        for start in 0..self.nodes.len() {
            if seen[start] || self.adjacency[start].is_empty() {
                continue;
            }
            seen[start] = true;
            let (mut stack, mut edges) = (vec![start], BTreeSet::new());
            while let Some(n) = stack.pop() {
                for &(m, e) in &self.adjacency[n] {
                    edges.insert(e);
                    if !seen[m] {
                        seen[m] = true;
                        stack.push(m);
                    }
                }
            }
            pieces.push(edges.into_iter().collect());
        }
        pieces
    }
    /// Nodes within path length `limit` (world units) of the sources (node, starting length).
    pub fn reach(&self, sources: &[(usize, f64)], limit: f64) -> BTreeMap<usize, f64> {
        // Lengths are >= 0, so their bits sort as they do: a BTreeSet is the queue.
        let mut best: BTreeMap<usize, f64> = BTreeMap::new();
        let mut queue: BTreeSet<(u64, usize)> =
            sources.iter().map(|&(n, d)| (d.to_bits(), n)).collect();
        while let Some((bits, n)) = queue.pop_first() {
            let d = f64::from_bits(bits);
            if d > limit || best.contains_key(&n) {
                continue;
            }
            best.insert(n, d);
            for &(m, e) in &self.adjacency[n] {
                queue.insert(((d + seg_len(&self.segment(e))).to_bits(), m));
            }
        }
        best
    }
}

/// The crack network: ends welded within `weld_rel` of the bbox diagonal, split at ends on edges.
pub fn crack_graph(lines: &[Seg], weld_rel: f64) -> CrackGraph {
    crack_graph_curved(lines, weld_rel, 0.0)
}

/// `crack_graph` also splitting a segment at an end within `sag_rel` of its length (a chord's sag).
pub fn crack_graph_curved(lines: &[Seg], weld_rel: f64, sag_rel: f64) -> CrackGraph {
    let (lo, hi) = bounds(lines.iter().flatten());
    let weld = weld_rel * diagonal(lo, hi);
    let points: Vec<P3> = lines.iter().flatten().copied().collect();
    let (nodes, map) = weld_points(&points, weld);
    let pair = |i: usize| [map[2 * i], map[2 * i + 1]];
    let raw: Vec<_> = (0..lines.len()).map(pair).collect();
    let edges = split_at_nodes(&nodes, &raw, weld, sag_rel);
    CrackGraph::from_parts(nodes, &edges, weld)
}

/// Edges (world units) used by one triangle only, corners welded within `weld_rel` of the diagonal.
pub fn boundary_edges(tris: &[Tri], weld_rel: f64) -> Vec<Seg> {
    let (lo, hi) = bounds(tris.iter().flatten());
    let points: Vec<P3> = tris.iter().flatten().copied().collect();
    let (nodes, map) = weld_points(&points, weld_rel * diagonal(lo, hi));
    let mut count: BTreeMap<[usize; 2], usize> = BTreeMap::new();
    for t in 0..tris.len() {
        for k in 0..3 {
            let (a, b) = (map[3 * t + k], map[3 * t + (k + 1) % 3]);
            if a != b {
                *count.entry([a.min(b), a.max(b)]).or_default() += 1;
            }
        }
    }
    let once = count.into_iter().filter(|&(_, c)| c == 1);
    once.map(|([a, b], _)| [nodes[a], nodes[b]]).collect()
}

/// The segments with coordinate `axis` set to `value` (projection onto a plate's plane).
pub fn flatten(segs: &[Seg], axis: usize, value: f64) -> Vec<Seg> {
    let f = |p: P3| [0, 1, 2].map(|k| if k == axis { value } else { p[k] });
    segs.iter().map(|s| [f(s[0]), f(s[1])]).collect()
}

fn open_tip_nodes(graph: &CrackGraph, border: &[Seg]) -> Vec<usize> {
    let grid = segment_grid(border, mean_len(border).max(4.0 * graph.weld));
    let on_border = |p: P3| grid.near(p, graph.weld, |b| seg_dist(p, &border[b]).0 <= graph.weld);
    let tips = (0..graph.nodes.len()).filter(|&n| graph.degree[n] == 1);
    tips.filter(|&n| !on_border(graph.nodes[n])).collect()
}

/// Number of open crack tips: degree-1 nodes farther than the weld distance from the border.
pub fn open_tips(graph: &CrackGraph, border: &[Seg]) -> usize {
    open_tip_nodes(graph, border).len()
}

/// Open tips with another crack's segment within `radius` (world units): (node, distance), by node.
pub fn loose_ends(graph: &CrackGraph, border: &[Seg], radius: f64) -> Vec<(usize, f64)> {
    let segs = graph.segments();
    let grid = segment_grid(&segs, (2.0 * radius).max(mean_len(&segs)));
    let mut out = Vec::new();
    for tip in open_tip_nodes(graph, border) {
        let p = graph.nodes[tip];
        let reach = graph.reach(&[(tip, 0.0)], 3.0 * radius);
        let mut best = f64::INFINITY;
        grid.near(p, radius, |e| {
            let [a, b] = graph.edges[e];
            if !reach.contains_key(&a) && !reach.contains_key(&b) {
                best = best.min(seg_dist(p, &segs[e]).0);
            }
            false
        });
        if best <= radius {
            out.push((tip, best));
        }
    }
    out
}

/// Share (0..1) of crack length with another crack's parallel segment within `distance`.
pub fn paired_share(lines: &[Seg], distance: f64, max_angle_deg: f64) -> f64 {
    let graph = crack_graph(lines, DEFAULT_WELD_REL);
    paired_share_in(&graph, distance, max_angle_deg)
}

/// `paired_share` (0..1) over the edges of a given crack graph.
pub fn paired_share_in(graph: &CrackGraph, distance: f64, max_angle_deg: f64) -> f64 {
    let segs = graph.segments();
    let grid = segment_grid(&segs, (2.0 * distance).max(mean_len(&segs)));
    let cos_max = max_angle_deg.to_radians().cos();
    let (mut paired, mut total) = (0.0, 0.0);
    for (e, s) in segs.iter().enumerate() {
        let (len, m, d) = (seg_len(s), mid(s), unit(sub(s[1], s[0])));
        let limit = 3.0 * distance;
        let [u, v] = graph.edges[e];
        let start = (0.5 * len).min(limit);
        let reach = graph.reach(&[(u, start), (v, start)], limit);
        let found = grid.near(m, distance, |f| {
            let [a, b] = graph.edges[f];
            let other = f != e && !reach.contains_key(&a) && !reach.contains_key(&b);
            other
                && dot(d, unit(sub(segs[f][1], segs[f][0]))).abs() >= cos_max
                && seg_dist(m, &segs[f]).0 <= distance
        });
        total += len;
        paired += [0.0, len][found as usize];
    }
    ratio(paired, total)
}

// ---- Cells of a flat plate ----

/// The faces of cracks plus border in a plate's plane: the plane graph (nodes projected,
/// welded, edges split at nodes), each face as its cycle of half-edges (`2 e` runs
/// `a -> b` along edge `e`, `2 e + 1` back) with its signed area, and which edges of the
/// plane graph are the border's.
struct PlaneFaces {
    plane: CrackGraph,
    faces: Vec<(f64, Vec<usize>)>,
    border_edge: Vec<bool>,
}

fn plane_faces(graph: &CrackGraph, border: &[Seg]) -> PlaneFaces {
    let all = graph.nodes.iter().chain(border.iter().flatten());
    let (lo, hi) = bounds(all);
    let (i, j) = plane_axes(flat_axis(lo, hi));
    let proj = |p: &P3| [p[i], p[j], 0.0];
    let mut points: Vec<P3> = graph.nodes.iter().map(proj).collect();
    points.extend(border.iter().flatten().map(proj));
    let (nodes, map) = weld_points(&points, graph.weld);
    let mut raw: Vec<[usize; 2]> = graph.edges.iter().map(|&[a, b]| [map[a], map[b]]).collect();
    let base = graph.nodes.len();
    raw.extend((0..border.len()).map(|k| [map[base + 2 * k], map[base + 2 * k + 1]]));
    let split = split_at_nodes(&nodes, &raw, graph.weld, 0.0);
    let crack_edges: BTreeSet<[usize; 2]> = {
        let cracks = split_at_nodes(&nodes, &raw[..graph.edges.len()], graph.weld, 0.0);
        cracks.iter().map(|&[a, b]| [a.min(b), a.max(b)]).collect()
    };
    let plane = CrackGraph::from_parts(nodes, &split, graph.weld);
    let border_edge = plane
        .edges
        .iter()
        .map(|e| !crack_edges.contains(e))
        .collect();
    // Outgoing half-edges sorted by angle.
    let from = |h: usize| plane.edges[h / 2][h % 2];
    let to = |h: usize| plane.edges[h / 2][1 - h % 2];
    let angle = |h: usize| {
        let d = sub(plane.nodes[to(h)], plane.nodes[from(h)]);
        d[1].atan2(d[0])
    };
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); plane.nodes.len()];
    for h in 0..2 * plane.edges.len() {
        around[from(h)].push(h);
    }
    let mut slot = vec![0; 2 * plane.edges.len()];
    for list in &mut around {
        list.sort_by(|&a, &b| angle(a).total_cmp(&angle(b)).then(a.cmp(&b)));
        for (k, &h) in list.iter().enumerate() {
            slot[h] = k;
        }
    }
    // next(a -> b): at b, the half-edge just clockwise of b -> a (faces on the left).
    let next = |h: usize| {
        let list = &around[to(h)];
        list[(slot[h ^ 1] + list.len() - 1) % list.len()]
    };
    let mut seen = vec![false; 2 * plane.edges.len()];
    let mut faces = Vec::new();
    for h0 in 0..seen.len() {
        // A half-edge already walked gives an empty face of area 0, dropped by callers.
        let (mut h, mut area, mut cycle) = (h0, 0.0, Vec::new());
        while !seen[h] {
            seen[h] = true;
            cycle.push(h);
            let (p, q) = (plane.nodes[from(h)], plane.nodes[to(h)]);
            area += 0.5 * (p[0] * q[1] - q[0] * p[1]);
            h = next(h);
        }
        faces.push((area, cycle));
    }
    PlaneFaces {
        plane,
        faces,
        border_edge,
    }
}

impl PlaneFaces {
    /// The faces kept as cells: positive area at least `min_area_rel` of the enclosed area.
    fn cells(&self, min_area_rel: f64) -> Vec<usize> {
        let enclosed = self.faces.iter().fold(0.0f64, |m, f| m.max(-f.0));
        let positive: f64 = self.faces.iter().map(|f| f.0).filter(|&a| a > 0.0).sum();
        let total = if enclosed > 0.0 { enclosed } else { positive };
        (0..self.faces.len())
            .filter(|&k| self.faces[k].0 > 0.0 && self.faces[k].0 >= min_area_rel * total)
            .collect()
    }
}

/// Areas (world units squared) of the bounded faces of cracks plus border in a plate's plane.
pub fn planar_cells(graph: &CrackGraph, border: &[Seg], min_area_rel: f64) -> Vec<f64> {
    let pf = plane_faces(graph, border);
    pf.cells(min_area_rel)
        .into_iter()
        .map(|k| pf.faces[k].0)
        .collect()
}

/// Sides of the cells (as `planar_cells` finds them) that touch no border edge: the
/// junctions on a cell's outline (nodes where three or more edges meet) at which the
/// cell's inside angle is below `corner_deg`, the angle taken between the points `arm`
/// (world units) back and ahead along the outline (a T-junction's straight side is no
/// corner of the cell on that side).
pub fn planar_cell_sides(
    graph: &CrackGraph,
    border: &[Seg],
    min_area_rel: f64,
    arm: f64,
    corner_deg: f64,
) -> Vec<usize> {
    let pf = plane_faces(graph, border);
    let plane = &pf.plane;
    let from = |h: usize| plane.edges[h / 2][h % 2];
    let to = |h: usize| plane.edges[h / 2][1 - h % 2];
    let mut sides = Vec::new();
    for k in pf.cells(min_area_rel) {
        let cycle = &pf.faces[k].1;
        if cycle.iter().any(|&h| pf.border_edge[h / 2]) {
            continue;
        }
        let n = cycle.len();
        // The point `arm` away from node from(cycle[i]) walking forward (+1) or back (-1).
        let reach = |i: usize, forward: bool| -> P3 {
            let v = plane.nodes[from(cycle[i])];
            for step in 0..n {
                let h = if forward {
                    cycle[(i + step) % n]
                } else {
                    cycle[(i + n - 1 - step) % n]
                };
                let far = plane.nodes[if forward { to(h) } else { from(h) }];
                if dist(far, v) >= arm {
                    return far;
                }
            }
            plane.nodes[if forward {
                to(cycle[(i + n - 1) % n])
            } else {
                from(cycle[0])
            }]
        };
        let mut corners = 0;
        for (i, &h) in cycle.iter().enumerate() {
            if plane.degree[from(h)] < 3 {
                continue;
            }
            let v = plane.nodes[from(h)];
            let (f, b) = (sub(reach(i, true), v), sub(reach(i, false), v));
            // Faces are walked with the inside on the left: the inside angle turns from
            // the way ahead to the way back counter-clockwise.
            let inside = (f[0] * b[1] - f[1] * b[0])
                .atan2(dot(f, b))
                .rem_euclid(std::f64::consts::TAU)
                .to_degrees();
            if inside < corner_deg {
                corners += 1;
            }
        }
        sides.push(corners);
    }
    sides
}

/// Three-way junctions of the crack graph: each junction's angles between its arms,
/// an arm's direction taken to the point `arm` (world units, straight-line) along it
/// (or to the next junction or end, when nearer), in the plane of `normal` when it is
/// nonzero (else the plane of the two arms farthest from parallel). A junction is Y
/// when all three angles lie within 90..150 degrees, T when one exceeds 150. Returns
/// the counts, the Y share, the mean largest angle, the mean absolute deviation of the
/// angles from 120 degrees and a histogram of the angles in 12 bins of 15 degrees.
pub fn junction_stats(graph: &CrackGraph, arm: f64, normal: P3) -> Value {
    let (mut y, mut t, mut largest, mut deviation) = (0usize, 0usize, 0.0, 0.0);
    let mut hist = [0usize; 12];
    let mut count = 0usize;
    for v in 0..graph.nodes.len() {
        if graph.degree[v] != 3 {
            continue;
        }
        let p = graph.nodes[v];
        let dirs: Vec<P3> = graph.adjacency[v]
            .iter()
            .map(|&(first, _)| {
                let (mut prev, mut cur) = (v, first);
                for _ in 0..graph.nodes.len() {
                    if dist(graph.nodes[cur], p) >= arm || graph.degree[cur] != 2 || cur == v {
                        break;
                    }
                    let next = graph.adjacency[cur]
                        .iter()
                        .map(|&(m, _)| m)
                        .find(|&m| m != prev)
                        .unwrap_or(prev);
                    prev = cur;
                    cur = next;
                }
                sub(graph.nodes[cur], p)
            })
            .collect();
        let nrm = if norm(normal) > 0.0 {
            unit(normal)
        } else {
            let planes = [(0, 1), (1, 2), (0, 2)].map(|(i, j)| cross(dirs[i], dirs[j]));
            let w = planes
                .into_iter()
                .fold([0.0; 3], |m, c| if norm(c) > norm(m) { c } else { m });
            if norm(w) == 0.0 {
                continue;
            }
            unit(w)
        };
        let flat: Vec<P3> = dirs
            .iter()
            .map(|&d| {
                let along = dot(d, nrm);
                sub(d, nrm.map(|x| x * along))
            })
            .collect();
        if flat.iter().any(|d| norm(*d) == 0.0) {
            continue;
        }
        let e1 = unit(flat[0]);
        let e2 = cross(nrm, e1);
        let tau = std::f64::consts::TAU;
        let mut ang: Vec<f64> = flat
            .iter()
            .map(|&d| dot(d, e2).atan2(dot(d, e1)).rem_euclid(tau))
            .collect();
        ang.sort_by(f64::total_cmp);
        let gaps = [ang[1] - ang[0], ang[2] - ang[1], tau - ang[2] + ang[0]].map(f64::to_degrees);
        count += 1;
        for g in gaps {
            hist[((g / 15.0) as usize).min(11)] += 1;
            deviation += (g - 120.0).abs() / 3.0;
        }
        largest += gaps.iter().copied().fold(0.0, f64::max);
        if gaps.iter().any(|&g| g > 150.0) {
            t += 1;
        } else if gaps.iter().all(|&g| (90.0..=150.0).contains(&g)) {
            y += 1;
        }
    }
    serde_json::json!({
        "three_way": count,
        "y": y,
        "t": t,
        "y_share": ratio(y as f64, count as f64),
        "mean_largest_angle": ratio(largest, count as f64),
        "mean_deviation_from_120": ratio(deviation, count as f64),
        "angle_histogram_15deg": hist,
        "arm": arm,
    })
}

/// Mean equivalent-circle diameter sqrt(4 A / pi) of the areas, world units (0 when empty).
pub fn cell_diameters(areas: &[f64]) -> f64 {
    let d = |a: &f64| (4.0 * a / std::f64::consts::PI).sqrt();
    ratio(areas.iter().map(d).sum(), areas.len() as f64)
}

/// Impact statistics of crack lines around `center` (straight-line distance, which is
/// the surface's on a plate) with reference radius `radius`: per band of 0.1 R out to
/// 1.5 R the crack length, the length per area of the band's annulus, and the shares
/// of radial (within 30 degrees of the direction away from the center, measured in the
/// plane normal to `normal`), concentric (within 30 degrees of perpendicular to it)
/// and oblique length (a random network has a third of each); the largest share of the
/// total length in any band 0.05 R wide (a ring where the pattern is cut off shows as a
/// peak); and how many segments cross the circles at 0.25 R, 0.5 R and 0.75 R (a star of
/// N straight radial cracks crosses each N times), and at 0.5 R those within 30 degrees
/// of the way out from the hit (the radial cracks there). Segments are split into 64 pieces so
/// that long ones are binned where they lie.
pub fn impact_stats(lines: &[Seg], center: P3, normal: P3, radius: f64) -> Value {
    let n = unit(normal);
    let flat = |p: P3| {
        let d = sub(p, center);
        let h = dot(d, n);
        [d[0] - h * n[0], d[1] - h * n[1], d[2] - h * n[2]]
    };
    let disc = |a: f64, b: f64| std::f64::consts::PI * (b * b - a * a);
    let mut s = impact_stats_by(lines, radius, |p| norm(flat(p)), disc);
    s["center"] = serde_json::json!(center);
    s
}

/// [`impact_stats`] along a surface: distances from the hit are `surface`'s (geodesic, so a
/// crack is radial when it runs along the distance's gradient on the surface, whatever the
/// surface's curvature), and each band's area is the surface's own area in it.
pub fn impact_stats_on_surface(lines: &[Seg], surface: &SurfaceDistance, radius: f64) -> Value {
    let mut s = impact_stats_by(
        lines,
        radius,
        |p| surface.at(p),
        |a, b| surface.area_between(a, b),
    );
    s["center"] = serde_json::json!(surface.source);
    s
}

/// The impact measure with distance from the hit `d` and the area between two distances
/// `area(a, b)`: each segment cut in 64 pieces binned by their middles' distances; a segment
/// (a straight piece of crack, a fraction of a cell) radial when its distance changes by at
/// least cos 30 of its length, concentric when by at most sin 30. (Judged per piece, the
/// surface distance's own wobble between its graph's points read as direction: great circles
/// from the hit on a UV sphere of 400 x 200 measured 0.89-0.91 radial, its geodesic circles
/// 0.92 concentric; per segment 1.0 and 1.0.)
fn impact_stats_by(
    lines: &[Seg],
    radius: f64,
    d: impl Fn(P3) -> f64,
    area_between: impl Fn(f64, f64) -> f64,
) -> Value {
    let bands = 15;
    let mut len = vec![0.0; bands];
    let mut radial = vec![0.0; bands];
    let mut conc = vec![0.0; bands];
    let fine = 30;
    let mut fine_len = vec![0.0; fine];
    let mut total = 0.0;
    let cos30 = (30f64).to_radians().cos();
    let sin30 = 0.5;
    let pieces = 64;
    for s in lines {
        let mut dp = d(s[0]);
        let whole = ((d(s[1]) - dp) / seg_len(s)).abs();
        for k in 0..pieces {
            let p = lerp(s[0], s[1], k as f64 / pieces as f64);
            let q = lerp(s[0], s[1], (k + 1) as f64 / pieces as f64);
            let dq = d(q);
            let l = dist(p, q);
            let (d0, d1) = (dp, dq);
            dp = dq;
            if l == 0.0 {
                continue;
            }
            let r = 0.5 * (d0 + d1);
            total += l;
            let fi = (r / (0.05 * radius)) as usize;
            if fi < fine {
                fine_len[fi] += l;
            }
            let bi = (r / (0.1 * radius)) as usize;
            if bi >= bands || r == 0.0 {
                continue;
            }
            len[bi] += l;
            if whole >= cos30 {
                radial[bi] += l;
            } else if whole <= sin30 {
                conc[bi] += l;
            }
        }
    }
    let crossings = |rc: f64| {
        lines
            .iter()
            .filter(|s| (d(s[0]) - rc) * (d(s[1]) - rc) < 0.0)
            .count()
    };
    // Crossing segments radial as the bands count them (within 30 degrees of the way
    // out from the hit): arcs along the circle are no radial cracks however often
    // they wiggle across it.
    let radial_crossings = |rc: f64| {
        lines
            .iter()
            .filter(|s| {
                let (da, db) = (d(s[0]), d(s[1]));
                (da - rc) * (db - rc) < 0.0 && (db - da).abs() >= cos30 * seg_len(s)
            })
            .count()
    };
    let band: Vec<Value> = (0..bands)
        .map(|i| {
            let (r0, r1) = (0.1 * i as f64 * radius, 0.1 * (i + 1) as f64 * radius);
            let area = area_between(r0, r1);
            serde_json::json!({
                "from": 0.1 * i as f64, "length": len[i], "per_area": len[i] / area,
                "radial": ratio(radial[i], len[i]), "concentric": ratio(conc[i], len[i]),
            })
        })
        .collect();
    let sum = |v: &[f64], a: usize, b: usize| v[a..b].iter().sum::<f64>();
    let area = |a: f64, b: f64| area_between(a * radius, b * radius);
    serde_json::json!({
        "radius": radius, "total_length": total,
        "bands": band,
        "radial_share_0.2_0.8": ratio(sum(&radial, 2, 8), sum(&len, 2, 8)),
        "concentric_share_0.2_0.8": ratio(sum(&conc, 2, 8), sum(&len, 2, 8)),
        "per_area_0_0.3": sum(&len, 0, 3) / area(0.0, 0.3),
        "per_area_0.6_0.9": sum(&len, 6, 9) / area(0.6, 0.9),
        "max_band_share_0.05": fine_len.iter().fold(0.0f64, |m, &x| m.max(ratio(x, total))),
        "share_beyond_1.1": ratio(total - sum(&len, 0, 11).min(total), total),
        "crossings_0.25": crossings(0.25 * radius),
        "crossings_0.5": crossings(0.5 * radius),
        "crossings_0.75": crossings(0.75 * radius),
        "radial_crossings_0.5": radial_crossings(0.5 * radius),
    })
}

// ---- Distance along a surface ----

/// Distance along a triangulated surface from one point (`source`, on or near it): Dijkstra
/// over the faces' corners and `steiner` evenly spaced points on each edge, every two points of
/// one face joined by the straight line across it, so a path is a polyline through the faces
/// (within a few percent of the geodesic with 4-6 points per edge). Corners closer than 1e-7 of
/// the diagonal are welded (seams of UVs or normals do not stop a path). A point's distance is
/// the shortest straight line across its nearest face to that face's points (or to the source
/// in its own face).
pub struct SurfaceDistance {
    /// The surface point nearest the given source.
    pub source: P3,
    tris: Vec<Tri>,
    /// Per face: its points' ids (corners, then each edge's Steiner points).
    face_points: Vec<Vec<usize>>,
    pos: Vec<P3>,
    dist: Vec<f64>,
    source_face: usize,
    faces: Grid,
    /// Per face, 64 sub-triangles' (distance at the centroid, area).
    samples: Vec<(f64, f64)>,
}

/// The point of triangle `t` nearest `p` (Ericson, Real-Time Collision Detection 5.1.5).
pub fn closest_on_triangle(p: P3, t: &Tri) -> P3 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return lerp(a, b, d1 / (d1 - d3));
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return lerp(a, c, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return lerp(b, c, (d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    [0, 1, 2].map(|i| a[i] + ab[i] * v + ac[i] * w)
}

impl SurfaceDistance {
    /// Distances over `tris` from the surface point nearest `source`.
    pub fn new(tris: &[Tri], source: P3, steiner: usize) -> Self {
        let (lo, hi) = bounds(tris.iter().flatten());
        let corners: Vec<P3> = tris.iter().flatten().copied().collect();
        let (mut pos, map) = weld_points(&corners, 1e-7 * diagonal(lo, hi));
        let mut edge_points: BTreeMap<[usize; 2], Vec<usize>> = BTreeMap::new();
        let mut face_points = Vec::with_capacity(tris.len());
        for t in 0..tris.len() {
            let ids = [map[3 * t], map[3 * t + 1], map[3 * t + 2]];
            let mut pts = ids.to_vec();
            for k in 0..3 {
                let (a, b) = (ids[k].min(ids[(k + 1) % 3]), ids[k].max(ids[(k + 1) % 3]));
                let on_edge = edge_points.entry([a, b]).or_insert_with(|| {
                    (1..=steiner)
                        .map(|i| {
                            pos.push(lerp(pos[a], pos[b], i as f64 / (steiner + 1) as f64));
                            pos.len() - 1
                        })
                        .collect()
                });
                pts.extend_from_slice(on_edge);
            }
            face_points.push(pts);
        }
        let mean_edge = tris.iter().map(|t| dist(t[0], t[1])).sum::<f64>() / tris.len() as f64;
        let mut faces = Grid::new(mean_edge);
        for (f, t) in tris.iter().enumerate() {
            let (tl, th) = bounds(t.iter());
            let (kl, kh) = (faces.key(tl), faces.key(th));
            for x in kl.0..=kh.0 {
                for y in kl.1..=kh.1 {
                    for z in kl.2..=kh.2 {
                        faces.map.entry((x, y, z)).or_default().push(f as u32);
                    }
                }
            }
        }
        let mut me = SurfaceDistance {
            source,
            tris: tris.to_vec(),
            face_points,
            dist: vec![f64::INFINITY; pos.len()],
            pos,
            source_face: 0,
            faces,
            samples: Vec::new(),
        };
        me.source_face = me.nearest_face(source);
        me.source = closest_on_triangle(source, &me.tris[me.source_face]);
        me.dijkstra();
        me.samples = me.sample_areas();
        me
    }

    fn nearest_face(&self, p: P3) -> usize {
        let mut best = (f64::INFINITY, usize::MAX);
        // A face within `r` of `p` has its box within `r`, so the search is done once the
        // best face found lies within the radius searched.
        let mut r = self.faces.cell;
        loop {
            self.faces.near(p, r, |f| {
                let d = dist(p, closest_on_triangle(p, &self.tris[f]));
                if d < best.0 || (d == best.0 && f < best.1) {
                    best = (d, f);
                }
                false
            });
            if best.0 <= r {
                return best.1;
            }
            r = best.0.max(2.0 * r);
        }
    }

    fn dijkstra(&mut self) {
        use std::cmp::Reverse;
        use std::collections::BinaryHeap;
        let mut faces_of: Vec<Vec<u32>> = vec![Vec::new(); self.pos.len()];
        for (f, pts) in self.face_points.iter().enumerate() {
            for &p in pts {
                faces_of[p].push(f as u32);
            }
        }
        let mut heap = BinaryHeap::new();
        for &p in &self.face_points[self.source_face] {
            let d = dist(self.source, self.pos[p]);
            if d < self.dist[p] {
                self.dist[p] = d;
                heap.push(Reverse((d.to_bits(), p)));
            }
        }
        while let Some(Reverse((bits, p))) = heap.pop() {
            let d = f64::from_bits(bits);
            if d > self.dist[p] {
                continue;
            }
            for &f in &faces_of[p] {
                for &q in &self.face_points[f as usize] {
                    let dq = d + dist(self.pos[p], self.pos[q]);
                    if dq < self.dist[q] {
                        self.dist[q] = dq;
                        heap.push(Reverse((dq.to_bits(), q)));
                    }
                }
            }
        }
    }

    /// Distance of `p` (on or near the surface) from the source along the surface.
    pub fn at(&self, p: P3) -> f64 {
        self.in_face(p, self.nearest_face(p))
    }

    fn in_face(&self, p: P3, f: usize) -> f64 {
        let mut d = self.face_points[f]
            .iter()
            .map(|&q| self.dist[q] + dist(p, self.pos[q]))
            .fold(f64::INFINITY, f64::min);
        if f == self.source_face {
            d = d.min(dist(p, self.source));
        }
        d
    }

    fn sample_areas(&self) -> Vec<(f64, f64)> {
        let k = 8;
        let mut out = Vec::with_capacity(self.tris.len() * k * k);
        for (f, t) in self.tris.iter().enumerate() {
            let area = 0.5 * norm(cross(sub(t[1], t[0]), sub(t[2], t[0]))) / (k * k) as f64;
            let at = |i: f64, j: f64| {
                let (u, v) = (i / k as f64, j / k as f64);
                [0, 1, 2].map(|c| t[0][c] + u * (t[1][c] - t[0][c]) + v * (t[2][c] - t[0][c]))
            };
            for i in 0..k {
                for j in 0..k - i {
                    let (fi, fj) = (i as f64, j as f64);
                    // The upward sub-triangle, and the downward one beside it.
                    let c = at(fi + 1.0 / 3.0, fj + 1.0 / 3.0);
                    out.push((self.in_face(c, f), area));
                    if i + j + 1 < k {
                        let c = at(fi + 2.0 / 3.0, fj + 2.0 / 3.0);
                        out.push((self.in_face(c, f), area));
                    }
                }
            }
        }
        out
    }

    /// The surface's area at distances in `[a, b)` from the source.
    pub fn area_between(&self, a: f64, b: f64) -> f64 {
        self.samples
            .iter()
            .filter(|(d, _)| *d >= a && *d < b)
            .map(|(_, w)| w)
            .sum()
    }
}

// ---- Gap widths ----

/// Widths of the gaps of a plate's opened cracks: from the middle of every outline edge of the
/// top surface `top` (edges used by one triangle, corners welded within `weld_rel` of the
/// diagonal), projected onto the plate's plane (`flat` the axis across it), straight out of its
/// triangle to the nearest other outline edge, at most `reach` away. Edges within `margin` of the
/// plate's outer border are left out. `(width, edge length)` per edge that reaches another
/// outline; a gap that pinches shut shows as widths near zero.
pub fn gap_widths(
    top: &[Tri],
    flat: usize,
    weld_rel: f64,
    margin: f64,
    reach: f64,
) -> Vec<(f64, f64)> {
    let (u, v) = plane_axes(flat);
    let (lo, hi) = bounds(top.iter().flatten());
    let points: Vec<P3> = top.iter().flatten().copied().collect();
    let (nodes, map) = weld_points(&points, weld_rel * diagonal(lo, hi));
    let flat_p = |p: P3| [p[u], p[v], 0.0];
    // Directed edges with the corner across, counted undirected.
    let mut uses: BTreeMap<[usize; 2], (usize, [usize; 3])> = BTreeMap::new();
    for t in 0..top.len() {
        for k in 0..3 {
            let (a, b, c) = (
                map[3 * t + k],
                map[3 * t + (k + 1) % 3],
                map[3 * t + (k + 2) % 3],
            );
            if a != b {
                let e = uses.entry([a.min(b), a.max(b)]).or_insert((0, [a, b, c]));
                e.0 += 1;
            }
        }
    }
    let outline: Vec<([P3; 2], P3)> = uses
        .values()
        .filter(|(n, _)| *n == 1)
        .map(|(_, [a, b, c])| ([flat_p(nodes[*a]), flat_p(nodes[*b])], flat_p(nodes[*c])))
        .collect();
    let segs: Vec<Seg> = outline.iter().map(|(s, _)| *s).collect();
    let cell = mean_len(&segs).max(1e-12);
    let grid = segment_grid(&segs, cell);
    let (flo, fhi) = (flat_p(lo), flat_p(hi));
    let mut out = Vec::new();
    for (i, (s, c)) in outline.iter().enumerate() {
        let m = mid(s);
        if m[0] - flo[0] < margin
            || fhi[0] - m[0] < margin
            || m[1] - flo[1] < margin
            || fhi[1] - m[1] < margin
        {
            continue;
        }
        let e = sub(s[1], s[0]);
        let mut n = [-e[1], e[0], 0.0];
        if dot(n, sub(*c, m)) > 0.0 {
            n = [e[1], -e[0], 0.0];
        }
        if norm(n) == 0.0 {
            continue;
        }
        let n = unit(n);
        // The first other outline edge the ray from m along n meets.
        let mut best = f64::INFINITY;
        let steps = (reach / cell).ceil() as usize + 1;
        for k in 0..=steps {
            let q = [
                m[0] + n[0] * k as f64 * cell,
                m[1] + n[1] * k as f64 * cell,
                0.0,
            ];
            grid.near(q, cell, |j| {
                if j != i {
                    let [a, b] = segs[j];
                    let d = sub(b, a);
                    let den = n[0] * d[1] - n[1] * d[0];
                    if den.abs() > 1e-300 {
                        let w = sub(a, m);
                        let t = (w[0] * d[1] - w[1] * d[0]) / den;
                        let s2 = (w[0] * n[1] - w[1] * n[0]) / den;
                        if t > 1e-12 * cell && (0.0..=1.0).contains(&s2) && t < best {
                            best = t;
                        }
                    }
                }
                false
            });
            if best <= k as f64 * cell {
                break;
            }
        }
        if best <= reach {
            out.push((best, seg_len(s)));
        }
    }
    out
}

/// The length-weighted share of `widths` (from [`gap_widths`]) below `fraction` of their
/// length-weighted median: where the gaps pinch.
pub fn pinched_share(widths: &[(f64, f64)], fraction: f64) -> f64 {
    let mut w = widths.to_vec();
    w.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = w.iter().map(|x| x.1).sum();
    let mut acc = 0.0;
    let mut median = 0.0;
    for x in &w {
        acc += x.1;
        if acc >= 0.5 * total {
            median = x.0;
            break;
        }
    }
    let below: f64 = w
        .iter()
        .filter(|x| x.0 < fraction * median)
        .map(|x| x.1)
        .sum();
    ratio(below, total)
}
