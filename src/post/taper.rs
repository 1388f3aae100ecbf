//! Crack widths that close towards free tips as an elastic crack's opening
//! does (`[post] bake_taper`): a crack of half-length `a` between two free
//! tips opens `sqrt(1 - (x / a)^2)` of its widest at `x` from its middle,
//! lens-shaped; one ending on another crack or the border opens as half of
//! such a crack, widest there.

use crate::math::v3;
use std::collections::BTreeMap;

/// Per segment (ends at rest positions, joined where they are exactly
/// equal), its width factor in (0, 1]: 1 along chains of segments that end
/// on junctions or where `on_border` holds, the elastic profile above
/// along chains with a free tip (an end no other segment shares, off the
/// border), taken at the segment's middle.
pub fn tapers(segments: &[[[f64; 3]; 2]], on_border: impl Fn([f64; 3]) -> bool) -> Vec<f64> {
    let key = crate::mesh::spatial::position_key;
    // Node ids by position, and the segments at each node.
    let mut id: BTreeMap<[u64; 3], usize> = BTreeMap::new();
    let mut ends: Vec<[usize; 2]> = Vec::with_capacity(segments.len());
    let mut points: Vec<[f64; 3]> = Vec::new();
    for s in segments {
        let e = s.map(|p| {
            let next = id.len();
            let i = *id.entry(key(p)).or_insert(next);
            if i == points.len() {
                points.push(p);
            }
            i
        });
        ends.push(e);
    }
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); points.len()];
    for (i, e) in ends.iter().enumerate() {
        for &n in e {
            at[n].push(i);
        }
    }
    let through = |n: usize| at[n].len() == 2;
    let mut factor = vec![1.0; segments.len()];
    let mut seen = vec![false; segments.len()];
    for start in 0..segments.len() {
        if seen[start] {
            continue;
        }
        // The chain through `start`: out to each side until a node that is
        // not a plain pass-through (a tip, a junction or the border).
        seen[start] = true;
        let mut halves: [Vec<usize>; 2] = [Vec::new(), Vec::new()];
        let mut stops = [ends[start][1], ends[start][0]];
        for (k, half) in halves.iter_mut().enumerate() {
            let (mut seg, mut node) = (start, stops[k]);
            while through(node) {
                let next = at[node][(at[node][0] == seg) as usize];
                if seen[next] {
                    break;
                }
                seen[next] = true;
                half.push(next);
                node = ends[next][(ends[next][0] == node) as usize];
                seg = next;
            }
            stops[k] = node;
        }
        let [ahead, behind] = halves;
        let chain: Vec<usize> = behind
            .into_iter()
            .rev()
            .chain([start])
            .chain(ahead)
            .collect();
        let free = |n: usize| at[n].len() == 1 && !on_border(points[n]);
        let (tip_first, tip_last) = (free(stops[1]), free(stops[0]));
        if !tip_first && !tip_last {
            continue;
        }
        let lengths: Vec<f64> = chain
            .iter()
            .map(|&i| v3::norm(v3::sub(segments[i][1], segments[i][0])))
            .collect();
        let total: f64 = lengths.iter().sum();
        if total <= 0.0 {
            continue;
        }
        let mut s = 0.0;
        for (&i, l) in chain.iter().zip(&lengths) {
            let m = (s + 0.5 * l) / total; // the middle, 0 at the first end
            s += l;
            // Distance from the widest point over the half-length.
            let x = match (tip_first, tip_last) {
                (true, true) => (2.0 * m - 1.0).abs(),
                (true, false) => 1.0 - m,
                _ => m,
            };
            factor[i] = (1.0 - x * x).max(0.0).sqrt();
        }
    }
    factor
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A polyline through `xs` along x at y = `y`.
    fn line(xs: &[f64], y: f64) -> Vec<[[f64; 3]; 2]> {
        xs.windows(2)
            .map(|w| [[w[0], y, 0.0], [w[1], y, 0.0]])
            .collect()
    }

    #[test]
    fn a_check_between_two_tips_is_widest_in_the_middle() {
        let xs: Vec<f64> = (0..=10).map(f64::from).collect();
        let f = tapers(&line(&xs, 0.0), |_| false);
        // Middles at 0.05, 0.15, ... of the length: sqrt(1 - (2m - 1)^2).
        for (k, v) in f.iter().enumerate() {
            let m = (k as f64 + 0.5) / 10.0;
            assert!((v - (1.0 - (2.0 * m - 1.0).powi(2)).sqrt()).abs() < 1e-12);
        }
        assert!(
            f[0] < 0.5 && f[9] < 0.5 && f[4] > 0.99 && f[5] > 0.99,
            "{f:?}"
        );
        // Reversed segments and order: the same factors.
        let mut rev: Vec<[[f64; 3]; 2]> = line(&xs, 0.0).into_iter().map(|[a, b]| [b, a]).collect();
        rev.reverse();
        let g = tapers(&rev, |_| false);
        for (a, b) in f.iter().zip(g.iter().rev()) {
            assert!((a - b).abs() < 1e-12);
        }
    }

    #[test]
    fn ends_on_a_crack_or_the_border_stay_wide() {
        // A T: the bar from x = 0 to 4 ends on the border at both ends; the
        // stem from (2, 0) up to (2, 4) ends free.
        let mut segs = line(&[0.0, 1.0, 2.0, 3.0, 4.0], 0.0);
        segs.extend((0..4).map(|k| [[2.0, k as f64, 0.0], [2.0, k as f64 + 1.0, 0.0]]));
        let border = |p: [f64; 3]| p[0] == 0.0 || p[0] == 4.0;
        let f = tapers(&segs, border);
        assert!(f[..4].iter().all(|&v| v == 1.0), "{f:?}");
        // The stem: widest at the bar, closing to its tip.
        let stem = &f[4..];
        assert!(stem.windows(2).all(|w| w[0] > w[1]), "{stem:?}");
        assert!(stem[0] > 0.99 && stem[3] < 0.7, "{stem:?}");
        // Off the border, the bar's ends are tips too.
        let f = tapers(&segs, |_| false);
        assert!(f[0] < 0.7 && f[3] < 0.7, "{f:?}");
    }
}
