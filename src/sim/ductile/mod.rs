//! Ductile tearing by the level-set method of Hegemann et al. (the fourth
//! source text): a closed surface embedded in a regular grid of
//! tetrahedra, corotational elasticity stepped by backward Euler (CG on
//! the force differential, matrix-free), and a level set `phi` that moves
//! inward only, where a node's strain-energy density exceeds the fracture
//! resistance. Tetrahedra the level set cuts keep the material behind
//! their cut plane (their stiffness and mass scale with it), so a tear
//! opens smoothly through them; everything is updated in place.
//!
//! Virtual nodes (Molino, Bridson and Fedkiw 2004, `virtual_nodes.rs`): a
//! node outside the material whose tetrahedra the tear has separated into
//! groups not tied through material gets a copy per group after the
//! first, numbered after the grid's nodes, each copy's tetrahedra naming
//! it. A tetrahedron's material is convex (the level set is linear in it),
//! so tetrahedra are never split: only nodes. Pieces that have come apart
//! share no node, and no force passes between them through the slivers
//! of a gap narrower than a cube. The mechanics, the multigrid (a copy
//! stands at its grid node's place on every level) and the torn surface
//! (one vertex per cut edge between two node ids) follow the copies.
//!
//! Units: the object's longest side is [`DuctileParams::size`] metres
//! whatever the scene's unit, material constants are SI, pulls are
//! fractions of that length per second: the same setup gives the same
//! result at any scene scale and, up to discretisation, at any grid
//! resolution (mass is density times the volume each node carries).
//!
//! [`Ductile::new`] embeds the surface, [`Ductile::step`] advances one
//! step, [`Ductile::run`] runs the whole pull, and [`surface`] extracts the
//! deformed, torn surface. No I/O and no printing.

pub mod fem;
pub mod grid;
mod multigrid;
mod params;
mod pieces;
mod redistance;
mod solve;
pub mod surface;
mod virtual_nodes;

use crate::sim::ParamError;
pub use params::{DuctileParams, GripError, Pull, PullMode};

use fem::{Element, Lame, Rest};
use grid::{inside_fraction, EmbedError, Grid};
use rayon::prelude::*;

/// The least material (in cubes) a piece holds to count: less is a sliver
/// of rounding along the surface.
pub const SLIVER: f64 = 1e-3;

/// The least material (in cubes) a node carries for its tearing to bound
/// the step: a node left with less (its tetrahedra slivers, their
/// deformation unchecked) tears as fast as its energy says, at no cost.
const FRONT_MATERIAL: f64 = 1e-2;

/// The least weight (as a share of its volume) a tetrahedron with any
/// material inside takes in the mechanics: a sliver of material is as
/// stiff and heavy as this much of the tetrahedron (an ersatz material).
/// With its true share (down to 1e-8 and less where the level set barely
/// cuts it) a node whose tetrahedra are all slivers had an all but empty
/// row, which the solve's tolerance left free: on a block turned 30
/// degrees to the grid and torn at 24 cubes such nodes drifted up to
/// 7e8 m, and the input's vertices mapped by their tetrahedra came out
/// 0.9 of the block's length below it.
const ERSATZ: f64 = 1e-3;

/// The inside fraction from which the tetrahedra around a node outside
/// tie their pieces together, for the multigrid's coarse levels.
const BRIDGE: f64 = 0.1;

/// `values` on a grid of `dims` nodes (x fastest), each replaced by its
/// sum along `axis` weighted by `kernel[d]` at `d` nodes away.
fn tent_along(values: &[f64], dims: [usize; 3], axis: usize, kernel: &[f64]) -> Vec<f64> {
    let stride = match axis {
        0 => 1,
        1 => dims[0],
        _ => dims[0] * dims[1],
    };
    let len = dims[axis];
    (0..values.len())
        .into_par_iter()
        .map(|i| {
            let at = (i / stride) % len;
            let mut sum = kernel[0] * values[i];
            for (d, &w) in kernel.iter().enumerate().skip(1) {
                if at >= d {
                    sum += w * values[i - d * stride];
                }
                if at + d < len {
                    sum += w * values[i + d * stride];
                }
            }
            sum
        })
        .collect()
}

/// What one step did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct StepReport {
    /// Time step in seconds (CFL-bounded).
    pub dt: f64,
    /// CG iterations of the implicit solve.
    pub cg_iterations: usize,
    /// Its final relative residual.
    pub cg_residual: f64,
    /// Whether it met the tolerance.
    pub converged: bool,
    /// Elastic energy after the step (J).
    pub energy: f64,
    /// Kinetic energy after the step (J).
    pub kinetic: f64,
    /// Nodes whose level set moved this step.
    pub tearing_nodes: usize,
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct DuctileReport {
    /// Grid cubes along each axis and the cube side (metres).
    pub grid: [usize; 3],
    /// Cube side in metres.
    pub spacing: f64,
    /// Tetrahedra with material.
    pub tetrahedra: usize,
    /// Steps taken.
    pub steps: usize,
    /// Seconds simulated.
    pub time: f64,
    /// CG iterations: total and the most in one step.
    pub cg_iterations: usize,
    /// See `cg_iterations`.
    pub cg_max_iterations: usize,
    /// Steps whose solve missed the tolerance.
    pub cg_unconverged: usize,
    /// CG iterations a step on average before the level set first moved,
    /// and after the object came apart (0 without such steps).
    pub cg_mean_whole: f64,
    /// See `cg_mean_whole`.
    pub cg_mean_apart: f64,
    /// Multigrid cycles built (one is kept while it works).
    pub multigrid_builds: usize,
    /// Pull distance (fraction of the object's length, both ends together)
    /// when the level set first moved, if it did.
    pub first_tear_pull: Option<f64>,
    /// Pull distance when the object first came apart, if it did.
    pub separated_pull: Option<f64>,
    /// Pieces at the end.
    pub fragments: usize,
    /// Virtual nodes at the end (copies of grid nodes the tear separated
    /// the material around).
    pub virtual_nodes: usize,
    /// Pull distance at the end.
    pub pull: f64,
    /// Wall time per step (filled by the caller that times it).
    pub seconds_per_step: f64,
}

/// The simulation state, updated in place.
pub struct Ductile {
    /// The grid.
    pub grid: Grid,
    /// Tetrahedra (node indices), only those that start with material.
    pub tets: Vec<[u32; 4]>,
    rest: Vec<Rest>,
    /// Rest positions of the nodes (metres).
    pub rest_x: Vec<[f64; 3]>,
    /// Current positions (metres).
    pub x: Vec<[f64; 3]>,
    /// Velocities (m/s).
    pub v: Vec<[f64; 3]>,
    /// Level set at the nodes (metres, negative inside).
    pub phi: Vec<f64>,
    /// The level set at the start.
    pub phi0: Vec<f64>,
    /// Tetrahedra around each node (ascending), for gathering in order.
    node_tets: Vec<Vec<(u32, u8)>>,
    /// The grid node each node stands at: itself for the grid's nodes,
    /// the node it was copied from for a virtual node (see
    /// [`virtual_nodes`]), which are numbered after the grid's.
    home: Vec<u32>,
    /// Which nodes the pull moves: -1 / +1 (the two ends) or 0.
    pub pulled: Vec<i8>,
    params: DuctileParams,
    lame: Lame,
    /// Time simulated.
    pub time: f64,
    /// How far each end has been moved (metres).
    pub pulled_by: f64,
    /// The object's length (metres).
    pub length: f64,
    /// The pull's axis.
    axis: usize,
    /// Thickness of a pulled slab (metres).
    slab_thickness: f64,
    /// The last implicit step's velocity change (its solve's first guess).
    last_dv: Vec<[f64; 3]>,
    /// Whether the grips hold their nodes in every component: false while
    /// the object is whole (a grip lets the material narrow across the
    /// pull), true once it has come apart (a piece held by one grip alone
    /// would otherwise slide across it).
    grips_hold: bool,
    /// The scene's position of the metres' origin, and metres per scene
    /// unit.
    scene_frame: ([f64; 3], f64),
    /// The multigrid cycle kept from an earlier step.
    mg: Option<KeptCycle>,
    /// The elements at the end of the last step, with the positions and
    /// weights they were computed at: the next step starts from the same
    /// positions, so only tetrahedra whose weight the level set changed
    /// need their decomposition again.
    kept_elements: Option<KeptElements>,
    /// How many cycles were built.
    pub mg_builds: usize,
}

/// Elements kept from the end of a step.
struct KeptElements {
    x: Vec<[f64; 3]>,
    weights: Vec<f64>,
    elements: Vec<Element>,
}

/// A multigrid cycle kept across steps, and how its solves went.
struct KeptCycle {
    multigrid: multigrid::Multigrid,
    /// CG iterations of the first solve with it (`usize::MAX` before).
    iterations: usize,
    /// CG iterations of the last solve with it.
    last: usize,
    /// Whether the material tore since it was built.
    torn: bool,
}

/// Most grid cubes along the object's longest side, whether given as
/// `ductile.grid` or from `ductile.cell_size`.
pub const MAX_CELLS_ALONG: usize = 400;

/// Why a run cannot start.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DuctileError {
    /// A parameter is out of range.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// The fixed groups cannot grip the object.
    #[error(transparent)]
    Grips(#[from] GripError),
    /// The surface cannot be embedded.
    #[error(transparent)]
    Embed(#[from] EmbedError),
}

impl Ductile {
    /// Embed the closed surface `positions` / `triangles` (scene units,
    /// outward-oriented) and prepare the pull.
    ///
    /// # Errors
    /// [`DuctileError`] for a parameter out of range or a surface that
    /// cannot be embedded.
    pub fn new(
        positions: &[[f64; 3]],
        triangles: &[[u32; 3]],
        params: &DuctileParams,
    ) -> Result<Ductile, DuctileError> {
        Self::with_grips(positions, triangles, &[], params)
    }

    /// As [`Ductile::new`], pulled by the faces flagged in `grips` (one
    /// flag per triangle; none flagged: by the pull's slabs): the material
    /// within one grid cube of a grip face moves with it, the grips below
    /// the object's centre along the axis one way, those above the other.
    ///
    /// # Errors
    /// As [`Ductile::new`], and grips that pull nothing apart.
    pub fn with_grips(
        positions: &[[f64; 3]],
        triangles: &[[u32; 3]],
        grips: &[bool],
        params: &DuctileParams,
    ) -> Result<Ductile, DuctileError> {
        params.validate()?;
        let (lo, hi) = grid::bounds(positions);
        let longest = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        if !(longest.is_finite() && longest > 0.0) {
            return Err(EmbedError::Empty.into());
        }
        // Metres: the longest side is `size`.
        let scale = params.size / longest;
        let metres: Vec<[f64; 3]> = positions
            .iter()
            .map(|p| [0, 1, 2].map(|k| (p[k] - lo[k]) * scale))
            .collect();
        let (mlo, mhi) = grid::bounds(&metres);
        let cells = params.cells_along_longest(longest);
        if cells > MAX_CELLS_ALONG {
            return Err(DuctileError::Param(ParamError::invalid(
                "ductile.cell_size",
                format!(
                    "{} gives {cells} cubes along the object's longest side ({longest} scene units); at most {MAX_CELLS_ALONG} (as ductile.grid): a cell size of at least {:.3e}",
                    params.cell_size,
                    longest / MAX_CELLS_ALONG as f64
                ),
            )));
        }
        let grid = Grid::around(mlo, mhi, cells);
        let rest_x: Vec<[f64; 3]> = (0..grid.n_nodes()).map(|i| grid.position(i)).collect();
        let phi = grid::signed_distances(&metres, triangles, &rest_x)?;
        let mut tets = Vec::new();
        for k in 0..grid.n[2] {
            for j in 0..grid.n[1] {
                for i in 0..grid.n[0] {
                    for t in grid.cube_tets(i, j, k) {
                        if t.iter().any(|&n| phi[n as usize] < 0.0) {
                            tets.push(t);
                        }
                    }
                }
            }
        }
        let rest: Vec<Rest> = tets
            .iter()
            .map(|t| Rest::new(t.map(|n| rest_x[n as usize])))
            .collect();
        let mut node_tets = vec![Vec::new(); rest_x.len()];
        for (e, t) in tets.iter().enumerate() {
            for (c, &n) in t.iter().enumerate() {
                node_tets[n as usize].push((e as u32, c as u8));
            }
        }
        let (pulled, axis, slab_thickness) = if grips.iter().any(|&g| g) {
            params::grip_sides(
                &params.pull,
                &rest_x,
                &phi,
                &node_tets,
                (&metres, triangles),
                grips,
                grid.h,
            )?
        } else {
            params.pull.slabs(&rest_x, &phi, &node_tets)
        };
        let (mu, lambda) = fem::lame(params.young, params.poisson);
        let n = rest_x.len();
        let mut d = Ductile {
            grid,
            tets,
            rest,
            x: rest_x.clone(),
            rest_x,
            v: vec![[0.0; 3]; n],
            phi0: phi.clone(),
            phi,
            node_tets,
            home: (0..n as u32).collect(),
            pulled,
            params: params.clone(),
            lame: Lame { mu, lambda },
            time: 0.0,
            pulled_by: 0.0,
            length: params.size,
            axis,
            slab_thickness,
            last_dv: Vec::new(),
            grips_hold: false,
            scene_frame: (lo, scale),
            mg: None,
            kept_elements: None,
            mg_builds: 0,
        };
        // Material apart from the start (shells closer than a cube) does
        // not share a node either.
        if params.virtual_nodes {
            let all: Vec<usize> = (0..n).collect();
            d.split_nodes(&all);
        }
        Ok(d)
    }

    /// A point in metres in the scene's units.
    pub fn to_scene(&self, p: [f64; 3]) -> [f64; 3] {
        let (lo, scale) = self.scene_frame;
        [0, 1, 2].map(|k| lo[k] + p[k] / scale)
    }

    /// A point in the scene's units in metres.
    pub fn to_metres(&self, p: [f64; 3]) -> [f64; 3] {
        let (lo, scale) = self.scene_frame;
        [0, 1, 2].map(|k| (p[k] - lo[k]) * scale)
    }

    /// The fraction of tetrahedron `e` that is material.
    pub fn inside(&self, e: usize) -> f64 {
        inside_fraction(self.tets[e].map(|n| self.phi[n as usize]))
    }

    /// Each tetrahedron's weight: rest volume times its inside fraction,
    /// at least [`ERSATZ`] where it holds any material.
    fn weights(&self) -> Vec<f64> {
        (0..self.tets.len())
            .into_par_iter()
            .map(|e| {
                let inside = self.inside(e);
                let share = if inside > 0.0 {
                    inside.max(ERSATZ)
                } else {
                    0.0
                };
                self.rest[e].volume * share
            })
            .collect()
    }

    /// Each tetrahedron's current state.
    fn elements(&self, weights: &[f64]) -> Vec<Element> {
        (0..self.tets.len())
            .into_par_iter()
            .map(|e| self.element(e, weights[e]))
            .collect()
    }

    /// Tetrahedron `e`'s state at weight `weight`; one without material
    /// (weight 0, so it adds no force, stiffness or energy) is left at rest
    /// without its decomposition.
    fn element(&self, e: usize, weight: f64) -> Element {
        if weight <= 0.0 {
            return Element::at_rest(&self.rest[e]);
        }
        let x = self.tets[e].map(|n| self.x[n as usize]);
        Element::at(x, &self.rest[e], weight, self.lame)
    }

    /// Node masses: density times a quarter of each tetrahedron's weight.
    fn masses(&self, weights: &[f64]) -> Vec<f64> {
        self.node_tets
            .par_iter()
            .map(|ts| {
                ts.iter()
                    .map(|&(e, _)| 0.25 * weights[e as usize])
                    .sum::<f64>()
                    * self.params.density
            })
            .collect()
    }

    /// Elastic energy (J).
    pub fn energy(&self) -> f64 {
        let w = self.weights();
        let el = self.elements(&w);
        el.iter().zip(&w).map(|(e, w)| e.psi * w).sum()
    }

    /// The energy density the level set reads: [`Ductile::nodal_energy`]
    /// averaged over `params.nonlocal` around each node (see
    /// [`DuctileParams::nonlocal`]): three passes of a tent along the grid's
    /// axes over the nodes' material times energy and over their material,
    /// then the ratio. Nodes without material keep their own.
    pub fn driving_energy(&self, elements: &[Element], weights: &[f64], mass: &[f64]) -> Vec<f64> {
        let psi = self.nodal_energy(elements, weights);
        // The tent's reach in cubes: weight 1 - d / reach at d nodes away.
        let reach = self.params.nonlocal / self.grid.h;
        if reach <= 1.0 {
            return psi;
        }
        // On the grid's nodes: a virtual node's share goes to the node it
        // stands at, and it reads that node's average.
        let n_grid = self.grid.n_nodes();
        let (mut num, mut den) = (vec![0.0; n_grid], vec![0.0; n_grid]);
        for (i, (p, m)) in psi.iter().zip(mass).enumerate() {
            let h = self.home(i);
            num[h] += p * m;
            den[h] += m;
        }
        let kernel: Vec<f64> = (0..)
            .map(|d| 1.0 - f64::from(d) / reach)
            .take_while(|&w| w > 0.0)
            .collect();
        let dims = self.grid.nodes_per_axis();
        for axis in 0..3 {
            for values in [&mut num, &mut den] {
                *values = tent_along(values, dims, axis, &kernel);
            }
        }
        // Beside material already torn (a node whose level set rose, or
        // one sharing a tetrahedron with it) the front runs on its own
        // energy: the average is the onset's.
        let rose: Vec<bool> = self
            .phi
            .iter()
            .zip(&self.phi0)
            .map(|(p, q)| p > q)
            .collect();
        (0..psi.len())
            .into_par_iter()
            .map(|i| {
                let at_front = rose[i]
                    || self.node_tets[i]
                        .iter()
                        .any(|&(e, _)| self.tets[e as usize].iter().any(|&j| rose[j as usize]));
                let h = self.home(i);
                if at_front || mass[i] <= 0.0 || den[h] <= 0.0 {
                    psi[i]
                } else {
                    num[h] / den[h]
                }
            })
            .collect()
    }

    /// Strain-energy density at each node: its tetrahedra's, weighted by
    /// the part of their volume it carries (eq. 4 of the text).
    pub fn nodal_energy(&self, elements: &[Element], weights: &[f64]) -> Vec<f64> {
        self.node_tets
            .par_iter()
            .map(|ts| {
                let (mut num, mut den) = (0.0, 0.0);
                for &(e, _) in ts {
                    let w = 0.25 * weights[e as usize];
                    num += elements[e as usize].psi * w;
                    den += w;
                }
                if den > 0.0 {
                    num / den
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// The pull's speed of each end now (m/s), ramped.
    fn pull_speed_now(&self) -> f64 {
        let p = &self.params.pull;
        let full = p.speed * self.length;
        if p.ramp > 0.0 {
            full * (self.time / p.ramp).min(1.0)
        } else {
            full
        }
    }

    /// Whether a grip fixes component `k` of its nodes: the pull's always,
    /// the others once the object has come apart (see `grips_hold`).
    fn grip_holds(&self, k: usize) -> bool {
        k == self.axis || self.grips_hold
    }

    /// The velocity a grip gives component `k` of pulled node `i` at pull
    /// speed `speed`: the pull along the axis, still across it.
    fn grip_velocity(&self, i: usize, k: usize, speed: f64) -> f64 {
        if k == self.axis {
            f64::from(self.pulled[i]) * speed
        } else {
            0.0
        }
    }

    /// How far each end has moved along the axis: half the difference of
    /// the slabs' mean displacements.
    fn update_pulled_by(&mut self) {
        let mut sum = [0.0; 2];
        let mut count = [0usize; 2];
        for (n, &side) in self.pulled.iter().enumerate() {
            if side != 0 {
                let k = usize::from(side > 0);
                sum[k] += self.x[n][self.axis] - self.rest_x[n][self.axis];
                count[k] += 1;
            }
        }
        let mean = |k: usize| {
            if count[k] > 0 {
                sum[k] / count[k] as f64
            } else {
                0.0
            }
        };
        self.pulled_by = 0.5 * (mean(1) - mean(0));
    }

    /// How far the ends have moved apart, as a fraction of the length.
    pub fn pull_fraction(&self) -> f64 {
        2.0 * self.pulled_by / self.length
    }

    /// The elements at the current positions and `weights`: those kept
    /// from the end of the last step when the positions are the same, with
    /// the tetrahedra whose weight changed since computed again (the same
    /// values as computing all of them).
    fn elements_now(&mut self, weights: &[f64]) -> Vec<Element> {
        match self.kept_elements.take() {
            Some(kept) if kept.x == self.x => {
                let mut elements = kept.elements;
                elements
                    .par_iter_mut()
                    .enumerate()
                    .filter(|(e, _)| kept.weights[*e] != weights[*e])
                    .for_each(|(e, el)| *el = self.element(e, weights[e]));
                elements
            }
            _ => self.elements(weights),
        }
    }

    /// Advance one step: elasticity by backward Euler, then the level set.
    pub fn step(&mut self) -> StepReport {
        let weights = self.weights();
        let elements = self.elements_now(&weights);
        let mass = self.masses(&weights);
        let psi = self.driving_energy(&elements, &weights, &mass);
        let dt = self.cfl_step(&psi, &mass);
        let mut report = self.implicit_step(dt, &weights, &elements, &mass);
        self.time += dt;
        self.update_pulled_by();
        // The level set, from the energies after the step.
        let weights = self.weights();
        let elements = self.elements(&weights);
        let mass = self.masses(&weights);
        let psi = self.driving_energy(&elements, &weights, &mass);
        let before = (self.params.virtual_nodes).then(|| self.phi.clone());
        report.tearing_nodes = self.advance_level_set(&psi, dt);
        if report.tearing_nodes > 0 {
            if self.params.redistance {
                self.redistance();
            }
            if let Some(mg) = &mut self.mg {
                mg.torn = true;
            }
        }
        report.dt = dt;
        report.energy = elements.iter().zip(&weights).map(|(e, w)| e.psi * w).sum();
        self.kept_elements = Some(KeptElements {
            x: self.x.clone(),
            weights,
            elements,
        });
        report.kinetic = 0.5
            * self
                .v
                .iter()
                .zip(&mass)
                .map(|(v, m)| m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]))
                .sum::<f64>();
        // Where the tear separated the material around a node, each side
        // gets its own copy of it (the elements kept hold as they are).
        if let Some(before) = before.filter(|_| report.tearing_nodes > 0) {
            let candidates = self.split_candidates(&before);
            self.split_nodes(&candidates);
        }
        report
    }

    /// The fastest the torn front moves (m/s), as `advance_level_set`
    /// moves it, at the nodes carrying at least [`FRONT_MATERIAL`] of a
    /// cube of material.
    fn front_speed(&self, psi: &[f64], mass: &[f64]) -> f64 {
        let p = &self.params;
        let eps = p.eps * self.grid.h;
        let least = FRONT_MATERIAL * p.density * self.grid.h.powi(3);
        psi.iter()
            .zip(&self.phi)
            .zip(mass)
            .filter(|((&e, _), &m)| e > p.kappa && m >= least)
            .map(|((&e, &phi), _)| eps * eps / (eps * eps + phi * phi) * (e - p.kappa) / p.kappa)
            .fold(0.0, f64::max)
            * p.tear_speed
            * self.length
    }

    /// The fastest any material moves (m/s): the nodes inside, and the
    /// points where the surface crosses an edge from a node inside to one
    /// outside (a node outside carries material only up to there). A node
    /// far outside a cut tetrahedron can move fast with next to no
    /// material behind it (a torn sliver snapping back); the surface and
    /// the material move only a fraction of that.
    fn material_speed(&self) -> f64 {
        let speed = crate::math::v3::norm;
        (0..self.x.len())
            .into_par_iter()
            .map(|b| {
                let phi_b = self.phi[b];
                if phi_b < 0.0 {
                    return speed(self.v[b]);
                }
                let mut fastest = 0.0f64;
                for &(e, _) in &self.node_tets[b] {
                    for &a in &self.tets[e as usize] {
                        let phi_a = self.phi[a as usize];
                        if phi_a < 0.0 {
                            let t = phi_a / (phi_a - phi_b);
                            let (va, vb) = (self.v[a as usize], self.v[b]);
                            let v = std::array::from_fn(|k| va[k] + t * (vb[k] - va[k]));
                            fastest = fastest.max(speed(v));
                        }
                    }
                }
                fastest
            })
            .reduce(|| 0.0, f64::max)
    }

    /// The elastic step: at most `dt`, no material moving more than `cfl`
    /// cells ([`Ductile::material_speed`]), and the torn front no more
    /// than `tear_cells`.
    fn cfl_step(&self, psi: &[f64], mass: &[f64]) -> f64 {
        let p = &self.params;
        let h = self.grid.h;
        let vmax = self
            .material_speed()
            .max(self.params.pull.speed * self.length);
        let front = self.front_speed(psi, mass).max(1e-300);
        p.dt.min(p.cfl * h / vmax.max(1e-300))
            .min(p.tear_cells * h / front)
    }

    /// Over `dt`, each node's `d phi / dt = tear_speed * L * eps^2 /
    /// (eps^2 + phi^2) * max(0, Psi - kappa) / kappa` integrated exactly
    /// (the energies held): the text's `ds * delta_eps(phi) * (Psi -
    /// kappa)` with `delta_eps` of width `eps` (a fraction of the grid
    /// spacing), scaled so the front moves at `tear_speed` where the energy
    /// is twice the resistance, whatever the grid. Each node's equation is
    /// its own, and `phi + phi^3 / (3 eps^2)` grows by the rate times `dt`:
    /// no sub-steps, however fast a node tears. Inward only. Returns how
    /// many nodes moved.
    fn advance_level_set(&mut self, psi: &[f64], dt: f64) -> usize {
        let (eps, kappa) = (self.params.eps * self.grid.h, self.params.kappa);
        let rate = dt * self.params.tear_speed * self.length;
        let mut moved = 0;
        for (n, phi) in self.phi.iter_mut().enumerate() {
            if self.node_tets[n].is_empty() || psi[n] <= kappa {
                continue;
            }
            let next = delta_integral(*phi, rate * (psi[n] - kappa) / kappa, eps);
            if next > *phi {
                *phi = next;
                moved += 1;
            }
        }
        moved
    }

    /// Run until the pull reaches `params.pull.distance` (or `max_steps`);
    /// `on_step` sees every step.
    pub fn run(&mut self, mut on_step: impl FnMut(&Ductile, &StepReport)) -> DuctileReport {
        let mut report = DuctileReport {
            grid: self.grid.n,
            spacing: self.grid.h,
            tetrahedra: self.tets.len(),
            ..Default::default()
        };
        // A solid in several pieces from the start (an input of separate
        // shells) comes apart when it has more.
        let initial = self.fragments();
        // CG iterations and steps, whole and apart.
        let (mut whole, mut apart) = ((0, 0), (0, 0));
        while self.pull_fraction() < self.params.pull.distance
            && report.steps < self.params.max_steps
        {
            let s = self.step();
            report.steps += 1;
            report.cg_iterations += s.cg_iterations;
            report.cg_max_iterations = report.cg_max_iterations.max(s.cg_iterations);
            if !s.converged {
                report.cg_unconverged += 1;
            }
            if s.tearing_nodes > 0 && report.first_tear_pull.is_none() {
                report.first_tear_pull = Some(self.pull_fraction());
            }
            if report.separated_pull.is_none() && s.tearing_nodes > 0 && self.fragments() > initial
            {
                report.separated_pull = Some(self.pull_fraction());
                self.grips_hold = true;
            } else if report.separated_pull.is_some() {
                apart = (apart.0 + s.cg_iterations, apart.1 + 1);
            }
            if report.first_tear_pull.is_none() {
                whole = (whole.0 + s.cg_iterations, whole.1 + 1);
            }
            on_step(self, &s);
        }
        let mean = |(sum, steps): (usize, usize)| sum as f64 / steps.max(1) as f64;
        report.cg_mean_whole = mean(whole);
        report.cg_mean_apart = mean(apart);
        report.time = self.time;
        report.multigrid_builds = self.mg_builds;
        report.pull = self.pull_fraction();
        report.fragments = self.fragments();
        report.virtual_nodes = self.virtual_nodes();
        report
    }

    /// Parameters.
    pub fn params(&self) -> &DuctileParams {
        &self.params
    }
}

/// The `phi` reached from `phi0` by `d phi / dt = eps^2 / (eps^2 + phi^2)`
/// over a time `t` (at least `phi0`): the root of `g(phi) = g(phi0) + t`,
/// `g(phi) = phi + phi^3 / (3 eps^2)` (increasing), by Cardano's formula
/// for `phi^3 + 3 eps^2 phi - 3 eps^2 c = 0` and a Newton step.
fn delta_integral(phi0: f64, t: f64, eps: f64) -> f64 {
    let e2 = eps * eps;
    let g = |x: f64| x + x * x * x / (3.0 * e2);
    let c = g(phi0) + t;
    if !(c.is_finite() && t > 0.0) {
        return phi0;
    }
    // x = A - eps^2 / A, A = cbrt(u + sqrt(u^2 + eps^6)), u = 1.5 eps^2 c,
    // taken on |u| (the root is odd in c).
    let u = 1.5 * e2 * c.abs();
    let a = (u + (u * u + e2 * e2 * e2).sqrt()).cbrt();
    let mut x = (a - e2 / a).copysign(c);
    x -= (g(x) - c) / (1.0 + x * x / e2);
    x.max(phi0)
}

#[cfg(test)]
mod level_set_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod virtual_tests;
