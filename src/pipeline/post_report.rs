//! What the post stages did to one simulated mesh: `--report`'s `post`
//! of each mesh, one typed field per stage that ran (a stage that did not
//! run is left out of the JSON).

use crate::sim::ductile::DuctileReport;
use serde::Serialize;

/// The post stages' report of one mesh.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PostReport {
    /// `post.bake`: the crack maps baked into the mesh's materials (or,
    /// torn, into each piece's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bake: Option<BakeReport>,
    /// The cracks cut into the input's own triangles.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cut_input: Option<CutReport>,
    /// `post.grooves`: grooves cut along the cracks.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub groove: Option<GapReport>,
    /// `post.split_islands`: the pieces the mesh came apart into.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub islands: Option<IslandsReport>,
    /// `simulation.margin`: the strip the surface grew past its border.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub margin: Option<MarginReport>,
    /// `post.smooth_paths`: cracks along the simulation surface's edges
    /// smoothed off its zig-zag.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paths: Option<PathsReport>,
    /// Texture corners resampled where the gaps moved the surface.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resampled_corners: Option<usize>,
    /// `post.walls`: the side walls of the opened cracks.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub walls: Option<WallsReport>,
    /// `post.width` or `post.curl`: the cracks opened into gaps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub width: Option<GapReport>,
    /// The ductile model's tearing (its keys at the top level).
    #[serde(flatten)]
    pub tear: Option<TearReport>,
}

/// What `simulation.margin` grew.
#[derive(Clone, Debug, Serialize)]
pub struct MarginReport {
    /// Triangles of the strip past the border, as grown.
    pub strip_triangles: usize,
    /// The input's triangles, as grown on.
    pub input_triangles: usize,
}

/// The crack paths smoothed off the simulation surface's zig-zag.
#[derive(Clone, Debug, Serialize)]
pub struct PathsReport {
    /// Smoothing passes.
    pub passes: usize,
    /// Crack points (each once, however many copies) that may move: on a
    /// crack between two others, off the border.
    pub free_points: usize,
    /// Moves of a point taken short or left out to keep its faces.
    pub held: usize,
    /// Segments left out as spurs.
    pub spurs: usize,
    /// Nodes whose springs all broke (or all but one), their ring of lines
    /// drawn in to them.
    pub rings: usize,
    /// Open ends of lines joined to a crack nearby.
    pub joined: usize,
    /// Loops round a single triangle opened or left out.
    pub loops: usize,
    /// Their sides left out.
    pub loop_sides: usize,
    /// Crack length before and after (scene units).
    pub length: [f64; 2],
}

/// The cracks cut into the input's triangles, or why they stayed on the
/// simulation surface.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum CutReport {
    /// Cut.
    Cut {
        /// The input's triangles before and after the cut.
        triangles: [usize; 2],
        /// Triangles of the simulation surface.
        simulated_triangles: usize,
        /// Crack segments cut.
        cut_edges: usize,
        /// Crack ends and edge crossings within rounding of an input
        /// vertex or edge end, taken to be there.
        snapped: usize,
        /// Segments a straight walk could not follow (across a crease or
        /// a seam), cut along the input's edges instead.
        cut_along_edges: usize,
        /// Segments whose ends lie on two touching shells, cut on each up
        /// to its border.
        cut_across_shells: usize,
        /// Segments left out: their ends are not joined by the input
        /// nearby.
        skipped_segments: usize,
        /// Edges leaving the cracks split near them.
        refined_edges: usize,
        /// Edges next to the cut flipped so no needle lies along a crack.
        settled_edges: usize,
    },
    /// Not cut: the cracks stay on the simulation surface.
    FellBack {
        /// Why.
        fell_back: String,
    },
}

/// The cracks opened into gaps (or cut as grooves).
#[derive(Clone, Debug, Serialize)]
pub struct GapReport {
    /// Widest gap (scene units).
    pub max_gap: f64,
    /// Mean gap.
    pub mean_gap: f64,
    /// Nodes whose move was shortened by the width limit.
    pub width_limited_nodes: usize,
    /// Triangles the full moves would have flipped or collapsed.
    pub inverted_triangles_prevented: usize,
    /// Nodes whose move was shortened so no triangle flips.
    pub shortened_nodes: usize,
    /// Crack copies moved onto a cell's rounded corner (gap band only).
    pub rounded_corner_nodes: usize,
    /// On the input's own vertices (cut input): moves shortened.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shortened_nodes_on_input: Option<usize>,
}

/// The side walls.
#[derive(Clone, Debug, Serialize)]
pub struct WallsReport {
    /// Depth (scene units).
    pub depth: f64,
    /// Wall triangle pairs still crossing.
    pub crossing_pairs: usize,
    /// Crossing pairs undone.
    pub crossing_pairs_prevented: usize,
    /// Nodes whose moves were shortened to undo them.
    pub shortened_nodes: usize,
    /// Wall triangles.
    pub triangles: usize,
    /// Wall triangles of (nearly) zero area left out.
    pub skipped_degenerate: usize,
    /// Crack sides without walls because the crack stayed shut there.
    pub skipped_closed_sides: usize,
}

/// The pieces of `post.split_islands`.
#[derive(Clone, Debug, Serialize)]
pub struct IslandsReport {
    /// Pieces.
    pub pieces: usize,
    /// Whether each piece's vertices were moved to its centroid.
    pub recentred: bool,
    /// Triangles of the largest piece.
    pub largest_piece_triangles: usize,
}

/// The crack maps baked into a mesh (or into each torn piece).
#[derive(Clone, Debug, Serialize)]
pub struct BakeReport {
    /// Seconds.
    pub seconds: f64,
    /// One per material of the mesh.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub materials: Option<Vec<MaterialBake>>,
    /// Torn: one per piece that has a tear to draw.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pieces: Option<Vec<MeshBake>>,
}

/// The crack maps baked into one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct MeshBake {
    /// One per material.
    pub materials: Vec<MaterialBake>,
}

/// The crack maps baked into one material's triangles.
#[derive(Clone, Debug, Serialize)]
pub struct MaterialBake {
    /// The material baked over (its name, or `material`).
    pub material: String,
    /// The new material's name.
    pub variant: String,
    /// The maps' side, texels.
    pub size: u32,
    /// The UV set drawn in.
    pub texcoord: u32,
    /// The automatic atlas, when one was made.
    pub atlas: Option<AtlasReport>,
    /// A crack's width in the maps (scene units).
    pub crack_width: f64,
    /// Texels inside the UV charts.
    pub covered_texels: usize,
    /// Texels filled around them.
    pub dilated_texels: usize,
    /// Texels a crack darkens.
    pub crack_texels: usize,
    /// Bytes of the encoded maps.
    pub png_bytes: usize,
    /// Vertices split for the tangents the normal map is drawn with.
    pub tangent_split_vertices: usize,
}

/// An automatic atlas made for the bake.
#[derive(Clone, Debug, Serialize)]
pub struct AtlasReport {
    /// Why (no UVs, overlapping UVs...).
    pub reason: String,
    /// How the charts were laid out.
    pub layout: String,
    /// Charts.
    pub charts: usize,
    /// Texels per scene unit.
    pub texels_per_unit: f64,
    /// The UV set it went in.
    pub texcoord: u32,
    /// Vertices split along the charts' seams.
    pub split_vertices: usize,
    /// The share of the base colour texture's resolution the baked map keeps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base_texture_resolution_kept: Option<f64>,
}

/// The ductile model's tearing of one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct TearReport {
    /// The simulation.
    pub ductile: DuctileReport,
    /// Seconds of the simulation.
    pub seconds: f64,
    /// Triangles of the torn surface.
    pub triangles: usize,
    /// Its torn triangles.
    pub torn_triangles: usize,
    /// Their area (scene units squared).
    pub torn_area: f64,
    /// Crack-line segments along the tears.
    pub tear_line_segments: usize,
    /// Pieces written.
    pub pieces: usize,
    /// Which surface the pieces show.
    pub surface: SurfaceReport,
}

/// The surface of torn pieces: the input's own triangles embedded in the
/// grid, or the grid's.
#[derive(Clone, Debug, Serialize)]
pub struct SurfaceReport {
    /// `input` or `grid`.
    pub surface: String,
    /// Input triangles no piece shows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dropped_faces: Option<usize>,
    /// Border segments left out of the cut.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub skipped_border_segments: Option<usize>,
    /// The input's triangles and the pieces that show them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_triangles: Option<[usize; 2]>,
}

impl SurfaceReport {
    /// The grid's own surface.
    pub fn grid() -> SurfaceReport {
        SurfaceReport {
            surface: "grid".into(),
            dropped_faces: None,
            skipped_border_segments: None,
            input_triangles: None,
        }
    }
}
