//! Wavefront OBJ reader (with its MTL material libraries).
//!
//! The text is read in one pass: continuation lines are joined, numbers
//! parsed and checked, indices checked and made absolute, `o`/`g`/`usemtl`
//! state changes become numbered sections (so objects and groups stay
//! distinct), empty `usemtl` means "no material", `l`/`p` elements are
//! dropped with a warning. MTL files are cleaned before `tobj` reads them,
//! and texture-map options are parsed here.
//!
//! Mapping: one [`Mesh`] and one root [`Node`] per OBJ object (`o`; the part
//! of the file before the first `o` is an object named after the file), one
//! [`Primitive`] per (group, material) in order of first use, polygons
//! triangulated with [`triangulate_polygon`] (correct for concave faces).

use crate::geometry::triangulate_polygon;
use crate::io::IoError as Error;
use crate::scene::{
    Geometry, Material, Mesh, Node, Primitive, Scene, SceneRoot, TriGeometry, VertexAttribute,
};
use serde_json::Map;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

mod chunked;
mod mtl;
mod prim;
mod words;
use mtl::*;
use words::{corner_parts, split_keyword, strip_comment, words};
use prim::PrimBuilder;

/// Read an OBJ file (and the MTL libraries and textures it names, all inside
/// its folder) into a [`Scene`].
///
/// # Errors
/// [`Error::Io`] when the file cannot be read; [`Error::Obj`] naming the
/// line when it is malformed (bad number, index out of range...) or has no
/// face ([`ObjError`]). Missing material libraries and textures are only warnings
/// ([`Scene::warnings`]).
pub fn read_obj(path: &Path) -> Result<Scene, Error> {
    read_obj_with(path, &crate::io::ReadOptions::default())
}

/// [`read_obj`] within `options.max_memory`: the file (held whole) and its
/// objects ([`crate::io::PRIMITIVE_BYTES`] each) are checked against it
/// before they are built.
///
/// # Errors
/// Those of [`read_obj`]; a file or an object count over the budget.
pub fn read_obj_with(path: &Path, options: &crate::io::ReadOptions) -> Result<Scene, Error> {
    let bytes = crate::io::paths::read_capped(
        path,
        crate::io::model_cap(options.max_memory),
        crate::io::model_what(options.max_memory),
    )
    .map_err(|e| Error::io(path, e))?;
    let base_dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().map_or_else(
        || "model.obj".to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    read_impl(&bytes, &base_dir, &name, path, options.max_memory, true)
}

/// Read OBJ text as if it were the file `name` in the folder `base_dir`
/// (material libraries and textures are looked up there).
///
/// # Errors
/// As [`read_obj`]; errors name `base_dir/name`.
pub fn read_obj_from_str(text: &str, base_dir: &Path, name: &str) -> Result<Scene, Error> {
    read_impl(
        text.as_bytes(),
        base_dir,
        name,
        &base_dir.join(name),
        crate::io::DEFAULT_MAX_MEMORY,
        true,
    )
}

/// Read OBJ text held in memory, `name` naming it in messages; no file is
/// read: a material library it names is refused (by the parser's own
/// reading of the text, so no spelling of the line slips past).
///
/// # Errors
/// As [`read_obj`], and an `mtllib` line, naming the library.
pub fn read_obj_from_memory(text: &str, name: &str) -> Result<Scene, Error> {
    read_impl(
        text.as_bytes(),
        Path::new(""),
        name,
        Path::new(name),
        crate::io::DEFAULT_MAX_MEMORY,
        false,
    )
}

/// Marks an absent texture-coordinate or normal index.
const ABSENT: u32 = u32::MAX;

/// One face corner: 0-based indices into the file's `v`, `vt`, `vn` lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Corner {
    v: u32,
    vt: u32,
    vn: u32,
}

/// A run of the file with one (object, group, material) state.
#[derive(Clone, Debug, PartialEq)]
struct Section {
    object: usize,
    group: Option<String>,
    material: Option<String>,
}

/// One face: `len` corners from `start` in its [`Part`]'s corners.
#[derive(Clone, Copy, Debug)]
struct FaceRec {
    section: usize,
    start: usize,
    len: usize,
}

/// Faces in file order with the corners they name.
#[derive(Default)]
struct Part {
    faces: Vec<FaceRec>,
    corners: Vec<Corner>,
}

/// The parsed file: its numbers, sections, faces and what else it held.
#[derive(Default)]
struct Prepared {
    /// The vertex data by file index (`v` positions divided by `w`).
    data: Data,
    /// The material libraries named by `mtllib`, in order.
    libraries: Vec<String>,
    objects: Vec<String>,
    sections: Vec<Section>,
    /// The faces, in file order (one part per chunk of the text).
    parts: Vec<Part>,
    /// The faces and corners of the text being parsed (moved into `parts`).
    faces: Vec<FaceRec>,
    corners: Vec<Corner>,
    /// Parsing one chunk of the text ([`chunked`]): `o`/`g`/`usemtl`
    /// statements are kept here in order (a face's `section` is how many
    /// came before it in the chunk), not applied.
    events: Option<Vec<chunked::Event>>,
    /// Parsing a chunk: per kind (v, vt, vn), the fewest elements the text
    /// before the chunk must define for its indices to be in range.
    need: [i64; 3],
    /// Parsing a chunk: some index is relative (negative), stored as
    /// [`chunked::REL`] plus its offset from the chunk's start.
    relative: bool,
    colored: usize,
    skipped_elements: usize,
    short_faces: usize,
    freeform: usize,
    odd_vertex_lines: usize,
}

/// Read OBJ `text` (the file `name` in `base_dir`, `path` in messages)
/// within `max_memory`; with `files`, the material libraries it names are
/// read, else one is an error. Bytes that are not UTF-8 are read as U+FFFD.
fn read_impl(
    text: &[u8],
    base_dir: &Path,
    name: &str,
    path: &Path,
    max_memory: u64,
    files: bool,
) -> Result<Scene, Error> {
    // A UTF-8 byte-order mark (Windows editors write one) is not part of
    // the first line: left there, it hid that line (often the `mtllib`).
    let text = text.strip_prefix("\u{feff}".as_bytes()).unwrap_or(text);
    let stem = Path::new(name)
        .file_stem()
        .map_or_else(|| name.to_string(), |s| s.to_string_lossy().into_owned());
    let fail = |error| Error::Obj {
        path: path.to_path_buf(),
        error,
    };
    let mut prep = chunked::prepare(text, &stem, chunked::CHUNK_BYTES).map_err(fail)?;
    let n_v = prep.data.positions.len();
    let strip_colors = prep.colored > 0 && prep.colored < n_v;
    if prep.colored < n_v {
        prep.data.colors = Vec::new();
    }
    if prep.parts.iter().all(|p| p.faces.is_empty()) {
        return Err(fail(ObjError::NoFaces));
    }
    // Each (object, group, material) becomes a primitive.
    crate::io::check_primitive_count(
        primitive_count(&prep),
        "objects (one per object, group and material)",
        max_memory,
    )
    .map_err(|e| fail(e.into()))?;
    let mut warnings = skipped_warnings(&prep, name, strip_colors);

    // The material libraries: the one place an OBJ reads another file,
    // refused when reading from memory.
    let mut mtl = MtlState::default();
    for lib in &prep.libraries {
        if !files {
            return Err(fail(ObjError::LibraryInMemory {
                library: lib.clone(),
            }));
        }
        mtl.load_libraries(base_dir, name, Path::new(lib));
    }
    warnings.extend(mtl.warnings.iter().cloned());
    let data = std::mem::take(&mut prep.data);

    // Every library the OBJ names, found or not (a batch rebuilds when a
    // missing one appears).
    let mut sources: Vec<PathBuf> = mtl.loaded.iter().cloned().collect();
    sources.sort();
    let mut scene = Scene {
        warnings,
        sources,
        ..Default::default()
    };
    let mut materials = MaterialBuilder {
        base_dir,
        lib: &mtl.materials,
        by_name: HashMap::new(),
        textures: HashMap::new(),
        file_names: HashSet::new(),
    };
    let parts = std::mem::take(&mut prep.parts);
    let (objects, unreferenced) =
        object_primitives(&prep, parts, &data, &mut materials, &mut scene);
    add_objects(objects, &prep, &data, &mut scene);
    // Positions no face uses are not carried into the scene: say how many.
    if unreferenced > 0 {
        scene.warnings.push(format!(
            "{unreferenced} vertices are not used by any face and are left out"
        ));
    }
    scene.scenes = vec![SceneRoot {
        name: None,
        nodes: (0..scene.nodes.len()).collect(),
        rest: Map::new(),
    }];
    scene.default_scene = Some(0);
    // And every texture the materials name, found or not.
    scene.sources.extend(materials.textures.keys().cloned());
    scene.sources.sort();
    scene.sources.dedup();
    Ok(scene)
}

/// The number of primitives the file makes: its distinct (object, group,
/// material) states that hold a face.
fn primitive_count(prep: &Prepared) -> usize {
    let mut used = vec![false; prep.sections.len()];
    for f in prep.parts.iter().flat_map(|p| &p.faces) {
        used[f.section] = true;
    }
    prep.sections
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(s, _)| (s.object, s.group.as_deref(), s.material.as_deref()))
        .collect::<HashSet<_>>()
        .len()
}

/// The warnings about what of the file `name` is not read (partial
/// colours, points and lines, short faces, free-form geometry, vertex
/// lines with 5 values).
fn skipped_warnings(prep: &Prepared, name: &str, strip_colors: bool) -> Vec<String> {
    let mut warnings = Vec::new();
    if strip_colors {
        warnings.push(format!(
            "{name}: only some vertices have a colour; vertex colours are ignored"
        ));
    }
    if prep.skipped_elements > 0 {
        warnings.push(format!(
            "{name}: {} point/line element(s) (p, l) ignored: only faces are read",
            prep.skipped_elements
        ));
    }
    if prep.short_faces > 0 {
        warnings.push(format!(
            "{name}: {} face(s) with fewer than 3 vertices ignored",
            prep.short_faces
        ));
    }
    if prep.freeform > 0 {
        warnings.push(format!("{name}: free-form curves/surfaces (curv, curv2, surf) are not supported and were ignored"));
    }
    if prep.odd_vertex_lines > 0 {
        warnings.push(format!(
            "{name}: {} vertex line(s) with 5 values (neither w nor r g b): the extra values were ignored",
            prep.odd_vertex_lines
        ));
    }
    warnings
}

/// The faces of `parts` gathered into primitives per object, in order of
/// first use (one per group and material; materials added to `scene` as
/// met), and the number of positions no face uses. Each part is dropped
/// once read.
fn object_primitives(
    prep: &Prepared,
    parts: Vec<Part>,
    data: &Data,
    materials: &mut MaterialBuilder<'_>,
    scene: &mut Scene,
) -> (Vec<Vec<PrimBuilder>>, usize) {
    let mut objects: Vec<Vec<PrimBuilder>> = vec![Vec::new(); prep.objects.len()];
    let mut prim_of_section: Vec<Option<usize>> = vec![None; prep.sections.len()];
    let mut scratch = prim::Scratch::new(data.positions.len());
    for part in parts {
        for face in &part.faces {
            let prim = match prim_of_section[face.section] {
                Some(p) => p,
                None => {
                    let section = &prep.sections[face.section];
                    let material = section
                        .material
                        .as_ref()
                        .and_then(|m| materials.material(m, scene))
                        .or_else(|| Some(default_material(scene)));
                    let prims = &mut objects[section.object];
                    let p = match prims
                        .iter()
                        .position(|p| p.group == section.group && p.material == material)
                    {
                        Some(p) => p,
                        None => {
                            prims.push(PrimBuilder::new(
                                section.group.clone(),
                                material,
                                &mut scratch,
                            ));
                            prims.len() - 1
                        }
                    };
                    prim_of_section[face.section] = Some(p);
                    p
                }
            };
            let object = prep.sections[face.section].object;
            let corners = &part.corners[face.start..face.start + face.len];
            objects[object][prim].add_face(corners, &data.positions, &mut scratch);
        }
    }
    let unreferenced = scratch.unused_positions();
    (objects, unreferenced)
}

/// One mesh and one root node per object with a primitive, into `scene`.
fn add_objects(objects: Vec<Vec<PrimBuilder>>, prep: &Prepared, data: &Data, scene: &mut Scene) {
    let has_colors = !data.colors.is_empty();
    for (object, prims) in objects.into_iter().enumerate() {
        if prims.is_empty() {
            continue;
        }
        let object_name = &prep.objects[object];
        let primitives = prims
            .into_iter()
            .map(|p| p.finish(data, has_colors, object_name, scene))
            .collect();
        scene.meshes.push(Mesh {
            name: Some(object_name.clone()),
            primitives,
            ..Default::default()
        });
        scene.nodes.push(Node {
            name: Some(object_name.clone()),
            mesh: Some(scene.meshes.len() - 1),
            ..Default::default()
        });
    }
}

// ---------------------------------------------------------------------------
// Preprocessing of the OBJ text

/// Call `f` with every logical line (continuation lines joined) and the
/// number of its first physical line.
fn logical_lines(
    text: &str,
    mut f: impl FnMut(&str, usize) -> Result<(), ObjError>,
) -> Result<(), ObjError> {
    let mut pending = String::new();
    let mut pending_no = 0;
    for (i, raw) in text.lines().enumerate() {
        let t = raw.trim_end();
        if let Some(head) = t.strip_suffix('\\') {
            if pending.is_empty() {
                pending_no = i + 1;
            }
            pending.push_str(head);
            pending.push(' ');
            continue;
        }
        if pending.is_empty() {
            f(raw, i + 1)?;
        } else {
            pending.push_str(raw);
            f(&pending, pending_no)?;
            pending.clear();
        }
    }
    if !pending.is_empty() {
        f(&pending, pending_no)?;
    }
    Ok(())
}

/// The material of faces without one (no `usemtl`, or one the MTL files do
/// not define): OBJ's plain surface, a light grey non-metal (glTF's own
/// default material is a metal, which is not what an OBJ means). Added once,
/// named `default`; its index.
fn default_material(scene: &mut Scene) -> usize {
    const NAME: &str = "default";
    if let Some(i) = scene.materials.iter().position(|m| m.name() == Some(NAME)) {
        return i;
    }
    let json = serde_json::json!({
        "name": NAME,
        "pbrMetallicRoughness": {
            "baseColorFactor": [0.8, 0.8, 0.8, 1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 0.5
        }
    });
    scene.materials.push(crate::scene::Material {
        json: json.as_object().cloned().unwrap_or_default(),
    });
    scene.materials.len() - 1
}

/// A finite number, read as `f32`.
fn number(tok: &str) -> Option<f32> {
    tok.parse::<f32>().ok().filter(|x| x.is_finite())
}

/// The state at the start of a file: its first object (named `stem`), no
/// group, no material.
fn start_state(stem: &str) -> (Prepared, Section) {
    let state = Section {
        object: 0,
        group: None,
        material: None,
    };
    let p = Prepared {
        objects: vec![stem.to_string()],
        sections: vec![state.clone()],
        ..Default::default()
    };
    (p, state)
}

/// Parse the whole text in one pass (what gives the exact error of a
/// malformed file).
fn preprocess(text: &str, stem: &str) -> Result<Prepared, ObjError> {
    let (mut p, mut state) = start_state(stem);
    logical_lines(text, |line, no| p.line(line, no, stem, &mut state))?;
    p.end_part();
    Ok(p)
}

impl Prepared {
    fn line(
        &mut self,
        line: &str,
        no: usize,
        stem: &str,
        state: &mut Section,
    ) -> Result<(), ObjError> {
        let (kw, rest) = split_keyword(line);
        match kw {
            "v" => self.vertex(strip_comment(rest), no),
            "vt" => self.texcoord(strip_comment(rest), no),
            "vn" => self.normal(strip_comment(rest), no),
            "f" | "fo" => self.face(strip_comment(rest), no),
            "l" | "p" => {
                self.skipped_elements += 1;
                Ok(())
            }
            "o" | "g" | "usemtl" => {
                let name = rest.trim();
                let name = (!name.is_empty()).then(|| name.to_string());
                let event = match kw {
                    "o" => chunked::Event::Object(name),
                    "g" => chunked::Event::Group(name),
                    _ => chunked::Event::Material(name),
                };
                self.statement(event, stem, state);
                Ok(())
            }
            "mtllib" => {
                let lib = rest.trim();
                if !lib.is_empty() {
                    self.libraries.push(lib.to_string());
                }
                Ok(())
            }
            "curv" | "curv2" | "surf" => {
                self.freeform += 1;
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Move the faces parsed so far into a new part.
    fn end_part(&mut self) {
        self.parts.push(Part {
            faces: std::mem::take(&mut self.faces),
            corners: std::mem::take(&mut self.corners),
        });
    }

    /// Apply an `o`/`g`/`usemtl` statement to `state` (or, parsing a
    /// chunk, keep it for later).
    fn statement(&mut self, event: chunked::Event, stem: &str, state: &mut Section) {
        if let Some(events) = &mut self.events {
            events.push(event);
            return;
        }
        match event {
            chunked::Event::Object(name) => {
                self.objects.push(name.unwrap_or_else(|| stem.to_string()));
                state.object = self.objects.len() - 1;
                state.group = None;
            }
            chunked::Event::Group(name) => state.group = name,
            chunked::Event::Material(name) => state.material = name,
        }
        self.set_state(state);
    }

    /// Start a new section when the state changed.
    fn set_state(&mut self, state: &Section) {
        if self.sections.last() != Some(state) {
            self.sections.push(state.clone());
        }
    }

    fn vertex(&mut self, rest: &str, no: usize) -> Result<(), ObjError> {
        let invalid = || line(no, LineFault::Vertex {
                rest: rest.to_string(),
            });
        let mut values = [0f32; 6];
        let mut n = 0;
        for tok in words(rest) {
            let x = number(tok).ok_or_else(invalid)?;
            if n < 6 {
                values[n] = x;
            }
            n += 1;
        }
        if n < 3 {
            return Err(invalid());
        }
        let [x, y, z, a, b, c] = values;
        let mut position = [x, y, z];
        match n {
            3 => {}
            4 => {
                if a == 0.0 {
                    return Err(line(no, LineFault::ZeroW {
                        rest: rest.to_string(),
                    }));
                }
                position = position.map(|p| p / a);
            }
            5 => self.odd_vertex_lines += 1,
            _ => {
                self.colored += 1;
                // Uncoloured vertices before this one are white.
                self.data.colors.resize(self.data.positions.len(), [1.0; 3]);
                self.data.colors.push([a, b, c]);
            }
        }
        self.data.positions.push(position);
        Ok(())
    }

    fn texcoord(&mut self, rest: &str, no: usize) -> Result<(), ObjError> {
        let invalid = || line(no, LineFault::TexCoord {
                rest: rest.to_string(),
            });
        let mut uv = [0f32; 2];
        let mut n = 0;
        for tok in words(rest).take(3) {
            let x = number(tok).ok_or_else(invalid)?;
            if n < 2 {
                uv[n] = x;
            }
            n += 1;
        }
        if n == 0 {
            return Err(invalid());
        }
        self.data.texcoords.push(uv);
        Ok(())
    }

    fn normal(&mut self, rest: &str, no: usize) -> Result<(), ObjError> {
        let invalid = || line(no, LineFault::Normal {
                rest: rest.to_string(),
            });
        let mut v = [0f32; 3];
        let mut n = 0;
        for tok in words(rest).take(3) {
            v[n] = number(tok).ok_or_else(invalid)?;
            n += 1;
        }
        if n < 3 {
            return Err(invalid());
        }
        self.data.normals.push(v);
        Ok(())
    }

    fn face(&mut self, rest: &str, no: usize) -> Result<(), ObjError> {
        let start = self.corners.len();
        for tok in words(rest) {
            let parts = corner_parts(tok);
            let [v, vt, vn] = parts.unwrap_or(["", "", ""]);
            if parts.is_none() || v.is_empty() {
                self.corners.truncate(start);
                return Err(line(no, LineFault::FaceVertex {
                    token: tok.to_string(),
                }));
            }
            let corner = Corner {
                v: self.index(v, 0, no)?,
                vt: if vt.is_empty() {
                    ABSENT
                } else {
                    self.index(vt, 1, no)?
                },
                vn: if vn.is_empty() {
                    ABSENT
                } else {
                    self.index(vn, 2, no)?
                },
            };
            self.corners.push(corner);
        }
        let len = self.corners.len() - start;
        if len < 3 {
            self.corners.truncate(start);
            self.short_faces += 1;
            return Ok(());
        }
        let section = match &self.events {
            Some(events) => events.len(),
            None => self.sections.len() - 1,
        };
        self.faces.push(FaceRec {
            section,
            start,
            len,
        });
        Ok(())
    }

    /// Face index `tok` of `kind` (0 `v`, 1 `vt`, 2 `vn`) on line `no`:
    /// resolved against the elements defined so far, or, parsing a chunk,
    /// as [`chunked::chunk_index`] keeps it.
    fn index(&mut self, tok: &str, kind: usize, no: usize) -> Result<u32, ObjError> {
        let count = match kind {
            0 => self.data.positions.len(),
            1 => self.data.texcoords.len(),
            _ => self.data.normals.len(),
        };
        if self.events.is_some() {
            return chunked::chunk_index(tok, count, &mut self.need[kind], &mut self.relative);
        }
        let what = ["vertex", "texture coordinate", "normal"][kind];
        resolve_index(tok, count, what, no)
    }
}

/// A 1-based (or negative, relative) OBJ index to a 0-based one, checked
/// against the `count` elements defined so far.
fn resolve_index(tok: &str, count: usize, what: &'static str, no: usize) -> Result<u32, ObjError> {
    let i: i64 = tok.parse().map_err(|_| {
        line(
            no,
            LineFault::Index {
                what,
                token: tok.to_string(),
            },
        )
    })?;
    let idx = if i > 0 { i - 1 } else { count as i64 + i };
    if i == 0 || idx < 0 || idx >= count as i64 || idx >= ABSENT as i64 {
        return Err(line(
            no,
            LineFault::OutOfRange {
                what,
                index: i,
                count,
            },
        ));
    }
    Ok(idx as u32)
}

/// Fault `fault` of line `no`.
fn line(no: usize, fault: LineFault) -> ObjError {
    ObjError::Line { line: no, fault }
}

/// `what` (`vertex`, `normal`...) in the plural unless `count` is 1.
fn counted(what: &str, count: usize) -> String {
    match (what, count) {
        (_, 1) => what.to_string(),
        ("vertex", _) => "vertices".to_string(),
        _ => format!("{what}s"),
    }
}

/// An OBJ file that cannot be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ObjError {
    /// A malformed line.
    #[error("line {line}: {fault}")]
    Line {
        /// The line's number (its first physical line).
        line: usize,
        /// What is wrong with it.
        fault: LineFault,
    },
    /// No polygon.
    #[error("no faces: the OBJ file has no polygon (f) element to crack")]
    NoFaces,
    /// More objects than the memory budget allows.
    #[error(transparent)]
    Primitives(#[from] crate::io::PrimitiveBudgetError),
    /// A material library named by a file read from memory.
    #[error("names the material library '{library}'; an asset read from memory must hold all its data (read the file with crackle::read)")]
    LibraryInMemory {
        /// The library as the file names it.
        library: String,
    },
}

/// What is wrong with one OBJ line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LineFault {
    /// A vertex without three finite numbers.
    #[error("invalid vertex 'v {rest}' (expected x y z [w | r g b] as finite numbers)")]
    Vertex {
        /// The line after its keyword.
        rest: String,
    },
    /// A vertex with w = 0.
    #[error("vertex 'v {rest}' has w = 0")]
    ZeroW {
        /// The line after its keyword.
        rest: String,
    },
    /// A texture coordinate without a finite number.
    #[error("invalid texture coordinate 'vt {rest}' (expected u [v [w]] as finite numbers)")]
    TexCoord {
        /// The line after its keyword.
        rest: String,
    },
    /// A normal without three finite numbers.
    #[error("invalid normal 'vn {rest}' (expected x y z as finite numbers)")]
    Normal {
        /// The line after its keyword.
        rest: String,
    },
    /// A face corner that is not `v`, `v/vt`, `v//vn` or `v/vt/vn`.
    #[error("invalid face vertex '{token}' (expected v, v/vt, v//vn or v/vt/vn)")]
    FaceVertex {
        /// The corner as written.
        token: String,
    },
    /// An index that is not a number.
    #[error("invalid {what} index '{token}'")]
    Index {
        /// `vertex`, `texture coordinate` or `normal`.
        what: &'static str,
        /// The token.
        token: String,
    },
    /// An index to an element not defined before the line.
    #[error("{what} index {index} is out of range ({count} {} defined before this line)", counted(what, *count))]
    OutOfRange {
        /// `vertex`, `texture coordinate` or `normal`.
        what: &'static str,
        /// The index as written.
        index: i64,
        /// Elements defined so far.
        count: usize,
    },
}

/// The file's vertex data by file index.
#[derive(Default)]
struct Data {
    positions: Vec<[f32; 3]>,
    /// One per position when every vertex has a colour, else empty.
    colors: Vec<[f32; 3]>,
    texcoords: Vec<[f32; 2]>,
    normals: Vec<[f32; 3]>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::newell_normal;
    use crate::scene::ImageSource;
    use serde_json::json;

    /// A file of the shared evaluation data, or `None` (skip) when the data is
    /// not there; with `CI=true` missing data is a failure.
    fn eval(rel: &str) -> Option<PathBuf> {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/eval-data");
        if !root.is_dir() {
            if std::env::var("CI").as_deref() == Ok("true") {
                panic!("eval-data missing: {}", root.display());
            }
            eprintln!(
                "SKIP: eval-data not found at {} (test {rel} not run)",
                root.display()
            );
            return None;
        }
        let p = root.join(rel);
        assert!(p.is_file(), "eval file missing: {}", p.display());
        Some(p)
    }

    fn prims(scene: &Scene) -> Vec<(&Primitive, &TriGeometry)> {
        scene
            .meshes
            .iter()
            .flat_map(|m| &m.primitives)
            .map(|p| match &p.geometry {
                Geometry::Triangles(t) => (p, t),
                Geometry::Raw(_) => panic!("OBJ primitives are triangles"),
            })
            .collect()
    }

    fn tri_areas(t: &TriGeometry) -> impl Iterator<Item = f64> + '_ {
        t.triangles.iter().map(|tri| {
            let p = tri.map(|i| t.positions[i as usize].map(f64::from));
            let n = newell_normal(&p);
            (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() / 2.0
        })
    }

    fn total_area(scene: &Scene) -> f64 {
        prims(scene).iter().flat_map(|(_, t)| tri_areas(t)).sum()
    }

    fn has_warning(scene: &Scene, needle: &str) -> bool {
        scene.warnings.iter().any(|w| w.contains(needle))
    }

    fn read_str(text: &str) -> Result<Scene, Error> {
        read_obj_from_str(text, Path::new("/nonexistent-dir"), "test.obj")
    }

    fn check_consistent(scene: &Scene) {
        assert_eq!(scene.scenes.len(), 1);
        assert_eq!(scene.default_scene, Some(0));
        assert_eq!(
            scene.scenes[0].nodes,
            (0..scene.nodes.len()).collect::<Vec<_>>()
        );
        assert_eq!(scene.nodes.len(), scene.meshes.len());
        for (_, t) in prims(scene) {
            let n = t.positions.len();
            assert!(t.triangles.iter().flatten().all(|&i| (i as usize) < n));
            for a in &t.attributes {
                assert_eq!(a.len(), n, "{}", a.semantic);
            }
        }
    }

    #[test]
    fn spot_triangulated_and_quadrangulated() {
        let Some(tri) = eval("obj/spot/spot_triangulated.obj") else {
            return;
        };
        let Some(quad) = eval("obj/spot/spot_quadrangulated.obj") else {
            return;
        };
        let t = read_obj(&tri).unwrap();
        check_consistent(&t);
        assert_eq!(t.triangle_count(), 5856);
        assert_eq!(t.meshes.len(), 1);
        assert_eq!(t.meshes[0].name.as_deref(), Some("spot_triangulated"));
        // No mtllib: the plain default material.
        assert_eq!(t.materials.len(), 1);
        assert_eq!(t.materials[0].name(), Some("default"));
        assert!(prims(&t)
            .iter()
            .all(|(p, g)| p.material == Some(0) && g.attribute("TEXCOORD_0").is_some()));
        let q = read_obj(&quad).unwrap();
        check_consistent(&q);
        let quads = std::fs::read_to_string(&quad)
            .unwrap()
            .lines()
            .filter(|l| l.starts_with("f "))
            .count();
        assert_eq!(q.triangle_count(), 2 * quads);
        let (at, aq) = (total_area(&t), total_area(&q));
        assert!((at - aq).abs() < 0.02 * at, "areas {at} vs {aq}");
    }

    #[test]
    fn bunny_textured_with_negative_indices() {
        let Some(path) = eval("obj/bunny10k_textured/bunny10k_textured.obj") else {
            return;
        };
        let s = read_obj(&path).unwrap();
        check_consistent(&s);
        assert_eq!(s.triangle_count(), 9999);
        let ps = prims(&s);
        assert!(ps.iter().all(|(_, g)| g.attribute("TEXCOORD_0").is_some()));
        let m = ps[0].0.material.expect("material");
        let json = &s.materials[m].json;
        assert_eq!(json["name"], "01_-_Default");
        let tex = json["pbrMetallicRoughness"]["baseColorTexture"]["index"]
            .as_u64()
            .unwrap() as usize;
        let img = s.textures[tex]["source"].as_u64().unwrap() as usize;
        assert_read_once(&s, &s.images[img]);
        assert_eq!(s.images[img].file_name, "TextureDouble_A.png");
        assert_eq!(s.images[img].mime_type.as_deref(), Some("image/png"));
        // Kd 0.6, d 1, Ns 0.
        assert_eq!(
            json["pbrMetallicRoughness"]["baseColorFactor"],
            json!([0.6, 0.6, 0.6, 1.0])
        );
        assert_eq!(json["pbrMetallicRoughness"]["roughnessFactor"], json!(1.0));
        assert!(json.get("alphaMode").is_none());
    }

    #[test]
    fn spider_backslash_texture_paths() {
        let Some(path) = eval("obj/spider/spider.obj") else {
            return;
        };
        let s = read_obj(&path).unwrap();
        check_consistent(&s);
        assert_eq!(s.triangle_count(), 1368);
        assert_eq!(s.meshes.len(), 1);
        let ps = prims(&s);
        assert_eq!(ps.len(), 19);
        assert!(ps.iter().all(|(_, g)| g.group.is_some()));
        assert_eq!(ps[0].1.group.as_deref(), Some("HLeib01"));
        assert_eq!(s.materials.len(), 4);
        assert_eq!(s.images.len(), 4);
        assert_eq!(s.textures.len(), 4);
        for m in &s.materials {
            assert!(
                m.json["pbrMetallicRoughness"]["baseColorTexture"]["index"].is_u64(),
                "{:?}",
                m.json
            );
        }
        for img in &s.images {
            assert_read_once(&s, img);
            assert_eq!(img.mime_type.as_deref(), Some("image/jpeg"));
            assert!(!img.file_name.contains(['\\', '/']));
        }
        // The file has one zero normal (`vn 0 0 0`), used by 4 groups.
        assert_eq!(s.warnings.len(), 4, "{:?}", s.warnings);
        assert!(
            s.warnings.iter().all(|w| w.contains("NORMAL")),
            "{:?}",
            s.warnings
        );
    }

    #[test]
    fn fuze_texture_name_with_space() {
        let Some(path) = eval("obj/fuze/fuze.obj") else {
            return;
        };
        let s = read_obj(&path).unwrap();
        check_consistent(&s);
        assert_eq!(s.triangle_count(), 1000);
        assert_eq!(s.images.len(), 1);
        assert_eq!(s.images[0].file_name, "fuze uv.jpg");
        assert_read_once(&s, &s.images[0]);
        let m = &s.materials[0].json;
        assert_eq!(m["pbrMetallicRoughness"]["baseColorTexture"]["index"], 0);
        // `Tr 1` without `d`: taken as opaque, with a warning.
        assert_eq!(m["pbrMetallicRoughness"]["baseColorFactor"][3], 1.0);
        assert!(has_warning(&s, "Tr"), "{:?}", s.warnings);
        assert!(prims(&s)
            .iter()
            .all(|(_, g)| g.attribute("NORMAL").is_some() && g.attribute("TEXCOORD_0").is_some()));
    }

    #[test]
    fn polygonfaces_missing_mtllib() {
        let Some(path) = eval("obj/edge_cases/polygonfaces.obj") else {
            return;
        };
        let s = read_obj(&path).unwrap();
        check_consistent(&s);
        assert_eq!(s.triangle_count(), 3);
        assert!(has_warning(&s, "surface.mtl"), "{:?}", s.warnings);
        assert_eq!(s.meshes[0].name.as_deref(), Some("textureSurface"));
        assert_eq!(prims(&s)[0].0.material, Some(0));
        assert_eq!(s.materials.len(), 1);
        assert_eq!(s.materials[0].name(), Some("default"));
    }

    /// Polygons of an OBJ with absolute indices, parsed independently (continuation lines joined).
    fn raw_polygons(text: &str) -> Vec<Vec<[f64; 3]>> {
        let joined = text.replace("\\\r\n", " ").replace("\\\n", " ");
        let mut v = Vec::new();
        let mut polys = Vec::new();
        for line in joined.lines() {
            let mut w = line.split_whitespace();
            match w.next() {
                Some("v") => v.push([0, 1, 2].map(|_| w.next().unwrap().parse::<f64>().unwrap())),
                Some("f") => polys.push(
                    w.map(|c| v[c.split('/').next().unwrap().parse::<usize>().unwrap() - 1])
                        .collect(),
                ),
                _ => {}
            }
        }
        polys
    }

    #[test]
    fn wallhole_concave_polygons_and_continuations() {
        let Some(path) = eval("obj/edge_cases/wallhole.obj") else {
            return;
        };
        let s = read_obj(&path).unwrap();
        check_consistent(&s);
        let polys = raw_polygons(&std::fs::read_to_string(&path).unwrap());
        assert!(polys.iter().any(|p| p.len() == 11));
        let expected_tris: usize = polys.iter().map(|p| p.len() - 2).sum();
        assert_eq!(s.triangle_count(), expected_tris);
        assert_eq!(s.triangle_count(), 66);
        let poly_area: f64 = polys
            .iter()
            .map(|p| {
                let n = newell_normal(p);
                (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() / 2.0
            })
            .sum();
        let area = total_area(&s);
        assert!(
            (area - poly_area).abs() < 1e-6 * poly_area,
            "{area} vs {poly_area}"
        );
        let min = prims(&s)
            .iter()
            .flat_map(|(_, t)| tri_areas(t))
            .fold(f64::INFINITY, f64::min);
        assert!(min > 1e-3, "zero-area triangle: {min}");
        assert!(has_warning(&s, "00.mtl"), "{:?}", s.warnings);
        assert!(prims(&s).iter().all(|(p, _)| p.material == Some(0)));
        assert_eq!(s.materials.len(), 1);
    }

    #[test]
    fn negative_indices_file() {
        let Some(path) = eval("obj/edge_cases/negative_indices.obj") else {
            return;
        };
        let s = read_obj(&path).unwrap();
        check_consistent(&s);
        assert_eq!(s.triangle_count(), 12);
        let (_, g) = prims(&s)[0];
        assert!(g.attribute("TEXCOORD_0").is_some() && g.attribute("NORMAL").is_some());
        assert!(g.positions.iter().flatten().all(|c| c.abs() == 1.0));
        // The same cube with absolute indices gives the same positions.
        let text = std::fs::read_to_string(&path).unwrap();
        let nv = text.lines().filter(|l| l.starts_with("v ")).count() as i64;
        let abs: String = text
            .lines()
            .map(|l| {
                if let Some(rest) = l.strip_prefix("f ") {
                    let corners: Vec<String> = rest
                        .split_whitespace()
                        .map(|c| {
                            let v: i64 = c.split('/').next().unwrap().parse().unwrap();
                            format!("{}", if v < 0 { nv + v + 1 } else { v })
                        })
                        .collect();
                    format!("f {}\n", corners.join(" "))
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        let s2 = read_str(&abs).unwrap();
        let tris = |s: &Scene| {
            let (_, g) = prims(s)[0];
            g.triangles
                .iter()
                .map(|t| t.map(|i| g.positions[i as usize]))
                .collect::<Vec<_>>()
        };
        assert_eq!(tris(&s), tris(&s2));
    }

    #[test]
    fn groups_file() {
        let Some(path) = eval("obj/edge_cases/groups.obj") else {
            return;
        };
        let s = read_obj(&path).unwrap();
        check_consistent(&s);
        assert_eq!(s.triangle_count(), 2308);
        // 14 `g` groups, then an `o` (a second object) with 7 faces.
        assert_eq!(s.meshes.len(), 2);
        assert_eq!(s.meshes[0].name.as_deref(), Some("groups"));
        assert_eq!(s.meshes[1].name.as_deref(), Some("something!"));
        let groups: Vec<_> = s.meshes[0].primitives.iter().map(prims_group).collect();
        assert_eq!(
            groups,
            (1..=14)
                .map(|i| Some(format!("mmGroup{i}")))
                .collect::<Vec<_>>()
        );
        assert_eq!(s.meshes[1].primitives.len(), 1);
        assert!(prims(&s)
            .iter()
            .all(|(_, g)| g.attribute("NORMAL").is_some()));
    }

    fn prims_group(p: &Primitive) -> Option<String> {
        match &p.geometry {
            Geometry::Triangles(t) => t.group.clone(),
            Geometry::Raw(_) => None,
        }
    }

    #[test]
    fn two_objects_file() {
        let Some(path) = eval("obj/edge_cases/two_objects.obj") else {
            return;
        };
        let s = read_obj(&path).unwrap();
        check_consistent(&s);
        assert_eq!(s.meshes.len(), 2);
        assert_eq!(s.nodes.len(), 2);
        assert_eq!(s.nodes[0].name.as_deref(), Some("cube"));
        assert_eq!(s.nodes[1].name.as_deref(), Some("tetra"));
        assert_eq!(s.nodes[1].mesh, Some(1));
        let count = |m: &Mesh| m.primitives.iter().map(prims_tris).sum::<usize>();
        assert_eq!(count(&s.meshes[0]), 12);
        assert_eq!(count(&s.meshes[1]), 4);
        assert_eq!(s.scenes[0].nodes, vec![0, 1]);
    }

    fn prims_tris(p: &Primitive) -> usize {
        match &p.geometry {
            Geometry::Triangles(t) => t.triangles.len(),
            Geometry::Raw(_) => 0,
        }
    }

    #[test]
    fn concave_quad_face() {
        // A dart whose reflex corner is vertex 4: the 1-3 fan split would fold.
        let s = read_str("v 0 0 0\nv 2 -2 0\nv 4 0 0\nv 2 -1 0\nf 1 2 3 4\n").unwrap();
        let (_, g) = prims(&s)[0];
        assert_eq!(g.triangles.len(), 2);
        for t in &g.triangles {
            let p = t.map(|i| g.positions[i as usize].map(f64::from));
            assert!(newell_normal(&p)[2] > 0.0, "{:?}", g.triangles);
        }
        assert!((total_area(&s) - 2.0).abs() < 1e-9);
    }

    #[test]
    fn errors_name_the_problem() {
        let e = read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, Error::Obj { .. }));
        assert!(
            msg.contains("line 4")
                && msg.contains("out of range (3 vertices defined")
                && msg.contains("test.obj"),
            "{msg}"
        );
        let e = read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("out of range"), "{e}");
        let e = read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("texture coordinate index"), "{e}");
        let e = read_str("v 0 0 0\nv 1 zero 0\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("invalid vertex"), "{e}");
        let e = read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no faces"), "{e}");
        let e = read_str("").unwrap_err().to_string();
        assert!(e.contains("no faces"), "{e}");
        assert!(read_str("v 1e40 0 0\n").is_err());
        assert!(read_str("v nan 0 0\n").is_err());
        assert!(read_str("v 0 0 0 0\n").is_err());
        assert!(read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").is_err());
        assert!(read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n").is_err());
        assert!(read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3x\n").is_err());
        assert!(read_str("vn 1 0\n").is_err());
        assert!(read_str("vt\n").is_err());
    }

    #[test]
    fn garbage_does_not_panic() {
        let garbage = [
            "\0\0\0\x01",
            "f",
            "f 1",
            "f /",
            "f //",
            "f 1/ 2/ 3/",
            "v\nf 1 1 1",
            "o\ng\nusemtl\nmtllib\n",
            "\\",
            "\\\n\\\n",
        ];
        for g in garbage {
            let _ = read_str(g);
        }
        // Pseudo-random token soup.
        let toks = [
            "v", "vt", "vn", "f", "o", "g", "usemtl", "mtllib", "l", "p", "s", "1", "-1", "0",
            "2/3", "1//1", "-5/-1/2", "3/1/1", "nan", "1e50", "\\", "#", "x", "3.5", "-0.25", "\n",
            "\n", "\n",
        ];
        let mut state = 12345u64;
        for _ in 0..300 {
            let mut text = String::new();
            for _ in 0..60 {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                text.push_str(toks[(state >> 33) as usize % toks.len()]);
                text.push(' ');
            }
            let _ = read_str(&text);
        }
        let many = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n".repeat(3)
            + "f 1 2 3 4 5 6 7 8 9 10 11 12\nf 1 2 3 1 2 3\nf 1 1 1\n";
        let s = read_str(&many).unwrap();
        assert_eq!(s.triangle_count(), 10 + 4 + 1);
    }

    #[test]
    fn objects_groups_materials_and_continuations() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
                    f 1 2 3\n\
                    o first\ng left\nf 1 2 3\ng right\nf 2 4 3\ng left\nf 1 2 3\n\
                    usemtl\nf 2 4 \\\n 3\n\
                    l 1 2\np 3\n\
                    o second\nf 1 2 4\n";
        let s = read_str(text).unwrap();
        check_consistent(&s);
        let names: Vec<_> = s.meshes.iter().map(|m| m.name.clone().unwrap()).collect();
        assert_eq!(names, ["test", "first", "second"]);
        let groups: Vec<_> = s.meshes[1].primitives.iter().map(prims_group).collect();
        assert_eq!(
            groups,
            [Some("left".to_string()), Some("right".to_string())]
        );
        assert_eq!(
            s.meshes[1]
                .primitives
                .iter()
                .map(prims_tris)
                .collect::<Vec<_>>(),
            [3, 1]
        );
        assert_eq!(prims_group(&s.meshes[2].primitives[0]), None);
        assert!(has_warning(&s, "2 point/line element"), "{:?}", s.warnings);
        assert_eq!(s.triangle_count(), 6);
    }

    #[test]
    fn attributes_and_partial_attributes() {
        // Vertex colours, v flipped, normals normalized.
        let s = read_str(
            "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 2\nvt 0 0\nvt 1 0.25\nvt 0 1\nvn 0 0 2\n\
             f 1/1/1 2/2/1 3/3/1\n",
        )
        .unwrap();
        let (_, g) = prims(&s)[0];
        assert_eq!(
            g.attribute("COLOR_0").unwrap().data,
            [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        );
        assert_eq!(
            g.attribute("TEXCOORD_0").unwrap().data,
            [0.0, 1.0, 1.0, 0.75, 0.0, 0.0]
        );
        assert_eq!(g.attribute("NORMAL").unwrap().get(0), [0.0, 0.0, 1.0]);
        // Some corners without vt/vn: attributes left out with warnings.
        let s = read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2 3//1\n").unwrap();
        let (_, g) = prims(&s)[0];
        assert!(g.attribute("TEXCOORD_0").is_none() && g.attribute("NORMAL").is_none());
        assert!(
            has_warning(&s, "TEXCOORD_0") && has_warning(&s, "NORMAL"),
            "{:?}",
            s.warnings
        );
        // Zero normal.
        let s = read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n").unwrap();
        assert!(prims(&s)[0].1.attribute("NORMAL").is_none());
        assert!(has_warning(&s, "zero"), "{:?}", s.warnings);
        // Colours on only some vertices: ignored with a warning.
        let s = read_str("v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert!(prims(&s)[0].1.attribute("COLOR_0").is_none());
        assert!(has_warning(&s, "colour"), "{:?}", s.warnings);
        // A fourth value is w (positions divided by it; 0 is an error); a
        // fifth is neither w nor a colour: ignored with a warning.
        let s = read_str("v 2 0 0 2\nv 0 4 0 4\nv 0 0 1 0.5\nf 1 2 3\n").unwrap();
        assert_eq!(
            prims(&s)[0].1.positions,
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]
        );
        assert!(read_str("v 0 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").is_err());
        let s = read_str("v 0 0 0 1 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(prims(&s)[0].1.positions[0], [0.0, 0.0, 0.0]);
        assert!(has_warning(&s, "5 values"), "{:?}", s.warnings);
        // Shared corners become one vertex; distinct (v, vt) pairs are split.
        let s = read_str(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 1\nf 1/1 2/1 3/1\nf 2/1 4/1 3/2\n",
        )
        .unwrap();
        assert_eq!(prims(&s)[0].1.positions.len(), 5);
    }

    /// `img` holds its bytes, read when the asset was read, and its file is
    /// one of the scene's sources.
    fn assert_read_once(s: &Scene, img: &crate::scene::Image) {
        let ImageSource::Bytes(b) = &img.source else {
            panic!("{:?} kept as a file", img.file_name)
        };
        assert!(
            s.sources
                .iter()
                .any(|p| std::fs::read(p).is_ok_and(|f| f == *b)),
            "{:?}",
            s.sources
        );
    }

    /// A texture is read once, when the asset is read: swapped for a link
    /// to a file outside the folder before the output is written (during
    /// the simulation, say), the output holds the texture as it was read
    /// (the writer read the path again and embedded the outside file).
    #[cfg(unix)]
    #[test]
    fn a_texture_swapped_after_reading_never_reaches_the_output() {
        let dir = tempfile::tempdir().unwrap();
        let (d, outside) = (dir.path().join("asset"), dir.path().join("secret.png"));
        std::fs::create_dir(&d).unwrap();
        std::fs::write(&outside, b"\x89PNG secret").unwrap();
        std::fs::write(d.join("t.png"), b"\x89PNG texture").unwrap();
        std::fs::write(d.join("m.mtl"), "newmtl a\nmap_Kd t.png\n").unwrap();
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n";
        std::fs::write(d.join("a.obj"), obj).unwrap();
        let s = read_obj(&d.join("a.obj")).unwrap();
        std::fs::remove_file(d.join("t.png")).unwrap();
        std::os::unix::fs::symlink(&outside, d.join("t.png")).unwrap();
        let out = dir.path().join("out.glb");
        crate::io::gltf_write::write_scene(&s, &out).unwrap();
        let bytes = std::fs::read(&out).unwrap();
        let has = |needle: &[u8]| bytes.windows(needle.len()).any(|w| w == needle);
        assert!(has(b"PNG texture"));
        assert!(!has(b"secret"));
    }

    /// A UTF-8 byte-order mark before the first line (of the OBJ or of
    /// its MTL) does not hide that line: the `mtllib` and the first
    /// `newmtl` are read (every material was lost).
    #[test]
    fn a_byte_order_mark_hides_no_line() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("m.mtl"), "\u{feff}newmtl red\nKd 1 0 0\n").unwrap();
        let obj = "\u{feff}mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n";
        let s = read_obj_from_str(obj, d, "m.obj").unwrap();
        assert_eq!(s.materials.len(), 1, "{:?}", s.warnings);
        assert_eq!(s.materials[0].name(), Some("red"));
        std::fs::write(d.join("b.obj"), obj.as_bytes()).unwrap();
        let s = read_obj(&d.join("b.obj")).unwrap();
        assert_eq!(s.materials[0].name(), Some("red"), "{:?}", s.warnings);
    }

    #[test]
    fn mtllib_outside_the_folder_is_not_read() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        std::fs::write(dir.path().join("evil.mtl"), "newmtl evil\nKd 1 0 0\n").unwrap();
        let s = read_obj_from_str(
            "mtllib ../evil.mtl\nusemtl evil\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            &sub,
            "a.obj",
        )
        .unwrap();
        assert!(has_warning(&s, "../evil.mtl"), "{:?}", s.warnings);
        assert_eq!(s.materials.len(), 1, "only the default material");
        assert_eq!(prims(&s)[0].0.material, Some(0));
    }

    #[test]
    fn materials_from_mtl() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("tex")).unwrap();
        std::fs::write(d.join("tex").join("a b.png"), b"\x89PNG").unwrap();
        std::fs::write(d.join("n.JPG"), b"jpg").unwrap();
        std::fs::write(d.join("e.tga"), b"tga").unwrap();
        std::fs::write(
            d.join("m.mtl"),
            "newmtl glass\nkd 0.5\nd 0.25\nNs 98\nmap_Kd -s 1 1 1 -clamp on tex\\a b.png\n\
             map_Bump -bm 0.5 n.JPG\nKe 2 0.5 0\nmap_Ke e.tga\n\
             newmtl plain\nKd 0.1 0.2 0.3\nTr 0.5\nmap_Kd missing.png\nillum 2\nKa spectral x.rfl\n\
             newmtl same\nmap_kd tex/a b.png\nnorm n.JPG\n\
             newmtl unused\nKd 1 1 1\n",
        )
        .unwrap();
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n\
                   usemtl glass\nf 1 2 3\nusemtl plain\nf 1 2 3\nusemtl same\nf 1 2 3\nusemtl nope\nf 1 2 3\n";
        let s = read_obj_from_str(obj, d, "m.obj").unwrap();
        check_consistent(&s);
        // Three from the MTL; `nope` is not defined: the default material.
        assert_eq!(s.materials.len(), 4);
        assert_eq!(s.materials[3].name(), Some("default"));
        assert_eq!(
            s.materials[3].json["pbrMetallicRoughness"]["metallicFactor"],
            json!(0.0)
        );
        let ps = prims(&s);
        assert_eq!(
            ps.iter().map(|(p, _)| p.material).collect::<Vec<_>>(),
            [Some(0), Some(1), Some(2), Some(3)]
        );
        let glass = &s.materials[0].json;
        assert_eq!(glass["name"], "glass");
        let pbr = &glass["pbrMetallicRoughness"];
        assert_eq!(pbr["baseColorFactor"], json!([0.5, 0.5, 0.5, 0.25]));
        assert_eq!(pbr["metallicFactor"], json!(0.0));
        assert!((pbr["roughnessFactor"].as_f64().unwrap() - 0.02f64.sqrt()).abs() < 1e-9);
        assert_eq!(glass["alphaMode"], "BLEND");
        assert_eq!(glass["emissiveFactor"], json!([1.0, 0.5, 0.0]));
        assert!(glass.get("emissiveTexture").is_none());
        assert_eq!(glass["normalTexture"]["scale"], json!(0.5));
        let base = pbr["baseColorTexture"]["index"].as_u64().unwrap() as usize;
        let img = &s.images[s.textures[base]["source"].as_u64().unwrap() as usize];
        assert_eq!(img.file_name, "a b.png");
        assert_eq!(img.mime_type.as_deref(), Some("image/png"));
        let nimg = &s.images[s.textures[glass["normalTexture"]["index"].as_u64().unwrap() as usize]
            ["source"]
            .as_u64()
            .unwrap() as usize];
        assert_eq!(nimg.mime_type.as_deref(), Some("image/jpeg"));
        let plain = &s.materials[1].json;
        assert_eq!(
            plain["pbrMetallicRoughness"]["baseColorFactor"],
            json!([0.1, 0.2, 0.3, 0.5])
        );
        assert!(plain["pbrMetallicRoughness"]
            .get("baseColorTexture")
            .is_none());
        // The same files are shared: 2 images, 2 textures in all.
        let same = &s.materials[2].json;
        assert_eq!(
            same["pbrMetallicRoughness"]["baseColorTexture"]["index"].as_u64(),
            Some(base as u64)
        );
        assert!(same["normalTexture"].is_object());
        assert_eq!(s.images.len(), 2);
        assert_eq!(s.textures.len(), 2);
        for needle in ["e.tga", "missing.png", "spectral", "nope"] {
            assert!(has_warning(&s, needle), "{needle}: {:?}", s.warnings);
        }
    }

    #[test]
    fn map_values() {
        assert_eq!(parse_map("fuze uv.jpg"), ("fuze uv.jpg".to_string(), None));
        assert_eq!(
            parse_map(".\\SpiderTex.jpg"),
            (".\\SpiderTex.jpg".to_string(), None)
        );
        assert_eq!(parse_map("-s 1 1 1 tex.png"), ("tex.png".to_string(), None));
        assert_eq!(parse_map("-o 0.5 tex.png"), ("tex.png".to_string(), None));
        assert_eq!(
            parse_map("-bm 0.3 -mm 0 1 my normal.png"),
            ("my normal.png".to_string(), Some(0.3))
        );
        assert_eq!(parse_map("-clamp on"), (String::new(), None));
    }

    /// Every other evaluation OBJ loads with the triangle count of SOURCES.md.
    #[test]
    fn other_eval_objs_load() {
        let files = [
            ("obj/npm-bunny/bunny.obj", 3_674),
            ("obj/beast/beast.obj", 64_618),
            ("obj/fandisk/fandisk.obj", 12_946),
            ("obj/teapot/teapot.obj", 6_320),
            ("obj/capsule/capsule.obj", 10_200),
        ];
        for (rel, tris) in files {
            let Some(path) = eval(rel) else { return };
            let s = read_obj(&path).unwrap_or_else(|e| panic!("{rel}: {e}"));
            check_consistent(&s);
            assert_eq!(s.triangle_count(), tris, "{rel}");
            eprintln!(
                "{rel}: {} meshes, {} primitives, warnings {:?}",
                s.meshes.len(),
                prims(&s).len(),
                s.warnings
            );
        }
    }

    /// The large OBJ files load with their triangle counts (their parse time
    /// is measured by `cargo bench --bench io`).
    #[test]
    fn large_obj_parses() {
        let files = [
            ("large/ogre_loop1_496k.obj", 496_032),
            ("obj/stanford-bunny/stanford-bunny.obj", 69_451),
            ("obj/armadillo/armadillo.obj", 86_482),
            ("obj/nefertiti/nefertiti.obj", 99_938),
            ("obj/ogre/ogre.obj", 124_008),
        ];
        for (rel, tris) in files {
            let Some(path) = eval(rel) else { return };
            let s = read_obj(&path).unwrap();
            check_consistent(&s);
            assert_eq!(s.triangle_count(), tris, "{rel}");
        }
    }

    /// A group met again later in the file (after another group's faces
    /// used the same positions) keeps one vertex per
    /// (v, vt, vn) corner: its second run of faces reuses its vertices, and
    /// a seam (the same position with another texture coordinate) is a
    /// vertex of its own.
    #[test]
    fn a_section_met_again_reuses_its_vertices() {
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n\
                   g a\nf 1/1 2/2 3/3\n\
                   g b\nf 2/2 4/4 3/3\nf 1/1 2/2 3/3\n\
                   g a\nf 2/2 4/4 3/3\nf 1/1 2/2 3/3\nf 1/2 3/3 4/4\n";
        let scene = read_str(obj).unwrap();
        let counts: Vec<(usize, usize)> = prims(&scene)
            .iter()
            .map(|(_, t)| (t.positions.len(), t.triangles.len()))
            .collect();
        // a: corners 1/1 2/2 3/3 4/4 and the seam 1/2; b: 2/2 4/4 3/3 1/1.
        assert_eq!(counts, vec![(5, 4), (4, 2)]);
        let a = prims(&scene)[0].1;
        assert_eq!(a.triangles, vec![[0, 1, 2], [1, 3, 2], [0, 1, 2], [4, 2, 3]]);
    }

    /// Many corners on one position (a pole's fan of texture coordinates,
    /// or a hostile file's thousands): each gets its own vertex, met again
    /// it is found (the lookup stays bounded: the first few in a chain, the
    /// rest by hash), and the numbering is the order of first use.
    #[test]
    fn many_corners_on_one_position_are_found_again() {
        let n = 300;
        let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
        for k in 0..n {
            obj.push_str(&format!("vt {} 0\n", k as f64 / n as f64));
        }
        for _ in 0..2 {
            for k in 1..=n {
                obj.push_str(&format!("f 1/{k} 2/1 3/1\n"));
            }
        }
        let scene = read_str(&obj).unwrap();
        let t = prims(&scene)[0].1;
        // Corners 1/1 2/1 3/1 first, then 1/2 .. 1/300.
        assert_eq!(t.positions.len(), n + 2);
        assert_eq!(t.triangles.len(), 2 * n);
        assert_eq!(t.triangles[0], [0, 1, 2]);
        for k in 1..n {
            assert_eq!(t.triangles[k], [k as u32 + 2, 1, 2], "face {k}");
        }
        assert_eq!(t.triangles[..n], t.triangles[n..]);
    }
}
