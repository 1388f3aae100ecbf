//! The simulation core (Iben & O'Brien 2009): element geometry on the
//! simulation mesh, node forces, separation tensors and stress relaxation.
//! No I/O and no printing here.

pub mod ageing;
pub mod amg;
pub mod cg;
pub mod crack;
mod diffusion;
pub mod driver;
pub mod ductile;
pub mod error;
pub mod film;
mod finish;
pub mod forces;
pub mod implicit;
mod integrate;
mod load;
pub mod observer;
pub mod params;
mod per_element;
pub mod queue;
pub mod relax;
pub mod report;
mod separation;
pub mod springs;
mod state;
pub mod tangent;

pub use crack::{crack_node, CrackEvent, CrackRules};
pub use driver::{relax_only, run, run_with};
pub use error::{Divergence, Misfit, ParamError, SimError};
pub use forces::{element_forces, node_forces, separation_tensor, split_tensile, Elements};
pub use observer::{Observer, Snapshot};
pub use params::{
    FilmPreconditioner, Integrator, Model, Propagation, Relaxation, SimParams, AUTO_STEP_LIMIT,
};
pub use queue::FailureQueue;
pub use relax::{energy, relax_step, stable_dt, RelaxStep};
pub use report::{FilmSolves, FinishReport, Phase, Relaxed, SimReport};
