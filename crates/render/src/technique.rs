//! The `Technique` interface: one way of computing an image of the scene at a frame.
//! `prepare` is the per-frame build (voxelization, tree build, precomputation); `render` shades
//! the pixels of a GBuffer. Both report stage timings and memory, so a technique's build and
//! shading costs are always measured separately.

use crate::{FrameContext, ParamError, Stats};
use glimpse_core::Image;
use glimpse_trace::GBuffer;

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("{technique}: {message}")]
    Unsupported { technique: String, message: String },
    #[error("unknown technique '{id}' (known: {known})")]
    UnknownTechnique { id: String, known: String },
    /// A structure a technique would build does not fit the memory budget (`--max-memory`).
    #[error(transparent)]
    Memory(#[from] glimpse_core::memory_budget::BudgetError),
}

/// What a technique needs from a scene to compute anything meaningful.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Need {
    PunctualLights,
    Environment,
    AreaLights,
    /// Any light at all: punctual, area or environment.
    AnyLight,
}

/// Fails with [`RenderError::Unsupported`] when `scene` lacks what `technique` needs, so that a
/// technique never silently renders a black image (eval reports such pairs as not applicable).
pub fn require(scene: &glimpse_scene::Scene, technique: &str, need: Need) -> Result<(), RenderError> {
    let has_area = scene.instances.iter().any(|i| scene.materials[scene.meshes[i.mesh as usize].material as usize].is_emissive());
    let (ok, what) = match need {
        Need::PunctualLights => (!scene.lights.is_empty(), "punctual (point, spot or directional) lights"),
        Need::Environment => (scene.environment.is_some(), "environment map"),
        Need::AreaLights => (has_area, "area lights (emissive triangles)"),
        Need::AnyLight => (has_area || !scene.lights.is_empty() || scene.environment.is_some(), "lights of any kind"),
    };
    if ok {
        Ok(())
    } else {
        Err(RenderError::Unsupported { technique: technique.to_owned(), message: format!("the scene '{}' has no {what}", scene.name) })
    }
}

/// Settings every technique shares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Samples per pixel (what a "sample" is depends on the technique).
    pub spp: u32,
    pub seed: u64,
}

impl Default for Settings {
    fn default() -> Self {
        Self { spp: 16, seed: 0 }
    }
}

pub trait Technique: Send {
    fn id(&self) -> &'static str;

    /// Per-frame build. Called once before each `render` of a new frame.
    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError>;

    /// Shades every pixel of `gbuffer` into `out` (same size).
    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError>;
}
