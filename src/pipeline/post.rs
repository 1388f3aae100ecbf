//! The post-processing stages of `crackle crack`: crack width and curling,
//! side walls, shader attributes, crack lines. Each runs only when the
//! pipeline's `[post]` table asks for it.

use super::post_report::{
    BakeReport, CutReport, GapReport, IslandsReport, MarginReport, PathsReport, PostReport,
    WallsReport,
};
use super::primitives::{add_crack_lines, n_targets, wall_primitive};
use super::Post;
use crate::bridge::{write_back_with, SimEntry};
use crate::post::distance::{crack_vertices, distance_field};
use crate::post::walls::{bottom_offsets, build_walls_uncrossed, Hang, WallOptions, Walls};
use crate::post::width::{displace, groove, resample_moved_wedges, turn_normals};
use crate::scene::Scene;
use crate::sim::SimReport;
use std::time::Instant;

/// Seconds per post stage and what each did, summed over meshes.
#[derive(Default)]
pub struct PostOutcome {
    /// (stage name, seconds, the process's peak resident bytes when it
    /// last ended), in the order the stages ran.
    pub stages: Vec<(&'static str, f64, Option<u64>)>,
    /// Per mesh: the stage details for the report.
    pub details: Vec<PostReport>,
}

impl PostOutcome {
    fn time(&mut self, name: &'static str, seconds: f64) {
        let peak = super::memory::peak_resident_bytes();
        match self.stages.iter_mut().find(|(n, ..)| *n == name) {
            Some((_, s, p)) => {
                *s += seconds;
                *p = peak.max(*p);
            }
            None => self.stages.push((name, seconds, peak)),
        }
    }
}

/// A mesh's crack segments, their times (fractions of the run) and, when
/// the segments moved with the gaps, where they lie at rest.
type CrackLines = (Vec<[[f64; 3]; 2]>, Vec<f64>, Option<Vec<[[f64; 3]; 2]>>);

/// Post-process every simulated mesh and write it back into `scene`:
/// width and curling, walls, attributes, then the crack lines.
pub fn apply(
    scene: &mut Scene,
    entries: &mut [SimEntry],
    reports: &[(usize, SimReport)],
    post: &Post,
) -> crate::Result<PostOutcome> {
    let mut out = PostOutcome::default();
    let mut opened_meshes: Vec<Opened> = Vec::new();
    for (e, (_, r)) in entries.iter_mut().zip(reports) {
        let mut detail = PostReport::default();
        opened_meshes.push(open_mesh(scene, e, r, post, &mut detail, &mut out)?);
        out.details.push(detail);
    }
    let mut timing = PostOutcome::default();
    let cells: Vec<Option<f64>> = reports.iter().map(|(_, r)| r.cell_size).collect();
    for (((e, cell), opened), detail) in entries
        .iter()
        .zip(cells)
        .zip(opened_meshes)
        .zip(out.details.iter_mut())
    {
        lines_bake_and_walls(scene, e, cell, opened, detail, post, &mut timing)?;
    }
    if post.split_islands {
        super::islands::remove_empty_meshes(scene);
    }
    // Smooth shading where the input had no normals (after every stage:
    // the output's own geometry).
    let t = Instant::now();
    let mut smoothed = false;
    for m in 0..scene.meshes.len() {
        smoothed |= super::attributes::add_smooth_normals(scene, m, post.smooth_angle);
    }
    if smoothed {
        timing.time("normals", t.elapsed().as_secs_f64());
    }
    out.stages.extend(timing.stages);
    Ok(out)
}

/// How a mesh's cracks open: the groove width (0 without grooves), the
/// stage that times it, whether anything moves, and whether the moves of a
/// crack's two sides stay tied.
struct Plan {
    groove_width: f64,
    stage: &'static str,
    moves: bool,
    tied: bool,
}

impl Plan {
    fn of(e: &SimEntry, r: &SimReport, post: &Post) -> Plan {
        // Grooves: a width from the cell size (or, for models without one,
        // the bounding-box diagonal).
        let groove_width = if post.grooves() {
            let cell = r
                .cell_size
                .unwrap_or_else(|| super::Bounds::of(e.sim.positions().iter().copied()).diagonal());
            post.groove_width(cell)
        } else {
            0.0
        };
        let stage = if groove_width > 0.0 {
            "groove"
        } else {
            "width"
        };
        Plan {
            groove_width,
            stage,
            moves: post.width > 0.0 || post.curl > 0.0 || groove_width > 0.0,
            // Gaps opened in a band move each copy of a crack node by its
            // own opening, so a move shortened later is shortened alone;
            // whole cells' moves (and grooves) stay tied across the crack.
            tied: post.gap_band <= 0.0 || groove_width > 0.0,
        }
    }
}

/// A mesh's first pass: its cracks straightened, its gaps or grooves
/// opened, cut into the input, its walls built, its attributes added and
/// the mesh written back into `scene`; what the second pass needs.
fn open_mesh(
    scene: &mut Scene,
    e: &mut SimEntry,
    r: &SimReport,
    post: &Post,
    detail: &mut PostReport,
    out: &mut PostOutcome,
) -> crate::Result<Opened> {
    if let Some(u) = super::margin::grown(e) {
        // The simulation's crack events, triangles and energy count the
        // strip too; its crack length and segments are the input's. The
        // input's and the strip's triangles as grown (before remeshing).
        detail.margin = Some(MarginReport {
            strip_triangles: u.strip.len(),
            input_triangles: u.input.n_faces(),
        });
    }
    let plan = Plan::of(e, r, post);
    let moves = plan.moves;
    // Cracks along the simulation surface's edges, off its zig-zag.
    let straightened = straighten(e, r, post, moves, detail)?;
    let r = straightened.as_ref().unwrap_or(r);
    // Broken springs: lines across them where no gap opens along their
    // edges.
    let crossed;
    let r = if !moves && r.crossings.len() == r.segments.len() && !r.crossings.is_empty() {
        crossed = SimReport {
            segments: r.crossings.clone(),
            ..r.clone()
        };
        &crossed
    } else {
        r
    };
    // Gaps and grooves open on the simulation surface, whose triangles
    // the method made (well shaped, and a crack's nodes spaced alike).
    let t = Instant::now();
    let opened = moves.then(|| {
        if plan.groove_width > 0.0 {
            groove(&e.sim, 0.5 * plan.groove_width)
        } else {
            displace(&e.sim, &r.displacement, post)
        }
    });
    if moves {
        out.time(plan.stage, t.elapsed().as_secs_f64());
    }
    // Cutting into the input: from here on the mesh is the input's, cut,
    // with the simulation's values (and the gaps' moves) carried over.
    let cut = cut_mesh(e, r, post, &plan, opened.as_ref(), detail, out)?;
    let r = cut.report.as_ref().unwrap_or(r);
    let mut positions: Vec<[f64; 3]> = e.sim.positions().to_vec();
    // How far each crack opened, read at rest (before anything moves).
    let opening = openings(&e.sim, &r.displacement, &r.segments);
    let mut mean_gap = 0.0;
    if let Some(d) = opened {
        mean_gap = d.mean_gap;
        positions = gap_positions(e, d, cut.carried, &plan, detail, out);
    }
    let walls = build_walls(
        e,
        &mut positions,
        post,
        &plan,
        mean_gap,
        cut.hung,
        detail,
        out,
    );
    // Times as fractions of the run (0..1).
    let end = if r.time > 0.0 { r.time } else { 1.0 };
    let extra = if post.attributes {
        let t = Instant::now();
        let extra = crack_attributes(e, r, &positions, end);
        out.time("attributes", t.elapsed().as_secs_f64());
        extra
    } else {
        Vec::new()
    };
    // The crack lines follow the opened surface: each end moves to the
    // middle of the gap (the mean of the crack vertices at its rest
    // position).
    let segments = if moves {
        follow_gaps(&e.sim, &positions, &r.segments)
    } else {
        r.segments.clone()
    };
    if moves {
        // Gaps opened locally and grooves open over a texture that stays
        // in place; cells that shrink whole (no gap band) carry theirs
        // along.
        if post.gap_band > 0.0 || plan.groove_width > 0.0 {
            let n = resample_moved_wedges(&mut e.sim, &positions);
            detail.resampled_corners = Some(n);
        }
        turn_normals(&mut e.sim, &positions);
        e.sim
            .set_positions(&positions)
            .map_err(|err| crate::Error::Internal {
                mesh: e.label.clone(),
                error: err.into(),
            })?;
    }
    if post.keeps_input() {
        super::keep::add_attributes(scene, e, &extra);
    } else {
        write_back_with(scene, e, &extra);
    }
    let rest = moves.then(|| r.segments.clone());
    Ok(Opened {
        walls,
        widths: baked_widths(e, r, post, &opening, end),
        lines: (
            segments,
            r.segment_times.iter().map(|t| t / end).collect(),
            rest,
        ),
    })
}

/// What cutting the cracks into the input left: the report of the cut
/// mesh (none when the cracks stay on the simulation surface), the gaps'
/// moves carried onto the input's vertices, and the walls' bottom line.
#[derive(Default)]
struct CutMesh {
    report: Option<SimReport>,
    carried: Option<Vec<[f64; 3]>>,
    hung: Option<BottomLine>,
}

/// Cut `e`'s cracks into its input (its unremeshed mesh, when the pipeline
/// cuts the input), carrying the gaps' moves and the walls' bottom line
/// made on the simulation surface across with them.
fn cut_mesh(
    e: &mut SimEntry,
    r: &SimReport,
    post: &Post,
    plan: &Plan,
    opened: Option<&crate::post::width::Displaced>,
    detail: &mut PostReport,
    out: &mut PostOutcome,
) -> crate::Result<CutMesh> {
    let base = match e.unremeshed.take() {
        Some(base) if post.cuts_input() => base,
        _ => return Ok(CutMesh::default()),
    };
    let t = Instant::now();
    // The gaps' moves and the walls' bottom line, made on the simulation
    // surface (its walls uncrossed there), go across with the cracks.
    let sim = opened.map(|d| {
        let mut top = d.positions.clone();
        let bottoms = (post.walls || plan.groove_width > 0.0).then(|| {
            let opts = wall_options(post, plan.groove_width, d.mean_gap);
            build_walls_uncrossed(&e.sim, &mut top, &opts, None, plan.tied);
            bottom_offsets(&e.sim, &top, &opts)
        });
        (moves_from_rest(&e.sim, &top), bottoms)
    });
    let mut carry: Vec<&[[f64; 3]]> = Vec::new();
    if let Some((m, bottoms)) = &sim {
        carry.push(m);
        if let Some((o, n)) = bottoms {
            carry.extend([o.as_slice(), n.as_slice()]);
        }
    }
    match cut_into_input(&base, e, r, &carry) {
        Ok((report, d, mut c)) => {
            let mut cut = CutMesh::default();
            if c.len() == 3 {
                let n = c.pop().unwrap_or_default();
                cut.hung = c.pop().map(|o| (o, n));
            }
            cut.carried = c.pop();
            cut.report = Some(report);
            detail.cut_input = Some(d);
            out.time("cut_input", t.elapsed().as_secs_f64());
            Ok(cut)
        }
        Err(err) if e.unextended.is_some() => {
            // The simulation surface has the margin's strip: it may not be
            // written.
            Err(crate::Error::Internal {
                mesh: e.label.clone(),
                error: format!("the cracks cannot be cut into the input ({err}); with simulation.margin = 0 they stay on the simulation surface instead").into(),
            })
        }
        Err(err) => {
            log::warn!(
                "{}: the cracks stay on the simulation surface: {err}",
                e.label
            );
            detail.cut_input = Some(CutReport::FellBack {
                fell_back: err.to_string(),
            });
            Ok(CutMesh::default())
        }
    }
}

/// The opened positions of `e`'s nodes: the gaps' moves `d`, or on a cut
/// input its own vertices moved by the moves `carried` across (shortened
/// where they would turn one of its triangles over); the gaps' report.
fn gap_positions(
    e: &SimEntry,
    d: crate::post::width::Displaced,
    carried: Option<Vec<[f64; 3]>>,
    plan: &Plan,
    detail: &mut PostReport,
    out: &mut PostOutcome,
) -> Vec<[f64; 3]> {
    let mut info = GapReport {
        max_gap: d.max_gap,
        mean_gap: d.mean_gap,
        width_limited_nodes: d.width_limited,
        inverted_triangles_prevented: d.inverted_triangles,
        shortened_nodes: d.shortened_nodes,
        rounded_corner_nodes: d.rounded_nodes,
        shortened_nodes_on_input: None,
    };
    let positions = match carried {
        Some(m) => {
            let t = Instant::now();
            let mut positions: Vec<[f64; 3]> = e.sim.positions().to_vec();
            for (p, m) in positions.iter_mut().zip(m) {
                *p = crate::math::v3::add(*p, m);
            }
            let n = crate::post::width::shorten(&e.sim, &mut positions, &[], 1.0, plan.tied);
            info.shortened_nodes_on_input = Some(n);
            out.time(plan.stage, t.elapsed().as_secs_f64());
            positions
        }
        None => d.positions,
    };
    if plan.groove_width > 0.0 {
        detail.groove = Some(info);
    } else {
        detail.width = Some(info);
    }
    positions
}

/// The walls down each crack's sides (with walls or grooves), their moves
/// shortened where walls would pass through the surface or each other.
#[allow(clippy::too_many_arguments)]
fn build_walls(
    e: &SimEntry,
    positions: &mut [[f64; 3]],
    post: &Post,
    plan: &Plan,
    mean_gap: f64,
    hung: Option<BottomLine>,
    detail: &mut PostReport,
    out: &mut PostOutcome,
) -> Option<Walls> {
    if !(post.walls || plan.groove_width > 0.0) {
        return None;
    }
    let t = Instant::now();
    let opts = wall_options(post, plan.groove_width, mean_gap);
    let depth = opts.depth;
    // Walls passing through the surface or each other (narrow, sheared
    // gaps at junctions) have their moves shortened.
    let hang = hung.as_ref().map(|(o, n)| Hang {
        offsets: o,
        normals: n,
    });
    let (w, fix) = build_walls_uncrossed(&e.sim, positions, &opts, hang, plan.tied);
    if fix.crossing_after > 0 {
        log::info!(
            "{}: {} wall triangle pairs cross",
            e.label,
            fix.crossing_after
        );
    }
    detail.walls = Some(WallsReport {
        depth,
        crossing_pairs: fix.crossing_after,
        crossing_pairs_prevented: fix.crossing_before - fix.crossing_after,
        shortened_nodes: fix.shortened_nodes,
        triangles: w.triangles.len(),
        skipped_degenerate: w.skipped_degenerate,
        skipped_closed_sides: w.skipped_closed,
    });
    out.time("walls", t.elapsed().as_secs_f64());
    Some(w)
}

/// What the first pass left for a mesh's second: its walls, the baked
/// width of each crack segment, and its crack lines.
struct Opened {
    walls: Option<Walls>,
    widths: Vec<f64>,
    lines: CrackLines,
}

/// The second pass over one mesh, once every mesh is written back: its
/// crack lines (carried onto the input's surface when it is kept), the
/// baked maps, and its walls as a primitive or its pieces split apart.
fn lines_bake_and_walls(
    scene: &mut Scene,
    e: &SimEntry,
    cell: Option<f64>,
    opened: Opened,
    detail: &mut PostReport,
    post: &Post,
    timing: &mut PostOutcome,
) -> crate::Result<()> {
    let Opened {
        walls,
        widths,
        lines: (segments, times, rest),
    } = opened;
    let targets = n_targets(scene, e.mesh_index);
    // Kept geometry: the cracks carried onto the input's surface; for
    // the maps, halved until they lie within a tenth of the baked
    // crack's width of it.
    let (bake_segments, bake_widths) = if post.keeps_input() && post.bake {
        let diagonal = super::Bounds::of(e.sim.positions().iter().copied()).diagonal();
        let tolerance = 0.1 * post.bake_width_for(diagonal, cell);
        super::keep::onto_input(scene, e, &segments, &widths, tolerance)
    } else {
        (segments.clone(), widths)
    };
    let (segments, times) = if post.keeps_input() && post.lines {
        super::keep::onto_input(scene, e, &segments, &times, 0.0)
    } else {
        (segments, times)
    };
    if post.lines {
        add_crack_lines(scene, e.mesh_index, &segments, &times, rest.as_deref());
    }
    if post.bake {
        let t = Instant::now();
        let b = super::bake::bake_mesh(
            scene,
            e.mesh_index,
            &e.label,
            &bake_segments,
            &bake_widths,
            cell,
            post,
        )?;
        let seconds = t.elapsed().as_secs_f64();
        detail.bake = Some(BakeReport {
            seconds,
            materials: Some(b.materials),
            pieces: None,
        });
        timing.time("bake", seconds);
    }
    if post.split_islands {
        let t = Instant::now();
        let wall_material = if post.grooves() {
            &post.groove_material
        } else {
            &post.wall_material
        };
        let make = |scene: &mut Scene, w: &Walls, tris: &[usize], offset: [f64; 3]| {
            wall_primitive(scene, w, tris, offset, wall_material, targets)
        };
        let s = super::islands::split(scene, e, walls.as_ref(), &make);
        detail.islands = Some(IslandsReport {
            pieces: s.pieces,
            recentred: s.recentred,
            largest_piece_triangles: s.largest,
        });
        timing.time("islands", t.elapsed().as_secs_f64());
    } else if let Some(w) = walls {
        let all: Vec<usize> = (0..w.triangles.len()).collect();
        let name = if post.grooves() {
            &post.groove_material
        } else {
            &post.wall_material
        };
        if let Some(p) = wall_primitive(scene, &w, &all, [0.0; 3], name, targets) {
            scene.meshes[e.mesh_index].primitives.push(p);
        }
    }
    Ok(())
}

/// The shader attributes of a cracked mesh: each vertex's distance along
/// the surface to the nearest crack (`_CRACK_DISTANCE`, at `positions`) and
/// the time that crack formed (`_CRACK_TIME`, a fraction of the run, whose
/// end is `end`).
fn crack_attributes(
    e: &SimEntry,
    r: &SimReport,
    positions: &[[f64; 3]],
    end: f64,
) -> Vec<(String, Vec<f64>)> {
    // With a margin, only the input's cracks count: a crack in the
    // strip just past the border is not one the asset shows.
    let on_input = super::margin::on_input(e);
    let sources: Vec<_> = crack_vertices(&e.sim)
        .into_iter()
        .filter(|&v| on_input.as_ref().is_none_or(|on| on(e.sim.position(v))))
        .map(|v| {
            let time = r.crack_time.get(v.idx()).copied().unwrap_or(f64::NAN);
            (v, if time.is_nan() { 1.0 } else { time / end })
        })
        .collect();
    let (dist, label) = distance_field(&e.sim, positions, &sources);
    // Meshes without cracks (or pieces no crack reaches): the
    // largest finite distance, and time 1 (not yet cracked).
    let far = dist
        .iter()
        .copied()
        .filter(|d| d.is_finite())
        .fold(0.0, f64::max);
    let dist = dist
        .into_iter()
        .map(|d| if d.is_finite() { d } else { far })
        .collect();
    let label = label
        .into_iter()
        .map(|l| {
            if l.is_finite() {
                l.clamp(0.0, 1.0)
            } else {
                1.0
            }
        })
        .collect();
    vec![
        ("_CRACK_DISTANCE".into(), dist),
        ("_CRACK_TIME".into(), label),
    ]
}

/// The baked width of each segment of `r`: fading with its age and its
/// depth (`opening`, the opening between its sides, the deepest crack
/// full), tapered toward its tips when asked. Full width from the 95th
/// percentile of the openings up, so one wide crack does not thin all the
/// others.
fn baked_widths(e: &SimEntry, r: &SimReport, post: &Post, opening: &[f64], end: f64) -> Vec<f64> {
    let deepest = {
        let mut o: Vec<f64> = opening.iter().copied().filter(|x| x.is_finite()).collect();
        o.sort_by(f64::total_cmp);
        o.get(o.len() * 95 / 100).copied().unwrap_or(0.0)
    };
    let taper = post.bake_taper.then(|| {
        // Ends where the margin's clip cut a crack at the input's
        // border are on the border, not tips.
        let tolerance = 1e-4 * r.cell_size.unwrap_or(0.0);
        let cut = super::margin::on_input_border(e, tolerance);
        let border = border_points(&e.sim);
        crate::post::taper::tapers(&r.segments, |p| {
            border(p) || cut.as_ref().is_some_and(|on| on(p))
        })
    });
    r.segment_times
        .iter()
        .zip(opening)
        .enumerate()
        .map(|(i, (t, o))| {
            let w = post.fade(t / end, if deepest > 0.0 { o / deepest } else { 1.0 });
            w * taper.as_ref().map_or(1.0, |f| f[i])
        })
        .collect()
}

/// The walls' (or grooves') depth and profile: the groove's depth (its
/// width unless given), else the wall depth, given or relative to the
/// mean gap.
fn wall_options(post: &Post, groove_width: f64, mean_gap: f64) -> WallOptions {
    let depth = if groove_width > 0.0 {
        if post.groove_depth > 0.0 {
            post.groove_depth
        } else {
            groove_width
        }
    } else if post.wall_depth > 0.0 {
        post.wall_depth
    } else {
        post.wall_depth_relative * mean_gap
    };
    let rows = if groove_width > 0.0 {
        post.groove_rows()
    } else {
        0
    };
    WallOptions { depth, rows }
}

/// The report of `e` with its cracks taken off the simulation surface's
/// edges ([`crate::post::paths`]), `e.sim` moved with them; none when its
/// cracks split their triangles or `post.smooth_paths` is 0. Where no gap
/// opens (`moves` false) and the lines across broken springs are drawn,
/// those lines are smoothed instead and `e.sim` stays.
fn straighten(
    e: &mut SimEntry,
    r: &SimReport,
    post: &Post,
    moves: bool,
    detail: &mut PostReport,
) -> crate::Result<Option<SimReport>> {
    if !e.along_edges || post.smooth_paths == 0 || r.segments.is_empty() {
        return Ok(None);
    }
    let mut s = r.clone();
    let p = if !moves && s.crossings.len() == s.segments.len() {
        // No gap opens: the lines across the broken springs are drawn.
        let broken = std::mem::replace(&mut s.segments, std::mem::take(&mut s.crossings));
        crate::post::paths::smooth_lines(
            &e.sim,
            &broken,
            &mut s.segments,
            &mut s.segment_times,
            post.smooth_paths,
        )
    } else {
        s.crossings.clear();
        crate::post::paths::smooth(
            &mut e.sim,
            &mut s.segments,
            &mut s.segment_times,
            post.smooth_paths,
        )
        .map_err(|err| crate::Error::Internal {
            mesh: e.label.clone(),
            error: err.into(),
        })?
    };
    s.crack_length = p.length[1];
    detail.paths = Some(PathsReport {
        passes: post.smooth_paths,
        free_points: p.free,
        held: p.held,
        spurs: p.spurs,
        rings: p.rings,
        joined: p.joined,
        loops: p.loops,
        loop_sides: p.loop_sides,
        length: p.length,
    });
    Ok(Some(s))
}

/// Cut the cracks of `e` (simulated on its remeshed surface, `r`) into
/// `base`, its input: `e.sim` becomes the cut input, and the returned
/// report carries the displacements, crack times and segments over, with
/// the arrays of `carry` (per vertex of the simulation surface).
fn cut_into_input(
    base: &crate::mesh::SimMesh,
    e: &mut SimEntry,
    r: &SimReport,
    carry: &[&[[f64; 3]]],
) -> Result<Cut, crate::mesh::error::MeshError> {
    let im = crate::mesh::imprint::imprint(
        base,
        &e.sim,
        &r.segments,
        &r.segment_times,
        &r.displacement,
        &r.crack_time,
        carry,
    )?;
    let detail = CutReport::Cut {
        triangles: [base.n_faces(), im.mesh.n_faces()],
        simulated_triangles: e.sim.n_faces(),
        cut_edges: im.segments.len(),
        snapped: im.snapped,
        cut_along_edges: im.along_edges,
        cut_across_shells: im.across_shells,
        skipped_segments: im.skipped,
        refined_edges: im.refined,
        settled_edges: im.settled,
    };
    e.sim = im.mesh;
    let report = SimReport {
        displacement: im.displacement,
        crack_time: im.crack_time,
        segments: im.segments,
        segment_times: im.segment_times,
        ..r.clone()
    };
    Ok((report, detail, im.carried))
}

/// A walls' bottom line per vertex: offsets from rest and unit normals
/// ([`bottom_offsets`]).
type BottomLine = (Vec<[f64; 3]>, Vec<[f64; 3]>);

/// The cut input's report, its details for the run report, and the arrays
/// carried onto its vertices.
type Cut = (SimReport, CutReport, Vec<Vec<[f64; 3]>>);

/// Every vertex's move from its rest position in `mesh` to `positions`.
fn moves_from_rest(mesh: &crate::mesh::SimMesh, positions: &[[f64; 3]]) -> Vec<[f64; 3]> {
    mesh.positions()
        .iter()
        .zip(positions)
        .map(|(r, p)| crate::math::v3::sub(*p, *r))
        .collect()
}

/// `segments` (ends at crack vertices' rest positions) with each end moved
/// to the mean of the `positions` of the crack vertices resting there; ends
/// at no crack vertex stay.
fn follow_gaps(
    mesh: &crate::mesh::SimMesh,
    positions: &[[f64; 3]],
    segments: &[[[f64; 3]; 2]],
) -> Vec<[[f64; 3]; 2]> {
    let key = crate::mesh::spatial::position_key;
    let mut at: std::collections::BTreeMap<[u64; 3], ([f64; 3], f64)> = Default::default();
    for v in crack_vertices(mesh) {
        let e = at.entry(key(mesh.position(v))).or_insert(([0.0; 3], 0.0));
        let p = positions[v.idx()];
        e.0 = std::array::from_fn(|k| e.0[k] + p[k]);
        e.1 += 1.0;
    }
    let moved = |p: [f64; 3]| match at.get(&key(p)) {
        Some((sum, n)) => sum.map(|s| s / n),
        None => p,
    };
    segments.iter().map(|s| s.map(moved)).collect()
}

/// Per segment (ends at crack vertices' rest positions), how far its sides
/// moved apart: at each end the largest difference between the
/// accumulated relaxation displacements of the crack vertices resting
/// there, the two ends averaged (0 without displacements).
fn openings(
    mesh: &crate::mesh::SimMesh,
    displacement: &[[f64; 3]],
    segments: &[[[f64; 3]; 2]],
) -> Vec<f64> {
    let key = crate::mesh::spatial::position_key;
    let mut at: std::collections::BTreeMap<[u64; 3], Vec<[f64; 3]>> = Default::default();
    for v in crack_vertices(mesh) {
        if let Some(d) = displacement.get(v.idx()) {
            at.entry(key(mesh.position(v))).or_default().push(*d);
        }
    }
    let opening = |p: [f64; 3]| {
        at.get(&key(p)).map_or(0.0, |ds| {
            let mut most = 0.0f64;
            for (i, a) in ds.iter().enumerate() {
                for b in &ds[i + 1..] {
                    most = most.max(crate::math::v3::norm(crate::math::v3::sub(*a, *b)));
                }
            }
            most
        })
    };
    segments
        .iter()
        .map(|[a, b]| 0.5 * (opening(*a) + opening(*b)))
        .collect()
}

/// Whether a rest position is one of `mesh`'s vertices on its own border
/// (a boundary edge that is not a crack's side).
fn border_points(mesh: &crate::mesh::SimMesh) -> impl Fn([f64; 3]) -> bool {
    let on = crate::mesh::spatial::border_keys(mesh);
    move |p| on.contains(&crate::mesh::spatial::position_key(p))
}
