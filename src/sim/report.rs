//! What a run reports: [`SimReport`] with one [`Phase`] per round and the
//! [`FinishReport`] of the finishing passes; [`Relaxed`] for the study.

use crate::math::Sym3;

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
    /// Times at which later hits landed (impacts `in_turn`), in order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub hit_times: Vec<f64>,
    /// Every crack segment as its two end points (mesh units), in the order formed.
    #[serde(skip)]
    pub segments: Vec<[[f64; 3]; 2]>,
    /// When each segment of `segments` formed (simulation time).
    #[serde(skip)]
    pub segment_times: Vec<f64>,
    /// The spring model only: per segment of `segments` (a broken spring's
    /// edge, along which the surface opens), the crack across it: between
    /// the rest centroids of the two triangles on that edge. The springs
    /// broken along a crack draw one line through the triangles they share
    /// here, where their edges zig-zag; outputs that do not open gaps draw
    /// these.
    #[serde(skip)]
    pub crossings: Vec<[[f64; 3]; 2]>,
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
    /// A film's solves: their preconditioner, time and hierarchies.
    #[serde(skip_serializing_if = "FilmSolves::is_empty")]
    pub film_solves: FilmSolves,
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

/// A film's solves over a run: wall time in building multigrid
/// hierarchies and in the conjugate-gradient iterations, and the largest
/// hierarchy. Timings vary from run to run, so two of these always compare
/// equal (a run's report is the same at any thread count).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FilmSolves {
    /// `jacobi` or `multigrid`.
    pub preconditioner: &'static str,
    /// Solves.
    pub solves: usize,
    /// Multigrid hierarchies built (a solve whose rows did not change
    /// reuses the last one).
    pub builds: usize,
    /// Seconds building hierarchies.
    pub setup_seconds: f64,
    /// Seconds in the iterations.
    pub solve_seconds: f64,
    /// Rows of the solves' systems, summed over the solves.
    pub rows: usize,
    /// Of those, the rows computed (the others were kept from the solve
    /// before: their inputs had not changed).
    pub rows_assembled: usize,
    /// The largest hierarchy's levels, finest first: nodes, blocks, bytes.
    pub levels: Vec<[usize; 3]>,
}

impl FilmSolves {
    fn is_empty(&self) -> bool {
        self.solves == 0
    }
}

impl PartialEq for FilmSolves {
    fn eq(&self, _: &Self) -> bool {
        true
    }
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
    /// Tips found after the run (open crack ends and > 270 degree corners);
    /// with later hits, summed over the finishing before each lands and at
    /// the end (a tip left stuck is counted again).
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

pub(in crate::sim) fn is_zero(x: &usize) -> bool {
    *x == 0
}

/// What [`crate::sim::relax_only`] measured.
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
