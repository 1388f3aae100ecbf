//! Welding of input vertices by position.
//!
//! Vertices are processed in input order; each one joins the earliest
//! representative within the tolerance (Euclidean distance), or becomes a
//! new representative. Candidates are found with a uniform grid of cell size
//! `2 * tolerance`, so only the 2x2x2 block of cells nearest to a point can
//! hold representatives within the tolerance. The result depends only on the
//! input order (no hash-iteration order, no threads).

use super::hash::FxHasher;
use super::ids::INVALID;
use std::collections::HashMap;
use std::hash::BuildHasherDefault;

/// Result of welding.
pub(super) struct Welded {
    /// Input vertex -> welded id, `INVALID` for vertices not welded
    /// (unreferenced or non-finite).
    pub map: Vec<u32>,
    /// Welded id -> representative input vertex (increasing).
    pub reps: Vec<u32>,
}

type Grid = HashMap<u64, u32, BuildHasherDefault<FxHasher>>;

/// Packs a cell into 64 bits (21 bits per axis, wrapping). Distinct cells
/// may share a key; that only adds candidates, which the exact distance
/// test rejects.
#[inline]
fn pack(c: [i64; 3]) -> u64 {
    const M: u64 = (1 << 21) - 1;
    ((c[0] as u64 & M) << 42) | ((c[1] as u64 & M) << 21) | (c[2] as u64 & M)
}

/// Welds the vertices `i` with `use_vertex[i]` (which must have finite
/// positions) within `tolerance` (absolute; 0 welds exactly equal
/// positions). `origin` is subtracted before quantization.
pub(super) fn weld(
    positions: &[[f64; 3]],
    use_vertex: &[bool],
    tolerance: f64,
    origin: [f64; 3],
) -> Welded {
    let n = positions.len();
    let mut map = vec![INVALID; n];
    let mut reps: Vec<u32> = Vec::new();
    let n_used = use_vertex.iter().filter(|&&u| u).count();
    // Chain of representatives in the same cell.
    let mut next_in_cell: Vec<u32> = Vec::new();

    if tolerance > 0.0 && tolerance.is_finite() {
        let inv = 1.0 / (2.0 * tolerance);
        let mut grid: Grid = HashMap::with_capacity_and_hasher(n_used, Default::default());
        let tol2 = tolerance * tolerance;
        for i in 0..n {
            if !use_vertex[i] {
                continue;
            }
            let p = positions[i];
            let mut cell = [0i64; 3];
            let mut off = [0i64; 3];
            for k in 0..3 {
                let q = (p[k] - origin[k]) * inv;
                let c = q.floor();
                cell[k] = c as i64;
                off[k] = if q - c < 0.5 { -1 } else { 1 };
            }
            let mut best = INVALID;
            for dx in [0, off[0]] {
                for dy in [0, off[1]] {
                    for dz in [0, off[2]] {
                        let key = pack([cell[0] + dx, cell[1] + dy, cell[2] + dz]);
                        let mut r = grid.get(&key).copied().unwrap_or(INVALID);
                        while r != INVALID {
                            // Lower welded ids are earlier representatives.
                            if r < best {
                                let q = positions[reps[r as usize] as usize];
                                let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                                if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= tol2 {
                                    best = r;
                                }
                            }
                            r = next_in_cell[r as usize];
                        }
                    }
                }
            }
            if best == INVALID {
                let id = reps.len() as u32;
                reps.push(i as u32);
                let key = pack(cell);
                let head = grid.entry(key).or_insert(INVALID);
                next_in_cell.push(*head);
                *head = id;
                map[i] = id;
            } else {
                map[i] = best;
            }
        }
    } else {
        // Exact welding on the bit patterns (with -0.0 == 0.0).
        let key_of = |p: [f64; 3]| p.map(|x| if x == 0.0 { 0u64 } else { x.to_bits() });
        let mut exact: HashMap<[u64; 3], u32, BuildHasherDefault<FxHasher>> =
            HashMap::with_capacity_and_hasher(n_used, Default::default());
        for i in 0..n {
            if !use_vertex[i] {
                continue;
            }
            let key = key_of(positions[i]);
            let next_id = reps.len() as u32;
            let id = *exact.entry(key).or_insert(next_id);
            if id == next_id {
                reps.push(i as u32);
            }
            map[i] = id;
        }
    }
    Welded { map, reps }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welds_within_tolerance_first_seen_wins() {
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0009],
            [1.0005, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [0.0, 0.0, -0.0009],
        ];
        let w = weld(&p, &[true; 6], 1e-3, [0.0; 3]);
        assert_eq!(w.map, vec![0, 1, 0, 1, 2, 0]);
        assert_eq!(w.reps, vec![0, 1, 4]);
    }

    #[test]
    fn exact_mode_and_unused() {
        let p = vec![
            [0.0, 0.0, 0.0],
            [-0.0, 0.0, 0.0],
            [1e-9, 0.0, 0.0],
            [0.0; 3],
        ];
        let w = weld(&p, &[true, true, true, false], 0.0, [0.0; 3]);
        assert_eq!(w.map, vec![0, 0, 1, INVALID]);
    }

    #[test]
    fn across_cell_borders() {
        // Points straddling a cell border (cell size 2e-3) must weld.
        let p = vec![[0.0019999, 0.0, 0.0], [0.0020001, 0.0, 0.0]];
        let w = weld(&p, &[true; 2], 1e-3, [0.0; 3]);
        assert_eq!(w.map, vec![0, 0]);
    }
}
