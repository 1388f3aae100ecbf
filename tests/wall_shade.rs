//! Mud's walls read as shadowed cracks: their `COLOR_0` (which glTF
//! multiplies into the base colour) darkens with depth below the surface,
//! from about half at the rim to under a fifth at the bottom. Read from the
//! output's bytes here (the GLB's own accessors), with the rim found as the
//! wall vertices the surface shares and depth taken from the positions (the
//! plate lies in the xz plane, walls hang below it, cells curl a little),
//! not from the crate's wall coordinates.

mod common;
#[path = "common/shapes.rs"]
mod shapes;

use serde_json::Value;

/// The floats of accessor `i` of a GLB (`json`, `bin`), `n` per element.
fn floats(json: &Value, bin: &[u8], i: usize, n: usize) -> Vec<Vec<f32>> {
    let a = &json["accessors"][i];
    assert_eq!(a["componentType"], 5126, "float accessor {i}");
    let v = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let start = v["byteOffset"].as_u64().unwrap_or(0) + a["byteOffset"].as_u64().unwrap_or(0);
    let stride = v["byteStride"].as_u64().unwrap_or(4 * n as u64);
    (0..a["count"].as_u64().unwrap())
        .map(|k| {
            (0..n)
                .map(|c| {
                    let at = (start + k * stride + 4 * c as u64) as usize;
                    f32::from_le_bytes(bin[at..at + 4].try_into().unwrap())
                })
                .collect()
        })
        .collect()
}

#[test]
fn mud_walls_darken_with_depth() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plate.obj");
    shapes::write_obj(&input, &shapes::jittered_plate(80, 10.0, 0.3, 1));
    let out = dir.path().join("out.glb");
    let o = common::crack(&input, &out, &["-q", "--preset", "mud"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bytes = std::fs::read(&out).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin = &bytes[20 + json_len + 8..];
    let mut walls = 0;
    let prims = json["meshes"][0]["primitives"].as_array().unwrap();
    let material = |p: &Value| {
        json["materials"][p["material"].as_u64().unwrap() as usize]["name"]
            .as_str()
            .unwrap()
            .to_string()
    };
    let mut surface = std::collections::HashSet::new();
    for p in prims
        .iter()
        .filter(|p| p["mode"].as_u64().unwrap_or(4) == 4)
    {
        if material(p) != "crack_wall" {
            let at = p["attributes"]["POSITION"].as_u64().unwrap() as usize;
            for q in floats(&json, bin, at, 3) {
                surface.insert(q.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
            }
        }
    }
    for p in prims {
        if material(p) != "crack_wall" {
            assert!(p["attributes"].get("COLOR_0").is_none(), "{}", material(p));
            continue;
        }
        walls += 1;
        let at = |k: &str| p["attributes"][k].as_u64().unwrap() as usize;
        let pos = floats(&json, bin, at("POSITION"), 3);
        let color = floats(&json, bin, at("COLOR_0"), 3);
        let depth: Vec<f64> = pos.iter().map(|q| -f64::from(q[1])).collect();
        let shade: Vec<f64> = color.iter().map(|c| f64::from(c[0])).collect();
        let (lo, hi) = depth
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &d| (a.min(d), b.max(d)));
        let deepest = hi - lo;
        assert!(deepest > 0.0, "walls hang below the plate");
        for c in &color {
            assert!(c[0] == c[1] && c[1] == c[2], "grey {c:?}");
        }
        // Rims (on the surface) about half, the deepest under a fifth.
        let rim: Vec<f64> = (0..pos.len())
            .filter(|&k| surface.contains(&pos[k].iter().map(|x| x.to_bits()).collect::<Vec<_>>()))
            .map(|k| shade[k])
            .collect();
        assert!(
            rim.len() * 4 >= pos.len(),
            "{} rim corners of {}",
            rim.len(),
            pos.len()
        );
        assert!(rim.iter().all(|&s| (0.4..=0.6).contains(&s)), "{rim:?}");
        let bottom = (0..depth.len())
            .max_by(|&a, &b| depth[a].total_cmp(&depth[b]))
            .unwrap();
        assert!(shade[bottom] < 0.2, "{}", shade[bottom]);
        // Within each wall triangle, a corner below the rim is darker than
        // a corner on it.
        let on_rim =
            |k: usize| surface.contains(&pos[k].iter().map(|x| x.to_bits()).collect::<Vec<_>>());
        let mut pairs = 0;
        for t in (0..pos.len()).step_by(3) {
            for a in t..t + 3 {
                for b in t..t + 3 {
                    if on_rim(a) && !on_rim(b) {
                        pairs += 1;
                        assert!(shade[b] < shade[a], "{t}: below the rim is not darker");
                    }
                }
            }
        }
        assert!(pairs > 0);
    }
    assert_eq!(walls, 1, "one wall primitive");
}
