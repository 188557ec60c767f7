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
