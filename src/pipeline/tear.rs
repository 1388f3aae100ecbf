//! `model = "ductile"`: each simulated mesh, a closed solid, is torn by
//! [`crate::sim::ductile`]; its surface is replaced by the deformed, torn
//! surface. Triangles on the original surface take the input's attributes
//! (each vertex projected back onto the input at rest, its normal and
//! tangent turned by the deformation), the torn surface gets its own
//! material, and each fragment becomes its own node.

use super::post_report::{BakeReport, PostReport, SurfaceReport, TearReport};
use super::primitives::material;
use super::Observer;
use crate::bridge::SimEntry;
use crate::post::Post;
use crate::scene::{Geometry, Mesh, Node, Primitive, Scene, TriGeometry, VertexAttribute};
use crate::sim::ductile::surface::TornSurface;
use crate::sim::ductile::{Ductile, DuctileParams, DuctileReport};
use crate::sim::SimParams;
use parry3d::math::Vector;
use parry3d::query::PointQuery;
use parry3d::shape::TriMesh;
use serde_json::json;
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

/// Each torn mesh's index and report, and how many frames were handed over.
pub type Torn = (Vec<(usize, PostReport)>, usize);

/// Tear every mesh of `entries`; each mesh's report, and the
/// time-lapse frames handed to `observer` when `frames` (their count) asks
/// for them (one torn mesh only).
/// Each piece's tear border (where its torn faces meet the original
/// surface) becomes its crack lines with `post.lines` and its baked crack
/// maps with `post.bake`.
///
/// # Errors
/// A mesh that is open (with its boundary loops) or cannot be embedded, or
/// a bake that fails (naming the mesh).
pub fn tear_meshes(
    scene: &mut Scene,
    entries: &[SimEntry],
    params_of: &[SimParams],
    input: &Path,
    frames: Option<usize>,
    post: &Post,
    observer: &mut dyn Observer,
) -> crate::Result<Torn> {
    let mut out = Vec::new();
    let mut handed = 0;
    if frames.is_some() && entries.len() > 1 {
        return Err(crate::error::UsageError::DuctileFramesMeshes {
            asset: input.to_path_buf(),
            meshes: entries.len(),
        }
        .into());
    }
    // Frames are drawn on the scene as it was before tearing.
    let template = frames.map(|_| scene.clone());
    for (e, p) in entries.iter().zip(params_of) {
        let (positions, triangles) = super::tear_solid::solid_of(e, input)?;
        let t = Instant::now();
        // The `[select] fix` groups are the grips (none: the pull's slabs).
        let grips: Vec<bool> = e
            .sim
            .faces()
            .map(|f| p.fixed_groups.contains(&e.sim.face_group(f)))
            .chain(std::iter::repeat(false))
            .take(triangles.len())
            .collect();
        let mut d = Ductile::with_grips(&positions, &triangles, &grips, &p.ductile)
            .map_err(|err| crate::Error::mesh(input, &e.label, err))?;
        let mut cg_max = 0;
        // The time-lapse: frame k when the ends have moved apart by k / (N
        // - 1) of the pull's distance, from the untorn solid; frames the run
        // did not reach (it stopped at max_steps) show its last state.
        let mut frame = FrameWriter {
            frames,
            observer: &mut *observer,
            template: template.as_ref(),
            entry: e,
            smooth_angle: post.smooth_angle,
            warned: false,
            params: &p.ductile,
            next: 0,
            error: None,
        };
        frame.reach(&d, false);
        let mut report: DuctileReport = d.run(|d, s| {
            cg_max = cg_max.max(s.cg_iterations);
            frame.reach(d, false);
        });
        frame.reach(&d, true);
        if let Some(err) = frame.error {
            return Err(err);
        }
        handed += frame.next;
        let seconds = t.elapsed().as_secs_f64();
        report.seconds_per_step = seconds / report.steps.max(1) as f64;
        if report.cg_unconverged > 0 {
            log::warn!(
                "{}: {}: {} implicit steps stopped before CG reached tolerance {}",
                input.display(),
                e.label,
                report.cg_unconverged,
                p.ductile.tolerance
            );
        }
        let surface = d.surface(0.25 * d.grid.h);
        let (torn_triangles, torn_area) = super::tear_solid::torn_area(&surface, |p| d.to_scene(p));
        // The artist's surface, cut along the tear; the grid's surface
        // where the cut cannot be made.
        let embedded = match super::tear_embed::embed(e, &d, &surface) {
            Ok(m) => Some(m),
            Err(why) => {
                log::warn!(
                    "{}: {}: the torn surface is the grid's, not the input's: {why}",
                    input.display(),
                    e.label
                );
                None
            }
        };
        let kept = embedded.as_ref().map(|m| SurfaceReport {
            surface: "input".into(),
            dropped_faces: Some(m.dropped),
            skipped_border_segments: Some(m.skipped),
            input_triangles: Some([
                e.sim.n_faces(),
                m.piece.iter().filter(|p| p.is_some()).count(),
            ]),
        });
        let pieces = replace_mesh(
            scene,
            e,
            &d,
            &surface,
            &p.ductile,
            embedded.as_ref(),
            post.smooth_angle,
        );
        let border = embedded.as_ref().map(|m| &m.border);
        let (tear_lines, bakes, bake_seconds) =
            lines_and_bakes(scene, e, &d, &surface, &pieces, border, post)?;
        let detail = PostReport {
            tear: Some(TearReport {
                ductile: report,
                seconds,
                triangles: surface.triangles.len(),
                torn_triangles,
                torn_area,
                tear_line_segments: tear_lines,
                pieces: pieces.iter().flatten().count(),
                surface: kept.unwrap_or_else(SurfaceReport::grid),
            }),
            bake: post.bake.then_some(BakeReport {
                seconds: bake_seconds,
                materials: None,
                pieces: Some(bakes),
            }),
            ..PostReport::default()
        };
        out.push((e.mesh_index, detail));
    }
    Ok((out, handed))
}

/// Each piece's tear border as its crack lines (with `post.lines`) and
/// baked into its maps (with `post.bake`): the segments drawn, each
/// piece's bake and the seconds baking took.
fn lines_and_bakes(
    scene: &mut Scene,
    e: &SimEntry,
    d: &Ductile,
    surface: &TornSurface,
    pieces: &[Option<usize>],
    border: Option<&HashMap<u32, [f64; 3]>>,
    post: &Post,
) -> crate::Result<(usize, Vec<super::post_report::MeshBake>, f64)> {
    let mut tear_lines = 0;
    let mut bakes = Vec::new();
    let mut bake_seconds = 0.0;
    for (k, (mesh, segments)) in pieces
        .iter()
        .zip(tear_borders(d, surface, border))
        .enumerate()
    {
        let Some(mesh) = mesh else { continue };
        if post.lines {
            tear_lines += segments.len();
            super::primitives::add_crack_lines(scene, *mesh, &segments, &[], None);
        }
        if post.bake && !segments.is_empty() {
            let t = Instant::now();
            let label = format!("{} (piece {k})", e.label);
            let widths = vec![1.0; segments.len()];
            let b = super::bake::bake_mesh(scene, *mesh, &label, &segments, &widths, None, post)?;
            bake_seconds += t.elapsed().as_secs_f64();
            bakes.push(b);
        }
    }
    Ok((tear_lines, bakes, bake_seconds))
}

/// Hands the time-lapse frames of one torn mesh to the observer as the
/// pull reaches them.
struct FrameWriter<'a> {
    /// How many frames (none: no time-lapse).
    frames: Option<usize>,
    observer: &'a mut dyn Observer,
    template: Option<&'a Scene>,
    entry: &'a SimEntry,
    /// `post.smooth_angle`, as the output's.
    smooth_angle: f64,
    /// Whether a frame fell back to the grid's surface (said once).
    warned: bool,
    params: &'a DuctileParams,
    next: usize,
    error: Option<crate::Error>,
}

impl FrameWriter<'_> {
    /// Write every frame the pull has reached (all that are left when
    /// `last`).
    fn reach(&mut self, d: &Ductile, last: bool) {
        let (Some(n), Some(template)) = (self.frames, self.template) else {
            return;
        };
        while self.next < n && self.error.is_none() {
            let target = self.params.pull.distance * self.next as f64 / (n - 1) as f64;
            if !last && d.pull_fraction() < target - 1e-12 {
                break;
            }
            let surface = d.surface(0.25 * d.grid.h);
            let mut scene = template.clone();
            let embedded = match super::tear_embed::embed(self.entry, d, &surface) {
                Ok(m) => Some(m),
                Err(why) => {
                    if !self.warned {
                        log::warn!(
                            "{}: a time-lapse frame shows the grid's surface, not the input's: {why}",
                            self.entry.label
                        );
                        self.warned = true;
                    }
                    None
                }
            };
            replace_mesh(
                &mut scene,
                self.entry,
                d,
                &surface,
                self.params,
                embedded.as_ref(),
                self.smooth_angle,
            );
            if let Err(e) = self.observer.frame(self.next, n, &scene) {
                self.error = Some(e);
            }
            self.next += 1;
        }
    }
}

/// The input's triangles for projection, one set per triangle primitive
/// (a vertex reads its attributes from the primitive its triangle shows,
/// whose triangle indices and layout they follow).
struct Source {
    /// Per primitive: its triangles (positions about `centre`, single
    /// precision as the projection takes them), if it has any.
    prims: Vec<Option<TriMesh>>,
    centre: [f64; 3],
}

impl Source {
    fn of(mesh: &Mesh) -> Option<Source> {
        let all = mesh.primitives.iter().filter_map(|p| match &p.geometry {
            Geometry::Triangles(t) => Some(t.positions.iter().map(|q| q.map(f64::from))),
            Geometry::Raw(_) => None,
        });
        let pos: Vec<[f64; 3]> = all.flatten().collect();
        if pos.is_empty() {
            return None;
        }
        let (lo, hi) = crate::sim::ductile::grid::bounds(&pos);
        let centre: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
        let prims = mesh
            .primitives
            .iter()
            .map(|p| match &p.geometry {
                Geometry::Triangles(t) if !t.triangles.is_empty() => {
                    let v: Vec<Vector> = t
                        .positions
                        .iter()
                        .map(|p| {
                            Vector::new(
                                (f64::from(p[0]) - centre[0]) as f32,
                                (f64::from(p[1]) - centre[1]) as f32,
                                (f64::from(p[2]) - centre[2]) as f32,
                            )
                        })
                        .collect();
                    TriMesh::new(v, t.triangles.clone()).ok()
                }
                _ => None,
            })
            .collect();
        Some(Source { prims, centre })
    }

    /// The closest point to `p` on primitive `pi`: (triangle, point).
    fn project_in(&self, pi: usize, p: [f64; 3]) -> Option<(usize, [f64; 3])> {
        let mesh = self.prims.get(pi)?.as_ref()?;
        let c = self.centre;
        let q = Vector::new(
            (p[0] - c[0]) as f32,
            (p[1] - c[1]) as f32,
            (p[2] - c[2]) as f32,
        );
        // The triangle is the projection's sub-shape (its feature is the
        // triangle's own face, vertex or edge).
        let (proj, _) = mesh.project_local_point_and_get_feature(q);
        let x = proj.point;
        Some((
            proj.subshape as usize,
            [
                f64::from(x.x) + c[0],
                f64::from(x.y) + c[1],
                f64::from(x.z) + c[2],
            ],
        ))
    }

    /// The closest input point to `p` over all primitives: (primitive,
    /// triangle, point); the first primitive on a tie.
    fn project(&self, p: [f64; 3]) -> Option<(usize, usize, [f64; 3])> {
        let mut best: Option<(usize, usize, [f64; 3])> = None;
        let mut nearest = f64::INFINITY;
        for pi in 0..self.prims.len() {
            if let Some((ti, q)) = self.project_in(pi, p) {
                let d = crate::math::v3::norm(crate::math::v3::sub(q, p));
                if d < nearest {
                    nearest = d;
                    best = Some((pi, ti, q));
                }
            }
        }
        best
    }
}

/// Barycentric coordinates of `p` in triangle `t`.
fn barycentric(t: [[f64; 3]; 3], p: [f64; 3]) -> [f64; 3] {
    use crate::math::v3::{cross, dot, sub};
    let (e1, e2, d) = (sub(t[1], t[0]), sub(t[2], t[0]), sub(p, t[0]));
    let n = cross(e1, e2);
    let nn = dot(n, n);
    if nn <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let b1 = dot(cross(d, e2), n) / nn;
    let b2 = dot(cross(e1, d), n) / nn;
    let w = [1.0 - b1 - b2, b1, b2].map(|w| w.clamp(0.0, 1.0));
    let sum = w[0] + w[1] + w[2];
    w.map(|x| x / sum)
}

/// Replace mesh `mesh_index` by the torn surface: one primitive per input
/// primitive (its material, its attributes) and one for the torn surface,
/// per piece; several pieces become child nodes of the mesh's nodes.
fn replace_grid_surface(
    scene: &mut Scene,
    mesh_index: usize,
    d: &Ductile,
    s: &TornSurface,
    params: &DuctileParams,
) -> Vec<Option<usize>> {
    let meshes = grid_pieces(scene, mesh_index, d, s, params);
    place_pieces(scene, mesh_index, meshes)
}

/// Replace mesh `e.mesh_index` by the torn solid: with `embedded`, per
/// piece the input's own triangles cut along the tear and moved, and the
/// torn faces, the input's triangles shaded as the input was (smooth by
/// `smooth_angle` where it had no normals); without, the grid's surface
/// ([`replace_grid_surface`]).
fn replace_mesh(
    scene: &mut Scene,
    e: &SimEntry,
    d: &Ductile,
    s: &TornSurface,
    params: &DuctileParams,
    embedded: Option<&super::tear_embed::Embedded>,
    smooth_angle: f64,
) -> Vec<Option<usize>> {
    let Some(m) = embedded else {
        return replace_grid_surface(scene, e.mesh_index, d, s, params);
    };
    let tear_mat = torn_material(scene, params);
    let old = scene.meshes[e.mesh_index].clone();
    let no_torn = vec![true; s.rest.len()];
    let mut meshes = Vec::new();
    for piece in 0..s.pieces as u32 {
        let mut mesh = old.clone();
        crate::bridge::write_faces_into(
            &mut mesh,
            e,
            &m.cut,
            &|f| m.piece[f.idx()] == Some(piece),
            &[],
        );
        // Primitives the tear does not cut (lines, points) stay with the
        // first piece, once.
        let mut prims: Vec<Primitive> = mesh
            .primitives
            .into_iter()
            .filter(|p| match &p.geometry {
                Geometry::Triangles(t) => !t.triangles.is_empty(),
                Geometry::Raw(_) => piece == 0,
            })
            .collect();
        let torn: Vec<usize> = (0..s.triangles.len())
            .filter(|&t| s.torn[t] && s.piece[t] == piece)
            .collect();
        if !torn.is_empty() {
            let geo = piece_geometry(d, s, &torn, None, None, &no_torn, Some(&m.border));
            prims.push(Primitive {
                material: Some(tear_mat),
                geometry: Geometry::Triangles(geo),
                rest: Default::default(),
            });
        }
        meshes.push(prims);
    }
    let pieces = place_pieces(scene, e.mesh_index, meshes);
    for &m in pieces.iter().flatten() {
        super::attributes::add_smooth_normals(scene, m, smooth_angle);
    }
    pieces
}

/// The torn surface's material (made once per scene).
fn torn_material(scene: &mut Scene, params: &DuctileParams) -> usize {
    material(
        scene,
        &params.tear_material,
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.55, 0.38, 0.28, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.9}}),
    )
}

/// Per piece, the primitives of the grid's torn surface (the input's
/// attributes projected onto its original part).
fn grid_pieces(
    scene: &mut Scene,
    mesh_index: usize,
    d: &Ductile,
    s: &TornSurface,
    params: &DuctileParams,
) -> Vec<Vec<Primitive>> {
    let source = Source::of(&scene.meshes[mesh_index]);
    let tear_mat = torn_material(scene, params);
    let old = scene.meshes[mesh_index].clone();
    // A vertex on the original surface only (no torn triangle) is
    // projected back onto the input at rest.
    let mut on_torn = vec![false; s.rest.len()];
    for (t, &torn) in s.triangles.iter().zip(&s.torn) {
        if torn {
            t.iter().for_each(|&v| on_torn[v as usize] = true);
        }
    }
    // Per triangle: the input primitive it shows (by its centre), or None
    // for the torn surface.
    let owner: Vec<Option<usize>> = s
        .triangles
        .iter()
        .zip(&s.torn)
        .map(|(t, &torn)| {
            if torn {
                return None;
            }
            let c: [f64; 3] = std::array::from_fn(|k| {
                t.iter().map(|&v| s.rest[v as usize][k]).sum::<f64>() / 3.0
            });
            source
                .as_ref()
                .and_then(|src| src.project(d.to_scene(c)))
                .map(|(pi, _, _)| pi)
        })
        .collect();
    let mut meshes = Vec::new();
    for piece in 0..s.pieces as u32 {
        let mut prims = Vec::new();
        let groups: Vec<Option<usize>> = {
            let mut g: Vec<Option<usize>> = (0..s.triangles.len())
                .filter(|&t| s.piece[t] == piece)
                .map(|t| owner[t])
                .collect();
            g.sort_unstable();
            g.dedup();
            g
        };
        for group in groups {
            let tris: Vec<usize> = (0..s.triangles.len())
                .filter(|&t| s.piece[t] == piece && owner[t] == group)
                .collect();
            let (template, material_index) = match group {
                Some(pi) => (
                    old.primitives.get(pi).map(|p| (pi, p)),
                    old.primitives.get(pi).and_then(|p| p.material),
                ),
                None => (None, Some(tear_mat)),
            };
            let geo = piece_geometry(d, s, &tris, template, source.as_ref(), &on_torn, None);
            prims.push(Primitive {
                material: material_index,
                geometry: Geometry::Triangles(geo),
                rest: template.map(|(_, p)| p.rest.clone()).unwrap_or_default(),
            });
        }
        meshes.push(prims);
    }
    meshes
}

/// Put `meshes` (per piece, its primitives) in place of mesh `mesh_index`:
/// one piece replaces its primitives; several become meshes of their own,
/// child nodes of the mesh's nodes. Returns the pieces' mesh indices.
fn place_pieces(
    scene: &mut Scene,
    mesh_index: usize,
    meshes: Vec<Vec<Primitive>>,
) -> Vec<Option<usize>> {
    // A piece with nothing to show (a sliver of the solid under a hole of
    // the input, closed only for the solid) gets no mesh and no node.
    let mut placed: Vec<Option<usize>> = vec![None; meshes.len()];
    let shown: Vec<(usize, Vec<Primitive>)> = meshes
        .into_iter()
        .enumerate()
        .filter(|(_, prims)| !prims.is_empty())
        .collect();
    let old = scene.meshes[mesh_index].clone();
    if shown.len() <= 1 {
        match shown.into_iter().next() {
            Some((k, prims)) => {
                scene.meshes[mesh_index].primitives = prims;
                placed[k] = Some(mesh_index);
            }
            None => scene.meshes[mesh_index].primitives.clear(),
        }
        return placed;
    }
    // Pieces: each its own mesh and node, children of the mesh's nodes.
    let name = old
        .name
        .clone()
        .unwrap_or_else(|| format!("mesh{mesh_index}"));
    let first = scene.meshes.len();
    let count = shown.len();
    let mut order = Vec::with_capacity(count);
    for (i, (k, prims)) in shown.into_iter().enumerate() {
        order.push(k);
        scene.meshes.push(Mesh {
            name: Some(format!("{name}_piece{i}")),
            primitives: prims,
            weights: None,
            rest: old.rest.clone(),
        });
    }
    scene.meshes[mesh_index].primitives.clear();
    let holders: Vec<usize> = (0..scene.nodes.len())
        .filter(|&n| scene.nodes[n].mesh == Some(mesh_index))
        .collect();
    for n in holders {
        scene.nodes[n].mesh = None;
        for k in first..scene.meshes.len() {
            let child = scene.nodes.len();
            scene.nodes.push(Node {
                name: scene.meshes[k].name.clone(),
                mesh: Some(k),
                ..Default::default()
            });
            scene.nodes[n].children.push(child);
        }
    }
    // Removing the emptied mesh (before the pieces) shifts their indices.
    super::islands::remove_empty_meshes(scene);
    let shift = (first + count).saturating_sub(scene.meshes.len());
    for (i, k) in order.into_iter().enumerate() {
        placed[k] = Some(first - shift + i);
    }
    placed
}

/// Per piece of `s`: the tear's border, the edges between a torn and an
/// original triangle, deformed, in scene units, in triangle order.
fn tear_borders(
    d: &Ductile,
    s: &TornSurface,
    border: Option<&HashMap<u32, [f64; 3]>>,
) -> Vec<Vec<[[f64; 3]; 2]>> {
    let mut sides: std::collections::BTreeMap<(u32, u32), [usize; 2]> = Default::default();
    for (t, &torn) in s.triangles.iter().zip(&s.torn) {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            sides.entry((a.min(b), a.max(b))).or_default()[usize::from(torn)] += 1;
        }
    }
    let mut out = vec![Vec::new(); s.pieces];
    for (t, (&torn, &piece)) in s.triangles.iter().zip(s.torn.iter().zip(&s.piece)) {
        if !torn {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if sides[&(a.min(b), a.max(b))][0] > 0 {
                // Where the torn faces' vertices are (`piece_geometry`).
                let at = |v: u32| match border.and_then(|b| b.get(&v)) {
                    Some(&p) => p,
                    None => d.to_scene(s.positions[v as usize]),
                };
                out[piece as usize].push([at(a), at(b)]);
            }
        }
    }
    out
}

/// One primitive's geometry: triangles `tris` of the surface, in scene
/// units, with the attributes of `template` (interpolated at each vertex's
/// projection onto the input) or, for the torn surface, normals only.
fn piece_geometry(
    d: &Ductile,
    s: &TornSurface,
    tris: &[usize],
    template: Option<(usize, &Primitive)>,
    source: Option<&Source>,
    on_torn: &[bool],
    border: Option<&HashMap<u32, [f64; 3]>>,
) -> TriGeometry {
    let mut index: HashMap<u32, u32> = HashMap::new();
    let mut order: Vec<u32> = Vec::new();
    let triangles: Vec<[u32; 3]> = tris
        .iter()
        .map(|&t| {
            s.triangles[t].map(|v| {
                *index.entry(v).or_insert_with(|| {
                    order.push(v);
                    (order.len() - 1) as u32
                })
            })
        })
        .collect();
    let tgeo = template.and_then(|(_, p)| match &p.geometry {
        Geometry::Triangles(t) => Some(t),
        Geometry::Raw(_) => None,
    });
    // Normals always: the torn surface is curved, and flat shading of its
    // small triangles would show the grid.
    let mut layout: Vec<(String, usize)> = match tgeo {
        Some(t) => t
            .attributes
            .iter()
            .map(|a| (a.semantic.clone(), a.components))
            .collect(),
        None => Vec::new(),
    };
    if !layout.iter().any(|(s, c)| s == "NORMAL" && *c == 3) {
        layout.retain(|(s, _)| s != "NORMAL");
        layout.insert(0, ("NORMAL".into(), 3));
    }
    let mut attrs: Vec<VertexAttribute> = layout
        .iter()
        .map(|(sem, c)| VertexAttribute {
            semantic: sem.clone(),
            components: *c,
            data: Vec::with_capacity(order.len() * c),
        })
        .collect();
    let mut positions = Vec::with_capacity(order.len());
    for &v in &order {
        let vi = v as usize;
        let rest_scene = d.to_scene(s.rest[vi]);
        // The input point this vertex shows, and its attributes there.
        // A vertex on the tear's border keeps its place (the torn faces
        // share it) but shows the input's attributes there too.
        let hit = match (tgeo, source) {
            (Some(_), Some(src)) => {
                let pi = template.map_or(0, |(pi, _)| pi);
                src.project_in(pi, rest_scene).map(|(ti, q)| (pi, ti, q))
            }
            _ => None,
        };
        // A vertex of the original surface shows the input point it
        // projects to, mapped by its tetrahedron; one of the torn surface
        // is where the surface puts it (smoothed: see `TornSurface`).
        let projected = match hit {
            Some((_, _, p)) if !on_torn[vi] => Some(d.to_metres(p)),
            _ => None,
        };
        let tet = s.tet_of[vi] as usize;
        let now = match (border.and_then(|b| b.get(&v)), projected) {
            (Some(&p), _) => p,
            (None, Some(rest_m)) => d.to_scene(d.deform(tet, rest_m)),
            (None, None) => d.to_scene(s.positions[vi]),
        };
        positions.push(now.map(|x| x as f32));
        let f = d.deformation(tet);
        for (a, (sem, c)) in attrs.iter_mut().zip(&layout) {
            let value: Vec<f64> = match (tgeo, hit) {
                (Some(t), Some((_, ti, p))) => match t.attribute(sem) {
                    Some(src) => {
                        let corners = t.triangles[ti];
                        let w =
                            barycentric(corners.map(|i| t.positions[i as usize].map(f64::from)), p);
                        (0..*c)
                            .map(|k| {
                                (0..3)
                                    .map(|j| w[j] * f64::from(src.get(corners[j] as usize)[k]))
                                    .sum()
                            })
                            .collect()
                    }
                    None => vec![0.0; *c],
                },
                _ => vec![0.0; *c],
            };
            let value = match sem.as_str() {
                "NORMAL" => {
                    let n = if hit.is_some() {
                        [value[0], value[1], value[2]]
                    } else {
                        [0.0; 3]
                    };
                    turn_normal(&f, n).to_vec()
                }
                "TANGENT" => {
                    let t = f * nalgebra::Vector3::new(value[0], value[1], value[2]);
                    let t = t.try_normalize(1e-30).unwrap_or_else(nalgebra::Vector3::x);
                    vec![t[0], t[1], t[2], if value[3] < 0.0 { -1.0 } else { 1.0 }]
                }
                _ => value,
            };
            a.data.extend(value.iter().map(|&x| x as f32));
        }
    }
    let mut geo = TriGeometry {
        positions,
        attributes: attrs,
        triangles,
        group: tgeo.and_then(|t| t.group.clone()),
        ..Default::default()
    };
    fill_missing_normals(&mut geo);
    geo
}

/// A normal carried through deformation `f` (`F^-T n`, unit), or zero.
fn turn_normal(f: &nalgebra::Matrix3<f64>, n: [f64; 3]) -> [f64; 3] {
    let m = f.try_inverse().map_or(*f, |i| i.transpose());
    let v = m * nalgebra::Vector3::new(n[0], n[1], n[2]);
    v.try_normalize(1e-30)
        .map_or([0.0; 3], |u| [u[0], u[1], u[2]])
}

/// Area-weighted normals where a vertex has none (zero): the torn surface
/// and vertices not projected onto the input.
fn fill_missing_normals(geo: &mut TriGeometry) {
    let Some(k) = geo
        .attributes
        .iter()
        .position(|a| a.semantic == "NORMAL" && a.components == 3)
    else {
        return;
    };
    let mut acc = vec![[0.0f64; 3]; geo.positions.len()];
    for t in &geo.triangles {
        let [a, b, c] = t.map(|i| geo.positions[i as usize].map(f64::from));
        let n = crate::math::v3::cross(crate::math::v3::sub(b, a), crate::math::v3::sub(c, a));
        for &i in t {
            acc[i as usize] = crate::math::v3::add(acc[i as usize], n);
        }
    }
    let data = &mut geo.attributes[k].data;
    for (i, a) in acc.iter().enumerate() {
        let cur = &data[3 * i..3 * i + 3];
        if cur.iter().all(|&x| x == 0.0) {
            let n = crate::math::v3::unit(*a).unwrap_or([0.0, 0.0, 1.0]);
            data[3 * i..3 * i + 3].copy_from_slice(&n.map(|x| x as f32));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Primitive;

    /// A vertex reads the attributes of the input point it projects to: on
    /// a sphere of two primitives whose UVs are linear in the position,
    /// every projection lands in the triangle it names, and the UVs
    /// interpolated there are the linear function at that point.
    #[test]
    fn projections_name_their_own_primitive_and_triangle() {
        let ico = crate::mesh::shapes::icosphere_input(2);
        let uv_of = |p: [f64; 3]| [p[0] + 0.5 * p[1], p[2] - 0.25 * p[0]];
        let half = ico.triangles.len() / 2;
        let prim = |tris: &[[u32; 3]]| Primitive {
            material: None,
            geometry: Geometry::Triangles(TriGeometry {
                positions: ico.positions.iter().map(|p| p.map(|x| x as f32)).collect(),
                attributes: vec![VertexAttribute {
                    semantic: "TEXCOORD_0".into(),
                    components: 2,
                    data: ico
                        .positions
                        .iter()
                        .flat_map(|&p| uv_of(p).map(|x| x as f32))
                        .collect(),
                }],
                triangles: tris.to_vec(),
                ..Default::default()
            }),
            rest: Default::default(),
        };
        let mesh = Mesh {
            name: None,
            primitives: vec![prim(&ico.triangles[..half]), prim(&ico.triangles[half..])],
            weights: None,
            rest: Default::default(),
        };
        let source = Source::of(&mesh).expect("a source");
        let mut used = [false; 2];
        for i in 0..400 {
            // Points around the sphere, inside and outside it.
            let (a, b) = (i as f64 * 2.399_963, (i as f64 / 400.0) * 2.0 - 1.0);
            let r = if i % 2 == 0 { 1.1 } else { 0.9 };
            let s = (1.0 - b * b).sqrt();
            let p = [r * s * a.cos(), r * s * a.sin(), r * b];
            let (pi, ti, q) = source.project(p).expect("a projection");
            used[pi] = true;
            let Geometry::Triangles(t) = &mesh.primitives[pi].geometry else {
                unreachable!()
            };
            let corners = t.triangles[ti];
            let w = barycentric(corners.map(|c| t.positions[c as usize].map(f64::from)), q);
            let uv = t.attribute("TEXCOORD_0").expect("uvs");
            let got: [f64; 2] = std::array::from_fn(|k| {
                (0..3)
                    .map(|j| w[j] * f64::from(uv.data[2 * corners[j] as usize + k]))
                    .sum()
            });
            let want = uv_of(q);
            for k in 0..2 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-5,
                    "point {p:?}: primitive {pi} triangle {ti} gives {got:?}, {want:?} at {q:?}"
                );
            }
        }
        assert!(used[0] && used[1], "both primitives are found");
    }
}
