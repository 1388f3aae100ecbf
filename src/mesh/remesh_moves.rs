//! The remesher's moves along the surface: tangential smoothing and the
//! seeded jitter, each kept only where no face turns over.

use super::{Input, Work};
use crate::mesh::spatial::{add, cross, dot, norm, scale, sub};
use rayon::prelude::*;

impl Work {
    /// Tangential smoothing toward the neighbours' centroid, then
    /// projection onto the input (feature vertices along their lines).
    pub(super) fn smooth(&mut self, input: &Input) {
        // Every target is computed from the same positions, so the
        // vertices are independent: in parallel, in a fixed order.
        let next: Vec<[f64; 3]> = (0..self.pos.len())
            .into_par_iter()
            .map_init(Vec::new, |nb, v| {
                self.smoothed(input, v, nb).unwrap_or(self.pos[v])
            })
            .collect();
        self.move_unless_turned(&next);
    }

    /// Where [`Work::smooth`] sends vertex `v` (`None`: it stays); `nb`
    /// is working memory for its neighbours.
    fn smoothed(&self, input: &Input, v: usize, nb: &mut Vec<u32>) -> Option<[f64; 3]> {
        if self.dead_vertex[v] || self.corner[v] || self.vf[v].is_empty() {
            return None;
        }
        let vv = v as u32;
        self.neighbours_in(vv, nb);
        if self.nfeat[v] > 0 {
            nb.retain(|&u| self.is_feature(vv, u));
        }
        if nb.is_empty() {
            return None;
        }
        let mut c = [0.0; 3];
        for &u in nb.iter() {
            c = add(c, self.pos[u as usize]);
        }
        c = scale(c, 1.0 / nb.len() as f64);
        let p = self.pos[v];
        let mut d = sub(c, p);
        if self.nfeat[v] == 0 {
            let mut nrm = [0.0; 3];
            for &f in &self.vf[v] {
                nrm = add(nrm, self.face_normal(self.faces[f as usize]));
            }
            let l = norm(nrm);
            if l > 0.0 {
                let nn = scale(nrm, 1.0 / l);
                d = sub(d, scale(nn, dot(d, nn)));
            }
        }
        let q = add(p, d);
        Some(if self.nfeat[v] > 0 {
            input.closest_feature(q).unwrap_or(q)
        } else {
            let chart = self.chart[self.vf[v][0] as usize];
            input.closest_face(q, Some(chart)).map_or(q, |x| x.2)
        })
    }

    /// Move every vertex to `next` where none of its faces turns over
    /// (checked against the moves made so far, in vertex order).
    fn move_unless_turned(&mut self, next: &[[f64; 3]]) {
        for (v, &to) in next.iter().enumerate() {
            if to == self.pos[v] {
                continue;
            }
            let ok = self.vf[v].iter().all(|&f| {
                let t = self.faces[f as usize];
                let before = self.face_normal(t);
                let pts = t.map(|x| {
                    if x as usize == v {
                        to
                    } else {
                        self.pos[x as usize]
                    }
                });
                let after = cross(sub(pts[1], pts[0]), sub(pts[2], pts[0]));
                dot(before, after) > 0.2 * norm(before) * norm(after)
            });
            if ok {
                self.pos[v] = to;
            }
        }
    }

    /// Move every free vertex a seeded random distance along the surface:
    /// up to `amount` of the shorter of its size and its edges, in a
    /// uniformly random direction of its tangent plane (a vertex on a
    /// feature line along the line), then back onto the input.
    pub(super) fn jitter(&mut self, input: &Input, amount: f64, seed: u64, pass: u64) {
        let next: Vec<[f64; 3]> = (0..self.pos.len())
            .into_par_iter()
            .map_init(Vec::new, |nb, v| {
                self.jittered(input, amount, seed, pass, v, nb)
                    .unwrap_or(self.pos[v])
            })
            .collect();
        self.move_unless_turned(&next);
    }

    /// Where [`Work::jitter`] sends vertex `v` (`None`: it stays); `nb` is
    /// working memory for its neighbours.
    fn jittered(
        &self,
        input: &Input,
        amount: f64,
        seed: u64,
        pass: u64,
        v: usize,
        nb: &mut Vec<u32>,
    ) -> Option<[f64; 3]> {
        if self.dead_vertex[v] || self.corner[v] || self.vf[v].is_empty() {
            return None;
        }
        let vv = v as u32;
        let p = self.pos[v];
        self.neighbours_in(vv, nb);
        if nb.is_empty() {
            return None;
        }
        let edge = nb.iter().map(|&u| self.len(vv, u)).sum::<f64>() / nb.len() as f64;
        let key = ((v as u64) << 8 | pass) * 2;
        let (u1, u2) = (
            0.5 + 0.5 * crate::math::hash_unit(seed, key),
            crate::math::hash_unit(seed, key + 1),
        );
        let reach = amount * self.size[v].min(edge);
        if self.nfeat[v] > 0 {
            // Along the feature line: between its two neighbours on it.
            let on: Vec<u32> = nb.iter().copied().filter(|&u| self.is_feature(vv, u)).collect();
            if on.len() != 2 {
                return None;
            }
            let d = sub(self.pos[on[1] as usize], self.pos[on[0] as usize]);
            let l = norm(d);
            if l <= 0.0 {
                return None;
            }
            let q = add(p, scale(d, u2 * reach / l));
            return Some(input.closest_feature(q).unwrap_or(q));
        }
        let mut nrm = [0.0; 3];
        for &f in &self.vf[v] {
            nrm = add(nrm, self.face_normal(self.faces[f as usize]));
        }
        let l = norm(nrm);
        if l <= 0.0 {
            return None;
        }
        let n = scale(nrm, 1.0 / l);
        // A tangent axis from the coordinate axis least along the normal.
        let k = (0..3)
            .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
            .unwrap_or(0);
        let mut axis = [0.0; 3];
        axis[k] = 1.0;
        let t1 = cross(n, axis);
        let t1 = scale(t1, 1.0 / norm(t1));
        let t2 = cross(n, t1);
        let (r, a) = (reach * u1.sqrt(), std::f64::consts::PI * u2);
        let q = add(p, add(scale(t1, r * a.cos()), scale(t2, r * a.sin())));
        let chart = self.chart[self.vf[v][0] as usize];
        Some(input.closest_face(q, Some(chart)).map_or(q, |x| x.2))
    }
}
