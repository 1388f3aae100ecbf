//! Index references inside the glTF JSON the writer carries over: the used
//! subset's new indices, and the texture, image and material references of
//! materials, textures and primitives.

use serde_json::{Map, Value};
use std::collections::{BTreeMap, BTreeSet};

/// Old index -> new index for the used subset, keeping the original order.
pub(super) fn remap(used: &BTreeSet<usize>) -> BTreeMap<usize, usize> {
    used.iter()
        .enumerate()
        .map(|(new, &old)| (old, new))
        .collect()
}

/// Texture references in a material: every `*Texture` object with an `index`,
/// in the core material and its extensions (not in extras).
pub(super) fn visit_texture_refs(v: &mut Value, f: &mut dyn FnMut(&mut Value)) {
    if let Value::Object(o) = v {
        for (k, child) in o.iter_mut() {
            if k == "extras" {
                continue;
            }
            if k.ends_with("Texture") && child.get("index").is_some() {
                f(child.get_mut("index").expect("checked"));
            }
            visit_texture_refs(child, f);
        }
    }
}

/// Image references of a texture: `source` and each extension's `source`.
pub(super) fn visit_image_refs(t: &mut Value, f: &mut dyn FnMut(&mut Value)) {
    if let Some(s) = t.get_mut("source") {
        f(s);
    }
    if let Some(ext) = t.get_mut("extensions").and_then(Value::as_object_mut) {
        for (_, e) in ext.iter_mut() {
            if let Some(s) = e.get_mut("source") {
                f(s);
            }
        }
    }
}

/// Material references in a primitive's `KHR_materials_variants` mappings.
pub(super) fn visit_variant_material_refs(
    rest: &mut Map<String, Value>,
    f: &mut dyn FnMut(&mut Value),
) {
    if let Some(maps) = rest
        .get_mut("extensions")
        .and_then(|e| e.get_mut("KHR_materials_variants"))
        .and_then(|v| v.get_mut("mappings"))
        .and_then(Value::as_array_mut)
    {
        for m in maps {
            if let Some(x) = m.get_mut("material") {
                f(x);
            }
        }
    }
}

pub(super) fn as_idx(v: &Value) -> Option<usize> {
    v.as_u64().map(|x| x as usize)
}

pub(super) fn set_idx(v: &mut Value, map: &BTreeMap<usize, usize>) {
    if let Some(new) = as_idx(v).and_then(|o| map.get(&o)) {
        *v = (*new).into();
    }
}
