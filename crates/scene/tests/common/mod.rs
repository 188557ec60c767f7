//! Helpers shared by the scene crate's test files (each test binary uses a subset).
#![allow(dead_code)]

use glimpse_scene::{Scene, SceneError};
use std::path::{Path, PathBuf};

/// `../shared/scenes` beside the repository, or `None` (printing why) when it is not there.
pub fn shared_scenes() -> Option<PathBuf> {
    match PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes").canonicalize() {
        Ok(dir) => Some(dir),
        Err(_) => {
            println!("skipped: ../shared/scenes not found");
            None
        }
    }
}

/// A fresh scratch folder per test, named after the test binary and the test.
pub fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("glimpse-{}-{}-{test}", env!("CARGO_CRATE_NAME"), std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub fn write(dir: &Path, name: &str, content: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

pub fn load(path: &Path) -> Result<Scene, SceneError> {
    glimpse_scene::load(path.to_str().unwrap())
}
