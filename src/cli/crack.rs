//! `crackle crack`: its options (a pipeline plus flags), the progress it
//! shows, and the summary line; the run itself is
//! [`crate::pipeline::crack_file`].

use crate::mesh::WeldOptions;
use crate::pipeline::{Config, Frames, Pipeline};
use crate::sim::SimParams;
use anyhow::Result;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

/// The `--help` group of the simulation's own options, after the look.
const ADVANCED: &str = "Advanced simulation";

/// Simulation options of the crack command: a pipeline (file or preset)
/// plus overrides. Each flag below is short for `--set simulation.KEY=VALUE`
/// (defaults and units: README). Lengths and times are in the mesh's own
/// units normalised by its mean edge length; stress is dimensionless.
#[derive(clap::Args, Debug)]
pub struct SimArgs {
    /// Pipeline file (TOML): mesh selection, stress terms, simulation
    #[arg(long, value_name = "FILE", conflicts_with = "preset")]
    pipeline: Option<PathBuf>,
    /// Built-in pipeline (`crackle presets` lists them)
    #[arg(long, value_name = "NAME")]
    preset: Option<String>,
    /// Override a pipeline key (repeatable), e.g. `--set simulation.toughness=3`; a stress entry's key by its index, e.g. `--preset glass-impact --set stress.0.radius_relative=0.1` (`crackle presets NAME` shows a preset's entries)
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// The artist's controls (`Look` in `--help`).
    #[command(flatten)]
    look: super::look::LookArgs,
    /// Cell size of the pattern in scene units (replaces the pipeline's cell size)
    #[arg(
        long,
        value_name = "SIZE",
        conflicts_with = "cell_size_relative",
        help_heading = "Look"
    )]
    cell_size: Option<f64>,
    /// Cell size as a fraction of each mesh's bounding-box diagonal (replaces the pipeline's cell size)
    #[arg(long, value_name = "FRACTION", help_heading = "Look")]
    cell_size_relative: Option<f64>,
    #[arg(long, value_name = "N", help_heading = ADVANCED, help = with_default("Most triangles of the remeshed simulation surface", SimParams::default().max_triangles))]
    max_triangles: Option<usize>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Toughness: a node fails when its separation eigenvalue exceeds it", SimParams::default().toughness))]
    toughness: Option<f64>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Fraction of the residual stress handed to crack tips, in [0, 1]", SimParams::default().alpha))]
    alpha: Option<f64>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Constant added to the residual at crack tips, for long joined cracks", SimParams::default().residual_constant))]
    residual_constant: Option<f64>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Uniform shrinkage added per unit of relaxation time", SimParams::default().shrink_rate))]
    shrink_rate: Option<f64>,
    #[arg(long, help_heading = ADVANCED, help = with_default("How long the load acts; then the run goes on until nothing fails", SimParams::default().load_time))]
    load_time: Option<f64>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Seeded variation of the load between triangles, in [0, 1]", SimParams::default().noise))]
    noise: Option<f64>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Seed of every random choice", SimParams::default().seed))]
    seed: Option<u64>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Relaxation time between crack checks", SimParams::default().relax_time))]
    relax_time: Option<f64>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Largest relaxation step; 0: the stable step", SimParams::default().relax_dt))]
    relax_dt: Option<f64>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Relaxation steps per round; 0: as many as --relax-time needs", SimParams::default().relax_steps))]
    relax_steps: Option<usize>,
    #[arg(long, value_name = "NAME", help_heading = ADVANCED, help = with_default("Relaxation integrator: local-euler, euler, paper-euler (needs --relax-dt), backward-euler, equilibrium, rkl, or auto (local-euler unless the mesh is stiff, then backward-euler)", SimParams::default().integrator.name()))]
    integrator: Option<String>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Relative residual of each backward-Euler solve", SimParams::default().tolerance))]
    tolerance: Option<f64>,
    #[arg(long, value_name = "RINGS", help_heading = ADVANCED, help = with_default("Finishing passes relax only this many rings around their new cracks; 0: the whole mesh", SimParams::default().finish_rings))]
    finish_rings: Option<usize>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Most relaxation rounds", SimParams::default().max_rounds))]
    max_rounds: Option<usize>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Most crack events per mesh", SimParams::default().max_cracks))]
    max_cracks: Option<usize>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Most crack events per round before the load is held; 0: 1% of the nodes", SimParams::default().max_cracks_per_round))]
    max_cracks_per_round: Option<usize>,
    #[arg(long, help_heading = ADVANCED, help = with_default("Conditioning cap on element gradients, times the input mean", SimParams::default().clamp_factor))]
    clamp_factor: Option<f64>,
    /// Fix the mesh's open boundary instead of leaving it free
    #[arg(long, help_heading = ADVANCED)]
    fixed_boundary: bool,
    /// Fix every node of the primitives with this material or OBJ group name (repeatable)
    #[arg(long, help_heading = ADVANCED, value_name = "NAME")]
    fix: Vec<String>,
    /// Do not bond the surface to the body under it (closed shells then shrink instead of cracking)
    #[arg(long, help_heading = ADVANCED)]
    unbonded: bool,
    /// Write each piece the cracks cut a mesh into as its own node (same as --set post.split_islands=true)
    #[arg(long, help_heading = "Look")]
    split_islands: bool,
}

/// The flags that set the simulation key of their name as they are, listed
/// once for [`SimArgs::apply_flags`] and [`SimArgs::overrides`].
macro_rules! plain_sim_flags {
    ($m:ident) => {
        $m!(max_triangles);
        $m!(toughness);
        $m!(alpha);
        $m!(residual_constant);
        $m!(shrink_rate);
        $m!(load_time);
        $m!(noise);
        $m!(seed);
        $m!(relax_time);
        $m!(relax_dt);
        $m!(relax_steps);
        $m!(tolerance);
        $m!(finish_rings);
        $m!(max_rounds);
        $m!(max_cracks);
        $m!(max_cracks_per_round);
        $m!(clamp_factor);
    };
}

impl SimArgs {
    /// The folder of the pipeline file (relative mask images are found
    /// there); `None` for a preset or the defaults.
    pub fn pipeline_dir(&self) -> Option<PathBuf> {
        self.pipeline.as_ref().map(|p| {
            p.parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."))
                .to_path_buf()
        })
    }

    /// The pipeline these options give: the file or preset (or the
    /// defaults), then the flags, then `--set`, all checked.
    pub fn pipeline(&self) -> Result<Pipeline> {
        self.pipeline_with(self.pipeline.as_deref(), self.preset.as_deref(), &[])
    }

    /// The `--pipeline` file, if given.
    pub fn pipeline_file(&self) -> Option<&Path> {
        self.pipeline.as_deref()
    }

    /// The `--preset` name, if given.
    pub fn preset_name(&self) -> Option<&str> {
        self.preset.as_deref()
    }

    /// The look flags as command-line words.
    pub fn look_flags(&self) -> Vec<String> {
        self.look.flags()
    }

    /// The `--fix` names.
    pub fn fix_names(&self) -> &[String] {
        &self.fix
    }

    /// Whether `--pipeline` or `--preset` was given.
    pub fn has_choice(&self) -> bool {
        self.pipeline.is_some() || self.preset.is_some()
    }

    /// The pipeline of `file` or `preset` (or the defaults) with these
    /// options' flags and `--set` on top.
    pub fn pipeline_with(
        &self,
        file: Option<&Path>,
        preset: Option<&str>,
        extra: &[String],
    ) -> Result<Pipeline> {
        // The rules' keys and `--set` go through the pipeline's TOML; the
        // flags then set their typed fields, except where a `--set` names
        // the same key (it comes last on the command line and wins).
        let usage = |e: crate::pipeline::PipelineError| super::UsageError(e.to_string());
        let text = match (file, preset) {
            (Some(path), _) => {
                crate::io::paths::read_config_text(path, "pipeline").map_err(|e| {
                    super::UsageError(format!("{}: cannot read the pipeline: {e}", path.display()))
                })?
            }
            _ => String::new(),
        };
        let parse = |sets: &[String]| match (file, preset) {
            (Some(path), _) => Pipeline::parse(&text, &path.display().to_string(), sets),
            (None, Some(name)) => Pipeline::preset(name, sets),
            (None, None) => Pipeline::parse("", "defaults", sets),
        };
        // The look flags set the entries of the pipeline as given.
        let mut sets: Vec<String> = extra.to_vec();
        let base = parse(&sets).map_err(usage)?;
        sets.extend(self.look.sets(&base)?);
        sets.extend(self.sets.iter().cloned());
        let mut p = parse(&sets).map_err(usage)?;
        self.apply_flags(&mut p)?;
        p.check_all().map_err(usage)?;
        p.select.fix.extend(self.fix.iter().cloned());
        Ok(p)
    }

    /// Whether a `--set` names `key` (or its `_relative` alternative).
    fn set_names(&self, key: &str) -> bool {
        let alt = match key.strip_suffix("_relative") {
            Some(base) => base.to_string(),
            None => format!("{key}_relative"),
        };
        self.sets.iter().any(|s| {
            let k = s.split_once('=').map_or(s.as_str(), |(k, _)| k).trim();
            k == key || k == alt
        })
    }

    /// Set the typed field of every flag given, unless a `--set` names it.
    fn apply_flags(&self, p: &mut Pipeline) -> Result<(), super::UsageError> {
        macro_rules! flag {
            ($field:ident) => {
                if let Some(v) = self.$field.clone() {
                    if !self.set_names(concat!("simulation.", stringify!($field))) {
                        p.simulation.$field = v;
                    }
                }
            };
        }
        plain_sim_flags!(flag);
        let s = &mut p.simulation;
        if let Some(x) = self.cell_size {
            if !self.set_names("simulation.cell_size") {
                (s.cell_size, s.cell_size_relative) = (Some(x), None);
            }
        }
        if let Some(x) = self.cell_size_relative {
            if !self.set_names("simulation.cell_size_relative") {
                (s.cell_size, s.cell_size_relative) = (None, Some(x));
            }
        }
        if let Some(name) = &self.integrator {
            if !self.set_names("simulation.integrator") {
                s.integrator = name.parse().map_err(|e| {
                    super::UsageError(format!("{}: simulation.integrator: {e}", p.source_name))
                })?;
            }
        }
        if self.unbonded && !self.set_names("simulation.bonded") {
            p.simulation.bonded = false;
        }
        if self.fixed_boundary && !self.set_names("select.fixed_boundary") {
            p.select.fixed_boundary = true;
        }
        if self.split_islands && !self.set_names("post.split_islands") {
            p.post.split_islands = true;
        }
        Ok(())
    }

    /// Every override as a `--set KEY=VALUE` string: `extra` first, then
    /// the flags, then `--set`.
    pub fn overrides(&self, extra: &[String]) -> Vec<String> {
        let mut sets: Vec<String> = extra.to_vec();
        let mut set = |k: &str, v: Option<String>| {
            if let Some(v) = v {
                sets.push(format!("simulation.{k}={v}"));
            }
        };
        set("cell_size", self.cell_size.map(|x| format!("{x:?}")));
        set(
            "cell_size_relative",
            self.cell_size_relative.map(|x| format!("{x:?}")),
        );
        macro_rules! flag {
            ($field:ident) => {
                set(stringify!($field), self.$field.map(|x| format!("{x:?}")));
            };
        }
        plain_sim_flags!(flag);
        set("integrator", self.integrator.clone());
        set("bonded", self.unbonded.then(|| "false".to_string()));
        if self.fixed_boundary {
            sets.push("select.fixed_boundary=true".into());
        }
        if self.split_islands {
            sets.push("post.split_islands=true".into());
        }
        sets.extend(self.sets.iter().cloned());
        sets
    }
}

/// A flag's help with the library's default, so the help never retypes it.
fn with_default(text: &str, default: impl std::fmt::Display) -> String {
    format!("{text} [default: {default}]")
}

/// Options of the crack command.
pub struct CrackArgs<'a> {
    pub input: &'a Path,
    pub output: &'a Path,
    pub report: Option<&'a Path>,
    pub weld: WeldOptions,
    pub pipeline: Pipeline,
    /// Folder of the pipeline file, for relative mask images.
    pub pipeline_dir: Option<PathBuf>,
    pub quiet: bool,
    /// `--frames N DIR`.
    pub frames: Option<Frames>,
    /// How the input is read.
    pub read: crate::io::ReadOptions,
}

/// The progress a run shows: a bar per simulated mesh on a terminal and a
/// log line per round (`-v`).
struct Progress {
    /// Whether to draw bars.
    show: bool,
    bar: Option<indicatif::ProgressBar>,
}

impl crate::pipeline::Observer for Progress {
    fn simulate_start(&mut self, mesh: &str, max_rounds: usize) {
        self.bar = self.show.then(|| {
            let b = indicatif::ProgressBar::new(max_rounds as u64);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{prefix} [{bar:30}] round {pos}/{len} {msg}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b.set_prefix(mesh.to_string());
            b
        });
    }

    fn round(
        &mut self,
        mesh: &str,
        round: usize,
        max_rounds: usize,
        cracks: usize,
        relax_steps: usize,
    ) {
        log::info!("{mesh}: round {round}: {cracks} cracks, {relax_steps} relaxation steps");
        if let Some(b) = &self.bar {
            b.set_length(max_rounds as u64);
            b.set_position(round as u64);
            b.set_message(format!("{cracks} cracks"));
        }
    }

    fn simulate_end(&mut self, _mesh: &str) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
    }
}

/// `crackle crack`: read, crack and write one asset, write the report,
/// print the summary line.
pub fn run(a: CrackArgs) -> Result<()> {
    if let Some(p) = a.report {
        for (what, other) in [("input", a.input), ("output", a.output)] {
            if crate::io::write::same_file(p, other) {
                anyhow::bail!(
                    "{}: the report would overwrite the {what}; name another file",
                    p.display()
                );
            }
        }
    }
    let config = Config {
        pipeline: a.pipeline,
        weld: a.weld,
        asset: a.input.to_path_buf(),
        frames: a.frames,
        output: a.output.to_path_buf(),
        read: a.read,
    };
    let mut progress = Progress {
        show: !a.quiet && std::io::stderr().is_terminal(),
        bar: None,
    };
    let report =
        crate::pipeline::crack_file(config, a.pipeline_dir.as_deref(), false, &mut progress)?;
    if let Some(p) = a.report {
        crate::io::write::write_atomic(p, &serde_json::to_vec_pretty(&report)?)
            .map_err(|e| anyhow::anyhow!("{}: cannot write the report: {e}", p.display()))?;
    }
    if !a.quiet {
        let run = &report.run;
        if let Some(area) = run.torn_area() {
            let pieces = match run.pieces().unwrap_or(1) {
                1 => "1 piece (not torn through)".to_string(),
                n => format!("{n} pieces"),
            };
            eprintln!(
                "{} -> {}: torn into {pieces}, torn faces' area {:.4}, {} -> {} triangles",
                a.input.display(),
                a.output.display(),
                area + 0.0, // no "-0.0000"
                report.mesh_triangles.before,
                report.mesh_triangles.after,
            );
        } else {
            let pieces = run
                .pieces()
                .map(|n| format!(", {n} pieces"))
                .unwrap_or_default();
            eprintln!(
                "{} -> {}: {} cracks, crack length {:.3}{pieces}, {} -> {} triangles (simulated on {}), {} relaxation steps",
                a.input.display(),
                a.output.display(),
                run.cracks,
                run.crack_length,
                report.mesh_triangles.before,
                report.mesh_triangles.after,
                run.triangles.after,
                run.relaxation_steps
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Args {
        #[command(flatten)]
        sim: SimArgs,
    }

    fn args(a: &[&str]) -> SimArgs {
        let mut v = vec!["crackle"];
        v.extend_from_slice(a);
        Args::try_parse_from(v).expect("valid arguments").sim
    }

    /// The old way, for comparison: every flag as a `--set` string.
    fn through_strings(s: &SimArgs, preset: Option<&str>) -> Pipeline {
        let sets = s.overrides(&[]);
        let mut p = match preset {
            Some(name) => Pipeline::preset(name, &sets),
            None => Pipeline::parse("", "defaults", &sets),
        }
        .expect("valid");
        p.select.fix.extend(s.fix_names().iter().cloned());
        p
    }

    #[test]
    fn flags_set_the_typed_fields() {
        let s = args(&[
            "--toughness",
            "3",
            "--integrator",
            "rkl",
            "--cell-size",
            "0.5",
            "--seed",
            "9",
            "--unbonded",
            "--fixed-boundary",
            "--split-islands",
        ]);
        let p = s.pipeline().expect("valid");
        assert_eq!(p.simulation.toughness, 3.0);
        assert_eq!(p.simulation.integrator, crate::sim::Integrator::Rkl);
        assert_eq!(p.simulation.cell_size, Some(0.5));
        assert_eq!(p.simulation.cell_size_relative, None);
        assert_eq!(p.simulation.seed, 9);
        assert!(!p.simulation.bonded && p.select.fixed_boundary && p.post.split_islands);
        // The same pipeline as the flags written as `--set` strings.
        assert_eq!(p, through_strings(&s, None));
    }

    #[test]
    fn a_set_of_the_same_key_wins_over_the_flag() {
        let s = args(&[
            "--preset",
            "glaze",
            "--toughness",
            "3",
            "--set",
            "simulation.toughness=4",
            "--cell-size",
            "0.5",
            "--set",
            "simulation.cell_size_relative=0.1",
        ]);
        let p = s.pipeline().expect("valid");
        assert_eq!(p.simulation.toughness, 4.0);
        assert_eq!(p.simulation.cell_size, None);
        assert_eq!(p.simulation.cell_size_relative, Some(0.1));
        assert_eq!(p, through_strings(&s, Some("glaze")));
    }

    #[test]
    fn a_bad_flag_value_is_refused_with_its_key() {
        let e = args(&["--alpha", "1.5"]).pipeline().expect_err("alpha > 1");
        assert!(e.to_string().contains("alpha"), "{e}");
        let e = args(&["--integrator", "rk4"])
            .pipeline()
            .expect_err("no rk4");
        assert!(e.to_string().contains("rk4"), "{e}");
        for i in ["local-euler", "euler", "backward-euler", "rkl", "auto"] {
            let p = args(&["--integrator", i]).pipeline().expect("known");
            assert_eq!(p.simulation.integrator.name(), i);
        }
    }
}
