//! Per-corner attribute values ("wedges"): UVs, normals, colours...
//!
//! A wedge is one row of a [`WedgeAttributes`] table: one value of every
//! [`Channel`]. Face corners of a [`SimMesh`](super::SimMesh) reference
//! wedges, so a welded vertex can carry several wedges (UV or hard-normal
//! seams) while the surface is topologically joined.

use super::ids::WedgeId;
use serde::{Deserialize, Serialize};

/// How values of a channel are interpolated.
#[derive(Copy, Clone, PartialEq, Eq, Debug, Default, Serialize, Deserialize)]
pub enum ChannelKind {
    /// Componentwise linear interpolation (UVs, colours, weights...).
    #[default]
    Linear,
    /// A direction: interpolated linearly, then renormalized. With 4
    /// components (a glTF tangent) only `xyz` is renormalized and `w` keeps
    /// the sign of the dominant source; otherwise all components are
    /// renormalized.
    UnitVector,
}

/// One attribute channel: `components` values per wedge, wedge-major.
#[derive(Clone, PartialEq, Debug, Default, Serialize, Deserialize)]
pub struct Channel {
    /// Attribute name (e.g. `TEXCOORD_0`, `NORMAL`).
    pub name: String,
    /// Number of values per wedge (at least 1).
    pub components: usize,
    /// The values: `data[w * components + c]`.
    pub data: Vec<f64>,
    /// How the values are interpolated.
    pub kind: ChannelKind,
}

impl Channel {
    /// A channel named `name` with `components` values per wedge.
    pub fn new(
        name: impl Into<String>,
        components: usize,
        kind: ChannelKind,
        data: Vec<f64>,
    ) -> Self {
        Channel {
            name: name.into(),
            components,
            data,
            kind,
        }
    }

    /// The values of wedge `w`.
    ///
    /// # Panics
    /// If `w` is out of range.
    pub fn get(&self, w: WedgeId) -> &[f64] {
        let c = self.components;
        &self.data[w.idx() * c..(w.idx() + 1) * c]
    }
}

/// The wedge table of a mesh: `len()` wedges, each with one value per
/// channel. Channels always hold exactly `len() * components` values.
#[derive(Clone, PartialEq, Debug, Default)]
pub struct WedgeAttributes {
    channels: Vec<Channel>,
    len: usize,
}

impl WedgeAttributes {
    /// A table of `len` wedges with the given channels.
    ///
    /// Returns `None` if a channel has zero components or its data length
    /// is not `len * components`.
    pub fn new(len: usize, channels: Vec<Channel>) -> Option<Self> {
        for ch in &channels {
            if ch.components == 0 || ch.data.len() != len.checked_mul(ch.components)? {
                return None;
            }
        }
        Some(WedgeAttributes { channels, len })
    }

    /// Number of wedges.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are no wedges.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The channels.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The channel named `name`, if any.
    pub fn channel(&self, name: &str) -> Option<&Channel> {
        self.channels.iter().find(|c| c.name == name)
    }

    /// The values of the channel named `name` (wedge-major), to edit in place.
    pub fn channel_values_mut(&mut self, name: &str) -> Option<&mut [f64]> {
        self.channels
            .iter_mut()
            .find(|c| c.name == name)
            .map(|c| c.data.as_mut_slice())
    }

    /// Appends a wedge holding the weighted combination of `sources`
    /// (weights are expected to sum to 1) and returns its id.
    ///
    /// [`ChannelKind::UnitVector`] channels are renormalized; if the
    /// combination vanishes, the dominant source's value is copied.
    pub fn push_interpolated(&mut self, sources: &[(WedgeId, f64)]) -> WedgeId {
        let id = WedgeId::from_idx(self.len);
        // The source with the largest weight (first on ties).
        let dominant = sources
            .iter()
            .copied()
            .fold(None::<(WedgeId, f64)>, |best, s| match best {
                Some(b) if b.1 >= s.1 => Some(b),
                _ => Some(s),
            })
            .map(|s| s.0);
        for ch in &mut self.channels {
            let nc = ch.components;
            let mut val = vec![0.0; nc];
            for &(w, t) in sources {
                let src = &ch.data[w.idx() * nc..(w.idx() + 1) * nc];
                for (v, s) in val.iter_mut().zip(src) {
                    *v += t * s;
                }
            }
            if ch.kind == ChannelKind::UnitVector {
                let dom = dominant.map(|w| ch.data[w.idx() * nc..(w.idx() + 1) * nc].to_vec());
                let nv = if nc == 4 { 3 } else { nc };
                let norm = val[..nv].iter().map(|x| x * x).sum::<f64>().sqrt();
                if norm > 1e-300 && norm.is_finite() {
                    for x in &mut val[..nv] {
                        *x /= norm;
                    }
                } else if let Some(d) = &dom {
                    val[..nv].copy_from_slice(&d[..nv]);
                }
                if nc == 4 {
                    let sign = dom.map_or(1.0, |d| if d[3] < 0.0 { -1.0 } else { 1.0 });
                    val[3] = sign;
                }
            }
            ch.data.extend_from_slice(&val);
        }
        self.len += 1;
        id
    }

    /// Whether every channel holds `len() * components` values.
    pub(crate) fn is_consistent(&self) -> bool {
        self.channels
            .iter()
            .all(|c| c.components > 0 && c.data.len() == self.len * c.components)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_linear_and_unit() {
        let uv = Channel::new("uv", 2, ChannelKind::Linear, vec![0.0, 0.0, 1.0, 2.0]);
        let n = Channel::new(
            "n",
            3,
            ChannelKind::UnitVector,
            vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        );
        let tan = Channel::new(
            "t",
            4,
            ChannelKind::UnitVector,
            vec![1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 1.0],
        );
        let mut w = WedgeAttributes::new(2, vec![uv, n, tan]).unwrap();
        let id = w.push_interpolated(&[(WedgeId(0), 0.75), (WedgeId(1), 0.25)]);
        assert_eq!(id, WedgeId(2));
        assert_eq!(w.len(), 3);
        assert_eq!(w.channel("uv").unwrap().get(id), &[0.25, 0.5]);
        let nn = w.channel("n").unwrap().get(id);
        let l = (nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]).sqrt();
        assert!((l - 1.0).abs() < 1e-12);
        assert!((nn[0] / nn[1] - 3.0).abs() < 1e-12);
        let t = w.channel("t").unwrap().get(id);
        assert_eq!(t[3], -1.0);
        assert!(w.is_consistent());
    }

    #[test]
    fn rejects_bad_lengths() {
        let uv = Channel::new("uv", 2, ChannelKind::Linear, vec![0.0; 3]);
        assert!(WedgeAttributes::new(2, vec![uv]).is_none());
        let z = Channel::new("z", 0, ChannelKind::Linear, vec![]);
        assert!(WedgeAttributes::new(2, vec![z]).is_none());
    }
}
