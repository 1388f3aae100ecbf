//! Errors of a simulation run.

use crate::mesh::MeshError;

/// An invalid simulation parameter; the message names it and its value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParamError {
    /// A value outside its range: `{key} must be {expected}, got {got}`.
    #[error("{key} must be {expected}, got {got}")]
    Range {
        /// The parameter (e.g. `springs.alpha`, `ductile.young`).
        key: String,
        /// What it must be (e.g. `in (0, 1]`).
        expected: String,
        /// The value given.
        got: String,
    },
    /// A value that cannot be used as given (or with another one); the
    /// message is the key followed by the reason.
    #[error("{key} {reason}")]
    Invalid {
        /// The parameter (or parameters).
        key: String,
        /// Why (e.g. `must be at least 1`).
        reason: String,
    },
    /// Two keys that exclude each other were both given.
    #[error("give {first} or {second}, not both")]
    Both {
        /// The first key.
        first: String,
        /// The second key.
        second: String,
    },
    /// A name (an integrator's) that is not one of the known ones; the
    /// message lists them.
    #[error("unknown variant `{name}`, expected one of {}", quoted(known))]
    UnknownName {
        /// The name given.
        name: String,
        /// The known names.
        known: &'static [&'static str],
    },
}

/// `names` each in backquotes, joined by commas.
fn quoted(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    quoted.join(", ")
}

impl ParamError {
    /// `{key} must be {expected}, got {got}`.
    pub fn range(
        key: impl Into<String>,
        expected: impl Into<String>,
        got: impl std::fmt::Display,
    ) -> Self {
        ParamError::Range {
            key: key.into(),
            expected: expected.into(),
            got: got.to_string(),
        }
    }
    /// `{key} {reason}`.
    pub fn invalid(key: impl Into<String>, reason: impl Into<String>) -> Self {
        ParamError::Invalid {
            key: key.into(),
            reason: reason.into(),
        }
    }
    /// The parameter the error names (the first of two), if one.
    pub fn key(&self) -> Option<&str> {
        match self {
            ParamError::Range { key, .. } | ParamError::Invalid { key, .. } => Some(key),
            ParamError::Both { first, .. } => Some(first),
            ParamError::UnknownName { .. } => None,
        }
    }
}

/// Errors of a simulation run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// A parameter is invalid.
    #[error("invalid parameter: {0}")]
    Params(ParamError),
    /// The mesh or the stress field does not fit the parameters (no edge
    /// of positive length, a field of another mesh, a step too small).
    #[error("invalid parameter: {fault}")]
    Param {
        /// What does not fit.
        fault: Misfit,
    },
    /// Relaxation diverged (an explicit step above the stable one).
    #[error("{fault}")]
    Diverged {
        /// Where and how.
        fault: Divergence,
    },
    /// A mesh invariant broke (a bug).
    #[error("internal mesh error: {0}")]
    Mesh(#[from] MeshError),
}

/// How the mesh or the stress field does not fit the parameters
/// ([`SimError::Param`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Misfit {
    /// The mesh has no edge of positive length.
    #[error("the mesh has no edge of positive length")]
    NoEdgeLength,
    /// Stress terms given to the spring model.
    #[error(
        "stress terms do not apply to model = \"springs\" (its load is the drying of the springs)"
    )]
    FieldOnSprings,
    /// Several drying cycles without a cell size.
    #[error("cycles above 1 need a cell size")]
    CyclesWithoutCell,
    /// A stress field of another mesh.
    #[error("the stress field has {field} faces, the mesh {mesh}")]
    FieldFaces {
        /// The field's faces.
        field: usize,
        /// The mesh's faces.
        mesh: usize,
    },
    /// The spring model would need more steps than are run.
    #[error("springs: max_time {max_time} needs {steps:.3e} steps of {dt:.3e} (the stable step of the stiffest spring); at most {limit} are run: lower the stiffness range or max_time")]
    SpringSteps {
        /// `springs.max_time`.
        max_time: f64,
        /// The steps it needs.
        steps: f64,
        /// The step (the stable step of the stiffest spring).
        dt: f64,
        /// The most steps run.
        limit: usize,
    },
}

/// How a relaxation diverged ([`SimError::Diverged`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Divergence {
    /// The spring model's positions stopped being finite.
    #[error(
        "the spring model diverged at time {time:.3} (step {dt:.3e}, stable step {stable:.3e})"
    )]
    Springs {
        /// The simulated time.
        time: f64,
        /// The step.
        dt: f64,
        /// The stable step.
        stable: f64,
    },
    /// The energy of a relaxation stopped being finite, or grew under the
    /// paper's explicit step.
    #[error("relaxation diverged with integrator {integrator} (energy {before:.3e} -> {after:.3e}); relax_dt {relax_dt} is above the stable step {stable_dt:.3e}: use a smaller relax_dt or another integrator")]
    Relaxation {
        /// The integrator's name.
        integrator: &'static str,
        /// The energy before.
        before: f64,
        /// The energy after.
        after: f64,
        /// `relax_dt`.
        relax_dt: f64,
        /// The stable step.
        stable_dt: f64,
    },
}

impl From<Misfit> for SimError {
    fn from(fault: Misfit) -> Self {
        SimError::Param { fault }
    }
}

impl From<Divergence> for SimError {
    fn from(fault: Divergence) -> Self {
        SimError::Diverged { fault }
    }
}

impl From<ParamError> for SimError {
    fn from(e: ParamError) -> Self {
        SimError::Params(e)
    }
}
