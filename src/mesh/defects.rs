//! What [`SimMesh::build`](super::SimMesh::build) found and repaired in its
//! input.

use serde::Serialize;

/// Statistics and defects of a mesh input, as built into a
/// `SimMesh`.
///
/// Non-manifold, orientation and duplicate counts describe the input (after
/// welding, before repair); boundary, loop and component counts describe the
/// final manifold mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DefectReport {
    /// Number of input vertices.
    pub input_vertices: usize,
    /// Number of input triangles.
    pub input_triangles: usize,
    /// Number of distinct positions after welding (referenced, finite
    /// vertices only).
    pub welded_vertices: usize,
    /// Number of vertices of the final mesh (after dropping vertices of
    /// dropped triangles and duplicating non-manifold vertices).
    pub vertices: usize,
    /// Number of faces of the final mesh.
    pub faces: usize,
    /// Number of boundary edges of the final mesh (including edges made
    /// boundary by the repair).
    pub boundary_edges: usize,
    /// Number of closed boundary loops of the final mesh.
    pub boundary_loops: usize,
    /// Edges of the welded input shared by more than two triangles.
    pub non_manifold_edges: usize,
    /// Welded input vertices whose incident triangles (connected through
    /// edges incident to the vertex) form more than one fan ("bow-ties").
    pub non_manifold_vertices: usize,
    /// Edges shared by exactly two triangles that traverse it in the same
    /// direction (inconsistent orientation); they were made boundary.
    pub inconsistent_orientation_edges: usize,
    /// Vertices added by the manifold repair (copies of split vertices).
    pub duplicated_vertices: usize,
    /// Triangles dropped: corners welded together, area below
    /// `1e-12 * diagonal^2`, or non-finite corner positions.
    pub degenerate_triangles_dropped: usize,
    /// Kept triangles with the same three welded vertices as an earlier
    /// kept triangle (in either orientation); they are kept.
    pub duplicate_triangles: usize,
    /// Connected components (through shared edges) of the final mesh.
    pub components: usize,
    /// Input vertices not referenced by any input triangle.
    pub unreferenced_vertices: usize,
}

impl DefectReport {
    /// Whether the input needed no repair: no non-manifold edges or
    /// vertices, no inconsistent orientation, no dropped or duplicate
    /// triangles. Open boundaries, several components and unreferenced
    /// vertices are not defects.
    pub fn is_clean(&self) -> bool {
        self.non_manifold_edges == 0
            && self.non_manifold_vertices == 0
            && self.inconsistent_orientation_edges == 0
            && self.degenerate_triangles_dropped == 0
            && self.duplicate_triangles == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_clean_and_serializes() {
        let r = DefectReport::default();
        assert!(r.is_clean());
        let r2 = DefectReport {
            duplicate_triangles: 1,
            ..Default::default()
        };
        assert!(!r2.is_clean());
        let json = serde_json::to_string(&r2).unwrap();
        assert!(json.contains("\"duplicate_triangles\":1"));
    }
}
