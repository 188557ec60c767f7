//! Scene errors. Every variant names the file (or built-in scene) and says what is wrong, so
//! the command line can print one clear line.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("{path}: malformed file: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: {message}")]
    Unsupported { path: PathBuf, message: String },
    #[error("{source_name}: invalid scene: {message}")]
    Invalid { source_name: String, message: String },
    #[error("unknown scene '{name}' (built-in scenes: {known}; or give a .gltf, .glb, .obj, .ply, .toml or Mitsuba 3 .xml path)")]
    UnknownScene { name: String, known: String },
}

impl SceneError {
    pub fn io(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Self {
        SceneError::Io { path: path.into(), message: e.to_string() }
    }

    pub fn parse(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Self {
        SceneError::Parse { path: path.into(), message: e.to_string() }
    }
}
