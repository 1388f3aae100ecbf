//! Pieces of a cracked surface: the connected components of its faces,
//! where two faces are connected when they share an edge that is not open
//! (a crack or the input's border). Pieces touching only at a vertex are
//! separate: the simulation mesh has already split such vertices.

use crate::math::v3;
use crate::mesh::{FaceId, SimMesh};

/// The pieces of a mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Islands {
    /// Piece of each face, indexed by face id. Pieces are numbered in the
    /// order of their smallest face id.
    pub of_face: Vec<u32>,
    /// Number of pieces.
    pub count: usize,
}

impl Islands {
    /// The faces of each piece, in increasing face id.
    pub fn faces(&self) -> Vec<Vec<FaceId>> {
        let mut out = vec![Vec::new(); self.count];
        for (f, &k) in self.of_face.iter().enumerate() {
            out[k as usize].push(FaceId(f as u32));
        }
        out
    }
}

/// The pieces the cracks (and the input's own borders) cut `mesh` into.
pub fn face_islands(mesh: &SimMesh) -> Islands {
    let (count, of_face) = mesh.connected_components();
    Islands { of_face, count }
}

/// Area-weighted centroid of `faces` at `positions` (per vertex id); the
/// mean of their corners when the area is zero; the origin for no faces.
pub fn centroid(mesh: &SimMesh, faces: &[FaceId], positions: &[[f64; 3]]) -> [f64; 3] {
    let (mut sum, mut area) = ([0.0; 3], 0.0);
    let (mut corners, mut n) = ([0.0; 3], 0.0);
    for &f in faces {
        let [a, b, c] = mesh.face_vertices(f).map(|v| positions[v.idx()]);
        let w = 0.5 * v3::norm(v3::cross(v3::sub(b, a), v3::sub(c, a)));
        let m: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0);
        if w.is_finite() {
            sum = v3::add(sum, v3::scale(m, w));
            area += w;
        }
        corners = v3::add(corners, m);
        n += 1.0;
    }
    if area > 0.0 {
        sum.map(|s| s / area)
    } else if n > 0.0 {
        corners.map(|s| s / n)
    } else {
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{build, grid_input};

    fn open_row(m: &mut SimMesh, y: f64, x0: usize, x1: usize) {
        for x in x0..x1 {
            let h = m
                .halfedges()
                .find(|&h| {
                    let (p, q) = (m.position(m.origin(h)), m.position(m.dest(h)));
                    p == [x as f64, y, 0.0] && q == [x as f64 + 1.0, y, 0.0] && m.twin(h).is_some()
                })
                .unwrap();
            m.open_edge(h).unwrap();
        }
    }

    #[test]
    fn a_crack_across_the_plate_makes_two_pieces() {
        let (mut m, _) = build(&grid_input(4, 4));
        assert_eq!(face_islands(&m).count, 1);
        // Half way across: still one piece.
        open_row(&mut m, 2.0, 0, 2);
        assert_eq!(face_islands(&m).count, 1);
        open_row(&mut m, 2.0, 2, 4);
        m.validate().unwrap();
        let isl = face_islands(&m);
        assert_eq!(isl.count, 2);
        // Piece 0 holds face 0; every face below y = 2 is in one piece.
        assert_eq!(isl.of_face[0], 0);
        for f in m.faces() {
            let below = m.face_vertices(f).iter().all(|&v| m.position(v)[1] <= 2.0);
            let k = isl.of_face[f.idx()];
            assert_eq!(k, isl.of_face[0] ^ u32::from(!below));
        }
        let faces = isl.faces();
        assert_eq!(faces[0].len() + faces[1].len(), m.n_faces());
        let c0 = centroid(&m, &faces[0], m.positions());
        let c1 = centroid(&m, &faces[1], m.positions());
        assert!((c0[1] - 1.0).abs() < 1e-12 && (c1[1] - 3.0).abs() < 1e-12);
        assert!((c0[0] - 2.0).abs() < 1e-12);
    }
}
