//! Finishing: open crack tips run on until they meet a crack or the
//! border, where the material allows it (confined masks are respected).

use crate::math::{v3, Sym3};
use crate::mesh::{SimMesh, VertexId};
use crate::sim::crack::crack_node_avoiding;
use crate::sim::integrate::relax_round;
use crate::sim::observer::Observer;
use crate::sim::params::crack_rules;
use crate::sim::separation::separation_factor;
use crate::sim::state::apply_event;
use crate::sim::state::observe;
use crate::sim::state::touched_nodes;
use crate::sim::state::vertex_root;
use crate::sim::state::State;
use crate::sim::FinishReport;
use crate::sim::SimError;
use crate::sim::SimParams;
use crate::sim::SimReport;

/// The tips to finish, in id order, with the normal of the plane each
/// cracks along.
pub(in crate::sim) fn finish_tips(mesh: &SimMesh, st: &State) -> Vec<(VertexId, [f64; 3])> {
    mesh.vertices()
        .filter_map(|v| tip_plane(mesh, st, v).map(|p| (v, p)))
        .collect()
}

/// Whether `v` is a crack tip to finish, and the normal of the plane it
/// cracks along: an open crack end (one crack edge, not on the border) goes
/// on along its residual's direction, or straight on; a node where two
/// crack edges enclose more than 270 degrees of surface splits that corner
/// along its bisector.
pub(in crate::sim) fn tip_plane(mesh: &SimMesh, st: &State, v: VertexId) -> Option<[f64; 3]> {
    if separation_factor(mesh, st, v) < FINISH_MIN_FACTOR {
        return None; // the field keeps this material from cracking
    }
    open_tip_plane(mesh, st, v)
}

/// Finishing leaves a tip where the mean separation factor of its faces is
/// below this: material a confining mask (or a curvature scale) keeps from
/// cracking is not cracked by finishing either.
pub(in crate::sim) const FINISH_MIN_FACTOR: f64 = 0.5;

/// [`tip_plane`] without the field's confinement.
pub(in crate::sim) fn open_tip_plane(mesh: &SimMesh, st: &State, v: VertexId) -> Option<[f64; 3]> {
    let mut crack_sides = 0;
    for h in mesh.vertex_outgoing(v) {
        for e in [h, mesh.prev(h)] {
            if mesh.is_boundary_halfedge(e) {
                if !mesh.is_crack_halfedge(e) {
                    return None; // on the border: finished
                }
                crack_sides += 1;
            }
        }
    }
    if crack_sides == 0 {
        return None;
    }
    let dirs = crate::sim::crack::crack_directions(mesh, v);
    let n = mesh
        .vertex_faces(v)
        .map(|f| mesh.face_normal(f))
        .fold([0.0; 3], v3::add);
    if dirs.len() == 1 {
        let (val, dir) = st.residual[v.idx()].max_eigen();
        Some(if val > 0.0 {
            dir
        } else {
            v3::cross(n, dirs[0])
        })
    } else {
        wide_corner(mesh, v).map(|bisector| v3::cross(n, bisector))
    }
}

/// For a node whose single fan (it is duplicated per side of a crack, so
/// each copy has one) spans more than 270 degrees between two crack
/// edges, the unit bisector of that fan; otherwise `None`.
pub(in crate::sim) fn wide_corner(mesh: &SimMesh, v: VertexId) -> Option<[f64; 3]> {
    mesh.fan_middle(v)
        .filter(|(angle, _)| *angle > 1.5 * std::f64::consts::PI)
        .map(|(_, d)| d)
}

/// Crack finishing (sec. 5): each pass cracks every tip once along its
/// plane (its residual's direction, or straight on), regardless of the
/// toughness, then relaxes without load; until no tip is left, every tip is
/// stuck, or `max_cracks` is reached. A tip whose step makes no crack
/// (blocked by the angle rules) is left where it is.
pub(in crate::sim) fn finish_cracks(
    mesh: &mut SimMesh,
    st: &mut State,
    params: &SimParams,
    g: &mut Vec<[f64; 3]>,
    report: &mut SimReport,
    observer: &mut dyn Observer,
) -> Result<FinishReport, SimError> {
    let mut fin = FinishReport::default();
    let mut stuck: std::collections::BTreeSet<u32> = Default::default();
    let (cracks0, length0) = (report.cracks, report.crack_length);
    fin.tips = finish_tips(mesh, st).len();
    let mut loaded = params.load_time;
    // With a reach: the tips allowed to run on and the length each has left.
    let mut reach: Option<std::collections::BTreeMap<u32, f64>> = st
        .film
        .as_ref()
        .filter(|_| params.finish_reach > 0.0)
        .map(|film| tips_with_a_crack_ahead(mesh, st, params.finish_reach * film.cell));
    // Every pass moves each tip at least one fan further; a generous bound
    // on the passes keeps a pathological mesh from looping.
    let max_passes = 4 * mesh.n_vertices().max(16);
    while fin.passes < max_passes && report.cracks < params.max_cracks {
        let tips: Vec<(VertexId, [f64; 3])> = finish_tips(mesh, st)
            .into_iter()
            .filter(|(v, _)| !stuck.contains(&v.0))
            .filter(|(v, _)| {
                reach
                    .as_ref()
                    .is_none_or(|r| r.get(&vertex_root(mesh, *v).0).is_some_and(|&l| l > 0.0))
            })
            .collect();
        if tips.is_empty() {
            break;
        }
        fin.passes += 1;
        let mut moved = false;
        let mut seeds: Vec<VertexId> = Vec::new();
        for (v, _) in tips {
            if report.cracks >= params.max_cracks {
                break;
            }
            // A tip may have stopped being one during this pass (another
            // crack ran into it).
            let Some(plane) = tip_plane(mesh, st, v) else {
                continue;
            };
            let ev = crack_node_avoiding(mesh, v, plane, &crack_rules(params), &|m, w| {
                crowded_junction(m, &st.crack_degree, w)
            })
            .map_err(SimError::Mesh)?;
            let residual = st.residual[v.idx()];
            st.residual[v.idx()] = Sym3::ZERO;
            let left = reach
                .as_ref()
                .and_then(|r| r.get(&vertex_root(mesh, v).0).copied());
            if apply_event(mesh, st, report, &ev) {
                moved = true;
                if let (Some(r), Some(left)) = (reach.as_mut(), left) {
                    for &(_, tip) in &ev.segments {
                        r.insert(vertex_root(mesh, tip).0, left - ev.length);
                    }
                }
                seeds.extend(touched_nodes(mesh, &ev));
                // The new tips carry the direction on.
                for &(_, tip) in &ev.segments {
                    st.residual[tip.idx()] = if residual.frobenius_sq() > 0.0 {
                        residual
                    } else {
                        Sym3::m(plane)
                    };
                }
            } else {
                stuck.insert(v.0);
            }
        }
        // A film's tips follow their own directions: its stress is settled
        // once, after the last pass.
        if st.film.is_none() {
            relax_round(
                mesh,
                st,
                params,
                g,
                false,
                &mut loaded,
                report,
                Some(&seeds),
            )?;
        }
        observe(observer, mesh, st, report);
        if !moved {
            break;
        }
    }
    if st.film.is_some() && report.cracks > cracks0 {
        relax_round(mesh, st, params, g, false, &mut loaded, report, None)?;
        observe(observer, mesh, st, report);
    }
    fin.cracks = report.cracks - cracks0;
    fin.length = report.crack_length - length0;
    fin.stuck = finish_tips(mesh, st).len();
    fin.confined = mesh
        .vertices()
        .filter(|&v| {
            separation_factor(mesh, st, v) < FINISH_MIN_FACTOR
                && open_tip_plane(mesh, st, v).is_some()
        })
        .count();
    Ok(fin)
}

/// The finishing tips (by root vertex) with a crack ahead: a crack vertex
/// within `reach` (scene units) whose direction from the tip is within 45
/// degrees of the tip's way on (away from its crack, or along a wide
/// corner's bisector; the tip's own crack lies behind it); each may run on
/// twice `reach`. A uniform grid of `reach` cells finds the candidates.
fn tips_with_a_crack_ahead(
    mesh: &SimMesh,
    st: &State,
    reach: f64,
) -> std::collections::BTreeMap<u32, f64> {
    use std::collections::{BTreeMap, HashMap};
    let key = |p: [f64; 3]| p.map(|x| (x / reach).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<VertexId>> = HashMap::new();
    for h in mesh.halfedges() {
        if mesh.is_crack_halfedge(h) {
            let v = mesh.origin(h);
            grid.entry(key(mesh.position(v))).or_default().push(v);
        }
    }
    let mut out = BTreeMap::new();
    for (v, _) in finish_tips(mesh, st) {
        let dirs = crate::sim::crack::crack_directions(mesh, v);
        let ahead = match dirs.len() {
            1 => Some(v3::scale(dirs[0], -1.0)),
            _ => wide_corner(mesh, v),
        };
        let Some(ahead) = ahead else {
            continue;
        };
        let p = mesh.position(v);
        let c = key(p);
        let near = |q: &VertexId| {
            let d = v3::sub(mesh.position(*q), p);
            let l = v3::norm(d);
            l > 0.0 && l <= reach && v3::dot(d, ahead) >= l * std::f64::consts::FRAC_1_SQRT_2
        };
        let found = (-1..=1).any(|dz| {
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                        .is_some_and(|list| list.iter().any(near))
                })
            })
        });
        if found {
            out.insert(vertex_root(mesh, v).0, 2.0 * reach);
        }
    }
    out
}

/// Whether a new crack should not end on `w`: three or more cracks meet
/// there already (a fourth makes a cross; more, a fan).
pub(in crate::sim) fn crowded_junction(mesh: &SimMesh, degree: &[u8], w: VertexId) -> bool {
    mesh.is_boundary_vertex(w)
        && degree
            .get(vertex_root(mesh, w).idx())
            .is_some_and(|&d| d >= 3)
}
