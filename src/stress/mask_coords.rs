//! Where a stress term's mask samples on a mesh: the UV set it names, or,
//! on a mesh with no UV set at all, a projection along the three axes.

use super::frame::{face_frame, FieldError, TermFault};
use super::texture::Mask;
use crate::mesh::{FaceId, SimMesh};

/// Where a mask's coordinates come from on a mesh.
#[derive(Clone, Copy, Debug)]
pub(super) enum MaskCoords<'a> {
    /// The UV set it names.
    Uv(&'a crate::mesh::Channel),
    /// A mesh with no UV set at all: the mask projected along the three
    /// axes (triplanar), one image across the bounding box's largest
    /// extent from its low corner, blended by the face normal's components
    /// to the fourth power, so a surface facing an axis takes that
    /// projection and the blend is smooth between.
    Box { lo: [f64; 3], size: f64 },
}

impl<'a> MaskCoords<'a> {
    /// The coordinates `mask` samples on `mesh`: its `TEXCOORD_n`; with no
    /// `TEXCOORD_*` set at all, the projection over the box.
    ///
    /// # Errors
    /// The mesh has UV sets but not the one the mask names.
    pub(super) fn of(mesh: &'a SimMesh, mask: &Mask) -> Result<MaskCoords<'a>, FieldError> {
        let name = format!("TEXCOORD_{}", mask.tex_coord);
        let wedges = mesh.wedges();
        if let Some(ch) = wedges.channel(&name).filter(|ch| ch.components >= 2) {
            return Ok(MaskCoords::Uv(ch));
        }
        if wedges
            .channels()
            .iter()
            .any(|c| c.name.starts_with("TEXCOORD_"))
        {
            return Err(TermFault::NoUvSet {
                tex_coord: mask.tex_coord,
            }
            .into());
        }
        let (lo, hi) = mesh.bounding_box();
        let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        Ok(MaskCoords::Box {
            lo,
            size: if size > 0.0 { size } else { 1.0 },
        })
    }

    /// `mask`'s weight on face `f`.
    pub(super) fn weight(&self, mesh: &SimMesh, f: FaceId, mask: &Mask) -> f64 {
        match *self {
            MaskCoords::Uv(ch) => mask.weight(face_uv(mesh, f, ch)),
            MaskCoords::Box { lo, size } => {
                let Some((c, n)) = face_frame(mesh, f) else {
                    return mask.weight([0.0; 2]);
                };
                let mut sum = (0.0, 0.0);
                for (axis, [a, b]) in [(0, [1, 2]), (1, [0, 2]), (2, [0, 1])] {
                    let w = n[axis].powi(4);
                    if w > 0.0 {
                        let uv = [(c[a] - lo[a]) / size, (c[b] - lo[b]) / size];
                        sum.0 += w * mask.weight(uv);
                        sum.1 += w;
                    }
                }
                if sum.1 > 0.0 {
                    sum.0 / sum.1
                } else {
                    1.0
                }
            }
        }
    }

    /// Whether the mask is projected (the mesh has no UV set).
    pub(super) fn projected(&self) -> bool {
        matches!(self, MaskCoords::Box { .. })
    }
}

/// The UV of face `f`'s centroid in channel `ch` (2 components).
fn face_uv(mesh: &SimMesh, f: FaceId, ch: &crate::mesh::Channel) -> [f64; 2] {
    let mut uv = [0.0; 2];
    for w in mesh.face_wedges(f) {
        let x = ch.get(w);
        uv[0] += x[0] / 3.0;
        uv[1] += x[1] / 3.0;
    }
    uv
}
