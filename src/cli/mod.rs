//! Commands of the `crackle` binary: parses arguments, runs a command, maps
//! errors to exit codes (0 ok, 1 processing failed, 2 bad usage or
//! configuration). Inside the library (behind the `cli` feature) so the
//! commands reach its machinery without making it public.

mod batch;
mod convert;
mod crack;
mod diff;
mod info;
pub mod logger;
mod look;
mod stats;
mod study;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

/// The `crackle` command line on the process's arguments: the exit code.
pub fn main() -> ExitCode {
    let args = match Cli::try_parse() {
        Ok(a) => a,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    logger::init(args.verbose, args.quiet);
    match run(args) {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(exit_code(&e))
        }
    }
}

/// Grow surface crack patterns on 3D meshes and write cracked glTF.
///
/// Exit codes: 0 success, 1 processing failed, 2 bad usage or configuration.
#[derive(Parser, Debug)]
#[command(name = "crackle", version, about, long_about = None)]
pub struct Cli {
    /// More log output on stderr (-v: info, -vv: debug).
    #[arg(short, long, action = clap::ArgAction::Count, global = true, conflicts_with = "quiet")]
    pub verbose: u8,
    /// Only errors on stderr.
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// Most memory one input's model file, decoded glTF data, external
    /// buffers, objects or primitives (16K each), simulation surfaces (1K a
    /// triangle), or one decoded image (a texture baked over, a mask) may
    /// take (bytes, or with K, M, G); an input asking for more is refused
    /// before allocating. Each file's decoded accessors also stay within 64
    /// times its real size, at least 1G.
    #[arg(long, global = true, value_name = "SIZE", default_value = "8G", value_parser = parse_size)]
    pub max_memory: u64,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
#[allow(clippy::large_enum_variant)] // parsed once; boxing would only obscure clap's derive
enum Command {
    /// List the built-in pipelines (use one with `crack --preset NAME`)
    Presets {
        /// Print the named preset's TOML instead
        #[arg(value_name = "NAME")]
        show: Option<String>,
    },
    /// Print a scene summary and a mesh defect report
    Info {
        /// Input mesh (.obj, .gltf, .glb)
        input: PathBuf,
        /// Print the report as JSON on stdout
        #[arg(long)]
        json: bool,
        /// Weld tolerance, relative to each mesh's bounding-box diagonal
        #[arg(long, value_name = "REL", default_value_t = crate::mesh::WeldOptions::default().relative_tolerance)]
        weld_tolerance: f64,
    },
    /// Grow cracks on a mesh and write cracked glTF
    Crack {
        /// Input mesh (.obj, .gltf, .glb)
        input: PathBuf,
        /// Output file: .gltf or .glb
        output: PathBuf,
        /// Write a JSON run report to this file
        #[arg(long, value_name = "PATH")]
        report: Option<PathBuf>,
        /// Weld tolerance, relative to each mesh's bounding-box diagonal
        #[arg(long, value_name = "REL", default_value_t = crate::mesh::WeldOptions::default().relative_tolerance)]
        weld_tolerance: f64,
        /// Also write N frames of the crack state through the run into DIR (a time-lapse; runs the simulation twice)
        #[arg(long, num_args = 2, value_names = ["N", "DIR"])]
        frames: Option<Vec<String>>,
        #[command(flatten)]
        sim: crack::SimArgs,
    },
    /// Error against run time of every relaxation integrator on one mesh (the largest of the input) and pipeline
    Study {
        /// Input mesh (.obj, .gltf, .glb)
        input: PathBuf,
        /// Write study.csv, study.json, study.svg and study.png (error against seconds) into this folder
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Relaxation rounds (of relax_time) every integrator runs
        #[arg(long, default_value_t = 4)]
        rounds: usize,
        /// Time each relaxation this many times and keep the least (the results are identical)
        #[arg(long, default_value_t = 1, value_name = "N")]
        repeat: usize,
        /// Also compare whole simulations with cracking (crack count, length, cells, junction angles)
        #[arg(long)]
        full: bool,
        /// Weld tolerance, relative to each mesh's bounding-box diagonal
        #[arg(long, value_name = "REL", default_value_t = crate::mesh::WeldOptions::default().relative_tolerance)]
        weld_tolerance: f64,
        #[command(flatten)]
        sim: crack::SimArgs,
    },
    /// Crack a whole asset library: files, folders (-r) or globs into a mirrored output tree, in parallel, redoing only what changed
    ///
    /// Exit codes: 0 every asset succeeded or was up to date, 1 an asset failed, 2 bad usage, 3 nothing to do.
    Batch {
        /// Input files, folders or quoted globs ('assets/**/*.obj')
        #[arg(required = true)]
        inputs: Vec<String>,
        /// Output folder: the inputs' tree mirrored, each asset as <name>.glb (or .gltf)
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Go into sub-folders of folder inputs
        #[arg(short, long)]
        recursive: bool,
        /// Output format of cracked assets
        #[arg(long, value_enum, default_value = "glb")]
        format: batch::OutFormat,
        /// TOML file mapping globs to pipelines (first match wins); see the README
        #[arg(long, value_name = "FILE")]
        rules: Option<PathBuf>,
        /// Assets processed at once [default: all cores]
        #[arg(short, long, default_value_t = 0, hide_default_value = true)]
        jobs: usize,
        /// Stop starting new assets after the first failure
        #[arg(long)]
        fail_fast: bool,
        /// Rebuild every asset, even those up to date
        #[arg(long)]
        force: bool,
        /// Write a JSON report (per asset: status, error, stages, cracks, sizes; totals)
        #[arg(long, value_name = "FILE")]
        report: Option<PathBuf>,
        /// List what would be done and stop
        #[arg(long)]
        dry_run: bool,
        /// Only shard K of N (1-based): each asset belongs to one shard, by a hash of its path
        #[arg(long, value_name = "K/N")]
        shard: Option<String>,
        /// Print a build file with one edge per asset instead of running (ninja or make)
        #[arg(long, value_enum, value_name = "KIND")]
        emit: Option<batch::Emit>,
        /// Weld tolerance, relative to each mesh's bounding-box diagonal
        #[arg(long, value_name = "REL", default_value_t = crate::mesh::WeldOptions::default().relative_tolerance)]
        weld_tolerance: f64,
        #[command(flatten)]
        sim: crack::SimArgs,
    },
    /// Statistics of a crack pattern in an output file: cells, cell size, crack density, junctions, open tips, orientations
    Stats {
        /// A crackle output (.glb, .gltf)
        file: PathBuf,
        /// The input the output was made from: also measure the share of crack length along its edges
        #[arg(long, value_name = "FILE")]
        input: Option<PathBuf>,
        /// Print the statistics as JSON on stdout
        #[arg(long)]
        json: bool,
        /// An impact's hit (X,Y,Z in the output's mesh coordinates): also report radial and concentric crack length by distance from it and the cracks crossing the circle at half of --radius
        #[arg(
            long,
            value_name = "X,Y,Z",
            requires = "radius",
            allow_hyphen_values = true
        )]
        impact: Option<String>,
        /// The impact's reference radius (with --impact), in the output's units
        #[arg(long, value_name = "R", requires = "impact")]
        radius: Option<f64>,
    },
    /// Compare two glTF (or OBJ) files structurally and geometrically; exit 0 when equivalent, 1 when not
    ///
    /// Exit codes: 0 equivalent, 1 the files differ, 2 a file cannot be read or bad usage.
    ///
    /// With --geometry, "B is A's own mesh": whether an output kept the input's
    /// triangles, vertex positions, indices and attributes, whatever crackle
    /// added on top. Per mesh (matched by index; counts and names must match)
    /// the triangle primitives are taken in order, leaving out non-triangle
    /// primitives (the crack LINES...) in both files and, in B, those whose
    /// material is named crack_wall; their triangles are concatenated. The
    /// triangle counts must match, and triangle t of A and of B are compared
    /// corner by corner (same corner order): the position and every attribute
    /// A's primitive has (same semantic and component count; morph target
    /// displacements too) within the tolerance. Attributes only B has
    /// (_CRACK_DISTANCE, _CRACK_TIME, TANGENT, a new TEXCOORD_n...) are ignored.
    /// Node hierarchy, transforms and skin indices, skin, camera and animation
    /// counts and the number of morph targets are compared; materials,
    /// textures, images, samplers and added primitives are not. Vertices B has
    /// beyond A's (split on the seams of a new UV set) and index buffers that
    /// changed are reported on the "geometry:" line (and in summary.geometry of
    /// --json), and are a difference only with --same-indices.
    Diff {
        /// First file (the reference: tolerances scale with its values)
        a: PathBuf,
        /// Second file
        b: PathBuf,
        /// Largest difference of positions and attributes still equal (relative to the attribute's size, at least 1)
        #[arg(long, default_value_t = 1e-6)]
        tolerance: f64,
        /// Print the comparison as JSON on stdout
        #[arg(long)]
        json: bool,
        /// Only whether B is A's own mesh: triangles corner by corner, nodes, skins, morph targets (not materials, textures or added primitives and attributes)
        #[arg(long)]
        geometry: bool,
        /// With --geometry: a changed index buffer or vertex count (split vertices) is a difference too
        #[arg(long, requires = "geometry")]
        same_indices: bool,
    },
    /// Read and write a mesh (.gltf or .glb output): its primitives as read, or welded and repaired with --weld
    Convert {
        /// Input mesh (.obj, .gltf, .glb)
        input: PathBuf,
        /// Output file: .gltf (with .bin and images beside it) or .glb
        output: PathBuf,
        /// Weld each mesh as cracking does (vertices by position, degenerate triangles dropped, split into an oriented manifold) and report its defects; without it the primitives are written as read
        #[arg(long)]
        weld: bool,
        /// Weld tolerance, relative to each mesh's bounding-box diagonal (implies --weld) [default: 1e-6]
        #[arg(long, value_name = "REL")]
        weld_tolerance: Option<f64>,
        /// Print a JSON report on stdout
        #[arg(long)]
        json: bool,
    },
}

/// An error whose exit code is 2 (bad usage or configuration).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

impl From<&str> for UsageError {
    fn from(message: &str) -> Self {
        UsageError(message.to_string())
    }
}

/// Exit code for an error: 2 for usage/configuration, 1 otherwise.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    if e.downcast_ref::<UsageError>().is_some()
        || matches!(
            e.downcast_ref::<crate::Error>(),
            Some(
                crate::Error::Config { .. }
                    | crate::Error::Usage(_)
                    | crate::Error::Inputs(_)
                    | crate::Error::Rules(_)
                    | crate::Error::Pipeline(_)
                    | crate::Error::FramesRequest(_)
            )
        )
    {
        2
    } else {
        1
    }
}

/// `crackle presets [NAME]`: one line per preset, or one preset's TOML.
fn presets(show: Option<&str>) -> anyhow::Result<()> {
    use crate::pipeline::{Pipeline, PRESETS};
    match show {
        Some(name) => {
            let Some((_, text)) = PRESETS.iter().find(|(n, _)| *n == name) else {
                Pipeline::preset(name, &[]).map_err(|e| UsageError(e.to_string()))?;
                return Ok(());
            };
            print!("{text}");
            let p = Pipeline::preset(name, &[]).map_err(|e| UsageError(e.to_string()))?;
            println!();
            for line in look::summary(&p) {
                println!("{line}");
            }
        }
        None => {
            for (name, _) in PRESETS {
                let p = Pipeline::preset(name, &[]).map_err(|e| UsageError(e.to_string()))?;
                println!("{name:<14} {}", p.description);
            }
        }
    }
    Ok(())
}

fn weld_options(rel: f64) -> anyhow::Result<crate::mesh::WeldOptions> {
    if !(rel.is_finite() && (0.0..0.1).contains(&rel)) {
        return Err(UsageError(format!("--weld-tolerance {rel} must be in [0, 0.1)")).into());
    }
    Ok(crate::mesh::WeldOptions {
        relative_tolerance: rel,
    })
}

/// Run the parsed command; returns the exit code.
/// A size in bytes: a number with an optional K, M or G (powers of 1024).
fn parse_size(s: &str) -> Result<u64, UsageError> {
    let t = s.trim();
    let (num, shift) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some('K') => (&t[..t.len() - 1], 10),
        Some('M') => (&t[..t.len() - 1], 20),
        Some('G') => (&t[..t.len() - 1], 30),
        _ => (t, 0),
    };
    let n: u64 = num.trim().parse().map_err(|_| {
        UsageError(format!(
            "'{s}' is not a size (a number of bytes, or with K, M or G)"
        ))
    })?;
    n.checked_mul(1u64 << shift)
        .filter(|&b| b > 0)
        .ok_or_else(|| UsageError(format!("'{s}' is not a usable size")))
}

pub fn run(cli: Cli) -> anyhow::Result<u8> {
    let quiet = cli.quiet;
    let read = crate::io::ReadOptions {
        max_memory: cli.max_memory,
    };
    match cli.command {
        Command::Batch {
            inputs,
            out,
            recursive,
            format,
            rules,
            sim,
            jobs,
            fail_fast,
            force,
            report,
            dry_run,
            shard,
            emit,
            weld_tolerance,
        } => {
            let weld = weld_options(weld_tolerance)?;
            return batch::run(batch::BatchArgs {
                inputs: &inputs,
                out: &out,
                recursive,
                format,
                sim: &sim,
                rules: rules.as_deref(),
                jobs,
                fail_fast,
                force,
                report: report.as_deref(),
                dry_run,
                shard: shard.as_deref(),
                emit,
                weld,
                quiet,
                read,
            });
        }
        Command::Diff {
            a,
            b,
            tolerance,
            json,
            geometry,
            same_indices,
        } => {
            let same = diff::run(diff::DiffArgs {
                a: &a,
                b: &b,
                tolerance,
                json,
                mode: diff::mode(geometry, same_indices),
                read,
            })?;
            return Ok(if same { 0 } else { 1 });
        }
        _ => {}
    }
    run_other(cli.command, quiet, &read).map(|()| 0)
}

fn run_other(command: Command, quiet: bool, read: &crate::io::ReadOptions) -> anyhow::Result<()> {
    match command {
        Command::Batch { .. } | Command::Diff { .. } => unreachable!("handled by run"),
        Command::Info {
            input,
            json,
            weld_tolerance,
        } => info::run(&input, json, &weld_options(weld_tolerance)?, read),
        Command::Stats {
            file,
            input,
            json,
            impact,
            radius,
        } => {
            let impact = match (impact, radius) {
                (Some(p), Some(r)) => Some((stats::parse_point(&p)?, r)),
                _ => None,
            };
            stats::run(&file, input.as_deref(), json, impact, read)
        }
        Command::Crack {
            input,
            output,
            report,
            sim,
            weld_tolerance,
            frames,
        } => {
            check_output_format(&output)?;
            crack::run(crack::CrackArgs {
                input: &input,
                output: &output,
                report: report.as_deref(),
                weld: weld_options(weld_tolerance)?,
                pipeline: sim.pipeline()?,
                pipeline_dir: sim.pipeline_dir(),
                quiet,
                read: *read,
                frames: frames
                    .map(|v| crate::pipeline::Frames::parse(&v))
                    .transpose()?,
            })
        }
        Command::Presets { show } => presets(show.as_deref()),
        Command::Study {
            input,
            sim,
            out,
            rounds,
            repeat,
            full,
            weld_tolerance,
        } => study::run(study::StudyArgs {
            input: &input,
            pipeline: sim.pipeline()?,
            pipeline_dir: sim.pipeline_dir(),
            out: out.as_deref(),
            rounds,
            repeat,
            full,
            weld: weld_options(weld_tolerance)?,
            read: *read,
        }),
        Command::Convert {
            input,
            output,
            weld,
            weld_tolerance,
            json,
        } => convert::run(
            &input,
            &output,
            match (weld, weld_tolerance) {
                (false, None) => None,
                (_, rel) => Some(weld_options(
                    rel.unwrap_or(crate::mesh::WeldOptions::default().relative_tolerance),
                )?),
            }
            .as_ref(),
            json,
            quiet,
            read,
        ),
    }
}

/// A usage error unless `output` names a format crackle writes (.gltf or
/// .glb), checked before any work.
pub(crate) fn check_output_format(output: &std::path::Path) -> Result<(), UsageError> {
    crate::io::Format::from_path(output)
        .ok()
        .filter(|f| *f != crate::io::Format::Obj)
        .map(|_| ())
        .ok_or_else(|| {
            UsageError(format!(
                "{}: output must be .gltf or .glb (the formats crackle writes)",
                output.display()
            ))
        })
}
