//! The finest level's virtual nodes: unknowns beyond the grid's nodes,
//! each standing at a grid node (its home) but coupled only through the
//! tetrahedra that name it. Their rows, and every block of a grid node's
//! row that couples it to one, are kept apart from the grid's stencil as
//! sparse rows (a column and a block each, columns ascending); the grid's
//! rows keep their stencil. Without virtual nodes all of it is empty.

use super::{Block, CycleBlock, Operator};
use std::collections::BTreeMap;

/// The blocks that involve a virtual node.
#[derive(Default)]
pub(super) struct Irregular {
    /// Per virtual node (numbered from the grid's node count): its home.
    pub home: Vec<u32>,
    /// Per grid node: where its virtual nodes start in `copies` (one more
    /// entry at the end); empty without virtual nodes.
    copies_start: Vec<u32>,
    /// The virtual nodes at each grid node, ascending.
    copies: Vec<u32>,
    /// Per unknown (grid nodes, then virtual ones): where its blocks start
    /// (one more entry at the end); empty without virtual nodes.
    start: Vec<u32>,
    /// Each block's column.
    pub cols: Vec<u32>,
    /// The blocks, in double precision (the CG's products).
    pub blocks: Vec<Block>,
    /// The blocks as the cycle reads them: each averaged with its mirror,
    /// rounded to single precision.
    pub cycle: Vec<CycleBlock>,
}

impl Irregular {
    /// The blocks of `op`'s tetrahedra that involve a virtual node (a
    /// corner numbered `n_grid` or more), summed in the tetrahedra's
    /// order, `op.mass` on the virtual nodes' diagonals, the fixed
    /// unknowns' rows and columns left out.
    pub(super) fn assemble(op: &Operator<'_>, n_grid: usize) -> Irregular {
        let n_total = op.mass.len();
        if n_total <= n_grid {
            return Irregular::default();
        }
        let mut map: BTreeMap<(u32, u32), Block> = BTreeMap::new();
        for v in n_grid..n_total {
            map.insert((v as u32, v as u32), [0.0; 9]);
        }
        let virtual_corner = |n: u32| n as usize >= n_grid;
        for (e, t) in op.tets.iter().enumerate() {
            if !t.iter().any(|&n| virtual_corner(n)) {
                continue;
            }
            let k = (op.stiffness)(e);
            for c in 0..4 {
                for d in 0..4 {
                    if !virtual_corner(t[c]) && !virtual_corner(t[d]) {
                        continue;
                    }
                    let out = map.entry((t[c], t[d])).or_insert([0.0; 9]);
                    for (o, x) in out.iter_mut().zip(&k[c][d]) {
                        *o += x;
                    }
                }
            }
        }
        for (&(u, v), blk) in map.iter_mut() {
            let (u, v) = (u as usize, v as usize);
            if u == v {
                for k in 0..3 {
                    blk[4 * k] += op.mass[u];
                }
            }
            for k in 0..3 {
                for l in 0..3 {
                    if op.fixed[u][k] || op.fixed[v][l] {
                        blk[3 * k + l] = 0.0;
                    }
                }
            }
        }
        let mut start = vec![0u32; n_total + 1];
        for &(u, _) in map.keys() {
            start[u as usize + 1] += 1;
        }
        for i in 0..n_total {
            start[i + 1] += start[i];
        }
        let cycle = map
            .iter()
            .map(|(&(u, v), blk)| {
                let mirror = &map[&(v, u)];
                std::array::from_fn(|j| {
                    let (k, l) = (j / 3, j % 3);
                    (0.5 * (blk[j] + mirror[3 * l + k])) as f32
                })
            })
            .collect();
        let home: Vec<u32> = op.home[n_grid..].to_vec();
        let mut copies_start = vec![0u32; n_grid + 1];
        for &h in &home {
            copies_start[h as usize + 1] += 1;
        }
        for i in 0..n_grid {
            copies_start[i + 1] += copies_start[i];
        }
        let mut fill = copies_start.clone();
        let mut copies = vec![0u32; home.len()];
        for (i, &h) in home.iter().enumerate() {
            copies[fill[h as usize] as usize] = (n_grid + i) as u32;
            fill[h as usize] += 1;
        }
        Irregular {
            home,
            copies_start,
            copies,
            start,
            cols: map.keys().map(|&(_, v)| v).collect(),
            blocks: map.into_values().collect(),
            cycle,
        }
    }

    /// The range of unknown `n`'s blocks in `cols`, `blocks` and `cycle`.
    pub(super) fn row(&self, n: usize) -> std::ops::Range<usize> {
        if self.start.is_empty() {
            return 0..0;
        }
        self.start[n] as usize..self.start[n + 1] as usize
    }

    /// The virtual nodes at grid node `i`.
    pub(super) fn copies(&self, i: usize) -> &[u32] {
        if self.copies_start.is_empty() {
            return &[];
        }
        &self.copies[self.copies_start[i] as usize..self.copies_start[i + 1] as usize]
    }

    /// Unknown `n`'s diagonal block among its blocks (a virtual node's).
    pub(super) fn diagonal(&self, n: usize) -> Option<&Block> {
        self.row(n)
            .find(|&i| self.cols[i] as usize == n)
            .map(|i| &self.blocks[i])
    }
}
