//! The [`Observer`] a run tells about each round (progress) and, when it
//! asks, the state after it ([`Snapshot`], for time-lapse frames).

use crate::mesh::SimMesh;

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

/// The state of a run at one moment, for [`Observer::state`].
pub struct Snapshot<'a> {
    /// The mesh, cracks opened so far.
    pub mesh: &'a SimMesh,
    /// Simulation time.
    pub time: f64,
    /// Every node's accumulated relaxation displacement, as
    /// [`crate::sim::SimReport::displacement`].
    pub displacement: &'a [[f64; 3]],
    /// Every node's crack time so far (NaN: not on a crack), as
    /// [`crate::sim::SimReport::crack_time`].
    pub crack_time: &'a [f64],
    /// The crack segments so far and their times, as
    /// [`crate::sim::SimReport::segments`] and [`crate::sim::SimReport::segment_times`].
    pub segments: &'a [[[f64; 3]; 2]],
    /// See `segments`.
    pub segment_times: &'a [f64],
    /// Area-weighted stress energy `1/2 sum_e A_e |S_e|^2` now.
    pub energy: f64,
}
