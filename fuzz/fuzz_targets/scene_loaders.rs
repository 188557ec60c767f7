//! Raw fuzzer bytes as a scene file: the first byte picks the format (glTF, GLB, OBJ, scene.toml,
//! Mitsuba XML, PLY), the rest is the file. Seeds:
//! crates/scene/tests/corpus (with the first byte prepended). A panic is a bug; an error is fine.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, body)) = data.split_first() else { return };
    let ext = ["gltf", "glb", "obj", "toml", "xml", "ply"][pick as usize % 6];
    glimpse_core::memory_budget::set_budget(256 << 20);
    let dir = std::env::temp_dir().join(format!("glimpse-cargo-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(format!("fuzz.{ext}"));
    if std::fs::write(&path, body).is_ok() {
        let _ = glimpse_scene::load(path.to_str().unwrap());
    }
});
