//! `wood-grain`'s checks in the baked maps are lens-shaped: widest in the
//! middle, closing to their tips, as a drying check in a board opens. Read
//! from the output's base colour map itself (no code shared with the crate):
//! each dark blob of the map is a check (or a piece of one cut by a chart's
//! seam); along its long axis, its width in the middle fifth over that in
//! its two end fifths.

mod common;

/// Length-weighted mean, over the dark blobs at least `min_len` pixels
/// long, of the width in the middle fifth along the blob's long axis over
/// the mean width in its two end fifths.
fn lens_ratio(w: usize, h: usize, lum: &[f64], min_len: f64) -> (f64, usize) {
    let mut sorted = lum.to_vec();
    sorted.sort_by(f64::total_cmp);
    let paper = sorted[sorted.len() / 2];
    let dark: Vec<bool> = lum.iter().map(|&l| l < 0.5 * paper).collect();
    let mut seen = vec![false; w * h];
    let (mut sum, mut weight, mut blobs) = (0.0, 0.0, 0);
    for start in 0..w * h {
        if !dark[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        let mut stack = vec![start];
        let mut pix: Vec<(f64, f64)> = Vec::new();
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            pix.push((x as f64, y as f64));
            let mut visit = |j: usize| {
                if dark[j] && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        // The long axis (principal direction of the pixels).
        let n = pix.len() as f64;
        let (mx, my) = pix
            .iter()
            .fold((0.0, 0.0), |a, p| (a.0 + p.0 / n, a.1 + p.1 / n));
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for p in &pix {
            let (dx, dy) = (p.0 - mx, p.1 - my);
            sxx += dx * dx;
            sxy += dx * dy;
            syy += dy * dy;
        }
        let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let (ux, uy) = (angle.cos(), angle.sin());
        let t: Vec<f64> = pix
            .iter()
            .map(|p| (p.0 - mx) * ux + (p.1 - my) * uy)
            .collect();
        let (lo, hi) = t.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &x| {
            (a.0.min(x), a.1.max(x))
        });
        let len = hi - lo;
        if len < min_len {
            continue;
        }
        let mut bins = [0.0f64; 5];
        for x in t {
            bins[(((x - lo) / len * 5.0) as usize).min(4)] += 1.0;
        }
        let ends = 0.5 * (bins[0] + bins[4]);
        if ends > 0.0 {
            sum += len * bins[2] / ends;
            weight += len;
            blobs += 1;
        }
    }
    (sum / weight.max(1e-300), blobs)
}

fn ratio(taper: bool) -> (f64, usize) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.glb");
    let input = common::fixture("plate_jittered.obj");
    let set = format!("post.bake_taper={taper}");
    let o = common::crack(
        &input,
        &out,
        &["-q", "--preset", "wood-grain", "--set", &set],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (w, h, lum) = common::base_color(&out);
    lens_ratio(w, h, &lum, 0.02 * w as f64)
}

#[test]
fn checks_are_widest_in_the_middle() {
    let (lens, n) = ratio(true);
    let (even, m) = ratio(false);
    eprintln!("middle over end width: tapered {lens:.2} ({n} checks), even {even:.2} ({m} checks)");
    assert!(n >= 20 && m >= 20, "{n} / {m} checks");
    assert!(lens > 1.4, "tapered {lens:.2}");
    assert!(lens > 1.3 * even, "tapered {lens:.2}, even {even:.2}");
}
