//! Parameters of a simulation run: [`SimParams`] (a pipeline's
//! `[simulation]` table) and its enums, with their defaults and checks.

use crate::math::v3;
use crate::mesh::SimMesh;
use crate::sim::crack::CrackRules;

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
    /// between steps, until it meets another crack or the border. On the
    /// spring model: each open tip runs along the shortest path of unbroken
    /// springs to the crack or border ahead. Set by a pipeline's
    /// `[post] finish`. Default false.
    #[serde(skip)]
    pub finish: bool,
    /// With `finish` on a film: only tips with another crack ahead within
    /// this many cell sizes run on, at most twice that far (0: all, to the
    /// end). On the spring model: a tip runs on only to a crack or the
    /// border within this many cell sizes along its path (0: one cell
    /// size). Set by a pipeline's `[post] finish_reach`. Default 0.
    #[serde(skip)]
    pub finish_reach: f64,
    /// How relaxation is integrated over each round's `relax_time`; see
    /// [`Integrator`]. Default `local-euler`.
    pub integrator: Integrator,
    /// Relative residual each backward-Euler solve reaches. Default 1e-4.
    pub tolerance: f64,
    /// How a film's solves are preconditioned; see [`FilmPreconditioner`].
    /// Default `jacobi`.
    pub film_preconditioner: FilmPreconditioner,
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
    pub springs: SpringParams,
    /// Parameters of `model = "ductile"` (`[simulation.ductile]`).
    pub ductile: crate::sim::ductile::DuctileParams,
    /// The pattern's cell size in scene units: the surface is a film bonded
    /// to its body (`sim::film`) whose cells come out near this
    /// diameter, whatever the triangles. Give this or
    /// `cell_size_relative`, not both; with neither, lengths are the
    /// mesh's (the mean edge length) and cells follow the triangles.
    pub cell_size: Option<f64>,
    /// The cell size as a fraction of each simulated mesh's bounding-box
    /// diagonal (every preset sets one).
    pub cell_size_relative: Option<f64>,
    /// With a cell size: crack each surface on its own isotropic
    /// simulation surface, remeshed to `cell size / 8` edges (refined when
    /// coarse, coarsened when fine, jittered so no row of the input's
    /// tessellation survives). Default true; false cracks the input's own
    /// triangles.
    pub isotropic_remesh: bool,
    /// With `isotropic_remesh`: also remesh surfaces already fine enough
    /// (at most 10% of their area in triangles with an edge above 4/3 of
    /// the target). Default true; false leaves such a surface as it is,
    /// and its rows show in the pattern.
    pub coarsen: bool,
    /// Most triangles the remeshed surface may have: a request above it is
    /// refused with the numbers before any work. Default 2,000,000.
    pub max_triangles: usize,
    /// Drying cycles (a film only): each cycle after the first re-opens
    /// the last one's cracks, aged by one wetting and drying
    /// (`sim::ageing`): junctions move toward equal angles, so
    /// T-junctions turn into Y-junctions and cells toward hexagons over a
    /// few cycles. Only the first drying is simulated; the further cycles
    /// age its crack network, which costs little. In 1..=50; default 1.
    pub cycles: usize,
    /// With a cell size and an output that is the input's own mesh: the
    /// pattern is grown on the surface extended beyond its open border by
    /// a strip this many cell sizes wide (`mesh::margin`), so the
    /// border cuts through cells instead of lining them up along it (a
    /// ground patch, a wall: a piece of a larger surface). The strip is
    /// never written. It applies to a film (a cell size, `relaxation =
    /// "tensor"`) on its remeshed surface (`isotropic_remesh`) whose cracks
    /// are cut into the input (`post.output = "input"` with gaps, grooves
    /// or walls); elsewhere it is left out with a warning. 0 (the default): the border is the film's free edge.
    /// In [0, 4].
    pub margin: f64,
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
    /// (see `sim::springs`).
    Springs,
    /// Ductile tearing of a closed solid by a level set in a grid of
    /// tetrahedra (see `sim::ductile`).
    Ductile,
}

/// Preconditioners of a bonded film's conjugate-gradient solves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilmPreconditioner {
    /// Each node's 2x2 block inverted: cheap per iteration, but the
    /// iterations grow with the triangles per cell.
    #[default]
    Jacobi,
    /// One V-cycle of smoothed-aggregation multigrid (`sim::amg`):
    /// dearer per iteration and to build, in iterations that barely grow
    /// with the triangles. Patterns may differ in realisation from
    /// `jacobi`'s (the solves stop at the tolerance from other sides).
    Multigrid,
}

impl FilmPreconditioner {
    /// The pipeline name.
    pub fn name(self) -> &'static str {
        match self {
            FilmPreconditioner::Jacobi => "jacobi",
            FilmPreconditioner::Multigrid => "multigrid",
        }
    }
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
    /// stable sub-steps and counted in [`crate::sim::SimReport::dt_limited_rounds`].
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

/// Most stages of an RKL super-step; stiffer nodes than this covers are
/// slowed down (their mobility reduced) instead.
pub const RKL_MAX_STAGES: usize = 48;

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
            film_preconditioner: FilmPreconditioner::Jacobi,
            finish_rings: 8,
            finish: false,
            finish_reach: 0.0,
            model: Model::Quasistatic,
            springs: Default::default(),
            ductile: Default::default(),
            remesh: true,
            propagation: Propagation::Queue,
            relaxation: Relaxation::Tensor,
            diffusion_passes: 30,
            diffusion_fraction: 0.05,
            rules: CrackRules::default(),
            cell_size: None,
            cell_size_relative: None,
            isotropic_remesh: true,
            coarsen: true,
            max_triangles: 2_000_000,
            cycles: 1,
            margin: 0.0,
        }
    }
}

impl SimParams {
    /// The cell size for `mesh` in scene units, when one is asked for
    /// (relative sizes scale with the mesh's bounding-box diagonal).
    pub(crate) fn cell_size_for(&self, mesh: &SimMesh) -> Option<f64> {
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

    /// Whether this mesh's cracks run along edges it already has (the
    /// spring model, or the quasistatic model snapping to its edges)
    /// instead of splitting triangles along the crack.
    pub fn cracks_along_edges(&self) -> bool {
        match self.model {
            Model::Springs => true,
            Model::Quasistatic => !self.remesh,
            Model::Ductile => false,
        }
    }

    /// Check every value, naming the parameter that is wrong.
    pub fn validate(&self) -> Result<(), super::ParamError> {
        use super::ParamError;
        let finite_pos = |name: &str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err(ParamError::range(name, "a positive number", x))
            }
        };
        if self.model == Model::Ductile {
            self.ductile.validate()?;
        }
        if self.model == Model::Springs {
            self.springs.validate()?;
        }
        if !(1..=50).contains(&self.cycles) {
            return Err(ParamError::range("cycles", "in 1..=50", self.cycles));
        }
        if self.cycles > 1 && !self.is_film() {
            return Err(ParamError::invalid(
                "cycles",
                "above 1 re-open the cracks of a film: they need model = \"quasistatic\" with a cell size (simulation.cell_size or cell_size_relative) and relaxation = \"tensor\"",
            ));
        }
        if !(self.margin.is_finite() && (0.0..=4.0).contains(&self.margin)) {
            return Err(ParamError::range(
                "margin",
                "in [0, 4] cell sizes",
                self.margin,
            ));
        }
        if !(0.0..=1.0).contains(&self.diffusion_fraction) {
            return Err(ParamError::range(
                "diffusion_fraction",
                "in [0, 1]",
                self.diffusion_fraction,
            ));
        }
        finite_pos("toughness", self.toughness)?;
        finite_pos("relax_time", self.relax_time)?;
        finite_pos("clamp_factor", self.clamp_factor)?;
        if !(self.tolerance.is_finite() && self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(ParamError::range("tolerance", "in (0, 1)", self.tolerance));
        }
        if self.integrator == Integrator::PaperEuler && self.relax_dt <= 0.0 {
            return Err(ParamError::invalid(
                "integrator",
                "paper-euler needs relax_dt > 0 (its fixed step)",
            ));
        }
        if !(0.0..=1.0).contains(&self.alpha) {
            return Err(ParamError::range(
                "alpha",
                "in [0, 1] (above 1 the residual propagation is unstable)",
                self.alpha,
            ));
        }
        if !(self.shrink_rate.is_finite() && self.shrink_rate >= 0.0) {
            return Err(ParamError::range("shrink_rate", ">= 0", self.shrink_rate));
        }
        if !(self.relax_dt.is_finite() && self.relax_dt >= 0.0) {
            return Err(ParamError::range(
                "relax_dt",
                ">= 0 (0: the stable step)",
                self.relax_dt,
            ));
        }
        if !(self.load_time.is_finite() && self.load_time >= 0.0) {
            return Err(ParamError::range("load_time", ">= 0", self.load_time));
        }
        if !(0.0..=1.0).contains(&self.noise) {
            return Err(ParamError::range("noise", "in [0, 1]", self.noise));
        }
        match (self.cell_size, self.cell_size_relative) {
            (Some(_), Some(_)) => {
                return Err(ParamError::Both {
                    first: "simulation.cell_size".into(),
                    second: "simulation.cell_size_relative".into(),
                })
            }
            (Some(c), None) => finite_pos("cell_size", c)?,
            (None, Some(r)) => {
                finite_pos("cell_size_relative", r)?;
                if r > 1.0 {
                    return Err(ParamError::invalid(
                        "cell_size_relative",
                        format!("is a fraction of the bounding-box diagonal, at most 1; got {r}"),
                    ));
                }
            }
            (None, None) => {}
        }
        if self.max_triangles == 0 {
            return Err(ParamError::invalid("max_triangles", "must be at least 1"));
        }
        if !(self.residual_constant.is_finite() && self.residual_constant >= 0.0) {
            return Err(ParamError::range(
                "residual_constant",
                ">= 0",
                self.residual_constant,
            ));
        }
        Ok(())
    }
}

/// The cracking rules: the pipeline's, or with `remesh = false` ones that
/// always snap to the existing edge nearest the crack plane.
pub(in crate::sim) fn crack_rules(params: &SimParams) -> CrackRules {
    if params.remesh {
        params.rules
    } else {
        CrackRules {
            theta1: std::f64::consts::PI,
            ..params.rules
        }
    }
}

/// Parameters of the spring model (`[simulation.springs]`).
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpringParams {
    /// Range of spring stiffness (per unit strain), drawn per spring with
    /// the seed. Default [1, 1].
    pub stiffness: [f64; 2],
    /// Range of breaking strain, drawn per spring. Default [0.04, 0.08].
    pub break_strain: [f64; 2],
    /// Rest lengths shrink toward `alpha L0`. In (0, 1]; default 0.85.
    pub alpha: f64,
    /// Shrink rate `s` per unit time. Default 0.02.
    pub rate: f64,
    /// Drying law. Default `relax`.
    pub law: DryingLaw,
    /// Velocity damping per unit time. Default 0.5.
    pub damping: f64,
    /// Node mass. Default 1.
    pub mass: f64,
    /// Time step; 0 picks the stable step of the stiffest node. A larger
    /// one is split into stable sub-steps (reported). Default 0.
    pub dt: f64,
    /// Keep nodes on their tangent planes (the surface keeps its shape).
    /// Default true.
    pub tangent: bool,
    /// Simulated time. Default 200.
    pub max_time: f64,
    /// Stiffness of each node's bond to the body under it (force per unit
    /// of the node's displacement, in mean edges): a glaze on its pot, mud
    /// on its ground. Stress then builds again within a few edges of a
    /// crack (about `sqrt(k / bond)` of them), so cracks keep forming
    /// until the cells are that small, instead of the first cracks
    /// freeing whole regions. 0: no bond (the text's model). Default 0.
    pub bond: f64,
}

impl Default for SpringParams {
    fn default() -> Self {
        SpringParams {
            stiffness: [1.0, 1.0],
            break_strain: [0.04, 0.08],
            alpha: 0.85,
            rate: 0.02,
            law: DryingLaw::Relax,
            damping: 0.5,
            mass: 1.0,
            dt: 0.0,
            tangent: true,
            max_time: 200.0,
            bond: 0.0,
        }
    }
}

/// How rest lengths shrink.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DryingLaw {
    /// The text's law: `L -= (L - alpha L0) s dt` (fast at first, slowing
    /// as the target nears).
    #[default]
    Relax,
    /// At a constant rate, `L -= (1 - alpha) L0 s dt`, until `alpha L0`.
    Linear,
}

impl std::str::FromStr for Integrator {
    type Err = super::ParamError;

    /// An integrator by its pipeline name (`local-euler`, `backward-euler`...).
    fn from_str(s: &str) -> Result<Self, super::ParamError> {
        use serde::Deserialize;
        Integrator::deserialize(
            serde::de::value::StrDeserializer::<serde::de::value::Error>::new(s),
        )
        .map_err(|_| super::ParamError::UnknownName {
            name: s.to_string(),
            known: INTEGRATOR_NAMES,
        })
    }
}

/// The integrators' names, in the order the pipeline's parser lists them.
const INTEGRATOR_NAMES: &[&str] = &[
    "auto",
    "local-euler",
    "euler",
    "paper-euler",
    "backward-euler",
    "equilibrium",
    "rkl",
];

#[cfg(test)]
mod integrator_names {
    use super::*;

    /// The names are the parser's, and its message is the error's.
    #[test]
    fn unknown_integrator_lists_the_parsers_names() {
        use serde::Deserialize;
        let serde_says = Integrator::deserialize(serde::de::value::StrDeserializer::<
            serde::de::value::Error,
        >::new("nope"))
        .unwrap_err()
        .to_string();
        let e = "nope".parse::<Integrator>().unwrap_err();
        assert_eq!(e.to_string(), serde_says);
        for n in INTEGRATOR_NAMES {
            assert_eq!(n.parse::<Integrator>().unwrap().name(), *n);
        }
    }
}
