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

/// Simulation options of the crack command. Lengths and times are in the
/// mesh's own units normalised by its mean edge length, so the same values
/// crack a model in centimetres and in metres alike; stress is dimensionless.
#[derive(clap::Args, Debug)]
pub struct SimArgs {
    /// Toughness: a node fails when its separation eigenvalue (dimensionless stress) exceeds it
    #[arg(long, default_value_t = SimParams::default().toughness)]
    toughness: f64,
    /// Fraction of the residual stress handed to crack tips, in [0, 1]
    #[arg(long, default_value_t = SimParams::default().alpha)]
    alpha: f64,
    /// Constant added to the residual at crack tips (dimensionless stress), for long wrapping cracks
    #[arg(long, default_value_t = SimParams::default().residual_constant)]
    residual_constant: f64,
    /// Shrinkage (dimensionless strain) added per unit of relaxation time
    #[arg(long, default_value_t = SimParams::default().shrink_rate)]
    shrink_rate: f64,
    /// How long the load acts (relaxation time); then the run goes on until nothing fails.
    /// Total shrinkage is shrink-rate x load-time
    #[arg(long, default_value_t = SimParams::default().load_time)]
    load_time: f64,
    /// Seeded variation of the shrink rate between triangles, as a fraction in [0, 1]
    #[arg(long, default_value_t = SimParams::default().noise)]
    noise: f64,
    /// Seed of every random choice (same seed, same input: byte-identical output)
    #[arg(long, default_value_t = SimParams::default().seed)]
    seed: u64,
    /// Relaxation time between crack checks (time unit: one unit-stiffness step over one mean edge)
    #[arg(long, default_value_t = SimParams::default().relax_time)]
    relax_time: f64,
    /// Largest relaxation step; 0: the stable step (a larger value is reduced to it)
    #[arg(long, default_value_t = SimParams::default().relax_dt)]
    relax_dt: f64,
    /// Relaxation steps per round; 0: as many as --relax-time needs
    #[arg(long, default_value_t = SimParams::default().relax_steps)]
    relax_steps: usize,
    /// Most relaxation rounds
    #[arg(long, default_value_t = SimParams::default().max_rounds)]
    max_rounds: usize,
    /// Most crack events per mesh
    #[arg(long, default_value_t = SimParams::default().max_cracks)]
    max_cracks: usize,
    /// Most crack events per round before the load is held for a round; 0: 1% of the nodes, at least 16
    #[arg(long, default_value_t = SimParams::default().max_cracks_per_round)]
    max_cracks_per_round: usize,
    /// Conditioning cap on element gradients, as a multiple of the input mean
    #[arg(long, default_value_t = SimParams::default().clamp_factor)]
    clamp_factor: f64,
    /// Fix the mesh's open boundary instead of leaving it free
    #[arg(long)]
    fixed_boundary: bool,
    /// Fix every node of the primitives with this material or OBJ group name (repeatable)
    #[arg(long, value_name = "NAME")]
    pub fix: Vec<String>,
    /// Do not bond the surface to the body under it (closed shells then shrink instead of cracking)
    #[arg(long)]
    unbonded: bool,
}

impl SimArgs {
    /// The simulation parameters these options give (fixed groups are
    /// resolved per mesh from `fix`).
    pub fn params(&self) -> SimParams {
        SimParams {
            toughness: self.toughness,
            alpha: self.alpha,
            residual_constant: self.residual_constant,
            shrink_rate: self.shrink_rate,
            load_time: self.load_time,
            noise: self.noise,
            seed: self.seed,
            relax_time: self.relax_time,
            relax_dt: self.relax_dt,
            relax_steps: self.relax_steps,
            max_rounds: self.max_rounds,
            max_cracks: self.max_cracks,
            max_cracks_per_round: self.max_cracks_per_round,
            clamp_factor: self.clamp_factor,
            fixed_boundary: self.fixed_boundary,
            bonded: !self.unbonded,
            ..Default::default()
        }
    }
}

/// Options of the crack command.
pub struct CrackArgs<'a> {
    pub input: &'a Path,
    pub output: &'a Path,
    pub report: Option<&'a Path>,
    pub weld: WeldOptions,
    pub params: SimParams,
    /// Material or group names whose nodes are fixed.
    pub fix: Vec<String>,
    pub quiet: bool,
}

/// Groups (primitive indices) of mesh `mesh_index` whose material or OBJ
/// group name is in `names`, and the names that matched.
fn fixed_groups(scene: &Scene, mesh_index: usize, names: &[String]) -> (Vec<u32>, Vec<String>) {
    let mut groups = Vec::new();
    let mut matched = Vec::new();
    for (pi, p) in scene.meshes[mesh_index].primitives.iter().enumerate() {
        let material = p
            .material
            .and_then(|m| scene.materials.get(m))
            .and_then(|m| m.name());
        let group = match &p.geometry {
            Geometry::Triangles(t) => t.group.as_deref(),
            Geometry::Raw(_) => None,
        };
        for n in names {
            if Some(n.as_str()) == material || Some(n.as_str()) == group {
                groups.push(pi as u32);
                matched.push(n.clone());
            }
        }
    }
    (groups, matched)
}

/// Every material and group name in the scene, for error messages.
fn all_names(scene: &Scene) -> Vec<String> {
    let mut out: Vec<String> = scene
        .materials
        .iter()
        .filter_map(|m| m.name().map(str::to_owned))
        .collect();
    for m in &scene.meshes {
        for p in &m.primitives {
            if let Geometry::Triangles(t) = &p.geometry {
                out.extend(t.group.clone());
            }
        }
    }
    out.sort();
    out.dedup();
    out
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
/// `crack_lines` material; `_CRACK_TIME` gives each line vertex the
/// simulation time its segment formed at (for shaders: grow cracks over time).
fn add_crack_lines(
    scene: &mut Scene,
    mesh_index: usize,
    segments: &[[[f64; 3]; 2]],
    times: &[f64],
) {
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
    let mut tdata = Vec::with_capacity(segments.len() * 8);
    let (mut tmin, mut tmax) = (f32::INFINITY, f32::NEG_INFINITY);
    for &t in times.iter().take(segments.len()) {
        let t = t as f32;
        tmin = tmin.min(t);
        tmax = tmax.max(t);
        for _ in 0..2 {
            tdata.extend_from_slice(&t.to_le_bytes());
        }
    }
    let time_acc = (times.len() == segments.len()).then(|| {
        scene.accessors.push(RawAccessor {
            component_type: 5126,
            kind: "SCALAR".into(),
            normalized: false,
            count: segments.len() * 2,
            min: Some(json!([tmin])),
            max: Some(json!([tmax])),
            name: Some("crack_time".into()),
            data: tdata,
        });
        scene.accessors.len() - 1
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
    if let Some(t) = time_acc {
        geo.attributes.insert("_CRACK_TIME".into(), t);
    }
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
    let mut matched: Vec<String> = Vec::new();
    let mut params_of = Vec::new();
    for e in &entries {
        let (groups, m) = fixed_groups(&scene, e.mesh_index, &a.fix);
        matched.extend(m);
        params_of.push(SimParams {
            fixed_groups: groups,
            ..a.params.clone()
        });
    }
    if let Some(missing) = a.fix.iter().find(|n| !matched.contains(n)) {
        return Err(super::UsageError(format!(
            "--fix {missing}: no crackable primitive of {} has that material or group name (names: {})",
            a.input.display(),
            all_names(&scene).join(", ")
        ))
        .into());
    }
    let t = Instant::now();
    let show = !a.quiet && std::io::stderr().is_terminal();
    let mut total = SimReport::default();
    let mut per_mesh = Vec::new();
    for (e, params) in entries.iter_mut().zip(&params_of) {
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
        let r = crackle::sim::run(&mut e.sim, params, &mut obs)
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
        add_crack_lines(&mut scene, *mi, &r.segments, &r.segment_times);
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
