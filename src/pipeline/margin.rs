//! `simulation.margin`: the pattern grown on the surface extended beyond
//! its open border ([`crate::mesh::margin`]), then kept only on the input.
//!
//! The strip is simulated like the rest of the surface; what cracks in it
//! is cut off where the crack leaves the input (the input's border), so
//! the output is the input's own surface, cut through by a pattern that
//! does not know where the border is.

use crate::bridge::{SimEntry, Unextended};
use crate::mesh::margin::extend;
use crate::mesh::spatial::Faces;
use crate::sim::{SimParams, SimReport};
use crate::{Error, Result};
use std::path::Path;

/// Grow each entry's margin (where its parameters ask for one, it has a
/// border, and the run can take one: a film on its remeshed surface whose
/// output is the input's own mesh; with `post.output = "simulation"` the
/// simulation surface is written, and no strip may be in it; elsewhere a
/// warning; the input kept unchanged or cut): its cell size is fixed in
/// scene units first (a relative cell size is the input's, not the
/// extended surface's), and the welded input is kept as
/// [`SimEntry::unextended`].
///
/// # Errors
/// [`Error::Mesh`] when the strip cannot be built.
pub(super) fn grow(
    entries: &mut [SimEntry],
    params_of: &mut [SimParams],
    post: &super::Post,
    input: &Path,
) -> Result<()> {
    for (e, p) in entries.iter_mut().zip(params_of.iter_mut()) {
        if p.margin <= 0.0 || e.sim.n_boundary_halfedges() == 0 {
            continue;
        }
        if !(p.is_film() && p.isotropic_remesh && post.output == "input") {
            log::warn!(
                "{}: simulation.margin is left out: it grows a film's remeshed simulation surface (a cell size, relaxation = \"tensor\", isotropic_remesh = true) whose cracks go onto the input (post.output = \"input\")",
                e.label
            );
            continue;
        }
        let Some(cell) = p.cell_size_for(&e.sim) else {
            continue;
        };
        p.cell_size = Some(cell);
        p.cell_size_relative = None;
        let target = cell / crate::sim::film::EDGES_PER_CELL;
        let (extended, report) = extend(&e.sim, p.margin * cell, target)
            .map_err(|err| Error::mesh(input, &e.label, format!("margin: {err}")))?;
        log::info!(
            "{}: a margin of {:.3} cell sizes around {} border loop{}: {} triangles ({} strip vertices left out where it came back over the surface; {} loop{} left free)",
            e.label,
            p.margin,
            report.loops,
            if report.loops == 1 { "" } else { "s" },
            report.triangles,
            report.trimmed,
            report.left_free,
            if report.left_free == 1 { "" } else { "s" },
        );
        if report.loops == 0 {
            continue;
        }
        // Faces keep their order: the input's first, then the strip's.
        let n = e.sim.n_faces();
        let strip: Vec<[u32; 3]> = extended
            .faces()
            .skip(n)
            .map(|f| extended.face_vertices(f).map(|v| v.0))
            .collect();
        let strip = Faces::new(extended.positions().to_vec(), strip);
        let input = std::mem::replace(&mut e.sim, extended);
        e.unextended = Some(Unextended {
            input_faces: Faces::of_mesh(&input),
            input,
            strip,
        });
    }
    Ok(())
}

/// Keep each report's crack segments (and crossed springs) on its entry's
/// input: a segment leaving it ends where it leaves, one outside is
/// dropped; the crack length is that of what is kept. A point is on the
/// input when it lies no farther from the input than from the strip, so
/// the line between them is the input's border, whatever the simulation
/// surface's chords stray from a curved input.
pub(super) fn clip(entries: &[SimEntry], reports: &mut [(usize, SimReport)]) {
    for (e, (_, r)) in entries.iter().zip(reports.iter_mut()) {
        let Some(on) = on_input(e) else {
            continue;
        };
        let times = std::mem::take(&mut r.segment_times);
        let mut kept = Vec::with_capacity(r.segments.len());
        let mut kept_times = Vec::with_capacity(times.len());
        for (i, s) in r.segments.iter().enumerate() {
            if let Some(c) = clip_segment(*s, &on) {
                kept.push(c);
                if let Some(&t) = times.get(i) {
                    kept_times.push(t);
                }
            }
        }
        r.segments = kept;
        r.segment_times = kept_times;
        r.crossings = r
            .crossings
            .iter()
            .filter_map(|s| clip_segment(*s, &on))
            .collect();
        r.crack_length = r
            .segments
            .iter()
            .map(|[a, b]| crate::mesh::spatial::dist2(*a, *b).sqrt())
            .sum();
    }
}

/// The input and strip of an entry grown with a margin.
pub(super) fn grown(e: &SimEntry) -> Option<&Unextended> {
    e.unextended.as_ref().filter(|u| !u.strip.is_empty())
}

/// For an entry grown with a margin: whether a point of its simulation
/// surface lies on the input (no farther from it than from the strip).
pub(super) fn on_input(e: &SimEntry) -> Option<impl Fn([f64; 3]) -> bool + '_> {
    let u = grown(e)?;
    Some(move |p: [f64; 3]| u.input_faces.distance(p) <= u.strip.distance(p))
}

/// For an entry grown with a margin: whether a point lies on the input's
/// own border (within `tolerance` of the strip), where [`clip`] ends the
/// cracks that leave the input: those ends are not crack tips.
pub(super) fn on_input_border(
    e: &SimEntry,
    tolerance: f64,
) -> Option<impl Fn([f64; 3]) -> bool + '_> {
    let u = grown(e)?;
    Some(move |p: [f64; 3]| u.strip.distance(p) <= tolerance)
}

/// `[a, b]` cut back to the part on the input (`on`): whole when both ends
/// are on it, none when neither is, else up to where it leaves (found by
/// bisection to a millionth of the segment).
fn clip_segment(s: [[f64; 3]; 2], on: &impl Fn([f64; 3]) -> bool) -> Option<[[f64; 3]; 2]> {
    let [a, b] = s;
    match (on(a), on(b)) {
        (true, true) => Some(s),
        (false, false) => None,
        (a_on, _) => {
            let (inside, outside) = if a_on { (a, b) } else { (b, a) };
            let at = |t: f64| std::array::from_fn(|k| inside[k] + t * (outside[k] - inside[k]));
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..20 {
                let mid = 0.5 * (lo + hi);
                if on(at(mid)) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            if lo <= 0.0 {
                return None;
            }
            let end = at(lo);
            Some(if a_on { [inside, end] } else { [end, inside] })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_segment_is_cut_where_it_leaves() {
        let on = |p: [f64; 3]| p[0] <= 1.0;
        let s = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        let c = clip_segment(s, &on).unwrap();
        assert_eq!(c[0], [0.0, 0.0, 0.0]);
        assert!((c[1][0] - 1.0).abs() < 1e-5 && c[1][0] <= 1.0, "{c:?}");
        let r = clip_segment([s[1], s[0]], &on).unwrap();
        assert!((r[0][0] - 1.0).abs() < 1e-5 && r[1] == [0.0; 3], "{r:?}");
        assert!(clip_segment([[1.5, 0.0, 0.0], [2.0, 0.0, 0.0]], &on).is_none());
        assert_eq!(
            clip_segment([[0.5, 0.0, 0.0], [0.9, 1.0, 0.0]], &on),
            Some([[0.5, 0.0, 0.0], [0.9, 1.0, 0.0]])
        );
    }
}
