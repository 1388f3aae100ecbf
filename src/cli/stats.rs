//! `crackle stats`: the statistics of a crack pattern in an output file.

use crate::stats::{impact_stats, pattern_stats, ImpactStats, PatternInput, ReferenceEdges};
use anyhow::{Context, Result};
use std::path::Path;

pub fn run(
    file: &Path,
    input: Option<&Path>,
    as_json: bool,
    impact: Option<([f64; 3], f64)>,
    read: &crate::io::ReadOptions,
) -> Result<()> {
    if let Some((_, r)) = impact {
        if !(r.is_finite() && r > 0.0) {
            anyhow::bail!("--radius must be a positive number, got {r}");
        }
    }
    let scene = crate::io::read_with(file, read).with_context(|| format!("{}", file.display()))?;
    let pattern = PatternInput::from_scene(&scene);
    if pattern.triangles.is_empty() {
        anyhow::bail!("{}: no triangles to measure", file.display());
    }
    for note in &pattern.notes {
        log::warn!("{}: {note}", file.display());
    }
    let reference = match input {
        Some(path) => {
            let s =
                crate::io::read_with(path, read).with_context(|| format!("{}", path.display()))?;
            let p = PatternInput::from_scene(&s);
            Some(ReferenceEdges::new(&p.positions, &p.triangles))
        }
        None => None,
    };
    let s = pattern_stats(&pattern, reference.as_ref());
    let hit = impact.map(|(c, r)| impact_stats(&pattern, c, r));
    if as_json {
        let mut v = serde_json::to_value(&s)?;
        v["file"] = file.display().to_string().into();
        if let Some(h) = &hit {
            v["impact"] = serde_json::to_value(h)?;
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    let q = s.cell_area_quantiles;
    println!("{}", file.display());
    println!("  area                  {:.6}", s.area);
    println!(
        "  crack length          {:.6} ({:.4} per area, spacing 2A/L {:.6})",
        s.crack_length, s.crack_length_per_area, s.spacing
    );
    println!(
        "  cells                 {} (mean diameter {:.6})",
        s.cells, s.mean_cell_diameter
    );
    println!(
        "  cell area quantiles   10% {:.4e}  25% {:.4e}  50% {:.4e}  75% {:.4e}  90% {:.4e}",
        q[0], q[1], q[2], q[3], q[4]
    );
    println!(
        "  junctions by degree   1: {}  2: {}  3: {}  4+: {}  (most at one vertex: {})",
        s.degree[0], s.degree[1], s.degree[2], s.degree[3], s.max_degree
    );
    println!("  open tips             {}", s.dangling_tips);
    println!(
        "  degree-3 junctions    T {} ({:.2})  Y {} ({:.2})",
        s.t_junctions, s.t_share, s.y_junctions, s.y_share
    );
    println!(
        "  cell sides            {:.2} on average over {} cells off the border",
        s.mean_cell_sides, s.sided_cells
    );
    let hist = |v: &[usize]| {
        v.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    println!(
        "  junction angles       {} (15-degree bins over 0..180)",
        hist(&s.junction_angles)
    );
    let o: Vec<String> = s.orientation.iter().map(|x| format!("{:.3}", x)).collect();
    println!(
        "  orientation           {} (30-degree bins, share of length)",
        o.join(" ")
    );
    println!(
        "  paired parallel       {:.4} of the length (closer than {:.6})",
        s.paired, s.paired_distance
    );
    if let Some(a) = s.along_reference_edges {
        println!("  along input edges     {:.4} of the length", a);
    }
    if let Some(h) = &hit {
        print_impact(h);
    }
    Ok(())
}

fn print_impact(h: &ImpactStats) {
    let c = h.center;
    println!(
        "  impact at             {} {} {} (radius {})",
        c[0], c[1], c[2], h.radius
    );
    println!(
        "  distances             {}",
        if h.along_surface {
            "along the surface"
        } else {
            "straight (the surface does not carry them)"
        }
    );
    println!(
        "  radial share          {:.3} of the length from 0.2 to 0.8 radii",
        h.radial_share_mid
    );
    println!(
        "  crossing half radius  {} crack segments, {} of them radial",
        h.crossings_half, h.radial_crossings_half
    );
    println!("  by distance (radii)   radial  concentric  all  per area");
    let w = crate::stats::impact::BAND;
    for i in 0..h.total.len() {
        println!(
            "    {:.1}-{:.1}            {:.4}  {:.4}  {:.4}  {:.4}",
            i as f64 * w,
            (i + 1) as f64 * w,
            h.radial[i],
            h.concentric[i],
            h.total[i],
            h.per_area[i]
        );
    }
    println!("    beyond              {:.4}", h.beyond);
    if h.unreached > 0.0 {
        println!("    out of reach        {:.4}", h.unreached);
    }
}

/// `X,Y,Z` as a point.
pub fn parse_point(text: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = text
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--impact '{text}': give three numbers X,Y,Z"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|a| a.is_finite()) => Ok([x, y, z]),
        _ => anyhow::bail!("--impact '{text}': give three finite numbers X,Y,Z"),
    }
}
