//! Loader for toml scenes (not written yet).

use crate::{Scene, SceneError};
use std::path::Path;

pub fn load(path: &Path) -> Result<Scene, SceneError> {
    Err(SceneError::Unsupported { path: path.to_owned(), message: "the toml loader is not written yet".into() })
}
