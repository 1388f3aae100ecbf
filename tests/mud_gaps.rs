//! `mud`'s gaps on a flat patch: each side of a cell stands off evenly, and
//! the gap stays open where cracks meet. The gaps used to open by each
//! crack node's own relaxation displacement, an elastic crack's profile:
//! widest in the middle of a crack that was free while it grew, small where
//! it later met another crack, so every side opened as a lens and the gap
//! pinched shut at the junctions (worse the wider the gaps). Measured with
//! the independent measure (`common/measure.rs`, which reads the output's
//! top surface itself and shares no code with the crate): from every
//! outline edge of the opened surface, the distance straight across the gap
//! to the next outline.

mod common;
#[path = "common/measure.rs"]
mod measure;

/// The shares of `mud`'s gap outline (length-weighted) whose gap is under
/// a quarter and under half of the median width, on the jittered plate
/// fixture with `post.width = width`.
fn pinched(width: &str) -> (f64, f64) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.glb");
    let input = common::fixture("plate_jittered.obj");
    let set = format!("post.width={width}");
    let o = common::crack(&input, &out, &["-q", "--preset", "mud", "--set", &set]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let top = measure::read_model(&out).triangles(|m| m != "crack_wall");
    let (lo, hi) = measure::bounds(top.iter().flatten());
    let flat = measure::flat_axis(lo, hi);
    // The preset's cell: a tenth of the plate's diagonal.
    let cell = 0.1 * (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    let w = measure::gap_widths(&top, flat, 1e-7, cell, cell);
    assert!(w.len() > 1000, "{} outline edges measured", w.len());
    (
        measure::pinched_share(&w, 0.25),
        measure::pinched_share(&w, 0.5),
    )
}

#[test]
fn gaps_stand_off_evenly_and_stay_open_at_junctions() {
    // Lens-shaped gaps (the openings per node): 0.012 / 0.063 at the
    // preset's width, 0.066 / 0.163 at three times it.
    let (quarter, half) = pinched("0.01");
    eprintln!("width 0.01: under a quarter of the median {quarter:.4}, under half {half:.4}");
    assert!(quarter < 0.006 && half < 0.05, "{quarter:.4} / {half:.4}");
    let (quarter, half) = pinched("0.03");
    eprintln!("width 0.03: under a quarter of the median {quarter:.4}, under half {half:.4}");
    assert!(quarter < 0.04 && half < 0.12, "{quarter:.4} / {half:.4}");
}
