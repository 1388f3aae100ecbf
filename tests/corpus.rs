//! Khronos' negative test corpus (glTF-Validator `test/`): every file either
//! loads or is refused with an error — never a panic. Files that load are
//! also welded and written, which must not panic either.

mod common;

use std::panic::{catch_unwind, AssertUnwindSafe};

#[test]
fn validator_corpus_loads_or_errors_without_panic() {
    let Some(root) = common::eval_data("validator_testsuite/test") else {
        return;
    };
    let files = common::files_under(&root, &["gltf", "glb"]);
    assert!(
        files.len() > 300,
        "expected the whole corpus, found {} files",
        files.len()
    );
    let out_dir = tempfile::tempdir().unwrap();
    let (mut loaded, mut refused, mut panics) = (0, 0, Vec::new());
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    for (i, f) in files.iter().enumerate() {
        let r = catch_unwind(AssertUnwindSafe(|| -> Result<(), String> {
            let mut scene = crackle::io::read(f).map_err(|e| e.to_string())?;
            let (entries, _) = crackle::bridge::build_sim_meshes(&scene, &Default::default());
            for e in &entries {
                e.sim
                    .validate()
                    .map_err(|e| format!("invalid simulation mesh: {e}"))?;
                crackle::bridge::write_back(&mut scene, e);
            }
            let out = out_dir.path().join(format!("{i}.glb"));
            crackle::io::gltf_write::write_scene(&scene, &out).map_err(|e| e.to_string())?;
            crackle::io::read(&out).map_err(|e| format!("cannot re-read our own output: {e}"))?;
            Ok(())
        }));
        match r {
            Ok(Ok(())) => loaded += 1,
            Ok(Err(msg)) => {
                assert!(!msg.is_empty());
                assert!(
                    !msg.starts_with("cannot re-read our own output")
                        && !msg.starts_with("invalid simulation mesh"),
                    "{}: {msg}",
                    f.display()
                );
                refused += 1;
            }
            Err(_) => panics.push(f.clone()),
        }
    }
    std::panic::set_hook(hook);
    eprintln!(
        "corpus: {} files, {loaded} loaded, {refused} refused with an error, {} panics",
        files.len(),
        panics.len()
    );
    assert!(
        panics.is_empty(),
        "{} files panicked: {:#?}",
        panics.len(),
        panics
    );
    assert!(loaded > 0 && refused > 0);
}
