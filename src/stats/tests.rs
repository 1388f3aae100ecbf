//! Pattern statistics on patterns whose answers are known.

use super::graph::split_within;
use super::*;

/// An n x n grid of unit squares (two triangles each) and a vertex id.
#[allow(clippy::type_complexity)]
fn grid(n: u32) -> (Vec<[f64; 3]>, Vec<[u32; 3]>, impl Fn(u32, u32) -> u32) {
    let id = move |i: u32, j: u32| j * (n + 1) + i;
    let mut p = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            p.push([f64::from(i), f64::from(j), 0.0]);
        }
    }
    let mut t = Vec::new();
    for j in 0..n {
        for i in 0..n {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    (p, t, id)
}

/// The statistics of `cracks` on the surface `positions`, `triangles`.
fn stats_of(
    positions: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    cracks: Vec<[u32; 2]>,
) -> PatternStats {
    pattern_stats(
        &PatternInput {
            positions,
            triangles,
            cracks,
            ..Default::default()
        },
        None,
    )
}

fn vertical(id: &impl Fn(u32, u32) -> u32, x: u32, j0: u32, j1: u32) -> Vec<[u32; 2]> {
    (j0..j1)
        .map(|j| {
            let (a, b) = (id(x, j), id(x, j + 1));
            [a.min(b), a.max(b)]
        })
        .collect()
}

fn horizontal(id: &impl Fn(u32, u32) -> u32, y: u32, i0: u32, i1: u32) -> Vec<[u32; 2]> {
    (i0..i1)
        .map(|i| {
            let (a, b) = (id(i, y), id(i + 1, y));
            [a.min(b), a.max(b)]
        })
        .collect()
}

#[test]
fn a_cross_makes_four_cells_and_one_junction_of_four() {
    let (positions, triangles, id) = grid(4);
    let mut cracks = vertical(&id, 2, 0, 4);
    cracks.extend(horizontal(&id, 2, 0, 4));
    let s = stats_of(positions, triangles, cracks);
    assert_eq!(s.cells, 4);
    assert_eq!(s.cell_area_quantiles, [4.0; 5]);
    assert!((s.crack_length - 8.0).abs() < 1e-12);
    assert!((s.crack_length_per_area - 0.5).abs() < 1e-12);
    assert!((s.spacing - 4.0).abs() < 1e-12);
    assert!((s.mean_cell_diameter - (16.0 / std::f64::consts::PI).sqrt()).abs() < 1e-12);
    assert_eq!(s.degree[3], 1, "one junction of four: {:?}", s.degree);
    assert_eq!(s.max_degree, 4);
    assert_eq!(s.dangling_tips, 0, "the ends are on the border");
    assert!(
        (s.orientation[0] - 0.5).abs() < 1e-12 && (s.orientation[3] - 0.5).abs() < 1e-12,
        "{:?}",
        s.orientation
    );
}

#[test]
fn a_crack_ending_on_another_is_a_t_junction() {
    let (positions, triangles, id) = grid(4);
    let mut cracks = vertical(&id, 2, 0, 4);
    cracks.extend(horizontal(&id, 2, 0, 2));
    let s = stats_of(positions, triangles, cracks);
    assert_eq!(s.cells, 3);
    assert_eq!((s.t_junctions, s.y_junctions), (1, 0));
    assert_eq!(
        s.junction_angles[6], 2,
        "two right angles: {:?}",
        s.junction_angles
    );
    assert_eq!(s.junction_angles[11], 1, "one straight angle");
    assert_eq!(s.dangling_tips, 0);
}

#[test]
fn an_open_crack_has_two_dangling_tips_and_cuts_nothing() {
    let (positions, triangles, id) = grid(4);
    let cracks = horizontal(&id, 2, 1, 3);
    let s = stats_of(positions, triangles, cracks);
    assert_eq!(s.cells, 1);
    assert_eq!(s.dangling_tips, 2);
}

#[test]
fn close_parallel_cracks_are_paired_far_ones_are_not() {
    let (positions, triangles, id) = grid(8);
    let close: Vec<[u32; 2]> = [vertical(&id, 3, 0, 8), vertical(&id, 4, 0, 8)].concat();
    let s = stats_of(positions.clone(), triangles.clone(), close);
    // Cells of 24, 8 and 32 all touch the border: the median's (24)
    // diameter sqrt(96 / pi) = 5.53, paired below 1.38: the cracks are 1
    // apart.
    let d = (96.0 / std::f64::consts::PI).sqrt();
    assert!(
        (s.paired_distance - d / 4.0).abs() < 1e-12,
        "{}",
        s.paired_distance
    );
    assert!((s.paired - 1.0).abs() < 1e-12, "{}", s.paired);
    let far: Vec<[u32; 2]> = [vertical(&id, 1, 0, 8), vertical(&id, 6, 0, 8)].concat();
    let s = stats_of(positions, triangles, far);
    assert_eq!(s.paired, 0.0);
    assert_eq!(s.cells, 3);
}

#[test]
fn cracks_along_the_input_edges_are_counted() {
    let (positions, triangles, id) = grid(4);
    let cracks = vertical(&id, 2, 0, 4);
    let same = ReferenceEdges::new(&positions, &triangles);
    let shifted: Vec<[f64; 3]> = positions.iter().map(|p| [p[0] + 0.5, p[1], p[2]]).collect();
    let other = ReferenceEdges::new(&shifted, &triangles);
    let input = PatternInput {
        positions,
        triangles,
        cracks,
        ..Default::default()
    };
    assert_eq!(
        pattern_stats(&input, Some(&same)).along_reference_edges,
        Some(1.0)
    );
    assert_eq!(
        pattern_stats(&input, Some(&other)).along_reference_edges,
        Some(0.0)
    );
}

#[test]
fn a_crack_ending_inside_a_whole_segment_of_another_is_joined_to_it() {
    let (positions, triangles, id) = grid(4);
    // The earlier crack's segment over (2,1)-(2,3) was written whole; the
    // later one ends at (2,2), inside it.
    let mut cracks = vec![
        [id(2, 0), id(2, 1)],
        [id(2, 1), id(2, 3)],
        [id(2, 3), id(2, 4)],
    ];
    cracks.extend(horizontal(&id, 2, 0, 2));
    let unsplit = stats_of(positions.clone(), triangles.clone(), cracks.clone());
    assert_eq!(unsplit.dangling_tips, 1, "the check can fail: {unsplit:?}");
    let mut cracks = split_within(&positions, cracks, 1e-6);
    cracks.sort_unstable();
    assert!(cracks.contains(&[id(2, 1), id(2, 2)]) && cracks.contains(&[id(2, 2), id(2, 3)]));
    assert_eq!(cracks.len(), 6);
    let s = stats_of(positions, triangles, cracks);
    assert_eq!(s.cells, 3);
    assert_eq!((s.t_junctions, s.dangling_tips), (1, 0));
}

/// Lines lying across the faces of an uncut surface (a kept output) are cut
/// into it: a line across a 4 x 4 grid and one ending on it (inside its
/// segment) make three cells and a T-junction.
#[test]
fn lines_across_the_faces_of_a_kept_surface_enclose_cells() {
    let (positions, triangles, _) = grid(4);
    let mut m = MeshParts::default();
    for t in &triangles {
        m.surface
            .push(t.map(|v| m.welder.id(positions[v as usize])));
    }
    m.lines = vec![
        [[2.3, 0.0, 0.0], [2.3, 4.0, 0.0]],
        [[0.0, 1.6, 0.0], [2.3, 1.6, 0.0]],
    ];
    m.rest = m.lines.clone();
    let p = m.pattern("grid");
    assert!(p.notes.is_empty(), "{:?}", p.notes);
    let s = pattern_stats(&p, None);
    assert_eq!(s.cells, 3, "{s:?}");
    // Areas 2.3 x 1.6, 2.3 x 2.4 and 1.7 x 4.
    let want = [3.68, 5.52, 5.52, 6.8, 6.8];
    for (got, want) in s.cell_area_quantiles.iter().zip(want) {
        assert!((got - want).abs() < 1e-9, "{:?}", s.cell_area_quantiles);
    }
    assert_eq!((s.t_junctions, s.dangling_tips), (1, 0), "{s:?}");
    assert!((s.crack_length - 6.3).abs() < 1e-9);
}

/// A pattern covering a small part of the surface is paired at its own
/// cells' size: on a 16 x 16 grid, a 2 x 2 block of unit cells at one
/// corner's middle pairs nothing, where a quarter of 2A/L (6.4) would pair
/// every crack.
#[test]
fn a_partial_pattern_is_paired_at_its_own_cells_size() {
    let (positions, triangles, id) = grid(16);
    let mut cracks = Vec::new();
    for k in 7..=9 {
        cracks.extend(vertical(&id, k, 7, 9));
        cracks.extend(horizontal(&id, k, 7, 9));
    }
    let s = stats_of(positions, triangles, cracks);
    assert_eq!(s.cells, 5, "{s:?}");
    assert!(s.spacing / 4.0 > 6.0, "{}", s.spacing);
    let d = (4.0 / std::f64::consts::PI).sqrt();
    assert!(
        (s.paired_distance - d / 4.0).abs() < 1e-12,
        "{}",
        s.paired_distance
    );
    assert_eq!(s.paired, 0.0);
}

/// Bricks: rows of cracks across a 24 x 24 grid and staggered cracks
/// between them. A brick has four corners (its T-junctions' right angles)
/// whatever T-junctions meet its long sides from the next rows.
#[test]
fn bricks_have_four_sides_and_the_outer_outline_is_no_cell() {
    let (positions, triangles, id) = grid(24);
    let mut cracks = Vec::new();
    for y in [4, 8, 12, 16, 20] {
        cracks.extend(horizontal(&id, y, 0, 24));
    }
    for row in 0..6 {
        let shift = 2 * (row % 2);
        for x in (4..24).step_by(4) {
            cracks.extend(vertical(&id, x - shift, 4 * row, 4 * row + 4));
        }
    }
    let s = stats_of(positions.clone(), triangles.clone(), cracks);
    // Off the border: rows 1 to 4, four bricks a row not on the sides.
    assert_eq!(s.sided_cells, 4 * 4, "{s:?}");
    assert!((s.mean_cell_sides - 4.0).abs() < 1e-12, "{s:?}");
    // A ring off the border with a cross inside it: four cells of three
    // corners (the cross's middle and the two T-junctions on the ring; the
    // ring's own corners are no junctions); the outside of the ring is no
    // cell.
    let mut cracks = Vec::new();
    let (a, b) = (4, 20);
    cracks.extend(horizontal(&id, a, a, b));
    cracks.extend(horizontal(&id, b, a, b));
    cracks.extend(vertical(&id, a, a, b));
    cracks.extend(vertical(&id, b, a, b));
    cracks.extend(horizontal(&id, 12, 4, 20));
    cracks.extend(vertical(&id, 12, 4, 20));
    let s = stats_of(positions, triangles, cracks);
    assert_eq!(s.sided_cells, 4, "{s:?}");
    assert!((s.mean_cell_sides - 3.0).abs() < 1e-12, "{s:?}");
}
