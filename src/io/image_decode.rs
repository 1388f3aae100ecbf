//! Decoding PNG, JPEG and WebP images (the pure-Rust `png` and
//! `zune-jpeg` crates, libwebp) into luminance or RGBA values, the declared
//! size checked (against [`MAX_PIXELS`] and a memory budget) before any
//! pixel buffer is allocated. The stress layer samples what this decodes
//! ([`GreyImage`]); luminance as its module describes.

use crate::stress::texture::{GreyImage, TextureError, MAX_PIXELS, PNG_DECODER_LIMIT};

/// What a decoded pixel becomes: its luminance (one value), or its red,
/// green, blue and alpha (four values, alpha 1 when the image has none).
/// Values are the stored ones scaled to [0, 1] (no sRGB decoding).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channels {
    /// Rec. 709 luma of the stored values (grey images: their value).
    Luma,
    /// RGBA (grey images: grey in R, G and B).
    Rgba,
}

impl Channels {
    fn count(self) -> usize {
        match self {
            Channels::Luma => 1,
            Channels::Rgba => 4,
        }
    }
}

/// Decode a PNG (1 to 16 bits; grey, grey + alpha, RGB, RGBA or palette;
/// interlaced or not), a JPEG (baseline or progressive; grey, YCbCr, CMYK)
/// or a WebP into luminance. The format is recognised from the bytes;
/// `name` names the image in errors.
///
/// # Errors
/// [`TextureError::TooLarge`] when the header declares more than
/// [`MAX_PIXELS`] pixels (checked before decoding pixels),
/// [`TextureError::Decode`] when the bytes are not a PNG, JPEG or WebP or
/// do not decode.
pub fn grey(bytes: &[u8], name: &str) -> Result<GreyImage, TextureError> {
    grey_within(bytes, name, u64::MAX)
}

/// [`grey`] refusing, before decoding, an image whose decoded values would
/// take more than `budget` bytes ([`TextureError::OverBudget`]).
///
/// # Errors
/// Those of [`grey`] and [`TextureError::OverBudget`].
pub fn grey_within(bytes: &[u8], name: &str, budget: u64) -> Result<GreyImage, TextureError> {
    let (width, height, data) = decode_channels_within(bytes, name, Channels::Luma, budget)?;
    Ok(GreyImage {
        width,
        height,
        data,
    })
}

/// Decode a PNG, JPEG or WebP (as [`grey`]) into `(width, height,
/// values)`, one (luma) or four (RGBA) values a pixel, row 0 at the top.
///
/// # Errors
/// Those of [`grey`].
pub fn decode_channels(
    bytes: &[u8],
    name: &str,
    channels: Channels,
) -> Result<(u32, u32, Vec<f32>), TextureError> {
    decode_channels_within(bytes, name, channels, u64::MAX)
}

/// [`decode_channels`] refusing, before decoding, an image whose decoded
/// values (and the decoder's rows) would take more than `budget` bytes.
///
/// # Errors
/// Those of [`decode_channels`] and [`TextureError::OverBudget`].
pub fn decode_channels_within(
    bytes: &[u8],
    name: &str,
    channels: Channels,
    budget: u64,
) -> Result<(u32, u32, Vec<f32>), TextureError> {
    decode_or_check(
        bytes,
        &Size {
            name,
            channels,
            budget,
            header_only: false,
        },
    )
}

/// The checks of [`decode_channels_within`] on the image's header alone
/// (nothing is decoded or allocated): its `(width, height)`, or the error
/// decoding it would give before allocating (format, size, budget).
///
/// # Errors
/// Those of [`decode_channels_within`] up to the header.
pub fn check_within(
    bytes: &[u8],
    name: &str,
    channels: Channels,
    budget: u64,
) -> Result<(u32, u32), TextureError> {
    let size = Size {
        name,
        channels,
        budget,
        header_only: true,
    };
    decode_or_check(bytes, &size).map(|(w, h, _)| (w, h))
}

fn decode_or_check(bytes: &[u8], size: &Size) -> Result<(u32, u32, Vec<f32>), TextureError> {
    let name = size.name;
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        decode_png(bytes, size)
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        decode_jpeg(bytes, size)
    } else if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        decode_webp(bytes, size)
    } else {
        let what = if bytes.starts_with(b"\xABKTX 20\xBB") {
            "a KTX2 texture"
        } else if bytes.is_empty() {
            "empty"
        } else {
            "not an image format this tool knows"
        };
        Err(TextureError::Decode {
            image: name.to_string(),
            reason: format!("{what}; masks must be PNG, JPEG or WebP"),
        })
    }
}

/// Rec. 709 luma weights on the stored (not linearised) values.
pub(crate) fn luma(r: f64, g: f64, b: f64) -> f64 {
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

/// What an image may be: its name, the values a pixel decodes to and the
/// memory budget.
struct Size<'a> {
    name: &'a str,
    channels: Channels,
    budget: u64,
    /// Stop after the header's checks (nothing decoded).
    header_only: bool,
}

impl Size<'_> {
    /// The declared size checked against [`MAX_PIXELS`] and the budget
    /// (the decoded values, 4 bytes each, and the decoder's own buffer of
    /// up to 8 bytes a pixel); the number of pixels.
    fn check(&self, width: u64, height: u64) -> Result<usize, TextureError> {
        let pixels = check_size(self.name, width, height)?;
        let bytes = pixels as u64 * (4 * self.channels.count() as u64 + 8);
        if bytes > self.budget {
            return Err(TextureError::OverBudget {
                image: self.name.to_string(),
                width,
                height,
                bytes,
                budget: self.budget,
            });
        }
        Ok(pixels)
    }
}

fn check_size(name: &str, width: u64, height: u64) -> Result<usize, TextureError> {
    if width == 0 || height == 0 {
        return Err(TextureError::Decode {
            image: name.to_string(),
            reason: format!("the header declares an empty image ({width} x {height})"),
        });
    }
    match width.checked_mul(height) {
        Some(n) if n <= MAX_PIXELS => Ok(n as usize),
        _ => Err(TextureError::TooLarge {
            image: name.to_string(),
            width,
            height,
            max: MAX_PIXELS,
        }),
    }
}

fn size_mismatch(name: &str, detail: String) -> TextureError {
    TextureError::Decode {
        image: name.to_string(),
        reason: format!("decoded size does not match the header: {detail}"),
    }
}

fn decode_png(bytes: &[u8], size: &Size) -> Result<(u32, u32, Vec<f32>), TextureError> {
    let (name, out) = (size.name, size.channels);
    let fail = |e: png::DecodingError| TextureError::Decode {
        image: name.to_string(),
        reason: match e {
            png::DecodingError::LimitsExceeded => {
                "PNG needs more memory than the decoder allows".to_string()
            }
            e => format!("PNG does not decode: {e}"),
        },
    };
    let mut decoder = png::Decoder::new_with_limits(
        std::io::Cursor::new(bytes),
        png::Limits {
            bytes: PNG_DECODER_LIMIT,
        },
    );
    // Palette to RGB(A), 1/2/4-bit grey to 8 bits; 16 bits stay 16 bits.
    decoder.set_transformations(png::Transformations::EXPAND);
    let header = decoder.read_header_info().map_err(fail)?;
    let (width, height) = (header.width, header.height);
    let pixels = size.check(u64::from(width), u64::from(height))?;
    if size.header_only {
        return Ok((width, height, Vec::new()));
    }
    let mut reader = decoder.read_info().map_err(fail)?;
    let (color, depth) = reader.output_color_type();
    let bytes_per_sample = match depth {
        png::BitDepth::Eight => 1,
        png::BitDepth::Sixteen => 2,
        d => {
            return Err(TextureError::Decode {
                image: name.to_string(),
                reason: format!("unexpected PNG sample depth {d:?} after expansion"),
            })
        }
    };
    let channels = match color {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => {
            return Err(TextureError::Decode {
                image: name.to_string(),
                reason: "palette PNG was not expanded".to_string(),
            })
        }
    };
    let line = width as usize * channels * bytes_per_sample;
    let expected = line * height as usize;
    if reader.output_buffer_size() != Some(expected) {
        return Err(size_mismatch(
            name,
            format!(
                "the decoder needs {:?} bytes, {width} x {height} x {channels} channels x {bytes_per_sample} bytes is {expected}",
                reader.output_buffer_size()
            ),
        ));
    }
    // Reserve at most 4 Mi pixels up front: a tiny file that declares a big
    // image and then holds no data costs no big allocation.
    let mut data = Vec::with_capacity(pixels.min(1 << 22) * out.count());
    if reader.info().interlaced {
        // Adam7: the decoder assembles the whole frame.
        let mut buf = vec![0u8; expected];
        let frame = reader.next_frame(&mut buf).map_err(fail)?;
        if frame.width != width || frame.height != height || frame.line_size != line {
            return Err(size_mismatch(
                name,
                format!(
                    "frame {} x {} with {}-byte rows, expected {width} x {height} with {line}-byte rows",
                    frame.width, frame.height, frame.line_size
                ),
            ));
        }
        for row in buf.chunks_exact(line) {
            push_row(row, channels, bytes_per_sample, out, &mut data);
        }
    } else {
        // Row by row: no buffer of the raw image is ever held.
        let mut rows = 0usize;
        while let Some(row) = reader.next_row().map_err(fail)? {
            let row = row.data();
            if row.len() != line || rows >= height as usize {
                return Err(size_mismatch(
                    name,
                    format!(
                        "row {rows} has {} bytes, expected {line} bytes in each of {height} rows",
                        row.len()
                    ),
                ));
            }
            push_row(row, channels, bytes_per_sample, out, &mut data);
            rows += 1;
        }
    }
    if data.len() != pixels * out.count() {
        return Err(size_mismatch(
            name,
            format!(
                "{} pixels decoded, expected {pixels}",
                data.len() / out.count()
            ),
        ));
    }
    Ok((width, height, data))
}

/// A still WebP (lossy or lossless), its size checked from the bitstream's
/// header before libwebp decodes it.
fn decode_webp(bytes: &[u8], size: &Size) -> Result<(u32, u32, Vec<f32>), TextureError> {
    let fail = |reason: &str| TextureError::Decode {
        image: size.name.to_string(),
        reason: reason.to_string(),
    };
    let header =
        webp::BitstreamFeatures::new(bytes).ok_or_else(|| fail("WebP header does not decode"))?;
    if header.has_animation() {
        return Err(fail("an animated WebP; a texture must be a still image"));
    }
    let (width, height) = (header.width(), header.height());
    let pixels = size.check(u64::from(width), u64::from(height))?;
    if size.header_only {
        return Ok((width, height, Vec::new()));
    }
    let image = webp::Decoder::new(bytes)
        .decode()
        .ok_or_else(|| fail("WebP does not decode"))?;
    let channels = if image.is_alpha() { 4 } else { 3 };
    if (image.width(), image.height()) != (width, height) || image.len() != pixels * channels {
        return Err(size_mismatch(
            size.name,
            format!(
                "{} x {} with {} bytes, the header says {width} x {height}",
                image.width(),
                image.height(),
                image.len()
            ),
        ));
    }
    let mut data = Vec::with_capacity(pixels * size.channels.count());
    push_row(&image, channels, 1, size.channels, &mut data);
    Ok((width, height, data))
}

/// Append the luminance (or RGBA) of one decoded PNG row.
fn push_row(
    row: &[u8],
    channels: usize,
    bytes_per_sample: usize,
    kind: Channels,
    out: &mut Vec<f32>,
) {
    let sample = |k: usize| -> f64 {
        if bytes_per_sample == 1 {
            f64::from(row[k]) / 255.0
        } else {
            f64::from(u16::from_be_bytes([row[2 * k], row[2 * k + 1]])) / 65535.0
        }
    };
    let n = row.len() / (channels * bytes_per_sample);
    if kind == Channels::Rgba {
        for p in 0..n {
            let k = p * channels;
            let rgba = match channels {
                1 => [sample(k), sample(k), sample(k), 1.0],
                2 => [sample(k), sample(k), sample(k), sample(k + 1)],
                3 => [sample(k), sample(k + 1), sample(k + 2), 1.0],
                _ => [sample(k), sample(k + 1), sample(k + 2), sample(k + 3)],
            };
            out.extend(rgba.map(|c| c.clamp(0.0, 1.0) as f32));
        }
        return;
    }
    out.extend((0..n).map(|p| {
        let k = p * channels;
        let l = if channels >= 3 {
            luma(sample(k), sample(k + 1), sample(k + 2))
        } else {
            sample(k)
        };
        l.clamp(0.0, 1.0) as f32
    }));
}

fn decode_jpeg(bytes: &[u8], size: &Size) -> Result<(u32, u32, Vec<f32>), TextureError> {
    let (name, out) = (size.name, size.channels);
    use zune_jpeg::zune_core::bytestream::ZCursor;
    use zune_jpeg::zune_core::colorspace::ColorSpace;
    use zune_jpeg::zune_core::options::DecoderOptions;
    let fail = |e: zune_jpeg::errors::DecodeErrors| TextureError::Decode {
        image: name.to_string(),
        reason: format!("JPEG does not decode: {e}"),
    };
    // The decoder's own dimension limits are raised to JPEG's maximum; the
    // pixel count is checked here from the header.
    let options = DecoderOptions::default()
        .jpeg_set_out_colorspace(ColorSpace::RGB)
        .set_max_width(usize::from(u16::MAX))
        .set_max_height(usize::from(u16::MAX));
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    decoder.decode_headers().map_err(fail)?;
    let (w, h) = decoder.dimensions().ok_or_else(|| TextureError::Decode {
        image: name.to_string(),
        reason: "JPEG header has no frame size".to_string(),
    })?;
    let pixels = size.check(w as u64, h as u64)?;
    if size.header_only {
        return Ok((w as u32, h as u32, Vec::new()));
    }
    let expected = pixels * 3;
    if decoder.output_buffer_size() != Some(expected) {
        return Err(size_mismatch(
            name,
            format!(
                "the decoder needs {:?} bytes, {w} x {h} RGB is {expected}",
                decoder.output_buffer_size()
            ),
        ));
    }
    let mut buf = vec![0u8; expected];
    decoder.decode_into(&mut buf).map_err(fail)?;
    let data = match out {
        Channels::Luma => buf
            .chunks_exact(3)
            .map(|p| {
                let [r, g, b] = [p[0], p[1], p[2]].map(|c| f64::from(c) / 255.0);
                luma(r, g, b).clamp(0.0, 1.0) as f32
            })
            .collect(),
        Channels::Rgba => buf
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255].map(|c| f32::from(c) / 255.0))
            .collect(),
    };
    Ok((w as u32, h as u32, data))
}
