//! Work in progress.

use glimpse_render::TechniqueInfo;

/// The techniques of this crate, for the registry.
pub fn techniques() -> Vec<TechniqueInfo> {
    Vec::new()
}
