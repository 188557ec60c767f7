//! Fuzzing on stable Rust (issue #15): proptest drives structured mutations
//! ([`glimpse_core::mutate`]: bit flips, truncations, insertions, duplicated chunks, numbers and
//! u32 fields replaced by 0, −1, 2^31, 1e38, NaN …) of the seed corpus in `tests/corpus/` through
//! every scene loader: glTF (JSON with a data: buffer, and with an external .bin), GLB, OBJ, MTL
//! (through an OBJ that uses it) and scene.toml. Every case must load or fail with an error naming
//! the file — never a panic (a panic here fails the test; proptest then shrinks it and records the
//! seed in `proptest-regressions/`). Hangs cannot be caught without a wall-clock limit (which tests
//! must not have); every loop in the loaders is bounded by the input's size. The files in
//! `tests/corpus/regressions/` (each once a crash, a hang or a runaway allocation) are loaded too.
//!
//! Cases per target: `GLIMPSE_FUZZ_CASES` (default 1000; the cargo-fuzz targets in `fuzz/` are for
//! longer runs). The memory budget is 256 MiB, so no mutation can make the test allocate gigabytes.

use glimpse_core::mutate::{self, Mutation};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

fn corpus() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/corpus")
}

fn cases() -> u32 {
    std::env::var("GLIMPSE_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(1000)
}

/// A scratch folder holding a copy of the corpus, so relative references (.bin, .mtl, .obj) resolve;
/// removed when the returned `TempDir` is dropped (at the end of the test, also when it fails).
fn scratch(target: &str) -> tempfile::TempDir {
    let dir = tempfile::Builder::new().prefix(&format!("glimpse-fuzz-{target}-")).tempdir().unwrap();
    for e in std::fs::read_dir(corpus()).unwrap().flatten() {
        if e.path().is_file() {
            std::fs::copy(e.path(), dir.path().join(e.file_name())).unwrap();
        }
    }
    dir
}

fn mutations() -> impl Strategy<Value = Vec<Mutation>> {
    prop::collection::vec((0..mutate::KINDS, any::<u32>(), any::<u32>()).prop_map(|(kind, at, value)| Mutation { kind, at, value }), 1..6)
}

/// Fuzzes `load_name` in a copy of the corpus: each case writes `seed` mutated to `write_name`
/// and loads `load_name` (the same file, or one that references it).
fn fuzz(target: &str, seed: &str, write_name: &str, load_name: &str) {
    glimpse_core::memory_budget::set_budget(256 << 20);
    let tmp = scratch(target);
    let dir = tmp.path();
    let seed_bytes = std::fs::read(corpus().join(seed)).unwrap();
    let (ok, failed, contained) = (AtomicUsize::new(0), AtomicUsize::new(0), AtomicUsize::new(0));
    let mut runner = TestRunner::new(Config { cases: cases(), failure_persistence: None, ..Config::default() });
    let result = runner.run(&mutations(), |m| {
        std::fs::write(dir.join(write_name), mutate::mutated(&seed_bytes, &m)).unwrap();
        let path = dir.join(load_name);
        match glimpse_scene::load(path.to_str().unwrap()) {
            Ok(_) => ok.fetch_add(1, Ordering::Relaxed),
            Err(e) => {
                let e = e.to_string();
                prop_assert!(e.contains(load_name) || e.contains(write_name), "error does not name the file: {e}");
                if e.contains("internal panic") {
                    contained.fetch_add(1, Ordering::Relaxed);
                }
                failed.fetch_add(1, Ordering::Relaxed)
            }
        };
        Ok(())
    });
    let (ok, failed, contained) = (ok.into_inner(), failed.into_inner(), contained.into_inner());
    println!(
        "{target}: {} cases from {seed}: {ok} loaded, {failed} refused with an error ({contained} of them a third-party reader's panic contained by the loader), 0 panics",
        ok + failed
    );
    if let Err(e) = result {
        panic!("{target}: {e}");
    }
}

#[test]
fn fuzz_gltf_json() {
    fuzz("gltf", "quad.gltf", "fuzz.gltf", "fuzz.gltf");
}

#[test]
fn fuzz_gltf_external_buffer() {
    fuzz("gltf-bin", "quad.bin", "quad.bin", "external.gltf");
}

#[test]
fn fuzz_glb() {
    fuzz("glb", "quad.glb", "fuzz.glb", "fuzz.glb");
}

#[test]
fn fuzz_obj() {
    fuzz("obj", "cube.obj", "fuzz.obj", "fuzz.obj");
}

#[test]
fn fuzz_mtl() {
    fuzz("mtl", "cube.mtl", "cube.mtl", "cube.obj");
}

#[test]
fn fuzz_scene_toml() {
    fuzz("toml", "scene.toml", "fuzz.toml", "fuzz.toml");
}

#[test]
fn fuzz_mitsuba_xml() {
    fuzz("mitsuba", "scene.xml", "fuzz.xml", "fuzz.xml");
}

/// The binary PLY a Mitsuba scene references, mutated under the scene that loads it.
#[test]
fn fuzz_mitsuba_referenced_ply() {
    fuzz("mitsuba-ply", "quad_le.ply", "quad_le.ply", "scene.xml");
}

#[test]
fn fuzz_ply_ascii() {
    fuzz("ply-ascii", "quad.ply", "fuzz.ply", "fuzz.ply");
}

#[test]
fn fuzz_ply_binary() {
    fuzz("ply-binary", "quad_le.ply", "fuzz_le.ply", "fuzz_le.ply");
}

/// Every file in `tests/corpus/regressions/` loads or fails cleanly, never panics or runs away.
#[test]
fn regression_corpus_fails_cleanly() {
    glimpse_core::memory_budget::set_budget(256 << 20);
    let dir = corpus().join("regressions");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap().flatten() {
        let path = e.path();
        let ext = path.extension().and_then(|x| x.to_str()).unwrap_or("");
        if !matches!(ext, "gltf" | "glb" | "obj" | "toml") {
            continue;
        }
        let result = glimpse_scene::load(path.to_str().unwrap());
        println!("{}: {}", path.file_name().unwrap().to_string_lossy(), result.as_ref().err().map_or("loaded".into(), |e| e.to_string()));
        if let Err(e) = result {
            assert!(!e.to_string().contains("internal panic"), "{e}");
        }
        n += 1;
    }
    assert!(n >= 5, "the regression corpus is there");
}

#[test]
fn seeds_load() {
    for seed in ["quad.gltf", "external.gltf", "quad.glb", "cube.obj", "scene.toml"] {
        let scene = glimpse_scene::load(corpus().join(seed).to_str().unwrap()).unwrap();
        assert!(scene.warnings.is_empty(), "{seed}: {:?}", scene.warnings);
    }
}
