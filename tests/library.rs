//! The library's front door (`crackle::{read, read_bytes, run, write,
//! write_bytes, crack_file}`), used as a Rust program would: a mesh cracked
//! in memory comes out as a valid GLB that reads back; in-memory reading
//! never touches the disk; the file-to-file call writes what it reports.

mod common;

use crackle::{Config, Pipeline};

fn preset(name: &str) -> Pipeline {
    Pipeline::preset(name, &[]).unwrap()
}

/// OBJ text in, GLB bytes out, no file involved; the bytes are valid glTF
/// and read back with the same triangles.
#[test]
fn a_mesh_cracked_in_memory_is_a_valid_glb() {
    let text = std::fs::read(common::manifest_dir().join("fixtures/icosphere.obj")).unwrap();
    let mut scene = crackle::read_bytes(&text, "icosphere.obj").unwrap();
    let before = scene.triangle_count();
    let config = Config::in_memory(preset("glaze"), "icosphere.obj");
    let report = crackle::run(&mut scene, &config, &mut crackle::Quiet).unwrap();
    assert!(report.cracks > 100, "{} cracks", report.cracks);
    // The post stages' report is typed: glaze bakes its maps into each
    // material and opens no gap.
    let post: &crackle::PostReport = &report.meshes[0].post;
    let bake = post.bake.as_ref().expect("glaze bakes");
    let materials = bake.materials.as_ref().expect("one bake per material");
    assert!(!materials.is_empty() && materials.iter().all(|m| m.crack_texels > 0));
    assert!(post.width.is_none() && post.walls.is_none() && post.tear.is_none());
    let glb = crackle::write_bytes(&scene).unwrap();
    assert_eq!(&glb[..4], b"glTF");
    let back = crackle::read_bytes(&glb, "out.glb").unwrap();
    assert_eq!(back.triangle_count(), scene.triangle_count());
    assert_eq!(
        scene.triangle_count(),
        before,
        "glaze returns the artist's triangles"
    );
    // The same bytes as the file writer's.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.glb");
    crackle::write(&scene, &path).unwrap();
    assert_eq!(
        std::fs::read(&path).unwrap(),
        glb,
        "write and write_bytes differ"
    );
    if let Some(v) = common::validator() {
        let r = v.validate(&path);
        assert_eq!(r.errors, 0, "{r:?}");
    }
}

/// A time-lapse in memory: `run` writes no file, it hands each frame's
/// scene to the observer as it is reached (the last one the output); an
/// observer that does not take frames makes the run fail, not lose them.
#[test]
fn frames_reach_the_observer_and_no_file_is_written() {
    struct Keep(Vec<(usize, usize, Vec<u8>)>);
    impl crackle::Observer for Keep {
        fn frame(
            &mut self,
            index: usize,
            count: usize,
            scene: &crackle::Scene,
        ) -> crackle::Result<()> {
            self.0.push((index, count, crackle::write_bytes(scene)?));
            Ok(())
        }
    }
    let text = std::fs::read(common::manifest_dir().join("fixtures/plate_jittered.obj")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let unused = dir.path().join("frames");
    let mut config = Config::in_memory(preset("mud"), "plate_jittered.obj");
    config.frames = Some(crackle::Frames {
        count: 4,
        dir: unused.clone(),
    });
    let mut scene = crackle::read_bytes(&text, "plate_jittered.obj").unwrap();
    let mut keep = Keep(Vec::new());
    let report = crackle::run(&mut scene, &config, &mut keep).unwrap();
    assert_eq!(report.frames.as_ref().map(|f| f.count), Some(4));
    let indices: Vec<(usize, usize)> = keep.0.iter().map(|(i, n, _)| (*i, *n)).collect();
    assert_eq!(indices, [(0, 4), (1, 4), (2, 4), (3, 4)]);
    assert_eq!(
        keep.0[3].2,
        crackle::write_bytes(&scene).unwrap(),
        "the last frame is the output"
    );
    assert_ne!(keep.0[0].2, keep.0[3].2);
    assert!(!unused.exists(), "run wrote the frames folder");
    let mut scene = crackle::read_bytes(&text, "plate_jittered.obj").unwrap();
    let e = crackle::run(&mut scene, &config, &mut crackle::Quiet).unwrap_err();
    assert!(e.to_string().contains("Observer::frame"), "{e}");
}

/// A document read from memory that names a file is refused by name,
/// before anything is read; a glTF with its data embedded is read.
#[test]
fn reading_from_memory_never_reads_a_file() {
    let gltf = std::fs::read(common::manifest_dir().join("fixtures/textured_quad.gltf")).unwrap();
    let e = crackle::read_bytes(&gltf, "quad.gltf")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("quad.gltf") && e.contains("textured_quad.bin"),
        "{e}"
    );
    let obj = b"mtllib secret.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let e = crackle::read_bytes(obj, "tri.obj").unwrap_err().to_string();
    assert!(e.contains("secret.mtl"), "{e}");
    // However the line is spelled: after a byte-order mark, indented, in
    // a continued line; read from inside the folder holding the library.
    for obj in [
        "\u{feff}mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n \tmtllib m.mtl\nf 1 2 3\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nmtllib \\\nm.mtl\nf 1 2 3\n",
    ] {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.mtl"), "newmtl red\nKd 1 0 0\n").unwrap();
        let here = std::env::current_dir().unwrap();
        let read = {
            let _back = CwdGuard::enter(dir.path(), &here);
            crackle::read_bytes(obj.as_bytes(), "tri.obj")
        };
        let e = read.unwrap_err().to_string();
        assert!(e.contains("m.mtl"), "{obj:?}: {e}");
    }
    let e = crackle::read_bytes(&[0xff, 0xfe, 0x00], "junk.bin")
        .unwrap_err()
        .to_string();
    assert!(e.contains("junk.bin"), "{e}");
    // Embedded data reads: the file's own bytes, written as a GLB.
    let scene = crackle::read(&common::manifest_dir().join("fixtures/textured_quad.gltf")).unwrap();
    let glb = crackle::write_bytes(&scene).unwrap();
    let back = crackle::read_bytes(&glb, "quad.glb").unwrap();
    assert_eq!(back.triangle_count(), scene.triangle_count());
    assert_eq!(
        back.images.len(),
        scene.images.len(),
        "the texture travels inside"
    );
}

/// `crack_file` writes the file its report names, and the report's counts
/// are those of the file.
#[test]
fn crack_file_writes_what_it_reports() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::manifest_dir().join("fixtures/plate_jittered.obj");
    let mut config = Config::in_memory(preset("mud"), "plate_jittered.obj");
    config.asset = input;
    config.output = dir.path().join("nested/out.glb");
    let report = crackle::crack_file(config, None, false, &mut crackle::Quiet).unwrap();
    let bytes = std::fs::read(dir.path().join("nested/out.glb")).unwrap();
    assert_eq!(report.bytes, bytes.len() as u64);
    let back = crackle::read_bytes(&bytes, "out.glb").unwrap();
    assert_eq!(back.triangle_count(), report.mesh_triangles.after);
    assert!(report.run.cracks > 10);
}

/// Sets the working folder for a block and restores it.
struct CwdGuard(std::path::PathBuf);

impl CwdGuard {
    fn enter(dir: &std::path::Path, back: &std::path::Path) -> CwdGuard {
        std::env::set_current_dir(dir).unwrap();
        CwdGuard(back.to_path_buf())
    }
}

impl Drop for CwdGuard {
    fn drop(&mut self) {
        let _ = std::env::set_current_dir(&self.0);
    }
}

/// Every type the front door hands out can be named there (the crate
/// denies unnameable public types): a pipeline's options changed in code,
/// a mesh's simulation report and an error's fault matched by their types.
#[test]
fn what_the_front_door_hands_out_can_be_named() {
    use crackle::error::{Error, IoError, LineFault, ObjError};
    use crackle::options::{Model, SimParams};
    use crackle::report::SimReport;
    let mut pipeline = preset("glaze");
    let simulation: &mut SimParams = &mut pipeline.simulation;
    assert_eq!(simulation.model, Model::Quasistatic);
    simulation.seed = 11;
    let text = std::fs::read(common::manifest_dir().join("fixtures/icosphere.obj")).unwrap();
    let mut scene = crackle::read_bytes(&text, "icosphere.obj").unwrap();
    let config = Config::in_memory(pipeline, "icosphere.obj");
    let report = crackle::run(&mut scene, &config, &mut crackle::Quiet).unwrap();
    let simulated: &SimReport = &report.meshes[0].report;
    assert_eq!(simulated.cracks, report.cracks);
    let bad = crackle::read_bytes(b"v 0 0 0\nv 1 0 nan\nf 1 2 1\n", "bad.obj");
    match bad {
        Err(Error::File(IoError::Obj {
            error:
                ObjError::Line {
                    line: 2,
                    fault: LineFault::Vertex { rest },
                },
            ..
        })) => assert_eq!(rest, "1 0 nan"),
        other => panic!("expected line 2's vertex fault, got {other:?}"),
    }
}
