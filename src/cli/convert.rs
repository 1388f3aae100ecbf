//! `crackle convert`: read and write, the input's primitives as read; with
//! `--weld`, the round trip every cracking command builds on (read, weld
//! and repair, write back).

use crate::bridge::{build_sim_meshes, write_back};
use crate::mesh::WeldOptions;
use anyhow::Result;
use serde_json::json;
use std::path::Path;
use std::time::Instant;

pub fn run(
    input: &Path,
    output: &Path,
    weld: Option<&WeldOptions>,
    as_json: bool,
    quiet: bool,
    read: &crate::io::ReadOptions,
) -> Result<()> {
    super::check_output_format(output)?;
    let t0 = Instant::now();
    let mut scene = crate::pipeline::read_crackable(input, read)?;
    let t_read = t0.elapsed();
    let t1 = Instant::now();
    let (entries, skipped) = match weld {
        Some(weld) => build_sim_meshes(&scene, weld),
        None => Default::default(),
    };
    for s in &skipped {
        log::warn!(
            "{}: {} is written unchanged: {}",
            input.display(),
            s.label,
            s.reason
        );
    }
    for e in &entries {
        if e.report.degenerate_triangles_dropped > 0 {
            log::warn!(
                "{}: {}: dropped {} degenerate triangles",
                input.display(),
                e.label,
                e.report.degenerate_triangles_dropped
            );
        }
        let r = &e.report;
        if r.non_manifold_edges + r.non_manifold_vertices + r.inconsistent_orientation_edges > 0 {
            log::info!(
                "{}: {}: made manifold by splitting ({} non-manifold edges, {} non-manifold vertices, {} inconsistent edges)",
                input.display(),
                e.label,
                r.non_manifold_edges,
                r.non_manifold_vertices,
                r.inconsistent_orientation_edges
            );
        }
        write_back(&mut scene, e);
    }
    let t_weld = t1.elapsed();
    let t2 = Instant::now();
    let summary = crate::pipeline::write_output(&scene, output, false)?;
    let t_write = t2.elapsed();
    log::info!(
        "read {:.3} s, weld {:.3} s, write {:.3} s",
        t_read.as_secs_f64(),
        t_weld.as_secs_f64(),
        t_write.as_secs_f64()
    );
    if as_json {
        let report = json!({
            "input": input.display().to_string(),
            "output": output.display().to_string(),
            "files": summary.files,
            "bytes": summary.bytes,
            "triangles": summary.triangles,
            "welded": weld.is_some(),
            "meshes": entries.iter().map(|e| json!({"index": e.mesh_index, "label": e.label, "defects": e.report})).collect::<Vec<_>>(),
            "skipped": skipped.iter().map(|s| json!({"index": s.mesh_index, "label": s.label, "reason": s.reason})).collect::<Vec<_>>(),
            "warnings": scene.warnings,
            "seconds": {"read": t_read.as_secs_f64(), "weld": t_weld.as_secs_f64(), "write": t_write.as_secs_f64()},
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else if !quiet {
        let in_size = std::fs::metadata(input).map(|m| m.len()).unwrap_or(0);
        println!(
            "{} ({}) -> {} ({}), {} triangles",
            input.display(),
            human_bytes(in_size),
            output.display(),
            human_bytes(summary.bytes),
            summary.triangles
        );
    }
    Ok(())
}

fn human_bytes(b: u64) -> String {
    if b >= 1 << 20 {
        format!("{:.1} MB", b as f64 / (1u64 << 20) as f64)
    } else if b >= 1 << 10 {
        format!("{:.1} kB", b as f64 / 1024.0)
    } else {
        format!("{b} B")
    }
}
