//! `crackle crack`: read, weld, grow cracks, write the cracked scene with the
//! crack network as a LINES primitive, and report.

use anyhow::Result;
use crackle::bridge::{build_sim_meshes, write_back};
use crackle::mesh::WeldOptions;
use crackle::scene::{Geometry, Material, Primitive, RawAccessor, RawGeometry, Scene};
use crackle::sim::{SimParams, SimReport};
use serde_json::json;
use std::io::IsTerminal;
use std::path::Path;
use std::time::Instant;

/// Options of the crack command.
pub struct CrackArgs<'a> {
    pub input: &'a Path,
    pub output: &'a Path,
    pub report: Option<&'a Path>,
    pub weld: WeldOptions,
    pub params: SimParams,
    pub quiet: bool,
}

struct Bar(Option<indicatif::ProgressBar>);

impl crackle::sim::Observer for Bar {
    fn round(&mut self, round: usize, max_rounds: usize, cracks: usize) {
        if let Some(b) = &self.0 {
            b.set_length(max_rounds as u64);
            b.set_position(round as u64);
            b.set_message(format!("{cracks} cracks"));
        }
    }
}

/// Add the crack segments of mesh `mesh_index` as a LINES primitive with the
/// `crack_lines` material.
fn add_crack_lines(scene: &mut Scene, mesh_index: usize, segments: &[[[f64; 3]; 2]]) {
    if segments.is_empty() {
        return;
    }
    let mut data = Vec::with_capacity(segments.len() * 24);
    let mut min = [f32::INFINITY; 3];
    let mut max = [f32::NEG_INFINITY; 3];
    for seg in segments {
        for p in seg {
            for k in 0..3 {
                let x = p[k] as f32;
                min[k] = min[k].min(x);
                max[k] = max[k].max(x);
                data.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    let acc = scene.accessors.len();
    scene.accessors.push(RawAccessor {
        component_type: 5126,
        kind: "VEC3".into(),
        normalized: false,
        count: segments.len() * 2,
        min: Some(json!(min)),
        max: Some(json!(max)),
        name: Some("crack_lines".into()),
        data,
    });
    let material = match scene
        .materials
        .iter()
        .position(|m| m.name() == Some("crack_lines"))
    {
        Some(m) => m,
        None => {
            let m = json!({"name": "crack_lines", "pbrMetallicRoughness": {"baseColorFactor": [0.02, 0.02, 0.02, 1.0], "metallicFactor": 0.0}});
            scene.materials.push(Material {
                json: m.as_object().cloned().unwrap_or_default(),
            });
            scene.materials.len() - 1
        }
    };
    let mut geo = RawGeometry {
        mode: crackle::scene::mode::LINES,
        ..Default::default()
    };
    geo.attributes.insert("POSITION".into(), acc);
    scene.meshes[mesh_index].primitives.push(Primitive {
        material: Some(material),
        geometry: Geometry::Raw(geo),
        rest: Default::default(),
    });
}

pub fn run(a: CrackArgs) -> Result<()> {
    a.params
        .validate()
        .map_err(|e| super::UsageError(format!("invalid parameter: {e}")))?;
    let mut stages = Vec::new();
    let t = Instant::now();
    let mut scene = super::read_crackable(a.input)?;
    stages.push(json!({"name": "read", "seconds": t.elapsed().as_secs_f64()}));
    let t = Instant::now();
    let (mut entries, skipped) = build_sim_meshes(&scene, &a.weld);
    for s in &skipped {
        log::warn!(
            "{}: {} is written unchanged: {}",
            a.input.display(),
            s.label,
            s.reason
        );
    }
    stages.push(json!({"name": "weld", "seconds": t.elapsed().as_secs_f64()}));
    let t = Instant::now();
    let show = !a.quiet && std::io::stderr().is_terminal();
    let mut total = SimReport::default();
    let mut per_mesh = Vec::new();
    for e in entries.iter_mut() {
        let bar = show.then(|| {
            let b = indicatif::ProgressBar::new(a.params.max_rounds as u64);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{prefix} [{bar:30}] round {pos}/{len} {msg}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b.set_prefix(e.label.clone());
            b
        });
        let mut obs = Bar(bar);
        let r = crackle::sim::run(&mut e.sim, &a.params, &mut obs)
            .map_err(|err| anyhow::anyhow!("{}: {}: {err}", a.input.display(), e.label))?;
        if let Some(b) = obs.0 {
            b.finish_and_clear();
        }
        total.cracks += r.cracks;
        total.crack_length += r.crack_length;
        total.rounds = total.rounds.max(r.rounds);
        total.relax_steps += r.relax_steps;
        for k in 0..2 {
            total.triangles[k] += r.triangles[k];
            total.nodes[k] += r.nodes[k];
            total.energy[k] += r.energy[k];
        }
        per_mesh.push((e.mesh_index, r));
    }
    stages.push(json!({"name": "simulate", "seconds": t.elapsed().as_secs_f64()}));
    let t = Instant::now();
    for e in &entries {
        write_back(&mut scene, e);
    }
    for (mi, r) in &per_mesh {
        add_crack_lines(&mut scene, *mi, &r.segments);
    }
    let summary = super::write_output(&scene, a.output)?;
    stages.push(json!({"name": "write", "seconds": t.elapsed().as_secs_f64()}));
    let report = json!({
        "input": a.input.display().to_string(),
        "output": a.output.display().to_string(),
        "files": summary.files,
        "cracks": total.cracks,
        "crack_length": total.crack_length,
        "triangles": {"before": total.triangles[0], "after": total.triangles[1]},
        "nodes": {"before": total.nodes[0], "after": total.nodes[1]},
        "relaxation_steps": total.relax_steps,
        "rounds": total.rounds,
        "energy": {"start": total.energy[0], "end": total.energy[1]},
        "stages": stages,
        "meshes": per_mesh.iter().map(|(mi, r)| json!({"index": mi, "report": r})).collect::<Vec<_>>(),
        "warnings": scene.warnings,
    });
    if let Some(p) = a.report {
        std::fs::write(p, serde_json::to_vec_pretty(&report)?)
            .map_err(|e| anyhow::anyhow!("{}: cannot write the report: {e}", p.display()))?;
    }
    if !a.quiet {
        eprintln!(
            "{} -> {}: {} cracks, crack length {:.3}, {} -> {} triangles, {} relaxation steps",
            a.input.display(),
            a.output.display(),
            total.cracks,
            total.crack_length,
            total.triangles[0],
            total.triangles[1],
            total.relax_steps
        );
    }
    Ok(())
}
