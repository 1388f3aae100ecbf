//! crackle as a library, both ways: file to file, and in memory.
//!
//! ```text
//! cargo run --release --example library [INPUT] [OUTPUT_FOLDER]
//! ```
//!
//! Cracks INPUT (default: the project's `fixtures/icosphere.obj`) with the
//! `glaze` preset into `OUTPUT_FOLDER/cracked.glb` (default: a folder under
//! the system's temporary folder), then reads that file's bytes, cracks them
//! again with `mud` in memory and writes `cracked_twice.glb`. Prints what
//! each run did; exits non-zero, with the error, when a step fails.

use crackle::{Config, Pipeline};
use std::path::{Path, PathBuf};

fn main() {
    if let Err(e) = go() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn go() -> crackle::Result<()> {
    let mut args = std::env::args().skip(1);
    let input = args
        .next()
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/icosphere.obj"));
    let folder = args
        .next()
        .map(PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("crackle-library-example"));
    std::fs::create_dir_all(&folder).map_err(|e| crackle::error::IoError::io(&folder, e))?;
    let preset = |name: &str| Pipeline::preset(name, &[]).map_err(crackle::Error::from);

    // File to file: read, run, write, as `crackle crack` does.
    let output = folder.join("cracked.glb");
    let mut config = Config::in_memory(preset("glaze")?, &input.display().to_string());
    config.asset = input.clone();
    config.output = output.clone();
    let report = crackle::crack_file(config, None, false, &mut crackle::Quiet)?;
    println!(
        "{} -> {}: {} cracks, {} bytes, {} -> {} triangles",
        report.input,
        report.output,
        report.run.cracks,
        report.bytes,
        report.mesh_triangles.before,
        report.mesh_triangles.after
    );

    // In memory: bytes in, bytes out, no file read or written by the library.
    let bytes = std::fs::read(&output).map_err(|e| crackle::error::IoError::io(&output, e))?;
    let mut scene = crackle::read_bytes(&bytes, "cracked.glb")?;
    let config = Config::in_memory(preset("mud")?, "cracked.glb");
    let run = crackle::run(&mut scene, &config, &mut crackle::Quiet)?;
    let glb = crackle::write_bytes(&scene)?;
    let again = folder.join("cracked_twice.glb");
    std::fs::write(&again, &glb).map_err(|e| crackle::error::IoError::io(&again, e))?;
    println!(
        "in memory: {} cracks more, {} bytes -> {}",
        run.cracks,
        glb.len(),
        again.display()
    );
    // What the library wrote reads back.
    let back = crackle::read_bytes(&glb, "cracked_twice.glb")?;
    assert_eq!(back.triangle_count(), scene.triangle_count());
    Ok(())
}
