//! Virtual nodes (Molino, Bridson and Fedkiw 2004): where the tear has
//! separated the material around a grid node, the node is duplicated, one
//! copy per side, each copy carrying the tetrahedra of its side.
//!
//! The level set is linear in each tetrahedron, so a tetrahedron's
//! material (where `phi < 0`) is convex: one piece, never to be split. What
//! the tear separates are the tetrahedra around a node outside the
//! material: two of them are tied through material only across a face
//! they share whose other two corners are not both outside (the material
//! of a tetrahedron reaches its face only through the face's corners
//! inside). A node whose tetrahedra with material fall into several groups
//! so tied keeps the first group (by the tetrahedra's order) and gives each
//! other group a copy of its own: same rest place, position, velocity,
//! level set and grip, its mass from its own tetrahedra. Pieces that have
//! come apart then share no node, and no force passes between them through
//! a sliver in a gap narrower than a tetrahedron. The level set only rises,
//! so groups never join again: a copy is for good.
//!
//! Nodes are never merged, and a copy may split again later.

use super::Ductile;

impl Ductile {
    /// The grid node node `n` stands at (itself, or the node a virtual
    /// copy was made from).
    pub fn home(&self, n: usize) -> usize {
        self.home[n] as usize
    }

    /// How many nodes are copies (beyond the grid's).
    pub fn virtual_nodes(&self) -> usize {
        self.x.len() - self.grid.n_nodes()
    }

    /// Whether tetrahedron `e` holds any material.
    fn has_material(&self, e: usize) -> bool {
        self.tets[e].iter().any(|&n| self.phi[n as usize] < 0.0)
    }

    /// The groups of node `s`'s tetrahedra tied through material (see the
    /// module): per entry of `node_tets[s]`, its group, numbered in order
    /// of first entry; tetrahedra without material join the first group.
    /// Returns the groups and how many there are.
    fn material_groups(&self, s: usize) -> (Vec<u32>, u32) {
        let ts = &self.node_tets[s];
        let material: Vec<bool> = ts
            .iter()
            .map(|&(e, _)| self.has_material(e as usize))
            .collect();
        let mut parent: Vec<usize> = (0..ts.len()).collect();
        fn find(p: &mut [usize], mut x: usize) -> usize {
            while p[x] != x {
                p[x] = p[p[x]];
                x = p[x];
            }
            x
        }
        for i in 0..ts.len() {
            if !material[i] {
                continue;
            }
            let a = self.tets[ts[i].0 as usize];
            for j in i + 1..ts.len() {
                if !material[j] {
                    continue;
                }
                let b = self.tets[ts[j].0 as usize];
                // The corners other than `s` the two share: a shared face
                // has two.
                let mut shared = [0u32; 3];
                let mut count = 0;
                for &n in &a {
                    if n as usize != s && b.contains(&n) {
                        shared[count.min(2)] = n;
                        count += 1;
                    }
                }
                if count != 2 || shared[..2].iter().all(|&n| self.phi[n as usize] >= 0.0) {
                    continue;
                }
                let (ra, rb) = (find(&mut parent, i), find(&mut parent, j));
                if ra != rb {
                    parent[ra.max(rb)] = ra.min(rb);
                }
            }
        }
        // Tetrahedra without material go with the first one with material.
        let first = material.iter().position(|&m| m).unwrap_or(0);
        let mut number = vec![u32::MAX; ts.len()];
        let mut groups = vec![0u32; ts.len()];
        let mut count = 0u32;
        for i in 0..ts.len() {
            let r = if material[i] {
                find(&mut parent, i)
            } else {
                find(&mut parent, first)
            };
            if number[r] == u32::MAX {
                number[r] = count;
                count += 1;
            }
            groups[i] = number[r];
        }
        (groups, count)
    }

    /// Split every node in `candidates` (ascending) that lies outside the
    /// material and whose tetrahedra fall into several groups: each group
    /// after the first gets a copy of the node. Returns how many copies
    /// were made.
    pub(super) fn split_nodes(&mut self, candidates: &[usize]) -> usize {
        let mut made = 0;
        for &s in candidates {
            if self.phi[s] < 0.0 || self.node_tets[s].len() < 2 {
                continue;
            }
            let (groups, count) = self.material_groups(s);
            if count < 2 {
                continue;
            }
            let entries = std::mem::take(&mut self.node_tets[s]);
            let mut split: Vec<Vec<(u32, u8)>> = vec![Vec::new(); count as usize];
            for (&entry, &g) in entries.iter().zip(&groups) {
                split[g as usize].push(entry);
            }
            let mut split = split.into_iter();
            self.node_tets[s] = split.next().unwrap_or_default();
            for list in split {
                let copy = self.x.len() as u32;
                for &(e, c) in &list {
                    self.tets[e as usize][c as usize] = copy;
                }
                self.copy_node(s, list);
                made += 1;
            }
        }
        made
    }

    /// Append a copy of node `s` carrying the tetrahedra `list`.
    fn copy_node(&mut self, s: usize, list: Vec<(u32, u8)>) {
        self.rest_x.push(self.rest_x[s]);
        self.x.push(self.x[s]);
        self.v.push(self.v[s]);
        self.phi.push(self.phi[s]);
        self.phi0.push(self.phi0[s]);
        self.pulled.push(self.pulled[s]);
        self.home.push(self.home[s]);
        if !self.last_dv.is_empty() {
            self.last_dv.push(self.last_dv[s]);
        }
        // The elements kept from the step hold: the copy is where the node
        // is, and its tetrahedra's corners are where they were.
        if let Some(kept) = &mut self.kept_elements {
            if kept.x.len() == self.x.len() - 1 {
                kept.x.push(kept.x[s]);
            }
        }
        self.node_tets.push(list);
    }

    /// The nodes that may split now that the level set moved from
    /// `before`: those sharing a tetrahedron with a node whose value
    /// changed (a node's groups change only with the level set around it).
    pub(super) fn split_candidates(&self, before: &[f64]) -> Vec<usize> {
        let changed: Vec<bool> = self.phi.iter().zip(before).map(|(p, q)| p != q).collect();
        let mut near = vec![false; self.x.len()];
        for t in &self.tets {
            if t.iter().any(|&n| changed[n as usize]) {
                for &n in t {
                    near[n as usize] = true;
                }
            }
        }
        (0..near.len()).filter(|&n| near[n]).collect()
    }
}
