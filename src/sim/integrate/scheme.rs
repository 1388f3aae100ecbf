//! What every integrator family's round shares: the [`Scheme`] trait, the
//! [`Round`] it works with and the [`RoundEnd`] it leaves.

use crate::mesh::SimMesh;
use crate::sim::forces::Fans;
use crate::sim::integrate::region::Region;
use crate::sim::load::Load;
use crate::sim::report::{Phase, SimReport};
use crate::sim::state::{RoundCache, State};
use crate::sim::SimParams;

/// What a round's scheme works with besides the state.
pub(in crate::sim) struct Round<'a> {
    pub(in crate::sim) mesh: &'a SimMesh,
    pub(in crate::sim) params: &'a SimParams,
    pub(in crate::sim) fans: &'a Fans,
    pub(in crate::sim) normals: &'a [[f64; 3]],
    /// Local relaxation: only this region moves.
    pub(in crate::sim) region: Option<&'a Region>,
    /// Whether the load acts in this round.
    pub(in crate::sim) loading: bool,
}

impl Round<'_> {
    /// The load of a step of `dt`: while loading, what is left of the load
    /// time, at most `dt` (added to `loaded`).
    pub(in crate::sim) fn load_for(&self, loaded: &mut f64, dt: f64) -> Load {
        let load_dt = if self.loading {
            dt.min(self.params.load_time - *loaded).max(0.0)
        } else {
            0.0
        };
        *loaded += load_dt;
        Load {
            dt: load_dt,
            shrink_rate: self.params.shrink_rate,
        }
    }

    /// The steps of a round and their length for a largest step `dt`:
    /// `relax_steps` of `dt`, or as many as `relax_time` needs.
    pub(in crate::sim) fn steps_for(&self, dt: f64) -> (usize, f64) {
        let params = self.params;
        if params.relax_steps > 0 {
            (params.relax_steps, dt)
        } else {
            let n = ((params.relax_time / dt).ceil() as usize).max(1);
            (n, params.relax_time / n as f64)
        }
    }
}

/// What a scheme's round leaves for the round's common end.
#[derive(Default)]
pub(in crate::sim) struct RoundEnd {
    /// The force at the end of the round, when the scheme gives it.
    pub(in crate::sim) end_force: Option<Vec<[f64; 3]>>,
    /// The energy at the end of the round, when the last pass gave it.
    pub(in crate::sim) end_energy: Option<f64>,
    /// The step the error estimate assumes (0: none).
    pub(in crate::sim) step_dt: f64,
    /// The mobility of each node in the steps (empty: 1 everywhere).
    pub(in crate::sim) step_mobility: Vec<f64>,
    /// RKL: the round's step-doubling error estimate, when sampled.
    pub(in crate::sim) rkl_estimate: Option<f64>,
}

/// One integrator family's relaxation round: moves the state on by the
/// round's relaxation time (and load), counting time, steps and solver
/// work in `report` and `phase`.
pub(in crate::sim) trait Scheme {
    #[allow(clippy::too_many_arguments)]
    fn relax(
        &self,
        r: &Round,
        st: &mut State,
        cache: &mut RoundCache,
        known_force: &mut Option<Vec<[f64; 3]>>,
        loaded: &mut f64,
        g: &mut Vec<[f64; 3]>,
        report: &mut SimReport,
        phase: &mut Phase,
    ) -> RoundEnd;
}

/// The step of an equilibrium solve: long enough that `I` is negligible
/// beside `dt K` (stiffness is of order 1 in normalised units).
pub(in crate::sim) const EQUILIBRIUM_DT: f64 = 1e12;
