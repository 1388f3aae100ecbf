//! Baked crack maps: the crack network drawn into a mesh's UV space as a
//! base-colour map (the material's own colour with the cracks darkened), a
//! tangent-space normal map of V-shaped grooves (over the material's own
//! normal map) and an occlusion map, so any glTF viewer shows the cracks.
//!
//! [`raster`] finds what each texel shows (and grows the islands by a band
//! so filtering never reads background), [`field`] measures the cracks in
//! world units from each texel, [`atlas`] makes a UV set for meshes without
//! a usable one, and [`compose`] mixes the result into the material's
//! textures. Pure computation: the caller decodes and encodes the images'
//! files.

pub mod atlas;
pub mod field;
pub mod raster;

pub use field::{crack_texels, CrackTexel, Cracks, Profile, Surface};
pub use raster::{rasterize, Raster, Texel, EMPTY};

use crate::stress::texture::{UvTransform, Wrap};
use rayon::prelude::*;

/// A decoded texture of the material, with how it is sampled.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// RGBA in [0, 1] as stored (no sRGB decoding), row 0 at the top.
    pub rgba: Vec<f32>,
    /// Wrap in `u`.
    pub wrap_s: Wrap,
    /// Wrap in `v`.
    pub wrap_t: Wrap,
    /// `KHR_texture_transform`.
    pub transform: UvTransform,
    /// The UV set it reads.
    pub tex_coord: u32,
}

impl Layer {
    /// Bilinear RGBA at `uv` (after the transform), as [`crate::stress::texture::GreyImage::sample`].
    pub fn sample(&self, uv: [f64; 2]) -> [f64; 4] {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || self.rgba.len() != 4 * w * h {
            return [1.0; 4];
        }
        let uv = self.transform.apply(uv);
        let x = self.wrap_s.reduce(uv[0]) * w as f64 - 0.5;
        let y = self.wrap_t.reduce(uv[1]) * h as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let i = [
            self.wrap_s.texel(x0 as i64, w as i64),
            self.wrap_s.texel(x0 as i64 + 1, w as i64),
        ];
        let j = [
            self.wrap_t.texel(y0 as i64, h as i64),
            self.wrap_t.texel(y0 as i64 + 1, h as i64),
        ];
        let px = |i: usize, j: usize, c: usize| f64::from(self.rgba[(j * w + i) * 4 + c]);
        std::array::from_fn(|c| {
            let top = px(i[0], j[0], c) * (1.0 - fx) + px(i[1], j[0], c) * fx;
            let bottom = px(i[0], j[1], c) * (1.0 - fx) + px(i[1], j[1], c) * fx;
            top * (1.0 - fy) + bottom * fy
        })
    }
}

/// What the material brings to the maps.
#[derive(Clone, Debug, Default)]
pub struct Material {
    /// Base colour factor (linear RGBA).
    pub base_factor: [f64; 4],
    /// Base colour texture (sRGB).
    pub base: Option<Layer>,
    /// Normal texture and its `scale`.
    pub normal: Option<(Layer, f64)>,
    /// Occlusion texture (red channel) and its `strength`.
    pub occlusion: Option<(Layer, f64)>,
}

/// How cracks look in the maps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Look {
    /// Colour inside a crack (linear RGB).
    pub crack_color: [f64; 3],
    /// How much the shadow band darkens the occlusion map, in [0, 1].
    pub occlusion: f64,
}

/// Per-vertex frames to carry the material's own normal map into the baked
/// map's tangent space, when the two read different UV sets (an atlas).
/// Tangents as glTF's: `xyz` and the bitangent's sign in `w`.
#[derive(Clone, Copy, Debug)]
pub struct Reframe<'a> {
    /// Vertex normals.
    pub normals: &'a [[f64; 3]],
    /// Tangents of the UV set the material's normal map reads.
    pub from: &'a [[f64; 4]],
    /// Tangents of the baked UV set.
    pub to: &'a [[f64; 4]],
}

impl Reframe<'_> {
    /// `v`, a tangent-space vector of the `from` frame at the point with
    /// barycentric `weights` in triangle `corners`, in the `to` frame. The
    /// frames are what a viewer builds from the interpolated attributes.
    fn carry(&self, corners: [u32; 3], weights: [f64; 3], v: [f64; 3]) -> [f64; 3] {
        use crate::math::v3;
        let lerp3 = |a: &[[f64; 3]]| -> [f64; 3] {
            std::array::from_fn(|i| (0..3).map(|k| weights[k] * a[corners[k] as usize][i]).sum())
        };
        let lerp4 = |a: &[[f64; 4]]| -> [f64; 4] {
            std::array::from_fn(|i| (0..3).map(|k| weights[k] * a[corners[k] as usize][i]).sum())
        };
        let Some(n) = v3::unit(lerp3(self.normals)) else {
            return v;
        };
        let frame = |t: [f64; 4]| -> Option<([f64; 3], [f64; 3])> {
            let t3 = [t[0], t[1], t[2]];
            let t3 = v3::unit(v3::sub(t3, v3::scale(n, v3::dot(t3, n))))?;
            let sign = if t[3] < 0.0 { -1.0 } else { 1.0 };
            Some((t3, v3::scale(v3::cross(n, t3), sign)))
        };
        let (Some((t0, b0)), Some((t1, b1))) = (frame(lerp4(self.from)), frame(lerp4(self.to)))
        else {
            return v;
        };
        let world = v3::add(
            v3::add(v3::scale(t0, v[0]), v3::scale(b0, v[1])),
            v3::scale(n, v[2]),
        );
        [v3::dot(world, t1), v3::dot(world, b1), v3::dot(world, n)]
    }
}

/// The three maps, row-major, 8 bits a channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Maps {
    /// Width and height.
    pub size: u32,
    /// Base colour, sRGB, RGBA.
    pub base: Vec<[u8; 4]>,
    /// Tangent-space normal, RGB.
    pub normal: Vec<[u8; 3]>,
    /// Occlusion, grey.
    pub occlusion: Vec<u8>,
    /// Texels a crack covers at least half.
    pub crack_texels: usize,
}

/// The maps: per texel, the material's own values at its point (textures
/// sampled through `uv(set, vertex)`) with `cracks` mixed in. `reframe`,
/// when given, carries the material's own normals into the baked set's
/// tangent frame.
pub fn compose(
    triangles: &[[u32; 3]],
    raster: &Raster,
    cracks: &[CrackTexel],
    material: &Material,
    look: &Look,
    uv: &(dyn Fn(u32, usize) -> [f64; 2] + Sync),
    reframe: Option<&Reframe<'_>>,
) -> Maps {
    let n = raster.size as usize;
    let texel_uv = |t: &Texel, set: u32| {
        let w = t.weights();
        let corners = triangles[t.tri as usize];
        let mut acc = [0.0; 2];
        for k in 0..3 {
            let p = uv(set, corners[k] as usize);
            acc[0] += w[k] * p[0];
            acc[1] += w[k] * p[1];
        }
        acc
    };
    let mut out = Maps {
        size: raster.size,
        base: vec![[0; 4]; n * n],
        normal: vec![[0; 3]; n * n],
        occlusion: vec![0; n * n],
        crack_texels: 0,
    };
    let counts: usize = out
        .base
        .par_chunks_mut(n)
        .zip(out.normal.par_chunks_mut(n))
        .zip(out.occlusion.par_chunks_mut(n))
        .enumerate()
        .map(|(y, ((base, normal), occl))| {
            let mut count = 0;
            for x in 0..n {
                let k = y * n + x;
                let t = &raster.texels[k];
                let c = cracks[k];
                if t.tri == EMPTY {
                    // Background: no island within the band reaches here.
                    base[x] = [0, 0, 0, 0];
                    normal[x] = [128, 128, 255];
                    occl[x] = 255;
                    continue;
                }
                let here = |layer: &Layer| Some(layer.sample(texel_uv(t, layer.tex_coord)));
                // Base colour, mixed in linear light.
                let f = material.base_factor;
                let tex = material.base.as_ref().and_then(here).unwrap_or([1.0; 4]);
                let lin: [f64; 3] = std::array::from_fn(|i| srgb_to_linear(tex[i]) * f[i]);
                let cov = f64::from(c.coverage);
                // The crack's edge in COVERAGE_LEVELS steps: over a plain
                // colour the map is a palette image, over a texture of flat
                // areas it repeats the same few blends.
                let cov = (cov * COVERAGE_LEVELS).round() / COVERAGE_LEVELS;
                let mixed: [f64; 3] =
                    std::array::from_fn(|i| lin[i] + (look.crack_color[i] - lin[i]) * cov);
                let a = (tex[3] * f[3]).clamp(0.0, 1.0);
                base[x] = [
                    to_u8(linear_to_srgb(mixed[0])),
                    to_u8(linear_to_srgb(mixed[1])),
                    to_u8(linear_to_srgb(mixed[2])),
                    to_u8(a),
                ];
                // Normal: the groove over the material's own (whiteout blend).
                let own = material
                    .normal
                    .as_ref()
                    .and_then(|(l, scale)| here(l).map(|s| (s, *scale)))
                    .map(|(s, scale)| {
                        let v = [
                            (2.0 * s[0] - 1.0) * scale,
                            (2.0 * s[1] - 1.0) * scale,
                            2.0 * s[2] - 1.0,
                        ];
                        let v = match reframe {
                            Some(r) => r.carry(triangles[t.tri as usize], t.weights(), v),
                            None => v,
                        };
                        crate::math::v3::unit(v).unwrap_or([0.0, 0.0, 1.0])
                    })
                    .unwrap_or([0.0, 0.0, 1.0]);
                let g = c.normal.map(f64::from);
                let g = if material.normal.is_none() {
                    quantize_direction(g)
                } else {
                    g
                };
                let nrm = crate::math::v3::unit([own[0] + g[0], own[1] + g[1], own[2] * g[2]])
                    .unwrap_or([0.0, 0.0, 1.0]);
                normal[x] = nrm.map(|v| to_u8(0.5 * v + 0.5));
                // Occlusion.
                let ao = material
                    .occlusion
                    .as_ref()
                    .and_then(|(l, strength)| here(l).map(|s| 1.0 + strength * (s[0] - 1.0)))
                    .unwrap_or(1.0);
                let shadow = f64::from(c.shadow);
                let shadow = (shadow * SHADOW_LEVELS).round() / SHADOW_LEVELS;
                occl[x] = to_u8(ao * (1.0 - look.occlusion * shadow));
                if c.coverage >= 0.5 {
                    count += 1;
                }
            }
            count
        })
        .sum();
    out.crack_texels = counts;
    out
}

/// Steps of a crack's coverage over a plain base colour (the crack's edge
/// shades in 1/64ths, below what a viewer shows apart).
const COVERAGE_LEVELS: f64 = 64.0;
/// Steps of the shadow band over a material without an occlusion map
/// (with white: 16 greys, a 4-bit palette image).
const SHADOW_LEVELS: f64 = 15.0;
/// Azimuth steps of a groove's normal over a material without a normal map
/// (11.25 degrees), and tilt steps from flat to edge-on (11.25 degrees, the
/// last short of edge-on): at most 1 + 32 x 7 normals, a palette image.
const AZIMUTH_STEPS: f64 = 32.0;
const TILT_STEPS: f64 = 8.0;

/// A unit normal in the tangent frame, to the nearest of the directions
/// [`AZIMUTH_STEPS`] x [`TILT_STEPS`] span (the groove's shading; its
/// shape stays the coverage's).
fn quantize_direction(n: [f64; 3]) -> [f64; 3] {
    use std::f64::consts::{FRAC_PI_2, TAU};
    let r = n[0].hypot(n[1]);
    // Edge-on (a step of 90 degrees) is no groove's: at most the step below.
    let step = FRAC_PI_2 / TILT_STEPS;
    let tilt = (r.atan2(n[2]) / step).round().min(TILT_STEPS - 1.0) * step;
    if tilt == 0.0 {
        return [0.0, 0.0, 1.0];
    }
    let az = n[1].atan2(n[0]);
    // One step for both ends of the angle's range.
    let az = (az / (TAU / AZIMUTH_STEPS))
        .round()
        .rem_euclid(AZIMUTH_STEPS)
        * (TAU / AZIMUTH_STEPS);
    [tilt.sin() * az.cos(), tilt.sin() * az.sin(), tilt.cos()]
}

fn to_u8(x: f64) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// sRGB transfer function, decoding.
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB transfer function, encoding.
pub fn linear_to_srgb(c: f64) -> f64 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// A PNG of `size` x `size` pixels of `channels` (1: grey, 3: RGB, 4: RGBA)
/// 8-bit samples, as small as the encoder makes it without loss: an image of
/// at most 256 distinct pixels is written with a palette (1 byte a pixel,
/// or fewer bits for 16 or fewer grey levels), and each image is compressed
/// with the row filters chosen per row and with none, keeping the smaller
/// (maps of flat areas and few colours compress best unfiltered).
///
/// # Errors
/// The encoder's, when `data` does not hold `size * size * channels` bytes.
pub fn encode_png(size: u32, channels: usize, data: &[u8]) -> Result<Vec<u8>, png::EncodingError> {
    let color = match channels {
        1 => png::ColorType::Grayscale,
        3 => png::ColorType::Rgb,
        _ => png::ColorType::Rgba,
    };
    if data.len() != (size as usize).pow(2) * channels || ![1, 3, 4].contains(&channels) {
        // The encoder names the mismatch.
        return encode_with(size, color, data, None, png::Filter::NoFilter);
    }
    let layout = palette(data, channels, size as usize);
    let (a, b) = rayon::join(
        || encode_with(size, color, data, layout.as_ref(), png::Filter::Adaptive),
        || encode_with(size, color, data, layout.as_ref(), png::Filter::NoFilter),
    );
    let (a, b) = (a?, b?);
    Ok(if b.len() < a.len() { b } else { a })
}

/// A lossless WebP of `size` x `size` pixels of `channels` (1: grey, 3:
/// RGB, 4: RGBA) 8-bit samples (grey written as RGB, as WebP has no grey).
///
/// # Errors
/// When `data` does not hold `size * size * channels` bytes, or the encoder
/// fails.
pub fn encode_webp(size: u32, channels: usize, data: &[u8]) -> Result<Vec<u8>, EncodeError> {
    if data.len() != (size as usize).pow(2) * channels || ![1, 3, 4].contains(&channels) {
        return Err(EncodeError::Size {
            bytes: data.len(),
            size,
            channels,
        });
    }
    let grey: Vec<u8>;
    let encoder = match channels {
        1 => {
            grey = data.iter().flat_map(|&g| [g, g, g]).collect();
            webp::Encoder::from_rgb(&grey, size, size)
        }
        3 => webp::Encoder::from_rgb(data, size, size),
        _ => webp::Encoder::from_rgba(data, size, size),
    };
    let mut config = webp::WebPConfig::new().map_err(|()| EncodeError::WebpSettings)?;
    config.lossless = 1;
    config.quality = 75.0;
    // Pixels under full transparency kept as they are (a lossless copy).
    config.exact = 1;
    encoder
        .encode_advanced(&config)
        .map(|m| m.to_vec())
        .map_err(EncodeError::Webp)
}

/// Why a baked map cannot be encoded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EncodeError {
    /// The data is not `size` x `size` pixels of 1, 3 or 4 channels.
    #[error("{bytes} bytes are not {size} x {size} pixels of {channels} channels")]
    Size {
        /// Bytes given.
        bytes: usize,
        /// The map's side.
        size: u32,
        /// Channels asked for.
        channels: usize,
    },
    /// The WebP encoder has no default settings.
    #[error("WebP has no default settings")]
    WebpSettings,
    /// The WebP encoder failed.
    #[error("WebP does not encode: {0:?}")]
    Webp(webp::WebPEncodingError),
    /// The PNG encoder failed.
    #[error(transparent)]
    Png(#[from] png::EncodingError),
}

/// An image's pixels as indices into a palette, when it has at most 256
/// distinct pixels: the palette sorted (so the same pixels give the same
/// file), the indices packed at the fewest bits a pixel (8, or 4 for 16 or
/// fewer colours).
struct Palette {
    /// RGB entries.
    rgb: Vec<u8>,
    /// Alpha per entry, when any is not opaque.
    alpha: Option<Vec<u8>>,
    /// Packed index rows.
    packed: Vec<u8>,
    depth: png::BitDepth,
}

fn palette(data: &[u8], channels: usize, size: usize) -> Option<Palette> {
    // Grey at 8 bits is already a byte a pixel: a palette only for 4 bits.
    let most = if channels == 1 { 16 } else { 256 };
    let px = |c: &[u8]| -> [u8; 4] {
        match channels {
            1 => [c[0], c[0], c[0], 255],
            3 => [c[0], c[1], c[2], 255],
            _ => [c[0], c[1], c[2], c[3]],
        }
    };
    let mut seen: Vec<[u8; 4]> = Vec::new();
    let mut last: Option<[u8; 4]> = None;
    for c in data.chunks_exact(channels) {
        let p = px(c);
        if last == Some(p) {
            continue;
        }
        last = Some(p);
        if let Err(at) = seen.binary_search(&p) {
            if seen.len() == most {
                return None;
            }
            seen.insert(at, p);
        }
    }
    let bits = if seen.len() <= 16 { 4 } else { 8 };
    let row_bytes = (size * bits).div_ceil(8);
    let mut packed = vec![0u8; row_bytes * size];
    let mut last: Option<([u8; 4], u8)> = None;
    for (i, c) in data.chunks_exact(channels).enumerate() {
        let p = px(c);
        let k = match last {
            Some((q, k)) if q == p => k,
            _ => {
                let k = seen.binary_search(&p).unwrap_or(0) as u8;
                last = Some((p, k));
                k
            }
        };
        let (y, x) = (i / size, i % size);
        if bits == 8 {
            packed[y * row_bytes + x] = k;
        } else {
            packed[y * row_bytes + x / 2] |= if x % 2 == 0 { k << 4 } else { k };
        }
    }
    let alpha = seen
        .iter()
        .any(|p| p[3] != 255)
        .then(|| seen.iter().map(|p| p[3]).collect());
    Some(Palette {
        rgb: seen.iter().flat_map(|p| [p[0], p[1], p[2]]).collect(),
        alpha,
        packed,
        depth: if bits == 8 {
            png::BitDepth::Eight
        } else {
            png::BitDepth::Four
        },
    })
}

fn encode_with(
    size: u32,
    color: png::ColorType,
    data: &[u8],
    palette: Option<&Palette>,
    filter: png::Filter,
) -> Result<Vec<u8>, png::EncodingError> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, size, size);
        enc.set_compression(png::Compression::Balanced);
        enc.set_filter(filter);
        let pixels = match palette {
            Some(p) => {
                enc.set_color(png::ColorType::Indexed);
                enc.set_depth(p.depth);
                enc.set_palette(&p.rgb[..]);
                if let Some(a) = &p.alpha {
                    enc.set_trns(&a[..]);
                }
                &p.packed[..]
            }
            None => {
                enc.set_color(color);
                enc.set_depth(png::BitDepth::Eight);
                data
            }
        };
        let mut w = enc.write_header()?;
        w.write_image_data(pixels)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
