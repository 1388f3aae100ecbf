//! The remeshed surface as a mesh input: faces in a spatial order, every
//! corner's attributes evaluated on the input in its face's chart.

use super::{Input, Projection, Work};
use crate::mesh::attributes::{Channel, ChannelKind};
use crate::mesh::build::MeshInput;
use crate::mesh::halfedge::SimMesh;
use crate::mesh::ids::FaceId;
use rayon::prelude::*;

impl Work {
    /// The live faces along a Morton curve through their centroids (ties
    /// by index): the output's faces, and so its vertices (numbered as
    /// they first appear), are stored near their neighbours, which keeps
    /// the simulation's passes over elements and nodes in cache. Splits
    /// append their faces at the end; without this order a remeshed
    /// surface is scattered through memory.
    fn spatial_order(&self) -> Vec<usize> {
        let live: Vec<usize> = (0..self.faces.len()).filter(|&f| self.alive[f]).collect();
        let centroids: Vec<[f64; 3]> = live
            .iter()
            .map(|&f| {
                let t = self.faces[f];
                std::array::from_fn(|k| {
                    (self.pos[t[0] as usize][k]
                        + self.pos[t[1] as usize][k]
                        + self.pos[t[2] as usize][k])
                        / 3.0
                })
            })
            .collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for c in &centroids {
            for k in 0..3 {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
        }
        let span = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        if !(span > 0.0 && span.is_finite()) {
            return live;
        }
        // 21 bits per axis, interleaved.
        let spread = |x: u64| -> u64 {
            let mut x = x & 0x1f_ffff;
            x = (x | x << 32) & 0x1f_0000_0000_ffff;
            x = (x | x << 16) & 0x1f_0000_ff00_00ff;
            x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
            x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
            (x | x << 2) & 0x1249_2492_4924_9249
        };
        let scale = ((1u64 << 21) - 1) as f64 / span;
        let mut keyed: Vec<(u64, usize)> = live
            .iter()
            .zip(&centroids)
            .map(|(&f, c)| {
                let q = |k: usize| ((c[k] - lo[k]) * scale) as u64;
                (spread(q(0)) | spread(q(1)) << 1 | spread(q(2)) << 2, f)
            })
            .collect();
        keyed.sort_unstable();
        keyed.into_iter().map(|(_, f)| f).collect()
    }

    /// The result as a mesh input: every output vertex once per distinct
    /// set of corner values (evaluated on the input in each face's chart),
    /// faces in [`spatial_order`](Self::spatial_order).
    pub(super) fn to_input(&self, mesh: &SimMesh, input: &Input) -> MeshInput {
        let wedges = mesh.wedges();
        let channels = wedges.channels();
        let width: usize = channels.iter().map(|c| c.components).sum();
        let mut positions = Vec::new();
        let mut values: Vec<f64> = Vec::new();
        let mut triangles = Vec::new();
        let mut groups = Vec::new();
        // The output vertices made from each work vertex, as a list
        // through `next` (most have one; a seam's have one per side).
        let mut first = vec![u32::MAX; self.pos.len()];
        let mut next: Vec<u32> = Vec::new();
        let mut vals = vec![0.0; width];
        let order = self.spatial_order();
        // Each corner's input face and coordinates, found in parallel
        // (each on its own; the results are used in order below).
        let found: Vec<[Option<Projection>; 3]> = order
            .par_iter()
            .map(|&f| {
                let chart = self.chart[f];
                self.faces[f].map(|v| input.closest_face(self.pos[v as usize], Some(chart)))
            })
            .collect();
        for (&f, found) in order.iter().zip(&found) {
            let t = &self.faces[f];
            let mut tri = [0u32; 3];
            let mut group = 0;
            for k in 0..3 {
                let v = t[k];
                let p = self.pos[v as usize];
                vals.fill(0.0);
                if let Some((inf, bary, _)) = found[k] {
                    group = mesh.face_group(FaceId(inf));
                    if width > 0 {
                        let ws = mesh.face_wedges(FaceId(inf));
                        let mut off = 0;
                        for ch in channels {
                            for j in 0..ch.components {
                                vals[off + j] = (0..3)
                                    .map(|i| bary[i] * ch.data[ws[i].idx() * ch.components + j])
                                    .sum();
                            }
                            if ch.kind == ChannelKind::UnitVector {
                                // A tangent's fourth value is its handedness
                                // sign: the vector is its first three.
                                let nv = if ch.components == 4 { 3 } else { ch.components };
                                let v = &mut vals[off..off + nv];
                                let l = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                                if l > 0.0 {
                                    v.iter_mut().for_each(|x| *x /= l);
                                }
                                if ch.components == 4 {
                                    let w = &mut vals[off + 3];
                                    *w = if *w < 0.0 { -1.0 } else { 1.0 };
                                }
                            }
                            off += ch.components;
                        }
                    }
                }
                // The same values bit for bit: the same output vertex.
                let same = |id: u32| {
                    let at = id as usize * width;
                    values[at..at + width]
                        .iter()
                        .zip(&vals)
                        .all(|(a, b)| a.to_bits() == b.to_bits())
                };
                let mut id = first[v as usize];
                while id != u32::MAX && !same(id) {
                    id = next[id as usize];
                }
                if id == u32::MAX {
                    id = positions.len() as u32;
                    positions.push(p);
                    values.extend_from_slice(&vals);
                    next.push(first[v as usize]);
                    first[v as usize] = id;
                }
                tri[k] = id;
            }
            triangles.push(tri);
            groups.push(group);
        }
        let n = positions.len();
        let mut off = 0;
        let wedge_channels: Vec<Channel> = channels
            .iter()
            .map(|ch| {
                let mut vals = Vec::with_capacity(n * ch.components);
                for i in 0..n {
                    vals.extend_from_slice(
                        &values[i * width + off..i * width + off + ch.components],
                    );
                }
                off += ch.components;
                Channel::new(&ch.name, ch.components, ch.kind, vals)
            })
            .collect();
        MeshInput {
            positions,
            triangles,
            face_groups: groups,
            wedge_channels,
        }
    }
}
