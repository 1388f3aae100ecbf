//! No tensor relaxation (eigenvalue diffusion): the round only adds its load, and the separation it adds goes into the frozen tensors.

use crate::math::Sym3;
use crate::mesh::VertexId;
use crate::sim::forces::{corner_forces, separation_tensor};
use crate::sim::integrate::scheme::{Round, RoundEnd, Scheme};
use crate::sim::load::add_load;
use crate::sim::state::RoundCache;
use crate::sim::state::State;
use crate::sim::Phase;
use crate::sim::SimReport;
use rayon::prelude::*;

/// No tensor relaxation (eigenvalue diffusion): the round only adds its load, and the separation it adds goes into the frozen tensors.
pub(in crate::sim) struct Frozen;

impl Scheme for Frozen {
    fn relax(
        &self,
        r: &Round,
        st: &mut State,
        _cache: &mut RoundCache,
        _known_force: &mut Option<Vec<[f64; 3]>>,
        loaded: &mut f64,
        _g: &mut Vec<[f64; 3]>,
        report: &mut SimReport,
        _phase: &mut Phase,
    ) -> RoundEnd {
        let Round {
            mesh,
            params,
            fans: _,
            normals: _,
            region: _,
            ..
        } = *r;
        let mut out = RoundEnd::default();
        // No tensor relaxation: the round only adds its load, and the
        // separation it adds goes into the frozen tensors.
        let load = r.load_for(loaded, params.relax_time);
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
        out.step_dt = 0.0;
        out
    }
}
