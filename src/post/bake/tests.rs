use super::*;

/// A unit plate in the xy plane, `n` x `n` quads, normal +z, tangent +x;
/// `uv(x, y)` gives each vertex's UV. Vertices are per quad column when
/// `seam_at` splits the plate into two UV islands at that column.
struct Plate {
    positions: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    tangents: Vec<[f64; 4]>,
    uvs: Vec<[f64; 2]>,
    triangles: Vec<[u32; 3]>,
}

impl Plate {
    fn new(n: usize, seam_at: Option<usize>, uv: &dyn Fn(f64, f64, bool) -> [f64; 2]) -> Plate {
        let mut p = Plate {
            positions: Vec::new(),
            normals: Vec::new(),
            tangents: Vec::new(),
            uvs: Vec::new(),
            triangles: Vec::new(),
        };
        let mut index = std::collections::BTreeMap::new();
        let mut vertex = |p: &mut Plate, i: usize, j: usize, right: bool| {
            *index.entry((i, j, right)).or_insert_with(|| {
                let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                p.positions.push([x, y, 0.0]);
                p.normals.push([0.0, 0.0, 1.0]);
                p.tangents.push([1.0, 0.0, 0.0, 1.0]);
                p.uvs.push(uv(x, y, right));
                p.positions.len() as u32 - 1
            })
        };
        for j in 0..n {
            for i in 0..n {
                let right = seam_at.is_some_and(|s| i >= s);
                let a = vertex(&mut p, i, j, right);
                let b = vertex(&mut p, i + 1, j, right);
                let c = vertex(&mut p, i + 1, j + 1, right);
                let d = vertex(&mut p, i, j + 1, right);
                p.triangles.push([a, b, c]);
                p.triangles.push([a, c, d]);
            }
        }
        p
    }

    fn surface(&self) -> Surface<'_> {
        Surface {
            positions: &self.positions,
            normals: &self.normals,
            tangents: &self.tangents,
            uvs: &self.uvs,
            triangles: &self.triangles,
        }
    }

    fn bake(&self, segments: &[[[f64; 3]; 2]], size: u32, dilate: u32) -> (Raster, Maps) {
        let raster = rasterize(&self.uvs, &self.triangles, size, dilate);
        let profile = Profile {
            half_width: 0.01,
            slope: 1.0,
            shadow: 1.5,
        };
        let cracks = Cracks {
            segments,
            widths: &[],
        };
        let texels = crack_texels(&self.surface(), &raster, &cracks, &profile);
        let material = Material {
            base_factor: [0.8, 0.8, 0.8, 1.0],
            ..Default::default()
        };
        let look = Look {
            crack_color: [0.0; 3],
            occlusion: 0.8,
        };
        let uvs = &self.uvs;
        let maps = compose(
            &self.triangles,
            &raster,
            &texels,
            &material,
            &look,
            &|_, v| uvs[v],
            None,
        );
        (raster, maps)
    }
}

/// Darkness of a base-colour texel (0: the plate's colour, 1: the crack's).
fn dark(maps: &Maps, x: usize, y: usize) -> f64 {
    let plate = linear_to_srgb(0.8);
    let px = maps.base[y * maps.size as usize + x];
    if px[3] == 0 {
        return 0.0;
    }
    let v = f64::from(px[0]) / 255.0;
    ((plate - v) / plate).clamp(0.0, 1.0)
}

/// World width of the dark band along texel column `x` (a crack across
/// the map's rows) or row `y`, from the summed darkness and the world size
/// of a texel in that direction.
fn band_width(maps: &Maps, along_rows: bool, at: usize, texel_world: f64) -> f64 {
    let n = maps.size as usize;
    let sum: f64 = (0..n)
        .map(|k| {
            if along_rows {
                dark(maps, at, k)
            } else {
                dark(maps, k, at)
            }
        })
        .sum();
    sum * texel_world
}

#[test]
fn a_crack_is_as_wide_on_a_stretched_island_as_on_a_tight_one() {
    // Cracks along x (at y = 0.5) and along y (at x = 0.5).
    let segments = [
        [[0.0, 0.5, 0.0], [1.0, 0.5, 0.0]],
        [[0.5, 0.0, 0.0], [0.5, 1.0, 0.0]],
    ];
    let size = 512;
    // UVs squeezed 4x in v: the plate fills u in [0, 1], v in [0, 0.25].
    let stretched = Plate::new(16, None, &|x, y, _| [x, y / 4.0]);
    let square = Plate::new(16, None, &|x, y, _| [x, y]);
    let (_, s) = stretched.bake(&segments, size, 4);
    let (_, q) = square.bake(&segments, size, 4);
    let texel = 1.0 / f64::from(size);
    // The crack at y = 0.5 crosses texel columns; measured down column 100
    // (rows cover v in [0, 0.25] on the stretched plate: 4 world texels a row).
    let w_stretched = band_width(&s, true, 100, 4.0 * texel);
    let w_square = band_width(&q, true, 100, texel);
    assert!(
        (w_stretched - 0.02).abs() < 0.25 * 0.02 && (w_square - 0.02).abs() < 0.1 * 0.02,
        "world widths {w_stretched} (stretched) and {w_square} (square), asked 0.02"
    );
    // The crack at x = 0.5 crosses rows; measured along row 40 (inside the
    // stretched plate's band of rows).
    let w_stretched = band_width(&s, false, 40, texel);
    let w_square = band_width(&q, false, 40, texel);
    assert!(
        (w_stretched - 0.02).abs() < 0.1 * 0.02 && (w_square - 0.02).abs() < 0.1 * 0.02,
        "world widths {w_stretched} and {w_square}, asked 0.02"
    );
}

#[test]
fn no_crack_texel_lies_outside_the_islands_band() {
    // Two islands with a wide gap: the left half of the plate at u in
    // [0.05, 0.35], the right half at u in [0.65, 0.95].
    let plate = Plate::new(16, Some(8), &|x, y, right| {
        let u = if right {
            0.65 + 0.6 * (x - 0.5)
        } else {
            0.05 + 0.6 * x
        };
        [u, 0.05 + 0.9 * y]
    });
    let segments = [[[0.0, 0.5, 0.0], [1.0, 0.5, 0.0]]];
    let dilate = 4;
    let (raster, maps) = plate.bake(&segments, 256, dilate);
    assert!(maps.crack_texels > 0);
    let n = 256usize;
    let mut dark_texels = 0;
    for y in 0..n {
        for x in 0..n {
            let t = raster.texels[y * n + x];
            if dark(&maps, x, y) > 0.01 && maps.base[y * n + x][3] > 0 {
                dark_texels += 1;
                assert!(t.tri != EMPTY, "dark texel {x},{y} outside every island");
                // Within `dilate` texels of an island's covered texel.
                let near = (y.saturating_sub(dilate as usize)..(y + dilate as usize + 1).min(n))
                    .any(|yy| {
                        (x.saturating_sub(dilate as usize)..(x + dilate as usize + 1).min(n))
                            .any(|xx| raster.texels[yy * n + xx].inside)
                    });
                assert!(near, "dark texel {x},{y} beyond the dilation band");
            }
        }
    }
    assert!(dark_texels > 0);
    // The gap between the islands stays background.
    assert_eq!(maps.base[128 * n + 128], [0, 0, 0, 0]);
}

/// Bilinear darkness of the base map at `uv`.
fn dark_at(maps: &Maps, uv: [f64; 2]) -> f64 {
    let n = maps.size as usize;
    let x = uv[0] * n as f64 - 0.5;
    let y = uv[1] * n as f64 - 0.5;
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (fx, fy) = (x - x0 as f64, y - y0 as f64);
    let d = |i, j| dark(maps, i, j);
    let alpha = |i: usize, j: usize| f64::from(maps.base[j * n + i][3]);
    // Background texels (alpha 0) would read as black: count them as fully dark.
    let val = |i, j| if alpha(i, j) == 0.0 { 1.0 } else { d(i, j) };
    (val(x0, y0) * (1.0 - fx) + val(x0 + 1, y0) * fx) * (1.0 - fy)
        + (val(x0, y0 + 1) * (1.0 - fx) + val(x0 + 1, y0 + 1) * fx) * fy
}

#[test]
fn seams_show_no_background_line_and_cracks_cross_them() {
    // Islands split at x = 0.5, the right one turned upside down (v flipped).
    let plate = Plate::new(16, Some(8), &|x, y, right| {
        if right {
            [0.55 + 0.4 * (x - 0.5) * 2.0, 0.95 - 0.9 * y]
        } else {
            [0.05 + 0.4 * x * 2.0, 0.05 + 0.9 * y]
        }
    });
    // A crack across the seam, along x at y = 0.3.
    let segments = [[[0.0, 0.3, 0.0], [1.0, 0.3, 0.0]]];
    let (_, maps) = plate.bake(&segments, 256, 4);
    // The seam in each island: u = 0.45 (left), u = 0.55 (right).
    for k in 0..50 {
        let y = 0.02 + 0.96 * k as f64 / 49.0;
        let left = dark_at(&maps, [0.45, 0.05 + 0.9 * y]);
        let right = dark_at(&maps, [0.55, 0.95 - 0.9 * y]);
        if (y - 0.3).abs() > 0.03 {
            assert!(
                left < 0.02 && right < 0.02,
                "seam at y = {y}: darkness {left} | {right}"
            );
        }
        assert!(
            (left - right).abs() < 0.1,
            "y = {y}: the two sides differ, {left} | {right}"
        );
    }
    let left = dark_at(&maps, [0.45, 0.05 + 0.9 * 0.3]);
    let right = dark_at(&maps, [0.55, 0.95 - 0.9 * 0.3]);
    assert!(
        left > 0.5 && right > 0.5,
        "the crack at the seam: {left} | {right}"
    );
}

#[test]
fn the_groove_tilts_towards_the_crack() {
    let plate = Plate::new(8, None, &|x, y, _| [x, y]);
    let segments = [[[0.5, 0.0, 0.0], [0.5, 1.0, 0.0]]];
    let (_, maps) = plate.bake(&segments, 256, 2);
    // Just right of the crack (x = 0.5 + 0.005): the normal leans to -x.
    let row = 100 * 256;
    let right = maps.normal[row + 129];
    let left = maps.normal[row + 126];
    assert!(right[0] < 120 && left[0] > 136, "{left:?} {right:?}");
    assert_eq!(maps.normal[row + 20], [128, 128, 255]);
    assert!(maps.occlusion[row + 128] < 128 && maps.occlusion[row + 20] == 255);
}

#[test]
fn pngs_decode_to_what_was_encoded() {
    let data: Vec<u8> = (0..16 * 16 * 3).map(|i| (i % 251) as u8).collect();
    let png = encode_png(16, 3, &data).unwrap();
    let (w, h, back) =
        crate::io::image_decode::decode_channels(&png, "t", crate::io::image_decode::Channels::Rgba)
            .unwrap();
    assert_eq!((w, h), (16, 16));
    for (i, px) in back.chunks(4).enumerate() {
        for c in 0..3 {
            assert_eq!((px[c] * 255.0).round() as u8, data[i * 3 + c]);
        }
    }
}

/// (colour type, bit depth) from a PNG's header.
fn png_kind(png: &[u8]) -> (u8, u8) {
    (png[25], png[24])
}

fn decoded(png: &[u8], n: usize) -> Vec<[u8; 4]> {
    let (w, h, back) =
        crate::io::image_decode::decode_channels(png, "t", crate::io::image_decode::Channels::Rgba)
            .unwrap();
    assert_eq!((w as usize, h as usize), (n, n));
    back.chunks(4)
        .map(|p| std::array::from_fn(|c| (p[c] * 255.0).round() as u8))
        .collect()
}

#[test]
fn maps_of_few_colours_are_palette_images_that_decode_to_the_same_pixels() {
    let n = 64;
    // 200 colours (a crack's blends over one colour): a palette of 8 bits.
    let colour = |i: usize| {
        let k = ((i * 7919) % 200) as u8;
        [k, 255 - k, k / 2]
    };
    let rgb: Vec<u8> = (0..n * n).flat_map(colour).collect();
    let png = encode_png(n as u32, 3, &rgb).unwrap();
    assert_eq!(png_kind(&png), (3, 8));
    for (i, px) in decoded(&png, n).iter().enumerate() {
        assert_eq!(px[..3], colour(i)[..], "texel {i}");
        assert_eq!(px[3], 255);
    }
    // 300 colours: RGB as before.
    let rgb: Vec<u8> = (0..n * n)
        .flat_map(|i| [(i % 300 / 2) as u8, (i % 300 % 2) as u8, 9])
        .collect();
    assert_eq!(png_kind(&encode_png(n as u32, 3, &rgb).unwrap()), (2, 8));
    // RGBA with transparent background: the palette keeps alpha.
    let rgba: Vec<u8> = (0..n * n)
        .flat_map(|i| {
            if i % 3 == 0 {
                [0, 0, 0, 0]
            } else {
                [200, 100, (i % 50) as u8, 255]
            }
        })
        .collect();
    let png = encode_png(n as u32, 4, &rgba).unwrap();
    assert_eq!(png_kind(&png), (3, 8));
    let back = decoded(&png, n);
    assert!(back.iter().zip(rgba.chunks(4)).all(|(a, b)| a[..] == b[..]));
    // Grey: 16 levels fit 4 bits, more stay 8-bit grey.
    let grey: Vec<u8> = (0..n * n).map(|i| (i % 16 * 17) as u8).collect();
    let png = encode_png(n as u32, 1, &grey).unwrap();
    assert_eq!(png_kind(&png), (3, 4));
    assert!(decoded(&png, n).iter().zip(&grey).all(|(a, &g)| a[0] == g));
    let grey: Vec<u8> = (0..n * n).map(|i| (i % 100) as u8).collect();
    let png = encode_png(n as u32, 1, &grey).unwrap();
    assert_eq!(png_kind(&png), (0, 8));
    assert!(decoded(&png, n).iter().zip(&grey).all(|(a, &g)| a[0] == g));
    // A wrong length is the encoder's error, not a panic.
    assert!(encode_png(n as u32, 3, &grey).is_err());
}

#[test]
fn groove_normals_snap_to_a_few_hundred_directions_within_eight_degrees() {
    let mut seen = std::collections::BTreeSet::new();
    let mut worst = 0.0f64;
    // Tilts up to 79 degrees: walls five times as deep as half wide.
    for i in 0..79 {
        for j in 0..360 {
            let (tilt, az) = ((i as f64).to_radians(), (j as f64 + 0.37).to_radians());
            let n = [tilt.sin() * az.cos(), tilt.sin() * az.sin(), tilt.cos()];
            let q = super::quantize_direction(n);
            let dot: f64 = (0..3).map(|k| n[k] * q[k]).sum();
            worst = worst.max(dot.clamp(-1.0, 1.0).acos().to_degrees());
            seen.insert(q.map(|x| super::to_u8(0.5 * x + 0.5)));
        }
    }
    assert!(worst < 8.0, "{worst} degrees");
    assert!(seen.len() <= 225, "{} directions", seen.len());
    assert_eq!(super::quantize_direction([0.01, 0.0, 1.0]), [0.0, 0.0, 1.0]);
}

#[test]
fn the_own_normal_map_is_carried_into_the_baked_frame() {
    // The own map's frame: tangent +x, bitangent +y; the baked set's is
    // turned a quarter about +z (tangent +y, bitangent cross(z, y) = -x).
    let normals = [[0.0, 0.0, 1.0]; 3];
    let from = [[1.0, 0.0, 0.0, 1.0]; 3];
    let to = [[0.0, 1.0, 0.0, 1.0]; 3];
    let r = Reframe {
        normals: &normals,
        from: &from,
        to: &to,
    };
    let w = [0.2, 0.3, 0.5];
    // Tilted towards +x in the world: along the baked tangent's -bitangent.
    let v = r.carry([0, 1, 2], w, [0.6, 0.0, 0.8]);
    for (got, want) in v.iter().zip([0.0, -0.6, 0.8]) {
        assert!((got - want).abs() < 1e-12, "{v:?}");
    }
    // A mirrored baked frame (w = -1) flips the bitangent's component.
    let mirrored = [[0.0, 1.0, 0.0, -1.0]; 3];
    let r = Reframe { to: &mirrored, ..r };
    let v = r.carry([0, 1, 2], w, [0.6, 0.0, 0.8]);
    assert!((v[1] - 0.6).abs() < 1e-12, "{v:?}");
}
