//! `glass-impact` shows an impact: a star of radial cracks from the hit whose
//! crack length per area falls with distance, arcs between the rays, and no
//! ring where the pattern is cut off. Measured with the independent measure
//! (`common/measure.rs`, which counts the output's crack lines itself and
//! shares no code with the crate) on a jittered plate a DCC tool could make.

mod common;
#[path = "common/measure.rs"]
mod measure;
#[path = "common/shapes.rs"]
mod shapes;

/// The impact's numbers on the 160 x 160 jittered plate (10 units wide,
/// hit in the middle, reference radius a quarter of the diagonal).
fn impact_on_plate(extra: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    impact_on_plate_in(dir.path(), extra)
}

/// [`impact_on_plate`], its output `out.glb` left in `dir`.
fn impact_on_plate_in(dir: &std::path::Path, extra: &[&str]) -> serde_json::Value {
    let input = dir.join("plate.obj");
    shapes::write_obj(&input, &shapes::jittered_plate(160, 10.0, 0.3, 1));
    let out = dir.join("out.glb");
    common::crack_lines(&input, &out, "glass-impact", extra);
    let lines = measure::read_model(&out).rest_lines("crack_lines");
    assert!(!lines.is_empty(), "no crack lines");
    let radius = 0.25 * 200f64.sqrt();
    measure::impact_stats(&lines, [0.0; 3], [0.0, 1.0, 0.0], radius)
}

#[test]
fn glass_impact_is_a_star_that_thins_out_and_is_not_cut_off() {
    let dir = tempfile::tempdir().unwrap();
    let s = impact_on_plate_in(dir.path(), &[]);
    let lines = measure::read_model(&dir.path().join("out.glb")).rest_lines("crack_lines");
    let num = |k: &str| s[k].as_f64().unwrap_or_else(|| panic!("{k} in {s}"));
    // The paper's disc measured 0.48 radial, 5.2 and 5.1 per area, and all
    // of its length inside 1.1 R.
    assert!(
        num("radial_share_0.2_0.8") >= 0.65,
        "radial share from 0.2 to 0.8 R: {s}"
    );
    assert!(
        num("per_area_0.6_0.9") <= 0.5 * num("per_area_0_0.3"),
        "crack length per area does not fall with distance: {s}"
    );
    assert!(
        num("max_band_share_0.05") <= 0.10,
        "a ring holds more than a tenth of the length: {s}"
    );
    // Cracks reach past half the radius in several directions.
    assert!(s["crossings_0.5"].as_u64().unwrap() >= 6, "{s}");
    // Each ray one crack: the preset's 8 rays cross half the radius as 6
    // to 11 radial cracks, and no crack runs beside another within 0.6
    // (a sixth of the radius, 20 degrees). At a cell size of 0.05 of the
    // diagonal the rays ran in pairs: 15 radial cracks, 0.42 of the length
    // paired.
    let rays = s["radial_crossings_0.5"].as_u64().unwrap();
    assert!(
        (6..=11).contains(&rays),
        "{rays} radial cracks at half the radius: {s}"
    );
    let paired = measure::paired_share(&lines, 0.6, 20.0);
    assert!(
        paired < 0.1,
        "{paired} of the length runs beside another crack"
    );
}

/// The star holds over seeds and on a regular grid a DCC tool makes, not
/// only on the seed the test above pins: seeds 2 to 8 on the jittered plate
/// and 1 to 8 on the regular one (160 x 160, one diagonal per square), and
/// seeds 1 to 8 on the 80 x 80 jittered plate. Over these the
/// radial share from 0.2 to 0.8 R measured 0.715-0.928 (the 80 x 80 plate
/// 0.742-0.822) and the fullest band of 0.05 R 0.058-0.101 (the regular
/// plate's seed 7): its tenth is asked within 5%. With the ring tension at
/// full strength up to the hit, the first rings closed into a polygon
/// around it: radial share under 0.65 on 3 of 16 seeds (0.632), a band of
/// 0.117. Between the rays, rings: a tenth of the length from 0.2 to 0.8 R
/// concentric over all the runs (0.100), and nearly all of it near the hit
/// (concentric length per area 7.8 summed over the runs within 0.1-0.4 R,
/// 0.2 within 0.5-0.9 R: the rings thin out outward, and beyond half the
/// radius hardly any are left).
#[test]
fn the_star_holds_over_seeds_and_on_a_regular_grid() {
    let dir = tempfile::tempdir().unwrap();
    let radius = 0.25 * 200f64.sqrt();
    let plates = [
        ("jittered", shapes::jittered_plate(160, 10.0, 0.3, 1), 2..=8),
        ("regular", shapes::regular_plate(160, 10.0), 1..=8),
        (
            "jittered 80x80",
            shapes::jittered_plate(80, 10.0, 0.3, 2),
            1..=8,
        ),
    ];
    let mut failures = Vec::new();
    // Concentric crack length per area inside 0.1-0.4 R and 0.5-0.9 R, and
    // all crack length and concentric length from 0.2 to 0.8 R, pooled.
    let (mut inner, mut outer, mut mid, mut mid_rings) = (0.0, 0.0, 0.0, 0.0);
    for (name, text, seeds) in plates {
        let input = dir.path().join(format!("{name}.obj"));
        shapes::write_obj(&input, &text);
        for seed in seeds {
            let out = dir.path().join(format!("{name}-{seed}.glb"));
            let seed = seed.to_string();
            common::crack_lines(&input, &out, "glass-impact", &["--seed", &seed]);
            let lines = measure::read_model(&out).rest_lines("crack_lines");
            let s = measure::impact_stats(&lines, [0.0; 3], [0.0, 1.0, 0.0], radius);
            let radial = s["radial_share_0.2_0.8"].as_f64().unwrap();
            let band = s["max_band_share_0.05"].as_f64().unwrap();
            let fall =
                s["per_area_0.6_0.9"].as_f64().unwrap() / s["per_area_0_0.3"].as_f64().unwrap();
            eprintln!("{name} seed {seed}: radial {radial:.3}, band {band:.3}, fall {fall:.2}");
            if radial < 0.65 || band > 0.105 || fall > 0.5 {
                failures.push(format!(
                    "{name} seed {seed}: radial {radial:.3}, band {band:.3}, fall {fall:.2}"
                ));
            }
            let bands = s["bands"].as_array().unwrap();
            let ring = |i: usize, key: &str| {
                bands[i][key].as_f64().unwrap() * bands[i]["concentric"].as_f64().unwrap()
            };
            inner += (1..4).map(|i| ring(i, "per_area")).sum::<f64>() / 3.0;
            outer += (5..9).map(|i| ring(i, "per_area")).sum::<f64>() / 4.0;
            mid += (2..8)
                .map(|i| bands[i]["length"].as_f64().unwrap())
                .sum::<f64>();
            mid_rings += (2..8).map(|i| ring(i, "length")).sum::<f64>();
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
    // Rings between the rays, farther apart outward: concentric length
    // from 0.2 to 0.8 R, and less of it per area away from the hit.
    eprintln!(
        "concentric share 0.2-0.8 R {:.3}; per area 0.1-0.4 R {inner:.3}, 0.5-0.9 R {outer:.3} (summed over the runs)",
        mid_rings / mid
    );
    assert!(mid_rings >= 0.08 * mid, "{mid_rings} of {mid} concentric");
    assert!(
        inner >= 1.5 * outer,
        "rings no closer near the hit: {inner} against {outer} per area"
    );
}

/// The radial cracks at half the radius grow as the square root of the
/// impact speed (Vandenberghe, Vermorel and Villermaux 2013): 16 times the
/// speed, 4 times the cracks, within 25%, over three seeds each.
#[test]
fn radial_cracks_grow_as_the_square_root_of_the_speed() {
    let mean = |speed: &str| {
        let counts: Vec<u64> = ["1", "2", "3"]
            .iter()
            .map(|seed| {
                let s = impact_on_plate(&["--set", speed, "--seed", seed]);
                s["radial_crossings_0.5"].as_u64().unwrap()
            })
            .collect();
        (counts.iter().sum::<u64>() as f64 / 3.0, counts)
    };
    let (slow, at_slow) = mean("stress.0.speed=1");
    let (fast, at_fast) = mean("stress.0.speed=16");
    let ratio = fast / slow;
    assert!(
        (3.0..=5.0).contains(&ratio),
        "1 m/s {at_slow:?}, 16 m/s {at_fast:?}: x{ratio:.2}, not x4"
    );
}

/// `crackle stats --impact X,Y,Z --radius R` reports what the independent
/// measure finds on the same output: the radial share between 0.2 and 0.8
/// radii, the cracks crossing the half-radius circle and the radial ones
/// among them.
#[test]
fn crackle_stats_reports_the_impact_as_the_independent_measure_does() {
    let dir = tempfile::tempdir().unwrap();
    let m = impact_on_plate_in(dir.path(), &[]);
    let radius = (0.25 * 200f64.sqrt()).to_string();
    let o = common::run_ok([
        "stats".as_ref(),
        dir.path().join("out.glb").as_os_str(),
        "--json".as_ref(),
        "--impact".as_ref(),
        "0,0,0".as_ref(),
        "--radius".as_ref(),
        radius.as_ref(),
    ]);
    let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let h = &s["impact"];
    eprintln!("crackle stats: {h}");
    let share = h["radial_share_mid"].as_f64().unwrap();
    let measured = m["radial_share_0.2_0.8"].as_f64().unwrap();
    assert!((share - measured).abs() <= 0.05, "stats {h}\nmeasure {m}");
    let crossings = h["crossings_half"].as_u64().unwrap() as i64;
    let counted = m["crossings_0.5"].as_u64().unwrap() as i64;
    assert!((crossings - counted).abs() <= 2, "stats {h}\nmeasure {m}");
    let rays = h["radial_crossings_half"].as_u64().unwrap() as i64;
    let counted = m["radial_crossings_0.5"].as_u64().unwrap() as i64;
    assert!((rays - counted).abs() <= 1, "stats {h}\nmeasure {m}");
    // Crack length per area falls with distance in its bands too.
    let per_area: Vec<f64> = h["per_area"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(per_area[7] < 0.5 * per_area[1], "{per_area:?}");
    // A hit that is not three numbers is refused, naming the flag.
    let bad = common::run([
        "stats".as_ref(),
        dir.path().join("out.glb").as_os_str(),
        "--impact".as_ref(),
        "0,0".as_ref(),
        "--radius".as_ref(),
        "1".as_ref(),
    ]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--impact"));
}

/// Two hits on one pane, at once (two points in one term) and one after the
/// other (`in_turn`: the second lands once the first's cracks have come to
/// rest): each makes its star, and where they meet a crack ends on the
/// other star's instead of crossing it, so the two stars are one network
/// with no node where four cracks meet away from the hits (a star's rays
/// may all start at its hit).
#[test]
fn two_hits_make_two_stars_that_end_on_each_other() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plate.obj");
    shapes::write_obj(&input, &shapes::jittered_plate(160, 10.0, 0.3, 1));
    let star = |at: &str, weights: &str| {
        format!(
            "[[stress]]\nkind = \"impact\"\n{weights}\npoints_relative = {at}\n\
             radius_relative = 0.25\nspeed = 4.0\n"
        )
    };
    let pane = "[select]\nfixed_boundary = true\n[simulation]\ncell_size_relative = 0.05\n\
                shrink_rate = 0.0\nalpha = 0.5\nresidual_constant = 0.0\n\
                [post]\nlines = true\nbake = false\n";
    let hits = [[-1.2, 0.0, -0.5], [1.2, 0.0, 0.5]];
    let at_once = format!(
        "{pane}{}",
        star("[[0.38, 1.0, 0.45], [0.62, 1.0, 0.55]]", "init = 30.0")
    );
    let in_turn = format!(
        "{pane}{}",
        star(
            "[[0.38, 1.0, 0.45], [0.62, 1.0, 0.55]]",
            "init = 30.0\nin_turn = true"
        )
    );
    for (name, pipeline) in [("at_once", at_once), ("in_turn", in_turn)] {
        let file = dir.path().join(format!("{name}.toml"));
        std::fs::write(&file, pipeline).unwrap();
        let out = dir.path().join(format!("{name}.glb"));
        let o = common::crack(&input, &out, &["-q", "--pipeline", file.to_str().unwrap()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let lines = measure::read_model(&out).rest_lines("crack_lines");
        let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
        let radius = 0.25 * 200f64.sqrt();
        for hit in hits {
            let s = measure::impact_stats(&lines, hit, [0.0, 1.0, 0.0], radius);
            let rays = s["radial_crossings_0.5"].as_u64().unwrap();
            assert!(rays >= 5, "{name}: {rays} radial cracks around {hit:?}");
        }
        // A star's rays may meet at its hit; elsewhere a node where four
        // cracks meet is one crack crossing another.
        let off_hits = |n: usize| {
            let q = graph.nodes[n];
            hits.iter()
                .all(|h| (q[0] - h[0]).hypot(q[2] - h[2]) > 0.1 * radius)
        };
        let four = (0..graph.nodes.len())
            .filter(|&n| graph.degree[n] >= 4 && off_hits(n))
            .count();
        assert_eq!(four, 0, "{name}: {four} nodes where four cracks meet");
        // The node nearest each hit: both in one piece of the network.
        let nearest = |p: [f64; 3]| {
            (0..graph.nodes.len())
                .min_by(|&a, &b| {
                    let d = |n: usize| {
                        let q = graph.nodes[n];
                        (q[0] - p[0]).powi(2) + (q[2] - p[2]).powi(2)
                    };
                    d(a).total_cmp(&d(b))
                })
                .unwrap()
        };
        let pieces = graph.pieces();
        let piece_of = |n: usize| {
            pieces
                .iter()
                .position(|edges| edges.iter().any(|&e| graph.edges[e].contains(&n)))
        };
        let (a, b) = (piece_of(nearest(hits[0])), piece_of(nearest(hits[1])));
        assert!(a.is_some() && a == b, "{name}: the stars are apart");
    }
}

/// A later hit stops at the earlier cracks (`in_turn`): the second star's
/// load is measured along the surface as the first left it, so its cracks
/// stay in the piece of the pane the first star's cracks leave around the
/// hit (open where the first star's rays end, so a load wraps around their
/// tips). Counted on the output's crack lines, split by their
/// `_CRACK_TIME` at the time the report gives for the second hit: the
/// first stage's lines drawn into a raster of a fifth of a cell, the
/// regions between them filled, and the second stage's crack length in
/// each region summed: nearly all of it in one.
#[test]
fn a_later_hit_stops_at_the_earlier_cracks() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("plate.obj");
    shapes::write_obj(&input, &shapes::jittered_plate(160, 10.0, 0.3, 1));
    let mut seen = Vec::new();
    for (seed, b) in [("1", [2.4, 1.6]), ("2", [-2.2, 2.0]), ("3", [1.0, -2.7])] {
        let out = dir.path().join(format!("in_turn_{seed}.glb"));
        let hits = format!("stress.0.points=[[0, 0, 0], [{}, 0, {}]]", b[0], b[1]);
        let turn = [
            "--seed",
            seed,
            "--set",
            &hits,
            "--set",
            "stress.0.in_turn=true",
        ];
        common::crack_lines(&input, &out, "glass-impact", &turn);
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.with_extension("json")).unwrap()).unwrap();
        let sim = &report["meshes"][0]["report"];
        // `_CRACK_TIME` is a fraction of the run's time.
        let end = sim["time"].as_f64().unwrap();
        let at = sim["hit_times"][0]
            .as_f64()
            .unwrap_or_else(|| panic!("no hit time: {sim}"))
            / end;
        let cell = sim["cell_size"].as_f64().unwrap();
        let lines = measure::read_model(&out).timed_rest_lines("crack_lines");
        assert!(
            lines.iter().all(|(_, t)| t.is_finite()),
            "lines without times"
        );
        // The first star's finished before the second lands, at the
        // landing's time; the second's cracks a round later.
        let split = at + 0.5 * sim["phases"][0]["time"].as_f64().unwrap() / end;
        let (first, second): (Vec<_>, Vec<_>) = lines.into_iter().partition(|(_, t)| *t < split);
        let first: Vec<measure::Seg> = first.into_iter().map(|(s, _)| s).collect();
        let second: Vec<measure::Seg> = second.into_iter().map(|(s, _)| s).collect();
        let total = measure::crack_length(&second);
        let by_region = length_by_region(&first, &second, 0.2 * cell, 5.0);
        let most = by_region.iter().copied().fold(0.0, f64::max);
        // Segments whose middle lies on a first-stage line are in no region.
        let placed: f64 = by_region.iter().sum();
        eprintln!(
            "seed {seed}: the first hit {:.1} of crack length, the second {total:.1} \
             (landed at {at:.3} of the run), {:.3} of it in one region ({} regions, \
             {:.3} of it placed)",
            measure::crack_length(&first),
            most / placed,
            by_region.len(),
            placed / total
        );
        assert!(
            total > 5.0 * cell,
            "seed {seed}: the second hit made only {total:.2} of cracks"
        );
        seen.push(most / placed);
    }
    for (k, share) in seen.iter().enumerate() {
        assert!(
            *share >= 0.9,
            "seed {}: {share:.3} of the second star in its region",
            k + 1
        );
    }
}

/// The crack length of `lines` in each region of the XZ square
/// `[-half, half]^2` that `walls` leave (drawn into a raster of `pixel`,
/// regions filled 4-connected); a segment counts in the region of its
/// middle's pixel, nowhere when that pixel is a wall.
fn length_by_region(
    walls: &[measure::Seg],
    lines: &[measure::Seg],
    pixel: f64,
    half: f64,
) -> Vec<f64> {
    let n = (2.0 * half / pixel).ceil() as usize + 1;
    let at = |x: f64, z: f64| {
        let i = (((x + half) / pixel).floor().max(0.0) as usize).min(n - 1);
        let j = (((z + half) / pixel).floor().max(0.0) as usize).min(n - 1);
        j * n + i
    };
    let mut wall = vec![false; n * n];
    for [p, q] in walls {
        let steps = (d3(*p, *q) / (0.25 * pixel)).ceil() as usize + 1;
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            wall[at(p[0] + t * (q[0] - p[0]), p[2] + t * (q[2] - p[2]))] = true;
        }
    }
    let mut region = vec![usize::MAX; n * n];
    let mut count = 0;
    for start in 0..n * n {
        if wall[start] || region[start] != usize::MAX {
            continue;
        }
        let mut stack = vec![start];
        region[start] = count;
        while let Some(c) = stack.pop() {
            let (i, j) = (c % n, c / n);
            let mut near = Vec::with_capacity(4);
            if i > 0 {
                near.push(c - 1);
            }
            if i + 1 < n {
                near.push(c + 1);
            }
            if j > 0 {
                near.push(c - n);
            }
            if j + 1 < n {
                near.push(c + n);
            }
            for m in near {
                if !wall[m] && region[m] == usize::MAX {
                    region[m] = count;
                    stack.push(m);
                }
            }
        }
        count += 1;
    }
    let mut length = std::collections::BTreeMap::new();
    for s in lines {
        let c = at(0.5 * (s[0][0] + s[1][0]), 0.5 * (s[0][2] + s[1][2]));
        if !wall[c] {
            *length.entry(region[c]).or_insert(0.0) += d3(s[0], s[1]);
        }
    }
    length.into_values().collect()
}

/// The arcs between the rays end on them: the preset's finishing runs on
/// the tips with a crack within 0.3 cells ahead (`post.finish_reach`), so
/// an arc's end meets the ray beside it, while the rays' outer tips stay
/// where the load left them. An open end is an arc's when the crack it
/// ends runs across the way out from the hit (its chord over the last
/// 0.3 units, a twelfth of the radius, within 60 degrees of the circle
/// through it). Without finishing the arcs floated as dashes.
#[test]
fn arcs_end_on_the_rays_beside_them() {
    let ends = |extra: &[&str]| {
        let dir = tempfile::tempdir().unwrap();
        let s = impact_on_plate_in(dir.path(), extra);
        let lines = measure::read_model(&dir.path().join("out.glb")).rest_lines("crack_lines");
        let graph = measure::crack_graph(&lines, measure::DEFAULT_WELD_REL);
        let open: Vec<usize> = (0..graph.nodes.len())
            .filter(|&n| graph.degree[n] == 1)
            .collect();
        let arc_ends = open
            .iter()
            .filter(|&&n| {
                let (p, q) = (graph.nodes[n], graph.nodes[graph.walk_from_end(n, 0.3)]);
                let chord = [q[0] - p[0], q[2] - p[2]];
                let out = [p[0], p[2]]; // the hit is the origin, the plate is y = 0
                let (lc, lo) = (chord[0].hypot(chord[1]), out[0].hypot(out[1]));
                lc > 0.0
                    && lo > 0.0
                    && (chord[0] * out[0] + chord[1] * out[1]).abs() < 0.5 * lc * lo
            })
            .count();
        (arc_ends, open.len(), s)
    };
    let (arc_ends, open, s) = ends(&[]);
    let (loose_arc_ends, loose_open, _) = ends(&["--set", "post.finish=false"]);
    eprintln!(
        "arc ends / open ends: finished {arc_ends} / {open}, not {loose_arc_ends} / {loose_open}"
    );
    assert!(
        3 * arc_ends <= loose_arc_ends,
        "{arc_ends} arc ends finished, {loose_arc_ends} not"
    );
    assert!(arc_ends <= 2, "{arc_ends} arcs end in the open");
    // Still a star: no ray ran on to the pane's border.
    assert!(s["max_band_share_0.05"].as_f64().unwrap() <= 0.10, "{s}");
    let outside: f64 = s["share_beyond_1.1"].as_f64().unwrap_or(0.0);
    assert!(outside <= 0.05, "{outside} of the length beyond 1.1 R: {s}");
}

/// Euclidean distance.
fn d3(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The first surface point on the line through `(a, b)` (the other two
/// coordinates) along axis `k`, coming from its positive side, by
/// Moller-Trumbore on every triangle.
fn first_hit_from_positive(tris: &[measure::Tri], k: usize, line: [f64; 3]) -> Option<[f64; 3]> {
    let mut best: Option<f64> = None;
    for t in tris {
        // Solve p0 + u e1 + v e2 = line + s e_k for (u, v, s).
        let e1: Vec<f64> = (0..3).map(|i| t[1][i] - t[0][i]).collect();
        let e2: Vec<f64> = (0..3).map(|i| t[2][i] - t[0][i]).collect();
        let r: Vec<f64> = (0..3).map(|i| line[i] - t[0][i]).collect();
        let det3 = |a: &[f64], b: &[f64], c: &[f64]| {
            a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0])
        };
        let mut ek = vec![0.0; 3];
        ek[k] = -1.0;
        let d = det3(&e1, &e2, &ek);
        if d.abs() < 1e-15 {
            continue;
        }
        let u = det3(&r, &e2, &ek) / d;
        let v = det3(&e1, &r, &ek) / d;
        let s = det3(&e1, &e2, &r) / d;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && best.is_none_or(|b| s > b) {
            best = Some(s);
        }
    }
    best.map(|s| {
        let mut p = line;
        p[k] += s;
        p
    })
}

/// Where the crate's default hit should land, found here independently:
/// the first surface point on the line through the middle of the box,
/// coming from the positive side of axis `axis`.
fn default_hit(tris: &[measure::Tri], axis: usize) -> [f64; 3] {
    let (lo, hi) = measure::bounds(tris.iter().flatten());
    let mut line = [0.0; 3];
    for i in 0..3 {
        line[i] = 0.5 * (lo[i] + hi[i]);
    }
    line[axis] = hi[axis];
    first_hit_from_positive(tris, axis, line).expect("the line meets the asset")
}

/// With no point given the hit lands where a curved asset faces the
/// viewer, not on its highest point: on the teapot's body (from +z, the
/// thinner horizontal side; it was the lid's knob) and on spot's flank
/// (from +x). Most of the crack length lies around that point, little on the
/// teapot's lid (a few cracks run up over its rim).
#[test]
fn on_a_curved_asset_the_default_hit_lands_where_it_faces_the_viewer() {
    let dir = tempfile::tempdir().unwrap();
    for (name, rel, axis) in [
        ("teapot", "obj/teapot/teapot.obj", 2),
        ("spot", "obj/spot/spot_triangulated.obj", 0),
    ] {
        let Some(input) = common::eval_data(rel) else {
            continue;
        };
        let tris = measure::read_model(&input).triangles(|_| true);
        let (lo, hi) = measure::bounds(tris.iter().flatten());
        let diag = d3(lo, hi);
        let hit = default_hit(&tris, axis);
        let out = dir.path().join(format!("{name}.glb"));
        common::crack_lines(&input, &out, "glass-impact", &[]);
        let lines = measure::read_model(&out).rest_lines("crack_lines");
        let total = measure::crack_length(&lines);
        assert!(total > 0.0, "{name}: no cracks");
        let reach = 0.25 * diag; // the preset's radius_relative
        let near: f64 = lines
            .iter()
            .filter(|s| {
                d3(
                    [
                        0.5 * (s[0][0] + s[1][0]),
                        0.5 * (s[0][1] + s[1][1]),
                        0.5 * (s[0][2] + s[1][2]),
                    ],
                    hit,
                ) < 1.5 * reach
            })
            .map(|s| d3(s[0], s[1]))
            .sum();
        assert!(
            near >= 0.9 * total,
            "{name}: {near} of {total} within 1.5 R of the hit {hit:?}"
        );
        if name == "teapot" {
            let lid: f64 = lines
                .iter()
                .filter(|s| s[0][1].min(s[1][1]) > 2.45)
                .map(|s| d3(s[0], s[1]))
                .sum();
            assert!(lid <= 0.05 * total, "teapot: {lid} of {total} on the lid");
        }
    }
}

/// The surface distance of the independent measure is the sphere's: on a
/// UV sphere of 60 x 30 (as a DCC tool makes it), from a point off the
/// grid, from a fifth of the radius to the far side: within 0.6% of the
/// great circle's on average and 2.5% at worst (1.9% measured, in the
/// slivers of the poles' fans; 7% with 3 points per edge instead of 5);
/// crack pieces along great circles from the point are radial and along
/// circles around it concentric.
#[test]
fn the_measure_s_distance_along_a_sphere_is_the_great_circle() {
    let tris = measure::parse_obj(&shapes::latlong_sphere(60, 30));
    let source = {
        let p = [0.3, 0.5, 0.2];
        let l = d3(p, [0.0; 3]);
        [p[0] / l, p[1] / l, p[2] / l]
    };
    let surface = measure::SurfaceDistance::new(&tris, source, 5);
    let (mut worst, mut sum, mut n): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for t in tris.iter().step_by(5) {
        let c = [0, 1, 2].map(|i| (t[0][i] + t[1][i] + t[2][i]) / 3.0);
        let r = d3(c, [0.0; 3]);
        let cos = (c[0] * source[0] + c[1] * source[1] + c[2] * source[2]) / r;
        let exact = cos.clamp(-1.0, 1.0).acos();
        if exact > 0.2 && exact < 3.0 {
            let e = (surface.at(c) - exact).abs() / exact;
            (worst, sum, n) = (worst.max(e), sum + e, n + 1.0);
        }
    }
    assert!(n > 300.0, "{n} points");
    assert!(
        sum / n < 0.006 && worst < 0.025,
        "relative error: mean {}, worst {worst}",
        sum / n
    );
    // Great circles from the source are radial, circles around it concentric,
    // in pieces of 0.05 (a crack line's segment is a fraction of a cell).
    let e1 = {
        let t = [source[1], -source[0], 0.0];
        let l = d3(t, [0.0; 3]);
        t.map(|x| x / l)
    };
    let e2 = [
        source[1] * e1[2] - source[2] * e1[1],
        source[2] * e1[0] - source[0] * e1[2],
        source[0] * e1[1] - source[1] * e1[0],
    ];
    let at = |a: f64, t: f64| {
        [0, 1, 2].map(|i| a.cos() * source[i] + a.sin() * (t.cos() * e1[i] + t.sin() * e2[i]))
    };
    let step = 0.05;
    let rays: Vec<[[f64; 3]; 2]> = (0..12)
        .flat_map(|k| {
            let t = 0.1 + k as f64 * std::f64::consts::TAU / 12.0;
            (0..32).map(move |i| [i as f64 * step, (i + 1) as f64 * step, t])
        })
        .map(|[a, b, t]| [at(a, t), at(b, t)])
        .collect();
    let rings: Vec<[[f64; 3]; 2]> = [0.3f64, 0.5, 0.7, 0.9]
        .into_iter()
        .flat_map(|a| {
            let n = (std::f64::consts::TAU * a.sin() / step) as usize;
            let dt = std::f64::consts::TAU / n as f64;
            (0..n).map(move |i| [at(a, i as f64 * dt), at(a, (i + 1) as f64 * dt)])
        })
        .collect();
    let radial = measure::impact_stats_on_surface(&rays, &surface, 1.0)["radial_share_0.2_0.8"]
        .as_f64()
        .unwrap();
    let concentric = measure::impact_stats_on_surface(&rings, &surface, 1.0)
        ["concentric_share_0.2_0.8"]
        .as_f64()
        .unwrap();
    assert!(
        radial > 0.98 && concentric > 0.98,
        "great circles {radial} radial, circles {concentric} concentric"
    );
    // The area between two distances is the sphere's zone, 2 pi (cos a - cos b).
    let zone = surface.area_between(0.5, 1.0);
    let exact = std::f64::consts::TAU * (0.5f64.cos() - 1.0f64.cos());
    assert!(
        (zone / exact - 1.0).abs() < 0.02,
        "zone {zone} against {exact}"
    );
}

/// `crackle stats FILE --json --impact HIT --radius R`'s impact section.
fn crackle_stats_impact(file: &std::path::Path, hit: [f64; 3], radius: f64) -> serde_json::Value {
    let (hit, radius) = (
        format!("{},{},{}", hit[0], hit[1], hit[2]),
        radius.to_string(),
    );
    let o = common::run_ok([
        "stats".as_ref(),
        file.as_os_str(),
        "--json".as_ref(),
        "--impact".as_ref(),
        hit.as_ref(),
        "--radius".as_ref(),
        radius.as_ref(),
    ]);
    let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    s["impact"].clone()
}

/// On curved assets the star is measured along the surface: distances from
/// the default hit (the teapot's body from +z, spot's flank from +x) along
/// the input's own surface, so a crack is radial when it runs away from
/// the hit on the surface, and each band's area is the surface's. Seeds
/// 1-3: the radial share from 0.2 to 0.8 R at least 0.65 and no band of
/// 0.05 R over a tenth of the length (within 5%), length per area falling to
/// under half from the hit to 0.6-0.9 R, at most an eighth of it beyond
/// 1.1 R (rays that run on where the load fades: 0.101 on spot's seed 3,
/// under 0.06 with the hoop tension's decay at 0.8 R), and a star of rays
/// across half the radius; `crackle stats --impact` finds the same radial
/// share (within 0.05, along the surface) on seed 1. Over seeds 1-8 the radial share measured 0.70-0.90 on the
/// teapot and 0.69-0.87 on spot, the fullest band 0.076-0.102 and
/// 0.057-0.092; with the hoop tension's decay at 0.8 R and the rings at
/// half the rays' strength it was 0.63-0.86 and 0.63-0.80, bands up to
/// 0.131 (7 of 16 seeds missed 0.65 or 0.10).
#[test]
fn on_curved_assets_the_star_holds_along_the_surface() {
    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for (name, rel, axis) in [
        ("teapot", "obj/teapot/teapot.obj", 2),
        ("spot", "obj/spot/spot_triangulated.obj", 0),
    ] {
        let Some(input) = common::eval_data(rel) else {
            continue;
        };
        let tris = measure::read_model(&input).triangles(|_| true);
        let (lo, hi) = measure::bounds(tris.iter().flatten());
        let hit = default_hit(&tris, axis);
        let surface = measure::SurfaceDistance::new(&tris, hit, 5);
        let radius = 0.25 * d3(lo, hi); // the preset's radius_relative
        for seed in 1..=3 {
            let out = dir.path().join(format!("{name}-{seed}.glb"));
            let seed = seed.to_string();
            common::crack_lines(&input, &out, "glass-impact", &["--seed", &seed]);
            let lines = measure::read_model(&out).rest_lines("crack_lines");
            let s = measure::impact_stats_on_surface(&lines, &surface, radius);
            let get = |k: &str| s[k].as_f64().unwrap();
            let fall = get("per_area_0.6_0.9") / get("per_area_0_0.3");
            let rays = s["radial_crossings_0.5"].as_u64().unwrap();
            let (radial, band) = (get("radial_share_0.2_0.8"), get("max_band_share_0.05"));
            let beyond = get("share_beyond_1.1");
            eprintln!("{name} seed {seed}: radial {radial:.3}, band {band:.3}, fall {fall:.2}, beyond 1.1 R {beyond:.3}, rays {rays}");
            if seed == "1" {
                // `crackle stats --impact` measures along the surface too.
                let stats = crackle_stats_impact(&out, hit, radius);
                let share = stats["radial_share_mid"].as_f64().unwrap();
                if stats["along_surface"] != true || (share - radial).abs() > 0.05 {
                    failures.push(format!(
                        "{name} seed 1: crackle stats {stats}\nagainst radial {radial:.3}"
                    ));
                }
            }
            if radial < 0.65
                || band > 0.105
                || fall > 0.5
                || beyond > 0.125
                || !(6..=14).contains(&rays)
            {
                failures.push(format!(
                    "{name} seed {seed}: radial {radial:.3}, band {band:.3}, fall {fall:.2}, \
                     beyond 1.1 R {beyond:.3}, rays at 0.5 R {rays}"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
