//! A glTF document's buffers: data URIs decoded, external files read inside the asset's folder with a size cap, the binary chunk, and the checks made before any accessor is read (positions present, schema).

use super::*;
use crate::io::paths::{resolve_file_inside, MAX_MODEL_BYTES};
use base64::Engine;
use serde_json::Value;
use std::io::Read;
use std::path::Path;

/// POSITION accessor indices must exist before the `gltf` crate's schema check
/// looks them up (it indexes without checking).
pub(super) fn precheck_positions(root: &Value) -> std::result::Result<(), GltfError> {
    let n_acc = arr(root, "accessors").len();
    for (mi, m) in arr(root, "meshes").iter().enumerate() {
        for (pi, p) in arr(m, "primitives").iter().enumerate() {
            let pos = p.get("attributes").and_then(|a| a.get("POSITION"));
            if let Some(pos) = pos {
                match pos.as_u64() {
                    Some(i) if (i as usize) < n_acc => {}
                    _ => {
                        return Err(GltfError::NoPositionAccessor {
                            mesh: mi,
                            primitive: pi,
                            accessor: pos.to_string(),
                            accessors: n_acc,
                        })
                    }
                }
            }
        }
    }
    Ok(())
}

/// Structural validation by the `gltf` crate's schema (indices in range,
/// required fields), ignoring its refusal of extensions we handle ourselves.
pub(super) fn validate_schema(json: &[u8]) -> std::result::Result<(), GltfError> {
    use gltf::json::validation::{Error as VErr, Validate};
    let root: gltf::json::Root =
        gltf::json::deserialize::from_slice(json).map_err(GltfError::SchemaJson)?;
    let mut errors = Vec::new();
    root.validate(&root, gltf::json::Path::new, &mut |path, e| {
        if e != VErr::Unsupported {
            errors.push(format!("{}: {e}", path()));
        }
    });
    if errors.is_empty() {
        Ok(())
    } else {
        let count = errors.len();
        errors.truncate(5);
        Err(GltfError::Schema { count, errors })
    }
}

pub(super) fn decode_data_uri(uri: &str) -> Option<std::result::Result<DataUri, DataUriError>> {
    let rest = uri.strip_prefix("data:")?;
    Some((|| {
        let (meta, data) = rest.split_once(',').ok_or(DataUriError::Malformed)?;
        let mime = meta
            .split(';')
            .next()
            .filter(|m| !m.is_empty())
            .map(str::to_string);
        if !meta.ends_with(";base64") {
            return Err(DataUriError::NotBase64);
        }
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(data.trim())
            .map_err(DataUriError::Base64)?;
        Ok((mime, bytes))
    })())
}

/// Load every buffer that some buffer view uses. External files are held
/// to [`MAX_MODEL_BYTES`] each and, with every buffer before them, to
/// `max_memory` in all, checked on their declared lengths before anything
/// is allocated (a sparse file declaring gigabytes is refused, not read).
pub(super) fn load_buffers(
    root: &Value,
    mut bin: Option<Vec<u8>>,
    base_dir: &Path,
    max_memory: u64,
) -> std::result::Result<Vec<Option<Vec<u8>>>, GltfError> {
    let bufs = arr(root, "buffers");
    let mut used = vec![false; bufs.len()];
    if let Some(views) = root.get("bufferViews").and_then(Value::as_array) {
        for v in views {
            if let Some(b) = v.get("buffer").and_then(Value::as_u64) {
                if let Some(u) = used.get_mut(b as usize) {
                    *u = true;
                }
            }
        }
    }
    let mut out = Vec::with_capacity(bufs.len());
    // Bytes held by the buffers loaded so far.
    let mut held: u64 = 0;
    for (i, b) in bufs.iter().enumerate() {
        let fail = |fault| GltfError::Buffer { buffer: i, fault };
        if !used[i] {
            out.push(None);
            continue;
        }
        let declared = b
            .get("byteLength")
            .and_then(Value::as_u64)
            .ok_or(fail(BufferFault::NoLength))?;
        let external = b
            .get("uri")
            .and_then(Value::as_str)
            .is_some_and(|u| !u.starts_with("data:"));
        if external && declared > MAX_MODEL_BYTES {
            return Err(fail(BufferFault::TooLarge { declared }));
        }
        if external && held.saturating_add(declared) > max_memory {
            return Err(fail(BufferFault::OverBudget {
                declared,
                total: held.saturating_add(declared),
                max_memory,
            }));
        }
        let data = match b.get("uri").and_then(Value::as_str) {
            None => {
                if i != 0 {
                    return Err(GltfError::BufferNoUri(i));
                }
                let data = bin.take().ok_or(GltfError::NoChunk(i))?;
                if (data.len() as u64) < declared {
                    return Err(fail(BufferFault::ShortChunk {
                        holds: data.len(),
                        declared,
                    }));
                }
                data
            }
            Some(uri) => {
                if let Some(r) = decode_data_uri(uri) {
                    // Check the declared size against the encoded size before decoding.
                    if (uri.len() as u64) < declared.saturating_mul(4) / 3 {
                        return Err(fail(BufferFault::ShortUri { declared }));
                    }
                    let (_, data) = r.map_err(|e| fail(BufferFault::DataUri(e)))?;
                    if (data.len() as u64) < declared {
                        return Err(fail(BufferFault::ShortData {
                            holds: data.len(),
                            declared,
                        }));
                    }
                    data
                } else {
                    let file = resolve_file_inside(base_dir, uri)
                        .map_err(|e| fail(BufferFault::Reference(e)))?;
                    let open = |error| {
                        fail(BufferFault::Open {
                            file: file.clone(),
                            error,
                        })
                    };
                    // Opened without following a link: one swapped in after
                    // the path was checked is refused, not read.
                    let opened = crate::io::paths::open_no_follow(&file).map_err(open)?;
                    let meta = opened.metadata().map_err(open)?;
                    if meta.len() < declared {
                        return Err(fail(BufferFault::ShortFile {
                            file: file.clone(),
                            len: meta.len(),
                            declared,
                        }));
                    }
                    let mut data = Vec::with_capacity(declared as usize);
                    opened
                        .take(declared)
                        .read_to_end(&mut data)
                        .map_err(|error| {
                            fail(BufferFault::ReadFile {
                                file: file.clone(),
                                error,
                            })
                        })?;
                    data
                }
            }
        };
        let mut data = data;
        data.truncate(declared as usize);
        held = held.saturating_add(data.len() as u64);
        out.push(Some(data));
    }
    Ok(out)
}
