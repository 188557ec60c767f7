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

/// A scratch folder, removed with its files when this is dropped (at the end of the test that
/// holds it, also when the test fails): keep it alive while its files are used. It derefs to
/// the folder's path.
pub struct Scratch(tempfile::TempDir);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

/// A fresh scratch folder per test, named after the test binary and the test.
pub fn scratch(test: &str) -> Scratch {
    Scratch(tempfile::Builder::new().prefix(&format!("glimpse-{}-{test}-", env!("CARGO_CRATE_NAME"))).tempdir().unwrap())
}

pub fn write(dir: &Path, name: &str, content: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

pub fn load(path: &Path) -> Result<Scene, SceneError> {
    glimpse_scene::load(path.to_str().unwrap())
}
