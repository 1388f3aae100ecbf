//! Material libraries (MTL) of an OBJ: the statements crackle keeps, texture maps with their options, and the glTF materials built from them.

use super::*;
use crate::io::paths::{locate_inside, read_capped, resolve_inside, Located, MAX_MTL_BYTES};
use crate::scene::{Image, ImageSource, Material, Scene};
use serde_json::{json, Map, Value};
use std::collections::{HashMap, HashSet};
use std::io::Cursor;
use std::path::{Path, PathBuf};

/// What the material-library callback collected.
#[derive(Default)]
pub(super) struct MtlState {
    pub(super) materials: Vec<tobj::Material>,
    pub(super) warnings: Vec<String>,
    pub(super) loaded: HashSet<PathBuf>,
}

impl MtlState {
    /// Load the libraries of one `mtllib` line (one file name, possibly with
    /// spaces, or several names separated by spaces).
    pub(super) fn load_libraries(&mut self, base_dir: &Path, obj_name: &str, lib: &Path) {
        let reference = lib.to_string_lossy().trim().to_string();
        let whole_exists = resolve_inside(base_dir, &reference).is_ok_and(|p| p.is_file());
        if whole_exists || !reference.contains(char::is_whitespace) {
            self.load_one(base_dir, obj_name, &reference);
        } else {
            for part in reference.split_whitespace() {
                self.load_one(base_dir, obj_name, part);
            }
        }
    }

    pub(super) fn load_one(&mut self, base_dir: &Path, obj_name: &str, reference: &str) {
        let path = match locate_inside(base_dir, reference) {
            Ok(Located::Missing(p)) => {
                // A source all the same: its appearing later changes the output.
                if !self.loaded.insert(p) {
                    return;
                }
                self.warnings.push(format!(
                    "{obj_name}: material library '{reference}' not found; faces using its materials get no material"
                ));
                return;
            }
            Ok(Located::Found(p)) => p,
            Err(msg) => {
                self.warnings.push(format!(
                    "{obj_name}: material library '{reference}' not read: {msg}"
                ));
                return;
            }
        };
        if !self.loaded.insert(path.clone()) {
            return;
        }
        let bytes = match read_capped(&path, MAX_MTL_BYTES, "material library") {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                self.warnings.push(format!(
                    "{obj_name}: material library '{reference}' not found; faces using its materials get no material"
                ));
                return;
            }
            Err(e) => {
                self.warnings.push(format!(
                    "{obj_name}: material library '{reference}' could not be read: {e}"
                ));
                return;
            }
        };
        let text = String::from_utf8_lossy(&bytes);
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let (clean, warnings) = clean_mtl(text, reference);
        self.warnings.extend(warnings);
        match tobj::load_mtl_buf(&mut Cursor::new(clean.as_bytes())) {
            Ok((materials, _)) => self.materials.extend(materials),
            Err(e) => self.warnings.push(format!(
                "{reference}: material library could not be parsed ({e}); it is ignored"
            )),
        }
    }
}

/// Canonical spelling of the MTL keywords this reader uses.
pub(super) const MTL_KEYWORDS: [&str; 19] = [
    "newmtl", "Ka", "Kd", "Ks", "Ke", "Ns", "Ni", "d", "Tr", "illum", "map_Ka", "map_Kd", "map_Ks",
    "map_Ke", "map_Ns", "map_d", "map_bump", "bump", "norm",
];

/// Rewrite an MTL file so tobj reads it without failing (or panicking):
/// continuation lines joined, keywords in canonical case, one-value colours
/// expanded, unsupported or malformed statements dropped with a warning.
pub(super) fn clean_mtl(text: &str, lib: &str) -> (String, Vec<String>) {
    let mut out = String::with_capacity(text.len());
    let mut warnings = Vec::new();
    let _ = logical_lines(text, |line, no| {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            return Ok(());
        }
        let (kw, rest) = split_keyword(t);
        let canon = MTL_KEYWORDS
            .iter()
            .find(|k| k.eq_ignore_ascii_case(kw))
            .copied();
        let mut skip = |why: &str| warnings.push(format!("{lib} line {no}: '{t}' ignored ({why})"));
        match canon {
            Some("newmtl") => {
                if rest.is_empty() {
                    skip("material without a name");
                } else {
                    out.push_str(&format!("newmtl {rest}\n"));
                }
            }
            Some(k @ ("Ka" | "Kd" | "Ks" | "Ke")) => {
                let nums: Vec<f32> = rest.split_whitespace().take(3).map_while(number).collect();
                match nums.len() {
                    1 => out.push_str(&format!("{k} {0} {0} {0}\n", nums[0])),
                    3 => out.push_str(&format!("{k} {} {} {}\n", nums[0], nums[1], nums[2])),
                    _ => skip("expected r g b numbers; spectral and xyz colours are not supported"),
                }
            }
            Some(k @ ("Ns" | "Ni" | "d" | "Tr")) => {
                match rest.split_whitespace().find_map(number) {
                    Some(x) => out.push_str(&format!("{k} {x}\n")),
                    None => skip("expected a number"),
                }
            }
            Some("illum") => match rest.split_whitespace().next().and_then(number) {
                Some(x) if (0.0..=255.0).contains(&x) => {
                    out.push_str(&format!("illum {}\n", x.round() as u8))
                }
                _ => skip("expected an illumination model number"),
            },
            Some(k) => {
                // Texture maps: keep the whole value (options and file name).
                if !rest.is_empty() {
                    out.push_str(&format!("{k} {rest}\n"));
                }
            }
            None => {
                if kw.is_empty() || kw.starts_with('#') {
                    return Ok(());
                }
                out.push_str(&format!("{kw} {rest}\n"));
            }
        }
        Ok(())
    });
    (out, warnings)
}

/// Split a texture-map value into its file name and the `-bm` (bump
/// multiplier) option; other options (`-s 1 1 1`, `-clamp on`...) are skipped.
/// The file name is the rest of the value after the options, spaces included.
pub(super) fn parse_map(value: &str) -> (String, Option<f32>) {
    let mut rest = value.trim();
    let mut bm = None;
    loop {
        let (opt, after) = split_keyword(rest);
        let lower = opt.to_ascii_lowercase();
        let (min_args, max_args) = match lower.as_str() {
            "-blendu" | "-blendv" | "-cc" | "-clamp" | "-bm" | "-boost" | "-texres"
            | "-imfchan" | "-type" => (1, 1),
            "-mm" => (2, 2),
            "-o" | "-s" | "-t" => (1, 3),
            _ => break,
        };
        let mut r = after;
        for taken in 0..max_args {
            let (arg, after_arg) = split_keyword(r);
            if arg.is_empty() || (taken >= min_args && number(arg).is_none()) {
                break;
            }
            if lower == "-bm" {
                bm = number(arg);
            }
            r = after_arg;
        }
        rest = r;
    }
    (rest.trim().to_string(), bm)
}

/// Turns used MTL materials into glTF materials, textures and images.
pub(super) struct MaterialBuilder<'a> {
    pub(super) base_dir: &'a Path,
    pub(super) lib: &'a [tobj::Material],
    pub(super) by_name: HashMap<String, Option<usize>>,
    pub(super) textures: HashMap<PathBuf, Option<usize>>,
    pub(super) file_names: HashSet<String>,
}

/// An `f32` as a JSON number with its shortest decimal form (0.8, not 0.800000011920929).
pub(super) fn jnum(x: f32) -> Value {
    x.to_string()
        .parse::<f64>()
        .map_or(Value::Null, |v| json!(v))
}

impl MaterialBuilder<'_> {
    /// The scene material for `usemtl name`, created on first use.
    pub(super) fn material(&mut self, name: &str, scene: &mut Scene) -> Option<usize> {
        if let Some(&m) = self.by_name.get(name) {
            return m;
        }
        let result = match self.lib.iter().rev().find(|m| m.name == name) {
            Some(m) => {
                let json = self.build(m, scene);
                scene.materials.push(Material { json });
                Some(scene.materials.len() - 1)
            }
            None => {
                scene.warnings.push(format!(
                    "usemtl '{name}': no such material in the loaded material libraries; its faces get no material"
                ));
                None
            }
        };
        self.by_name.insert(name.to_string(), result);
        result
    }

    pub(super) fn build(&mut self, m: &tobj::Material, scene: &mut Scene) -> Map<String, Value> {
        let mut json = Map::new();
        json.insert("name".into(), json!(m.name));
        let kd = m.diffuse.unwrap_or([1.0; 3]).map(|x| x.clamp(0.0, 1.0));
        let tr = m
            .unknown_param
            .get("Tr")
            .and_then(|v| v.split_whitespace().next())
            .and_then(number);
        let alpha = match (m.dissolve, tr) {
            (Some(d), _) => d.clamp(0.0, 1.0),
            (None, Some(t)) => {
                let a = 1.0 - t.clamp(0.0, 1.0);
                if a <= 0.0 {
                    scene.warnings.push(format!(
                        "material '{}': 'Tr {t}' would make it fully transparent; taken as opaque (some exporters write Tr as opacity)",
                        m.name
                    ));
                    1.0
                } else {
                    a
                }
            }
            (None, None) => 1.0,
        };
        let ns = m.shininess.unwrap_or(0.0).max(0.0) as f64;
        let roughness = (2.0 / (ns + 2.0)).sqrt().clamp(0.0, 1.0);
        let mut pbr = Map::new();
        pbr.insert(
            "baseColorFactor".into(),
            json!([jnum(kd[0]), jnum(kd[1]), jnum(kd[2]), jnum(alpha)]),
        );
        pbr.insert("metallicFactor".into(), json!(0.0));
        pbr.insert("roughnessFactor".into(), json!(roughness));
        if let Some(t) = m
            .diffuse_texture
            .as_deref()
            .and_then(|v| self.texture(v, &m.name, scene))
        {
            pbr.insert("baseColorTexture".into(), json!({ "index": t }));
        }
        json.insert("pbrMetallicRoughness".into(), Value::Object(pbr));
        let normal_map = m.unknown_param.get("norm").or(m.normal_texture.as_ref());
        if let Some(value) = normal_map {
            let (_, bm) = parse_map(value);
            if let Some(t) = self.texture(value, &m.name, scene) {
                let mut info = json!({ "index": t });
                if let Some(bm) = bm.filter(|&b| b != 1.0) {
                    info["scale"] = jnum(bm);
                }
                json.insert("normalTexture".into(), info);
            }
        }
        let emissive_tex = m
            .unknown_param
            .get("map_Ke")
            .and_then(|v| self.texture(v, &m.name, scene));
        let ke = m.emissive.map(|e| e.map(|x| x.clamp(0.0, 1.0)));
        let ke = match (ke, emissive_tex) {
            (Some(ke), _) => Some(ke),
            (None, Some(_)) => Some([1.0; 3]),
            (None, None) => None,
        };
        if let Some(ke) = ke.filter(|ke| ke.iter().any(|&x| x > 0.0)) {
            json.insert(
                "emissiveFactor".into(),
                json!([jnum(ke[0]), jnum(ke[1]), jnum(ke[2])]),
            );
        }
        if let Some(t) = emissive_tex {
            json.insert("emissiveTexture".into(), json!({ "index": t }));
        }
        if alpha < 1.0 {
            json.insert("alphaMode".into(), json!("BLEND"));
        }
        json
    }

    /// The texture index for a map value, adding the image on first use;
    /// `None` (with a warning) when the file is refused, missing or not PNG/JPEG.
    pub(super) fn texture(
        &mut self,
        value: &str,
        material: &str,
        scene: &mut Scene,
    ) -> Option<usize> {
        let (file, _) = parse_map(value);
        if file.is_empty() {
            scene.warnings.push(format!(
                "material '{material}': texture map '{value}' names no file; ignored"
            ));
            return None;
        }
        let path = match locate_inside(self.base_dir, &file) {
            // A missing file is reported below, with the type check.
            Ok(Located::Missing(p) | Located::Found(p)) => p,
            Err(msg) => {
                scene.warnings.push(format!(
                    "material '{material}': texture '{file}' not read: {msg}"
                ));
                return None;
            }
        };
        if let Some(&t) = self.textures.get(&path) {
            return t;
        }
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let mime = match ext.as_deref() {
            Some("png") => Some("image/png"),
            Some("jpg" | "jpeg") => Some("image/jpeg"),
            _ => None,
        };
        let result = match mime {
            None => {
                scene.warnings.push(format!(
                    "material '{material}': texture '{file}' is not PNG or JPEG (the only image types of core glTF); the texture is dropped"
                ));
                None
            }
            Some(_) if !path.is_file() => {
                scene.warnings.push(format!("material '{material}': texture file '{file}' not found; the texture is dropped"));
                None
            }
            Some(mime) => match crate::io::paths::read_capped(
                &path,
                crate::io::paths::MAX_IMAGE_BYTES,
                "image",
            ) {
                Err(e) => {
                    scene.warnings.push(format!(
                        "material '{material}': texture '{file}' not read: {e}; the texture is dropped"
                    ));
                    None
                }
                // Read once, here, where the path was checked: a file
                // swapped for a link meanwhile is never read later.
                Ok(bytes) => {
                    let own = path.file_name().map_or_else(
                        || "texture".to_string(),
                        |n| n.to_string_lossy().into_owned(),
                    );
                    let mut file_name = own.clone();
                    let mut k = 1;
                    while !self.file_names.insert(file_name.clone()) {
                        file_name = format!("{k}_{own}");
                        k += 1;
                    }
                    scene.images.push(Image {
                        name: Some(own),
                        mime_type: Some(mime.to_string()),
                        source: ImageSource::Bytes(bytes),
                        file_name,
                        rest: Map::new(),
                    });
                    scene
                        .textures
                        .push(json!({ "source": scene.images.len() - 1 }));
                    Some(scene.textures.len() - 1)
                }
            },
        };
        self.textures.insert(path, result);
        result
    }
}
