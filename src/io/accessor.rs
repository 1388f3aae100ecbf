//! Bounds-checked decoding of glTF accessors.
//!
//! Every size an asset declares (buffer lengths, view ranges, strides, accessor
//! counts, sparse counts) is checked against the real data before anything is
//! allocated, so a malformed or hostile file gives an error, never a panic or a
//! huge allocation.

use serde_json::Value;

/// An accessor that cannot be decoded; the message names it and why.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum AccessorError {
    /// No accessor by that index.
    #[error("accessor {0} does not exist")]
    NoAccessor(usize),
    /// No buffer view by that index.
    #[error("bufferView {0} does not exist")]
    NoView(usize),
    /// A field that must be a non-negative integer is not.
    #[error("'{key}' must be a non-negative integer")]
    NotInteger {
        /// The field.
        key: &'static str,
    },
    /// The accessor is malformed or cannot be decoded.
    #[error("accessor {index}: {fault}")]
    Accessor {
        /// The accessor.
        index: usize,
        /// What is wrong.
        fault: AccessorFault,
    },
    /// A buffer view the accessor reads is malformed.
    #[error("bufferView {view}: {fault}")]
    View {
        /// The buffer view.
        view: usize,
        /// What is wrong.
        fault: ViewFault,
    },
}

/// What is wrong with one accessor.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum AccessorFault {
    /// Decoding it would go over the document's budget.
    #[error("decoding its {bytes} bytes would take the file's decoded data past {limit} bytes ({DECODE_FACTOR} times its real size, at least {DECODE_FLOOR}, at most --max-memory); refused")]
    Budget {
        /// Bytes its decoding takes.
        bytes: usize,
        /// The document's whole budget.
        limit: u64,
    },
    /// A required field is missing (`componentType`, `type`, `count`).
    #[error("missing {0}")]
    Missing(&'static str),
    /// `type` is not SCALAR, VEC2..4 or MAT2..4.
    #[error("invalid type '{kind}'")]
    Type {
        /// The accessor's `type`.
        kind: String,
    },
    /// `componentType` is not a glTF component type.
    #[error("invalid componentType {0}")]
    ComponentType(u32),
    /// `count` is 0.
    #[error("count must be at least 1")]
    ZeroCount,
    /// `count` times the element size overflows.
    #[error("count {0} overflows")]
    Overflow(usize),
    /// The view's stride is under the element size.
    #[error("byteStride {stride} is smaller than the element size {size}")]
    StrideTooSmall {
        /// The stride.
        stride: usize,
        /// The element size.
        size: usize,
    },
    /// The elements do not fit in the view.
    #[error("{count} elements of {size} bytes (stride {stride}, offset {offset}) do not fit in bufferView {view} ({bytes} bytes)")]
    DoesNotFit {
        /// Elements.
        count: usize,
        /// Element size.
        size: usize,
        /// Stride.
        stride: usize,
        /// Offset in the view.
        offset: usize,
        /// The view.
        view: usize,
        /// The view's length.
        bytes: usize,
    },
    /// An accessor without a view (all zeros) over the limit.
    #[error("{count} elements without a bufferView would need {bytes} bytes; refused")]
    ZerosTooLarge {
        /// Elements.
        count: usize,
        /// Bytes they would take.
        bytes: usize,
    },
    /// A sparse field is missing (`count`, `indices`, `values.bufferView`...).
    #[error("sparse.{0} missing")]
    SparseMissing(&'static str),
    /// `sparse.count` out of range.
    #[error("sparse.count {sparse} must be in 1..={count}")]
    SparseCount {
        /// `sparse.count`.
        sparse: usize,
        /// The accessor's count.
        count: usize,
    },
    /// `sparse.indices.componentType` is not an unsigned integer type.
    #[error("sparse.indices componentType {0} is invalid")]
    SparseIndexType(u32),
    /// The sparse indices do not fit in their view.
    #[error("sparse indices do not fit in bufferView {0}")]
    SparseIndicesFit(usize),
    /// The sparse values do not fit in their view.
    #[error("sparse values do not fit in bufferView {0}")]
    SparseValuesFit(usize),
    /// A sparse index beyond the accessor.
    #[error("sparse index {index} out of range ({count} elements)")]
    SparseIndex {
        /// The index.
        index: usize,
        /// The accessor's count.
        count: usize,
    },
    /// Sparse indices out of order.
    #[error("sparse indices are not strictly increasing")]
    SparseOrder,
    /// A matrix where a vector was expected.
    #[error("matrix accessor where a vector was expected")]
    Matrix,
    /// Indices that are not unnormalised scalars.
    #[error("indices must be SCALAR and not normalized")]
    IndicesKind,
    /// Indices of a signed or float component type.
    #[error("index componentType {0} is not an unsigned integer type")]
    IndexType(u32),
}

/// What is wrong with a buffer view an accessor reads.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ViewFault {
    /// A required field is missing (`buffer`, `byteLength`).
    #[error("missing {0}")]
    Missing(&'static str),
    /// An invalid stride.
    #[error("byteStride {0} is invalid (must be a multiple of 4 in 4..=252)")]
    Stride(usize),
    /// The buffer does not exist.
    #[error("buffer {0} does not exist")]
    NoBuffer(usize),
    /// The buffer was not loaded.
    #[error("buffer {0} has no data")]
    NoData(usize),
    /// The view's range is beyond the buffer.
    #[error("range {offset}+{length} exceeds buffer {buffer} ({bytes} bytes)")]
    Range {
        /// The view's offset.
        offset: usize,
        /// The view's length.
        length: usize,
        /// The buffer.
        buffer: usize,
        /// The buffer's length.
        bytes: usize,
    },
}

/// Most bytes a zero-initialised accessor (no bufferView) may claim: 256 MiB.
const MAX_ZERO_ACCESSOR_BYTES: u64 = 256 << 20;

/// Size in bytes of a glTF componentType.
pub fn component_size(component_type: u32) -> Option<usize> {
    match component_type {
        5120 | 5121 => Some(1),
        5122 | 5123 => Some(2),
        5125 | 5126 => Some(4),
        _ => None,
    }
}

/// Number of components of a glTF accessor type.
pub fn type_components(kind: &str) -> Option<usize> {
    match kind {
        "SCALAR" => Some(1),
        "VEC2" => Some(2),
        "VEC3" => Some(3),
        "VEC4" | "MAT2" => Some(4),
        "MAT3" => Some(9),
        "MAT4" => Some(16),
        _ => None,
    }
}

/// The glTF accessor type for `n` components of a vertex attribute.
pub fn vector_type(n: usize) -> &'static str {
    match n {
        1 => "SCALAR",
        2 => "VEC2",
        3 => "VEC3",
        _ => "VEC4",
    }
}

/// Per-component minimum and maximum of `data`, `components` values per
/// element (an accessor's `min` and `max`).
pub fn f32_bounds(data: &[f32], components: usize) -> (Vec<f32>, Vec<f32>) {
    let mut min = vec![f32::INFINITY; components];
    let mut max = vec![f32::NEG_INFINITY; components];
    for v in data.chunks_exact(components) {
        for k in 0..components {
            min[k] = min[k].min(v[k]);
            max[k] = max[k].max(v[k]);
        }
    }
    (min, max)
}

/// Byte size of one element, with glTF's column padding for small matrices.
pub fn element_size(component_type: u32, kind: &str) -> Option<usize> {
    let cs = component_size(component_type)?;
    let (cols, rows) = match kind {
        "MAT2" => (2, 2),
        "MAT3" => (3, 3),
        "MAT4" => (4, 4),
        _ => return Some(type_components(kind)? * cs),
    };
    let col = (rows * cs).div_ceil(4) * 4;
    Some(cols * col)
}

/// Parsed and validated description of one accessor.
#[derive(Clone, Debug)]
pub struct AccessorInfo {
    /// componentType.
    pub component_type: u32,
    /// type (`VEC3`...).
    pub kind: String,
    /// Components per element.
    pub components: usize,
    /// Bytes per element.
    pub element_size: usize,
    /// Element count.
    pub count: usize,
    /// normalized flag.
    pub normalized: bool,
}

/// Decodes accessors of one document against its loaded buffers.
pub struct AccessorReader<'a> {
    root: &'a Value,
    buffers: &'a [Option<Vec<u8>>],
    /// Bytes the document's decoded accessors may still take, together
    /// (each read of an accessor counts: many primitives sharing one, or
    /// sparse accessors without data, cannot multiply a small file into
    /// unbounded memory).
    budget: std::cell::Cell<u64>,
    /// The whole budget, for the message.
    limit: u64,
}

/// The decoded-data budget of a document of `real_bytes` bytes (its JSON
/// and buffers): [`DECODE_FACTOR`] times them, at least [`DECODE_FLOOR`],
/// at most `max_memory`.
pub fn decode_budget(real_bytes: u64, max_memory: u64) -> u64 {
    real_bytes
        .saturating_mul(DECODE_FACTOR)
        .max(DECODE_FLOOR)
        .min(max_memory)
}

/// Decoded accessor data may take this many times the document's real
/// bytes (integer to `f32` conversion takes 4x, shared accessors more).
pub const DECODE_FACTOR: u64 = 64;
/// Every document may decode at least this much: 1 GiB.
pub const DECODE_FLOOR: u64 = 1 << 30;

fn get_usize(v: &Value, key: &'static str) -> Result<Option<usize>, AccessorError> {
    match v.get(key) {
        None => Ok(None),
        Some(x) => x
            .as_u64()
            .and_then(|n| usize::try_from(n).ok())
            .map(Some)
            .ok_or(AccessorError::NotInteger { key }),
    }
}

/// Fault `fault` of accessor `index`.
fn fault(index: usize, fault: AccessorFault) -> AccessorError {
    AccessorError::Accessor { index, fault }
}

impl<'a> AccessorReader<'a> {
    /// A reader over the document `root` and its buffers (index-aligned with `root.buffers`;
    /// `None` for a buffer that was not loaded).
    pub fn new(root: &'a Value, buffers: &'a [Option<Vec<u8>>]) -> Self {
        Self::with_budget(root, buffers, DECODE_FLOOR)
    }

    /// A reader whose decoded accessors may take `budget` bytes in all.
    pub fn with_budget(root: &'a Value, buffers: &'a [Option<Vec<u8>>], budget: u64) -> Self {
        AccessorReader {
            root,
            buffers,
            budget: std::cell::Cell::new(budget),
            limit: budget,
        }
    }

    /// Take `bytes` from the budget before allocating them.
    fn charge(&self, index: usize, bytes: usize) -> Result<(), AccessorError> {
        let left = self.budget.get();
        if bytes as u64 > left {
            return Err(fault(
                index,
                AccessorFault::Budget {
                    bytes,
                    limit: self.limit,
                },
            ));
        }
        self.budget.set(left - bytes as u64);
        Ok(())
    }

    fn accessor_json(&self, index: usize) -> Result<&'a Value, AccessorError> {
        self.root
            .get("accessors")
            .and_then(|a| a.get(index))
            .ok_or(AccessorError::NoAccessor(index))
    }

    /// Describe accessor `index`, checking its fields.
    pub fn info(&self, index: usize) -> Result<AccessorInfo, AccessorError> {
        let a = self.accessor_json(index)?;
        let missing = |key| fault(index, AccessorFault::Missing(key));
        let ct = get_usize(a, "componentType")?.ok_or_else(|| missing("componentType"))? as u32;
        let kind = a
            .get("type")
            .and_then(Value::as_str)
            .ok_or_else(|| missing("type"))?
            .to_string();
        let components = type_components(&kind)
            .ok_or_else(|| fault(index, AccessorFault::Type { kind: kind.clone() }))?;
        let element_size = element_size(ct, &kind)
            .ok_or_else(|| fault(index, AccessorFault::ComponentType(ct)))?;
        let count = get_usize(a, "count")?.ok_or_else(|| missing("count"))?;
        if count == 0 {
            return Err(fault(index, AccessorFault::ZeroCount));
        }
        let normalized = a
            .get("normalized")
            .and_then(Value::as_bool)
            .unwrap_or(false);
        Ok(AccessorInfo {
            component_type: ct,
            kind,
            components,
            element_size,
            count,
            normalized,
        })
    }

    /// The bytes of buffer view `view`, and its stride (None when tightly packed).
    fn view(&self, view: usize) -> Result<(&'a [u8], Option<usize>), AccessorError> {
        let v = self
            .root
            .get("bufferViews")
            .and_then(|a| a.get(view))
            .ok_or(AccessorError::NoView(view))?;
        let err = |fault| AccessorError::View { view, fault };
        let buffer = get_usize(v, "buffer")?.ok_or_else(|| err(ViewFault::Missing("buffer")))?;
        let offset = get_usize(v, "byteOffset")?.unwrap_or(0);
        let length =
            get_usize(v, "byteLength")?.ok_or_else(|| err(ViewFault::Missing("byteLength")))?;
        let stride = get_usize(v, "byteStride")?;
        if let Some(s) = stride {
            if !(4..=252).contains(&s) || s % 4 != 0 {
                return Err(err(ViewFault::Stride(s)));
            }
        }
        let data = self
            .buffers
            .get(buffer)
            .ok_or_else(|| err(ViewFault::NoBuffer(buffer)))?
            .as_deref()
            .ok_or_else(|| err(ViewFault::NoData(buffer)))?;
        let end = offset
            .checked_add(length)
            .filter(|&e| e <= data.len())
            .ok_or_else(|| {
                err(ViewFault::Range {
                    offset,
                    length,
                    buffer,
                    bytes: data.len(),
                })
            })?;
        Ok((&data[offset..end], stride))
    }

    /// Tightly packed element bytes of accessor `index` (sparse substitution applied).
    pub fn read_packed(&self, index: usize) -> Result<(AccessorInfo, Vec<u8>), AccessorError> {
        let info = self.info(index)?;
        let a = self.accessor_json(index)?;
        let es = info.element_size;
        let total = info
            .count
            .checked_mul(es)
            .ok_or_else(|| fault(index, AccessorFault::Overflow(info.count)))?;
        self.charge(index, total)?;
        let mut out;
        match get_usize(a, "bufferView")? {
            Some(view) => {
                let (bytes, stride) = self.view(view)?;
                let offset = get_usize(a, "byteOffset")?.unwrap_or(0);
                let stride = stride.unwrap_or(es);
                if stride < es {
                    return Err(fault(
                        index,
                        AccessorFault::StrideTooSmall { stride, size: es },
                    ));
                }
                // Last byte needed: offset + stride*(count-1) + es
                let need = stride
                    .checked_mul(info.count - 1)
                    .and_then(|x| x.checked_add(es))
                    .and_then(|x| x.checked_add(offset));
                match need {
                    Some(n) if n <= bytes.len() => {}
                    _ => {
                        return Err(fault(
                            index,
                            AccessorFault::DoesNotFit {
                                count: info.count,
                                size: es,
                                stride,
                                offset,
                                view,
                                bytes: bytes.len(),
                            },
                        ))
                    }
                }
                if stride == es {
                    out = bytes[offset..offset + total].to_vec();
                } else {
                    out = Vec::with_capacity(total);
                    for i in 0..info.count {
                        let s = offset + i * stride;
                        out.extend_from_slice(&bytes[s..s + es]);
                    }
                }
            }
            None => {
                if a.get("sparse").is_none() {
                    // Legal but unusual: all zeros. Bound it.
                }
                if total as u64 > MAX_ZERO_ACCESSOR_BYTES {
                    return Err(fault(
                        index,
                        AccessorFault::ZerosTooLarge {
                            count: info.count,
                            bytes: total,
                        },
                    ));
                }
                out = vec![0u8; total];
            }
        }
        if let Some(sparse) = a.get("sparse") {
            self.apply_sparse(index, &info, sparse, &mut out)?;
        }
        Ok((info, out))
    }

    fn apply_sparse(
        &self,
        index: usize,
        info: &AccessorInfo,
        sparse: &Value,
        out: &mut [u8],
    ) -> Result<(), AccessorError> {
        let err = |f| fault(index, f);
        let missing = |key| err(AccessorFault::SparseMissing(key));
        let n = get_usize(sparse, "count")?.ok_or_else(|| missing("count"))?;
        if n == 0 || n > info.count {
            return Err(err(AccessorFault::SparseCount {
                sparse: n,
                count: info.count,
            }));
        }
        let idx = sparse.get("indices").ok_or_else(|| missing("indices"))?;
        let vals = sparse.get("values").ok_or_else(|| missing("values"))?;
        let ict = get_usize(idx, "componentType")?.unwrap_or(0) as u32;
        let ics = match ict {
            5121 => 1,
            5123 => 2,
            5125 => 4,
            _ => return Err(err(AccessorFault::SparseIndexType(ict))),
        };
        let iview = get_usize(idx, "bufferView")?.ok_or_else(|| missing("indices.bufferView"))?;
        let ioff = get_usize(idx, "byteOffset")?.unwrap_or(0);
        let (ibytes, _) = self.view(iview)?;
        let ineed = n.checked_mul(ics).and_then(|x| x.checked_add(ioff));
        if ineed.is_none_or(|x| x > ibytes.len()) {
            return Err(err(AccessorFault::SparseIndicesFit(iview)));
        }
        let vview = get_usize(vals, "bufferView")?.ok_or_else(|| missing("values.bufferView"))?;
        let voff = get_usize(vals, "byteOffset")?.unwrap_or(0);
        let (vbytes, _) = self.view(vview)?;
        let es = info.element_size;
        let vneed = n.checked_mul(es).and_then(|x| x.checked_add(voff));
        if vneed.is_none_or(|x| x > vbytes.len()) {
            return Err(err(AccessorFault::SparseValuesFit(vview)));
        }
        let mut prev: Option<usize> = None;
        for k in 0..n {
            let p = ioff + k * ics;
            let target = match ics {
                1 => ibytes[p] as usize,
                2 => u16::from_le_bytes([ibytes[p], ibytes[p + 1]]) as usize,
                _ => u32::from_le_bytes([ibytes[p], ibytes[p + 1], ibytes[p + 2], ibytes[p + 3]])
                    as usize,
            };
            if target >= info.count {
                return Err(err(AccessorFault::SparseIndex {
                    index: target,
                    count: info.count,
                }));
            }
            if prev.is_some_and(|q| target <= q) {
                return Err(err(AccessorFault::SparseOrder));
            }
            prev = Some(target);
            let src = voff + k * es;
            out[target * es..(target + 1) * es].copy_from_slice(&vbytes[src..src + es]);
        }
        Ok(())
    }

    /// Accessor `index` as `f32` components (normalized integers are mapped to
    /// `[0,1]` or `[-1,1]`, other integers converted). Matrices are refused.
    pub fn read_f32(&self, index: usize) -> Result<(AccessorInfo, Vec<f32>), AccessorError> {
        let (info, bytes) = self.read_packed(index)?;
        if info.kind.starts_with("MAT") {
            return Err(fault(index, AccessorFault::Matrix));
        }
        let n = info.count * info.components;
        self.charge(index, 4 * n)?;
        let mut out = Vec::with_capacity(n);
        let norm = info.normalized;
        match info.component_type {
            5126 => out.extend(
                bytes
                    .chunks_exact(4)
                    .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])),
            ),
            5120 => out.extend(bytes.iter().map(|&b| {
                let v = b as i8 as f32;
                if norm {
                    (v / 127.0).max(-1.0)
                } else {
                    v
                }
            })),
            5121 => out.extend(
                bytes
                    .iter()
                    .map(|&b| if norm { b as f32 / 255.0 } else { b as f32 }),
            ),
            5122 => out.extend(bytes.chunks_exact(2).map(|c| {
                let v = i16::from_le_bytes([c[0], c[1]]) as f32;
                if norm {
                    (v / 32767.0).max(-1.0)
                } else {
                    v
                }
            })),
            5123 => out.extend(bytes.chunks_exact(2).map(|c| {
                let v = u16::from_le_bytes([c[0], c[1]]) as f32;
                if norm {
                    v / 65535.0
                } else {
                    v
                }
            })),
            5125 => out.extend(bytes.chunks_exact(4).map(|c| {
                let v = u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f32;
                if norm {
                    v / 4294967295.0
                } else {
                    v
                }
            })),
            ct => return Err(fault(index, AccessorFault::ComponentType(ct))),
        }
        Ok((info, out))
    }

    /// An index accessor as `u32` values (SCALAR, unsigned byte/short/int, not normalized).
    pub fn read_indices(&self, index: usize) -> Result<Vec<u32>, AccessorError> {
        let (info, bytes) = self.read_packed(index)?;
        self.charge(index, 4 * info.count)?;
        if info.kind != "SCALAR" || info.normalized {
            return Err(fault(index, AccessorFault::IndicesKind));
        }
        Ok(match info.component_type {
            5121 => bytes.iter().map(|&b| b as u32).collect(),
            5123 => bytes
                .chunks_exact(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
                .collect(),
            5125 => bytes
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
            ct => return Err(fault(index, AccessorFault::IndexType(ct))),
        })
    }
}

/// Triangle or line indices into `vertices` vertices as glTF bytes: 16-bit
/// (componentType 5123) while every index fits below 65,535 (the restart
/// value), else 32-bit (5125). Returns the bytes and the component type.
pub fn encode_indices(indices: &[u32], vertices: usize) -> (Vec<u8>, u32) {
    if vertices <= usize::from(u16::MAX) {
        let bytes = indices.iter().flat_map(|&i| (i as u16).to_le_bytes());
        (bytes.collect(), 5123)
    } else {
        let bytes = indices.iter().flat_map(|&i| i.to_le_bytes());
        (bytes.collect(), 5125)
    }
}

/// An accessor's values as f64 (normalized integers mapped like glTF says);
/// None for matrices or malformed data.
pub fn decode_raw(acc: &crate::scene::RawAccessor) -> Option<(usize, Vec<f64>)> {
    if acc.kind.starts_with("MAT") {
        return None;
    }
    let comps = type_components(&acc.kind)?;
    let size = component_size(acc.component_type)?;
    let n = acc.count.checked_mul(comps)?;
    let bytes = acc.data.get(..n.checked_mul(size)?)?;
    let norm = acc.normalized;
    let values = bytes
        .chunks_exact(size)
        .map(|c| match acc.component_type {
            5126 => f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]])),
            5120 => {
                let v = f64::from(c[0] as i8);
                if norm {
                    (v / 127.0).max(-1.0)
                } else {
                    v
                }
            }
            5121 => f64::from(c[0]) / if norm { 255.0 } else { 1.0 },
            5122 => {
                let v = f64::from(i16::from_le_bytes([c[0], c[1]]));
                if norm {
                    (v / 32767.0).max(-1.0)
                } else {
                    v
                }
            }
            5123 => f64::from(u16::from_le_bytes([c[0], c[1]])) / if norm { 65535.0 } else { 1.0 },
            _ => {
                f64::from(u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                    / if norm { 4294967295.0 } else { 1.0 }
            }
        })
        .collect();
    Some((comps, values))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn f32s(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    #[test]
    fn strided_and_sparse() {
        // 3 VEC2 floats interleaved with 8 bytes of padding (stride 16)
        let mut buf = Vec::new();
        for i in 0..3 {
            buf.extend(f32s(&[i as f32, 10.0 + i as f32]));
            buf.extend([0u8; 8]);
        }
        let sparse_idx_off = buf.len();
        buf.extend(2u16.to_le_bytes());
        buf.extend([0u8; 2]);
        let sparse_val_off = buf.len();
        buf.extend(f32s(&[-1.0, -2.0]));
        let root = json!({
            "bufferViews": [
                {"buffer":0, "byteOffset":0, "byteLength":48, "byteStride":16},
                {"buffer":0, "byteOffset":sparse_idx_off, "byteLength":2},
                {"buffer":0, "byteOffset":sparse_val_off, "byteLength":8}
            ],
            "accessors": [
                {"bufferView":0, "componentType":5126, "type":"VEC2", "count":3,
                 "sparse": {"count":1, "indices":{"bufferView":1,"componentType":5123}, "values":{"bufferView":2}}},
                {"bufferView":0, "componentType":5126, "type":"VEC2", "count":4}
            ]
        });
        let bufs = vec![Some(buf)];
        let r = AccessorReader::new(&root, &bufs);
        let (_, v) = r.read_f32(0).unwrap();
        assert_eq!(v, vec![0.0, 10.0, 1.0, 11.0, -1.0, -2.0]);
        let e = r.read_f32(1).unwrap_err().to_string();
        assert!(e.contains("do not fit"), "{e}");
    }

    #[test]
    fn hostile_sizes_are_errors() {
        let root = json!({
            "bufferViews": [{"buffer":0, "byteLength":8}],
            "accessors": [
                {"bufferView":0, "componentType":5126, "type":"VEC3", "count": 4000000000u64},
                {"componentType":5126, "type":"MAT4", "count": 100000000},
                {"bufferView":0, "componentType":5126, "type":"VEC3", "count": 0},
                {"bufferView":5, "componentType":5126, "type":"VEC3", "count": 1},
                {"bufferView":0, "componentType":1234, "type":"VEC3", "count": 1}
            ]
        });
        let bufs = vec![Some(vec![0u8; 8])];
        let r = AccessorReader::new(&root, &bufs);
        for i in 0..5 {
            assert!(r.read_packed(i).is_err(), "accessor {i} must be refused");
        }
    }

    #[test]
    fn normalized_integers() {
        let buf: Vec<u8> = [0u16, 65535, 32768]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .chain([0, 0])
            .collect();
        let root = json!({
            "bufferViews": [{"buffer":0, "byteLength":8}],
            "accessors": [{"bufferView":0, "componentType":5123, "type":"SCALAR", "count":3, "normalized": true}]
        });
        let bufs = vec![Some(buf)];
        let (_, v) = AccessorReader::new(&root, &bufs).read_f32(0).unwrap();
        assert_eq!(v[0], 0.0);
        assert_eq!(v[1], 1.0);
        assert!((v[2] - 0.5).abs() < 1e-4);
    }

    #[test]
    fn matrix_padding() {
        assert_eq!(element_size(5121, "MAT3"), Some(12));
        assert_eq!(element_size(5122, "MAT3"), Some(24));
        assert_eq!(element_size(5126, "MAT4"), Some(64));
        assert_eq!(element_size(5121, "MAT2"), Some(8));
    }
}
