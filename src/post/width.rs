//! Crack width and curling (Iben & O'Brien 2009, sec. 5).
//!
//! The simulation never moves a node; it accumulates each node's relaxation
//! displacement (eq. 15). Displacing the nodes by a multiple of it opens the
//! cracks into gaps, because the two sides of a crack were pulled apart
//! after it opened. Curling then lifts crack nodes along the surface normal
//! by a fraction of how far they moved, falling off over a few rings of
//! neighbours (mud, peeling paint).
//!
//! Nothing here inverts a triangle silently: a node whose move would flip
//! or collapse one of its triangles has its move shortened (halved until the
//! triangle is fine, at most [`MAX_HALVINGS`] times, then dropped), and the
//! shortened nodes and flipped triangles are counted.

use crate::math::v3;
use crate::mesh::{FaceId, SimMesh, VertexId};
use crate::post::distance::crack_vertices;
use crate::post::Post;

mod band;
mod even;
mod follow;
use band::spread_over_band;
use even::{even_openings, group_sizes, round_corners, side_runs, smooth_runs, t_corner};
pub use follow::{resample_moved_wedges, turn_normals};

/// How many times a node's move is halved before it is dropped.
pub const MAX_HALVINGS: usize = 12;

/// A triangle whose area falls below this fraction of its rest area counts
/// as collapsed.
const MIN_AREA_FRACTION: f64 = 1e-3;

/// Rounds in which the corners of a flipped triangle move toward their mean
/// move before moves are halved.
const MAX_EVENINGS: usize = 6;

/// The displaced surface and what it took.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Displaced {
    /// Final position of every vertex, indexed by vertex id.
    pub positions: Vec<[f64; 3]>,
    /// Nodes whose move was shortened by the width limit.
    pub width_limited: usize,
    /// Crack nodes whose move relative to the other side of their crack was
    /// reduced to a pure opening (no overlap, no sliding along the crack).
    pub closed_nodes: usize,
    /// Triangles the full moves would have flipped or collapsed.
    pub inverted_triangles: usize,
    /// Nodes whose move was shortened so no triangle flips.
    pub shortened_nodes: usize,
    /// Crack copies moved onto a cell's rounded corner (gap band only).
    pub rounded_nodes: usize,
    /// Widest gap across a crack after the moves (scene units).
    pub max_gap: f64,
    /// Mean gap over the crack nodes (scene units; 0 without cracks).
    pub mean_gap: f64,
}

/// Unit area-weighted normal of every vertex at `positions` (zero where
/// undefined).
pub fn vertex_normals(mesh: &SimMesh, positions: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut n = vec![[0.0; 3]; mesh.n_vertices()];
    for f in mesh.faces() {
        let vs = mesh.face_vertices(f);
        let [a, b, c] = vs.map(|v| positions[v.idx()]);
        let fnrm = v3::cross(v3::sub(b, a), v3::sub(c, a)); // length: twice the area
        for v in vs {
            n[v.idx()] = v3::add(n[v.idx()], fnrm);
        }
    }
    for x in &mut n {
        let l = v3::norm(*x);
        *x = if l > 0.0 && l.is_finite() {
            v3::scale(*x, 1.0 / l)
        } else {
            [0.0; 3]
        };
    }
    n
}

/// The unit direction from crack node `v` into its own faces: the middle
/// of the angle its fan spans (a copy of a crack node has one fan, between
/// two crack edges; a tip's fan goes all round and its middle points away
/// from the crack). Perpendicular to a straight crack, the bisector at a
/// junction. `None` when undefined.
fn away_from_crack(mesh: &SimMesh, v: VertexId) -> Option<[f64; 3]> {
    // A fan that ends on the input's border: open perpendicular to the
    // crack edge, into the fan.
    let pv = mesh.position(v);
    let first = mesh.vertex_outgoing(v).next()?;
    let last = mesh.prev(mesh.vertex_outgoing(v).last()?);
    let crack_edge = match (mesh.is_crack_halfedge(first), mesh.is_crack_halfedge(last)) {
        (true, false) => v3::sub(mesh.position(mesh.dest(first)), pv),
        (false, true) => v3::sub(mesh.position(mesh.origin(last)), pv),
        _ => return mesh.fan_middle(v).map(|(_, middle)| middle),
    };
    // The plane and the inside of the fan from its first proper corner.
    let unit = |x: [f64; 3]| {
        let l = v3::norm(x);
        (l > 0.0).then(|| v3::scale(x, 1.0 / l))
    };
    let (ua, ub) = mesh.vertex_outgoing(v).find_map(|h| {
        let a = unit(v3::sub(mesh.position(mesh.dest(h)), pv))?;
        let b = unit(v3::sub(mesh.position(mesh.origin(mesh.prev(h))), pv))?;
        Some((a, b))
    })?;
    let mut d = v3::cross(v3::cross(ua, ub), crack_edge);
    if v3::dot(d, v3::add(ua, ub)) < 0.0 {
        d = v3::scale(d, -1.0);
    }
    let l = v3::norm(d);
    (l > 0.0 && l.is_finite()).then(|| v3::scale(d, 1.0 / l))
}

/// Crack nodes that lie inside a crack side edge of another group (rest
/// positions): `(node, edge start, edge end, parameter along the edge)`, in
/// node order. Found with a uniform grid over the crack nodes.
fn t_junctions(mesh: &SimMesh) -> Vec<(VertexId, VertexId, VertexId, f64)> {
    let nodes = crack_vertices(mesh);
    let roots = mesh.vertex_roots();
    let sides: Vec<(VertexId, VertexId)> = mesh
        .halfedges()
        .filter(|&h| mesh.is_crack_halfedge(h))
        .map(|h| (mesh.origin(h), mesh.dest(h)))
        .collect();
    if nodes.is_empty() || sides.is_empty() {
        return Vec::new();
    }
    let cell = sides
        .iter()
        .map(|&(a, b)| v3::norm(v3::sub(mesh.position(b), mesh.position(a))))
        .fold(0.0, f64::max)
        .max(1e-300);
    let key = |p: [f64; 3]| p.map(|x| (x / cell).floor() as i64);
    let mut grid: std::collections::BTreeMap<[i64; 3], Vec<VertexId>> = Default::default();
    for &v in &nodes {
        grid.entry(key(mesh.position(v))).or_default().push(v);
    }
    let mut out = Vec::new();
    for (a, b) in sides {
        let (pa, pb) = (mesh.position(a), mesh.position(b));
        let e = v3::sub(pb, pa);
        let l2 = v3::dot(e, e);
        if l2 == 0.0 {
            continue;
        }
        let (ra, rb) = (roots[a.idx()], roots[b.idx()]);
        let (ka, kb) = (key(pa), key(pb));
        let lo: [i64; 3] = std::array::from_fn(|k| ka[k].min(kb[k]) - 1);
        let hi: [i64; 3] = std::array::from_fn(|k| ka[k].max(kb[k]) + 1);
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    for &q in grid.get(&[x, y, z]).map_or(&[][..], |v| v.as_slice()) {
                        let rq = roots[q.idx()];
                        if rq == ra || rq == rb {
                            continue;
                        }
                        let d = v3::sub(mesh.position(q), pa);
                        let t = v3::dot(d, e) / l2;
                        if t <= 0.0 || t >= 1.0 {
                            continue;
                        }
                        let off = v3::sub(d, v3::scale(e, t));
                        if v3::dot(off, off) <= 1e-18 * l2 {
                            out.push((q, a, b, t));
                        }
                    }
                }
            }
        }
    }
    out.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    out
}

/// Sets of crack nodes whose moves are tied together by the opening rules:
/// the copies of a crack vertex, joined with the copies of the ends of the
/// edge a T-junction node lies on.
struct Links {
    /// Set index of each vertex ([`usize::MAX`]: not a crack node).
    set_of: Vec<usize>,
    /// Members of each set, in id order.
    sets: Vec<Vec<VertexId>>,
}

impl Links {
    /// No node tied to another.
    fn none(n: usize) -> Links {
        Links {
            set_of: vec![usize::MAX; n],
            sets: Vec::new(),
        }
    }

    /// `v` and every node tied to it (just `v` when it is not a crack node).
    fn of(&self, v: VertexId) -> Vec<VertexId> {
        match self.set_of[v.idx()] {
            usize::MAX => vec![v],
            s => self.sets[s].clone(),
        }
    }
}

/// The [`Links`] of `mesh` from its crack groups and T-junctions.
fn linked_nodes(
    mesh: &SimMesh,
    groups: &[Vec<VertexId>],
    junctions: &[(VertexId, VertexId, VertexId, f64)],
) -> Links {
    // Union-find over groups.
    let mut group_of = vec![usize::MAX; mesh.n_vertices()];
    for (i, g) in groups.iter().enumerate() {
        for v in g {
            group_of[v.idx()] = i;
        }
    }
    let mut parent: Vec<usize> = (0..groups.len()).collect();
    fn find(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for &(q, a, b, _) in junctions {
        let gq = group_of[q.idx()];
        for e in [a, b] {
            let ge = group_of[e.idx()];
            if gq != usize::MAX && ge != usize::MAX {
                let (x, y) = (find(&mut parent, gq), find(&mut parent, ge));
                // The smaller index as the root keeps the sets' order fixed.
                parent[x.max(y)] = x.min(y);
            }
        }
    }
    let mut set_index = vec![usize::MAX; groups.len()];
    let mut sets: Vec<Vec<VertexId>> = Vec::new();
    let mut set_of = vec![usize::MAX; mesh.n_vertices()];
    for (i, group) in groups.iter().enumerate() {
        let r = find(&mut parent, i);
        if set_index[r] == usize::MAX {
            set_index[r] = sets.len();
            sets.push(Vec::new());
        }
        let s = set_index[r];
        for &v in group {
            sets[s].push(v);
            set_of[v.idx()] = s;
        }
    }
    for s in &mut sets {
        s.sort();
    }
    Links { set_of, sets }
}

/// Crack nodes grouped by root, in order of the smallest root: the copies
/// of each crack vertex. Roots at exactly the same rest position form one
/// group (where both sides of a crack edge were split at the same point,
/// each side's new vertex is its own root), as for the walls' bottom
/// vertices.
fn crack_groups(mesh: &SimMesh) -> Vec<Vec<VertexId>> {
    let roots = mesh.vertex_roots();
    let mut group_at: std::collections::BTreeMap<[u64; 3], usize> = Default::default();
    let mut groups: Vec<Vec<VertexId>> = Vec::new();
    let mut by_root: std::collections::BTreeMap<u32, Vec<VertexId>> = Default::default();
    for v in crack_vertices(mesh) {
        by_root.entry(roots[v.idx()]).or_default().push(v);
    }
    for (r, vs) in by_root {
        let key = mesh.position(VertexId(r)).map(|x| (x + 0.0).to_bits()); // -0.0 and 0.0 alike
        let next = groups.len();
        let g = *group_at.entry(key).or_insert(next);
        if g == next {
            groups.push(Vec::new());
        }
        groups[g].extend(vs);
    }
    for g in &mut groups {
        g.sort();
    }
    groups
}

/// Widest distance between two of `group`'s positions.
fn spread(group: &[VertexId], position: impl Fn(VertexId) -> [f64; 3]) -> f64 {
    let mut w: f64 = 0.0;
    for (i, &a) in group.iter().enumerate() {
        for &b in &group[i + 1..] {
            w = w.max(v3::norm(v3::sub(position(a), position(b))));
        }
    }
    w
}

/// Mean of `group`'s moves.
fn mean_move(group: &[VertexId], mv: &[[f64; 3]]) -> [f64; 3] {
    let sum = group.iter().fold([0.0; 3], |s, v| v3::add(s, mv[v.idx()]));
    v3::scale(sum, 1.0 / group.len() as f64)
}

/// Whether face `f` is flipped or collapsed at `positions` compared with
/// its rest shape.
fn bad_face(mesh: &SimMesh, f: FaceId, positions: &[[f64; 3]]) -> bool {
    let vs = mesh.face_vertices(f);
    let [a, b, c] = vs.map(|v| mesh.position(v));
    let rest = v3::cross(v3::sub(b, a), v3::sub(c, a));
    let rest_area = v3::norm(rest);
    if rest_area <= 0.0 {
        return false; // degenerate already: nothing to keep
    }
    let [a, b, c] = vs.map(|v| positions[v.idx()]);
    let now = v3::cross(v3::sub(b, a), v3::sub(c, a));
    v3::dot(now, rest) <= MIN_AREA_FRACTION * rest_area * rest_area
}

/// Displace the nodes of `mesh` by `opts.width` times `displacement` (scene
/// units, per vertex), limit the gaps to `opts.max_width`, curl the crack
/// edges, and shorten moves that would flip a triangle.
///
/// The openings are evened out between junctions (`even_openings`):
/// a cell's side opens as far all along, instead of as a lens that pinches
/// shut where it meets the next crack.
pub fn displace(mesh: &SimMesh, displacement: &[[f64; 3]], opts: &Post) -> Displaced {
    open_up(mesh, displacement, opts, true)
}

/// [`displace`], with the openings evened out between junctions (`even`)
/// or each node's own.
fn open_up(mesh: &SimMesh, displacement: &[[f64; 3]], opts: &Post, even: bool) -> Displaced {
    let rest: Vec<[f64; 3]> = mesh.positions().to_vec();
    let mut mv: Vec<[f64; 3]> = (0..mesh.n_vertices())
        .map(|i| {
            let d = displacement.get(i).copied().unwrap_or([0.0; 3]);
            if d.iter().all(|x| x.is_finite()) {
                v3::scale(d, opts.width)
            } else {
                [0.0; 3]
            }
        })
        .collect();
    let groups = crack_groups(mesh);
    let mut out = Displaced::default();

    // Width limit: shrink each crack vertex's copies towards their mean move.
    if opts.max_width > 0.0 {
        out.width_limited = limit_width(&groups, &rest, &mut mv, opts.max_width);
    }

    // Cracks only open: each copy of a crack node moves with its copies'
    // mean move plus an opening straight away from the crack into its own
    // faces. The rest of its own move is dropped: moving back across the
    // crack (a squeezed crack stays closed instead of its sides
    // overlapping), and sliding along the crack or off the surface
    // relative to the other side (which would tilt the walls into their
    // neighbours).
    // With a gap band the copies keep only their opening: the crack line
    // stays where it was.
    let local = opts.gap_band > 0.0;
    let junctions = t_junctions(mesh);
    let means: Vec<[f64; 3]> = groups.iter().map(|g| mean_move(g, &mv)).collect();
    let mut opening = vec![0.0; mesh.n_vertices()];
    let mut dirs: Vec<Option<[f64; 3]>> = vec![None; mesh.n_vertices()];
    for (g, mean) in groups.iter().zip(&means).filter(|(g, _)| g.len() >= 2) {
        for &v in g {
            dirs[v.idx()] = away_from_crack(mesh, v);
            if let Some(dir) = dirs[v.idx()] {
                opening[v.idx()] = v3::dot(v3::sub(mv[v.idx()], *mean), dir).max(0.0);
            }
        }
    }
    let mut runs = Vec::new();
    let sizes = group_sizes(mesh, &groups);
    if even {
        runs = side_runs(mesh, &groups, &sizes, &junctions);
        even_openings(mesh, &groups, &sizes, &runs, &mut opening);
    }
    let mut open: Vec<[f64; 3]> = dirs
        .iter()
        .zip(&opening)
        .map(|(d, o)| d.map_or([0.0; 3], |d| v3::scale(d, *o)))
        .collect();
    smooth_runs(mesh, &runs, &mut open);
    for (g, &mean) in groups.iter().zip(&means) {
        if g.len() < 2 {
            if local {
                mv[g[0].idx()] = [0.0; 3];
            }
            continue;
        }
        let base = if local { [0.0; 3] } else { mean };
        for &v in g {
            let new = v3::add(base, open[v.idx()]);
            if v3::norm(v3::sub(new, mv[v.idx()])) > 1e-12 * (1.0 + v3::norm(mean)) {
                out.closed_nodes += 1;
            }
            mv[v.idx()] = new;
        }
    }
    // The same at T-junctions: a crack node lying on the other side's edge
    // (that side has no node there) opens away from that edge only.
    // Evened, the corner stands off the arriving crack's side as far as
    // that side does.
    for &(q, a, b, t) in &junctions {
        let w = v3::add(v3::scale(mv[a.idx()], 1.0 - t), v3::scale(mv[b.idx()], t));
        let cornered = even
            .then(|| t_corner(mesh, q, (a, b), w, &dirs, &opening))
            .flatten();
        mv[q.idx()] = cornered.unwrap_or_else(|| {
            let open = away_from_crack(mesh, q)
                .map(|dir| v3::scale(dir, v3::dot(v3::sub(mv[q.idx()], w), dir).max(0.0)))
                .unwrap_or([0.0; 3]);
            v3::add(w, open)
        });
        out.closed_nodes += 1;
    }

    if local {
        if even {
            let mut on_t = vec![false; mesh.n_vertices()];
            for &(q, _, _, _) in &junctions {
                on_t[q.idx()] = true;
            }
            out.rounded_nodes = round_corners(mesh, &sizes, &on_t, &opening, &mut mv);
        }
        spread_over_band(mesh, &mut mv, opts.gap_band);
    }

    curl(mesh, &rest, &groups, &mut mv, opts, local);

    // No silent inversion: halve the moves of the nodes of flipped
    // triangles until none is left, then drop the rest.
    let mut positions: Vec<[f64; 3]> = rest.iter().zip(&mv).map(|(p, d)| v3::add(*p, *d)).collect();
    // A crack node is halved together with every node its move was tied
    // to above (its copies, and at a T-junction the spanning edge's ends
    // and their copies), so the two sides of a crack stay apart: halving
    // one copy alone would slide it against the other side.
    // With a gap band each copy moves by its own opening alone, so one
    // copy shortened does not slide against the others: nothing is tied
    // (tied, one flipped triangle shortened every copy of its corners and
    // pinched the gap shut on the far side of the crack too).
    let links = if local {
        Links::none(mesh.n_vertices())
    } else {
        linked_nodes(mesh, &groups, &junctions)
    };
    let mut shortened = vec![false; mesh.n_vertices()];
    out.inverted_triangles = unflip(mesh, &links, &mut mv, &mut positions, &mut shortened);
    out.shortened_nodes = shortened.iter().filter(|&&s| s).count();
    let mut sum = 0.0;
    for g in &groups {
        let w = spread(g, |v| positions[v.idx()]);
        out.max_gap = out.max_gap.max(w);
        sum += w;
    }
    if !groups.is_empty() {
        out.mean_gap = sum / groups.len() as f64;
    }
    out.positions = positions;
    out
}

/// Shrink each crack vertex's copies towards their mean move until they
/// lie at most `max_width` apart; the copies shrunk.
fn limit_width(
    groups: &[Vec<VertexId>],
    rest: &[[f64; 3]],
    mv: &mut [[f64; 3]],
    max_width: f64,
) -> usize {
    let mut limited = 0;
    for g in groups {
        let w = spread(g, |v| v3::add(rest[v.idx()], mv[v.idx()]));
        if w > max_width {
            let k = max_width / w;
            let mean = mean_move(g, mv);
            for v in g {
                let off = v3::sub(mv[v.idx()], mean);
                mv[v.idx()] = v3::add(mean, v3::scale(off, k));
            }
            limited += g.len();
        }
    }
    limited
}

/// Curling: crack nodes rise by a fraction of how far they moved, and
/// each ring of neighbours rises by `falloff` times the ring before. With
/// a gap band (`local`) every node rises by a fraction of its own move, so
/// the lift fades with the move over the band (a distance along the
/// surface, whatever the tessellation); without, ring by ring.
fn curl(
    mesh: &SimMesh,
    rest: &[[f64; 3]],
    groups: &[Vec<VertexId>],
    mv: &mut [[f64; 3]],
    opts: &Post,
    local: bool,
) {
    if local && opts.curl > 0.0 && !groups.is_empty() {
        let normals = vertex_normals(mesh, rest);
        for (m, n) in mv.iter_mut().zip(&normals) {
            let lift = opts.curl * v3::norm(*m);
            *m = v3::add(*m, v3::scale(*n, lift));
        }
    } else if opts.curl > 0.0 && !groups.is_empty() {
        let normals = vertex_normals(mesh, rest);
        let mut lift = vec![f64::NAN; mesh.n_vertices()];
        let mut ring: Vec<VertexId> = Vec::new();
        for g in groups {
            for &v in g {
                lift[v.idx()] = opts.curl * v3::norm(mv[v.idx()]);
                ring.push(v);
            }
        }
        for _ in 0..opts.curl_rings {
            let mut next: Vec<(VertexId, f64)> = Vec::new();
            for &v in &ring {
                for f in mesh.vertex_faces(v) {
                    for u in mesh.face_vertices(f) {
                        if lift[u.idx()].is_nan() {
                            next.push((u, opts.curl_falloff * lift[v.idx()]));
                        }
                    }
                }
            }
            // The largest offer wins; id order keeps it deterministic.
            next.sort_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)));
            next.dedup_by_key(|x| x.0);
            ring = next.iter().map(|x| x.0).collect();
            for (u, l) in next {
                lift[u.idx()] = l;
            }
            if ring.is_empty() {
                break;
            }
        }
        for (i, l) in lift.iter().enumerate() {
            if l.is_finite() && *l > 0.0 {
                mv[i] = v3::add(mv[i], v3::scale(normals[i], *l));
            }
        }
    }
}

/// Grooves (`[post] groove`): every copy of a split crack node moves
/// `half_width` straight away from its crack into its own faces, so each
/// crack opens into a channel `2 half_width` wide whose walls
/// ([`crate::post::walls`]) make a V down to the crack line. Unsplit nodes
/// (crack tips) stay, so a groove narrows to a point at a tip; T-junctions,
/// the no-sliding rule and the flipped-triangle guard are those of
/// [`displace`].
pub fn groove(mesh: &SimMesh, half_width: f64) -> Displaced {
    let mut d = vec![[0.0; 3]; mesh.n_vertices()];
    for g in crack_groups(mesh) {
        if g.len() < 2 {
            continue;
        }
        for v in g {
            if let Some(dir) = away_from_crack(mesh, v) {
                d[v.idx()] = v3::scale(dir, half_width);
            }
        }
    }
    let opts = Post {
        width: 1.0,
        ..Post::default()
    };
    open_up(mesh, &d, &opts, false)
}

/// Halve the moves `mv` of the nodes of flipped or collapsed triangles at
/// `positions` (the rest positions plus `mv`), each with every node tied
/// to it, until none is left; after [`MAX_HALVINGS`] halvings the moves
/// left are dropped. Marks the nodes it moved in `shortened`; returns how
/// many triangles were flipped at first.
fn unflip(
    mesh: &SimMesh,
    links: &Links,
    mv: &mut [[f64; 3]],
    positions: &mut [[f64; 3]],
    shortened: &mut [bool],
) -> usize {
    let bad = |positions: &[[f64; 3]]| -> Vec<FaceId> {
        mesh.faces()
            .filter(|&f| bad_face(mesh, f, positions))
            .collect()
    };
    let mut flipped = bad(positions);
    let first = flipped.len();
    // First the corners of each flipped triangle move more alike (half way
    // to their mean move, a few times), a crack node together with the
    // nodes tied to it (its copies keep their gap): a needle beside a
    // crack, or a triangle inside a bend of one, every corner pushed into
    // it, then moves as one and the gap keeps its width. What is still
    // flipped is shortened below.
    for _ in 0..MAX_EVENINGS {
        if flipped.is_empty() {
            break;
        }
        let mut sum: std::collections::BTreeMap<u32, ([f64; 3], f64)> = Default::default();
        for &f in &flipped {
            let vs = mesh.face_vertices(f);
            let mean = v3::scale(
                vs.iter().fold([0.0; 3], |s, v| v3::add(s, mv[v.idx()])),
                1.0 / 3.0,
            );
            for v in vs {
                let e = sum.entry(v.0).or_insert(([0.0; 3], 0.0));
                e.0 = v3::add(e.0, v3::sub(mean, mv[v.idx()]));
                e.1 += 1.0;
            }
        }
        for (v, (s, n)) in sum {
            let delta = v3::scale(s, 0.5 / n);
            for u in links.of(VertexId(v)) {
                let i = u.idx();
                mv[i] = v3::add(mv[i], delta);
                positions[i] = v3::add(mesh.position(u), mv[i]);
                shortened[i] = true;
            }
        }
        flipped = bad(positions);
    }
    for round in 0..=MAX_HALVINGS {
        if flipped.is_empty() {
            break;
        }
        let mut nodes: Vec<VertexId> = flipped
            .iter()
            .flat_map(|&f| mesh.face_vertices(f))
            .flat_map(|v| links.of(v))
            .collect();
        nodes.sort();
        nodes.dedup();
        for v in nodes {
            shortened[v.idx()] = true;
            mv[v.idx()] = if round == MAX_HALVINGS {
                [0.0; 3]
            } else {
                v3::scale(mv[v.idx()], 0.5)
            };
            positions[v.idx()] = v3::add(mesh.position(v), mv[v.idx()]);
        }
        flipped = bad(positions);
    }
    first
}

/// Scale by `factor` the moves (from the rest positions to `positions`)
/// of `nodes` and, when `tied`, of every node tied to them (the copies of a
/// crack vertex, and at a T-junction the spanning edge's ends), so the
/// sides of a crack keep their shape relative to each other; then halve
/// moves that this flipped as [`displace`] does (tied or each node alone:
/// gaps opened in a band move each copy by its own opening, so a copy
/// shortened alone slides against no other). Returns the number of nodes
/// moved.
pub fn shorten(
    mesh: &SimMesh,
    positions: &mut [[f64; 3]],
    nodes: &[VertexId],
    factor: f64,
    tied: bool,
) -> usize {
    let groups = crack_groups(mesh);
    let junctions = t_junctions(mesh);
    let links = if tied {
        linked_nodes(mesh, &groups, &junctions)
    } else {
        Links::none(mesh.n_vertices())
    };
    let mut tied: Vec<VertexId> = nodes.iter().flat_map(|&v| links.of(v)).collect();
    tied.sort();
    tied.dedup();
    let mut mv: Vec<[f64; 3]> = mesh
        .positions()
        .iter()
        .zip(positions.iter())
        .map(|(r, p)| v3::sub(*p, *r))
        .collect();
    let mut shortened = vec![false; mesh.n_vertices()];
    for &v in &tied {
        shortened[v.idx()] = true;
        mv[v.idx()] = v3::scale(mv[v.idx()], factor);
        positions[v.idx()] = v3::add(mesh.position(v), mv[v.idx()]);
    }
    unflip(mesh, &links, &mut mv, positions, &mut shortened);
    shortened.iter().filter(|&&s| s).count()
}

/// Shut the cracks at `nodes`: every copy of each of those crack vertices
/// moves to the copies' mean position (so the sides meet exactly and their
/// walls are left out), and a T-junction node among them onto the edge it
/// lies on; then halve moves that this flipped as [`displace`] does, each
/// with the nodes tied to it when `tied` (as [`shorten`]).
pub fn shut(mesh: &SimMesh, positions: &mut [[f64; 3]], nodes: &[VertexId], tied: bool) {
    let groups = crack_groups(mesh);
    let junctions = t_junctions(mesh);
    let mut wanted = vec![false; mesh.n_vertices()];
    for v in nodes {
        wanted[v.idx()] = true;
    }
    for g in &groups {
        if g.iter().any(|v| wanted[v.idx()]) {
            let sum = g
                .iter()
                .fold([0.0; 3], |s, v| v3::add(s, positions[v.idx()]));
            let mean = v3::scale(sum, 1.0 / g.len() as f64);
            for v in g {
                positions[v.idx()] = mean;
            }
        }
    }
    for &(q, a, b, t) in &junctions {
        if wanted[q.idx()] {
            positions[q.idx()] = v3::add(
                v3::scale(positions[a.idx()], 1.0 - t),
                v3::scale(positions[b.idx()], t),
            );
        }
    }
    let links = if tied {
        linked_nodes(mesh, &groups, &junctions)
    } else {
        Links::none(mesh.n_vertices())
    };
    let mut mv: Vec<[f64; 3]> = mesh
        .positions()
        .iter()
        .zip(positions.iter())
        .map(|(r, p)| v3::sub(*p, *r))
        .collect();
    unflip(
        mesh,
        &links,
        &mut mv,
        positions,
        &mut vec![false; mesh.n_vertices()],
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{build, grid_input};

    /// A 6 x 6 grid with the interior edges along y = 3 opened from x = 0
    /// to x = 6 (a crack across the plate).
    fn cracked_plate() -> SimMesh {
        cracked_plate_to(6)
    }

    /// A 6 x 6 grid with the interior edges along y = 3 opened from x = 0
    /// to x = `end` (a free tip there when under 6).
    fn cracked_plate_to(end: usize) -> SimMesh {
        let (mut m, _) = build(&grid_input(6, 6));
        for x in 0..end {
            let find = |m: &SimMesh, p: [f64; 2]| {
                m.vertices()
                    .find(|&v| m.position(v)[0] == p[0] && m.position(v)[1] == p[1])
                    .unwrap()
            };
            let a = find(&m, [x as f64, 3.0]);
            let b = find(&m, [x as f64 + 1.0, 3.0]);
            // The copy of `a` on the lower side may be the one connected to b.
            let h = m
                .vertex_outgoing(a)
                .find(|&h| m.dest(h) == b)
                .or_else(|| m.find_halfedge(a, b))
                .unwrap();
            if m.twin(h).is_some() {
                m.open_edge(h).unwrap();
            }
        }
        m.validate().unwrap();
        m
    }

    /// Upper side moves +y by `d`, lower side -y.
    fn pull_apart(m: &SimMesh, d: f64) -> Vec<[f64; 3]> {
        m.vertices()
            .map(|v| {
                let y = m.position(v)[1];
                let up = y > 3.0
                    || (y == 3.0
                        && m.vertex_faces(v)
                            .all(|f| m.face_vertices(f).iter().all(|&u| m.position(u)[1] >= 3.0)));
                [0.0, if up { d } else { -d }, 0.0]
            })
            .collect()
    }

    fn opts(width: f64) -> Post {
        Post {
            width,
            ..Post::default()
        }
    }

    #[test]
    fn the_gap_opens_by_the_scaled_displacement() {
        let m = cracked_plate();
        let d = pull_apart(&m, 0.1);
        let out = displace(&m, &d, &opts(2.0));
        assert!((out.max_gap - 0.4).abs() < 1e-12, "{}", out.max_gap);
        assert!((out.mean_gap - 0.4).abs() < 1e-12);
        assert_eq!(out.inverted_triangles, 0);
        assert_eq!(out.shortened_nodes, 0);
        for v in m.vertices() {
            let p = out.positions[v.idx()];
            assert!((p[1] - m.position(v)[1] - 2.0 * d[v.idx()][1]).abs() < 1e-12);
        }
        // Scale 0: nothing moves.
        let out = displace(&m, &d, &opts(0.0));
        assert_eq!(out.positions, m.positions().to_vec());
        assert_eq!(out.max_gap, 0.0);
    }

    #[test]
    fn a_gap_band_opens_the_crack_and_leaves_the_cells_in_place() {
        let m = cracked_plate();
        // Each side pulled 0.3 off the crack, and everything carried 0.5
        // along x (the cells' shrinking as a whole).
        let d: Vec<[f64; 3]> = pull_apart(&m, 0.3)
            .into_iter()
            .map(|x| v3::add(x, [0.5, 0.0, 0.0]))
            .collect();
        let out = displace(
            &m,
            &d,
            &Post {
                gap_band: 4.0,
                ..opts(1.0)
            },
        );
        assert!((out.max_gap - 0.6).abs() < 1e-9, "{}", out.max_gap);
        assert_eq!(out.inverted_triangles, 0);
        for v in m.vertices() {
            let (p, q) = (m.position(v), out.positions[v.idx()]);
            let dy = (p[1] - 3.0).abs();
            // Nothing slides along the crack; each side moves off it by
            // 0.3 (1 - d / 1.2) at distance d, and not at all from 1.2 on.
            assert!((q[0] - p[0]).abs() < 1e-9, "{v:?} slid along the crack");
            let want = if dy >= 1.2 {
                0.0
            } else {
                0.3 * (1.0 - dy / 1.2)
            };
            assert!(
                ((q[1] - p[1]).abs() - want).abs() < 1e-9,
                "{v:?}: {q:?} from {p:?}"
            );
        }
        // Without a band every node moves by its displacement.
        let out = displace(&m, &d, &opts(1.0));
        for v in m.vertices() {
            let x = out.positions[v.idx()][0];
            assert!((x - m.position(v)[0] - 0.5).abs() < 1e-12, "{v:?} at {x}");
        }
    }

    /// The gap across the crack at x (the spread of the copies there).
    fn gap_at(m: &SimMesh, out: &Displaced, x: f64) -> f64 {
        let copies: Vec<VertexId> = m
            .vertices()
            .filter(|&v| m.position(v) == [x, 3.0, 0.0])
            .collect();
        spread(&copies, |v| out.positions[v.idx()])
    }

    #[test]
    fn a_side_between_junctions_stands_off_evenly_and_a_tip_closes() {
        // Each side pulled off the crack as an elastic crack opens: most in
        // the middle, little near its ends.
        let lens = |m: &SimMesh| -> Vec<[f64; 3]> {
            pull_apart(m, 0.1)
                .into_iter()
                .zip(m.positions())
                .map(|(d, p)| v3::scale(d, (std::f64::consts::PI * p[0] / 6.0).sin()))
                .collect()
        };
        let banded = Post {
            gap_band: 2.0,
            ..opts(1.0)
        };
        // Across the plate (both ends on the border): every node as far.
        let m = cracked_plate();
        let out = displace(&m, &lens(&m), &banded);
        let gaps: Vec<f64> = (1..6).map(|x| gap_at(&m, &out, x as f64)).collect();
        let mean = gaps.iter().sum::<f64>() / 5.0;
        for g in &gaps {
            assert!((g - mean).abs() < 1e-9 * mean, "{gaps:?}");
        }
        // The mean of the openings (0.2 sin(pi x / 6) over every copy of
        // the run, the border ends included).
        let want = (0..=6)
            .map(|x| 0.2 * (std::f64::consts::PI * x as f64 / 6.0).sin())
            .sum::<f64>()
            / 7.0;
        assert!((mean - want).abs() < 1e-9, "{mean} for {want}");
        assert_eq!(out.inverted_triangles, 0);
        // Ending at a free tip: the crack keeps its own profile, closing
        // towards the tip.
        let m = cracked_plate_to(4);
        let out = displace(&m, &lens(&m), &banded);
        let gaps: Vec<f64> = (1..4).map(|x| gap_at(&m, &out, x as f64)).collect();
        for (x, g) in gaps.iter().enumerate() {
            let want = 0.2 * (std::f64::consts::PI * (x + 1) as f64 / 6.0).sin();
            assert!((g - want).abs() < 1e-9, "{gaps:?}");
        }
    }

    /// [`cracked_plate`] with a second crack up from its middle: the edges
    /// along x = 3 opened from y = 3 to the border, so two cells meet the
    /// first crack at right-angled corners.
    fn plate_with_a_junction() -> SimMesh {
        let mut m = cracked_plate();
        for y in 3..6 {
            let at = |m: &SimMesh, p: [f64; 2]| -> Vec<VertexId> {
                m.vertices()
                    .filter(|&v| m.position(v)[0] == p[0] && m.position(v)[1] == p[1])
                    .collect()
            };
            let h = at(&m, [3.0, y as f64])
                .into_iter()
                .flat_map(|a| m.vertex_outgoing(a).collect::<Vec<_>>())
                .find(|&h| m.position(m.dest(h)) == [3.0, y as f64 + 1.0, 0.0])
                .unwrap();
            if m.twin(h).is_some() {
                m.open_edge(h).unwrap();
            }
        }
        m.validate().unwrap();
        m
    }

    #[test]
    fn a_cells_corner_rounds_off_and_no_triangle_turns_over() {
        let m = plate_with_a_junction();
        // Each cell shrinks towards its middle: a quarter of the way.
        let middle = |v: VertexId| -> [f64; 3] {
            let c = m
                .vertex_faces(v)
                .flat_map(|f| m.face_vertices(f))
                .fold([0.0; 3], |s, u| v3::add(s, m.position(u)));
            let n = m.vertex_faces(v).count() as f64 * 3.0;
            let (x, y) = (c[0] / n, c[1] / n);
            if y < 3.0 {
                [3.0, 1.5, 0.0]
            } else if x < 3.0 {
                [1.5, 4.5, 0.0]
            } else {
                [4.5, 4.5, 0.0]
            }
        };
        let d: Vec<[f64; 3]> = m
            .vertices()
            .map(|v| v3::scale(v3::sub(middle(v), m.position(v)), 0.25))
            .collect();
        let out = displace(
            &m,
            &d,
            &Post {
                gap_band: 2.0,
                ..opts(1.0)
            },
        );
        assert_eq!(out.inverted_triangles, 0);
        assert_eq!(out.shortened_nodes, 0);
        assert!(out.rounded_nodes >= 2, "{}", out.rounded_nodes);
        // Every side opens by 0.375; the upper left cell's corner lies on
        // the circle of radius 0.375 touching both sides' offset lines
        // (centre (2.25, 3.75)), towards the corner: 0.686 into the cell,
        // where straight offsets would have met at 0.530.
        let corner = m
            .vertices()
            .find(|&v| {
                m.position(v) == [3.0, 3.0, 0.0] && middle(v)[0] == 1.5 && middle(v)[1] == 4.5
            })
            .unwrap();
        let p = out.positions[corner.idx()];
        let h = 0.375 * std::f64::consts::FRAC_1_SQRT_2;
        for (got, want) in p.iter().zip([2.25 + h, 3.75 - h, 0.0]) {
            assert!((got - want).abs() < 1e-9, "{p:?}");
        }
        // The gap is widest where the cracks meet, not pinched there.
        let side = gap_at(&m, &out, 1.0);
        assert!(side >= 0.75 - 1e-9, "{side}");
        assert!(gap_at(&m, &out, 3.0) > side);
    }

    #[test]
    fn with_a_gap_band_curling_fades_over_the_band_whatever_the_rings() {
        let m = cracked_plate();
        let d = pull_apart(&m, 0.3);
        for rings in [1, 6] {
            let out = displace(
                &m,
                &d,
                &Post {
                    gap_band: 4.0,
                    curl: 0.5,
                    curl_rings: rings,
                    ..opts(1.0)
                },
            );
            for v in m.vertices() {
                let (p, q) = (m.position(v), out.positions[v.idx()]);
                let dy = (p[1] - 3.0).abs();
                // Lifted by half its move, 0.3 (1 - d / 1.2), up to 1.2.
                let want = if dy >= 1.2 {
                    0.0
                } else {
                    0.5 * 0.3 * (1.0 - dy / 1.2)
                };
                assert!((q[2] - want).abs() < 1e-9, "rings {rings}: {v:?} at {q:?}");
            }
        }
    }

    /// A 4 x 4 grid whose corners carry the normal +z.
    fn flat_plate_with_normals() -> SimMesh {
        let mut input = grid_input(4, 4);
        let n = input.positions.len();
        input.wedge_channels.push(crate::mesh::Channel::new(
            "NORMAL",
            3,
            crate::mesh::ChannelKind::UnitVector,
            [0.0, 0.0, 1.0].repeat(n),
        ));
        build(&input).0
    }

    #[test]
    fn normals_stay_where_the_surface_stays() {
        let mut m = flat_plate_with_normals();
        // One interior vertex rises: its faces tilt, and so would its
        // neighbours' normals, although their other faces stay flat.
        let lifted = m
            .vertices()
            .find(|&v| m.position(v) == [2.0, 2.0, 0.0])
            .unwrap();
        let mut moved: Vec<[f64; 3]> = m.positions().to_vec();
        moved[lifted.idx()][2] = 0.5;
        turn_normals(&mut m, &moved);
        let ch = m.wedges().channel("NORMAL").unwrap();
        for f in m.faces() {
            for (v, w) in m.face_vertices(f).into_iter().zip(m.face_wedges(f)) {
                let x = ch.get(w);
                if v == lifted {
                    // Its own faces are symmetric about it: still up.
                    assert!((x[2] - 1.0).abs() < 1e-9, "{x:?}");
                } else {
                    assert_eq!(x, &[0.0, 0.0, 1.0], "{v:?} turned");
                }
            }
        }
    }

    #[test]
    fn max_width_limits_the_gap() {
        let m = cracked_plate();
        let d = pull_apart(&m, 0.1);
        let out = displace(
            &m,
            &d,
            &Post {
                max_width: 0.05,
                ..opts(1.0)
            },
        );
        assert!((out.max_gap - 0.05).abs() < 1e-12, "{}", out.max_gap);
        assert!(out.width_limited > 0);
    }

    #[test]
    fn flipping_moves_are_shortened_and_counted() {
        let m = cracked_plate();
        // Push one interior node far across its neighbours.
        let mut d = vec![[0.0; 3]; m.n_vertices()];
        let v = m
            .vertices()
            .find(|&v| m.position(v) == [1.0, 1.0, 0.0])
            .unwrap();
        d[v.idx()] = [3.0, 0.0, 0.0];
        let out = displace(&m, &d, &opts(1.0));
        assert!(out.inverted_triangles > 0);
        assert!(out.shortened_nodes > 0);
        for f in m.faces() {
            assert!(!bad_face(&m, f, &out.positions), "face {f} still flipped");
        }
        // The node still moved some of the way.
        assert!(out.positions[v.idx()][0] > 1.0);
    }

    /// A crack node whose triangle would flip is shortened together with
    /// its copy on the other side, so the two never slide past each other:
    /// after the halving, every pair of copies differs by a pure opening
    /// (across the crack, here along y).
    #[test]
    fn shortening_keeps_the_copies_of_a_crack_node_together() {
        let m = cracked_plate();
        let mut d = pull_apart(&m, 0.1);
        // Both copies of the crack node at x = 2 slide far along the crack,
        // flipping triangles on both sides.
        for v in m.vertices() {
            if m.position(v) == [2.0, 3.0, 0.0] {
                d[v.idx()][0] = 2.5;
            }
        }
        let out = displace(&m, &d, &opts(1.0));
        assert!(out.shortened_nodes > 0);
        let copies: Vec<VertexId> = m
            .vertices()
            .filter(|&v| m.position(v) == [2.0, 3.0, 0.0])
            .collect();
        assert_eq!(copies.len(), 2);
        let (a, b) = (
            out.positions[copies[0].idx()],
            out.positions[copies[1].idx()],
        );
        assert_eq!(a[0], b[0], "the copies slid apart along the crack");
        assert!(a[0] > 2.0, "still moved some of the way");
        for f in m.faces() {
            assert!(!bad_face(&m, f, &out.positions));
        }
    }

    /// Two roots at one rest position (both sides split at the same point)
    /// are one crack node for the opening rule.
    #[test]
    fn roots_at_one_position_form_one_group() {
        let m = cracked_plate();
        let groups = crack_groups(&m);
        for g in &groups {
            let p = m.position(g[0]);
            assert!(g.iter().all(|&v| m.position(v) == p));
        }
        let mut positions: Vec<[u64; 3]> = groups
            .iter()
            .map(|g| m.position(g[0]).map(f64::to_bits))
            .collect();
        let n = positions.len();
        positions.sort();
        positions.dedup();
        assert_eq!(positions.len(), n, "one group per rest position");
    }

    #[test]
    fn curling_lifts_crack_edges_and_falls_off() {
        let m = cracked_plate();
        let d = pull_apart(&m, 0.1);
        let out = displace(
            &m,
            &d,
            &Post {
                curl: 0.5,
                ..opts(1.0)
            },
        );
        // Crack nodes rise by 0.5 * 0.1; the next ring by half that; rows
        // further than 3 rings stay flat.
        for v in m.vertices() {
            let y = m.position(v)[1];
            let z = out.positions[v.idx()][2];
            let ring = (y - 3.0).abs().round() as i32;
            let expect = match ring {
                0 => 0.05,
                1 => 0.025,
                2 => 0.0125,
                3 => 0.00625,
                _ => 0.0,
            };
            assert!((z - expect).abs() < 1e-9, "y {y}: z {z}, expected {expect}");
        }
    }

    #[test]
    fn normals_turn_with_the_surface() {
        let mut m = flat_plate_with_normals();
        // Turn the whole plate 90 degrees about x, (x, y, z) -> (x, -z, y):
        // normals go from +z to -y.
        let rot: Vec<[f64; 3]> = m.positions().iter().map(|p| [p[0], -p[2], p[1]]).collect();
        turn_normals(&mut m, &rot);
        let ch = m.wedges().channel("NORMAL").unwrap();
        for w in 0..m.n_wedges() {
            let x = ch.get(crate::mesh::WedgeId(w as u32));
            assert!(
                x[0].abs() < 1e-9 && (x[1] + 1.0).abs() < 1e-9 && x[2].abs() < 1e-9,
                "{x:?}"
            );
        }
    }

    #[test]
    fn moved_vertices_read_the_texture_where_they_now_lie() {
        // A 4 x 4 plate whose UVs are its x and y: a texture fixed on the
        // surface means a moved vertex's UV is its new x and y.
        let (mut m, _) = crate::mesh::shapes::build(&crate::mesh::shapes::grid_input(4, 4));
        let uv_of = |m: &SimMesh, v: VertexId| -> Vec<[f64; 2]> {
            let ch = m.wedges().channel("uv").unwrap();
            m.halfedges()
                .filter(|&h| m.origin(h) == v)
                .map(|h| {
                    let x = ch.get(m.wedge(h));
                    [x[0], x[1]]
                })
                .collect()
        };
        let find = |m: &SimMesh, p: [f64; 3]| m.vertices().find(|&v| m.position(v) == p).unwrap();
        let (a, b, still) = (
            find(&m, [2.0, 2.0, 0.0]),
            find(&m, [1.0, 3.0, 0.0]),
            find(&m, [3.0, 1.0, 0.0]),
        );
        let mut to = m.positions().to_vec();
        to[a.idx()] = [2.3, 1.8, 0.0];
        // Off the surface: read where it projects onto its faces.
        to[b.idx()] = [1.2, 3.0, 0.4];
        // Off the plate's border: read at the nearest point of the face
        // nearest to containing it.
        let c = find(&m, [4.0, 2.0, 0.0]);
        to[c.idx()] = [4.5, 2.0, 0.0];
        let n = resample_moved_wedges(&mut m, &to);
        assert_eq!(n, 3, "one wedge per moved vertex");
        for uv in uv_of(&m, c) {
            assert!(
                (uv[0] - 4.0).abs() < 1e-12 && (uv[1] - 2.0).abs() < 1e-12,
                "{uv:?}"
            );
        }
        for uv in uv_of(&m, a) {
            assert!(
                (uv[0] - 2.3).abs() < 1e-12 && (uv[1] - 1.8).abs() < 1e-12,
                "{uv:?}"
            );
        }
        for uv in uv_of(&m, b) {
            assert!(
                (uv[0] - 1.2).abs() < 1e-12 && (uv[1] - 3.0).abs() < 1e-12,
                "{uv:?}"
            );
        }
        for uv in uv_of(&m, still) {
            assert_eq!(uv, [3.0, 1.0]);
        }
    }
}
