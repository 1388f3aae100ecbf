//! Finishing for the spring model (`post.finish`): after the drying, an
//! open crack tip runs on along the shortest path of unbroken springs to
//! another crack or the border ahead of it, when one lies within reach.
//!
//! A drying spring network stops with many cracks ending free: the last
//! springs ahead of a tip hold once the load is spent, though the ligament
//! they leave is far weaker than the sheet. Real mud that has dried cracks
//! through: its network is closed cells, tips are rare. The film's
//! finishing (sec. 5 of the paper) cracks a tip along its residual's plane
//! one fan at a time; a spring network has no such plane, only its edges,
//! so a tip here takes the shortest edge path to the nearest crack (not its
//! own, whose last stretch is behind it) or border point within 75 degrees
//! of the direction it was running, and only when that path is no longer
//! than the reach. The path is as jagged as the edges it follows;
//! `post.smooth_paths` takes it off them like every other spring crack.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BTreeSet, BinaryHeap, HashMap};

use super::{break_spring, Springs};
use crate::math::v3;
use crate::mesh::spatial::position_key as key;
use crate::mesh::{SimMesh, VertexId};
use crate::sim::{FinishReport, SimError, SimReport};

/// A target's direction from the tip within this angle of the tip's own
/// running direction (cosine of 75 degrees): a tip meets the crack ahead of
/// it or beside it, never one behind it.
const AHEAD_COS: f64 = 0.258_819;

/// The crack points within this many segments of a tip, along its own
/// crack, are not a target (the tip would turn back on itself).
const OWN_HOPS: usize = 12;

/// The tip's running direction: from the point this many segments back
/// along its crack (fewer when the crack is shorter) to the tip.
const DIRECTION_HOPS: usize = 3;

type Key = [u64; 3];

/// Run every open tip on to a crack or the border ahead within `reach`
/// (normalised units: the mean edge is 1), in vertex order, each seeing the
/// cracks the tips before it made; at most `max_cracks` crack events in
/// all. A tip is a vertex, neither fixed nor on the border, whose crack
/// sides lead to one rest position.
pub(super) fn finish_tips(
    mesh: &mut SimMesh,
    st: &mut Springs,
    report: &mut SimReport,
    unit: f64,
    reach: f64,
    max_cracks: usize,
) -> Result<FinishReport, SimError> {
    let clock = std::time::Instant::now();
    let mut fin = FinishReport::default();
    // The cracks by position (the crack's copies of a point are one).
    let mut along: BTreeMap<Key, Vec<Key>> = BTreeMap::new();
    for s in &report.segments {
        link(&mut along, s[0], s[1]);
    }
    let tips: Vec<VertexId> = mesh
        .vertices()
        .filter(|&v| is_tip(mesh, st, &along, v))
        .collect();
    fin.tips = tips.len();
    fin.passes = 1;
    let (cracks0, length0) = (report.cracks, report.crack_length);
    for v in tips {
        if report.cracks >= max_cracks {
            break;
        }
        // An earlier path may have ended here: no longer a tip.
        if !is_tip(mesh, st, &along, v) {
            continue;
        }
        let Some(path) = path_ahead(mesh, st, &along, v, reach) else {
            fin.stuck += 1;
            continue;
        };
        for k in path {
            if report.cracks >= max_cracks {
                break;
            }
            let seg = report.segments.len();
            break_spring(mesh, st, k as usize, report, unit)?;
            for i in seg..report.segments.len() {
                let [p, q] = report.segments[i];
                link(&mut along, p, q);
            }
        }
    }
    fin.cracks = report.cracks - cracks0;
    fin.length = report.crack_length - length0;
    fin.seconds = clock.elapsed().as_secs_f64();
    Ok(fin)
}

/// Whether `v` lies on a crack and on the mesh's own border (a boundary
/// halfedge round it that is not a crack's side).
fn sides(mesh: &SimMesh, v: VertexId) -> (bool, bool) {
    let (mut crack, mut border) = (false, false);
    for h in mesh.vertex_outgoing(v) {
        for e in [h, mesh.prev(h)] {
            if mesh.is_boundary_halfedge(e) {
                if mesh.is_crack_halfedge(e) {
                    crack = true;
                } else {
                    border = true;
                }
            }
        }
    }
    (crack, border)
}

/// A tip: a vertex on a crack, neither fixed nor on the border, whose crack
/// sides lead to one position.
fn is_tip(mesh: &SimMesh, st: &Springs, along: &BTreeMap<Key, Vec<Key>>, v: VertexId) -> bool {
    let (crack, border) = sides(mesh, v);
    crack
        && !border
        && !st.fixed[v.idx()]
        && along
            .get(&key(mesh.position(v)))
            .is_some_and(|n| n.len() == 1)
}

fn link(along: &mut BTreeMap<Key, Vec<Key>>, p: [f64; 3], q: [f64; 3]) {
    let (a, b) = (key(p), key(q));
    if a == b {
        return;
    }
    for (x, y) in [(a, b), (b, a)] {
        let n = along.entry(x).or_default();
        if !n.contains(&y) {
            n.push(y);
        }
    }
}

/// The springs (in order from the tip) of the shortest path from tip `v`
/// to a crack point not on its own crack's last [`OWN_HOPS`] segments, or a
/// border point, lying ahead of the tip, no longer than `reach`; `None`
/// when there is none. A crack or border point not ahead blocks the way.
fn path_ahead(
    mesh: &SimMesh,
    st: &Springs,
    along: &BTreeMap<Key, Vec<Key>>,
    v: VertexId,
    reach: f64,
) -> Option<Vec<u32>> {
    let tip = key(mesh.position(v));
    let own = own_crack(along, tip);
    let dir = running_direction(along, tip)?;
    let p = mesh.position(v);
    let mut dist: HashMap<u32, (f64, u32)> = HashMap::new(); // node -> (length, spring in)
    let mut heap = BinaryHeap::new();
    dist.insert(v.0, (0.0, u32::MAX));
    heap.push(Reverse((0u64, v.0)));
    while let Some(Reverse((bits, u))) = heap.pop() {
        let d = f64::from_bits(bits);
        if dist.get(&u).is_some_and(|x| x.0 < d) {
            continue;
        }
        if u != v.0 {
            let (crack, border) = sides(mesh, VertexId(u));
            if crack || border {
                let q = mesh.position(VertexId(u));
                if own.contains(&key(q)) {
                    continue;
                }
                let to = v3::sub(q, p);
                let l = v3::norm(to);
                if l > 0.0 && v3::dot(to, dir) >= AHEAD_COS * l {
                    return Some(trace(&dist, st, u));
                }
                continue; // a crack or the border beside or behind: no way through
            }
        }
        for &(k, _) in &st.adjacency[u as usize] {
            let s = &st.springs[k as usize];
            let w = if s.a == u { s.b } else { s.a };
            if st.fixed[u as usize] && st.fixed[w as usize] {
                continue;
            }
            let nd = d + s.rest0;
            if nd > reach || dist.get(&w).is_some_and(|x| x.0 <= nd) {
                continue;
            }
            dist.insert(w, (nd, k));
            heap.push(Reverse((nd.to_bits(), w)));
        }
    }
    None
}

/// The springs from the search's start to `end`, start first.
fn trace(dist: &HashMap<u32, (f64, u32)>, st: &Springs, end: u32) -> Vec<u32> {
    let mut path = Vec::new();
    let mut u = end;
    while let Some(&(_, k)) = dist.get(&u) {
        if k == u32::MAX {
            break;
        }
        path.push(k);
        let s = &st.springs[k as usize];
        u = if s.a == u { s.b } else { s.a };
    }
    path.reverse();
    path
}

/// The crack points within [`OWN_HOPS`] segments of `tip` along its crack
/// (the tip included).
fn own_crack(along: &BTreeMap<Key, Vec<Key>>, tip: Key) -> BTreeSet<Key> {
    let mut seen: BTreeSet<Key> = BTreeSet::from([tip]);
    let mut front = vec![tip];
    for _ in 0..OWN_HOPS {
        let mut next = Vec::new();
        for k in front {
            for &n in along.get(&k).into_iter().flatten() {
                if seen.insert(n) {
                    next.push(n);
                }
            }
        }
        front = next;
    }
    seen
}

/// The unit direction the crack ran in at `tip`: from the point
/// [`DIRECTION_HOPS`] segments back along it (fewer at a junction or the
/// crack's other end) to the tip.
fn running_direction(along: &BTreeMap<Key, Vec<Key>>, tip: Key) -> Option<[f64; 3]> {
    let (mut prev, mut at) = (tip, *along.get(&tip)?.first()?);
    for _ in 1..DIRECTION_HOPS {
        match along.get(&at).map(Vec::as_slice) {
            Some([a, b]) => {
                let next = if *a == prev { *b } else { *a };
                (prev, at) = (at, next);
            }
            _ => break,
        }
    }
    let d = v3::sub(tip.map(f64::from_bits), at.map(f64::from_bits));
    let l = v3::norm(d);
    (l > 0.0).then(|| v3::scale(d, 1.0 / l))
}
