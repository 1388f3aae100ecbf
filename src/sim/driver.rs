//! The quasistatic crack loop: relax (with stress evolution), compute
//! separation tensors, crack while the top of the failure queue exceeds the
//! toughness, repeat until nothing fails or a budget is reached.
//!
//! Units: lengths are normalised by the input mesh's mean edge length, so
//! every parameter means the same whatever the asset's scale or unit. Stress
//! is dimensionless (the material's stiffness is 1); the toughness is compared
//! with the separation tensor's eigenvalue in those units.

use crate::geometry::element::Element;
use crate::mesh::{FaceId, MeshError, SimMesh, VertexId};
use crate::sim::crack::{crack_node_avoiding, CrackRules};
use crate::sim::forces::{
    corner_forces, element_corner_forces, element_strain, face_points, gather, separation_tensor,
    separation_tensor_split, tensile_splits, Elements, Fans,
};
use crate::sim::queue::FailureQueue;
use crate::sim::relax::{apply_virtual_displacement_with_forces, energy, node_bounds};
use crate::stress::field::StressField;
use crate::stress::tensor::{v3, Sym3};
use rayon::prelude::*;
use std::sync::Arc;

/// Parameters of a run (all lengths in mean-edge-length units). A
/// pipeline's `[simulation]` table deserialises into it; the fixed
/// boundary and groups come from its `[select]` table instead.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimParams {
    /// Toughness `tau`: a node fails when its separation eigenvalue exceeds it. Default 2.
    pub toughness: f64,
    /// Fraction `alpha` of the residual `v+ - tau` handed to the crack tips, in [0, 1]. Default 0.8.
    pub alpha: f64,
    /// Constant added to the residual at the crack tips (dimensionless
    /// stress) so cracks run on until they meet another crack or the border,
    /// closing cells. Default 1 (half the default toughness).
    pub residual_constant: f64,
    /// Uniform shrinkage added to every element per unit relaxation time. Default 0.05.
    pub shrink_rate: f64,
    /// How long the load (shrinkage and the stress field's evolution terms)
    /// acts, in relaxation time; the run then goes on until nothing fails.
    /// Total uniform shrinkage is `shrink_rate * load_time`. Default 120.
    pub load_time: f64,
    /// Seeded variation of the load between input triangles, as a
    /// fraction: each triangle is loaded at `rate * (1 + noise * u)` with `u`
    /// uniform in [-1, 1] (split triangles keep their input triangle's `u`).
    /// Breaks the symmetry of perfectly regular meshes. In [0, 1]; default 0.2.
    pub noise: f64,
    /// Seed of every random choice. Default 1.
    pub seed: u64,
    /// Relaxation time between crack checks. Default 5.
    pub relax_time: f64,
    /// Largest relaxation step; 0 means the stable step of the current mesh
    /// (a larger value is reduced to it, so relaxation never diverges). Default 0.
    pub relax_dt: f64,
    /// Relaxation steps per round; 0 means as many as `relax_time` needs.
    /// When set, a round lasts `relax_steps * dt` instead of `relax_time`. Default 0.
    pub relax_steps: usize,
    /// Most relaxation rounds. Default 200.
    pub max_rounds: usize,
    /// Most crack events in the whole run. Default 1,000,000.
    pub max_cracks: usize,
    /// Most crack events per round; when a round reaches it the load is held
    /// (no shrinkage) for the next round, so stress can redistribute around
    /// the new cracks before more fail, as in a quasistatic loading. 0 means
    /// 1% of the nodes, at least 16. Default 0.
    pub max_cracks_per_round: usize,
    /// Conditioning cap: singular values of the barycentric bases are clamped
    /// at this factor times the input mean. Default 4.
    pub clamp_factor: f64,
    /// Fix the mesh's open boundary (otherwise it is free). Default false.
    #[serde(skip)]
    pub fixed_boundary: bool,
    /// Fix every node of the faces in these groups (the bridge makes one
    /// group per primitive, so a material or an OBJ group). Default none.
    #[serde(skip)]
    pub fixed_groups: Vec<u32>,
    /// The surface is bonded to the body under it (a glaze on a pot, mud on
    /// the ground): the body carries the normal part of each node force, so
    /// only tangential motion relaxes stress. Without it a free closed shell
    /// under uniform shrinkage just shrinks and never cracks. Default true.
    pub bonded: bool,
    /// Finish cracks after the run (sec. 5): every remaining crack tip, and
    /// every vertex where two crack edges enclose more than 270 degrees of
    /// surface, keeps cracking along its last direction, with relaxation
    /// between steps, until it meets another crack or the border. Set by a
    /// pipeline's `[post] finish`. Default false.
    #[serde(skip)]
    pub finish: bool,
    /// How relaxation is integrated over each round's `relax_time`; see
    /// [`Integrator`]. Default `local-euler`.
    pub integrator: Integrator,
    /// Relative residual each backward-Euler solve reaches. Default 1e-4.
    pub tolerance: f64,
    /// Local relaxation in the finishing passes: each pass relaxes only the
    /// nodes within this many rings of the nodes its cracks touched (the
    /// rest of the mesh holds still, as if fixed), for the same
    /// `relax_time`. 0 relaxes the whole mesh after every pass. Default 8.
    pub finish_rings: usize,
    /// Geometric cracking rules.
    #[serde(skip)]
    pub rules: CrackRules,
    /// The crack model. Default `quasistatic` (Iben & O'Brien 2009).
    pub model: Model,
    /// Cracks may split triangles (the paper's local remeshing). `false`
    /// snaps every crack to the existing edge nearest its plane (the
    /// snapping variant). Default true.
    pub remesh: bool,
    /// Which failing node cracks next; see [`Propagation`]. Default `queue`.
    pub propagation: Propagation,
    /// How stress relaxes between crack checks; see [`Relaxation`].
    /// Default `tensor`.
    pub relaxation: Relaxation,
    /// Eigen-diffusion passes after each crack (or each crack run with
    /// `propagation = "to-end"`). Default 30.
    pub diffusion_passes: usize,
    /// Fraction of a node's largest separation eigenvalue shared with its
    /// neighbours per pass, in [0, 1]. Default 0.05.
    pub diffusion_fraction: f64,
    /// Parameters of `model = "springs"` (`[simulation.springs]`).
    pub springs: crate::sim::springs::SpringParams,
    /// The pattern's cell size in scene units: the surface is a film bonded
    /// to its body ([`crate::sim::film`]) whose cells come out near this
    /// diameter, whatever the triangles. Give this or
    /// `cell_size_relative`, not both; with neither, lengths are the
    /// mesh's (the mean edge length) and cells follow the triangles.
    pub cell_size: Option<f64>,
    /// The cell size as a fraction of each simulated mesh's bounding-box
    /// diagonal (every preset sets one).
    pub cell_size_relative: Option<f64>,
    /// With a cell size: remesh each simulated surface isotropically to
    /// `cell size / 8` edges before cracking, refining coarse inputs (finer
    /// ones are left as they are). Default true.
    pub isotropic_remesh: bool,
    /// With `isotropic_remesh`: also coarsen surfaces finer than needed.
    /// Default false.
    pub coarsen: bool,
    /// Most triangles the remeshed surface may have: a request above it is
    /// refused with the numbers before any work. Default 2,000,000.
    pub max_triangles: usize,
}

/// Which failing node cracks next.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Propagation {
    /// The node whose separation is largest (the paper's priority queue).
    #[default]
    Queue,
    /// A crack runs on tip by tip while its tip's separation (with the
    /// residual scaled by `alpha`, the text's tip factor) exceeds the
    /// toughness, before the next crack starts (the snapping variant).
    ToEnd,
}

/// How stress relaxes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Relaxation {
    /// The paper's stress-tensor relaxation (by `integrator`).
    #[default]
    Tensor,
    /// No tensor relaxation: after each crack (or crack run) every node
    /// shares `diffusion_fraction` of its largest separation eigenvalue
    /// equally with its neighbours, `diffusion_passes` times (the snapping
    /// variant's mesh-based diffusion).
    EigenDiffusion,
}

/// Crack models.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Model {
    /// The quasistatic surface-crack method: stress, separation tensors,
    /// a failure queue and cracking with local remeshing.
    #[default]
    Quasistatic,
    /// Mass-spring drying: every edge a spring that shrinks and breaks
    /// (see [`crate::sim::springs`]).
    Springs,
}

/// Time integrators of the relaxation, all approximating the same
/// relaxation time per round.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Integrator {
    /// `local-euler`, unless the mesh is so stiff (sliver triangles) that a
    /// round would need more than [`AUTO_STEP_LIMIT`] of its steps; then
    /// `backward-euler`, whose cost does not grow with stiffness. The
    /// report names the scheme that ran and why.
    #[default]
    Auto,
    /// Forward Euler with the stable step of a typical node (the median of
    /// the per-node bounds); stiffer nodes move more slowly, each within
    /// its own stable limit. Fast, but stiff regions relax late.
    LocalEuler,
    /// Forward Euler with one step for every node: the largest step the
    /// Gershgorin bound of the stiffness allows (`1.9 / max_n b_n`), or
    /// `relax_dt` when smaller. A larger requested step is split into
    /// stable sub-steps and counted in [`SimReport::dt_limited_rounds`].
    Euler,
    /// Forward Euler with the requested `relax_dt` as it is, as in the
    /// paper: the reference scheme. Diverges above the stable step (the run
    /// then stops with an error).
    PaperEuler,
    /// Backward Euler, one step of `relax_dt` (or the whole `relax_time`
    /// when 0) per solve, by preconditioned conjugate gradients to
    /// `tolerance`: stable for every step.
    BackwardEuler,
    /// The limit of long relaxation: each round solves for equilibrium
    /// (`K du = f`, no residual force left) after adding the round's load.
    Equilibrium,
    /// Second-order Runge-Kutta-Legendre super time stepping: explicit,
    /// one super-step per round (or `relax_steps` of them, or steps of at
    /// most `relax_dt`) of `s` stages, `s` the fewest whose stable reach
    /// `(s^2 + s - 2) / 4` forward-Euler steps of the stiffest node covers
    /// it: about `sqrt(4 T / h)` force evaluations where forward Euler
    /// needs `T / h`. Above [`RKL_MAX_STAGES`] stages the stiffest nodes are
    /// slowed to fit, as in `local-euler`. Energy never rises over a
    /// super-step without load.
    Rkl,
}

/// With `integrator = "auto"`: the most local-euler steps a round may
/// take before the run uses backward Euler instead.
pub const AUTO_STEP_LIMIT: f64 = 2000.0;

/// The integrator `auto` stands for on this state, and why.
fn resolve_integrator(mesh: &SimMesh, st: &State, params: &SimParams) -> (Integrator, String) {
    if params.integrator != Integrator::Auto {
        return (params.integrator, "asked for".into());
    }
    let bounds = node_bounds(&Fans::new(mesh), &st.els);
    let mut positive: Vec<f64> = bounds.into_iter().filter(|b| *b > 0.0).collect();
    if positive.is_empty() {
        return (Integrator::LocalEuler, "nothing to relax".into());
    }
    let mid = positive.len() / 2;
    let median = *positive.select_nth_unstable_by(mid, f64::total_cmp).1;
    let steps = params.relax_time * median / 1.9;
    if steps > AUTO_STEP_LIMIT {
        (
            Integrator::BackwardEuler,
            format!(
                "auto: the mesh is stiff (a local-euler round would take {steps:.0} steps, above {AUTO_STEP_LIMIT:.0})"
            ),
        )
    } else {
        (
            Integrator::LocalEuler,
            format!("auto: {steps:.0} local-euler steps a round"),
        )
    }
}

/// Most stages of an RKL super-step; stiffer nodes than this covers are
/// slowed down (their mobility reduced) instead.
pub const RKL_MAX_STAGES: usize = 48;

/// Rounds between two step-doubling error estimates of the RKL integrator
/// (each costs about 1.4 rounds).
const RKL_ESTIMATE_EVERY: usize = 16;

/// Stages of an RKL super-step of length `tau` and every node's mobility:
/// the fewest stages whose reach covers `tau` in forward-Euler steps
/// `dt_fe` of the stiffest node, or at most [`RKL_MAX_STAGES`], stretching
/// a longer step and slowing the nodes too stiff for it.
fn rkl_plan(bounds: &[f64], dt_fe: f64, tau: f64) -> (usize, Vec<f64>) {
    let mut stages = crate::sim::relax::Rkl2::stages_for(tau / dt_fe);
    let mut dt_e = dt_fe;
    if stages > RKL_MAX_STAGES {
        stages = RKL_MAX_STAGES;
        dt_e = tau / crate::sim::relax::Rkl2::reach(stages);
    }
    let mobility = bounds
        .iter()
        .map(|&b| {
            if b * dt_e > 1.9 {
                1.9 / (b * dt_e)
            } else {
                1.0
            }
        })
        .collect();
    (stages, mobility)
}

/// The step of an equilibrium solve: long enough that `I` is negligible
/// beside `dt K` (stiffness is of order 1 in normalised units).
const EQUILIBRIUM_DT: f64 = 1e12;

impl Integrator {
    /// The pipeline name.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Auto => "auto",
            Integrator::LocalEuler => "local-euler",
            Integrator::Euler => "euler",
            Integrator::PaperEuler => "paper-euler",
            Integrator::BackwardEuler => "backward-euler",
            Integrator::Equilibrium => "equilibrium",
            Integrator::Rkl => "rkl",
        }
    }
}

impl Default for SimParams {
    fn default() -> Self {
        SimParams {
            toughness: 2.0,
            alpha: 0.8,
            residual_constant: 1.0,
            shrink_rate: 0.05,
            load_time: 120.0,
            noise: 0.2,
            seed: 1,
            relax_time: 5.0,
            relax_dt: 0.0,
            relax_steps: 0,
            max_rounds: 200,
            max_cracks: 1_000_000,
            max_cracks_per_round: 0,
            clamp_factor: 4.0,
            fixed_boundary: false,
            fixed_groups: Vec::new(),
            bonded: true,
            integrator: Integrator::Auto,
            tolerance: 1e-4,
            finish_rings: 8,
            finish: false,
            model: Model::Quasistatic,
            springs: Default::default(),
            remesh: true,
            propagation: Propagation::Queue,
            relaxation: Relaxation::Tensor,
            diffusion_passes: 30,
            diffusion_fraction: 0.05,
            rules: CrackRules::default(),
            cell_size: None,
            cell_size_relative: None,
            isotropic_remesh: true,
            coarsen: false,
            max_triangles: 2_000_000,
        }
    }
}

impl SimParams {
    /// The cell size for `mesh` in scene units, when one is asked for
    /// (relative sizes scale with the mesh's bounding-box diagonal).
    pub fn cell_size_for(&self, mesh: &SimMesh) -> Option<f64> {
        match (self.cell_size, self.cell_size_relative) {
            (Some(c), _) => Some(c),
            (None, Some(r)) => {
                let (lo, hi) = mesh.bounding_box();
                Some(r * v3::norm(v3::sub(hi, lo)))
            }
            (None, None) => None,
        }
    }

    /// Whether a run on this mesh is a bonded film (the quasistatic model
    /// with tensor relaxation and a cell size).
    pub fn is_film(&self) -> bool {
        self.model == Model::Quasistatic
            && self.relaxation == Relaxation::Tensor
            && (self.cell_size.is_some() || self.cell_size_relative.is_some())
    }

    /// Check every value, naming the parameter that is wrong.
    pub fn validate(&self) -> Result<(), String> {
        let finite_pos = |name: &str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a positive number, got {x}"))
            }
        };
        if self.model == Model::Springs {
            self.springs.validate()?;
            if self.finish {
                return Err("post.finish runs the quasistatic engine's tips on; it does not apply to model = \"springs\"".into());
            }
        }
        if !(0.0..=1.0).contains(&self.diffusion_fraction) {
            return Err(format!(
                "diffusion_fraction must be in [0, 1], got {}",
                self.diffusion_fraction
            ));
        }
        finite_pos("toughness", self.toughness)?;
        finite_pos("relax_time", self.relax_time)?;
        finite_pos("clamp_factor", self.clamp_factor)?;
        if !(self.tolerance.is_finite() && self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(format!(
                "tolerance must be in (0, 1), got {}",
                self.tolerance
            ));
        }
        if self.integrator == Integrator::PaperEuler && self.relax_dt <= 0.0 {
            return Err("integrator paper-euler needs relax_dt > 0 (its fixed step)".into());
        }
        if !(0.0..=1.0).contains(&self.alpha) {
            return Err(format!(
                "alpha must be in [0, 1] (above 1 the residual propagation is unstable), got {}",
                self.alpha
            ));
        }
        if !(self.shrink_rate.is_finite() && self.shrink_rate >= 0.0) {
            return Err(format!(
                "shrink_rate must be >= 0, got {}",
                self.shrink_rate
            ));
        }
        if !(self.relax_dt.is_finite() && self.relax_dt >= 0.0) {
            return Err(format!(
                "relax_dt must be >= 0 (0: the stable step), got {}",
                self.relax_dt
            ));
        }
        if !(self.load_time.is_finite() && self.load_time >= 0.0) {
            return Err(format!("load_time must be >= 0, got {}", self.load_time));
        }
        if !(0.0..=1.0).contains(&self.noise) {
            return Err(format!("noise must be in [0, 1], got {}", self.noise));
        }
        match (self.cell_size, self.cell_size_relative) {
            (Some(_), Some(_)) => {
                return Err(
                    "give simulation.cell_size or simulation.cell_size_relative, not both".into(),
                )
            }
            (Some(c), None) => finite_pos("cell_size", c)?,
            (None, Some(r)) => {
                finite_pos("cell_size_relative", r)?;
                if r > 1.0 {
                    return Err(format!(
                        "cell_size_relative is a fraction of the bounding-box diagonal, at most 1; got {r}"
                    ));
                }
            }
            (None, None) => {}
        }
        if self.max_triangles == 0 {
            return Err("max_triangles must be at least 1".into());
        }
        if !(self.residual_constant.is_finite() && self.residual_constant >= 0.0) {
            return Err(format!(
                "residual_constant must be >= 0, got {}",
                self.residual_constant
            ));
        }
        Ok(())
    }
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SimReport {
    /// Crack events.
    pub cracks: usize,
    /// Total crack length in mesh (scene) units.
    pub crack_length: f64,
    /// Relaxation rounds.
    pub rounds: usize,
    /// Relaxation steps.
    pub relax_steps: usize,
    /// Node visits of eigen-diffusion (passes times the nodes around each
    /// crack run; 0 without it): about the cracks times a constant, not
    /// times the mesh's size.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub diffusion_work: usize,
    /// Triangles before and after.
    pub triangles: [usize; 2],
    /// Nodes before and after.
    pub nodes: [usize; 2],
    /// Stress energy at the start of the first round and at the end.
    pub energy: [f64; 2],
    /// The length unit of the run in scene units: the mean edge length,
    /// or for a film the shear-lag length (`cell_size / 2`).
    pub length_unit: f64,
    /// The cell size of a film run, in scene units (none: mesh-scale run).
    pub cell_size: Option<f64>,
    /// Why the run stopped.
    pub stopped: String,
    /// Simulation time (relaxation-time units) at the end of the run.
    pub time: f64,
    /// Simulation time at which the first crack formed (none: no crack).
    pub first_crack_time: Option<f64>,
    /// Every crack segment as its two end points (mesh units), in the order formed.
    #[serde(skip)]
    pub segments: Vec<[[f64; 3]; 2]>,
    /// When each segment of `segments` formed (simulation time).
    #[serde(skip)]
    pub segment_times: Vec<f64>,
    /// Crack finishing, when asked for.
    pub finish: Option<FinishReport>,
    /// Relaxation rounds whose requested `relax_dt` was above the stable
    /// step: they ran the stable step instead (more, smaller steps over the
    /// same relaxation time).
    pub dt_limited_rounds: usize,
    /// Spring model: sub-steps each requested `springs.dt` was split into
    /// to stay stable (1: none).
    pub substeps: usize,
    /// The smallest stable step of any round (for `local-euler` the median
    /// node bound's, for the others the largest bound's). Infinite without
    /// elements.
    pub stable_dt: f64,
    /// The integrator used.
    pub integrator: &'static str,
    /// Why that integrator ran (`auto` chooses by the mesh's stiffness).
    pub integrator_reason: String,
    /// Implicit solves that stopped before reaching `tolerance` (iteration
    /// cap, or a breakdown); their step was still taken.
    pub cg_unconverged: usize,
    /// Per relaxation round (and finishing pass): the time at its end, the
    /// energy, the norm of the residual node forces, and the conjugate
    /// gradient iterations (backward Euler).
    pub phases: Vec<Phase>,
    /// Per node of the final mesh: its accumulated relaxation displacement
    /// (eq. 15 with `c = 1`), in mesh (scene) units. Crack width comes from it.
    #[serde(skip)]
    pub displacement: Vec<[f64; 3]>,
    /// Per node of the final mesh: the simulation time it first lay on a
    /// crack (NaN: never).
    #[serde(skip)]
    pub crack_time: Vec<f64>,
}

/// The state at the end of one relaxation round.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Phase {
    /// Simulation time.
    pub time: f64,
    /// Stress energy.
    pub energy: f64,
    /// Euclidean norm of the (projected) node forces.
    pub residual: f64,
    /// Relaxation steps in the round.
    pub steps: usize,
    /// Conjugate-gradient iterations in the round (0 for explicit).
    pub cg_iterations: usize,
    /// Largest relative residual any solve of the round ended with.
    pub cg_residual: f64,
    /// Estimated relative stress error of the round's time integration
    /// (see `relax_round`; for equilibrium rounds the solve's residual).
    /// Sampled: the first round and every 8th; NaN (`null`) between.
    pub error_estimate: f64,
}

/// What crack finishing did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FinishReport {
    /// Tips found after the run (open crack ends and > 270 degree corners).
    pub tips: usize,
    /// Crack events made while finishing.
    pub cracks: usize,
    /// Crack length added (mesh units).
    pub length: f64,
    /// Finishing passes (each: every tip one step, then a relaxation round).
    pub passes: usize,
    /// Tips that could not go on (blocked by the angle rules) and were left.
    pub stuck: usize,
    /// Tips left where the stress field keeps the material from cracking
    /// (a confining mask's white, a curvature scale near 0).
    pub confined: usize,
    /// Wall-clock seconds spent finishing.
    pub seconds: f64,
}

fn is_zero(x: &usize) -> bool {
    *x == 0
}

/// Progress reports from the loop (the CLI turns them into a progress bar).
pub trait Observer {
    /// After each round: its number (from 1), the round limit, the cracks
    /// and the relaxation steps so far.
    fn round(&mut self, _round: usize, _max_rounds: usize, _cracks: usize, _relax_steps: usize) {}
    /// Before the first round, after each round and after each finishing
    /// pass: the state of the run so far, for time-lapse frames. Called only
    /// when [`Observer::wants_state`] is true.
    fn state(&mut self, _snapshot: &Snapshot) {}
    /// Whether [`Observer::state`] should be called.
    fn wants_state(&self) -> bool {
        false
    }
}

impl Observer for () {}

/// Rounds between two error estimates of the time integration.
const ESTIMATE_EVERY: usize = 8;

/// The state of a run at one moment, for [`Observer::state`].
pub struct Snapshot<'a> {
    /// The mesh, cracks opened so far.
    pub mesh: &'a SimMesh,
    /// Simulation time.
    pub time: f64,
    /// Every node's accumulated relaxation displacement, as
    /// [`SimReport::displacement`].
    pub displacement: &'a [[f64; 3]],
    /// Every node's crack time so far (NaN: not on a crack), as
    /// [`SimReport::crack_time`].
    pub crack_time: &'a [f64],
    /// The crack segments so far and their times, as
    /// [`SimReport::segments`] and [`SimReport::segment_times`].
    pub segments: &'a [[[f64; 3]; 2]],
    /// See `segments`.
    pub segment_times: &'a [f64],
    /// Area-weighted stress energy `1/2 sum_e A_e |S_e|^2` now.
    pub energy: f64,
}

/// Tell `observer` the state, when it wants it.
fn observe(observer: &mut dyn Observer, mesh: &SimMesh, st: &State, report: &SimReport) {
    if observer.wants_state() {
        observer.state(&Snapshot {
            mesh,
            time: report.time,
            displacement: &st.displacement,
            crack_time: &st.crack_time,
            segments: &report.segments,
            segment_times: &report.segment_times,
            energy: energy(&st.els, &st.stress),
        });
    }
}

/// A uniform value in [-1, 1] from `seed` and `key` (SplitMix64), the same
/// on every platform and thread count.
pub fn hash_unit(seed: u64, key: u64) -> f64 {
    let mut z = seed ^ key.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for _ in 0..2 {
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
    }
    2.0 * ((z >> 11) as f64 / (1u64 << 53) as f64) - 1.0
}

/// Simulation state that grows with the mesh.
struct State {
    els: Elements,
    stress: Vec<Sym3>,
    residual: Vec<Sym3>,
    fixed: Vec<bool>,
    /// Load multiplier per face (seeded noise).
    shrink_scale: Vec<f64>,
    /// Evolution of the stress field per unit time, per face (children copy
    /// their parent's).
    evolve: Vec<Sym3>,
    /// Factor on each face's contribution to node separation (empty: 1;
    /// children copy their parent's).
    sep_scale: Vec<f64>,
    /// Accumulated virtual displacement per node (for crack width later).
    displacement: Vec<[f64; 3]>,
    /// Time each node first lay on a crack (NaN: never).
    crack_time: Vec<f64>,
    /// Cracks meeting at each node, indexed by the node's root (all copies
    /// of a crack node share it): 2 along a crack, 3 at a T.
    crack_degree: Vec<u8>,
    unit: f64,
    /// Scratch: per-corner element forces of the current step.
    corner: Vec<[f64; 3]>,
    /// The last implicit solve's solution: the next solve starts from it.
    warm: Vec<[f64; 3]>,
    /// Node visits of eigen-diffusion (passes times nodes), for the report.
    diffusion_work: usize,
    /// What relaxation rounds reuse while the mesh does not change.
    cache: RoundCache,
    /// Working memory of the implicit rounds, kept so that fresh memory is
    /// not paged in every round.
    implicit: ImplicitScratch,
    /// With eigen-diffusion: every node's separation tensor, taken from
    /// the stress once after the first round and then changed only by
    /// cracking and diffusion (`None`: computed from the stress).
    frozen: Option<Vec<Sym3>>,
    /// A bonded film's state, when the run has a cell size.
    film: Option<crate::sim::film::Film>,
}

/// Working memory of the implicit rounds.
#[derive(Default)]
struct ImplicitScratch {
    cg: crate::sim::implicit::CgScratch,
    rhs: Vec<[f64; 3]>,
    r: Vec<[f64; 3]>,
    ax: Vec<[f64; 3]>,
}

/// Earlier implicit solutions kept for the next solve's start.
const HISTORY: usize = 3;

/// What relaxation rounds reuse while the mesh does not change: built from
/// the mesh and the elements, and rebuilt when
/// [`SimMesh::generation`] moves on (a crack changes the mesh, its
/// elements and its fixed nodes together).
#[derive(Default)]
struct RoundCache {
    /// The mesh generation the cache was built for.
    generation: Option<u64>,
    fans: Option<Arc<Fans>>,
    /// Node normals when bonded (empty otherwise).
    normals: Vec<[f64; 3]>,
    /// Per-node stiffness bounds (explicit integrators).
    bounds: Option<Vec<f64>>,
    /// Implicit: the preconditioner for the step it was built for.
    pre: Option<(f64, Vec<Sym3>)>,
    /// Implicit: the projected node force of one unit of load time.
    load_force: Option<Vec<[f64; 3]>>,
    /// Implicit: earlier solutions of the system with the given step, and
    /// their products.
    history: Option<(f64, crate::sim::implicit::History)>,
    /// The projected node force at the current stress, when a
    /// backward-Euler round left it (gathered from the corner forces its
    /// last stress update wrote).
    force: Option<Vec<[f64; 3]>>,
}

impl RoundCache {
    /// Make the cache that of `mesh` as it is now.
    fn refresh(&mut self, mesh: &SimMesh, els: &Elements, bonded: bool) {
        let generation = mesh.generation();
        if self.generation == Some(generation)
            && self
                .fans
                .as_ref()
                .is_some_and(|f| f.n_vertices() == mesh.n_vertices())
        {
            return;
        }
        // The old cache goes first (it is as large as the new one).
        *self = RoundCache::default();
        let fans = Fans::new(mesh);
        let normals = if bonded {
            node_normals(&fans, els)
        } else {
            Vec::new()
        };
        *self = RoundCache {
            generation: Some(generation),
            fans: Some(Arc::new(fans)),
            normals,
            ..RoundCache::default()
        };
    }

    fn fans(&self) -> Arc<Fans> {
        Arc::clone(self.fans.as_ref().expect("refreshed"))
    }
}

impl State {
    fn element(&self, mesh: &SimMesh, f: FaceId) -> Option<Element> {
        let p = face_points(mesh, f).map(|q| v3::scale(q, 1.0 / self.unit));
        Element::new(p, self.els.clamp)
    }

    fn in_fixed_group(mesh: &SimMesh, params: &SimParams, v: VertexId) -> bool {
        !params.fixed_groups.is_empty()
            && mesh
                .vertex_faces(v)
                .any(|f| params.fixed_groups.contains(&mesh.face_group(f)))
    }

    /// Extend per-node and per-face state to new nodes and faces.
    /// Duplicates inherit their parent's displacement and crack time;
    /// inserted vertices are settled by the caller.
    fn grow(&mut self, mesh: &SimMesh, params: &SimParams) {
        self.residual.resize(mesh.n_vertices(), Sym3::ZERO);
        self.crack_degree.resize(mesh.n_vertices(), 0);
        if let Some(fz) = &mut self.frozen {
            while fz.len() < mesh.n_vertices() {
                let v = VertexId(fz.len() as u32);
                let parent = mesh.vertex_parent(v);
                let s = if parent != v {
                    fz.get(parent.idx()).copied()
                } else {
                    None
                };
                fz.push(s.unwrap_or(Sym3::ZERO));
            }
        }
        while self.displacement.len() < mesh.n_vertices() {
            let v = VertexId(self.displacement.len() as u32);
            let parent = mesh.vertex_parent(v);
            let (d, t) = if parent != v && parent.idx() < self.displacement.len() {
                (
                    self.displacement[parent.idx()],
                    self.crack_time[parent.idx()],
                )
            } else {
                ([0.0; 3], f64::NAN)
            };
            self.displacement.push(d);
            self.crack_time.push(t);
        }
        while self.fixed.len() < mesh.n_vertices() {
            let v = VertexId(self.fixed.len() as u32);
            // Duplicates inherit fixedness from their parent; inserted
            // vertices are settled by the caller (it knows the split edge).
            let parent = mesh.vertex_parent(v);
            let f = (parent != v && self.fixed.get(parent.idx()).copied().unwrap_or(false))
                || Self::in_fixed_group(mesh, params, v);
            self.fixed.push(f);
        }
        self.els.elements.resize(mesh.n_faces(), None);
        self.stress.resize(mesh.n_faces(), Sym3::ZERO);
        if !self.evolve.is_empty() {
            self.evolve.resize(mesh.n_faces(), Sym3::ZERO);
        }
        if !self.sep_scale.is_empty() {
            self.sep_scale.resize(mesh.n_faces(), 1.0);
        }
        while self.shrink_scale.len() < mesh.n_faces() {
            let f = FaceId(self.shrink_scale.len() as u32);
            let u = match &self.film {
                // A world-space field: the same wherever the triangles are.
                Some(film) => {
                    let c = face_points(mesh, f)
                        .iter()
                        .fold([0.0; 3], |a, p| v3::add(a, *p));
                    let spacing = crate::sim::film::NOISE_SPACING * film.cell;
                    crate::sim::film::value_noise(params.seed, v3::scale(c, 1.0 / (3.0 * spacing)))
                }
                None => hash_unit(params.seed, u64::from(mesh.face_source(f))),
            };
            self.shrink_scale.push(1.0 + params.noise * u);
        }
        if let Some(film) = &mut self.film {
            film.grow(mesh.n_vertices());
        }
    }
}

/// Run the crack simulation on `mesh` (edited in place) under uniform
/// shrinkage only.
///
/// # Errors
/// An invalid parameter (message names it), or a broken mesh invariant.
pub fn run(
    mesh: &mut SimMesh,
    params: &SimParams,
    observer: &mut dyn Observer,
) -> Result<SimReport, SimError> {
    run_with(mesh, params, None, observer)
}

/// Run the crack simulation on `mesh` (edited in place), with a stress
/// field's initial stress and evolution (per face of `mesh` as given) on top
/// of the parameters' uniform shrinkage.
///
/// # Errors
/// An invalid parameter (message names it), a field that does not fit the
/// mesh, or a broken mesh invariant.
pub fn run_with(
    mesh: &mut SimMesh,
    params: &SimParams,
    field: Option<&StressField>,
    observer: &mut dyn Observer,
) -> Result<SimReport, SimError> {
    if params.model == Model::Springs {
        if field.is_some() {
            return Err(SimError::Param(
                "stress terms do not apply to model = \"springs\" (its load is the drying of the springs)".into(),
            ));
        }
        return crate::sim::springs::run(mesh, params, observer);
    }
    let (mut st, mut report) = start(mesh, params, field)?;
    let resolved;
    let params = if st.film.is_none() && params.integrator == Integrator::Auto {
        let (integrator, why) = resolve_integrator(mesh, &st, params);
        report.integrator = integrator.name();
        report.integrator_reason = why;
        resolved = SimParams {
            integrator,
            ..params.clone()
        };
        &resolved
    } else {
        report.integrator_reason = if st.film.is_some() {
            "a film (cell size) is always solved for equilibrium".into()
        } else {
            "asked for".into()
        };
        params
    };
    let per_round_cap = if params.max_cracks_per_round > 0 {
        params.max_cracks_per_round
    } else if st.film.is_some() {
        // A film's shadows keep new cracks apart within a round, so it
        // can take more of them between two solves.
        (mesh.n_vertices() / 50).max(16)
    } else {
        (mesh.n_vertices() / 100).max(16)
    };
    report.energy[0] = energy(&st.els, &st.stress);
    observe(observer, mesh, &st, &report);
    let mut queue = FailureQueue::new();
    let mut loaded = 0.0; // time the load has acted so far
    let mut hold = false; // hold the load this round (the last one hit the cap)
    let mut g: Vec<[f64; 3]> = Vec::new();
    let rules = crack_rules(params);
    report.stopped = format!("reached max_rounds ({})", params.max_rounds);
    for round in 0..params.max_rounds {
        // ---- relax, with the load increasing unless held or complete
        let loading = !hold && loaded < params.load_time;
        let fans = relax_round(
            mesh,
            &mut st,
            params,
            &mut g,
            loading,
            &mut loaded,
            &mut report,
            None,
        )?;
        report.rounds = round + 1;
        if let Some(film) = &mut st.film {
            film.new_round();
        }
        if params.relaxation == Relaxation::EigenDiffusion && st.frozen.is_none() {
            let fz: Vec<Sym3> = (0..mesh.n_vertices())
                .into_par_iter()
                .map(|v| separation_tensor(mesh, &st.els, &st.stress, VertexId(v as u32)))
                .collect();
            st.frozen = Some(fz);
        }
        // ---- queue every failing node
        let sep = separations(mesh, &fans, &st, params.toughness);
        for (v, val) in sep.iter().enumerate() {
            queue.set(v as u32, *val, params.toughness);
        }
        // ---- crack while the top fails
        let mut cracked_this_round = 0;
        // With `to-end`, the tips of the crack being run come first.
        let mut follow: Vec<VertexId> = Vec::new();
        let mut chain = false;
        // The nodes the current crack run touched (eigen-diffusion).
        let mut run_nodes: Vec<VertexId> = Vec::new();
        loop {
            if follow.is_empty() {
                // A crack run ended: diffuse before the next one.
                if chain && params.relaxation == Relaxation::EigenDiffusion {
                    let changed = eigen_diffusion_around(
                        mesh,
                        &mut st,
                        params,
                        &run_nodes,
                        params.diffusion_passes,
                    );
                    for u in changed {
                        let s = node_separation(mesh, &st, VertexId(u));
                        queue.set(u, queue_value(s, params.toughness), params.toughness);
                    }
                }
                run_nodes.clear();
                chain = false;
            }
            // The round's cap ends a round between crack runs, never
            // inside one.
            if report.cracks >= params.max_cracks
                || (follow.is_empty() && cracked_this_round >= per_round_cap)
            {
                break;
            }
            let v = match follow.pop() {
                Some(v) => v,
                None => match queue.pop() {
                    Some((v, _)) => VertexId(v),
                    None => break,
                },
            };
            let (val, dir) = node_separation(mesh, &st, v).max_eigen();
            if val.is_nan() || val <= params.toughness {
                continue;
            }
            let run = st.film.as_mut().map_or(0, |film| film.run_at(v));
            let ev = crack_node_avoiding(mesh, v, dir, &rules, &|m, w| {
                crowded_junction(m, &st.crack_degree, w)
            })
            .map_err(SimError::Mesh)?;
            st.residual[v.idx()] = Sym3::ZERO;
            if let Some(fz) = &mut st.frozen {
                // The crack releases the node's failing component.
                let raw = fz[v.idx()];
                let (l, e) = raw.max_eigen();
                if l > 0.0 {
                    fz[v.idx()] = raw - Sym3::m(e) * l;
                }
            }
            if !apply_event(mesh, &mut st, params, &mut report, &ev) {
                continue;
            }
            if let Some(film) = &mut st.film {
                let ends: Vec<VertexId> = ev.segments.iter().flat_map(|&(a, b)| [a, b]).collect();
                film.mark_around(mesh, &ends, run);
            }
            cracked_this_round += 1;
            chain = true;
            if params.propagation == Propagation::ToEnd {
                follow.extend(ev.segments.iter().map(|&(_, tip)| tip).filter(|&tip| {
                    !mesh.is_boundary_vertex(tip)
                        || crate::sim::crack::crack_directions(mesh, tip).len() == 1
                }));
            } else if params.relaxation == Relaxation::EigenDiffusion {
                // Each crack is its own run.
                follow.clear();
            }
            // Residual propagation to the new crack tips.
            let residual = val - params.toughness + params.residual_constant;
            for &(_, tip) in &ev.segments {
                if !mesh.is_boundary_vertex(tip)
                    || crate::sim::crack::crack_directions(mesh, tip).len() == 1
                {
                    st.residual[tip.idx()] += Sym3::m(dir) * (params.alpha * residual);
                }
            }
            // New and nearby nodes get their separation immediately.
            for n in touched_nodes(mesh, &ev) {
                if params.relaxation == Relaxation::EigenDiffusion {
                    run_nodes.push(n);
                }
                let s = node_separation(mesh, &st, n);
                queue.set(n.0, queue_value(s, params.toughness), params.toughness);
            }
        }
        hold = cracked_this_round >= per_round_cap;
        observer.round(
            round + 1,
            params.max_rounds,
            report.cracks,
            report.relax_steps,
        );
        observe(observer, mesh, &st, &report);
        if report.cracks >= params.max_cracks {
            report.stopped = format!("reached max_cracks ({})", params.max_cracks);
            break;
        }
        let load_done = loaded >= params.load_time;
        if cracked_this_round == 0 && load_done {
            report.stopped = "nothing fails any more".into();
            break;
        }
    }
    if params.finish {
        let t = std::time::Instant::now();
        let mut fin = finish_cracks(mesh, &mut st, params, &mut g, &mut report, observer)?;
        fin.seconds = t.elapsed().as_secs_f64();
        report.finish = Some(fin);
    }
    report.energy[1] = energy(&st.els, &st.stress);
    report.triangles[1] = mesh.n_faces();
    report.nodes[1] = mesh.n_vertices();
    report.displacement = st.displacement;
    report.crack_time = st.crack_time;
    report.diffusion_work = st.diffusion_work;
    Ok(report)
}

/// The cracking rules: the pipeline's, or with `remesh = false` ones that
/// always snap to the existing edge nearest the crack plane.
fn crack_rules(params: &SimParams) -> CrackRules {
    if params.remesh {
        params.rules
    } else {
        CrackRules {
            theta1: std::f64::consts::PI,
            ..params.rules
        }
    }
}

/// Eigen-diffusion passes (see [`Relaxation::EigenDiffusion`]): each node
/// keeps `1 - f` of its largest separation eigenvalue (when positive) and
/// shares `f` equally among its neighbours; the change is added to the
/// node's residual along its eigenvector, so the crack directions stay.
#[cfg(test)]
fn eigen_diffusion(mesh: &SimMesh, st: &mut State, params: &SimParams) {
    let all: Vec<VertexId> = mesh.vertices().collect();
    eigen_diffusion_around(mesh, st, params, &all, 0);
}

/// The neighbours of `v` (sorted, without `v`).
fn vertex_neighbours(mesh: &SimMesh, v: u32) -> Vec<u32> {
    let mut nb: Vec<u32> = mesh
        .vertex_faces(VertexId(v))
        .flat_map(|fc| mesh.face_vertices(fc))
        .map(|u| u.0)
        .filter(|&u| u != v)
        .collect();
    nb.sort_unstable();
    nb.dedup();
    nb
}

/// Eigen-diffusion after a crack run, kept local: the nodes within
/// `rings` rings of `seeds` (the nodes the run touched) share, as
/// [`eigen_diffusion`] describes, and their neighbours receive; the rest of
/// the mesh is left as it is, so the work per run does not grow with the
/// mesh (a sweep of the whole mesh after every run made the snapping
/// variant quadratic). Returns the nodes whose separation changed, sorted.
fn eigen_diffusion_around(
    mesh: &SimMesh,
    st: &mut State,
    params: &SimParams,
    seeds: &[VertexId],
    rings: usize,
) -> Vec<u32> {
    let f = params.diffusion_fraction;
    if f <= 0.0 || seeds.is_empty() {
        return Vec::new();
    }
    // The sharing region: `rings` rings around the seeds.
    let mut sources: Vec<u32> = seeds.iter().map(|v| v.0).collect();
    sources.sort_unstable();
    sources.dedup();
    let mut inside: std::collections::HashSet<u32> = sources.iter().copied().collect();
    let mut frontier = sources.clone();
    for _ in 0..rings {
        let mut next = Vec::new();
        for &v in &frontier {
            for u in vertex_neighbours(mesh, v) {
                if inside.insert(u) {
                    next.push(u);
                }
            }
        }
        if next.is_empty() {
            break;
        }
        sources.extend_from_slice(&next);
        frontier = next;
    }
    sources.sort_unstable();
    let neighbours: Vec<Vec<u32>> = sources
        .iter()
        .map(|&v| vertex_neighbours(mesh, v))
        .collect();
    // Every node that may change: the sources and their neighbours.
    let mut nodes: Vec<u32> = sources
        .iter()
        .copied()
        .chain(neighbours.iter().flatten().copied())
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    let at: std::collections::HashMap<u32, usize> =
        nodes.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    st.diffusion_work += params.diffusion_passes * nodes.len();
    for _ in 0..params.diffusion_passes {
        let eig: Vec<(f64, [f64; 3])> = nodes
            .par_iter()
            .map(|&v| node_separation(mesh, st, VertexId(v)).max_eigen())
            .collect();
        let mut next: Vec<f64> = eig.iter().map(|(l, _)| *l).collect();
        for (k, &v) in sources.iter().enumerate() {
            let (l, _) = eig[at[&v]];
            if l.is_nan() || l <= 0.0 || neighbours[k].is_empty() {
                continue;
            }
            let share = f * l;
            next[at[&v]] -= share;
            let each = share / neighbours[k].len() as f64;
            for &u in &neighbours[k] {
                next[at[&u]] += each;
            }
        }
        for (i, &v) in nodes.iter().enumerate() {
            let (l, dir) = eig[i];
            let d = next[i] - l;
            if d != 0.0 && l.is_finite() {
                st.residual[v as usize] += Sym3::m(dir) * d;
            }
        }
    }
    nodes
}

/// The start state of a run: parameters and field checked, elements
/// built, the report begun.
fn start(
    mesh: &SimMesh,
    params: &SimParams,
    field: Option<&StressField>,
) -> Result<(State, SimReport), SimError> {
    params.validate().map_err(SimError::Param)?;
    if let Some(f) = field {
        if f.init.len() != mesh.n_faces()
            || f.evolve.len() != mesh.n_faces()
            || !(f.separation_scale.is_empty() || f.separation_scale.len() == mesh.n_faces())
        {
            return Err(SimError::Param(format!(
                "the stress field has {} faces, the mesh {}",
                f.init.len(),
                mesh.n_faces()
            )));
        }
    }
    let film = params
        .is_film()
        .then(|| params.cell_size_for(mesh))
        .flatten()
        .map(crate::sim::film::Film::new);
    let unit = match &film {
        Some(f) => f.length,
        None => mesh.mean_edge_length(),
    };
    if !(unit.is_finite() && unit > 0.0) {
        return Err(SimError::Param(
            "the mesh has no edge of positive length".into(),
        ));
    }
    let mut report = SimReport {
        triangles: [mesh.n_faces(), 0],
        nodes: [mesh.n_vertices(), 0],
        length_unit: unit,
        cell_size: film.as_ref().map(|f| f.cell),
        stable_dt: f64::INFINITY,
        integrator: if film.is_some() {
            "film-equilibrium"
        } else {
            params.integrator.name()
        },
        ..Default::default()
    };
    // Elements in normalised units.
    let clamp = Elements::clamp_threshold(mesh, params.clamp_factor) * unit;
    let mut st = State {
        els: Elements {
            elements: Vec::new(),
            clamp,
        },
        stress: field.map(|f| f.init.clone()).unwrap_or_default(),
        residual: Vec::new(),
        frozen: None,
        fixed: mesh
            .vertices()
            .map(|v| {
                (params.fixed_boundary && mesh.is_boundary_vertex(v))
                    || State::in_fixed_group(mesh, params, v)
            })
            .collect(),
        shrink_scale: Vec::new(),
        evolve: field.map(|f| f.evolve.clone()).unwrap_or_default(),
        sep_scale: field
            .map(|f| f.separation_scale.clone())
            .unwrap_or_default(),
        displacement: Vec::new(),
        crack_time: Vec::new(),
        crack_degree: Vec::new(),
        unit,
        corner: Vec::new(),
        warm: Vec::new(),
        diffusion_work: 0,
        cache: RoundCache::default(),
        implicit: ImplicitScratch::default(),
        film,
    };
    st.els.elements = (0..mesh.n_faces())
        .into_par_iter()
        .map(|f| st.element(mesh, FaceId(f as u32)))
        .collect();
    st.grow(mesh, params);
    // The rounds' working memory, paged in with the rest of the state (it
    // lives as long as the state; a fresh allocation would otherwise be
    // paged in during the first round).
    let (nf, nv) = (mesh.n_faces(), mesh.n_vertices());
    crate::sim::implicit::touch(&mut st.corner, 3 * nf);
    if st.film.is_some()
        || matches!(
            params.integrator,
            Integrator::BackwardEuler | Integrator::Equilibrium
        )
    {
        let b = &mut st.implicit;
        b.cg.reserve(nf, nv);
        for v in [&mut b.rhs, &mut b.r, &mut b.ax] {
            crate::sim::implicit::touch(v, nv);
        }
    }
    report.energy[0] = energy(&st.els, &st.stress);
    Ok((st, report))
}

/// What [`relax_only`] measured.
#[derive(Clone, Debug, Default)]
pub struct Relaxed {
    /// Per-face stress at the end.
    pub stress: Vec<Sym3>,
    /// Per-face area (normalised units; 0 for faces without element).
    pub areas: Vec<f64>,
    /// The run's report (time, steps, phases).
    pub report: SimReport,
    /// Wall-clock seconds of the relaxation rounds alone (setting up the
    /// elements and the starting stress not counted).
    pub seconds: f64,
}

impl Relaxed {
    /// Area-weighted relative L2 difference of the stress field from
    /// `reference`: `sqrt(sum A |S - S_ref|^2 / sum A |S_ref|^2)`.
    pub fn error_against(&self, reference: &Relaxed) -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for ((s, r), a) in self
            .stress
            .iter()
            .zip(&reference.stress)
            .zip(&reference.areas)
        {
            num += a * (*s - *r).frobenius_sq();
            den += a * r.frobenius_sq();
        }
        if den > 0.0 {
            (num / den).sqrt()
        } else {
            num.sqrt()
        }
    }
}

/// Relaxation alone, no cracking: `rounds` rounds of `params.relax_time`
/// from the start state (the load acting for `params.load_time`), by
/// `params.integrator`. For comparing integrators at the same relaxation
/// time.
pub fn relax_only(
    mesh: &SimMesh,
    params: &SimParams,
    field: Option<&StressField>,
    rounds: usize,
) -> Result<Relaxed, SimError> {
    let (mut st, mut report) = start(mesh, params, field)?;
    let (integrator, why) = resolve_integrator(mesh, &st, params);
    report.integrator = integrator.name();
    report.integrator_reason = why;
    let params = &SimParams {
        integrator,
        ..params.clone()
    };
    let mut loaded = 0.0;
    let mut g = Vec::new();
    crate::sim::implicit::touch(&mut g, mesh.n_vertices());
    let clock = std::time::Instant::now();
    for round in 0..rounds {
        relax_round(
            mesh,
            &mut st,
            params,
            &mut g,
            true,
            &mut loaded,
            &mut report,
            None,
        )?;
        report.rounds = round + 1;
    }
    let seconds = clock.elapsed().as_secs_f64();
    report.energy[1] = energy(&st.els, &st.stress);
    let areas = st
        .els
        .elements
        .iter()
        .map(|e| e.as_ref().map_or(0.0, |e| e.area))
        .collect();
    Ok(Relaxed {
        stress: st.stress,
        areas,
        report,
        seconds,
    })
}

/// One relaxation round of `params.relax_time` (or `relax_steps` steps),
/// with the load acting while `loading` (and `loaded` below the load time),
/// by `params.integrator`. Records the round's [`Phase`].
#[allow(clippy::too_many_arguments)]
fn relax_round(
    mesh: &SimMesh,
    st: &mut State,
    params: &SimParams,
    g: &mut Vec<[f64; 3]>,
    loading: bool,
    loaded: &mut f64,
    report: &mut SimReport,
    seeds: Option<&[VertexId]>,
) -> Result<Arc<Fans>, SimError> {
    let mut cache = std::mem::take(&mut st.cache);
    cache.refresh(mesh, &st.els, params.bonded);
    let fans = cache.fans();
    // Local relaxation (no load): only the region around `seeds` moves.
    let region = match seeds {
        Some(seeds) if !loading && params.finish_rings > 0 => {
            Some(Region::around(&fans, seeds, params.finish_rings))
        }
        _ => None,
    };
    // The force at the current stress is known only after a global
    // backward-Euler round, for the next one.
    let mut known_force = cache.force.take();
    // The force at the end of the round, when the round's scheme gives it.
    let mut end_force: Option<Vec<[f64; 3]>> = None;
    // The energy at the end of the round, when the round's last pass gave it.
    let mut end_energy: Option<f64> = None;
    let normals = std::mem::take(&mut cache.normals);
    // Only the paper's scheme is checked for divergence against it.
    let energy_before = if params.integrator == Integrator::PaperEuler {
        energy(&st.els, &st.stress)
    } else {
        0.0
    };
    let mut phase = Phase::default();
    let load_for = |loaded: &mut f64, dt: f64| {
        let load_dt = if loading {
            dt.min(params.load_time - *loaded).max(0.0)
        } else {
            0.0
        };
        *loaded += load_dt;
        Load {
            dt: load_dt,
            shrink_rate: params.shrink_rate,
        }
    };
    let steps_for = |dt: f64| {
        if params.relax_steps > 0 {
            (params.relax_steps, dt)
        } else {
            let n = ((params.relax_time / dt).ceil() as usize).max(1);
            (n, params.relax_time / n as f64)
        }
    };
    // What the error estimate needs: the step and the mobility used.
    let step_dt;
    let mut step_mobility: Vec<f64> = Vec::new();
    // RKL: the round's step-doubling error estimate, when sampled.
    let mut rkl_estimate: Option<f64> = None;
    if st.film.is_some() {
        let load = load_for(loaded, params.relax_time);
        let (energy, force) = relax_film_round(
            mesh,
            st,
            params,
            &mut cache,
            &fans,
            &normals,
            region.as_ref(),
            load,
            report,
            &mut phase,
        );
        end_energy = Some(energy);
        end_force = Some(force);
        report.time += params.relax_time;
        report.relax_steps += 1;
        phase.steps = 1;
        step_dt = 0.0;
    } else if params.relaxation == Relaxation::EigenDiffusion {
        // No tensor relaxation: the round only adds its load, and the
        // separation it adds goes into the frozen tensors.
        let load = load_for(loaded, params.relax_time);
        let frozen_before: Option<Vec<Sym3>> = (load.dt > 0.0 && st.frozen.is_some()).then(|| {
            (0..mesh.n_vertices())
                .into_par_iter()
                .map(|v| separation_tensor(mesh, &st.els, &st.stress, VertexId(v as u32)))
                .collect()
        });
        add_load(&mut st.stress, &st.els, &st.shrink_scale, &st.evolve, load);
        if let (Some(before), Some(fz)) = (frozen_before, st.frozen.as_mut()) {
            let (els, stress) = (&st.els, &st.stress);
            let after: Vec<Sym3> = (0..mesh.n_vertices())
                .into_par_iter()
                .map(|v| separation_tensor(mesh, els, stress, VertexId(v as u32)))
                .collect();
            for ((f, a), b) in fz.iter_mut().zip(&after).zip(&before) {
                *f += *a - *b;
            }
        }
        corner_forces(&st.els, &st.stress, &mut st.corner);
        report.time += params.relax_time;
        step_dt = 0.0;
    } else if matches!(
        params.integrator,
        Integrator::BackwardEuler | Integrator::Equilibrium
    ) {
        let dt_req = if params.relax_dt > 0.0 {
            params.relax_dt
        } else {
            params.relax_time
        };
        // Equilibrium: one solve per round with a step so long that
        // `(I + dt K) du = dt f` is `K du = f` to working precision; the
        // round's load goes in at once.
        let (steps, dt, solve_dt) = if params.integrator == Integrator::Equilibrium {
            (1, params.relax_time, EQUILIBRIUM_DT)
        } else {
            let (n, dt) = steps_for(dt_req);
            (n, dt, dt)
        };
        // Outside a local region every node is held.
        let held: Vec<bool>;
        let fixed: &[bool] = match &region {
            Some(r) => {
                held = st
                    .fixed
                    .iter()
                    .zip(&r.inside)
                    .map(|(&f, &i)| f || !i)
                    .collect();
                &held
            }
            None => &st.fixed,
        };
        let op = crate::sim::implicit::Operator {
            fans: &fans,
            els: &st.els,
            normals: &normals,
            fixed,
            interface: &[],
        };
        // The preconditioner, kept for the whole mesh's system.
        let local_pre: Vec<Sym3>;
        let pre: &[Sym3] = if region.is_some() {
            local_pre = op.block_preconditioner(solve_dt);
            &local_pre
        } else {
            if cache.pre.as_ref().is_none_or(|(d, _)| *d != solve_dt) {
                cache.pre = Some((solve_dt, op.block_preconditioner(solve_dt)));
            }
            &cache.pre.as_ref().expect("set").1
        };
        let shifted = crate::sim::implicit::Shifted {
            op: &op,
            dt: solve_dt,
            pre,
            tol: params.tolerance,
            max_iter: 10_000,
        };
        // A global backward-Euler round carries the force from step to step
        // and round to round (each stress update writes the corner forces
        // at the new stress; one gather gives the force), builds each
        // right-hand side from it and the force of a unit of load, and
        // starts each solve from the best combination of the last
        // solutions, whose products `A x = x + rhs - dt f_new` are exact:
        // no product beyond the solver's own.
        let carry = region.is_none() && params.integrator == Integrator::BackwardEuler;
        let mut bufs = std::mem::take(&mut st.implicit);
        let mut stress = std::mem::take(&mut st.stress);
        // The force at the current stress, and the force of a unit of
        // load time.
        let wants_load = carry && loading && params.load_time > *loaded;
        let mut force = None;
        if carry {
            force = Some(
                known_force
                    .take()
                    .unwrap_or_else(|| op.forces(&stress, &mut bufs.cg.corner)),
            );
            if wants_load && cache.load_force.is_none() {
                let unit = Load {
                    dt: 1.0,
                    shrink_rate: params.shrink_rate,
                };
                let (scale, evolve) = (&st.shrink_scale, &st.evolve);
                cache.load_force = Some(op.forces_with(
                    |f, el| load_increment(scale, evolve, f, el, unit),
                    &mut bufs.cg.corner,
                ));
            }
        }
        let load_force: Option<&[[f64; 3]]> = if wants_load {
            cache.load_force.as_deref()
        } else {
            None
        };
        if carry && cache.history.as_ref().is_none_or(|(d, _)| *d != solve_dt) {
            cache.history = Some((solve_dt, Vec::new()));
        }
        // Start each solve from the last one's solution (new nodes at 0).
        let mut x = std::mem::take(&mut st.warm);
        for _ in 0..steps {
            let load = load_for(loaded, dt);
            add_load(&mut stress, &st.els, &st.shrink_scale, &st.evolve, load);
            let rhs = &mut bufs.rhs;
            match (&force, load_force) {
                (Some(f), Some(lf)) if load.dt > 0.0 => {
                    rhs.resize(f.len(), [0.0; 3]);
                    rhs.par_iter_mut()
                        .zip(f.par_iter().zip(lf.par_iter()))
                        .for_each(|(b, (f, l))| {
                            *b = v3::scale(v3::add(*f, v3::scale(*l, load.dt)), solve_dt)
                        });
                }
                (Some(f), _) => {
                    rhs.resize(f.len(), [0.0; 3]);
                    rhs.par_iter_mut()
                        .zip(f.par_iter())
                        .for_each(|(b, f)| *b = v3::scale(*f, solve_dt));
                }
                (None, _) => {
                    *rhs = op.forces(&stress, &mut bufs.cg.corner);
                    rhs.par_iter_mut()
                        .for_each(|b| *b = v3::scale(*b, solve_dt));
                }
            }
            let rhs = &bufs.rhs;
            let history = cache.history.as_mut().filter(|_| carry).map(|h| &mut h.1);
            let started = history.as_deref().is_some_and(|h| {
                crate::sim::implicit::subspace_start(h, rhs, &mut x, &mut bufs.ax)
            });
            let ax = started.then_some(&bufs.ax[..]);
            let cg = shifted.solve(rhs, &mut x, ax, &mut bufs.r, &mut bufs.cg);
            phase.cg_iterations += cg.iterations;
            if !cg.converged {
                report.cg_unconverged += 1;
            }
            phase.cg_residual = phase.cg_residual.max(cg.relative_residual);
            // The stress update also writes the corner forces at the new
            // stress into `st.corner` and gives the energy.
            end_energy = Some(crate::sim::relax::apply_virtual_displacement_energy(
                &fans,
                &st.els,
                &mut stress,
                &mut st.corner,
                &x,
            ));
            let unit = st.unit;
            match (history, &mut force) {
                (Some(history), Some(f)) => {
                    // One pass over the nodes: the displacement, the force
                    // at the new stress (gathered afresh, never carried
                    // over from the solver's residual, which drifts), and
                    // `(x, A x)` for the history, with `A x = x + dt K x =
                    // x + rhs - dt f_new` exact (the oldest entry's storage
                    // reused when the history is full).
                    let (mut hx, mut hax) = if history.len() == HISTORY {
                        history.remove(0)
                    } else {
                        (Vec::new(), Vec::new())
                    };
                    hx.resize(x.len(), [0.0; 3]);
                    hax.resize(x.len(), [0.0; 3]);
                    let corner = &st.corner;
                    st.displacement
                        .par_iter_mut()
                        .zip(f.par_iter_mut())
                        .zip(hx.par_iter_mut().zip(hax.par_iter_mut()))
                        .zip(x.par_iter().zip(rhs.par_iter()))
                        .enumerate()
                        .with_min_len(512)
                        .for_each(|(n, (((d, f), (hx, hax)), (x, b)))| {
                            *d = v3::add(*d, v3::scale(*x, unit));
                            *f = op.project(n, gather(&fans, corner, n));
                            *hx = *x;
                            *hax = v3::add(*x, v3::sub(*b, v3::scale(*f, solve_dt)));
                        });
                    history.push((hx, hax));
                }
                _ => st
                    .displacement
                    .par_iter_mut()
                    .zip(x.par_iter())
                    .for_each(|(d, x)| *d = v3::add(*d, v3::scale(*x, unit))),
            }
        }
        st.stress = stress;
        st.warm = x;
        st.implicit = bufs;
        // `st.corner` holds the corner forces at the final stress (the last
        // stress update wrote them).
        if carry {
            end_force = force;
        }
        step_dt = if params.integrator == Integrator::Equilibrium {
            0.0
        } else {
            dt
        };
        report.time += steps as f64 * dt;
        report.relax_steps += steps;
        phase.steps = steps;
    } else if params.integrator == Integrator::Rkl {
        let bounds = cache
            .bounds
            .take()
            .unwrap_or_else(|| node_bounds(&fans, &st.els));
        let stiffest = bounds.iter().copied().fold(0.0, f64::max);
        let dt_fe = if stiffest > 0.0 {
            1.9 / stiffest
        } else {
            f64::INFINITY
        };
        report.stable_dt = report.stable_dt.min(dt_fe);
        let supers = if params.relax_steps > 0 {
            params.relax_steps
        } else if params.relax_dt > 0.0 {
            ((params.relax_time / params.relax_dt).ceil() as usize).max(1)
        } else {
            1
        };
        let tau = params.relax_time / supers as f64;
        match &region {
            Some(r) => region_corner_forces(&st.els, &st.stress, &mut st.corner, r),
            None => corner_forces(&st.els, &st.stress, &mut st.corner),
        }
        // Error estimate by step doubling on sampled rounds: the same
        // round again from the same start in super-steps of half the
        // length; for a second-order method the error of the result is
        // about 4/3 of the difference.
        let sampled = report.phases.len() % RKL_ESTIMATE_EVERY == 0;
        let start = sampled.then(|| {
            (
                st.stress.clone(),
                st.displacement.clone(),
                st.corner.clone(),
                *loaded,
            )
        });
        let mut scratch = RklScratch::default();
        let mut run = |st: &mut State, loaded: &mut f64, supers: usize, tau: f64| {
            let (stages, mobility) = rkl_plan(&bounds, dt_fe, tau);
            let coeffs = crate::sim::relax::Rkl2::new(stages);
            for _ in 0..supers {
                let load = load_for(loaded, tau);
                // The load as a constant rate over the super-step.
                let rate = Load {
                    dt: load.dt / tau,
                    shrink_rate: load.shrink_rate,
                };
                rkl_super_step(
                    &fans,
                    &normals,
                    &mobility,
                    st,
                    tau,
                    &coeffs,
                    rate,
                    region.as_ref(),
                    &mut scratch,
                );
            }
            stages
        };
        let stages = run(st, loaded, supers, tau);
        if let Some((stress, displacement, corner, mut half_loaded)) = start {
            let result = (
                std::mem::replace(&mut st.stress, stress),
                std::mem::replace(&mut st.displacement, displacement),
                std::mem::replace(&mut st.corner, corner),
            );
            run(st, &mut half_loaded, 2 * supers, tau / 2.0);
            let (mut diff, mut norm) = (0.0, 0.0);
            for ((el, a), b) in st.els.elements.iter().zip(&result.0).zip(&st.stress) {
                if let Some(el) = el {
                    diff += el.area * (*a - *b).frobenius_sq();
                    norm += el.area * a.frobenius_sq();
                }
            }
            rkl_estimate = Some(if norm > 0.0 {
                4.0 / 3.0 * (diff / norm).sqrt()
            } else {
                0.0
            });
            (st.stress, st.displacement, st.corner) = result;
        }
        report.time += params.relax_time;
        report.relax_steps += supers * stages;
        phase.steps = supers * stages;
        step_dt = tau;
        cache.bounds = Some(bounds);
    } else {
        let bounds = cache
            .bounds
            .take()
            .unwrap_or_else(|| node_bounds(&fans, &st.els));
        let stable = |b: f64| if b > 0.0 { 1.9 / b } else { f64::INFINITY };
        let mut dt_max = match params.integrator {
            Integrator::LocalEuler => {
                // The median bound (selection gives the sorted order's value).
                let mut sorted: Vec<f64> = bounds.iter().copied().filter(|b| *b > 0.0).collect();
                let mid = sorted.len() / 2;
                if sorted.is_empty() {
                    f64::INFINITY
                } else {
                    stable(*sorted.select_nth_unstable_by(mid, f64::total_cmp).1)
                }
            }
            _ => stable(bounds.iter().copied().fold(0.0, f64::max)),
        };
        report.stable_dt = report.stable_dt.min(dt_max);
        if params.integrator == Integrator::PaperEuler {
            dt_max = params.relax_dt;
        } else if params.relax_dt > 0.0 {
            if params.relax_dt > dt_max {
                report.dt_limited_rounds += 1;
            }
            dt_max = dt_max.min(params.relax_dt);
        }
        if !dt_max.is_finite() {
            dt_max = params.relax_time; // no element: nothing to relax
        }
        let mobility: Vec<f64> = match params.integrator {
            Integrator::LocalEuler => bounds
                .iter()
                .map(|&b| {
                    if b * dt_max > 1.9 {
                        1.9 / (b * dt_max)
                    } else {
                        1.0
                    }
                })
                .collect(),
            _ => vec![1.0; bounds.len()],
        };
        let (steps, dt) = steps_for(dt_max);
        match &region {
            // Outside the region the corner forces are still those of the
            // last round (stress there has not changed since; faces that
            // cracks split or added are in the region).
            Some(r) => region_corner_forces(&st.els, &st.stress, &mut st.corner, r),
            None => corner_forces(&st.els, &st.stress, &mut st.corner),
        }
        if let Some(r) = &region {
            g.clear();
            g.resize(fans.n_vertices(), [0.0; 3]);
            for _ in 0..steps {
                relax_region(&fans, &normals, &mobility, st, dt, r, g);
            }
        } else {
            for _ in 0..steps {
                let load = load_for(loaded, dt);
                relax_and_evolve(&fans, &normals, &mobility, st, dt, load, g);
            }
        }
        report.time += steps as f64 * dt;
        report.relax_steps += steps;
        phase.steps = steps;
        step_dt = dt;
        step_mobility = mobility;
        cache.bounds = Some(bounds);
    }
    // The round's phase: energy and residual force at its end (`st.corner`
    // holds the corner forces at the final stress: the explicit steps'
    // fused update leaves them there, the implicit branch computes them;
    // a global backward-Euler round has the force from its solves).
    let op = crate::sim::implicit::Operator {
        fans: &fans,
        els: &st.els,
        normals: &normals,
        fixed: &st.fixed,
        interface: &[],
    };
    let carried = end_force.is_some();
    let force: Vec<[f64; 3]> = end_force.unwrap_or_else(|| {
        let corner = &st.corner;
        (0..fans.n_vertices())
            .into_par_iter()
            .map(|n| op.project(n, gather(&fans, corner, n)))
            .collect()
    });
    phase.residual = crate::sim::implicit::dot(&force, &force).sqrt();
    phase.energy = end_energy.unwrap_or_else(|| energy(&st.els, &st.stress));
    // Error estimate of the round (relative, like the study's error): a
    // first-order step of `dt` errs by `dt^2 / 2 |u''|` with `u'' = M K M f`
    // (M the mobility), which moves the stress by `B u''`; the round's
    // steps add up. Its stress norm is `sqrt(u''^T K u'')` against
    // `|S| = sqrt(2 E)`. Equilibrium rounds report their solve's residual.
    // It costs two stiffness products, so it is sampled: the first round
    // and every `ESTIMATE_EVERY`-th after it (NaN, `null` in JSON, between).
    let sampled = report.phases.len() % ESTIMATE_EVERY == 0;
    phase.error_estimate = if params.integrator == Integrator::Rkl {
        rkl_estimate.unwrap_or(f64::NAN)
    } else if !sampled {
        f64::NAN
    } else if step_dt > 0.0 && phase.energy > 0.0 {
        let mob = |n: usize| step_mobility.get(n).copied().unwrap_or(1.0);
        // The implicit rounds' working memory (kept only by them).
        let mut bufs = std::mem::take(&mut st.implicit);
        let ImplicitScratch {
            cg, rhs: mf, r: w, ..
        } = &mut bufs;
        let n = force.len();
        mf.clear();
        mf.extend(force.iter().enumerate().map(|(n, f)| v3::scale(*f, mob(n))));
        w.resize(n, [0.0; 3]);
        op.apply(mf, &mut cg.corner, w);
        w.iter_mut()
            .enumerate()
            .for_each(|(n, x)| *x = v3::scale(*x, mob(n)));
        // `w . K w` from the strain of `w`: no second product.
        let stress_norm = op.energy_norm_sq(w).max(0.0).sqrt();
        if matches!(
            params.integrator,
            Integrator::BackwardEuler | Integrator::Equilibrium
        ) {
            st.implicit = bufs;
        }
        phase.steps as f64 * 0.5 * step_dt * step_dt * stress_norm / (2.0 * phase.energy).sqrt()
    } else {
        phase.cg_residual
    };
    phase.time = report.time;
    report.phases.push(phase);
    cache.force = carried.then_some(force);
    cache.normals = normals;
    st.cache = cache;
    if !phase.energy.is_finite()
        || (params.integrator == Integrator::PaperEuler
            && !loading
            && phase.energy > energy_before * (1.0 + 1e-6) + 1e-300)
    {
        return Err(SimError::Diverged(format!(
            "relaxation diverged with integrator {} (energy {:.3e} -> {:.3e}); relax_dt {} is above the stable step {:.3e}: use a smaller relax_dt or another integrator",
            params.integrator.name(),
            energy_before,
            phase.energy,
            params.relax_dt,
            report.stable_dt
        )));
    }
    Ok(fans)
}

/// One relaxation round of a bonded film ([`crate::sim::film`]): the
/// round's load, then the equilibrium `(K + k M) du = f - k M u` of the
/// film tied to its rest position, by conjugate gradients (the interface
/// term makes the system positive definite, so the solve converges in few
/// iterations whatever the triangles' shapes). Only the nodes of `region`
/// move when given. Returns the stress energy and the residual node force
/// (elastic plus interface) at the end.
#[allow(clippy::too_many_arguments)]
fn relax_film_round(
    mesh: &SimMesh,
    st: &mut State,
    params: &SimParams,
    cache: &mut RoundCache,
    fans: &Fans,
    normals: &[[f64; 3]],
    region: Option<&Region>,
    load: Load,
    report: &mut SimReport,
    phase: &mut Phase,
) -> (f64, Vec<[f64; 3]>) {
    let mut film = st.film.take().expect("a film run");
    film.refresh(mesh.generation(), fans, &st.els);
    add_load(&mut st.stress, &st.els, &st.shrink_scale, &st.evolve, load);
    let held: Vec<bool>;
    let fixed: &[bool] = match region {
        Some(r) => {
            held = st
                .fixed
                .iter()
                .zip(&r.inside)
                .map(|(&f, &i)| f || !i)
                .collect();
            &held
        }
        None => &st.fixed,
    };
    let op = crate::sim::implicit::Operator {
        fans,
        els: &st.els,
        normals,
        fixed,
        interface: &film.interface,
    };
    let local_pre: Vec<Sym3>;
    let pre: &[Sym3] = if region.is_some() {
        local_pre = op.block_preconditioner(EQUILIBRIUM_DT);
        &local_pre
    } else {
        if cache.pre.as_ref().is_none_or(|(d, _)| *d != EQUILIBRIUM_DT) {
            cache.pre = Some((EQUILIBRIUM_DT, op.block_preconditioner(EQUILIBRIUM_DT)));
        }
        &cache.pre.as_ref().expect("set").1
    };
    // The failure test needs the stress to about 1e-3: a film's solves stop
    // at ten times the backward-Euler tolerance.
    let shifted = crate::sim::implicit::Shifted {
        op: &op,
        dt: EQUILIBRIUM_DT,
        pre,
        tol: (10.0 * params.tolerance).min(0.1),
        max_iter: 10_000,
    };
    let unit = st.unit;
    let mut bufs = std::mem::take(&mut st.implicit);
    // The out-of-balance force: the stress's and the interface's pull
    // back toward the rest position.
    let residual = |op: &crate::sim::implicit::Operator,
                    stress: &[Sym3],
                    displacement: &[[f64; 3]],
                    corner: &mut Vec<[f64; 3]>| {
        let mut f = op.forces(stress, corner);
        f.par_iter_mut().enumerate().for_each(|(n, f)| {
            let tie = v3::scale(displacement[n], op.interface[n] / unit);
            *f = v3::sub(*f, op.project(n, tie));
        });
        f
    };
    let mut rhs = residual(&op, &st.stress, &st.displacement, &mut bufs.cg.corner);
    rhs.par_iter_mut()
        .for_each(|b| *b = v3::scale(*b, EQUILIBRIUM_DT));
    // Each solve starts from rest: a start from the last round's solution
    // is often already at the tolerance's rounding floor, where conjugate
    // gradients stall.
    let mut x = std::mem::take(&mut st.warm);
    x.clear();
    let cg = shifted.solve(&rhs, &mut x, None, &mut bufs.r, &mut bufs.cg);
    phase.cg_iterations += cg.iterations;
    if !cg.converged {
        report.cg_unconverged += 1;
    }
    phase.cg_residual = phase.cg_residual.max(cg.relative_residual);
    let energy = crate::sim::relax::apply_virtual_displacement_energy(
        fans,
        &st.els,
        &mut st.stress,
        &mut st.corner,
        &x,
    );
    st.displacement
        .par_iter_mut()
        .zip(x.par_iter())
        .for_each(|(d, x)| *d = v3::add(*d, v3::scale(*x, unit)));
    let force = residual(&op, &st.stress, &st.displacement, &mut bufs.cg.corner);
    st.warm = x;
    st.implicit = bufs;
    st.film = Some(film);
    (energy, force)
}

/// Add the stress `load` adds in its step to every face (nothing when the
/// load does not act).
fn add_load(stress: &mut [Sym3], els: &Elements, scale: &[f64], evolve: &[Sym3], load: Load) {
    if load.dt <= 0.0 {
        return;
    }
    stress
        .par_iter_mut()
        .zip(els.elements.par_iter())
        .enumerate()
        .for_each(|(f, (s, el))| {
            if let Some(el) = el {
                *s += load_increment(scale, evolve, f, el, load);
            }
        });
}

/// The stress the load adds to face `f` during one step.
#[inline]
fn load_increment(scale: &[f64], evolve: &[Sym3], f: usize, el: &Element, load: Load) -> Sym3 {
    if load.dt <= 0.0 {
        return Sym3::ZERO;
    }
    let k = load.dt * scale[f];
    let mut ds = Sym3::tangent_identity(el.normal, k * load.shrink_rate);
    if let Some(e) = evolve.get(f) {
        ds += *e * k;
    }
    ds
}

/// Book-keeping after `crack_node`: grow the state, fix vertices on fixed
/// borders, record segments and crack times, give split faces their
/// parent's stress and new elements, and settle inserted vertices'
/// displacement. Returns whether the event made a crack.
fn apply_event(
    mesh: &SimMesh,
    st: &mut State,
    params: &SimParams,
    report: &mut SimReport,
    ev: &crate::sim::crack::CrackEvent,
) -> bool {
    st.grow(mesh, params);
    for (&q, &(a, b, border)) in ev.inserted.iter().zip(&ev.inserted_on) {
        // A vertex on a fixed border edge is fixed.
        if border && st.fixed[a.idx()] && st.fixed[b.idx()] && params.fixed_boundary {
            st.fixed[q.idx()] = true;
        }
        // Its displacement is interpolated along the edge it split.
        let (pa, pb, pq) = (mesh.position(a), mesh.position(b), mesh.position(q));
        let l = v3::norm(v3::sub(pb, pa));
        let t = if l > 0.0 {
            (v3::norm(v3::sub(pq, pa)) / l).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let (da, db) = (st.displacement[a.idx()], st.displacement[b.idx()]);
        st.displacement[q.idx()] = v3::add(v3::scale(da, 1.0 - t), v3::scale(db, t));
        if let Some(fz) = &mut st.frozen {
            fz[q.idx()] = fz[a.idx()] * (1.0 - t) + fz[b.idx()] * t;
        }
    }
    if ev.segments.is_empty() {
        return false;
    }
    for (&q, &(a, b, border)) in ev.inserted.iter().zip(&ev.inserted_on) {
        // A vertex inserted on a crack lies on two of its segments.
        let on_crack = border
            && !st.crack_time[a.idx()].is_nan()
            && !st.crack_time[b.idx()].is_nan()
            && ev.segments.iter().any(|&(a, b)| a == q || b == q);
        if on_crack {
            let r = vertex_root(mesh, q).idx();
            st.crack_degree[r] = st.crack_degree[r].saturating_add(2);
        }
    }
    for &(a, b) in &ev.segments {
        for v in [a, b] {
            let r = vertex_root(mesh, v).idx();
            st.crack_degree[r] = st.crack_degree[r].saturating_add(1);
        }
    }
    report.cracks += 1;
    report.crack_length += ev.length;
    report.first_crack_time.get_or_insert(report.time);
    report.segments.extend(
        ev.segments
            .iter()
            .map(|&(a, b)| [mesh.position(a), mesh.position(b)]),
    );
    report
        .segment_times
        .extend(ev.segments.iter().map(|_| report.time));
    // Crack times: the segment ends, then the copies opening made of them.
    for &(a, b) in &ev.segments {
        for x in [a, b] {
            if st.crack_time[x.idx()].is_nan() {
                st.crack_time[x.idx()] = report.time;
            }
        }
    }
    for &(new, orig) in &ev.duplicated {
        if st.crack_time[new.idx()].is_nan() {
            st.crack_time[new.idx()] = st.crack_time[orig.idx()];
        }
    }
    // Children inherit their parent's stress; touched faces get new elements.
    let mut touched: Vec<FaceId> = Vec::new();
    for &(parent, child) in &ev.split_faces {
        st.stress[child.idx()] = st.stress[parent.idx()];
        if !st.evolve.is_empty() {
            st.evolve[child.idx()] = st.evolve[parent.idx()];
        }
        if !st.sep_scale.is_empty() {
            st.sep_scale[child.idx()] = st.sep_scale[parent.idx()];
        }
        touched.push(parent);
        touched.push(child);
    }
    for f in &touched {
        st.els.elements[f.idx()] = st.element(mesh, *f);
    }
    true
}

/// The nodes whose separation a crack event changes: the fans around its
/// segments, its duplicates and inserted vertices (sorted, unique).
fn touched_nodes(mesh: &SimMesh, ev: &crate::sim::crack::CrackEvent) -> Vec<VertexId> {
    let mut nodes: Vec<VertexId> = Vec::new();
    for &(a, b) in &ev.segments {
        for x in [a, b] {
            nodes.extend(mesh.vertex_faces(x).flat_map(|f| mesh.face_vertices(f)));
        }
    }
    nodes.extend(ev.duplicated.iter().map(|&(n, _)| n));
    nodes.extend(ev.inserted.iter().copied());
    nodes.sort();
    nodes.dedup();
    nodes
}

/// The tips to finish, in id order, with the normal of the plane each
/// cracks along.
fn finish_tips(mesh: &SimMesh, st: &State) -> Vec<(VertexId, [f64; 3])> {
    mesh.vertices()
        .filter_map(|v| tip_plane(mesh, st, v).map(|p| (v, p)))
        .collect()
}

/// Whether `v` is a crack tip to finish, and the normal of the plane it
/// cracks along: an open crack end (one crack edge, not on the border) goes
/// on along its residual's direction, or straight on; a node where two
/// crack edges enclose more than 270 degrees of surface splits that corner
/// along its bisector.
fn tip_plane(mesh: &SimMesh, st: &State, v: VertexId) -> Option<[f64; 3]> {
    if separation_factor(mesh, st, v) < FINISH_MIN_FACTOR {
        return None; // the field keeps this material from cracking
    }
    open_tip_plane(mesh, st, v)
}

/// Finishing leaves a tip where the mean separation factor of its faces is
/// below this: material a confining mask (or a curvature scale) keeps from
/// cracking is not cracked by finishing either.
const FINISH_MIN_FACTOR: f64 = 0.5;

/// The mean separation factor of the faces around `v` (1 without one).
fn separation_factor(mesh: &SimMesh, st: &State, v: VertexId) -> f64 {
    if st.sep_scale.is_empty() {
        return 1.0;
    }
    let (mut sum, mut n) = (0.0, 0usize);
    for f in mesh.vertex_faces(v) {
        sum += st.sep_scale[f.idx()];
        n += 1;
    }
    if n > 0 {
        sum / n as f64
    } else {
        1.0
    }
}

/// [`tip_plane`] without the field's confinement.
fn open_tip_plane(mesh: &SimMesh, st: &State, v: VertexId) -> Option<[f64; 3]> {
    let mut crack_sides = 0;
    for h in mesh.vertex_outgoing(v) {
        for e in [h, mesh.prev(h)] {
            if mesh.is_boundary_halfedge(e) {
                if !mesh.is_crack_halfedge(e) {
                    return None; // on the border: finished
                }
                crack_sides += 1;
            }
        }
    }
    if crack_sides == 0 {
        return None;
    }
    let dirs = crate::sim::crack::crack_directions(mesh, v);
    let n = mesh
        .vertex_faces(v)
        .map(|f| mesh.face_normal(f))
        .fold([0.0; 3], v3::add);
    if dirs.len() == 1 {
        let (val, dir) = st.residual[v.idx()].max_eigen();
        Some(if val > 0.0 {
            dir
        } else {
            v3::cross(n, dirs[0])
        })
    } else {
        wide_corner(mesh, v).map(|bisector| v3::cross(n, bisector))
    }
}

/// For a node whose single fan (it is duplicated per side of a crack, so
/// each copy has one) spans more than 270 degrees between two crack
/// edges, the unit bisector of that fan; otherwise `None`.
fn wide_corner(mesh: &SimMesh, v: VertexId) -> Option<[f64; 3]> {
    crate::sim::crack::fan_middle(mesh, v)
        .filter(|(angle, _)| *angle > 1.5 * std::f64::consts::PI)
        .map(|(_, d)| d)
}

/// Crack finishing (sec. 5): each pass cracks every tip once along its
/// plane (its residual's direction, or straight on), regardless of the
/// toughness, then relaxes without load; until no tip is left, every tip is
/// stuck, or `max_cracks` is reached. A tip whose step makes no crack
/// (blocked by the angle rules) is left where it is.
fn finish_cracks(
    mesh: &mut SimMesh,
    st: &mut State,
    params: &SimParams,
    g: &mut Vec<[f64; 3]>,
    report: &mut SimReport,
    observer: &mut dyn Observer,
) -> Result<FinishReport, SimError> {
    let mut fin = FinishReport::default();
    let mut stuck: std::collections::BTreeSet<u32> = Default::default();
    let (cracks0, length0) = (report.cracks, report.crack_length);
    fin.tips = finish_tips(mesh, st).len();
    let mut loaded = params.load_time;
    // Every pass moves each tip at least one fan further; a generous bound
    // on the passes keeps a pathological mesh from looping.
    let max_passes = 4 * mesh.n_vertices().max(16);
    while fin.passes < max_passes && report.cracks < params.max_cracks {
        let tips: Vec<(VertexId, [f64; 3])> = finish_tips(mesh, st)
            .into_iter()
            .filter(|(v, _)| !stuck.contains(&v.0))
            .collect();
        if tips.is_empty() {
            break;
        }
        fin.passes += 1;
        let mut moved = false;
        let mut seeds: Vec<VertexId> = Vec::new();
        for (v, _) in tips {
            if report.cracks >= params.max_cracks {
                break;
            }
            // A tip may have stopped being one during this pass (another
            // crack ran into it).
            let Some(plane) = tip_plane(mesh, st, v) else {
                continue;
            };
            let ev = crack_node_avoiding(mesh, v, plane, &crack_rules(params), &|m, w| {
                crowded_junction(m, &st.crack_degree, w)
            })
            .map_err(SimError::Mesh)?;
            let residual = st.residual[v.idx()];
            st.residual[v.idx()] = Sym3::ZERO;
            if apply_event(mesh, st, params, report, &ev) {
                moved = true;
                seeds.extend(touched_nodes(mesh, &ev));
                // The new tips carry the direction on.
                for &(_, tip) in &ev.segments {
                    st.residual[tip.idx()] = if residual.frobenius_sq() > 0.0 {
                        residual
                    } else {
                        Sym3::m(plane)
                    };
                }
            } else {
                stuck.insert(v.0);
            }
        }
        // A film's tips follow their own directions: its stress is settled
        // once, after the last pass.
        if st.film.is_none() {
            relax_round(
                mesh,
                st,
                params,
                g,
                false,
                &mut loaded,
                report,
                Some(&seeds),
            )?;
        }
        observe(observer, mesh, st, report);
        if !moved {
            break;
        }
    }
    if st.film.is_some() && report.cracks > cracks0 {
        relax_round(mesh, st, params, g, false, &mut loaded, report, None)?;
        observe(observer, mesh, st, report);
    }
    fin.cracks = report.cracks - cracks0;
    fin.length = report.crack_length - length0;
    fin.stuck = finish_tips(mesh, st).len();
    fin.confined = mesh
        .vertices()
        .filter(|&v| {
            separation_factor(mesh, st, v) < FINISH_MIN_FACTOR
                && open_tip_plane(mesh, st, v).is_some()
        })
        .count();
    Ok(fin)
}

/// The vertex `v`'s copies were all duplicated from (see
/// [`SimMesh::vertex_parent`]).
fn vertex_root(mesh: &SimMesh, v: VertexId) -> VertexId {
    let mut r = v;
    for _ in 0..64 {
        let p = mesh.vertex_parent(r);
        if p == r {
            break;
        }
        r = p;
    }
    r
}

/// Whether a new crack should not end on `w`: three or more cracks meet
/// there already (a fourth makes a cross; more, a fan).
fn crowded_junction(mesh: &SimMesh, degree: &[u8], w: VertexId) -> bool {
    mesh.is_boundary_vertex(w)
        && degree
            .get(vertex_root(mesh, w).idx())
            .is_some_and(|&d| d >= 3)
}

/// Separation tensor of node `v`: the force-based tensor (eq. 3) plus the
/// node's residual, times the mean separation factor of the node's faces
/// when the field scales it (a factor `f` acts as toughness `tau / f`).
fn node_separation(mesh: &SimMesh, st: &State, v: VertexId) -> Sym3 {
    if let Some(film) = &st.film {
        return film_separation(mesh, st, film, v);
    }
    let s = match &st.frozen {
        Some(fz) => fz.get(v.idx()).copied().unwrap_or(Sym3::ZERO),
        None => separation_tensor(mesh, &st.els, &st.stress, v),
    };
    scaled_separation(mesh, st, v, s)
}

/// A film's failure tensor at node `v`: the stress averaged over a disc of
/// world radius (see [`crate::sim::film`]) plus the node's residual, scaled
/// as [`scaled_separation`] does; zero for a node off the cracks that may
/// not start one (near a crack, or shadowed this round).
fn film_separation(mesh: &SimMesh, st: &State, film: &crate::sim::film::Film, v: VertexId) -> Sym3 {
    // Only a crack's open end runs on; anywhere else (a node beside a
    // crack included) a crack would be a new one.
    let tip = !st.crack_time[v.idx()].is_nan()
        && !mesh.is_boundary_vertex(v) | (crate::sim::crack::crack_directions(mesh, v).len() == 1);
    if if tip {
        !film.tip_may_run(v)
    } else {
        !film.may_start(v)
    } {
        return Sym3::ZERO;
    }
    let s = crate::sim::film::averaged_stress(
        mesh,
        &st.els,
        &st.stress,
        st.unit,
        film.average_radius(),
        v,
    ) + st.residual[v.idx()];
    // The least separation factor of the node's faces: a crack does not
    // enter a face where the field forbids it (a confining mask's white).
    if st.sep_scale.is_empty() {
        return s;
    }
    let factor = mesh
        .vertex_faces(v)
        .map(|f| st.sep_scale[f.idx()])
        .fold(f64::INFINITY, f64::min);
    if factor.is_finite() {
        s * factor
    } else {
        s
    }
}

/// The residual and the separation factor on node `v`'s force-based
/// separation tensor `s` (see [`node_separation`]).
fn scaled_separation(mesh: &SimMesh, st: &State, v: VertexId, s: Sym3) -> Sym3 {
    let s = s + st.residual[v.idx()];
    if st.sep_scale.is_empty() {
        return s;
    }
    s * separation_factor(mesh, st, v)
}

/// Largest separation eigenvalue and its direction at every node.
/// `fans` must be those of `mesh` as it is.
fn separations(mesh: &SimMesh, fans: &Fans, st: &State, threshold: f64) -> Vec<f64> {
    if st.frozen.is_some() || st.film.is_some() {
        return (0..mesh.n_vertices())
            .into_par_iter()
            .map(|v| queue_value(node_separation(mesh, st, VertexId(v as u32)), threshold))
            .collect();
    }
    let splits = tensile_splits(&st.els, &st.stress);
    (0..mesh.n_vertices())
        .into_par_iter()
        .map(|v| {
            let s = separation_tensor_split(fans, &st.els, &splits, v);
            queue_value(
                scaled_separation(mesh, st, VertexId(v as u32), s),
                threshold,
            )
        })
        .collect()
}

/// The value to queue a node with: its largest separation eigenvalue, or,
/// when the Gershgorin bound already shows that it cannot exceed
/// `threshold`, that bound (the queue drops both alike, and the bound
/// saves the eigen-decomposition for the many nodes far from failing).
fn queue_value(s: Sym3, threshold: f64) -> f64 {
    let bound = (s.xx + s.xy.abs() + s.xz.abs())
        .max(s.yy + s.xy.abs() + s.yz.abs())
        .max(s.zz + s.xz.abs() + s.yz.abs());
    if bound <= threshold {
        bound
    } else {
        s.max_eigen().0
    }
}

/// Unit area-weighted normal of every node (zero where undefined).
fn node_normals(fans: &Fans, els: &Elements) -> Vec<[f64; 3]> {
    (0..fans.n_vertices())
        .into_par_iter()
        .map(|v| {
            let mut n = [0.0; 3];
            for &(f, _) in fans.fan(v) {
                if let Some(Some(el)) = els.elements.get(f as usize) {
                    n = v3::add(n, v3::scale(el.normal, el.area));
                }
            }
            let l = v3::norm(n);
            if l > 0.0 {
                v3::scale(n, 1.0 / l)
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// The load acting during one step.
#[derive(Clone, Copy)]
struct Load {
    /// Time the load acts in this step (0 when held or complete).
    dt: f64,
    /// Uniform shrinkage per unit time.
    shrink_rate: f64,
}

/// Node `v`'s velocity in an explicit step: its net force from the corner
/// forces, without its normal part on a bonded surface, times its mobility.
#[inline]
fn node_velocity(
    fans: &Fans,
    corner: &[[f64; 3]],
    normals: &[[f64; 3]],
    mobility: &[f64],
    v: usize,
) -> [f64; 3] {
    let mut f = gather(fans, corner, v);
    if let Some(n) = normals.get(v) {
        f = v3::sub(f, v3::scale(*n, v3::dot(f, *n)));
    }
    v3::scale(f, mobility[v])
}

/// One forward-Euler relaxation step plus the load: in each face,
/// `load.dt * shrink_scale[f] * (shrink_rate (I - n n^T) + evolve[f])`,
/// in two parallel passes (nodes, then faces). Node `n` moves
/// by `dt * mobility[n] * g_n`. With `normals`
/// (a bonded surface), the normal part of each node force is carried by the
/// body under the surface and removed. `g` is scratch space.
fn relax_and_evolve(
    fans: &Fans,
    normals: &[[f64; 3]],
    mobility: &[f64],
    st: &mut State,
    dt: f64,
    load: Load,
    g: &mut Vec<[f64; 3]>,
) {
    g.resize(fans.n_vertices(), [0.0; 3]);
    // `st.corner` holds the forces at the current stress (set by the
    // caller before the first step, then by the fused update below).
    let (corner, fixed, unit) = (&st.corner, &st.fixed, st.unit);
    g.par_iter_mut()
        .zip(st.displacement.par_iter_mut())
        .enumerate()
        .with_min_len(512)
        .for_each(|(v, (gn, d))| {
            let f_net = if fixed[v] {
                [0.0; 3]
            } else {
                node_velocity(fans, corner, normals, mobility, v)
            };
            *gn = f_net;
            *d = v3::add(*d, v3::scale(f_net, dt * unit));
        });
    let (scale, evolve) = (&st.shrink_scale, &st.evolve);
    apply_virtual_displacement_with_forces(
        fans,
        &st.els,
        &mut st.stress,
        &mut st.corner,
        g,
        dt,
        |f, el| load_increment(scale, evolve, f, el, load),
    );
}

/// The nodes within some rings of a set of seed nodes and the faces around
/// them: where a local relaxation moves nodes and changes stress.
struct Region {
    /// Per node: inside the region.
    inside: Vec<bool>,
    /// Per face: a corner is in the region.
    face_in: Vec<bool>,
}

impl Region {
    /// The nodes within `rings` edge rings of `seeds` (breadth first over
    /// the fans) and their faces.
    fn around(fans: &Fans, seeds: &[VertexId], rings: usize) -> Region {
        let n = fans.n_vertices();
        let mut inside = vec![false; n];
        let mut front: Vec<u32> = Vec::new();
        for s in seeds {
            if s.idx() < n && !inside[s.idx()] {
                inside[s.idx()] = true;
                front.push(s.0);
            }
        }
        for _ in 0..rings {
            let mut next = Vec::new();
            for &v in &front {
                for &(f, _) in fans.fan(v as usize) {
                    for c in fans.corners(f as usize) {
                        if !inside[c as usize] {
                            inside[c as usize] = true;
                            next.push(c);
                        }
                    }
                }
            }
            if next.is_empty() {
                break;
            }
            front = next;
        }
        let mut face_in = vec![false; fans.n_faces()];
        for (v, _) in inside.iter().enumerate().filter(|(_, &i)| i) {
            for &(f, _) in fans.fan(v) {
                face_in[f as usize] = true;
            }
        }
        Region { inside, face_in }
    }
}

/// [`corner_forces`] of the region's faces only (`corner` grown to every face).
fn region_corner_forces(els: &Elements, stress: &[Sym3], corner: &mut Vec<[f64; 3]>, r: &Region) {
    corner.resize(3 * els.elements.len(), [0.0; 3]);
    corner
        .par_chunks_mut(3)
        .enumerate()
        .with_min_len(1024)
        .for_each(|(f, c)| {
            if r.face_in[f] {
                match els.elements.get(f) {
                    Some(Some(el)) => element_corner_forces(el, &stress[f], c),
                    _ => c.fill([0.0; 3]),
                }
            }
        });
}

/// One forward-Euler step without load restricted to `region`: its nodes
/// move (the others hold still) and its faces' stress and corner forces
/// change, with the same arithmetic as [`relax_and_evolve`]. `g` must be
/// zero outside the region. The loops run over every node and face and
/// skip those outside, which costs little next to the work inside.
fn relax_region(
    fans: &Fans,
    normals: &[[f64; 3]],
    mobility: &[f64],
    st: &mut State,
    dt: f64,
    region: &Region,
    g: &mut [[f64; 3]],
) {
    let (corner, fixed, unit) = (&st.corner, &st.fixed, st.unit);
    g.par_iter_mut()
        .zip(st.displacement.par_iter_mut())
        .enumerate()
        .with_min_len(512)
        .for_each(|(v, (gn, d))| {
            if !region.inside[v] {
                return;
            }
            let f_net = if fixed[v] {
                [0.0; 3]
            } else {
                node_velocity(fans, corner, normals, mobility, v)
            };
            *gn = f_net;
            *d = v3::add(*d, v3::scale(f_net, dt * unit));
        });
    let (els, g) = (&st.els, &*g);
    st.stress
        .par_iter_mut()
        .zip(st.corner.par_chunks_mut(3))
        .enumerate()
        .with_min_len(512)
        .for_each(|(f, (s, c))| {
            if !region.face_in[f] {
                return;
            }
            let Some(Some(el)) = els.elements.get(f) else {
                c.fill([0.0; 3]);
                return;
            };
            *s += element_strain(el, fans.corners(f), g, dt, Sym3::ZERO);
            element_corner_forces(el, s, c);
        });
}

/// Buffers of an RKL super-step: the start stress and its rate, the stress
/// two stages back, and node velocities.
#[derive(Default)]
struct RklScratch {
    s0: Vec<Sym3>,
    s_back: Vec<Sym3>,
    r0: Vec<Sym3>,
    g0: Vec<[f64; 3]>,
    g: Vec<[f64; 3]>,
}

/// One RKL2 super-step of length `tau` (see [`crate::sim::relax::Rkl2`]) on
/// the stress: its rate is the stress of the virtual displacement at node
/// velocity `M g` plus the load's `rate`. The displacement's rate `M g`
/// does not feed back, so it gets the super-step's weights of the stages'
/// velocities. With a `region`, nodes and faces outside it are left alone
/// (as in [`relax_region`]). `st.corner` must hold the corner forces of the
/// current stress; it holds the new ones after.
#[allow(clippy::too_many_arguments)]
fn rkl_super_step(
    fans: &Fans,
    normals: &[[f64; 3]],
    mobility: &[f64],
    st: &mut State,
    tau: f64,
    c: &crate::sim::relax::Rkl2,
    rate: Load,
    region: Option<&Region>,
    k: &mut RklScratch,
) {
    let n_nodes = fans.n_vertices();
    let n_faces = st.stress.len();
    let node_in = |v: usize| region.is_none_or(|r| r.inside[v]);
    let face_in = |f: usize| region.is_none_or(|r| r.face_in[f]);
    // Node velocities `M P g` from the corner forces in `st.corner`, and
    // the displacement's share `w tau M P g` of them.
    let (fixed, unit) = (&st.fixed, st.unit);
    let velocities =
        |corner: &[[f64; 3]], disp: &mut [[f64; 3]], out: &mut Vec<[f64; 3]>, w: f64| {
            out.resize(n_nodes, [0.0; 3]);
            out.par_iter_mut()
                .zip(disp.par_iter_mut())
                .enumerate()
                .with_min_len(512)
                .for_each(|(v, (o, d))| {
                    *o = [0.0; 3];
                    if fixed[v] || !node_in(v) {
                        return;
                    }
                    *o = node_velocity(fans, corner, normals, mobility, v);
                    *d = v3::add(*d, v3::scale(*o, w * tau * unit));
                });
        };
    let (scale, evolve) = (&st.shrink_scale, &st.evolve);
    let load = |f: usize, el: &Element| load_increment(scale, evolve, f, el, rate);
    // Stage 1: Y1 = Y0 + mu_t1 tau F(Y0).
    let mut g0 = std::mem::take(&mut k.g0);
    velocities(&st.corner, &mut st.displacement, &mut g0, c.weights[0]);
    k.s0.resize(n_faces, Sym3::ZERO);
    k.s_back.resize(n_faces, Sym3::ZERO);
    k.r0.resize(n_faces, Sym3::ZERO);
    let h1 = c.mu_t[1] * tau;
    {
        let els = &st.els;
        let g0 = &g0;
        st.stress
            .par_iter_mut()
            .zip(st.corner.par_chunks_mut(3))
            .zip(k.r0.par_iter_mut().zip(k.s0.par_iter_mut()))
            .enumerate()
            .with_min_len(512)
            .for_each(|(f, ((s, cf), (r0, s0)))| {
                if !face_in(f) {
                    return;
                }
                let Some(Some(el)) = els.elements.get(f) else {
                    cf.fill([0.0; 3]);
                    return;
                };
                *s0 = *s;
                *r0 = element_strain(el, fans.corners(f), g0, 1.0, load(f, el));
                *s += *r0 * h1;
                element_corner_forces(el, s, cf);
            });
    }
    k.g0 = g0;
    // Stages 2..s. At stage 2 the state two back is Y0 itself.
    let mut g = std::mem::take(&mut k.g);
    for j in 2..=c.s {
        let (mu, nu) = (c.mu[j], c.nu[j]);
        let rest = 1.0 - mu - nu;
        let (a, b) = (c.mu_t[j] * tau, c.gamma_t[j] * tau);
        velocities(&st.corner, &mut st.displacement, &mut g, c.weights[j - 1]);
        let (s0, r0, gg) = (&k.s0, &k.r0, &g);
        let els = &st.els;
        st.stress
            .par_iter_mut()
            .zip(st.corner.par_chunks_mut(3))
            .zip(k.s_back.par_iter_mut())
            .enumerate()
            .with_min_len(512)
            .for_each(|(f, ((s, cf), back))| {
                if !face_in(f) {
                    return;
                }
                let Some(Some(el)) = els.elements.get(f) else {
                    cf.fill([0.0; 3]);
                    return;
                };
                crate::sim::relax::prefetch_corners(
                    fans,
                    gg,
                    f + crate::sim::relax::PREFETCH_AHEAD,
                );
                let r = element_strain(el, fans.corners(f), gg, 1.0, load(f, el));
                let two_back = if j == 2 { s0[f] } else { *back };
                let x = *s * mu + two_back * nu + s0[f] * rest + r * a + r0[f] * b;
                *back = *s;
                *s = x;
                element_corner_forces(el, s, cf);
            });
    }
    k.g = g;
}

/// Errors of a simulation run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A parameter is invalid.
    #[error("invalid parameter: {0}")]
    Param(String),
    /// Relaxation diverged (an explicit step above the stable one).
    #[error("{0}")]
    Diverged(String),
    /// A mesh invariant broke (a bug).
    #[error("internal mesh error: {0}")]
    Mesh(#[from] MeshError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::forces::tests::jittered_plate;

    #[test]
    fn alpha_above_one_is_refused() {
        let mut mesh = jittered_plate(4, 0.1, 1);
        let p = SimParams {
            alpha: 1.5,
            ..Default::default()
        };
        let e = run(&mut mesh, &p, &mut ()).unwrap_err().to_string();
        assert!(e.contains("alpha"), "{e}");
    }

    #[test]
    fn shrinking_plate_cracks_into_cells() {
        let mut mesh = jittered_plate(24, 0.3, 7);
        let area = mesh.total_area();
        let p = SimParams {
            max_rounds: 60,
            ..Default::default()
        };
        let r = run(&mut mesh, &p, &mut ()).unwrap();
        mesh.validate().unwrap();
        assert!(r.cracks > 10, "{r:?}");
        assert!(((mesh.total_area() - area) / area).abs() < 1e-12);
        let (pieces, _) = mesh.connected_components();
        assert!(
            pieces > 3,
            "cracks meet and cut the plate into cells: {pieces} pieces, {r:?}"
        );
        assert!(
            pieces * 20 < mesh.n_faces(),
            "cells, not shattered triangles: {pieces} pieces, {r:?}"
        );
        assert!(r.energy[1].is_finite());
    }

    /// Crack nodes (positions with at least one crack edge, off the plate's
    /// border) and how many of them are dangling tips (one crack direction).
    fn crack_tips(mesh: &SimMesh, n: f64) -> (usize, usize) {
        let on_border = |p: [f64; 3]| {
            p[0].abs() < 1e-9
                || p[1].abs() < 1e-9
                || (p[0] - n).abs() < 1e-9
                || (p[1] - n).abs() < 1e-9
        };
        let mut dirs: std::collections::BTreeMap<[i64; 2], Vec<[f64; 3]>> = Default::default();
        for v in mesh.vertices() {
            let p = mesh.position(v);
            if on_border(p) || !mesh.is_boundary_vertex(v) {
                continue;
            }
            let key = [(p[0] * 1e6).round() as i64, (p[1] * 1e6).round() as i64];
            let e = dirs.entry(key).or_default();
            for d in crate::sim::crack::crack_directions(mesh, v) {
                if e.iter().all(|x| v3::dot(*x, d) < 1.0 - 1e-9) {
                    e.push(d);
                }
            }
        }
        let tips = dirs.values().filter(|d| d.len() == 1).count();
        (dirs.len(), tips)
    }

    #[test]
    fn plate_cracks_close_into_cells() {
        let mut mesh = jittered_plate(32, 0.3, 11);
        let r = run(&mut mesh, &SimParams::default(), &mut ()).unwrap();
        mesh.validate().unwrap();
        let (nodes, tips) = crack_tips(&mesh, 32.0);
        let (pieces, _) = mesh.connected_components();
        assert!(nodes > 50, "{nodes} crack nodes, {r:?}");
        assert!(
            tips * 10 <= nodes,
            "mostly closed cells: {tips} dangling tips among {nodes} crack nodes"
        );
        assert!(pieces >= 4, "{pieces} cells");
        assert_eq!(r.stopped, "nothing fails any more");
        assert_eq!(r.segments.len(), r.segment_times.len());
        assert!(r.segment_times.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!(r.first_crack_time, r.segment_times.first().copied());
    }

    #[test]
    fn fixed_nodes_hold_their_stress() {
        // No cracks (huge toughness), no noise: the energy left after loading
        // tells how much relaxation the fixed nodes allowed.
        let energy_with = |fixed_boundary: bool, fixed_groups: Vec<u32>| {
            let mut mesh = jittered_plate(10, 0.3, 2);
            let p = SimParams {
                toughness: 1e9,
                noise: 0.0,
                load_time: 10.0,
                shrink_rate: 0.1,
                max_rounds: 6,
                fixed_boundary,
                fixed_groups,
                ..Default::default()
            };
            let r = run(&mut mesh, &p, &mut ()).unwrap();
            assert_eq!(r.cracks, 0);
            // Area in normalised units times |shrinkage * I_2|^2 / 2.
            let full = 0.5 * mesh.total_area() / (r.length_unit * r.length_unit) * 2.0;
            r.energy[1] / full
        };
        let all = energy_with(false, vec![0]);
        let border = energy_with(true, vec![]);
        let free = energy_with(false, vec![]);
        assert!(
            (all - 1.0).abs() < 1e-9,
            "all nodes fixed: nothing relaxes ({all})"
        );
        assert!(
            free < border && border < all,
            "free {free} < fixed border {border} < all fixed {all}"
        );
    }

    /// Relaxation alone from a uniform starting stress: the paper's forward
    /// Euler and backward Euler both converge to the same stress field as
    /// their step shrinks (first order: halving the step about halves the
    /// error), against forward Euler with a tiny step; every scheme lowers
    /// the energy.
    #[test]
    fn integrators_converge_to_the_same_relaxation() {
        let mesh = jittered_plate(12, 0.3, 2);
        let terms = [crate::stress::Term {
            kind: crate::stress::TermKind::Uniform,
            init: 1.0,
            evolve: 0.0,
            mask: None,
        }];
        let field = StressField::build(&mesh, &terms, 1).unwrap();
        let base = SimParams {
            shrink_rate: 0.0,
            load_time: 0.0,
            noise: 0.0,
            relax_time: 2.0,
            ..Default::default()
        };
        let with = |integrator: Integrator, dt: f64| {
            let p = SimParams {
                integrator,
                relax_dt: dt,
                tolerance: 1e-12,
                ..base.clone()
            };
            relax_only(&mesh, &p, Some(&field), 1).unwrap()
        };
        let reference = with(Integrator::PaperEuler, 2.5e-4);
        assert!(reference.report.energy[1] < 0.9 * reference.report.energy[0]);
        for integrator in [Integrator::PaperEuler, Integrator::BackwardEuler] {
            let errors: Vec<f64> = [0.04, 0.02, 0.01]
                .iter()
                .map(|&dt| {
                    let r = with(integrator, dt);
                    assert!(r.report.energy[1] < r.report.energy[0]);
                    let err = r.error_against(&reference);
                    let est = r.report.phases[0].error_estimate;
                    eprintln!("{integrator:?} dt {dt}: error {err:.3e}, estimate {est:.3e}");
                    // The round's own estimate is of the right size.
                    assert!(est > err / 2.0 && est < err * 2.0, "{err} vs {est}");
                    err
                })
                .collect();
            eprintln!("{integrator:?}: relative stress errors at dt 0.04, 0.02, 0.01: {errors:?}");
            for w in errors.windows(2) {
                let ratio = w[0] / w[1];
                assert!(
                    (1.6..2.6).contains(&ratio),
                    "{integrator:?}: errors {errors:?} are not first order"
                );
            }
            assert!(errors[2] < 0.02, "{integrator:?}: {errors:?}");
        }
        // Backward Euler with one step for the whole round is stable but
        // further off; the Euler with the stable step is close.
        let one = with(Integrator::BackwardEuler, 0.0).error_against(&reference);
        let stable = with(Integrator::Euler, 0.0).error_against(&reference);
        let local = with(Integrator::LocalEuler, 0.0).error_against(&reference);
        eprintln!("one backward-Euler step: {one}, euler at the stable step: {stable}, local-euler: {local}");
        assert!(one.is_finite() && stable < one, "{stable} vs {one}");
    }

    /// `rounds` relaxation rounds from the start state (`fresh`: the
    /// round cache dropped before each).
    fn implicit_rounds(
        mesh: &SimMesh,
        field: &StressField,
        params: &SimParams,
        rounds: usize,
        fresh: bool,
    ) -> (State, SimReport) {
        let (mut st, mut report) = start(mesh, params, Some(field)).unwrap();
        let (mut loaded, mut g) = (0.0, Vec::new());
        for _ in 0..rounds {
            if fresh {
                st.cache = RoundCache::default();
            }
            relax_round(
                mesh,
                &mut st,
                params,
                &mut g,
                true,
                &mut loaded,
                &mut report,
                None,
            )
            .unwrap();
        }
        (st, report)
    }

    /// How far the force a backward-Euler round carried is from the force
    /// of the state's stress, and that force's norm.
    fn carried_force_error(st: &State) -> (f64, f64) {
        let fans = st.cache.fans();
        let op = crate::sim::implicit::Operator {
            fans: &fans,
            els: &st.els,
            normals: &st.cache.normals,
            fixed: &st.fixed,
            interface: &[],
        };
        let fresh = op.forces(&st.stress, &mut Vec::new());
        let carried = st.cache.force.clone().expect("a carried force");
        let diff: Vec<[f64; 3]> = carried
            .iter()
            .zip(&fresh)
            .map(|(a, b)| v3::sub(*a, *b))
            .collect();
        (
            crate::sim::implicit::dot(&diff, &diff).sqrt(),
            crate::sim::implicit::dot(&fresh, &fresh).sqrt(),
        )
    }

    /// The area-free L2 distance of two stress fields, and the second's norm.
    fn stress_gap(a: &[Sym3], b: &[Sym3]) -> (f64, f64) {
        let gap = a
            .iter()
            .zip(b)
            .map(|(a, b)| (*a - *b).frobenius_sq())
            .sum::<f64>();
        let scale = b.iter().map(|s| s.frobenius_sq()).sum::<f64>();
        (gap.sqrt(), scale.sqrt())
    }

    /// Backward-Euler rounds carry the force from solve to solve (gathered
    /// after each stress update, plus the force of the round's load): after
    /// rounds with load, bonding and a fixed border it equals the force computed afresh from
    /// the stress, and the stress equals that of rounds that compute
    /// everything afresh (cache dropped before every round).
    #[test]
    fn carried_implicit_forces_match_fresh_ones() {
        let mesh = jittered_plate(14, 0.3, 6);
        let terms = [crate::stress::Term {
            kind: crate::stress::TermKind::Uniform,
            init: 0.5,
            evolve: 0.1,
            mask: None,
        }];
        let field = StressField::build(&mesh, &terms, 1).unwrap();
        let params = SimParams {
            integrator: Integrator::BackwardEuler,
            relax_dt: 0.5,
            tolerance: 1e-12,
            bonded: true,
            fixed_boundary: true,
            shrink_rate: 0.1,
            load_time: 3.0,
            relax_time: 1.0,
            ..Default::default()
        };
        let (st, report) = implicit_rounds(&mesh, &field, &params, 5, false);
        assert!(report.phases.iter().all(|p| p.cg_iterations > 0));
        assert!(!st.cache.normals.is_empty() && st.fixed.iter().any(|&f| f));
        let (off, norm) = carried_force_error(&st);
        assert!(norm > 1e-6, "{norm}");
        assert!(
            off < 1e-8 * norm,
            "carried force off by {off} (norm {norm})"
        );
        let last = report.phases.last().unwrap().residual;
        assert!((last - norm).abs() < 1e-8 * norm, "{last} vs {norm}");
        // The same stress as rounds that compute everything afresh.
        let (st2, _) = implicit_rounds(&mesh, &field, &params, 5, true);
        let (gap, scale) = stress_gap(&st.stress, &st2.stress);
        assert!(gap < 1e-8 * scale, "stress differs by {gap} (norm {scale})");
    }

    /// Many backward-Euler rounds on one mesh at a tight tolerance and
    /// several steps a round (each solve starts from a combination of the
    /// last solutions, which extrapolates): the force and the products kept
    /// for the starts stay exact, so nothing drifts or blows up. The energy
    /// never rises once the load has stopped, the last round's force is the
    /// force of its stress, and the stress is that of rounds that keep
    /// nothing.
    #[test]
    fn long_implicit_runs_on_one_mesh_stay_exact() {
        let mesh = jittered_plate(30, 0.3, 4);
        let field = StressField::build(
            &mesh,
            &[crate::stress::Term {
                kind: crate::stress::TermKind::Uniform,
                init: 0.5,
                evolve: 0.0,
                mask: None,
            }],
            1,
        )
        .unwrap();
        let params = SimParams {
            integrator: Integrator::BackwardEuler,
            relax_dt: 0.125,
            tolerance: 1e-6,
            bonded: true,
            fixed_boundary: true,
            shrink_rate: 0.1,
            load_time: 3.0,
            relax_time: 1.0,
            ..Default::default()
        };
        let rounds = 150;
        let (st, report) = implicit_rounds(&mesh, &field, &params, rounds, false);
        assert_eq!(report.cg_unconverged, 0);
        let energies: Vec<f64> = report.phases.iter().map(|p| p.energy).collect();
        for (k, w) in energies.windows(2).enumerate().skip(3) {
            assert!(
                w[1] <= w[0] * (1.0 + 1e-12),
                "round {k}: energy {} -> {}",
                w[0],
                w[1]
            );
        }
        let (off, norm) = carried_force_error(&st);
        assert!(
            off <= 1e-9 * norm.max(1e-300),
            "carried force off by {off} (norm {norm})"
        );
        let (st2, _) = implicit_rounds(&mesh, &field, &params, rounds, true);
        let (gap, scale) = stress_gap(&st.stress, &st2.stress);
        assert!(gap < 1e-5 * scale, "stress differs by {gap} (norm {scale})");
    }

    #[test]
    fn rkl_is_second_order_and_estimates_its_error() {
        let mesh = jittered_plate(12, 0.3, 2);
        let terms = [crate::stress::Term {
            kind: crate::stress::TermKind::Uniform,
            init: 1.0,
            evolve: 0.0,
            mask: None,
        }];
        let field = StressField::build(&mesh, &terms, 1).unwrap();
        let base = SimParams {
            shrink_rate: 0.0,
            load_time: 0.0,
            noise: 0.0,
            relax_time: 2.0,
            ..Default::default()
        };
        let with = |integrator: Integrator, dt: f64| {
            let p = SimParams {
                integrator,
                relax_dt: dt,
                ..base.clone()
            };
            relax_only(&mesh, &p, Some(&field), 1).unwrap()
        };
        // Reference: forward Euler at two small steps, extrapolated.
        let (h, h2) = (
            with(Integrator::PaperEuler, 5e-4),
            with(Integrator::PaperEuler, 2.5e-4),
        );
        let reference = Relaxed {
            stress: h
                .stress
                .iter()
                .zip(&h2.stress)
                .map(|(a, b)| *b * 2.0 - *a)
                .collect(),
            areas: h2.areas.clone(),
            report: h2.report.clone(),
            seconds: 0.0,
        };
        let euler = with(Integrator::Euler, 0.0);
        let local = with(Integrator::LocalEuler, 0.0);
        eprintln!(
            "euler: error {:.3e}, {} steps; local-euler: error {:.3e}, {} steps",
            euler.error_against(&reference),
            euler.report.relax_steps,
            local.error_against(&reference),
            local.report.relax_steps
        );
        let mut errors = Vec::new();
        for supers in [1.0, 2.0, 4.0] {
            let r = with(Integrator::Rkl, 2.0 / supers);
            assert!(r.report.energy[1] < r.report.energy[0]);
            let err = r.error_against(&reference);
            let est = r.report.phases[0].error_estimate;
            eprintln!(
                "rkl, {supers} super-steps: error {err:.3e}, estimate {est:.3e}, {} evaluations (euler: {})",
                r.report.relax_steps, euler.report.relax_steps
            );
            assert!(est > err / 2.0 && est < err * 2.0, "{err} vs {est}");
            errors.push(err);
        }
        for w in errors.windows(2) {
            let ratio = w[0] / w[1];
            // Second order or better (the stiffest modes, which one
            // super-step damps least, fade faster than that).
            assert!((3.0..10.0).contains(&ratio), "not second order: {errors:?}");
        }
        // Fewer force evaluations than forward Euler at its stable step.
        let one = with(Integrator::Rkl, 0.0);
        assert!(2 * one.report.relax_steps < euler.report.relax_steps);
    }

    #[test]
    fn rkl_never_raises_the_energy_on_slivers() {
        // Stiff nodes beside soft ones: the stages are capped and the
        // stiffest nodes slowed; every super-step still lowers the energy.
        let mut input = crate::mesh::test_util::grid_input(12, 12);
        for (i, p) in input.positions.iter_mut().enumerate() {
            let interior = p[0] > 0.0 && p[0] < 12.0 && p[1] > 0.0 && p[1] < 12.0;
            if interior && i % 13 == 0 {
                p[0] += 0.999;
                p[1] += 1e-4;
            }
        }
        let (mesh, _) = SimMesh::build(&input, &Default::default()).unwrap();
        let terms = [crate::stress::Term {
            kind: crate::stress::TermKind::Uniform,
            init: 1.0,
            evolve: 0.0,
            mask: None,
        }];
        let field = StressField::build(&mesh, &terms, 1).unwrap();
        let p = SimParams {
            integrator: Integrator::Rkl,
            shrink_rate: 0.0,
            load_time: 0.0,
            relax_time: 50.0,
            clamp_factor: 1e6,
            ..Default::default()
        };
        let r = relax_only(&mesh, &p, Some(&field), 6).unwrap();
        let mut last = r.report.energy[0];
        for ph in &r.report.phases {
            assert!(
                ph.energy.is_finite() && ph.energy <= last * (1.0 + 1e-12),
                "{last} -> {}",
                ph.energy
            );
            last = ph.energy;
        }
        assert!(last < 0.9 * r.report.energy[0]);
        // Capped: at most RKL_MAX_STAGES evaluations per round.
        assert!(
            r.report.relax_steps <= 6 * RKL_MAX_STAGES,
            "{}",
            r.report.relax_steps
        );
    }

    fn impact_params() -> (SimParams, Vec<crate::stress::Term>) {
        let params = SimParams {
            shrink_rate: 0.0,
            alpha: 0.5,
            residual_constant: 0.0,
            fixed_boundary: true,
            ..Default::default()
        };
        let terms = vec![crate::stress::Term {
            kind: crate::stress::TermKind::Impact {
                points: vec![[12.0, 12.0, 0.0]],
                radius: 7.0,
                concentric_factor: 1.25,
            },
            init: 3.0,
            evolve: 0.0,
            mask: None,
        }];
        (params, terms)
    }

    #[test]
    fn without_remeshing_cracks_follow_existing_edges() {
        let (base, terms) = impact_params();
        let mut mesh = jittered_plate(24, 0.3, 5);
        let original: Vec<[f64; 3]> = mesh.positions().to_vec();
        let field = StressField::build(&mesh, &terms, 1).unwrap();
        let params = SimParams {
            remesh: false,
            ..base
        };
        let r = run_with(&mut mesh, &params, Some(&field), &mut ()).unwrap();
        mesh.validate().unwrap();
        assert!(r.cracks > 5, "{}", r.cracks);
        assert_eq!(r.triangles[0], r.triangles[1], "no triangle split");
        // Every crack segment joins two input vertices.
        let is_input = |p: [f64; 3]| original.contains(&p);
        for s in &r.segments {
            assert!(is_input(s[0]) && is_input(s[1]), "{s:?}");
        }
    }

    #[test]
    fn to_end_propagation_runs_each_crack_on_from_its_tip() {
        let (base, terms) = impact_params();
        let chained = |propagation| {
            let mut mesh = jittered_plate(24, 0.3, 5);
            let field = StressField::build(&mesh, &terms, 1).unwrap();
            let params = SimParams {
                propagation,
                ..base.clone()
            };
            let r = run_with(&mut mesh, &params, Some(&field), &mut ()).unwrap();
            mesh.validate().unwrap();
            // Segments that start where the one before ended.
            let follow = r
                .segments
                .windows(2)
                .filter(|w| w[1][0] == w[0][1] || w[1][1] == w[0][1])
                .count();
            (follow as f64 / r.segments.len().max(1) as f64, r.cracks)
        };
        let (queue, n_queue) = chained(Propagation::Queue);
        let (to_end, n_to_end) = chained(Propagation::ToEnd);
        eprintln!("segments continuing the previous one: queue {queue:.2} ({n_queue} cracks), to-end {to_end:.2} ({n_to_end})");
        assert!(n_to_end > 5);
        assert!(to_end > 0.5 && to_end > queue + 0.1, "{to_end} vs {queue}");
    }

    #[test]
    fn eigen_diffusion_spreads_and_conserves_the_eigenvalues() {
        let (base, terms) = impact_params();
        let mesh = jittered_plate(12, 0.3, 5);
        let field = StressField::build(&mesh, &terms, 1).unwrap();
        let params = SimParams {
            relaxation: Relaxation::EigenDiffusion,
            diffusion_passes: 1,
            diffusion_fraction: 0.05,
            ..base
        };
        let (mut st, _) = start(&mesh, &params, Some(&field)).unwrap();
        // A peak on one node, a flat positive field elsewhere.
        let mut fz = vec![Sym3::outer([1.0, 0.0, 0.0]) * 1.0; mesh.n_vertices()];
        fz[60] = Sym3::outer([0.0, 1.0, 0.0]) * 10.0;
        st.frozen = Some(fz);
        let eig = |st: &State| -> Vec<f64> {
            (0..mesh.n_vertices())
                .map(|v| node_separation(&mesh, st, VertexId(v as u32)).max_eigen().0)
                .collect()
        };
        let before = eig(&st);
        eigen_diffusion(&mesh, &mut st, &params);
        let after = eig(&st);
        let (s0, s1): (f64, f64) = (before.iter().sum(), after.iter().sum());
        assert!((s0 - s1).abs() < 1e-9 * s0, "{s0} -> {s1}");
        // The peak gives 5% (0.5) and takes back its neighbours' small shares.
        assert!(after[60] > 9.5 && after[60] < 9.6, "{}", after[60]);
        let gained = (0..mesh.n_vertices())
            .filter(|&v| after[v] > before[v] + 1e-3)
            .count();
        assert!(gained >= 4, "the peak's neighbours gain: {gained}");
        // Its direction stays: the peak's largest eigenvector is still y.
        let (_, dir) = node_separation(&mesh, &st, VertexId(60)).max_eigen();
        assert!(dir[1].abs() > 0.999, "{dir:?}");
        // The run with diffusion differs from the one without.
        let run = |passes| {
            let mut m = jittered_plate(24, 0.3, 5);
            let f = StressField::build(&m, &terms, 1).unwrap();
            let p = SimParams {
                relaxation: Relaxation::EigenDiffusion,
                remesh: false,
                propagation: Propagation::ToEnd,
                diffusion_passes: passes,
                ..params.clone()
            };
            let r = run_with(&mut m, &p, Some(&f), &mut ()).unwrap();
            m.validate().unwrap();
            r
        };
        let (plain, diffused) = (run(0), run(30));
        assert!(plain.cracks > 0 && diffused.cracks > 0);
        assert_ne!(plain.segments, diffused.segments);
        assert_eq!(plain.relax_steps, 0, "no tensor relaxation");
        // A load that builds up over the rounds (shrinkage, no starting
        // stress) reaches the frozen separations too.
        let mut m = jittered_plate(16, 0.3, 5);
        let p = SimParams {
            relaxation: Relaxation::EigenDiffusion,
            max_rounds: 60,
            ..Default::default()
        };
        let r = run_with(&mut m, &p, None, &mut ()).unwrap();
        m.validate().unwrap();
        assert!(r.cracks > 0, "shrinkage cracks under eigen-diffusion too");
    }

    /// Eigen-diffusion stays local: the same impact (same element size,
    /// same hit) on a plate with 4 times the elements costs about the same
    /// diffusion work per crack (a sweep of the whole mesh after every
    /// crack run cost 4 times as much: 5.5 s at 5.8k triangles, 427 s at
    /// 28.8k), and the mesh stays valid.
    #[test]
    fn eigen_diffusion_work_does_not_grow_with_the_mesh() {
        let (base, terms) = impact_params();
        let params = SimParams {
            relaxation: Relaxation::EigenDiffusion,
            remesh: false,
            propagation: Propagation::ToEnd,
            diffusion_passes: 10,
            diffusion_fraction: 0.05,
            ..base
        };
        let per_crack = |n: usize| {
            let mut m = jittered_plate(n, 0.3, 5);
            let f = StressField::build(&m, &terms, 1).unwrap();
            let r = run_with(&mut m, &params, Some(&f), &mut ()).unwrap();
            m.validate().unwrap();
            assert!(r.cracks > 10 && r.diffusion_work > 0, "{}", r.cracks);
            eprintln!(
                "{n}x{n}: {} triangles, {} cracks, {} diffusion visits",
                m.n_faces(),
                r.cracks,
                r.diffusion_work
            );
            r.diffusion_work as f64 / r.cracks as f64
        };
        let (small, large) = (per_crack(24), per_crack(48));
        assert!(
            large < 1.5 * small,
            "{small:.0} -> {large:.0} visits per crack"
        );
    }

    /// An equilibrium round leaves (almost) no residual force, and no
    /// finite backward-Euler step relaxes further.
    #[test]
    fn equilibrium_leaves_no_residual_force() {
        let mesh = jittered_plate(12, 0.3, 2);
        let terms = [crate::stress::Term {
            kind: crate::stress::TermKind::Uniform,
            init: 1.0,
            evolve: 0.0,
            mask: None,
        }];
        let field = StressField::build(&mesh, &terms, 1).unwrap();
        let p = |integrator, tolerance| SimParams {
            shrink_rate: 0.0,
            load_time: 0.0,
            integrator,
            tolerance,
            ..Default::default()
        };
        let eq = relax_only(&mesh, &p(Integrator::Equilibrium, 1e-8), Some(&field), 1).unwrap();
        let be = relax_only(&mesh, &p(Integrator::BackwardEuler, 1e-8), Some(&field), 1).unwrap();
        let start =
            relax_only(&mesh, &p(Integrator::BackwardEuler, 1e-8), Some(&field), 0).unwrap();
        let f0 = {
            let mut m = mesh.clone();
            let r = run_with(
                &mut m,
                &SimParams {
                    max_rounds: 1,
                    toughness: 1e30,
                    ..p(Integrator::BackwardEuler, 1e-8)
                },
                Some(&field),
                &mut (),
            )
            .unwrap();
            r.phases[0].residual
        };
        let res = eq.report.phases[0].residual;
        assert!(
            res < 1e-6 * f0.max(1.0),
            "equilibrium residual {res} (one BE round: {f0})"
        );
        assert!(eq.report.energy[1] <= be.report.energy[1] * (1.0 + 1e-9));
        assert!(eq.report.energy[1] < start.report.energy[1]);
    }

    /// The paper's scheme with a step far above the stable one stops with an
    /// error naming the integrator and the step, instead of blowing up.
    #[test]
    fn paper_euler_above_the_stable_step_is_an_error() {
        let mut mesh = jittered_plate(10, 0.3, 4);
        let p = SimParams {
            integrator: Integrator::PaperEuler,
            relax_dt: 50.0,
            ..Default::default()
        };
        let e = run(&mut mesh, &p, &mut ()).unwrap_err().to_string();
        assert!(e.contains("paper-euler") && e.contains("relax_dt"), "{e}");
        let p = SimParams {
            integrator: Integrator::PaperEuler,
            ..Default::default()
        };
        let e = run(&mut mesh, &p, &mut ()).unwrap_err().to_string();
        assert!(e.contains("relax_dt"), "{e}");
    }

    #[test]
    fn same_result_at_any_scale() {
        let run_scaled = |s: f64| {
            let mut input = crate::mesh::test_util::grid_input(10, 10);
            let mut rng = crate::mesh::test_util::Lcg(3);
            for q in input.positions.iter_mut() {
                if q[0] > 0.0 && q[0] < 10.0 && q[1] > 0.0 && q[1] < 10.0 {
                    q[0] += 0.3 * (2.0 * rng.next_f64() - 1.0);
                    q[1] += 0.3 * (2.0 * rng.next_f64() - 1.0);
                }
                *q = q.map(|x| x * s);
            }
            let (mut m, _) = SimMesh::build(&input, &Default::default()).unwrap();
            let params = SimParams {
                toughness: 1.0,
                shrink_rate: 0.2,
                relax_time: 1.0,
                max_rounds: 20,
                ..Default::default()
            };
            let r = run(&mut m, &params, &mut ()).unwrap();
            (r.cracks, m.n_faces(), r.crack_length / s)
        };
        let (c1, f1, l1) = run_scaled(1.0);
        let (c2, f2, l2) = run_scaled(100.0);
        assert!(c1 > 0);
        assert_eq!(
            (c1, f1),
            (c2, f2),
            "a mesh in centimetres cracks like the same mesh in metres"
        );
        assert!((l1 - l2).abs() < 1e-6 * l1);
    }

    #[test]
    fn a_region_of_every_node_is_the_global_step() {
        // One unloaded step restricted to a region holding every node is
        // the global step, bit for bit; a small region moves only its nodes
        // and changes only its faces.
        let mesh = jittered_plate(10, 0.3, 2);
        let params = SimParams::default();
        let (mut st, _) = start(&mesh, &params, None).unwrap();
        let fans = Fans::new(&mesh);
        // Some stress to relax.
        let mut rng = crate::mesh::test_util::Lcg(7);
        for (s, el) in st.stress.iter_mut().zip(&st.els.elements) {
            let n = el.as_ref().unwrap().normal;
            *s = Sym3::tangent_identity(n, 1.0 + rng.next_f64());
        }
        corner_forces(&st.els, &st.stress, &mut st.corner);
        let normals = node_normals(&fans, &st.els);
        let mobility = vec![1.0; fans.n_vertices()];
        let dt = 0.05;
        let unloaded = Load {
            dt: 0.0,
            shrink_rate: 0.0,
        };
        let before = (
            st.stress.clone(),
            st.displacement.clone(),
            st.corner.clone(),
        );
        let mut g = Vec::new();
        relax_and_evolve(&fans, &normals, &mobility, &mut st, dt, unloaded, &mut g);
        let global = (
            st.stress.clone(),
            st.displacement.clone(),
            st.corner.clone(),
        );
        (st.stress, st.displacement, st.corner) = before.clone();
        let all: Vec<VertexId> = mesh.vertices().collect();
        let region = Region::around(&fans, &all, 0);
        let mut g = vec![[0.0; 3]; fans.n_vertices()];
        relax_region(&fans, &normals, &mobility, &mut st, dt, &region, &mut g);
        assert_eq!(st.stress, global.0);
        assert_eq!(st.displacement, global.1);
        assert_eq!(st.corner, global.2);
        // A region of two rings around one node.
        (st.stress, st.displacement, st.corner) = before.clone();
        let small = Region::around(&fans, &[VertexId(55)], 2);
        let nodes = small.inside.iter().filter(|&&i| i).count();
        assert!(nodes > 7 && nodes < 40, "{nodes}");
        let mut g = vec![[0.0; 3]; fans.n_vertices()];
        relax_region(&fans, &normals, &mobility, &mut st, dt, &small, &mut g);
        for v in 0..fans.n_vertices() {
            if !small.inside[v] {
                assert_eq!(st.displacement[v], before.1[v], "node {v} moved");
            }
        }
        let mut changed = 0;
        for f in 0..fans.n_faces() {
            if st.stress[f] != before.0[f] {
                changed += 1;
                assert!(small.face_in[f], "face {f} changed");
            }
        }
        assert!(changed > 0);
        // The energy falls.
        assert!(energy(&st.els, &st.stress) < energy(&st.els, &before.0));
    }

    #[test]
    fn local_finishing_relaxes_only_near_the_new_cracks() {
        // Snapshots of each finishing pass: energy and displacement.
        struct Keep(Vec<(f64, Vec<[f64; 3]>)>);
        impl Observer for Keep {
            fn state(&mut self, s: &Snapshot) {
                self.0.push((s.energy, s.displacement.to_vec()));
            }
            fn wants_state(&self) -> bool {
                true
            }
        }
        let params = SimParams {
            max_rounds: 12,
            residual_constant: 0.0,
            alpha: 0.3,
            finish: true,
            ..Default::default()
        };
        let run_rings = |rings: usize| {
            let mut mesh = jittered_plate(24, 0.3, 5);
            let mut keep = Keep(Vec::new());
            let p = SimParams {
                finish_rings: rings,
                ..params.clone()
            };
            let r = run_with(&mut mesh, &p, None, &mut keep).unwrap();
            mesh.validate().unwrap();
            (r, keep.0)
        };
        let (global, global_snaps) = run_rings(0);
        let (local, snaps) = run_rings(2);
        let fin = local.finish.clone().unwrap();
        assert!(fin.passes >= 2, "{fin:?}");
        assert_eq!(global.finish.as_ref().unwrap().passes, fin.passes);
        // The finishing passes are the last snapshots: the energy never
        // rises, and the local passes move far fewer nodes than global ones.
        let moved = |snaps: &[(f64, Vec<[f64; 3]>)]| {
            let passes = &snaps[snaps.len() - fin.passes - 1..];
            let mut moved = 0;
            for w in passes.windows(2) {
                let (e0, d0) = &w[0];
                let (e1, d1) = &w[1];
                assert!(*e1 <= *e0 * (1.0 + 1e-12), "energy rose: {e0} -> {e1}");
                moved += d1.iter().zip(d0).filter(|(a, b)| a != b).count();
            }
            moved
        };
        let (m_local, m_global) = (moved(&snaps), moved(&global_snaps));
        eprintln!("finishing moved {m_local} nodes locally, {m_global} globally");
        assert!(2 * m_local < m_global, "{m_local} vs {m_global}");
        assert!(local.displacement != global.displacement);
        assert_eq!(local.cracks, global.cracks);
    }

    #[test]
    fn finishing_runs_open_tips_into_cracks_or_the_border() {
        // Stop early (few rounds, low residual constant) so cracks are left
        // open; finishing must run them on.
        let params = SimParams {
            max_rounds: 12,
            residual_constant: 0.0,
            alpha: 0.3,
            ..Default::default()
        };
        let mut open = jittered_plate(24, 0.3, 5);
        let r0 = run(&mut open, &params, &mut ()).unwrap();
        let st_tips = |mesh: &SimMesh, r: &SimReport| {
            // Tips as the finisher sees them (residuals do not matter for counting).
            let st = State {
                els: Elements {
                    elements: Vec::new(),
                    clamp: 0.0,
                },
                stress: Vec::new(),
                residual: vec![Sym3::ZERO; mesh.n_vertices()],
                frozen: None,
                fixed: Vec::new(),
                shrink_scale: Vec::new(),
                evolve: Vec::new(),
                sep_scale: Vec::new(),
                displacement: Vec::new(),
                crack_time: Vec::new(),
                crack_degree: Vec::new(),
                unit: r.length_unit,
                corner: Vec::new(),
                warm: Vec::new(),
                diffusion_work: 0,
                cache: RoundCache::default(),
                implicit: ImplicitScratch::default(),
                film: None,
            };
            finish_tips(mesh, &st).len()
        };
        let before = st_tips(&open, &r0);
        assert!(before > 3, "the early stop leaves open tips: {before}");
        let mut done = jittered_plate(24, 0.3, 5);
        let r1 = run(
            &mut done,
            &SimParams {
                finish: true,
                ..params.clone()
            },
            &mut (),
        )
        .unwrap();
        done.validate().unwrap();
        let fin = r1.finish.clone().unwrap();
        assert_eq!(fin.tips, before, "{fin:?}");
        assert!(fin.cracks > 0 && fin.length > 0.0, "{fin:?}");
        let after = st_tips(&done, &r1);
        eprintln!("finishing: {before} tips before, {after} after: {fin:?}");
        assert_eq!(after, fin.stuck);
        assert!(
            after * 4 <= before,
            "finishing closes most tips: {before} before, {after} after ({fin:?})"
        );
        // The main run is the same up to finishing.
        assert_eq!(&r1.segments[..r0.segments.len()], &r0.segments[..]);
        // Every crack node has a crack time, within the run; others none.
        for v in done.vertices() {
            let on_crack = done
                .vertex_outgoing(v)
                .any(|h| done.is_crack_halfedge(h) || done.is_crack_halfedge(done.prev(h)));
            let t = r1.crack_time[v.idx()];
            assert_eq!(on_crack, !t.is_nan(), "vertex {v}");
            if on_crack {
                assert!(t >= 0.0 && t <= r1.time, "{t}");
            }
        }
        assert_eq!(r1.displacement.len(), done.n_vertices());
    }

    #[test]
    fn duplicates_inherit_displacement_so_crack_sides_start_together() {
        let mut mesh = jittered_plate(16, 0.3, 9);
        let r = run(&mut mesh, &SimParams::default(), &mut ()).unwrap();
        assert!(r.cracks > 5);
        // The two sides of a crack moved apart (the gap opens): for crack
        // copies of one root, the displacement differs; for the whole mesh
        // the displacement is finite.
        assert!(r.displacement.iter().flatten().all(|x| x.is_finite()));
        let mut opened = 0;
        for v in mesh.vertices() {
            let p = mesh.vertex_parent(v);
            if p != v {
                let d = v3::norm(v3::sub(r.displacement[v.idx()], r.displacement[p.idx()]));
                if d > 1e-6 * r.length_unit {
                    opened += 1;
                }
            }
        }
        assert!(opened > 0, "crack sides move apart");
    }
}
