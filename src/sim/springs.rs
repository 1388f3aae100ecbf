//! The mass-spring drying model (the drying-cracks source text): every mesh
//! edge is a spring whose rest length shrinks toward `alpha * L0`; nodes
//! move by damped semi-implicit Euler; a spring whose strain reaches its
//! breaking strain breaks, and the mesh opens there as in the main engine
//! ([`SimMesh::open_edge`]: vertices are duplicated where a fan separates).
//!
//! Lengths are normalised by the mesh's mean edge length, like the main
//! engine, so the same asset in any unit cracks the same way. Nodes move for
//! real here: the report's `displacement` is each node's motion (scene
//! units), which the width post-processing turns into gaps.

use crate::math::hash_unit;
use crate::math::v3;
use crate::mesh::{HalfedgeId, SimMesh, VertexId};
pub use crate::sim::params::{DryingLaw, SpringParams};
use crate::sim::per_element::{Born, Grows, PerNode};
use crate::sim::{
    Divergence, Misfit, Observer, ParamError, SimError, SimParams, SimReport, Snapshot,
};

mod finish;

impl SpringParams {
    /// Check every value, naming the key.
    pub fn validate(&self) -> Result<(), ParamError> {
        let range = |name: &str, r: [f64; 2], lo_ok: f64| {
            if r.iter().all(|x| x.is_finite()) && r[0] >= lo_ok && r[0] <= r[1] {
                Ok(())
            } else {
                Err(ParamError::range(
                    format!("springs.{name}"),
                    format!("[low, high] with {lo_ok} <= low <= high"),
                    format!("{r:?}"),
                ))
            }
        };
        range("stiffness", self.stiffness, f64::MIN_POSITIVE)?;
        range("break_strain", self.break_strain, 0.0)?;
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return Err(ParamError::range("springs.alpha", "in (0, 1]", self.alpha));
        }
        for (name, x) in [
            ("rate", self.rate),
            ("damping", self.damping),
            ("dt", self.dt),
            ("bond", self.bond),
        ] {
            if !(x.is_finite() && x >= 0.0) {
                return Err(ParamError::range(format!("springs.{name}"), ">= 0", x));
            }
        }
        if !(self.mass.is_finite() && self.mass > 0.0) {
            return Err(ParamError::range("springs.mass", "> 0", self.mass));
        }
        if !(self.max_time.is_finite() && self.max_time > 0.0) {
            return Err(ParamError::range("springs.max_time", "> 0", self.max_time));
        }
        Ok(())
    }
}

/// Most time steps a spring run takes (a stiffer spring range or a longer
/// `max_time` is refused instead of running for hours).
const MAX_STEPS: usize = 10_000_000;

/// How long the load is held after a break, in units of the damping's
/// time (`1 / damping`): the network's motion has died down by then.
const SETTLE_DAMPINGS: f64 = 2.0;

/// Most held time over a run, as a multiple of `max_time`.
const HOLD_BUDGET: f64 = 4.0;

/// One spring: a mesh edge (one of its halfedges) with its properties.
#[derive(Clone, Debug)]
struct Spring {
    h: HalfedgeId,
    /// The halfedge's origin and destination (refreshed when the mesh
    /// changes).
    a: u32,
    b: u32,
    k: f64,
    threshold: f64,
    rest0: f64,
    rest: f64,
    broken: bool,
}

/// The state of a spring run (normalised units).
struct Springs {
    springs: Vec<Spring>,
    /// Per node (a crack's copy of a node takes the original's values):
    /// position, rest position, velocity, rest normal, fixedness, and the
    /// time it first lay on a crack (NaN: never).
    x: PerNode<[f64; 3]>,
    x0: PerNode<[f64; 3]>,
    v: PerNode<[f64; 3]>,
    normals: PerNode<[f64; 3]>,
    fixed: PerNode<bool>,
    crack_time: PerNode<f64>,
    /// Per node: (spring, +1 or -1 for the force's sign at it), in spring order.
    adjacency: Vec<Vec<(u32, f64)>>,
}

impl Springs {
    /// The spring state of `mesh` at rest, in units of `unit` (its mean
    /// edge length): one spring per edge, its stiffness and breaking
    /// strain drawn from the seed by the edge's input vertices (so the
    /// draw does not depend on halfedge numbering); the fixed nodes and
    /// the rest normals.
    fn new(mesh: &SimMesh, params: &SimParams, unit: f64) -> Springs {
        let sp = &params.springs;
        let x0: Vec<[f64; 3]> = mesh
            .positions()
            .iter()
            .map(|p| v3::scale(*p, 1.0 / unit))
            .collect();
        let n = x0.len();
        // Springs: one per edge, drawn from the seed by the edge's input
        // vertices (so the draw does not depend on halfedge numbering).
        let mut springs = Vec::new();
        for h in mesh.halfedges() {
            if mesh.twin(h).is_some_and(|t| t.0 < h.0) {
                continue;
            }
            let (a, b) = (mesh.origin(h), mesh.dest(h));
            let rest0 = v3::norm(v3::sub(x0[b.idx()], x0[a.idx()]));
            if rest0 <= 0.0 {
                continue;
            }
            let key = {
                let (i, j) = (u64::from(a.0.min(b.0)), u64::from(a.0.max(b.0)));
                i.wrapping_mul(0x1_0000_0001) ^ j.rotate_left(29)
            };
            let draw = |r: [f64; 2], salt: u64| {
                let u = 0.5 * (hash_unit(params.seed ^ salt, key) + 1.0);
                r[0] + (r[1] - r[0]) * u
            };
            springs.push(Spring {
                h,
                a: a.0,
                b: b.0,
                k: draw(sp.stiffness, 0x51),
                threshold: draw(sp.break_strain, 0xB7),
                rest0,
                rest: rest0,
                broken: false,
            });
        }
        let fixed: Vec<bool> = mesh
            .vertices()
            .map(|v| {
                (params.fixed_boundary && mesh.is_boundary_vertex(v))
                    || (!params.fixed_groups.is_empty()
                        && mesh
                            .vertex_faces(v)
                            .any(|f| params.fixed_groups.contains(&mesh.face_group(f))))
            })
            .collect();
        let normals: Vec<[f64; 3]> = mesh
            .vertices()
            .map(|v| {
                let mut nrm = [0.0; 3];
                for f in mesh.vertex_faces(v) {
                    let [a, b, c] = mesh.face_vertices(f).map(|u| x0[u.idx()]);
                    nrm = v3::add(nrm, v3::cross(v3::sub(b, a), v3::sub(c, a)));
                }
                let l = v3::norm(nrm);
                if l > 0.0 {
                    v3::scale(nrm, 1.0 / l)
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        let copied = |values, none| PerNode::new(values, Born::Parent(none));
        Springs {
            springs,
            x: copied(x0.clone(), [0.0; 3]),
            x0: copied(x0, [0.0; 3]),
            v: copied(vec![[0.0; 3]; n], [0.0; 3]),
            normals: copied(normals, [0.0; 3]),
            fixed: PerNode::new(fixed, Born::Parent(false)),
            crack_time: PerNode::new(vec![f64::NAN; n], Born::Parent(f64::NAN)),
            adjacency: Vec::new(),
        }
    }

    /// Every per-node array, for [`Grows::grow`] after a crack.
    fn arrays(&mut self) -> [&mut dyn Grows; 6] {
        [
            &mut self.x,
            &mut self.x0,
            &mut self.v,
            &mut self.normals,
            &mut self.fixed,
            &mut self.crack_time,
        ]
    }

    /// Rebuild the node-to-spring lists (after the mesh changed).
    fn rebuild_adjacency(&mut self, mesh: &SimMesh) {
        for s in &mut self.springs {
            s.a = mesh.origin(s.h).0;
            s.b = mesh.dest(s.h).0;
        }
        self.rebuild_lists();
    }

    /// The node lists after the mesh split node `src` into `src` and `new`
    /// for each pair of `split`: only the springs at `src` can have moved
    /// an end to `new`, so only those two lists change (in spring order,
    /// as [`Springs::rebuild_lists`] makes them). No pass over every spring
    /// or node: a crack event costs what its nodes hold.
    fn split_lists(
        &mut self,
        mesh: &SimMesh,
        split: &[(crate::mesh::VertexId, crate::mesh::VertexId)],
    ) {
        self.adjacency.resize_with(self.x.len(), Vec::new);
        for &(new, src) in split {
            let (new, src) = (new.0, src.0);
            let at_src = std::mem::take(&mut self.adjacency[src as usize]);
            let mut at_new = Vec::new();
            let mut kept = Vec::with_capacity(at_src.len());
            for (k, _) in at_src {
                let s = &mut self.springs[k as usize];
                s.a = mesh.origin(s.h).0;
                s.b = mesh.dest(s.h).0;
                for (node, sign) in [(s.a, 1.0), (s.b, -1.0)] {
                    if node == src {
                        kept.push((k, sign));
                    } else if node == new {
                        at_new.push((k, sign));
                    }
                }
            }
            kept.sort_by_key(|e| e.0);
            at_new.sort_by_key(|e| e.0);
            self.adjacency[src as usize] = kept;
            self.adjacency[new as usize] = at_new;
        }
    }

    /// The node-to-spring lists from the springs' endpoints. Each list is
    /// allocated at its length, in node order, so the lists lie in memory
    /// as the force pass reads them (grown by pushes in spring order they
    /// lay scattered: at 114k simulated triangles the pass waited on them
    /// for half its time).
    fn rebuild_lists(&mut self) {
        let mut count = vec![0usize; self.x.len()];
        for s in self.springs.iter().filter(|s| !s.broken) {
            count[s.a as usize] += 1;
            count[s.b as usize] += 1;
        }
        self.adjacency = count.into_iter().map(Vec::with_capacity).collect();
        for (i, s) in self.springs.iter().enumerate() {
            if s.broken {
                continue;
            }
            self.adjacency[s.a as usize].push((i as u32, 1.0));
            self.adjacency[s.b as usize].push((i as u32, -1.0));
        }
    }

    /// Dry for `dt` (unless `dry` is false: the load is held), then one
    /// damped semi-implicit Euler step: velocities from the forces, then
    /// positions from the new velocities.
    fn advance(&mut self, sp: &SpringParams, dt: f64, dry: bool) {
        for s in self.springs.iter_mut().filter(|s| !s.broken && dry) {
            let target = sp.alpha * s.rest0;
            s.rest = match sp.law {
                // The text's `dL/dt = -(L - alpha L0) s`, solved exactly
                // over the step (its Euler form overshoots for s dt > 1).
                DryingLaw::Relax => target + (s.rest - target) * (-sp.rate * dt).exp(),
                DryingLaw::Linear => {
                    (s.rest - (1.0 - sp.alpha) * s.rest0 * sp.rate * dt).max(target)
                }
            };
        }
        let forces = self.spring_forces();
        for v in 0..self.x.len() {
            if self.fixed[v] {
                self.v[v] = [0.0; 3];
                continue;
            }
            let mut f = v3::scale(v3::sub(self.x0[v], self.x[v]), sp.bond);
            for &(i, sign) in &self.adjacency[v] {
                f = v3::add(f, v3::scale(forces[i as usize].0, sign));
            }
            // Damping taken implicitly: stable for any damping.
            let mut vel = v3::scale(
                v3::add(self.v[v], v3::scale(f, dt / sp.mass)),
                1.0 / (1.0 + sp.damping * dt),
            );
            if sp.tangent {
                let nrm = self.normals[v];
                vel = v3::sub(vel, v3::scale(nrm, v3::dot(vel, nrm)));
            }
            self.v[v] = vel;
            self.x[v] = v3::add(self.x[v], v3::scale(vel, dt));
        }
    }

    /// Each spring's force on its halfedge's origin (the destination gets
    /// the opposite) and its strain.
    fn spring_forces(&self) -> Vec<([f64; 3], f64)> {
        self.springs
            .iter()
            .map(|s| {
                if s.broken {
                    return ([0.0; 3], 0.0);
                }
                let d = v3::sub(self.x[s.b as usize], self.x[s.a as usize]);
                let len = v3::norm(d);
                let strain = (len - s.rest) / s.rest;
                if len <= 0.0 {
                    return ([0.0; 3], strain);
                }
                (v3::scale(d, s.k * strain / len), strain)
            })
            .collect()
    }

    /// Elastic energy `sum 1/2 k L strain^2` (per unit rest length) plus
    /// kinetic energy.
    fn energy(&self, mass: f64) -> (f64, f64) {
        let mut elastic = 0.0;
        for s in self.springs.iter().filter(|s| !s.broken) {
            let d = v3::sub(self.x[s.b as usize], self.x[s.a as usize]);
            let strain = (v3::norm(d) - s.rest) / s.rest;
            elastic += 0.5 * s.k * s.rest * strain * strain;
        }
        let kinetic = self
            .v
            .iter()
            .map(|v| 0.5 * mass * v3::dot(*v, *v))
            .sum::<f64>();
        (elastic, kinetic)
    }
}

/// The stable step of damped semi-implicit Euler for the stiffest node
/// over the whole run: `0.9 * 2 / omega_max` with `omega_max^2 <= max_n 2
/// sum_e k_e / (L_e m)` (Gershgorin on the stiffness of the springs around
/// each node), each rest length taken at its smallest (`alpha L0`, where a
/// spring is stiffest) and a margin of 2 for the sideways stiffness of
/// stretched springs.
fn stable_dt(springs: &Springs, mass: f64, alpha: f64, bond: f64) -> f64 {
    let mut row = vec![0.0; springs.x.len()];
    for s in springs.springs.iter().filter(|s| !s.broken) {
        let k = 2.0 * s.k / (alpha * s.rest0).min(s.rest).max(1e-12);
        row[s.a as usize] += 2.0 * k;
        row[s.b as usize] += 2.0 * k;
    }
    let w2 = (row.iter().fold(0.0f64, |a, &b| a.max(b)) + bond) / mass;
    if w2 > 0.0 {
        0.9 * 2.0 / w2.sqrt()
    } else {
        f64::INFINITY
    }
}

/// Run the spring model on `mesh` (opened in place where springs break).
///
/// # Errors
/// An invalid parameter, or a broken mesh invariant.
pub fn run(
    mesh: &mut SimMesh,
    params: &SimParams,
    observer: &mut dyn Observer,
) -> Result<SimReport, SimError> {
    let sp = &params.springs;
    params.validate()?;
    let unit = mesh.mean_edge_length();
    if !(unit > 0.0 && unit.is_finite()) {
        return Err(Misfit::NoEdgeLength.into());
    }
    let mut st = Springs::new(mesh, params, unit);
    let n = st.x.len();
    st.rebuild_adjacency(mesh);
    let stable = stable_dt(&st, sp.mass, sp.alpha, sp.bond);
    let (dt, substeps) = if sp.dt > 0.0 && sp.dt > stable {
        let k = (sp.dt / stable).ceil();
        (sp.dt / k, k as usize)
    } else if sp.dt > 0.0 {
        (sp.dt, 1)
    } else {
        (stable.min(sp.max_time), 1)
    };
    let mut report = SimReport {
        triangles: [mesh.n_faces(), 0],
        nodes: [mesh.n_vertices(), 0],
        length_unit: unit,
        stable_dt: stable,
        integrator: "springs-semi-implicit-euler",
        substeps,
        ..Default::default()
    };
    let (e0, _) = st.energy(sp.mass);
    report.energy[0] = e0;
    let snapshot =
        |mesh: &SimMesh, st: &Springs, report: &SimReport, observer: &mut dyn Observer| {
            if observer.wants_state() {
                let disp: Vec<[f64; 3]> =
                    st.x.iter()
                        .zip(&st.x0)
                        .map(|(x, x0)| v3::scale(v3::sub(*x, *x0), unit))
                        .collect();
                let (e, k) = st.energy(sp.mass);
                observer.state(&Snapshot {
                    mesh,
                    time: report.time,
                    displacement: &disp,
                    crack_time: &st.crack_time,
                    segments: &report.segments,
                    segment_times: &report.segment_times,
                    energy: e + k,
                });
            }
        };
    snapshot(mesh, &st, &report, observer);
    let steps_f = (sp.max_time / dt).ceil();
    if !(steps_f.is_finite() && steps_f <= MAX_STEPS as f64) {
        return Err(Misfit::SpringSteps {
            max_time: sp.max_time,
            steps: steps_f,
            dt,
            limit: MAX_STEPS,
        }
        .into());
    }
    // Quasistatic drying: after a break the load is held (no drying) for
    // `settle` while the network settles, so the break's neighbours, not
    // springs anywhere else, fail next and a crack runs on from its tip
    // as an avalanche (held time at most HOLD_BUDGET times max_time).
    let settle = SETTLE_DAMPINGS / sp.damping.max(0.1);
    let drying_steps = steps_f as usize;
    let steps = (drying_steps as f64 * (1.0 + HOLD_BUDGET)).min(MAX_STEPS as f64) as usize;
    let mut held_steps = 0usize;
    let mut hold_until = 0.0;
    let mut dried_steps = 0usize;
    let per_round = ((1.0 / dt).ceil() as usize).max(1); // a "round" is one unit of time
    let max_rounds = steps.div_ceil(per_round);
    let mut quiet_since = 0.0;
    report.stopped = format!("reached max_time ({})", sp.max_time);
    for step in 0..steps {
        if dried_steps >= drying_steps {
            break;
        }
        let t = step as f64 * dt;
        let dry = t >= hold_until || held_steps >= steps - drying_steps;
        if dry {
            dried_steps += 1;
        } else {
            held_steps += 1;
        }
        st.advance(sp, dt, dry);
        report.relax_steps += 1;
        report.time = t + dt;
        if break_overstrained(mesh, &mut st, params, &mut report, unit)? {
            quiet_since = report.time;
            hold_until = report.time + settle;
        }
        if (step + 1) % per_round == 0 || step + 1 == steps || dried_steps >= drying_steps {
            report.rounds += 1;
            observer.round(report.rounds, max_rounds, report.cracks, step + 1);
            snapshot(mesh, &st, &report, observer);
            // Done when drying is over, nothing has broken for a while and
            // the motion has died down.
            let dried =
                st.springs.iter().filter(|s| !s.broken).all(|s| {
                    (s.rest - sp.alpha * s.rest0).abs() <= 1e-6 * s.rest0 || sp.rate == 0.0
                });
            let (_, kinetic) = st.energy(sp.mass);
            if dried && report.time - quiet_since > 10.0 && kinetic < 1e-12 * n as f64 {
                report.stopped = "dried and at rest".into();
                break;
            }
        }
        if report.cracks >= params.max_cracks {
            report.stopped = format!("reached max_cracks ({})", params.max_cracks);
            break;
        }
        if !st.x.iter().flatten().all(|c| c.is_finite()) {
            return Err(Divergence::Springs {
                time: report.time,
                dt,
                stable,
            }
            .into());
        }
    }
    if report.cracks < params.max_cracks && join_near_tips(mesh, &mut st, &mut report, unit)? > 0 {
        st.rebuild_adjacency(mesh);
    }
    if params.finish {
        let reach = finish_reach(mesh, params, unit);
        let fin = finish::finish_tips(mesh, &mut st, &mut report, unit, reach, params.max_cracks)?;
        report.finish = Some(fin);
    }
    let (e1, _) = st.energy(sp.mass);
    report.energy[1] = e1;
    report.triangles[1] = mesh.n_faces();
    report.nodes[1] = mesh.n_vertices();
    report.displacement =
        st.x.iter()
            .zip(&st.x0)
            .map(|(x, x0)| v3::scale(v3::sub(*x, *x0), unit))
            .collect();
    report.crack_time = st.crack_time.into_values();
    Ok(report)
}

/// How far (normalised units: the mean edge is 1) a tip runs on in
/// finishing: `finish_reach` cell sizes, one when it is 0 (a cell size with
/// none given: [`FINISH_EDGES_PER_CELL`] mean edges).
fn finish_reach(mesh: &SimMesh, params: &SimParams, unit: f64) -> f64 {
    let cells = if params.finish_reach > 0.0 {
        params.finish_reach
    } else {
        1.0
    };
    match params.cell_size_for(mesh) {
        Some(cell) => cells * cell / unit,
        None => cells * FINISH_EDGES_PER_CELL,
    }
}

/// Mean edges in a cell size when the spring model runs on the input's own
/// triangles without one (the simulation surface's edges are an eighth of
/// the cell size).
const FINISH_EDGES_PER_CELL: f64 = 8.0;

/// Breaking: every spring at or over its strain breaks in this step, in
/// spring order (a spring between two fixed nodes cannot relax: it
/// holds), up to `max_cracks`; the node lists follow. Whether any broke.
fn break_overstrained(
    mesh: &mut SimMesh,
    st: &mut Springs,
    params: &SimParams,
    report: &mut SimReport,
    unit: f64,
) -> Result<bool, SimError> {
    let breaking: Vec<usize> = st
        .spring_forces()
        .iter()
        .zip(&st.springs)
        .enumerate()
        .filter(|(_, ((_, strain), s))| {
            !s.broken
                && *strain >= s.threshold
                && !(st.fixed[s.a as usize] && st.fixed[s.b as usize])
        })
        .map(|(i, _)| i)
        .collect();
    let mut broke = false;
    for i in breaking {
        if report.cracks >= params.max_cracks {
            break;
        }
        broke = true;
        break_spring(mesh, st, i, report, unit)?;
    }
    // The node lists followed each break (`Springs::split_lists`).
    debug_assert!({
        let mut fresh = st.adjacency.clone();
        std::mem::swap(&mut fresh, &mut st.adjacency);
        st.rebuild_adjacency(mesh);
        std::mem::swap(&mut fresh, &mut st.adjacency);
        fresh == st.adjacency
    });
    Ok(broke)
}

/// A crack tip that stopped right beside another crack (closer to one of
/// its edges, across one of the tip's faces, than half the tip's shorter
/// spring to that edge's ends or half the mean edge; or a neighbour on
/// another crack closer than half the mean edge) snaps the spring to the
/// nearer of those vertices: the ligament left is far thinner than a
/// spring and would not hold, and the tip then meets the crack (a
/// T-junction instead of a near miss). A tip is a vertex whose crack
/// sides lead to one rest position (the far end's copies on the two sides
/// are one). Returns how many tips were joined.
fn join_near_tips(
    mesh: &mut SimMesh,
    st: &mut Springs,
    report: &mut SimReport,
    unit: f64,
) -> Result<usize, SimError> {
    let key = |a: VertexId, b: VertexId| (a.0.min(b.0), a.0.max(b.0));
    let mut spring_of: std::collections::BTreeMap<(u32, u32), usize> = Default::default();
    for (i, sp) in st.springs.iter().enumerate() {
        if !sp.broken {
            spring_of.insert(key(mesh.origin(sp.h), mesh.dest(sp.h)), i);
        }
    }
    // Crack tips: vertices whose crack sides all lead to one neighbour
    // (by rest position: the far end's copies on the two sides are one).
    let mut along: Vec<Vec<u32>> = vec![Vec::new(); mesh.n_vertices()];
    let mut border = vec![false; mesh.n_vertices()];
    for h in mesh.halfedges() {
        let (a, b) = (mesh.origin(h), mesh.dest(h));
        if mesh.is_crack_halfedge(h) {
            along[a.idx()].push(b.0);
            along[b.idx()].push(a.0);
        } else if mesh.twin(h).is_none() {
            border[a.idx()] = true;
            border[b.idx()] = true;
        }
    }
    let mut snap: Vec<usize> = Vec::new();
    for v in mesh.vertices() {
        let mut n: Vec<[u64; 3]> = along[v.idx()]
            .iter()
            .map(|&u| st.x0[u as usize].map(f64::to_bits))
            .collect();
        n.sort_unstable();
        n.dedup();
        let p = st.x0[v.idx()];
        if n.len() != 1 || border[v.idx()] || st.fixed[v.idx()] {
            continue;
        }
        let mut best: Option<(f64, usize)> = None;
        for f in mesh.vertex_faces(v) {
            let hs = mesh.face_halfedges(f);
            let Some(&g) = hs
                .iter()
                .find(|&&g| mesh.origin(g) != v && mesh.dest(g) != v)
            else {
                continue;
            };
            if !mesh.is_crack_halfedge(g) {
                continue;
            }
            let (a, b) = (mesh.origin(g), mesh.dest(g));
            let (pa, pb) = (st.x0[a.idx()], st.x0[b.idx()]);
            let ab = v3::sub(pb, pa);
            let t = (v3::dot(v3::sub(p, pa), ab) / v3::dot(ab, ab).max(1e-300)).clamp(0.0, 1.0);
            let d = v3::norm(v3::sub(p, v3::add(pa, v3::scale(ab, t))));
            let (la, lb) = (v3::norm(v3::sub(pa, p)), v3::norm(v3::sub(pb, p)));
            let (w, l) = if la <= lb { (a, la) } else { (b, lb) };
            // Normalised units: the mean edge is 1.
            if d < 0.5 * l.max(1.0) && best.is_none_or(|x| d < x.0) {
                if let Some(&i) = spring_of.get(&key(v, w)) {
                    best = Some((d, i));
                }
            }
        }
        // A neighbour on another crack, closer than half the mean edge:
        // the tip all but reached it.
        for f in mesh.vertex_faces(v) {
            for w in mesh.face_vertices(f) {
                let l = v3::norm(v3::sub(st.x0[w.idx()], p));
                if w == v
                    || along[w.idx()].is_empty()
                    || n.contains(&st.x0[w.idx()].map(f64::to_bits))
                    || l >= 0.5
                {
                    continue;
                }
                if best.is_none_or(|x| l < x.0) {
                    if let Some(&i) = spring_of.get(&key(v, w)) {
                        best = Some((l, i));
                    }
                }
            }
        }
        if let Some((_, i)) = best {
            snap.push(i);
        }
    }
    snap.sort_unstable();
    snap.dedup();
    for &i in &snap {
        if !st.springs[i].broken {
            break_spring(mesh, st, i, report, unit)?;
        }
    }
    Ok(snap.len())
}

/// Break spring `i` at the report's time: open its edge (unless it is on
/// the border already), give the new nodes their copies of the state, and
/// record the crack.
fn break_spring(
    mesh: &mut SimMesh,
    st: &mut Springs,
    i: usize,
    report: &mut SimReport,
    unit: f64,
) -> Result<(), SimError> {
    st.springs[i].broken = true;
    let h = st.springs[i].h;
    let (a, b) = (mesh.origin(h), mesh.dest(h));
    // A broken spring pulls no more.
    for node in [st.springs[i].a, st.springs[i].b] {
        if let Some(list) = st.adjacency.get_mut(node as usize) {
            list.retain(|&(k, _)| k as usize != i);
        }
    }
    let Some(twin) = mesh.twin(h) else {
        // A border edge (or a side of an earlier crack): nothing
        // to open.
        return Ok(());
    };
    // The crack crosses the spring: between the rest centroids of the two
    // triangles on its edge (the dual edge; see `SimReport::crossings`).
    let centroid = |f: crate::mesh::FaceId| {
        let [p, q, r] = mesh.face_vertices(f).map(|v| st.x0[v.idx()]);
        v3::scale(v3::add(v3::add(p, q), r), 1.0 / 3.0)
    };
    let across = [centroid(mesh.face(h)), centroid(mesh.face(twin))];
    let opened = mesh.open_edge(h).map_err(SimError::Mesh)?;
    debug_assert!(opened
        .new_vertices
        .iter()
        .all(|&(new, src)| mesh.vertex_parent(new) == src));
    for a in st.arrays() {
        a.grow(mesh);
    }
    st.split_lists(mesh, &opened.new_vertices);
    for u in [a, b] {
        if st.crack_time[u.idx()].is_nan() {
            st.crack_time[u.idx()] = report.time;
        }
    }
    for &(new, src) in &opened.new_vertices {
        st.crack_time[new.idx()] = st.crack_time[src.idx()];
    }
    report.cracks += 1;
    report.crack_length += st.springs[i].rest0 * unit;
    report.first_crack_time.get_or_insert(report.time);
    // At the mesh's own rest positions (bit for bit), so the ends name
    // the crack's vertices.
    report.segments.push([mesh.position(a), mesh.position(b)]);
    report.crossings.push(across.map(|p| v3::scale(p, unit)));
    report.segment_times.push(report.time);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::jittered_plate;
    use std::collections::BTreeMap;

    /// A spring state without a mesh: nodes, springs `(a, b, k, rest)`,
    /// fixed flags, normal +z for every node.
    fn bare(x: Vec<[f64; 3]>, springs: &[(u32, u32, f64, f64)], fixed: Vec<bool>) -> Springs {
        let n = x.len();
        let mut st = Springs {
            springs: springs
                .iter()
                .map(|&(a, b, k, rest)| Spring {
                    h: HalfedgeId(0),
                    a,
                    b,
                    k,
                    threshold: f64::INFINITY,
                    rest0: rest,
                    rest,
                    broken: false,
                })
                .collect(),
            x0: PerNode::new(x.clone(), Born::Parent([0.0; 3])),
            x: PerNode::new(x, Born::Parent([0.0; 3])),
            v: PerNode::new(vec![[0.0; 3]; n], Born::Parent([0.0; 3])),
            normals: PerNode::new(vec![[0.0, 0.0, 1.0]; n], Born::Parent([0.0; 3])),
            fixed: PerNode::new(fixed, Born::Parent(false)),
            crack_time: PerNode::new(vec![f64::NAN; n], Born::Parent(f64::NAN)),
            adjacency: Vec::new(),
        };
        st.rebuild_lists();
        st
    }

    #[test]
    fn a_chain_settles_where_the_forces_balance() {
        // Ends fixed 3 apart; springs (k 1, rest 1) and (k 4, rest 1): the
        // middle node balances at 1 * (x - 1) / 1 = 4 * (3 - x - 1) / 1,
        // x = 9 / 5.
        let mut st = bare(
            vec![[0.0; 3], [1.5, 0.0, 0.0], [3.0, 0.0, 0.0]],
            &[(0, 1, 1.0, 1.0), (1, 2, 4.0, 1.0)],
            vec![true, false, true],
        );
        let sp = SpringParams {
            rate: 0.0,
            damping: 1.0,
            ..Default::default()
        };
        let dt = 0.5 * stable_dt(&st, sp.mass, sp.alpha, sp.bond);
        for _ in 0..5000 {
            st.advance(&sp, dt, true);
        }
        assert!((st.x[1][0] - 1.8).abs() < 1e-9, "{:?}", st.x[1]);
        assert_eq!(st.x[0], [0.0; 3]);
        assert_eq!(st.x[2], [3.0, 0.0, 0.0]);
    }

    #[test]
    fn a_free_triangle_shrinks_to_alpha_keeping_its_shape_and_centre() {
        let p = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.5, 1.5, 0.0]];
        let len = |a: [f64; 3], b: [f64; 3]| v3::norm(v3::sub(a, b));
        let rests = [len(p[0], p[1]), len(p[1], p[2]), len(p[2], p[0])];
        let mut st = bare(
            p.to_vec(),
            &[
                (0, 1, 1.0, rests[0]),
                (1, 2, 2.0, rests[1]),
                (2, 0, 0.5, rests[2]),
            ],
            vec![false; 3],
        );
        let sp = SpringParams {
            alpha: 0.7,
            rate: 0.1,
            damping: 1.0,
            ..Default::default()
        };
        let dt = 0.5 * stable_dt(&st, sp.mass, sp.alpha, sp.bond);
        for _ in 0..40_000 {
            st.advance(&sp, dt, true);
        }
        let centre = |x: &[[f64; 3]]| v3::scale(v3::add(v3::add(x[0], x[1]), x[2]), 1.0 / 3.0);
        for (k, (a, b)) in [(0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
            let l = len(st.x[a], st.x[b]);
            assert!(
                (l - 0.7 * rests[k]).abs() < 1e-6,
                "edge {k}: {l} vs {}",
                0.7 * rests[k]
            );
        }
        assert!(v3::norm(v3::sub(centre(&st.x), centre(&p))) < 1e-9);
        assert!(st.x.iter().all(|x| x[2] == 0.0), "stays in its plane");
    }

    #[test]
    fn without_drying_the_damped_energy_only_falls() {
        // A jittered plate's nodes pushed off their rest places, then let go.
        let mesh = jittered_plate(8, 0.3, 4);
        let unit = mesh.mean_edge_length();
        let x: Vec<[f64; 3]> = mesh
            .positions()
            .iter()
            .map(|p| v3::scale(*p, 1.0 / unit))
            .collect();
        let mut st = bare(x.clone(), &[], vec![false; x.len()]);
        for h in mesh.halfedges() {
            if mesh.twin(h).is_some_and(|t| t.0 < h.0) {
                continue;
            }
            let (a, b) = (mesh.origin(h), mesh.dest(h));
            let rest = v3::norm(v3::sub(x[b.idx()], x[a.idx()]));
            st.springs.push(Spring {
                h,
                a: a.0,
                b: b.0,
                k: 1.0 + 0.5 * hash_unit(3, u64::from(h.0)),
                threshold: f64::INFINITY,
                rest0: rest,
                rest,
                broken: false,
            });
        }
        st.rebuild_lists();
        for (i, p) in st.x.iter_mut().enumerate() {
            p[0] += 0.1 * hash_unit(7, i as u64);
            p[1] += 0.1 * hash_unit(8, i as u64);
        }
        let sp = SpringParams {
            rate: 0.0,
            damping: 0.5,
            ..Default::default()
        };
        let dt = stable_dt(&st, sp.mass, sp.alpha, sp.bond);
        let total = |st: &Springs| {
            let (e, k) = st.energy(sp.mass);
            e + k
        };
        let e0 = total(&st);
        // Sampled every few steps (semi-implicit Euler trades a little
        // between the two energies within a step).
        let mut last = e0;
        for _ in 0..60 {
            for _ in 0..5 {
                st.advance(&sp, dt, true);
            }
            let e = total(&st);
            assert!(e <= last * (1.0 + 1e-9), "energy rose: {last} -> {e}");
            last = e;
        }
        assert!(last < 0.2 * e0, "{e0} -> {last}");
    }

    fn grid_run(break_strain: [f64; 2], jitter: f64) -> (SimMesh, SimReport) {
        let mut mesh = jittered_plate(12, jitter, 2);
        let params = SimParams {
            fixed_boundary: true,
            seed: 3,
            model: crate::sim::Model::Springs,
            springs: SpringParams {
                break_strain,
                max_time: 150.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let r = run(&mut mesh, &params, &mut ()).unwrap();
        mesh.validate().unwrap();
        (mesh, r)
    }

    #[test]
    fn identical_thresholds_break_everything_at_once_and_noise_makes_cells() {
        // A regular grid held at its border, every spring alike: strains
        // stay equal, so every spring breaks in the same step.
        let (mesh, r) = grid_run([0.05, 0.05], 0.0);
        let springs = mesh
            .halfedges()
            .filter(|&h| mesh.twin(h).is_none_or(|t| t.0 > h.0))
            .count();
        assert!(r.cracks > 0);
        let (t0, t1) = r
            .segment_times
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &t| (a.min(t), b.max(t)));
        assert!(
            t1 - t0 <= r.stable_dt * 1.01,
            "breaks spread over {t0}..{t1}"
        );
        // Every triangle ends on its own, but for the few held together by
        // an interior edge between two fixed border nodes (such a spring
        // cannot relax, so it never breaks).
        let pieces = crate::post::islands::face_islands(&mesh).count;
        assert!(
            pieces * 100 >= mesh.n_faces() * 98,
            "{pieces} pieces of {} triangles",
            mesh.n_faces()
        );
        assert!(springs > 0);
        // Spread thresholds: breaks spread over time and leave cells of
        // several triangles.
        let (mesh, r) = grid_run([0.03, 0.09], 0.3);
        let (t0, t1) = r
            .segment_times
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &t| (a.min(t), b.max(t)));
        assert!(t1 - t0 > 20.0 * r.stable_dt, "{t0}..{t1}");
        let pieces = crate::post::islands::face_islands(&mesh).count;
        assert!(
            pieces > 3 && pieces * 4 < mesh.n_faces(),
            "{pieces} pieces of {} triangles",
            mesh.n_faces()
        );
        assert_eq!(r.displacement.len(), mesh.n_vertices());
        assert_eq!(r.crack_time.len(), mesh.n_vertices());
        // Each crack crosses its broken spring: the line between the two
        // triangles' centroids cuts the spring's edge (in the plate's plane).
        assert_eq!(r.crossings.len(), r.segments.len());
        let cross2 = |o: [f64; 3], p: [f64; 3], q: [f64; 3]| {
            (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0])
        };
        for (&[a, b], &[c, d]) in r.segments.iter().zip(&r.crossings) {
            assert!(
                cross2(a, b, c) * cross2(a, b, d) < 0.0 && cross2(c, d, a) * cross2(c, d, b) < 0.0,
                "{a:?}-{b:?} not crossed by {c:?}-{d:?}"
            );
        }
    }

    #[test]
    fn strong_shrinkage_damping_and_fast_drying_stay_stable() {
        let run_with = |f: &dyn Fn(&mut SpringParams)| {
            let mut mesh = jittered_plate(10, 0.3, 2);
            let mut sp = SpringParams {
                max_time: 60.0,
                ..Default::default()
            };
            f(&mut sp);
            let params = SimParams {
                fixed_boundary: true,
                model: crate::sim::Model::Springs,
                springs: sp,
                ..Default::default()
            };
            let r = run(&mut mesh, &params, &mut ()).unwrap();
            assert!(r.displacement.iter().flatten().all(|x| x.is_finite()));
            r
        };
        // Rest lengths down to 30% (springs over three times stiffer) and
        // unbreakable springs: nothing breaks, nothing blows up.
        let r = run_with(&|sp| {
            sp.alpha = 0.3;
            sp.rate = 0.1;
            sp.break_strain = [10.0, 10.0];
        });
        assert_eq!(r.cracks, 0);
        // Heavy damping and near-instant drying run too.
        run_with(&|sp| sp.damping = 50.0);
        run_with(&|sp| sp.rate = 50.0);
        // A requested step above the stable one is split and reported.
        let r = run_with(&|sp| sp.dt = 5.0);
        assert!(r.substeps > 1, "{}", r.substeps);
    }

    /// Open crack ends by position: crack points with one crack
    /// neighbour, off the plate's border (the unit plate's box).
    fn open_ends(r: &SimReport, lo: [f64; 3], hi: [f64; 3]) -> usize {
        let mut degree: BTreeMap<[u64; 3], std::collections::BTreeSet<[u64; 3]>> = BTreeMap::new();
        for s in &r.segments {
            let [a, b] = s.map(|p| p.map(f64::to_bits));
            degree.entry(a).or_default().insert(b);
            degree.entry(b).or_default().insert(a);
        }
        let inside = |k: &[u64; 3]| {
            let p = k.map(f64::from_bits);
            (0..2).all(|i| p[i] > lo[i] + 1e-9 && p[i] < hi[i] - 1e-9)
        };
        degree
            .iter()
            .filter(|(k, n)| n.len() == 1 && inside(k))
            .count()
    }

    #[test]
    fn finishing_runs_open_tips_on_to_the_crack_ahead() {
        let crack = |finish: bool, reach: f64| {
            let mut mesh = jittered_plate(24, 0.3, 5);
            let params = SimParams {
                fixed_boundary: true,
                seed: 3,
                model: crate::sim::Model::Springs,
                finish,
                finish_reach: reach,
                springs: SpringParams {
                    break_strain: [0.05, 0.07],
                    bond: 0.05,
                    max_time: 150.0,
                    ..Default::default()
                },
                ..Default::default()
            };
            let box_ = mesh.bounding_box();
            let r = run(&mut mesh, &params, &mut ()).unwrap();
            mesh.validate().unwrap();
            (open_ends(&r, box_.0, box_.1), r)
        };
        let (ends0, r0) = crack(false, 0.0);
        let (ends1, r1) = crack(true, 40.0);
        assert!(r0.finish.is_none());
        let fin = r1.finish.as_ref().unwrap();
        assert!(ends0 >= 6, "{ends0} open ends to finish");
        // The drying is the same; finishing only adds springs after it.
        assert_eq!(r1.segments[..r0.segments.len()], r0.segments[..]);
        assert_eq!(fin.cracks, r1.cracks - r0.cracks);
        assert!(fin.cracks > 0);
        assert!(
            ends1 * 4 <= ends0,
            "open ends {ends0} -> {ends1} ({} tips, {} stuck)",
            fin.tips,
            fin.stuck
        );
        // Within a short reach fewer tips find a crack ahead.
        let (ends2, r2) = crack(true, 0.05);
        assert!(ends2 > ends1, "{ends2} <= {ends1}");
        assert!(r2.finish.unwrap().stuck > fin.stuck);
    }

    #[test]
    fn options_of_the_other_engine_are_refused() {
        let mut mesh = jittered_plate(4, 0.0, 1);
        let terms = [crate::stress::Term {
            kind: crate::stress::TermKind::Uniform,
            init: 1.0,
            evolve: 0.0,
            mask: None,
        }];
        let field = crate::stress::StressField::build(&mesh, &terms, 1).unwrap();
        let params = SimParams {
            model: crate::sim::Model::Springs,
            ..Default::default()
        };
        let e = crate::sim::run_with(&mut mesh, &params, Some(&field), &mut ())
            .unwrap_err()
            .to_string();
        assert!(e.contains("stress terms"), "{e}");
    }
}
