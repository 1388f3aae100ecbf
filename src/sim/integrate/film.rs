//! The bonded film's round: equilibrium of the film tied to its rest
//! position, by conjugate gradients.

use crate::math::{v3, Sym3};
use crate::mesh::SimMesh;
use crate::sim::forces::Fans;
use crate::sim::integrate::region::Region;
use crate::sim::integrate::scheme::{Round, RoundEnd, Scheme, EQUILIBRIUM_DT};
use crate::sim::load::add_load;
use crate::sim::load::Load;
use crate::sim::state::RoundCache;
use crate::sim::state::State;
use crate::sim::Phase;
use crate::sim::SimParams;
use crate::sim::SimReport;
use rayon::prelude::*;

/// One relaxation round of a bonded film ([`crate::sim::film`]): the
/// round's load, then the equilibrium `(K + k M) du = f - k M u` of the
/// film tied to its rest position, by conjugate gradients (the interface
/// term makes the system positive definite, so the solve converges in few
/// iterations whatever the triangles' shapes). Only the nodes of `region`
/// move when given. Returns the stress energy and the residual node force
/// (elastic plus interface) at the end.
#[allow(clippy::too_many_arguments)]
pub(in crate::sim) fn relax_film_round(
    mesh: &SimMesh,
    st: &mut State,
    params: &SimParams,
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
    // The failure test needs the stress to about 1e-3: a film's solves stop
    // at ten times the backward-Euler tolerance.
    let tol = (10.0 * params.tolerance).min(0.1);
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
    // Solved in the nodes' tangent planes, assembled once for the solve.
    bufs.tangent.assemble(&op, EQUILIBRIUM_DT);
    bufs.tangent
        .set_multigrid(params.film_preconditioner == crate::sim::FilmPreconditioner::Multigrid);
    let mut x = std::mem::take(&mut st.warm);
    let cg = bufs.tangent.solve_nodes(&rhs, &mut x, tol, 10_000);
    phase.cg_iterations += cg.iterations;
    let solves = &mut report.film_solves;
    let t = &bufs.tangent;
    solves.preconditioner = params.film_preconditioner.name();
    solves.solves += 1;
    solves.rows += t.n_nodes();
    solves.rows_assembled += t.reassembled;
    solves.builds = t.builds;
    [solves.setup_seconds, solves.solve_seconds] = t.seconds;
    if let Some(mg) = t.multigrid() {
        let levels = mg.stats().levels;
        if levels.first().map(|l| l.0) > solves.levels.first().map(|l| l[0]) {
            solves.levels = levels.iter().map(|&(n, b, m)| [n, b, m]).collect();
        }
    }
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

/// The bonded film (`[simulation] model = "film"`).
pub(in crate::sim) struct Film;

impl Scheme for Film {
    fn relax(
        &self,
        r: &Round,
        st: &mut State,
        _cache: &mut RoundCache,
        _known_force: &mut Option<Vec<[f64; 3]>>,
        loaded: &mut f64,
        _g: &mut Vec<[f64; 3]>,
        report: &mut SimReport,
        phase: &mut Phase,
    ) -> RoundEnd {
        let Round {
            mesh,
            params,
            fans,
            normals,
            region,
            ..
        } = *r;
        let mut out = RoundEnd::default();
        let load = r.load_for(loaded, params.relax_time);
        let (energy, force) =
            relax_film_round(mesh, st, params, fans, normals, region, load, report, phase);
        out.end_energy = Some(energy);
        out.end_force = Some(force);
        report.time += params.relax_time;
        report.relax_steps += 1;
        phase.steps = 1;
        out.step_dt = 0.0;
        out
    }
}
