//! A bonded film: the world-scale length that sets the size of crack cells.
//!
//! Crack spacing in a film bonded to its substrate (a glaze on a pot, mud on
//! the ground, paint) comes from the bond: a film of thickness `h` and
//! modulus `E` tied to the body through a compliant layer of stiffness `k`
//! per area obeys, for its in-plane displacement `u`,
//!
//! `div(E h eps(u) + sigma_load h) = k u`      (shear lag),
//!
//! so the stress recovers from zero at a crack edge to the far stress over
//! the length `l = sqrt(E h / k)`, and sequential cracking leaves cells a few
//! `l` across. Discretely, with the stiffness `K = P B^T A B P` of
//! [`crate::sim::implicit`] and the lumped node areas `M`,
//!
//! `(K + k M) u = f_load`,   `sigma = sigma_load + B u`.
//!
//! Units: in a film run the length unit is `l` itself (so `k = 1` and the
//! interface term of node `n` is its lumped area `M_n`), and stress is the
//! load's (the material's stiffness is 1). The artist asks for a cell size
//! `c` in scene units (`simulation.cell_size`) or as a fraction of the
//! mesh's bounding-box diagonal (`simulation.cell_size_relative`); `l =
//! c / CELL_PER_LENGTH`. Every length of the failure rule below is a fixed
//! fraction of `c`, so the pattern does not depend on the triangles once the
//! mesh resolves `l` (the pipeline remeshes it to [`EDGES_PER_CELL`] edges a
//! cell first).
//!
//! Failure converges under refinement because it is decided on the stress
//! averaged over a disc of world radius [`AVERAGE_RADIUS`]` * c` (the tip
//! field of a crack is singular; its average over a fixed disc is not), and
//! no new crack starts within [`EXCLUSION`]` * c` of an existing one (the
//! paper's no-back-cracking rule at a world-scale distance), nor, within one
//! round, within [`SHADOW`]` * c` of a crack that round made (its relief
//! is not solved for until the round ends).

use crate::math::GrowGently;
use crate::math::{v3, Sym3};
use crate::mesh::{FaceId, SimMesh, VertexId};
use crate::sim::forces::{Elements, Fans};

/// Cell size over the shear-lag length `l`. Calibrated so that the mean cell
/// diameter `crackle stats` measures comes out near the cell size asked
/// for (see the README's measurements).
pub const CELL_PER_LENGTH: f64 = 1.35;

/// Edges across one cell of the remeshed simulation surface.
pub const EDGES_PER_CELL: f64 = crate::stress::field::EDGES_PER_CELL;

/// Radius of the disc the failure stress is averaged over, in cell sizes.
pub const AVERAGE_RADIUS: f64 = 1.0 / 12.0;

/// No new crack starts closer than this to an existing crack, in cell sizes.
pub const EXCLUSION: f64 = 0.25;

/// Within one round no new crack starts closer than this to a crack the
/// round made, in cell sizes.
pub const SHADOW: f64 = 0.5;

/// Correlation length of the load's seeded variation, in cell sizes.
pub const NOISE_SPACING: f64 = 0.35;

/// [`Film::shadow`] of a node in the shadows of two or more crack runs.
pub const SHADOWED_BY_MANY: u32 = u32::MAX;

/// The film state of a run (lengths in the run's unit, `l`).
#[derive(Clone, Debug, Default)]
pub struct Film {
    /// The cell size asked for, in scene units.
    pub cell: f64,
    /// The shear-lag length `l`, in scene units (the run's length unit).
    pub length: f64,
    /// Per node: the interface stiffness times its lumped area (`k = 1`).
    pub interface: Vec<f64>,
    /// The mesh generation `interface` was built for.
    pub generation: Option<u64>,
    /// Nodes no new crack may start from (near a crack).
    pub near_crack: Vec<bool>,
    /// Per node, the crack run of this round whose shadow covers it: 0
    /// for none, [`SHADOWED_BY_MANY`] for more than one. No new crack starts
    /// in a shadow, and no tip runs on in another run's shadow.
    pub shadow: Vec<u32>,
    /// Per node, the crack run of this round it belongs to (0: none).
    pub run: Vec<u32>,
    /// The last run id this round handed out.
    runs: u32,
    /// Scratch for the searches: the stamp each node was last visited with.
    stamp: Vec<u32>,
    counter: u32,
}

impl Film {
    /// A film of cell size `cell` (scene units).
    pub fn new(cell: f64) -> Film {
        Film {
            cell,
            length: cell / CELL_PER_LENGTH,
            ..Film::default()
        }
    }

    /// Radius of the failure average in the run's unit.
    pub fn average_radius(&self) -> f64 {
        AVERAGE_RADIUS * CELL_PER_LENGTH
    }

    /// Grow the per-node arrays to `n` nodes (new nodes are not marked).
    pub fn grow(&mut self, n: usize) {
        self.near_crack.resize_gently(n, false);
        self.shadow.resize_gently(n, 0);
        self.run.resize_gently(n, 0);
        self.stamp.resize_gently(n, 0);
    }

    /// Rebuild the interface terms when the mesh changed.
    pub fn refresh(&mut self, generation: u64, fans: &Fans, els: &Elements) {
        if self.generation == Some(generation) && self.interface.len() == fans.n_vertices() {
            return;
        }
        self.interface = lumped_areas(fans, els);
        self.generation = Some(generation);
    }

    /// Forget this round's shadows and runs.
    pub fn new_round(&mut self) {
        self.shadow.iter_mut().for_each(|s| *s = 0);
        self.run.iter_mut().for_each(|s| *s = 0);
        self.runs = 0;
    }

    /// The run a crack from node `v` belongs to: the run `v` is the tip of,
    /// or a new one.
    pub fn run_at(&mut self, v: VertexId) -> u32 {
        match self.run.get(v.idx()).copied().unwrap_or(0) {
            0 => {
                self.runs += 1;
                self.runs
            }
            r => r,
        }
    }

    /// Whether the crack tip `v` may run on: not inside the shadow of
    /// another crack run of this round. Two tips of one round do not know of
    /// each other's relief until the round's relaxation, so without this
    /// they run side by side (paired cracks); a tip held here goes on next
    /// round, steered by the settled stress.
    pub fn tip_may_run(&self, v: VertexId) -> bool {
        let shadow = self.shadow.get(v.idx()).copied().unwrap_or(0);
        shadow == 0 || shadow == self.run.get(v.idx()).copied().unwrap_or(0)
    }

    /// Mark the nodes within `EXCLUSION` cell sizes of `seeds` as near a
    /// crack and those within `SHADOW` as shadowed this round by crack run
    /// `run` (the seeds become part of it).
    pub fn mark_around(&mut self, mesh: &SimMesh, seeds: &[VertexId], run: u32) {
        let n = mesh.n_vertices();
        self.grow(n);
        let reach = EXCLUSION.max(SHADOW) * self.cell;
        self.counter = self.counter.wrapping_add(1);
        if self.counter == 0 {
            self.stamp.iter_mut().for_each(|s| *s = 0);
            self.counter = 1;
        }
        let stamp = self.counter;
        let (near, shadow) = (EXCLUSION * self.cell, SHADOW * self.cell);
        let mut stack: Vec<(VertexId, [f64; 3])> = Vec::new();
        for &s in seeds {
            let origin = mesh.position(s);
            stack.push((s, origin));
            // Every seed searches its own disc (the stamp pairs a node with
            // the search that last reached it).
            self.counter = self.counter.wrapping_add(1).max(1);
            let stamp = self.counter;
            while let Some((v, o)) = stack.pop() {
                if self.stamp[v.idx()] == stamp {
                    continue;
                }
                self.stamp[v.idx()] = stamp;
                let d = v3::norm(v3::sub(mesh.position(v), o));
                if d > reach {
                    continue;
                }
                if d <= near {
                    self.near_crack[v.idx()] = true;
                }
                if d <= shadow {
                    let s = &mut self.shadow[v.idx()];
                    *s = if *s == 0 || *s == run {
                        run
                    } else {
                        SHADOWED_BY_MANY
                    };
                }
                for h in mesh.vertex_outgoing(v) {
                    let u = mesh.dest(h);
                    if self.stamp[u.idx()] != stamp {
                        stack.push((u, o));
                    }
                }
            }
        }
        let _ = stamp;
        for &s in seeds {
            self.run[s.idx()] = run;
        }
    }

    /// Whether node `v`, not on a crack, may start a new crack.
    pub fn may_start(&self, v: VertexId) -> bool {
        !(self.near_crack.get(v.idx()).copied().unwrap_or(false)
            || self.shadow.get(v.idx()).copied().unwrap_or(0) != 0)
    }
}

/// Lumped area of every node: a third of each incident element's area.
pub fn lumped_areas(fans: &Fans, els: &Elements) -> Vec<f64> {
    use rayon::prelude::*;
    (0..fans.n_vertices())
        .into_par_iter()
        .with_min_len(1024)
        .map(|v| {
            fans.fan(v)
                .iter()
                .filter_map(|&(f, _)| els.elements.get(f as usize).and_then(|e| e.as_ref()))
                .map(|el| el.area / 3.0)
                .sum()
        })
        .collect()
}

/// The stress averaged (area-weighted) over the faces whose centroid lies
/// within `radius` (run units) of node `v`, reached across uncracked edges
/// from `v`'s own faces (always included). `unit` converts mesh positions
/// to run units.
pub fn averaged_stress(
    mesh: &SimMesh,
    els: &Elements,
    stress: &[Sym3],
    unit: f64,
    radius: f64,
    v: VertexId,
) -> Sym3 {
    // The search's lists are kept per thread: this runs for every node of
    // every round.
    thread_local! {
        static SCRATCH: std::cell::RefCell<(Vec<u32>, Vec<FaceId>)> =
            const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
    }
    SCRATCH.with(|scratch| {
        let origin = v3::scale(mesh.position(v), 1.0 / unit);
        let r2 = radius * radius;
        let (seen, stack) = &mut *scratch.borrow_mut();
        seen.clear();
        stack.clear();
        stack.extend(mesh.vertex_faces(v));
        let own = stack.len();
        let (mut sum, mut area) = (Sym3::ZERO, 0.0);
        let mut k = 0usize;
        while let Some(f) = stack.pop() {
            k += 1;
            if seen.contains(&f.0) {
                continue;
            }
            seen.push(f.0);
            let inside = k <= own || {
                let c = mesh
                    .face_vertices(f)
                    .iter()
                    .fold([0.0; 3], |a, &u| v3::add(a, mesh.position(u)));
                let c = v3::scale(c, 1.0 / (3.0 * unit));
                let d = v3::sub(c, origin);
                v3::dot(d, d) <= r2
            };
            if !inside {
                continue;
            }
            if let Some(Some(el)) = els.elements.get(f.idx()) {
                sum += stress[f.idx()] * el.area;
                area += el.area;
            }
            if seen.len() > 4096 {
                break; // a radius far above the element size: enough to average
            }
            for h in mesh.face_halfedges(f) {
                if let Some(t) = mesh.twin(h) {
                    let g = mesh.face(t);
                    if !seen.contains(&g.0) {
                        stack.push(g);
                    }
                }
            }
        }
        if area > 0.0 {
            sum * (1.0 / area)
        } else {
            Sym3::ZERO
        }
    })
}

#[cfg(test)]
#[path = "film_tests.rs"]
mod run_tests;
