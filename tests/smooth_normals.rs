//! An input without normals comes back smooth where it is smooth and
//! faceted where it has creases, as a DCC tool shades it (Blender's auto
//! smooth at 30 degrees): every surface corner of the output has a unit
//! `NORMAL`, on a smooth surface within a few degrees of the angle-weighted
//! normal of all the output triangles at its position, on a block equal to
//! its face's. Read from the output's own accessors here; the reference
//! normals are computed here from the output's triangles.

mod common;
#[path = "common/shapes.rs"]
mod shapes;

use serde_json::Value;
use std::collections::HashMap;
use std::path::Path;

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn unit(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// Accessor `i` of a GLB as numbers, `n` per element (float, u8, u16 or
/// u32 components).
fn numbers(json: &Value, bin: &[u8], i: usize, n: usize) -> Vec<Vec<f64>> {
    let a = &json["accessors"][i];
    let (size, kind) = match a["componentType"].as_u64().unwrap() {
        5126 => (4, 'f'),
        5125 => (4, 'u'),
        5123 => (2, 'u'),
        5121 => (1, 'u'),
        c => panic!("component type {c}"),
    };
    let v = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let start = v["byteOffset"].as_u64().unwrap_or(0) + a["byteOffset"].as_u64().unwrap_or(0);
    let stride = v["byteStride"].as_u64().unwrap_or((size * n) as u64) as usize;
    (0..a["count"].as_u64().unwrap() as usize)
        .map(|k| {
            (0..n)
                .map(|c| {
                    let at = start as usize + k * stride + size * c;
                    let b = &bin[at..at + size];
                    match (kind, size) {
                        ('f', _) => f64::from(f32::from_le_bytes(b.try_into().unwrap())),
                        (_, 4) => f64::from(u32::from_le_bytes(b.try_into().unwrap())),
                        (_, 2) => f64::from(u16::from_le_bytes(b.try_into().unwrap())),
                        _ => f64::from(b[0]),
                    }
                })
                .collect()
        })
        .collect()
}

/// Per surface corner (triangles of materials other than the walls'):
/// its position, its triangle's unit normal and corner angle, and its
/// `NORMAL` (`None` where the primitive has none).
struct Corner {
    at: V3,
    face: V3,
    angle: f64,
    normal: Option<V3>,
}

fn surface_corners(path: &Path) -> Vec<Corner> {
    let bytes = std::fs::read(path).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin = &bytes[20 + json_len + 8..];
    let mut out = Vec::new();
    for mesh in json["meshes"].as_array().unwrap() {
        for p in mesh["primitives"].as_array().unwrap() {
            if p["mode"].as_u64().unwrap_or(4) != 4 {
                continue;
            }
            let material = p["material"]
                .as_u64()
                .and_then(|m| json["materials"][m as usize]["name"].as_str())
                .unwrap_or("");
            if material == "crack_wall" {
                continue;
            }
            let attr = |s: &str, n: usize| {
                p["attributes"][s]
                    .as_u64()
                    .map(|i| numbers(&json, bin, i as usize, n))
            };
            let pos: Vec<V3> = attr("POSITION", 3)
                .unwrap()
                .iter()
                .map(|v| [v[0], v[1], v[2]])
                .collect();
            let nrm: Option<Vec<V3>> =
                attr("NORMAL", 3).map(|n| n.iter().map(|v| [v[0], v[1], v[2]]).collect());
            let idx: Vec<usize> = numbers(&json, bin, p["indices"].as_u64().unwrap() as usize, 1)
                .iter()
                .map(|v| v[0] as usize)
                .collect();
            for t in idx.chunks(3) {
                let [a, b, c] = [pos[t[0]], pos[t[1]], pos[t[2]]];
                let n = cross(sub(b, a), sub(c, a));
                if dot(n, n) < 1e-24 {
                    continue;
                }
                let face = unit(n);
                for k in 0..3 {
                    let (p0, p1, p2) = (pos[t[k]], pos[t[(k + 1) % 3]], pos[t[(k + 2) % 3]]);
                    let (u, w) = (sub(p1, p0), sub(p2, p0));
                    out.push(Corner {
                        at: p0,
                        face,
                        angle: dot(cross(u, w), cross(u, w)).sqrt().atan2(dot(u, w)),
                        normal: nrm.as_ref().map(|n| n[t[k]]),
                    });
                }
            }
        }
    }
    out
}

/// Over the corners at a smooth position (any two triangles there within
/// 30 degrees of each other): the share whose
/// `NORMAL` lies within `degrees` of that normal, and their count. A
/// corner at a crease (a position with a triangle farther off) faces its
/// own triangle's side (a chain of gentle bends may smooth it a long way;
/// `a_block_keeps_its_creases` checks sharp ones). Panics when a corner
/// has no `NORMAL` or one not of unit length.
fn smooth_share(corners: &[Corner], degrees: f64) -> (f64, usize) {
    let key = |p: V3| p.map(|x| (x as f32).to_bits());
    let mut sum: HashMap<[u32; 3], V3> = HashMap::new();
    for c in corners {
        let s = sum.entry(key(c.at)).or_insert([0.0; 3]);
        for (x, f) in s.iter_mut().zip(c.face) {
            *x += c.angle * f;
        }
    }
    let crease = 30f64.to_radians().cos();
    let mut faces: HashMap<[u32; 3], Vec<V3>> = HashMap::new();
    for c in corners {
        faces.entry(key(c.at)).or_default().push(c.face);
    }
    let sharp: HashMap<[u32; 3], bool> = faces
        .iter()
        .map(|(k, f)| {
            let off = f.iter().any(|a| f.iter().any(|b| dot(*a, *b) < crease));
            (*k, off)
        })
        .collect();
    let cos = degrees.to_radians().cos();
    let (mut near, mut smooth) = (0, 0);
    for c in corners {
        let n = c.normal.expect("every surface corner has a NORMAL");
        assert!(
            (dot(n, n).sqrt() - 1.0).abs() < 1e-3,
            "NORMAL {n:?} is not unit"
        );
        if sharp[&key(c.at)] {
            assert!(
                dot(n, c.face) > 0.0,
                "a corner at a crease, {:?}: {n:?} against its face {:?}",
                c.at,
                c.face
            );
            continue;
        }
        smooth += 1;
        if dot(n, unit(sum[&key(c.at)])) >= cos {
            near += 1;
        }
    }
    (near as f64 / smooth.max(1) as f64, smooth)
}

fn crack(input: &Path, out: &Path, preset: &str) {
    let o = common::crack(input, out, &["-q", "--preset", preset]);
    assert!(
        o.status.success(),
        "{preset} on {}: {}",
        input.display(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A UV sphere as a DCC tool exports it (no normals): smooth, with the
/// preset's cracks cut, gapped or baked.
#[test]
fn a_uv_sphere_without_normals_comes_back_smooth() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("sphere.obj");
    shapes::write_obj(&input, &shapes::latlong_sphere(64, 32));
    for preset in ["glaze", "mud", "glass-impact"] {
        let out = dir.path().join(format!("{preset}.glb"));
        crack(&input, &out, preset);
        let (share, n) = smooth_share(&surface_corners(&out), 3.0);
        eprintln!("{preset}: {share:.4} of {n} smooth corners within 3 degrees");
        assert!(share >= 0.99, "{preset}: {share} of {n} corners smooth");
    }
    // The key turns it off: flat, as before.
    let out = dir.path().join("flat.glb");
    let o = common::crack(
        &input,
        &out,
        &["-q", "--preset", "glaze", "--set", "post.smooth_angle=0"],
    );
    assert!(o.status.success());
    assert!(surface_corners(&out).iter().all(|c| c.normal.is_none()));
}

/// A block keeps its creases: every corner's normal is its face's.
#[test]
fn a_block_keeps_its_creases() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("block.glb");
    crack(&common::fixture("notched_block.obj"), &out, "glaze");
    let corners = surface_corners(&out);
    assert!(!corners.is_empty());
    for c in &corners {
        let n = c.normal.expect("a NORMAL");
        assert!(
            dot(n, c.face) > 1f64.to_radians().cos(),
            "a block corner at {:?}: {n:?}, its face {:?}",
            c.at,
            c.face
        );
    }
}

/// The teapot and spot (no normals in their OBJ files) with glaze, mud and
/// glass-impact: smooth wherever the asset is, faceted at the teapot's
/// creases (rings of its lid).
#[test]
fn the_teapot_and_spot_come_back_smooth() {
    let dir = tempfile::tempdir().unwrap();
    for (name, rel) in [
        ("teapot", "obj/teapot/teapot.obj"),
        ("spot", "obj/spot/spot_triangulated.obj"),
    ] {
        let Some(input) = common::eval_data(rel) else {
            continue;
        };
        for preset in ["glaze", "mud", "glass-impact"] {
            let out = dir.path().join(format!("{name}-{preset}.glb"));
            crack(&input, &out, preset);
            let (share, n) = smooth_share(&surface_corners(&out), 5.0);
            eprintln!("{name} {preset}: {share:.4} of {n} smooth corners within 5 degrees");
            assert!(
                share >= 0.99,
                "{name} {preset}: {share} of {n} corners smooth"
            );
        }
    }
}
