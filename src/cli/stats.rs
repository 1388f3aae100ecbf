//! `crackle stats`: the statistics of a crack pattern in an output file.

use anyhow::{Context, Result};
use crackle::stats::{pattern_stats, PatternInput, ReferenceEdges};
use std::path::Path;

pub fn run(
    file: &Path,
    input: Option<&Path>,
    as_json: bool,
    read: &crackle::io::ReadOptions,
) -> Result<()> {
    let scene =
        crackle::io::read_with(file, read).with_context(|| format!("{}", file.display()))?;
    let pattern = PatternInput::from_scene(&scene);
    if pattern.triangles.is_empty() {
        anyhow::bail!("{}: no triangles to measure", file.display());
    }
    for note in &pattern.notes {
        log::warn!("{}: {note}", file.display());
    }
    let reference = match input {
        Some(path) => {
            let s = crackle::io::read_with(path, read)
                .with_context(|| format!("{}", path.display()))?;
            let p = PatternInput::from_scene(&s);
            Some(ReferenceEdges::new(&p.positions, &p.triangles))
        }
        None => None,
    };
    let s = pattern_stats(&pattern, reference.as_ref());
    if as_json {
        let mut v = serde_json::to_value(&s)?;
        v["file"] = file.display().to_string().into();
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
        "  degree-3 junctions    T {}  Y {}",
        s.t_junctions, s.y_junctions
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
    Ok(())
}
