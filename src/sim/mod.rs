//! The simulation core (Iben & O'Brien 2009): element geometry on the
//! simulation mesh, node forces, separation tensors and stress relaxation.
//! No I/O and no printing here.

pub mod crack;
pub mod driver;
pub mod film;
pub mod forces;
pub mod implicit;
pub mod queue;
pub mod relax;
pub mod springs;

pub use crack::{crack_node, CrackEvent, CrackRules};
pub use driver::{
    relax_only, run, run_with, Integrator, Observer, Phase, Relaxed, SimError, SimParams,
    SimReport, Snapshot,
};
pub use forces::{element_forces, node_forces, separation_tensor, split_tensile, Elements};
pub use queue::FailureQueue;
pub use relax::{energy, relax_step, stable_dt, RelaxStep};
