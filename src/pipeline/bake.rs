//! The `bake` post stage: per cracked mesh and material, crack maps baked
//! into the mesh's UV set (or an automatic atlas) and a material variant
//! that uses them (see [`crate::post::bake`]).

use super::post_report::{AtlasReport, MaterialBake, MeshBake};
use crate::geometry::tangents::{with_corner_attribute, with_generated_tangents};
use crate::io::image::Files;
use crate::math::v3;
use crate::post::bake::{self, atlas, Cracks, Layer, Look, Profile, Surface};
use crate::post::Post;
use crate::post::{BAKE_SIZE_CAP, BAKE_TEXELS_PER_CRACK};
use crate::scene::{Geometry, Image, ImageSource, Material, Scene, TriGeometry};
use crate::io::image_decode::{check_within, decode_channels_within, Channels};
use crate::stress::texture::{texture_of_material, TextureError};
use serde_json::{json, Map, Value};
use std::collections::BTreeMap;

/// Share of covered texels that may lie under two triangles before the UV
/// set counts as overlapping (mirrored, stacked or tiled islands).
const MAX_OVERLAP: f64 = 0.01;

/// Share of the UV set's own overlap its repacked islands may keep (the
/// islands' own folds) and still be used.
const ISLANDS_KEEP: f64 = 0.05;

/// Texels kept free around each automatic atlas chart at 2048 (scaled with
/// the map size, at least 1): charts are 4 texels apart, enough for
/// bilinear filtering; the dilation fills the gutters from the nearest
/// chart.
const ATLAS_PADDING_2048: u32 = 2;

/// Bake crack maps for mesh `mesh_index` of `scene` (its cracked
/// primitives; `segments` in the mesh's frame, `widths` their width factors
/// in [0, 1], from [`crate::post::Post::fade`]; `cell` the run's cell size,
/// which the crack width may follow). Returns the report's details.
///
/// # Errors
/// A mesh without the UV set asked for when `bake_atlas = "never"`, an
/// atlas that does not fit, a material texture that does not decode, all
/// naming the mesh (`label`).
pub fn bake_mesh(
    scene: &mut Scene,
    mesh_index: usize,
    label: &str,
    segments: &[[[f64; 3]; 2]],
    widths: &[f64],
    cell: Option<f64>,
    post: &Post,
) -> crate::Result<MeshBake> {
    let fail = |error: BakeError| crate::Error::Internal {
        mesh: label.to_string(),
        error: error.into(),
    };
    // The maps are drawn with the normals the output is shaded with.
    let _ = super::attributes::add_smooth_normals(scene, mesh_index, post.smooth_angle);
    let mut groups: BTreeMap<Option<usize>, Vec<usize>> = BTreeMap::new();
    for (i, p) in scene.meshes[mesh_index].primitives.iter().enumerate() {
        if let Geometry::Triangles(t) = &p.geometry {
            if !t.triangles.is_empty() {
                groups.entry(p.material).or_default().push(i);
            }
        }
    }
    let mut details = Vec::new();
    for (material, prims) in groups {
        let d = bake_group(
            scene,
            mesh_index,
            material,
            &prims,
            (segments, widths),
            cell,
            post,
        )
        .map_err(fail)?;
        details.push(d);
    }
    Ok(MeshBake { materials: details })
}

/// Before any work: every texture the bake of `meshes` will decode (their
/// materials' base colour, normal and occlusion images) checked by its
/// header against `budget`, as decoding it would (nothing is decoded), so
/// an image too large for the budget is refused before the simulation,
/// not after it.
///
/// # Errors
/// The first image that decoding would refuse.
pub fn check_material_images(
    scene: &Scene,
    meshes: &[usize],
    budget: u64,
) -> Result<(), TextureError> {
    let mut seen = std::collections::BTreeSet::new();
    for &mesh in meshes {
        for p in &scene.meshes[mesh].primitives {
            let Some(m) = p.material else { continue };
            let Geometry::Triangles(_) = &p.geometry else {
                continue;
            };
            if !seen.insert(m) {
                continue;
            }
            let Some(json) = scene.materials.get(m).map(|x| &x.json) else {
                continue;
            };
            for slot in BAKED_SLOTS {
                if !has_slot(json, slot) {
                    continue;
                }
                let t = texture_of_material(scene, m, slot)?;
                if let ImageSource::Bytes(bytes) = &scene.images[t.image].source {
                    check_within(bytes, &t.name, Channels::Rgba, budget)?;
                }
            }
        }
    }
    Ok(())
}

/// The material textures the bake decodes ([`material_layers`]).
const BAKED_SLOTS: [&str; 3] = ["baseColorTexture", "normalTexture", "occlusionTexture"];

/// Whether a material's JSON has a texture in `slot`.
fn has_slot(json: &Map<String, Value>, slot: &str) -> bool {
    match slot {
        "baseColorTexture" => json
            .get("pbrMetallicRoughness")
            .and_then(|p| p.get(slot))
            .is_some(),
        _ => json.get(slot).is_some(),
    }
}

/// Why the asked UV set cannot take the maps.
#[derive(Clone, Copy, Debug, thiserror::Error)]
enum AtlasWhy {
    /// The mesh lacks the set.
    #[error("the mesh has no TEXCOORD_{0}")]
    NoSet(u32),
    /// `bake_atlas = "always"`.
    #[error("bake_atlas = \"always\"")]
    Always,
    /// The set overlaps itself on this share of its texels.
    #[error("TEXCOORD_{set} overlaps itself on {:.1}% of its texels (mirrored, stacked or tiled islands)", 100.0 * .overlap)]
    Overlaps { set: u32, overlap: f64 },
}

/// Why the crack maps of one material's primitives cannot be baked.
#[derive(Debug, thiserror::Error)]
enum BakeError {
    /// The mesh needs an atlas and `post.bake_atlas` is `never`.
    #[error("cannot bake crack maps: {why}, and post.bake_atlas = \"never\" (give the mesh UVs or allow an automatic atlas)")]
    AtlasNever {
        /// Why an atlas is needed (no UVs, overlapping UVs).
        why: AtlasWhy,
    },
    /// Every UV set is taken.
    #[error("every TEXCOORD_0..7 set is taken; no room for an automatic atlas")]
    NoFreeSet,
    /// The atlas does not fit.
    #[error(transparent)]
    Atlas(#[from] atlas::AtlasError),
    /// A material texture cannot be used.
    #[error(transparent)]
    Texture(#[from] TextureError),
    /// A map does not encode.
    #[error(transparent)]
    Encode(#[from] bake::EncodeError),
    /// The material's `pbrMetallicRoughness` is not an object.
    #[error("the material's pbrMetallicRoughness is not an object")]
    PbrNotObject,
}

/// One material's primitives of a mesh.
fn bake_group(
    scene: &mut Scene,
    mesh_index: usize,
    material: Option<usize>,
    prims: &[usize],
    (segments, widths): (&[[[f64; 3]; 2]], &[f64]),
    cell: Option<f64>,
    post: &Post,
) -> Result<MaterialBake, BakeError> {
    let dilate = post.bake_dilate;
    // The atlas is laid out (and overlap measured) for a 2048 map when the
    // size follows the asset; the size is then taken from its UV area.
    let sized_to_asset = post.bake_size == 0;
    let laid = Post {
        bake_size: if sized_to_asset { 2048 } else { post.bake_size },
        ..post.clone()
    };
    let post = &laid;
    let mat_json = material
        .and_then(|m| scene.materials.get(m))
        .map(|m| m.json.clone())
        .unwrap_or_default();
    let t0 = std::time::Instant::now();
    // The UV set: the one asked for, unless missing or overlapping; then
    // an atlas in a new set (the asset's own sets stay as they are).
    let (set, mut atlas_report) = match why_atlas(scene, mesh_index, prims, post) {
        None => (post.bake_texcoord, None),
        Some(why) => {
            let (set, report) = make_atlas(scene, mesh_index, prims, post, why)?;
            (set, Some(report))
        }
    };
    log::debug!(
        "bake: uvset+atlas done at {:.3} s",
        t0.elapsed().as_secs_f64()
    );
    // The surface as viewers draw it, for the bake only: the output keeps
    // its own attributes.
    let (drawn, reframe) = as_drawn(scene, mesh_index, prims, &mat_json, set);
    log::debug!("bake: tangents done at {:.3} s", t0.elapsed().as_secs_f64());
    let own = material_layers(scene, material, &mat_json, post.memory_budget)?;
    let sets: Vec<u32> = [
        Some(set),
        own.base.as_ref().map(|l| l.tex_coord),
        own.normal.as_ref().map(|l| l.0.tex_coord),
        own.occlusion.as_ref().map(|l| l.0.tex_coord),
    ]
    .into_iter()
    .flatten()
    .collect();
    let arrays = Arrays::gather(&drawn, &sets, reframe);
    let surface = Surface {
        positions: &arrays.positions,
        normals: &arrays.normals,
        tangents: &arrays.tangents,
        uvs: &arrays.uvs[&set],
        triangles: &arrays.triangles,
    };
    log::debug!(
        "bake: layers+gather done at {:.3} s",
        t0.elapsed().as_secs_f64()
    );
    let diagonal = super::Bounds::of(arrays.positions.iter().copied()).diagonal();
    let width = post.bake_width_for(diagonal, cell);
    let uv_of = |s: u32, v: usize| arrays.uvs.get(&s).map_or([0.0; 2], |u| u[v]);
    let own_density = own.base.as_ref().map(|l| {
        density(
            &arrays,
            l.tex_coord,
            f64::from(l.width) * f64::from(l.height),
        )
    });
    // Texels per world unit per texel of map side in the baked set.
    let unit_density = density(&arrays, set, 1.0);
    let size = if sized_to_asset {
        auto_size(width, unit_density, own_density)
    } else {
        post.bake_size
    };
    // The atlas's density was measured on the map it was laid out for.
    if let Some(a) = &mut atlas_report {
        a.texels_per_unit *= f64::from(size) / f64::from(post.bake_size);
    }
    let raster = bake::rasterize(surface.uvs, surface.triangles, size, dilate);
    log::debug!("bake: raster done at {:.3} s", t0.elapsed().as_secs_f64());
    let profile = Profile {
        half_width: 0.5 * width,
        slope: post.bake_groove_slope,
        shadow: 1.5,
    };
    let cracks = Cracks { segments, widths };
    let texels = bake::crack_texels(&surface, &raster, &cracks, &profile);
    log::debug!("bake: field done at {:.3} s", t0.elapsed().as_secs_f64());
    let look = Look {
        crack_color: post.crack_color,
        occlusion: post.bake_occlusion,
    };
    if let (Some(a), Some(own_density)) = (&mut atlas_report, own_density) {
        note_kept_resolution(a, unit_density * f64::from(size) / own_density);
    }
    let frames = arrays.own_tangents.as_ref().map(|from| bake::Reframe {
        normals: &arrays.normals,
        from,
        to: &arrays.tangents,
    });
    let maps = bake::compose(
        &arrays.triangles,
        &raster,
        &texels,
        &own,
        &look,
        &uv_of,
        frames.as_ref(),
    );
    log::debug!("bake: compose done at {:.3} s", t0.elapsed().as_secs_f64());
    // Images, textures and the material variant.
    let base_name = mat_json
        .get("name")
        .and_then(Value::as_str)
        .map_or_else(|| "material".to_string(), str::to_string);
    let mesh_name = scene.meshes[mesh_index]
        .name
        .clone()
        .unwrap_or_else(|| format!("mesh{mesh_index}"));
    let stem = format!("{mesh_name}_{base_name}_cracked");
    let webp = post.bake_format == "webp";
    let pngs = encode_maps(&maps, size, webp)?;
    let bytes = pngs.iter().map(Vec::len).sum();
    log::debug!("bake: png done at {:.3} s", t0.elapsed().as_secs_f64());
    let variant = add_variant(scene, &mat_json, &stem, set, pngs, webp)?;
    let tangent_splits = use_variant(scene, mesh_index, prims, &drawn, variant);
    Ok(MaterialBake {
        material: base_name,
        variant: stem,
        size,
        texcoord: set,
        atlas: atlas_report,
        crack_width: width,
        covered_texels: raster.covered,
        dilated_texels: raster.dilated,
        crack_texels: maps.crack_texels,
        png_bytes: bytes,
        tangent_split_vertices: tangent_splits,
    })
}

/// Texels per world unit of UV set `set` of `arrays` on a map of `texels`
/// texels.
fn density(arrays: &Arrays, set: u32, texels: f64) -> f64 {
    let uv_of = |v: usize| arrays.uvs.get(&set).map_or([0.0; 2], |u| u[v]);
    let (mut uv_area, mut world_area) = (0.0, 0.0);
    for t in &arrays.triangles {
        let [p, q, r] = t.map(|i| uv_of(i as usize));
        uv_area += 0.5 * ((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])).abs();
        let [a, b, c] = t.map(|i| arrays.positions[i as usize]);
        world_area += 0.5 * v3::norm(v3::cross(v3::sub(b, a), v3::sub(c, a)));
    }
    (uv_area * texels / world_area).sqrt()
}

/// An atlas resamples the material's base colour texture: how much of its
/// resolution the baked map keeps (`kept`), in the report and, under 90%,
/// in a warning.
fn note_kept_resolution(a: &mut AtlasReport, kept: f64) {
    if kept.is_finite() {
        a.base_texture_resolution_kept = Some(kept);
        if kept < 0.9 {
            log::warn!(
                "the automatic atlas holds the base colour texture at {:.0}% of its resolution; a larger post.bake_size keeps more",
                100.0 * kept
            );
        }
    }
}

/// Give primitives `prims` of mesh `mesh_index` the baked material
/// `variant` and the tangents the bake drew with (`drawn`); the vertices
/// split to carry them.
fn use_variant(
    scene: &mut Scene,
    mesh_index: usize,
    prims: &[usize],
    drawn: &[TriGeometry],
    variant: usize,
) -> usize {
    let mut tangent_splits = 0;
    for (&p, drawn) in prims.iter().zip(drawn) {
        scene.meshes[mesh_index].primitives[p].material = Some(variant);
        if let Some(with) = with_drawn_tangents(tri_geometry(scene, mesh_index, p), drawn) {
            tangent_splits +=
                with.positions.len() - tri_geometry(scene, mesh_index, p).positions.len();
            set_geometry(scene, mesh_index, p, with);
        }
    }
    tangent_splits
}

/// The maps encoded (PNG, or lossless WebP when `webp`): base colour (RGB
/// when every texel is opaque or empty, else RGBA), normal and occlusion,
/// the three at once.
fn encode_maps(
    maps: &bake::Maps,
    size: u32,
    webp: bool,
) -> Result<[Vec<u8>; 3], bake::EncodeError> {
    let opaque = maps.base.iter().all(|p| p[3] == 255 || p == &[0, 0, 0, 0]);
    let encode = |channels: usize, data: &[u8]| {
        if webp {
            bake::encode_webp(size, channels, data)
        } else {
            Ok(bake::encode_png(size, channels, data)?)
        }
    };
    let base = || {
        if opaque {
            let rgb: Vec<u8> = maps.base.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
            encode(3, &rgb)
        } else {
            encode(4, &maps.base.concat())
        }
    };
    let (base_png, (normal_png, occl_png)) = rayon::join(base, || {
        rayon::join(
            || encode(3, &maps.normal.concat()),
            || encode(1, &maps.occlusion),
        )
    });
    Ok([base_png?, normal_png?, occl_png?])
}

/// The material variant `stem` of `mat_json` with the baked maps (`pngs`:
/// base colour, normal, occlusion) as its textures in UV set `set`, added
/// to `scene` with its images and textures; its index.
fn add_variant(
    scene: &mut Scene,
    mat_json: &Map<String, Value>,
    stem: &str,
    set: u32,
    pngs: [Vec<u8>; 3],
    webp: bool,
) -> Result<usize, BakeError> {
    let [base_png, normal_png, occl_png] = pngs;
    let tex_base = add_texture(scene, &format!("{stem}_basecolor"), base_png, webp);
    let tex_normal = add_texture(scene, &format!("{stem}_normal"), normal_png, webp);
    let tex_occl = add_texture(scene, &format!("{stem}_occlusion"), occl_png, webp);
    let mut m: Map<String, Value> = mat_json.clone();
    m.insert("name".into(), json!(stem));
    let pbr = m
        .entry("pbrMetallicRoughness")
        .or_insert_with(|| json!({}))
        .as_object_mut()
        .ok_or(BakeError::PbrNotObject)?;
    pbr.insert("baseColorFactor".into(), json!([1.0, 1.0, 1.0, 1.0]));
    pbr.insert(
        "baseColorTexture".into(),
        json!({"index": tex_base, "texCoord": set}),
    );
    m.insert(
        "normalTexture".into(),
        json!({"index": tex_normal, "texCoord": set}),
    );
    m.insert(
        "occlusionTexture".into(),
        json!({"index": tex_occl, "texCoord": set}),
    );
    scene.materials.push(Material { json: m });
    Ok(scene.materials.len() - 1)
}

/// The side of maps sized to the asset: a crack of `width` (scene units)
/// [`BAKE_TEXELS_PER_CRACK`] texels wide at `unit_density` texels per
/// world unit per texel of map side (the UV set's sqrt(UV area / world
/// area)), and the material's own base colour texture kept (`own_density`
/// texels per world unit), rounded up to a multiple of 64, from 256 to
/// [`BAKE_SIZE_CAP`].
fn auto_size(width: f64, unit_density: f64, own_density: Option<f64>) -> u32 {
    let per_unit = (BAKE_TEXELS_PER_CRACK / width).max(own_density.unwrap_or(0.0));
    let want = per_unit / unit_density;
    if !(want.is_finite() && want > 0.0) {
        return 2048;
    }
    let cap = f64::from(BAKE_SIZE_CAP);
    ((want.min(cap) / 64.0).ceil() as u32 * 64).clamp(256, BAKE_SIZE_CAP)
}

/// `geo` with the tangents the baked normal map was made in (`drawn`'s,
/// MikkTSpace of the baked set), when it has normals and no tangents of
/// its own: viewers then read the map in the frame it was baked in (the
/// glTF validator asks for them). A vertex whose corners take different
/// tangents is copied (at a mirrored UV seam, say); nothing else changes.
/// Without normals glTF tells viewers to draw flat and ignore tangents:
/// none are added.
fn with_drawn_tangents(geo: &TriGeometry, drawn: &TriGeometry) -> Option<TriGeometry> {
    if geo.attribute("TANGENT").is_some() || geo.attribute("NORMAL").is_none() {
        return None;
    }
    let t = drawn.attribute("TANGENT").filter(|a| a.components == 4)?;
    if drawn.triangles.len() != geo.triangles.len() {
        return None;
    }
    let corners: Vec<f32> = drawn
        .triangles
        .iter()
        .flat_map(|tri| tri.iter().flat_map(|&v| t.get(v as usize).to_vec()))
        .collect();
    Some(with_corner_attribute(geo, "TANGENT", 4, &corners))
}

/// Where the material's own normal map's tangents wait while the baked set's
/// are made, in [`as_drawn`]'s copies.
const OWN_TANGENT: &str = "_CRACKLE_OWN_TANGENT";

/// Copies of the primitives as a viewer draws them, for the bake: flat
/// normals where a primitive has none (glTF tells viewers to shade those
/// flat), and the tangent frame of the baked UV set `set` as `TANGENT`:
/// the given one, which viewers use, else MikkTSpace's (what glTF tells
/// viewers to make). When the material's own normal map reads another set
/// and no tangents are given, that map's frame (MikkTSpace of its set) is
/// kept as [`OWN_TANGENT`] to carry its normals over; the flag says so.
/// Nothing is written to the scene here: the output keeps its own
/// attributes (and takes these tangents only where it has normals and no
/// tangents, [`with_drawn_tangents`]).
fn as_drawn(
    scene: &Scene,
    mesh_index: usize,
    prims: &[usize],
    mat_json: &Map<String, Value>,
    set: u32,
) -> (Vec<TriGeometry>, bool) {
    let own_set = mat_json
        .get("normalTexture")
        .map(|n| n.get("texCoord").and_then(Value::as_u64).unwrap_or(0) as u32);
    let given = prims.iter().all(|&p| {
        tri_geometry(scene, mesh_index, p)
            .attribute("TANGENT")
            .is_some()
    });
    let reframe = !given && own_set.is_some_and(|s| s != set);
    let drawn = prims
        .iter()
        .map(|&p| {
            let mut geo = tri_geometry(scene, mesh_index, p).clone();
            if geo.attribute("NORMAL").is_none() {
                geo = with_flat_normals(&geo);
            }
            if !given {
                geo.attributes.retain(|a| a.semantic != "TANGENT");
                if let (true, Some(s)) = (reframe, own_set) {
                    if let Some(mut with) = with_generated_tangents(&geo, &set_name(s)) {
                        for a in &mut with.attributes {
                            if a.semantic == "TANGENT" {
                                a.semantic = OWN_TANGENT.into();
                            }
                        }
                        geo = with;
                    }
                }
                if let Some(with) = with_generated_tangents(&geo, &set_name(set)) {
                    geo = with;
                }
            }
            geo
        })
        .collect();
    (drawn, reframe)
}

/// `geo` with flat normals (each corner its triangle's).
fn with_flat_normals(geo: &TriGeometry) -> TriGeometry {
    let corners: Vec<f32> = geo
        .triangles
        .iter()
        .flat_map(|t| {
            let [a, b, c] = t.map(|i| geo.positions[i as usize].map(f64::from));
            let n = v3::unit(v3::cross(v3::sub(b, a), v3::sub(c, a))).unwrap_or([0.0, 0.0, 1.0]);
            [n; 3].into_iter().flatten().map(|x| x as f32)
        })
        .collect();
    with_corner_attribute(geo, "NORMAL", 3, &corners)
}

/// Why the asked UV set cannot take the maps (missing, overlapping, or an
/// atlas always asked for); `None` when it can.
fn why_atlas(scene: &Scene, mesh_index: usize, prims: &[usize], post: &Post) -> Option<AtlasWhy> {
    let asked = post.bake_texcoord;
    let has_set = prims.iter().all(|&p| {
        tri_geometry(scene, mesh_index, p)
            .attribute(&set_name(asked))
            .is_some()
    });
    if !has_set {
        return Some(AtlasWhy::NoSet(asked));
    }
    if post.bake_atlas == "always" {
        return Some(AtlasWhy::Always);
    }
    // The overlap is a share of texels: 1024 texels across measure it.
    let (uvs, tris) = gather_uvs(scene, mesh_index, prims, asked);
    let r = bake::rasterize(&uvs, &tris, post.bake_size.min(1024), 0);
    let overlap = r.overlap_fraction();
    (overlap > MAX_OVERLAP).then_some(AtlasWhy::Overlaps {
        set: asked,
        overlap,
    })
}

/// An automatic atlas in a new UV set of the primitives, the first one
/// none of them has (the asset's own sets stay as they are); returns it with
/// the report's `atlas` entry. `why` says why (with the own set's overlap
/// when [`why_atlas`] measured it). A vertex whose corners get different
/// atlas UVs (on a chart's or a repacked island's border) is split; every
/// other vertex keeps its index.
///
/// # Errors
/// `bake_atlas = "never"`, no free UV set, or an atlas that does not fit.
fn make_atlas(
    scene: &mut Scene,
    mesh_index: usize,
    prims: &[usize],
    post: &Post,
    why: AtlasWhy,
) -> Result<(u32, AtlasReport), BakeError> {
    if post.bake_atlas == "never" {
        return Err(BakeError::AtlasNever { why });
    }
    let overlap = match why {
        AtlasWhy::Overlaps { overlap, .. } => Some(overlap),
        _ => None,
    };
    let any_has = |scene: &Scene, k: u32| {
        prims.iter().any(|&p| {
            tri_geometry(scene, mesh_index, p)
                .attribute(&set_name(k))
                .is_some()
        })
    };
    let set = (0..8u32)
        .find(|&k| !any_has(scene, k))
        .ok_or(BakeError::NoFreeSet)?;
    let size = post.bake_size;
    let (positions, tris) = gather_positions(scene, mesh_index, prims);
    let padding = (ATLAS_PADDING_2048 * size / 2048).max(1);
    // A UV set that overlaps itself: its own islands repacked (textures
    // keep their seams and frames), unless they overlap even then (an
    // island wrapped onto itself); a mesh without one: charts of its own.
    let (own, _) = gather_uvs(scene, mesh_index, prims, post.bake_texcoord);
    let repacked = (own.len() == positions.len())
        .then_some(own)
        .and_then(|uvs| {
            // Accepted when it removes nearly all the overlap: islands that
            // overlap themselves (folds) keep theirs, scaled with them.
            let before = overlap.unwrap_or_else(|| {
                bake::rasterize(&uvs, &tris, size.min(1024), 0).overlap_fraction()
            });
            let a = atlas::islands(&positions, &uvs, &tris, size, padding).ok()?;
            let r = bake::rasterize(&a.uvs, &corner_triangles(tris.len()), size.min(1024), 0);
            (r.overlap_fraction() <= MAX_OVERLAP.max(ISLANDS_KEEP * before)).then_some(a)
        });
    let kind = if repacked.is_some() {
        "islands"
    } else {
        "charts"
    };
    let a = match repacked {
        Some(a) => a,
        None => atlas::atlas(&positions, &tris, size, padding)?,
    };
    let mut corner = 0;
    let mut split = 0;
    for &p in prims {
        let geo = tri_geometry(scene, mesh_index, p);
        let n = geo.triangles.len() * 3;
        let values: Vec<f32> = a.uvs[corner..corner + n]
            .iter()
            .flat_map(|uv| uv.map(|x| x as f32))
            .collect();
        corner += n;
        let with = with_corner_attribute(geo, &set_name(set), 2, &values);
        split += with.positions.len() - geo.positions.len();
        set_geometry(scene, mesh_index, p, with);
    }
    let report = AtlasReport {
        reason: why.to_string(),
        layout: kind.to_string(),
        charts: a.charts,
        texels_per_unit: a.density,
        texcoord: set,
        split_vertices: split,
        base_texture_resolution_kept: None,
    };
    Ok((set, report))
}

/// The material's base colour, normal and occlusion textures, decoded.
fn material_layers(
    scene: &Scene,
    material: Option<usize>,
    json: &Map<String, Value>,
    budget: u64,
) -> Result<bake::Material, TextureError> {
    let factor = json
        .get("pbrMetallicRoughness")
        .and_then(|p| p.get("baseColorFactor"))
        .and_then(Value::as_array)
        .filter(|a| a.len() == 4)
        .map(|a| std::array::from_fn(|i| a[i].as_f64().unwrap_or(1.0)))
        .unwrap_or([1.0; 4]);
    let mut out = bake::Material {
        base_factor: factor,
        ..Default::default()
    };
    let Some(m) = material else {
        return Ok(out);
    };
    let has = |slot: &str| has_slot(json, slot);
    let files = Files::default();
    let layer = |slot: &str| -> Result<Option<Layer>, TextureError> {
        if !has(slot) {
            return Ok(None);
        }
        let t = texture_of_material(scene, m, slot)?;
        let bytes = t.bytes(scene, &files)?;
        let (width, height, rgba) =
            decode_channels_within(&bytes, &t.name, Channels::Rgba, budget)?;
        Ok(Some(Layer {
            width,
            height,
            rgba,
            wrap_s: t.wrap_s,
            wrap_t: t.wrap_t,
            transform: t.transform,
            tex_coord: t.tex_coord,
        }))
    };
    let number = |slot: &str, key: &str| {
        json.get(slot)
            .and_then(|s| s.get(key))
            .and_then(Value::as_f64)
            .unwrap_or(1.0)
    };
    out.base = layer("baseColorTexture")?;
    out.normal = layer("normalTexture")?.map(|l| (l, number("normalTexture", "scale")));
    out.occlusion = layer("occlusionTexture")?.map(|l| (l, number("occlusionTexture", "strength")));
    Ok(out)
}

/// An image and a texture of it: a PNG, or a WebP through
/// `EXT_texture_webp` (then used and required: there is no fallback); the
/// texture's index.
fn add_texture(scene: &mut Scene, name: &str, bytes: Vec<u8>, webp: bool) -> usize {
    let (mime, ext) = if webp {
        ("image/webp", "webp")
    } else {
        ("image/png", "png")
    };
    scene.images.push(Image {
        name: Some(name.to_string()),
        mime_type: Some(mime.into()),
        source: ImageSource::Bytes(bytes),
        file_name: format!("{name}.{ext}"),
        rest: Map::new(),
    });
    let image = scene.images.len() - 1;
    if webp {
        for list in [&mut scene.extensions_used, &mut scene.extensions_required] {
            if !list.iter().any(|e| e == WEBP) {
                list.push(WEBP.into());
            }
        }
        scene
            .textures
            .push(json!({"name": name, "extensions": {WEBP: {"source": image}}}));
    } else {
        scene.textures.push(json!({"source": image, "name": name}));
    }
    scene.textures.len() - 1
}

const WEBP: &str = "EXT_texture_webp";

fn set_name(k: u32) -> String {
    format!("TEXCOORD_{k}")
}

fn tri_geometry(scene: &Scene, mesh: usize, prim: usize) -> &TriGeometry {
    match &scene.meshes[mesh].primitives[prim].geometry {
        Geometry::Triangles(t) => t,
        Geometry::Raw(_) => unreachable!("bake groups hold triangle primitives only"),
    }
}

fn set_geometry(scene: &mut Scene, mesh: usize, prim: usize, geo: TriGeometry) {
    scene.meshes[mesh].primitives[prim].geometry = Geometry::Triangles(geo);
}

/// Triangles of corners in order (0, 1, 2), (3, 4, 5), ...: an atlas's
/// per-corner UVs as a mesh.
fn corner_triangles(n: usize) -> Vec<[u32; 3]> {
    (0..n as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect()
}

/// The primitives' UV set `set` and triangles, one index space.
fn gather_uvs(
    scene: &Scene,
    mesh: usize,
    prims: &[usize],
    set: u32,
) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
    let mut uvs = Vec::new();
    let mut tris = Vec::new();
    for &p in prims {
        let geo = tri_geometry(scene, mesh, p);
        let base = uvs.len() as u32;
        if let Some(a) = geo.attribute(&set_name(set)) {
            uvs.extend((0..a.len()).map(|i| {
                let v = a.get(i);
                [f64::from(v[0]), f64::from(v[1])]
            }));
        }
        tris.extend(geo.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    (uvs, tris)
}

/// The primitives' positions and triangles, one index space.
fn gather_positions(scene: &Scene, mesh: usize, prims: &[usize]) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut pos = Vec::new();
    let mut tris = Vec::new();
    for &p in prims {
        let geo = tri_geometry(scene, mesh, p);
        let base = pos.len() as u32;
        pos.extend(geo.positions.iter().map(|q| q.map(f64::from)));
        tris.extend(geo.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    (pos, tris)
}

/// Per-vertex arrays of a material's primitives, in f64, one index space.
struct Arrays {
    positions: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    tangents: Vec<[f64; 4]>,
    /// The material's own normal map's tangents, when kept aside.
    own_tangents: Option<Vec<[f64; 4]>>,
    uvs: BTreeMap<u32, Vec<[f64; 2]>>,
    triangles: Vec<[u32; 3]>,
}

impl Arrays {
    /// The arrays of `geos` (one index space); `sets`: the UV sets
    /// wanted, each gathered once however often named; `own`: whether to
    /// gather [`OWN_TANGENT`] too.
    fn gather(geos: &[TriGeometry], sets: &[u32], own: bool) -> Arrays {
        let mut sets = sets.to_vec();
        sets.sort_unstable();
        sets.dedup();
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for geo in geos {
            let base = positions.len() as u32;
            positions.extend(geo.positions.iter().map(|q| q.map(f64::from)));
            triangles.extend(geo.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        let mut normals = Vec::with_capacity(positions.len());
        let mut tangents = Vec::with_capacity(positions.len());
        let mut own_tangents = Vec::with_capacity(if own { positions.len() } else { 0 });
        let mut uvs: BTreeMap<u32, Vec<[f64; 2]>> = BTreeMap::new();
        for geo in geos {
            let n = geo.positions.len();
            // One attribute's component `k` of every vertex (`default` without it).
            let column = |sem: &str, k: usize, default: f64| -> Vec<f64> {
                match geo.attribute(sem).filter(|a| a.components > k) {
                    Some(a) => (0..n).map(|i| f64::from(a.get(i)[k])).collect(),
                    None => vec![default; n],
                }
            };
            let nrm: [Vec<f64>; 3] =
                std::array::from_fn(|k| column("NORMAL", k, [0.0, 0.0, 1.0][k]));
            let tan: [Vec<f64>; 4] =
                std::array::from_fn(|k| column("TANGENT", k, [0.0, 0.0, 0.0, 1.0][k]));
            normals.extend((0..n).map(|i| std::array::from_fn(|k| nrm[k][i])));
            tangents.extend((0..n).map(|i| std::array::from_fn(|k| tan[k][i])));
            if own {
                let t: [Vec<f64>; 4] =
                    std::array::from_fn(|k| column(OWN_TANGENT, k, [0.0, 0.0, 0.0, 1.0][k]));
                own_tangents.extend((0..n).map(|i| std::array::from_fn(|k| t[k][i])));
            }
            for &s in &sets {
                let (u, v) = (column(&set_name(s), 0, 0.0), column(&set_name(s), 1, 0.0));
                uvs.entry(s)
                    .or_default()
                    .extend((0..n).map(|i| [u[i], v[i]]));
            }
        }
        Arrays {
            positions,
            normals,
            tangents,
            own_tangents: own.then_some(own_tangents),
            uvs,
            triangles,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Mesh, Primitive, VertexAttribute};

    /// A triangle primitive with material 0 and UVs.
    fn prim(z: f32) -> Primitive {
        Primitive {
            material: Some(0),
            geometry: Geometry::Triangles(TriGeometry {
                positions: vec![[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]],
                attributes: vec![VertexAttribute {
                    semantic: "TEXCOORD_0".into(),
                    components: 2,
                    data: vec![0.0, 0.0, z, 0.0, 0.0, z],
                }],
                triangles: vec![[0, 1, 2]],
                ..Default::default()
            }),
            rest: Map::new(),
        }
    }

    /// A PNG's signature and header (no pixels), declaring `w` x `h` grey.
    fn png_header(w: u32, h: u32) -> Vec<u8> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Grayscale);
        let writer = enc.write_header().unwrap();
        drop(writer);
        out
    }

    #[test]
    fn material_images_are_held_to_the_budget_by_their_headers() {
        let image = |w, h| Image {
            name: Some("big.png".into()),
            mime_type: Some("image/png".into()),
            source: ImageSource::Bytes(png_header(w, h)),
            file_name: "big.png".into(),
            rest: Map::new(),
        };
        let material = |slot: &str| {
            let json = if slot == "baseColorTexture" {
                json!({ "pbrMetallicRoughness": { slot: { "index": 0 } } })
            } else {
                json!({ slot: { "index": 0 } })
            };
            Material {
                json: json.as_object().unwrap().clone(),
            }
        };
        for slot in ["baseColorTexture", "normalTexture", "occlusionTexture"] {
            let mut scene = Scene {
                meshes: vec![Mesh {
                    primitives: vec![prim(0.0)],
                    ..Default::default()
                }],
                materials: vec![material(slot)],
                textures: vec![json!({ "source": 0 })],
                images: vec![image(16384, 16384)],
                ..Default::default()
            };
            // 16384^2 RGBA: 4 GiB of values and the decoder's rows.
            let err = check_material_images(&scene, &[0], 100 << 20).unwrap_err();
            assert!(
                matches!(err, TextureError::OverBudget { width: 16384, .. }),
                "{slot}: {err}"
            );
            assert!(err.to_string().contains("big.png"), "{err}");
            // Nothing is decoded: the header alone passes a budget that
            // holds it, and a mesh not cracked is not looked at.
            assert!(check_material_images(&scene, &[0], 8 << 30).is_ok());
            assert!(check_material_images(&scene, &[], 1).is_ok());
            scene.images[0] = image(64, 64);
            assert!(check_material_images(&scene, &[0], 100 << 20).is_ok());
        }
    }

    #[test]
    fn a_set_named_twice_is_gathered_once_per_vertex() {
        // The baked set and the base colour texture's set are the same:
        // the second primitive's UVs must still line up with its vertices.
        let scene = Scene {
            meshes: vec![Mesh {
                primitives: vec![prim(0.25), prim(0.75)],
                ..Default::default()
            }],
            ..Default::default()
        };
        let geos: Vec<TriGeometry> = [0, 1].map(|p| tri_geometry(&scene, 0, p).clone()).to_vec();
        let a = Arrays::gather(&geos, &[0, 0], false);
        let uv = &a.uvs[&0];
        assert_eq!(uv.len(), a.positions.len());
        assert_eq!(uv[4], [0.75, 0.0]);
        assert_eq!(a.triangles[1], [3, 4, 5]);
    }
}
