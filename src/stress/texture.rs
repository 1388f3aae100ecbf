//! Grey-scale mask images sampled at UV coordinates, for the "texture" stress
//! term (Iben & O'Brien 2009, sec. 4.2.4): a grey image is sampled at each
//! triangle centroid's UV; black means full stress (weight 1), white none
//! (weight 0), optionally inverted.
//!
//! Conventions, as in glTF 2.0:
//!
//! - UV `(0, 0)` is the top-left corner of the image, `u` grows to the right
//!   and `v` downwards; texel `(i, j)` has its centre at
//!   `((i + 0.5) / width, (j + 0.5) / height)`.
//! - Filtering is bilinear; the wrap mode (`REPEAT`, `CLAMP_TO_EDGE`,
//!   `MIRRORED_REPEAT`) is applied to the integer texel indices as OpenGL does,
//!   separately in `u` (wrapS) and `v` (wrapT).
//! - `KHR_texture_transform` is applied to the UV before sampling:
//!   `uv' = T * R * S * uv` with the rotation counter-clockwise in UV space
//!   (`v` down), i.e. `u' = cos r u + sin r v`, `v' = -sin r u + cos r v`.
//!   This is the convention of the extension's examples, its sample model and
//!   the implementations (Babylon.js, three.js, Blender); the GLSL listing in
//!   the extension's README has the transposed matrix (KhronosGroup/glTF
//!   issue 1563).
//!
//! Luminance: `0.2126 R + 0.7152 G + 0.0722 B` (Rec. 709 weights) applied to
//! the stored channel values scaled to [0, 1], **without sRGB decoding**: a
//! mask is painted by eye, so a pixel of grey value 128 means a weight of
//! about one half whatever texture slot the image sits in. Grey images use
//! their grey value as is; alpha is ignored (a mask is its colour, and
//! treating transparent pixels as black would turn them into full stress).
//! 16-bit PNGs keep their precision (value / 65535).
//!
//! This layer does no I/O and decodes no file format: the caller's
//! [`ImageFiles`] reads and decodes (`crate::io::image_decode`, sizes
//! checked from the header before any pixel buffer is allocated: at most
//! [`MAX_PIXELS`] pixels).

use crate::scene::{Image, ImageSource, Scene};
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// Most pixels an image may have (16384 x 16384); larger images are refused
/// before their pixels are decoded.
pub const MAX_PIXELS: u64 = 16384 * 16384;

/// Largest image file read from disk (1 GiB).
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Memory the PNG decoder may use for its own buffers (rows, ancillary chunks).
pub(crate) const PNG_DECODER_LIMIT: usize = 256 << 20;

/// The material texture slots a mask can come from.
pub const SLOTS: [&str; 5] = [
    "baseColorTexture",
    "metallicRoughnessTexture",
    "normalTexture",
    "occlusionTexture",
    "emissiveTexture",
];

/// What went wrong while finding, reading or decoding a mask image.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    /// The slot name is not one of the glTF material's five texture slots.
    #[error("unknown texture slot '{slot}' (valid slots: {})", SLOTS.join(", "))]
    UnknownSlot {
        /// The slot asked for.
        slot: String,
    },
    /// The material index is out of range.
    #[error("material {index} does not exist (the scene has {count} materials)")]
    NoMaterial {
        /// The index asked for.
        index: usize,
        /// Number of materials in the scene.
        count: usize,
    },
    /// The material has nothing in the slot.
    #[error("{material} has no {slot}")]
    NoTexture {
        /// The material (index and name).
        material: String,
        /// The slot asked for.
        slot: String,
    },
    /// A texture, sampler or image reference of the scene is broken or unusable.
    #[error("{context}: {reason}")]
    BadReference {
        /// What holds the reference (material slot, texture, sampler).
        context: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The image bytes are not a PNG, JPEG or WebP this module can decode.
    #[error("image {image}: {reason}")]
    Decode {
        /// The image.
        image: String,
        /// What is wrong.
        reason: String,
    },
    /// The image declares more pixels than 16384 x 16384.
    #[error("image {image} is {width} x {height} pixels; at most {max} pixels (16384 x 16384) are accepted")]
    TooLarge {
        /// The image.
        image: String,
        /// Declared width.
        width: u64,
        /// Declared height.
        height: u64,
        /// The limit (16384 x 16384).
        max: u64,
    },
    /// Decoding the image would take more memory than the run's budget
    /// (`--max-memory`); checked on the header's size before decoding.
    #[error("image {image} is {width} x {height} pixels: decoded it needs {bytes} bytes, over the memory budget of {budget} bytes (--max-memory)")]
    OverBudget {
        /// The image.
        image: String,
        /// Declared width.
        width: u64,
        /// Declared height.
        height: u64,
        /// Bytes the decoded image would take.
        bytes: u64,
        /// The budget.
        budget: u64,
    },
    /// The image file cannot be read.
    #[error("image {image}: cannot read '{}': {source}", path.display())]
    Io {
        /// The image.
        image: String,
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The image file lies outside the folder it must come from.
    #[error("image {image}: file '{}' lies outside the asset folder '{}' and is not read", path.display(), base.display())]
    OutsideBase {
        /// The image.
        image: String,
        /// The file (symbolic links resolved).
        path: PathBuf,
        /// The folder.
        base: PathBuf,
    },
    /// A `KHR_texture_transform` object is malformed.
    #[error("KHR_texture_transform: {fault}")]
    Transform {
        /// What is wrong with it.
        fault: Box<TransformFault>,
    },
}

/// What is wrong with a `KHR_texture_transform` object.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TransformFault {
    /// The value is not an object.
    #[error("expected an object, got {got}")]
    NotObject {
        /// The value.
        got: Value,
    },
    /// `rotation` is not a finite number.
    #[error("rotation must be a number, got {got}")]
    Rotation {
        /// The value.
        got: Value,
    },
    /// `offset` or `scale` is not an array of 2 finite numbers.
    #[error("{field} must be an array of 2 numbers, got {got}")]
    Pair {
        /// The field (`offset`, `scale`).
        field: &'static str,
        /// The value.
        got: Value,
    },
}

impl From<TransformFault> for TextureError {
    fn from(fault: TransformFault) -> Self {
        TextureError::Transform {
            fault: Box::new(fault),
        }
    }
}

/// Texture wrap mode (glTF sampler `wrapS` / `wrapT`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Wrap {
    /// `REPEAT` (10497), the glTF default.
    #[default]
    Repeat,
    /// `CLAMP_TO_EDGE` (33071).
    ClampToEdge,
    /// `MIRRORED_REPEAT` (33648).
    MirroredRepeat,
}

impl Wrap {
    /// The wrap mode of a glTF / OpenGL enum value, `None` for other values.
    pub const fn from_gl(code: u64) -> Option<Wrap> {
        match code {
            10497 => Some(Wrap::Repeat),
            33071 => Some(Wrap::ClampToEdge),
            33648 => Some(Wrap::MirroredRepeat),
            _ => None,
        }
    }

    /// The glTF / OpenGL enum value.
    pub const fn gl(self) -> u32 {
        match self {
            Wrap::Repeat => 10497,
            Wrap::ClampToEdge => 33071,
            Wrap::MirroredRepeat => 33648,
        }
    }

    /// Bring a coordinate into a small range without changing what it
    /// samples (so texel indices stay small integers). Not finite: 0.
    pub fn reduce(self, t: f64) -> f64 {
        if !t.is_finite() {
            return 0.0;
        }
        match self {
            Wrap::Repeat => t.rem_euclid(1.0),
            Wrap::MirroredRepeat => t.rem_euclid(2.0),
            Wrap::ClampToEdge => t.clamp(-1.0, 2.0),
        }
    }

    /// The texel an integer texel index `i` reads in an image `n` texels wide
    /// (OpenGL's wrap of texel coordinates).
    pub fn texel(self, i: i64, n: i64) -> usize {
        let k = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        };
        k as usize
    }
}

/// A `KHR_texture_transform`: `uv' = T(offset) * R(rotation) * S(scale) * uv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Offset added last (in UV units).
    pub offset: [f64; 2],
    /// Rotation in radians, counter-clockwise in UV space (u right, v down).
    pub rotation: f64,
    /// Scale applied first.
    pub scale: [f64; 2],
}

impl Default for UvTransform {
    fn default() -> Self {
        UvTransform {
            offset: [0.0, 0.0],
            rotation: 0.0,
            scale: [1.0, 1.0],
        }
    }
}

impl UvTransform {
    /// Whether this is the identity.
    pub fn is_identity(&self) -> bool {
        *self == UvTransform::default()
    }

    /// The transformed UV: scale, then rotate (`u' = cos r u + sin r v`,
    /// `v' = -sin r u + cos r v`), then offset.
    pub fn apply(&self, uv: [f64; 2]) -> [f64; 2] {
        if self.is_identity() {
            return uv;
        }
        let x = uv[0] * self.scale[0];
        let y = uv[1] * self.scale[1];
        let (s, c) = self.rotation.sin_cos();
        [
            c * x + s * y + self.offset[0],
            -s * x + c * y + self.offset[1],
        ]
    }

    /// Parse a `KHR_texture_transform` object (`offset`, `rotation`, `scale`;
    /// missing ones take their defaults; `texCoord` is not part of the
    /// transform and is read by [`mask_from_material`]).
    ///
    /// # Errors
    /// [`TextureError::Transform`] when the value is not an object or a field
    /// has the wrong type or a non-finite number.
    pub fn from_json(v: &Value) -> Result<UvTransform, TextureError> {
        let obj = v
            .as_object()
            .ok_or_else(|| TransformFault::NotObject { got: v.clone() })?;
        let mut t = UvTransform::default();
        if let Some(o) = obj.get("offset") {
            t.offset = vec2(o, "offset")?;
        }
        if let Some(r) = obj.get("rotation") {
            t.rotation = r
                .as_f64()
                .filter(|r| r.is_finite())
                .ok_or_else(|| TransformFault::Rotation { got: r.clone() })?;
        }
        if let Some(s) = obj.get("scale") {
            t.scale = vec2(s, "scale")?;
        }
        Ok(t)
    }
}

fn vec2(v: &Value, field: &'static str) -> Result<[f64; 2], TransformFault> {
    let bad = || TransformFault::Pair {
        field,
        got: v.clone(),
    };
    let a = v.as_array().filter(|a| a.len() == 2).ok_or_else(bad)?;
    let x = a[0].as_f64().filter(|x| x.is_finite()).ok_or_else(bad)?;
    let y = a[1].as_f64().filter(|y| y.is_finite()).ok_or_else(bad)?;
    Ok([x, y])
}

/// A decoded grey-scale image.
#[derive(Clone, Debug, PartialEq)]
pub struct GreyImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Luminance in [0, 1], row-major, row 0 at the top (`v = 0` in glTF).
    pub data: Vec<f32>,
}

impl GreyImage {
    /// The luminance of texel `(x, y)` (`y = 0` is the top row), or `None`
    /// outside the image.
    pub fn texel(&self, x: u32, y: u32) -> Option<f32> {
        if x >= self.width || y >= self.height {
            return None;
        }
        self.data
            .get(y as usize * self.width as usize + x as usize)
            .copied()
    }

    /// Bilinearly filtered luminance at `uv` (glTF convention: `(0, 0)` is the
    /// top-left corner of the image, `v` grows downwards, texel centres at
    /// `(i + 0.5) / width`), with `wrap_s` applied in `u` and `wrap_t` in
    /// `v`. Non-finite coordinates sample as 0. An image whose `data` does
    /// not hold `width * height` values samples as 0.
    pub fn sample(&self, uv: [f64; 2], wrap_s: Wrap, wrap_t: Wrap) -> f32 {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || self.data.len() != w * h {
            return 0.0;
        }
        let x = wrap_s.reduce(uv[0]) * w as f64 - 0.5;
        let y = wrap_t.reduce(uv[1]) * h as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let (wi, hi) = (w as i64, h as i64);
        let i0 = wrap_s.texel(x0, wi);
        let i1 = wrap_s.texel(x0 + 1, wi);
        let j0 = wrap_t.texel(y0, hi);
        let j1 = wrap_t.texel(y0 + 1, hi);
        let t = |i: usize, j: usize| f64::from(self.data[j * w + i]);
        let top = t(i0, j0) * (1.0 - fx) + t(i1, j0) * fx;
        let bottom = t(i0, j1) * (1.0 - fx) + t(i1, j1) * fx;
        (top * (1.0 - fy) + bottom * fy) as f32
    }
}


/// Where a material mask's image files come from and how they decode. This
/// layer does no I/O and decodes no format: the caller supplies both
/// (`crate::io::image::Files` reads inside an asset's folder, with a size
/// cap, and decodes within the run's memory budget).
pub trait ImageFiles {
    /// The bytes of the image file at `path`; `name` labels the image in
    /// errors.
    ///
    /// # Errors
    /// [`TextureError::Io`] or [`TextureError::OutsideBase`].
    fn read(&self, path: &Path, name: &str) -> Result<Vec<u8>, TextureError>;

    /// The image `bytes` (a file's or embedded) decoded into luminance,
    /// within the run's memory budget; `name` labels the image in errors.
    ///
    /// # Errors
    /// [`TextureError::Decode`], [`TextureError::TooLarge`] or
    /// [`TextureError::OverBudget`].
    fn decode(&self, bytes: &[u8], name: &str) -> Result<GreyImage, TextureError>;
}

/// A texture-stress mask: an image with its sampler and UV transform.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    /// The image.
    pub image: GreyImage,
    /// Wrap in `u`.
    pub wrap_s: Wrap,
    /// Wrap in `v`.
    pub wrap_t: Wrap,
    /// UV transform applied before sampling.
    pub transform: UvTransform,
    /// When set the weight is the luminance (white = full stress) instead of
    /// `1 - luminance`.
    pub invert: bool,
    /// The `TEXCOORD_n` set the UVs come from (the textureInfo's `texCoord`,
    /// or the `KHR_texture_transform` override).
    pub tex_coord: u32,
    /// Also scale the separation by the weight (the mask marks where the
    /// cracking layer is): cracks stay where the mask is dark.
    pub confine: bool,
}

impl Mask {
    /// A mask of `image` with repeat wrapping, no transform, `TEXCOORD_0`,
    /// not inverted.
    pub fn from_image(image: GreyImage) -> Mask {
        Mask {
            image,
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            transform: UvTransform::default(),
            invert: false,
            tex_coord: 0,
            confine: false,
        }
    }

    /// Stress weight in [0, 1] at `uv` (of set [`Mask::tex_coord`]): the
    /// transform is applied, the image sampled, and the weight is
    /// `1 - luminance` (black = 1), or the luminance when inverted.
    pub fn weight(&self, uv: [f64; 2]) -> f64 {
        let l = f64::from(
            self.image
                .sample(self.transform.apply(uv), self.wrap_s, self.wrap_t),
        )
        .clamp(0.0, 1.0);
        if self.invert {
            l
        } else {
            1.0 - l
        }
    }
}

/// `material 2 'bark'` or `material 2`.
fn material_label(scene: &Scene, i: usize) -> String {
    match scene.materials[i].name() {
        Some(n) => format!("material {i} '{n}'"),
        None => format!("material {i}"),
    }
}

/// `'bark' (image 3, bark.png)`, naming the image as well as the scene can.
fn image_label(i: usize, img: &Image) -> String {
    match &img.name {
        Some(n) if *n != img.file_name => format!("'{n}' (image {i}, {})", img.file_name),
        _ => format!("'{}' (image {i})", img.file_name),
    }
}

fn index_of(v: &Value, key: &str) -> Option<Result<usize, ()>> {
    v.get(key).map(|x| x.as_u64().map(|x| x as usize).ok_or(()))
}

/// Build the [`Mask`] of `material`'s texture in `slot` (one of [`SLOTS`]):
/// the texture's image decoded to grey, its sampler's `wrapS` / `wrapT`
/// (default repeat), the textureInfo's `KHR_texture_transform` and its
/// `texCoord` (the extension's `texCoord` overrides the textureInfo's).
///
/// Image files ([`ImageSource::File`]) are read through `files` from the
/// path the reader resolved (`crate::io::image::Files` refuses a file whose
/// real path lies outside the asset's folder).
///
/// # Errors
/// An unknown slot (the message lists the valid ones), a material index out of
/// range, a material with nothing in the slot (named), broken texture,
/// sampler or image references, a texture without a PNG/JPEG source, a
/// malformed `KHR_texture_transform`, a file `files` refuses,
/// and an image that does not decode (named).
pub fn mask_from_material(
    scene: &Scene,
    material: usize,
    slot: &str,
    invert: bool,
    files: &dyn ImageFiles,
) -> Result<Mask, TextureError> {
    let t = texture_of_material(scene, material, slot)?;
    let bytes = t.bytes(scene, files)?;
    Ok(Mask {
        image: files.decode(&bytes, &t.name)?,
        wrap_s: t.wrap_s,
        wrap_t: t.wrap_t,
        transform: t.transform,
        invert,
        tex_coord: t.tex_coord,
        confine: false,
    })
}

/// Where a material's texture in one slot samples from: its image, sampler
/// wraps, UV transform and UV set.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Scene::images`].
    pub image: usize,
    /// The image, named for messages.
    pub name: String,
    /// Wrap in `u`.
    pub wrap_s: Wrap,
    /// Wrap in `v`.
    pub wrap_t: Wrap,
    /// The textureInfo's `KHR_texture_transform` (identity without one).
    pub transform: UvTransform,
    /// The `TEXCOORD_n` set (the transform's `texCoord` overrides the
    /// textureInfo's).
    pub tex_coord: u32,
}

impl TextureRef {
    /// The image's encoded bytes (a file is read through `files`).
    ///
    /// # Errors
    /// What `files` returns for an image file.
    pub fn bytes(&self, scene: &Scene, files: &dyn ImageFiles) -> Result<Vec<u8>, TextureError> {
        match &scene.images[self.image].source {
            ImageSource::Bytes(b) => Ok(b.clone()),
            ImageSource::File(path) => files.read(path, &self.name),
        }
    }
}

/// The texture `material` has in `slot` (one of [`SLOTS`]), its references
/// checked, as [`mask_from_material`] describes.
///
/// # Errors
/// Those of [`mask_from_material`] except the image's reading and decoding.
pub fn texture_of_material(
    scene: &Scene,
    material: usize,
    slot: &str,
) -> Result<TextureRef, TextureError> {
    if !SLOTS.contains(&slot) {
        return Err(TextureError::UnknownSlot {
            slot: slot.to_string(),
        });
    }
    if material >= scene.materials.len() {
        return Err(TextureError::NoMaterial {
            index: material,
            count: scene.materials.len(),
        });
    }
    let json = &scene.materials[material].json;
    let info = match slot {
        "baseColorTexture" | "metallicRoughnessTexture" => {
            json.get("pbrMetallicRoughness").and_then(|p| p.get(slot))
        }
        _ => json.get(slot),
    };
    let label = material_label(scene, material);
    let Some(info) = info else {
        return Err(TextureError::NoTexture {
            material: label,
            slot: slot.to_string(),
        });
    };
    let context = format!("{label} {slot}");
    let bad = |context: &str, reason: String| TextureError::BadReference {
        context: context.to_string(),
        reason,
    };
    let texture = match index_of(info, "index") {
        Some(Ok(t)) => t,
        Some(Err(())) => return Err(bad(&context, "index is not a texture index".into())),
        None => return Err(bad(&context, "the textureInfo has no index".into())),
    };
    let tex = scene.textures.get(texture).ok_or_else(|| {
        bad(
            &context,
            format!(
                "texture {texture} does not exist (the scene has {})",
                scene.textures.len()
            ),
        )
    })?;
    let tex_context = format!("texture {texture} (of {context})");

    // texCoord, then the transform and its override.
    let mut tex_coord = match index_of(info, "texCoord") {
        Some(Ok(t)) => t as u32,
        Some(Err(())) => return Err(bad(&context, "texCoord is not a set index".into())),
        None => 0,
    };
    let mut transform = UvTransform::default();
    if let Some(ext) = info.pointer("/extensions/KHR_texture_transform") {
        transform = UvTransform::from_json(ext).map_err(|e| bad(&context, e.to_string()))?;
        match index_of(ext, "texCoord") {
            Some(Ok(t)) => tex_coord = t as u32,
            Some(Err(())) => {
                return Err(bad(
                    &context,
                    "KHR_texture_transform texCoord is not a set index".into(),
                ))
            }
            None => {}
        }
    }

    // Sampler.
    let (wrap_s, wrap_t) = match index_of(tex, "sampler") {
        None => (Wrap::Repeat, Wrap::Repeat),
        Some(Err(())) => return Err(bad(&tex_context, "sampler is not an index".into())),
        Some(Ok(s)) => {
            let sampler = scene.samplers.get(s).ok_or_else(|| {
                bad(
                    &tex_context,
                    format!(
                        "sampler {s} does not exist (the scene has {})",
                        scene.samplers.len()
                    ),
                )
            })?;
            let wrap = |key: &str| {
                match sampler.get(key) {
                None => Ok(Wrap::Repeat),
                Some(v) => v.as_u64().and_then(Wrap::from_gl).ok_or_else(|| {
                    bad(
                        &format!("sampler {s}"),
                        format!("{key} {v} is not 10497 (REPEAT), 33071 (CLAMP_TO_EDGE) or 33648 (MIRRORED_REPEAT)"),
                    )
                }),
            }
            };
            (wrap("wrapS")?, wrap("wrapT")?)
        }
    };

    // Image.
    // A WebP through EXT_texture_webp first (its `source` is the fallback).
    let webp = tex
        .get("extensions")
        .and_then(|e| e.get("EXT_texture_webp"))
        .and_then(|w| w.get("source"))
        .and_then(Value::as_u64)
        .map(|i| i as usize);
    let source = match webp.map(Ok).or_else(|| index_of(tex, "source")) {
        Some(Ok(i)) => i,
        Some(Err(())) => return Err(bad(&tex_context, "source is not an image index".into())),
        None => {
            let exts: Vec<&str> = tex
                .get("extensions")
                .and_then(Value::as_object)
                .map(|o: &Map<String, Value>| o.keys().map(String::as_str).collect())
                .unwrap_or_default();
            let reason = if exts.is_empty() {
                "it has no source image".to_string()
            } else {
                format!(
                    "it has no PNG/JPEG/WebP source, only images of extensions ({}) this tool does not decode",
                    exts.join(", ")
                )
            };
            return Err(bad(&tex_context, reason));
        }
    };
    let img = scene.images.get(source).ok_or_else(|| {
        bad(
            &tex_context,
            format!(
                "image {source} does not exist (the scene has {})",
                scene.images.len()
            ),
        )
    })?;
    Ok(TextureRef {
        image: source,
        name: image_label(source, img),
        wrap_s,
        wrap_t,
        transform,
        tex_coord,
    })
}

#[cfg(test)]
mod tests {
    use crate::io::image_decode::luma;
    use super::*;
    use crate::scene::Material;
    use base64::Engine as _;
    use serde_json::json;

    const EPS: f32 = 1e-6;

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() <= EPS
    }

    fn assert_close(a: f32, b: f32, what: &str) {
        assert!(close(a, b), "{what}: {a} != {b}");
    }

    /// A PNG from the `png` encoder.
    fn png_bytes(
        w: u32,
        h: u32,
        color: png::ColorType,
        depth: png::BitDepth,
        palette: Option<(&[u8], Option<&[u8]>)>,
        data: &[u8],
    ) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, w, h);
            enc.set_color(color);
            enc.set_depth(depth);
            if let Some((pal, trns)) = palette {
                enc.set_palette(pal.to_vec());
                if let Some(t) = trns {
                    enc.set_trns(t.to_vec());
                }
            }
            let mut wr = enc.write_header().unwrap();
            wr.write_image_data(data).unwrap();
            wr.finish().unwrap();
        }
        out
    }

    fn grey8(w: u32, h: u32, data: &[u8]) -> Vec<u8> {
        png_bytes(
            w,
            h,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            None,
            data,
        )
    }

    fn image(w: u32, h: u32, data: &[f32]) -> GreyImage {
        GreyImage {
            width: w,
            height: h,
            data: data.to_vec(),
        }
    }

    /// A 4x1 row 0, 1/3, 2/3, 1 decoded from an 8-bit grey PNG.
    fn ramp() -> GreyImage {
        let img = crate::io::image_decode::grey(&grey8(4, 1, &[0, 85, 170, 255]), "ramp").unwrap();
        assert_eq!((img.width, img.height), (4, 1));
        for (i, want) in [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0].into_iter().enumerate() {
            assert_close(img.data[i], want, "ramp texel");
        }
        img
    }

    #[test]
    fn bilinear_at_texel_centres_and_between() {
        let img = ramp();
        let s = |u: f64| img.sample([u, 0.5], Wrap::ClampToEdge, Wrap::ClampToEdge);
        // Texel centres (i + 0.5) / 4.
        for i in 0..4 {
            assert_close(s((i as f64 + 0.5) / 4.0), img.data[i], "centre");
        }
        // Halfway between centres 0 and 1, a quarter of the way from 1 to 2.
        assert_close(s(0.25), 1.0 / 6.0, "between 0 and 1");
        assert_close(s(0.375 + 0.0625), 1.0 / 3.0 + 0.25 / 3.0, "quarter 1..2");
        // 2-D: a 2x2 image; the centre is the mean, edges mix two texels.
        let sq = image(2, 2, &[0.0, 0.2, 0.6, 1.0]);
        let s2 = |u, v| sq.sample([u, v], Wrap::ClampToEdge, Wrap::ClampToEdge);
        assert_close(s2(0.25, 0.25), 0.0, "top-left centre");
        assert_close(s2(0.75, 0.25), 0.2, "top-right centre");
        assert_close(s2(0.25, 0.75), 0.6, "bottom-left centre (row 1 is below)");
        assert_close(s2(0.5, 0.5), 0.45, "centre = mean");
        assert_close(s2(0.5, 0.25), 0.1, "top edge");
        assert_close(s2(0.25, 0.5), 0.3, "left edge");
        // Bilinear weights (0.75, 0.25) x (0.5, 0.5).
        let want = 0.5 * (0.75 * 0.0 + 0.25 * 0.2) + 0.5 * (0.75 * 0.6 + 0.25 * 1.0);
        assert_close(s2(0.375, 0.5), want, "off-centre");
    }

    #[test]
    fn row_zero_is_the_top_v_zero() {
        // Top row black, bottom row white: small v samples the top.
        let img = crate::io::image_decode::grey(&grey8(1, 2, &[0, 255]), "column").unwrap();
        assert_close(
            img.sample([0.5, 0.25], Wrap::Repeat, Wrap::ClampToEdge),
            0.0,
            "top",
        );
        assert_close(
            img.sample([0.5, 0.75], Wrap::Repeat, Wrap::ClampToEdge),
            1.0,
            "bottom",
        );
        assert_close(img.texel(0, 1).unwrap(), 1.0, "texel (0, 1)");
        assert!(img.texel(1, 0).is_none());
    }

    #[test]
    fn repeat_wraps_outside_unit_square() {
        let img = ramp();
        let s = |u: f64| img.sample([u, 0.5], Wrap::Repeat, Wrap::Repeat);
        // u = 0 lies halfway between the last and the first texel.
        assert_close(s(0.0), 0.5, "u = 0");
        assert_close(s(1.0), 0.5, "u = 1");
        for u in [0.0, 0.1, 0.3, 0.5, 0.625, 0.9, 0.99] {
            for k in [-3.0, -1.0, 1.0, 2.0, 7.0] {
                assert!((s(u) - s(u + k)).abs() < 1e-5, "repeat u={u} k={k}");
            }
        }
        // Negative u: -0.125 is texel 3's centre (0.875 - 1).
        assert_close(s(-0.125), 1.0, "u = -0.125");
        assert_close(s(-0.875), 0.0, "u = -0.875");
        // In v too.
        let col = image(1, 2, &[0.0, 1.0]);
        let t = |v: f64| col.sample([0.5, v], Wrap::ClampToEdge, Wrap::Repeat);
        assert_close(t(-0.25), 1.0, "v = -0.25");
        assert_close(t(1.25), 0.0, "v = 1.25");
        assert_close(t(0.0), 0.5, "v = 0");
    }

    #[test]
    fn clamp_to_edge_holds_the_border_texel() {
        let img = ramp();
        let s = |u: f64| img.sample([u, 0.5], Wrap::ClampToEdge, Wrap::ClampToEdge);
        for u in [-100.0, -1.5, -0.2, 0.0, 0.125] {
            assert_close(s(u), 0.0, "left of the first centre");
        }
        for u in [0.875, 1.0, 1.3, 42.0] {
            assert_close(s(u), 1.0, "right of the last centre");
        }
        assert_close(s(f64::INFINITY), 0.0, "non-finite samples as 0");
        let col = image(1, 2, &[0.25, 0.75]);
        let t = |v: f64| col.sample([0.5, v], Wrap::Repeat, Wrap::ClampToEdge);
        assert_close(t(-3.0), 0.25, "v < 0");
        assert_close(t(3.0), 0.75, "v > 1");
    }

    #[test]
    fn mirrored_repeat_is_symmetric() {
        let img = ramp();
        let s = |u: f64| img.sample([u, 0.5], Wrap::MirroredRepeat, Wrap::MirroredRepeat);
        for u in [0.0, 0.05, 0.125, 0.2, 0.33, 0.5, 0.7, 0.875, 0.95, 1.0] {
            assert!((s(u) - s(-u)).abs() < 1e-5, "mirror about 0 at {u}");
            assert!(
                (s(1.0 + u) - s(1.0 - u)).abs() < 1e-5,
                "mirror about 1 at {u}"
            );
            assert!((s(u) - s(u + 2.0)).abs() < 1e-5, "period 2 at {u}");
            assert!((s(u) - s(u - 4.0)).abs() < 1e-5, "period 2 at {u} - 4");
        }
        // The edges repeat their texel: u = 0 and u = 1 are border texels.
        assert_close(s(0.0), 0.0, "u = 0");
        assert_close(s(1.0), 1.0, "u = 1");
        // Mirror images of the centres.
        assert_close(s(-0.375), 1.0 / 3.0, "u = -0.375 is texel 1");
        assert_close(s(1.125), 1.0, "u = 1.125 is texel 3");
        assert_close(s(1.375), 2.0 / 3.0, "u = 1.375 is texel 2");
        // Different from repeat, which would wrap to the other end.
        let r = img.sample([-0.125, 0.5], Wrap::Repeat, Wrap::Repeat);
        assert!((s(-0.125) - r).abs() > 0.5);
        // In v.
        let col = image(1, 3, &[0.0, 0.5, 1.0]);
        let t = |v: f64| col.sample([0.5, v], Wrap::Repeat, Wrap::MirroredRepeat);
        for v in [0.1, 0.4, 0.8] {
            assert!((t(v) - t(-v)).abs() < 1e-5, "v mirror at {v}");
        }
        assert_close(t(-0.5), 0.5, "v = -0.5 is row 1");
        assert_close(t(-1.0 / 6.0), 0.0, "v = -1/6 is row 0");
    }

    #[test]
    fn wrap_modes_from_gltf_codes() {
        for w in [Wrap::Repeat, Wrap::ClampToEdge, Wrap::MirroredRepeat] {
            assert_eq!(Wrap::from_gl(u64::from(w.gl())), Some(w));
        }
        assert_eq!(Wrap::from_gl(10497), Some(Wrap::Repeat));
        assert_eq!(Wrap::from_gl(33071), Some(Wrap::ClampToEdge));
        assert_eq!(Wrap::from_gl(33648), Some(Wrap::MirroredRepeat));
        assert_eq!(Wrap::from_gl(9729), None);
        assert_eq!(Wrap::default(), Wrap::Repeat);
    }

    fn assert_uv(a: [f64; 2], b: [f64; 2], what: &str) {
        assert!(
            (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9,
            "{what}: {a:?} != {b:?}"
        );
    }

    #[test]
    #[allow(clippy::approx_constant)] // the spec's literal 1.57079632679
    fn texture_transform_spec_examples() {
        // "This example utilizes only the lower left quadrant of the source
        // image, rotated clockwise 90 degrees."
        let t = UvTransform::from_json(&json!({
            "offset": [0, 1],
            "rotation": 1.57079632679,
            "scale": [0.5, 0.5]
        }))
        .unwrap();
        assert_eq!(t.offset, [0.0, 1.0]);
        assert_eq!(t.scale, [0.5, 0.5]);
        assert_uv(t.apply([0.0, 0.0]), [0.0, 1.0], "(0,0)");
        assert_uv(t.apply([1.0, 0.0]), [0.0, 0.5], "(1,0)");
        assert_uv(t.apply([0.0, 1.0]), [0.5, 1.0], "(0,1)");
        assert_uv(t.apply([1.0, 1.0]), [0.5, 0.5], "(1,1)");
        // Every UV of the unit square lands in the lower-left quadrant.
        for i in 0..=10 {
            for j in 0..=10 {
                let [u, v] = t.apply([i as f64 / 10.0, j as f64 / 10.0]);
                assert!((-1e-9..=0.5 + 1e-9).contains(&u), "u {u}");
                assert!((0.5 - 1e-9..=1.0 + 1e-9).contains(&v), "v {v}");
            }
        }
        // Sampled through a mask: a 4x4 image, white but for its lower-left
        // quadrant (columns 0-1, rows 2-3) of 0.0 0.2 / 0.4 0.6. The mask
        // shows that quadrant turned clockwise by 90 degrees: its top-left
        // texel at the top right, its bottom-left texel at the top left.
        #[rustfmt::skip]
        let px = [
            1.0, 1.0, 1.0, 1.0,
            1.0, 1.0, 1.0, 1.0,
            0.0, 0.2, 1.0, 1.0,
            0.4, 0.6, 1.0, 1.0,
        ];
        let mut m = Mask::from_image(image(4, 4, &px));
        m.wrap_s = Wrap::ClampToEdge;
        m.wrap_t = Wrap::ClampToEdge;
        m.transform = t;
        for (uv, lum) in [
            ([0.25, 0.25], 0.4),
            ([0.75, 0.25], 0.0),
            ([0.25, 0.75], 0.6),
            ([0.75, 0.75], 0.2),
        ] {
            assert!(
                (m.weight(uv) - (1.0 - lum)).abs() < 1e-6,
                "weight at {uv:?}"
            );
        }
        // "This example inverts the T axis, effectively defining a bottom-left origin."
        let flip = UvTransform::from_json(&json!({"offset": [0, 1], "scale": [1, -1]})).unwrap();
        assert_eq!(flip.rotation, 0.0);
        assert_uv(flip.apply([0.25, 0.0]), [0.25, 1.0], "flip (0.25,0)");
        assert_uv(flip.apply([0.25, 0.75]), [0.25, 0.25], "flip (0.25,0.75)");
    }

    #[test]
    fn texture_transform_is_translation_rotation_scale() {
        let t = UvTransform {
            offset: [0.3, -0.2],
            rotation: 0.7,
            scale: [2.0, 0.5],
        };
        let (s, c) = 0.7f64.sin_cos();
        for uv in [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.4, -1.3]] {
            // T * R * S with R = [[c, s], [-s, c]] (rows).
            let (x, y) = (uv[0] * 2.0, uv[1] * 0.5);
            let want = [c * x + s * y + 0.3, -s * x + c * y - 0.2];
            assert_uv(t.apply(uv), want, "T*R*S");
        }
        // Scale is applied before rotation: with scale (2, 1) and a quarter
        // turn, u = 1 becomes v = -2 (R * S), not -1 (S * R).
        let q = UvTransform {
            offset: [0.0, 0.0],
            rotation: std::f64::consts::FRAC_PI_2,
            scale: [2.0, 1.0],
        };
        assert_uv(q.apply([1.0, 0.0]), [0.0, -2.0], "R*S order");
        // Identity and defaults.
        let id = UvTransform::from_json(&json!({})).unwrap();
        assert!(id.is_identity());
        assert_eq!(id.apply([0.3, 0.7]), [0.3, 0.7]);
        assert_eq!(UvTransform::from_json(&json!({"texCoord": 1})).unwrap(), id);
    }

    #[test]
    fn texture_transform_errors() {
        for bad in [
            json!([1, 2]),
            json!({"offset": [1, 2, 3]}),
            json!({"offset": "x"}),
            json!({"scale": [1, "a"]}),
            json!({"rotation": "90deg"}),
        ] {
            let e = UvTransform::from_json(&bad).unwrap_err();
            assert!(matches!(e, TextureError::Transform { .. }), "{bad}");
            assert!(e.to_string().starts_with("KHR_texture_transform"), "{e}");
        }
    }

    #[test]
    fn grey_alpha_palette_and_16_bit_decode() {
        // Grey + alpha: alpha is ignored.
        let ga = png_bytes(
            2,
            1,
            png::ColorType::GrayscaleAlpha,
            png::BitDepth::Eight,
            None,
            &[51, 0, 204, 255],
        );
        let img = crate::io::image_decode::grey(&ga, "ga").unwrap();
        assert_close(img.data[0], 0.2, "grey+alpha 0");
        assert_close(img.data[1], 0.8, "grey+alpha 1");

        // Palette (with tRNS): Rec. 709 of the palette colour, no sRGB decoding.
        let pal: &[u8] = &[255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255];
        let trns: &[u8] = &[0, 128];
        for trns in [None, Some(trns)] {
            let p = png_bytes(
                4,
                1,
                png::ColorType::Indexed,
                png::BitDepth::Eight,
                Some((pal, trns)),
                &[0, 1, 2, 3],
            );
            let img = crate::io::image_decode::grey(&p, "palette").unwrap();
            assert_close(img.data[0], 0.2126, "red");
            assert_close(img.data[1], 0.7152, "green");
            assert_close(img.data[2], 0.0722, "blue");
            assert_close(img.data[3], 1.0, "white");
        }
        // 2-bit palette (packed indices).
        let p = png_bytes(
            4,
            1,
            png::ColorType::Indexed,
            png::BitDepth::Two,
            Some((pal, None)),
            &[0b00_01_10_11],
        );
        let img = crate::io::image_decode::grey(&p, "palette2").unwrap();
        assert_close(img.data[0], 0.2126, "2-bit red");
        assert_close(img.data[3], 1.0, "2-bit white");

        // 16-bit grey keeps its precision.
        let g16 = png_bytes(
            3,
            1,
            png::ColorType::Grayscale,
            png::BitDepth::Sixteen,
            None,
            &[0x00, 0x00, 0x80, 0x00, 0xFF, 0xFF],
        );
        let img = crate::io::image_decode::grey(&g16, "g16").unwrap();
        assert_close(img.data[0], 0.0, "16-bit 0");
        assert_close(img.data[1], 32768.0 / 65535.0, "16-bit mid");
        assert_close(img.data[2], 1.0, "16-bit max");

        // 16-bit RGBA.
        let rgba16 = png_bytes(
            1,
            1,
            png::ColorType::Rgba,
            png::BitDepth::Sixteen,
            None,
            &[0xFF, 0xFF, 0x00, 0x00, 0x80, 0x00, 0x00, 0x00],
        );
        let img = crate::io::image_decode::grey(&rgba16, "rgba16").unwrap();
        assert_close(
            img.data[0],
            0.2126 + 0.0722 * 32768.0 / 65535.0,
            "16-bit RGBA",
        );

        // 8-bit RGB: mid grey is 128/255 (no sRGB linearisation).
        let rgb = png_bytes(
            1,
            1,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            &[128, 128, 128],
        );
        let img = crate::io::image_decode::grey(&rgb, "rgb").unwrap();
        assert_close(img.data[0], 128.0 / 255.0, "RGB grey");

        // 1-bit grey expands to 0 / 1.
        let g1 = png_bytes(
            8,
            1,
            png::ColorType::Grayscale,
            png::BitDepth::One,
            None,
            &[0b1010_0001],
        );
        let img = crate::io::image_decode::grey(&g1, "g1").unwrap();
        let bits: Vec<f32> = img.data.clone();
        assert_eq!(bits, vec![1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    }

    /// 7 x 5 Adam7-interlaced 8-bit grey PNG, value 10 x + 40 y (written by
    /// a few lines of Python with zlib).
    const INTERLACED_PNG: &str = "iVBORw0KGgoAAAANSUhEUgAAAAcAAAAFCAAAAAHb9pmSAAAAN0lEQVR42mNgYNBgWHCCQcSGYcsdhoCUih4GLjkjhqi8JoZV+y4xaBjZuAVEpTBUNPVMW7BqCwAnoQ8LOtRHPAAAAABJRU5ErkJggg==";

    #[test]
    fn interlaced_png_decodes() {
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(INTERLACED_PNG)
            .unwrap();
        assert_eq!(bytes[28], 1, "the fixture is interlaced");
        let img = crate::io::image_decode::grey(&bytes, "interlaced").unwrap();
        assert_eq!((img.width, img.height), (7, 5));
        for y in 0..5 {
            for x in 0..7 {
                let want = (10 * x + 40 * y) as f32 / 255.0;
                assert_close(img.texel(x, y).unwrap(), want, "interlaced texel");
            }
        }
    }

    /// 16 x 8 grey JPEG (quality 95), left 8 columns black, right 8 white.
    const GREY_JPEG: &str = "/9j/4AAQSkZJRgABAQAAAQABAAD/2wBDAAIBAQEBAQIBAQECAgICAgQDAgICAgUEBAMEBgUGBgYFBgYGBwkIBgcJBwYGCAsICQoKCgoKBggLDAsKDAkKCgr/wAALCAAIABABAREA/8QAFAABAAAAAAAAAAAAAAAAAAAACv/EABQQAQAAAAAAAAAAAAAAAAAAAAD/2gAIAQEAAD8AP+f4/9k=";
    /// 16 x 16 RGB JPEG (quality 95, 4:4:4), 8 x 8 quadrants red, green /
    /// blue, white.
    const RGB_JPEG: &str = "/9j/4AAQSkZJRgABAQAAAQABAAD/2wBDAAIBAQEBAQIBAQECAgICAgQDAgICAgUEBAMEBgUGBgYFBgYGBwkIBgcJBwYGCAsICQoKCgoKBggLDAsKDAkKCgr/2wBDAQICAgICAgUDAwUKBwYHCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgoKCgr/wAARCAAQABADAREAAhEBAxEB/8QAFgABAQEAAAAAAAAAAAAAAAAACQgK/8QAFBABAAAAAAAAAAAAAAAAAAAAAP/EABcBAAMBAAAAAAAAAAAAAAAAAAgJCgf/xAAUEQEAAAAAAAAAAAAAAAAAAAAA/9oADAMBAAIRAxEAPwCLwpn+EoC2hXA2tMNYbiCA2qP/2Q==";

    fn b64(s: &str) -> Vec<u8> {
        base64::engine::general_purpose::STANDARD.decode(s).unwrap()
    }

    #[test]
    fn jpeg_decodes_to_luminance() {
        let img = crate::io::image_decode::grey(&b64(GREY_JPEG), "grey.jpg").unwrap();
        assert_eq!((img.width, img.height), (16, 8));
        for y in 0..8 {
            assert!(img.texel(2, y).unwrap() < 0.02, "black half");
            assert!(img.texel(13, y).unwrap() > 0.98, "white half");
        }
        let img = crate::io::image_decode::grey(&b64(RGB_JPEG), "rgb.jpg").unwrap();
        assert_eq!((img.width, img.height), (16, 16));
        let near = |x, y, want: f32| {
            let got = img.texel(x, y).unwrap();
            assert!((got - want).abs() < 0.02, "({x},{y}): {got} vs {want}");
        };
        near(4, 4, 0.2126);
        near(12, 4, 0.7152);
        near(4, 12, 0.0722);
        near(12, 12, 1.0);
    }

    #[test]
    fn jpeg_huge_dimensions_are_refused_from_the_header() {
        let mut bytes = b64(GREY_JPEG);
        // SOF0: FF C0, length (2), precision (1), height (2), width (2).
        let sof = bytes
            .windows(2)
            .position(|w| w == [0xFF, 0xC0])
            .expect("SOF0");
        bytes[sof + 5..sof + 9].copy_from_slice(&[0xFF, 0xFF, 0xFF, 0xFF]);
        let e = crate::io::image_decode::grey(&bytes, "huge.jpg").unwrap_err();
        assert!(
            matches!(
                e,
                TextureError::TooLarge {
                    width: 65535,
                    height: 65535,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("huge.jpg"), "{e}");
    }

    #[test]
    fn corrupt_images_give_errors_naming_the_image() {
        let good = grey8(4, 4, &[7; 16]);
        // Flip bytes inside the IDAT data.
        let idat = good.windows(4).position(|w| w == b"IDAT").unwrap();
        let mut bad = good.clone();
        for b in &mut bad[idat + 6..idat + 12] {
            *b ^= 0x5A;
        }
        let e = crate::io::image_decode::grey(&bad, "'wall_mask.png'").unwrap_err();
        assert!(matches!(e, TextureError::Decode { .. }), "{e}");
        assert!(e.to_string().contains("wall_mask.png"), "{e}");
        // Truncated.
        let e = crate::io::image_decode::grey(&good[..good.len() / 2], "'cut.png'").unwrap_err();
        assert!(e.to_string().contains("cut.png"), "{e}");
        // Truncated header.
        let e = crate::io::image_decode::grey(&good[..20], "'short.png'").unwrap_err();
        assert!(e.to_string().contains("short.png"), "{e}");
        // Not an image at all, and formats that are not decoded.
        let e = crate::io::image_decode::grey(b"hello world, not a picture", "'notes.txt'").unwrap_err();
        assert!(e.to_string().contains("notes.txt"), "{e}");
        assert!(e.to_string().contains("PNG, JPEG or WebP"), "{e}");
        let e = crate::io::image_decode::grey(b"RIFF\0\0\0\0WEBPVP8 ", "'a.webp'").unwrap_err();
        assert!(
            e.to_string().contains("WebP") && e.to_string().contains("a.webp"),
            "{e}"
        );
        // A JPEG cut after its header.
        let jpeg = b64(GREY_JPEG);
        let e = crate::io::image_decode::grey(&jpeg[..24], "'cut.jpg'").unwrap_err();
        assert!(e.to_string().contains("cut.jpg"), "{e}");
    }

    /// CRC-32 (IEEE) for hand-made PNG chunks.
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 != 0 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
        !crc
    }

    /// A PNG whose IHDR declares `w x h` 8-bit grey, with a tiny IDAT.
    fn png_header_only(w: u32, h: u32) -> Vec<u8> {
        let chunk = |tag: &[u8], data: &[u8]| {
            let mut c = (data.len() as u32).to_be_bytes().to_vec();
            let mut body = tag.to_vec();
            body.extend_from_slice(data);
            c.extend_from_slice(&body);
            c.extend_from_slice(&crc32(&body).to_be_bytes());
            c
        };
        let mut ihdr = w.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
        let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
        out.extend(chunk(b"IHDR", &ihdr));
        out.extend(chunk(
            b"IDAT",
            &[0x78, 0x9C, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
        ));
        out.extend(chunk(b"IEND", &[]));
        out
    }

    #[test]
    fn huge_png_dimensions_are_refused_before_decoding() {
        assert_eq!(crc32(b"IEND"), 0xAE42_6082, "crc32 helper");
        for (w, h) in [(100_000, 100_000), (16385, 16384), (u32::MAX >> 1, 2)] {
            let e = crate::io::image_decode::grey(&png_header_only(w, h), "'giant.png'").unwrap_err();
            match &e {
                TextureError::TooLarge {
                    width, height, max, ..
                } => {
                    assert_eq!((*width, *height), (u64::from(w), u64::from(h)));
                    assert_eq!(*max, MAX_PIXELS);
                }
                other => panic!("expected TooLarge, got {other}"),
            }
            assert!(e.to_string().contains("giant.png"), "{e}");
        }
        // At the limit the header is accepted, and the missing data is a
        // decode error, not an allocation of the declared size up front.
        let e = crate::io::image_decode::grey(&png_header_only(16384, 16384), "'big.png'").unwrap_err();
        assert!(matches!(e, TextureError::Decode { .. }), "{e}");
    }

    #[test]
    fn mask_weight_and_invert() {
        let mut m = Mask::from_image(image(2, 1, &[0.0, 1.0]));
        m.wrap_s = Wrap::ClampToEdge;
        assert!(
            (m.weight([0.1, 0.5]) - 1.0).abs() < 1e-9,
            "black = full stress"
        );
        assert!(m.weight([0.9, 0.5]).abs() < 1e-9, "white = none");
        assert!((m.weight([0.5, 0.5]) - 0.5).abs() < 1e-6, "grey = half");
        m.invert = true;
        assert!(m.weight([0.1, 0.5]).abs() < 1e-9, "inverted black");
        assert!((m.weight([0.9, 0.5]) - 1.0).abs() < 1e-9, "inverted white");
        // The transform is applied first: an offset of half the image swaps.
        m.invert = false;
        m.wrap_s = Wrap::Repeat;
        m.transform.offset = [0.5, 0.0];
        assert!(m.weight([0.25, 0.5]).abs() < 1e-9, "offset by half");
    }

    fn fixtures() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures")
    }

    #[test]
    fn fixture_checker_png() {
        // 64 x 64 8-bit grey checker, 8-px cells: 192 where (x/8 + y/8) is
        // even, 64 elsewhere (fixtures/make_fixtures.py).
        let img = crate::io::image::open_grey(&fixtures().join("checker.png")).unwrap();
        assert_eq!((img.width, img.height), (64, 64));
        let (hi, lo) = (192.0 / 255.0, 64.0 / 255.0);
        for (x, y, want) in [
            (0, 0, hi),
            (7, 7, hi),
            (8, 0, lo),
            (0, 8, lo),
            (8, 8, hi),
            (63, 63, hi),
            (63, 0, lo),
        ] {
            assert_close(img.texel(x, y).unwrap(), want, "checker texel");
        }
        // Sampling a cell's centre; the corner of four cells is their mean.
        let s = |u, v| img.sample([u, v], Wrap::Repeat, Wrap::Repeat);
        assert_close(s(4.0 / 64.0, 4.0 / 64.0), hi, "cell centre");
        assert_close(s(12.0 / 64.0, 4.0 / 64.0), lo, "next cell");
        assert_close(s(8.0 / 64.0, 8.0 / 64.0), (hi + lo) / 2.0, "cell corner");
        // RGB fixture: red (200, 60, 40) / cream (240, 230, 210).
        let cube = crate::io::image::open_grey(&fixtures().join("cube texture.png")).unwrap();
        assert_eq!((cube.width, cube.height), (32, 32));
        let l = |r: f64, g: f64, b: f64| luma(r / 255.0, g / 255.0, b / 255.0) as f32;
        assert_close(cube.texel(0, 0).unwrap(), l(200.0, 60.0, 40.0), "red cell");
        assert_close(
            cube.texel(8, 0).unwrap(),
            l(240.0, 230.0, 210.0),
            "cream cell",
        );
    }

    #[test]
    fn mask_from_the_textured_quad_fixture() {
        let dir = fixtures();
        let scene = crate::io::read(&dir.join("textured_quad.gltf")).unwrap();
        let m = mask_from_material(
            &scene,
            0,
            "baseColorTexture",
            false,
            &crate::io::image::Files::inside(&dir),
        )
        .unwrap();
        assert_eq!((m.wrap_s, m.wrap_t), (Wrap::Repeat, Wrap::Repeat));
        assert_eq!(m.tex_coord, 0);
        assert!(m.transform.is_identity());
        assert_eq!((m.image.width, m.image.height), (64, 64));
        let hi = 192.0 / 255.0;
        assert!((m.weight([4.0 / 64.0, 4.0 / 64.0]) - (1.0 - hi)).abs() < 1e-6);
        let inv = mask_from_material(
            &scene,
            0,
            "baseColorTexture",
            true,
            &crate::io::image::Files::default(),
        )
        .unwrap();
        assert!((inv.weight([4.0 / 64.0, 4.0 / 64.0]) - hi).abs() < 1e-6);

        // The material has no normal map: the error names the material.
        let e = mask_from_material(
            &scene,
            0,
            "normalTexture",
            false,
            &crate::io::image::Files::default(),
        )
        .unwrap_err();
        assert!(matches!(e, TextureError::NoTexture { .. }), "{e}");
        assert!(e.to_string().contains("'checker'"), "{e}");
        assert!(e.to_string().contains("normalTexture"), "{e}");

        // The reader keeps the image's bytes (read once, where its path
        // was checked); a scene naming an image by its file (a library
        // user's) is read through `Files`, and a folder the file is not in
        // is refused.
        assert!(matches!(scene.images[0].source, ImageSource::Bytes(_)));
        let mut scene = scene;
        scene.images[0].source = ImageSource::File(dir.join("checker.png"));
        let other = tempfile::tempdir().unwrap();
        let e = mask_from_material(
            &scene,
            0,
            "baseColorTexture",
            false,
            &crate::io::image::Files::inside(other.path()),
        )
        .unwrap_err();
        assert!(matches!(e, TextureError::OutsideBase { .. }), "{e}");
        assert!(e.to_string().contains("checker"), "{e}");
    }

    /// A scene with one embedded 2x2 grey image and the given JSON.
    fn json_scene(materials: Vec<Value>, textures: Vec<Value>, samplers: Vec<Value>) -> Scene {
        Scene {
            materials: materials
                .into_iter()
                .map(|m| Material {
                    json: m.as_object().unwrap().clone(),
                })
                .collect(),
            textures,
            samplers,
            images: vec![Image {
                name: Some("mask".into()),
                mime_type: Some("image/png".into()),
                source: ImageSource::Bytes(grey8(2, 2, &[0, 255, 255, 0])),
                file_name: "image0.png".into(),
                rest: Map::new(),
            }],
            ..Scene::default()
        }
    }

    #[test]
    fn mask_from_material_slots_samplers_and_transforms() {
        let scene = json_scene(
            vec![
                json!({
                    "name": "stone",
                    "pbrMetallicRoughness": {
                        "baseColorTexture": {"index": 0, "texCoord": 1},
                        "metallicRoughnessTexture": {"index": 1}
                    },
                    "normalTexture": {"index": 2, "scale": 0.5},
                    "occlusionTexture": {
                        "index": 0,
                        "extensions": {"KHR_texture_transform": {
                            "offset": [0.5, 0.25], "rotation": 0.3, "scale": [2, 3], "texCoord": 2
                        }}
                    },
                    "emissiveTexture": {"index": 3}
                }),
                json!({}),
            ],
            vec![
                json!({"source": 0, "sampler": 0}),
                json!({"source": 0, "sampler": 1}),
                json!({"source": 0}),
                json!({"extensions": {"KHR_texture_basisu": {"source": 0}}}),
            ],
            vec![
                json!({"wrapS": 33071, "wrapT": 33648}),
                json!({"magFilter": 9729}),
            ],
        );
        let m = mask_from_material(
            &scene,
            0,
            "baseColorTexture",
            false,
            &crate::io::image::Files::default(),
        )
        .unwrap();
        assert_eq!(
            (m.wrap_s, m.wrap_t),
            (Wrap::ClampToEdge, Wrap::MirroredRepeat)
        );
        assert_eq!(m.tex_coord, 1);
        assert_eq!(m.image.data, vec![0.0, 1.0, 1.0, 0.0]);
        let m = mask_from_material(
            &scene,
            0,
            "metallicRoughnessTexture",
            false,
            &crate::io::image::Files::default(),
        )
        .unwrap();
        assert_eq!(
            (m.wrap_s, m.wrap_t),
            (Wrap::Repeat, Wrap::Repeat),
            "sampler defaults"
        );
        let m = mask_from_material(
            &scene,
            0,
            "normalTexture",
            true,
            &crate::io::image::Files::default(),
        )
        .unwrap();
        assert_eq!(
            (m.wrap_s, m.wrap_t),
            (Wrap::Repeat, Wrap::Repeat),
            "no sampler"
        );
        assert!(m.invert);
        let m = mask_from_material(
            &scene,
            0,
            "occlusionTexture",
            false,
            &crate::io::image::Files::default(),
        )
        .unwrap();
        assert_eq!(
            m.transform,
            UvTransform {
                offset: [0.5, 0.25],
                rotation: 0.3,
                scale: [2.0, 3.0]
            }
        );
        assert_eq!(m.tex_coord, 2, "the extension's texCoord overrides");

        // A texture with only a KTX2 source.
        let e = mask_from_material(
            &scene,
            0,
            "emissiveTexture",
            false,
            &crate::io::image::Files::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("KHR_texture_basisu"), "{e}");
        assert!(e.to_string().contains("texture 3"), "{e}");

        // Unknown slot: the valid ones are listed.
        let e = mask_from_material(
            &scene,
            0,
            "diffuseTexture",
            false,
            &crate::io::image::Files::default(),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("diffuseTexture"), "{msg}");
        for s in SLOTS {
            assert!(msg.contains(s), "{msg} lists {s}");
        }
        // Unnamed material without the slot; material out of range.
        let e = mask_from_material(
            &scene,
            1,
            "baseColorTexture",
            false,
            &crate::io::image::Files::default(),
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "material 1 has no baseColorTexture");
        let e = mask_from_material(
            &scene,
            5,
            "baseColorTexture",
            false,
            &crate::io::image::Files::default(),
        )
        .unwrap_err();
        assert!(
            matches!(e, TextureError::NoMaterial { index: 5, count: 2 }),
            "{e}"
        );
    }

    #[test]
    fn mask_from_material_broken_references() {
        let mut scene = json_scene(
            vec![json!({
                "name": "m",
                "pbrMetallicRoughness": {"baseColorTexture": {"index": 9}},
                "normalTexture": {"index": 0},
                "occlusionTexture": {"index": 1},
                "emissiveTexture": {"index": 2,
                    "extensions": {"KHR_texture_transform": {"scale": [1]}}}
            })],
            vec![
                json!({"source": 0, "sampler": 0}),
                json!({"source": 4}),
                json!({"source": 0}),
            ],
            vec![json!({"wrapS": 1234})],
        );
        let msg = |scene: &Scene, slot| {
            mask_from_material(scene, 0, slot, false, &crate::io::image::Files::default())
                .unwrap_err()
                .to_string()
        };
        assert!(msg(&scene, "baseColorTexture").contains("texture 9 does not exist"));
        assert!(msg(&scene, "normalTexture").contains("wrapS 1234"));
        assert!(msg(&scene, "occlusionTexture").contains("image 4 does not exist"));
        assert!(msg(&scene, "emissiveTexture").contains("scale must be an array of 2 numbers"));
        // An image that does not decode is named.
        scene.samplers.clear();
        scene.textures[0] = json!({"source": 0});
        scene.images[0].source = ImageSource::Bytes(b"\x89PNG\r\n\x1a\nbroken".to_vec());
        let m = msg(&scene, "normalTexture");
        assert!(m.contains("'mask' (image 0, image0.png)"), "{m}");
    }
}
