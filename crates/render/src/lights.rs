//! `lights-exact`: direct diffuse light from every punctual light (point, spot, directional)
//! with one exact shadow ray per light per pixel and no sampling noise, the ground truth of the
//! voxel-array (many-lights) paper. `lights=N` uses only the first N lights (N larger than the
//! scene's count means all; default all).
//!
//! [`light_visibility`] returns the same shadow decisions as bits, per pixel and light, for the
//! visibility-error metrics (ε_v: wrong decisions; ε_s: their effect on shading), computed
//! through any [`Visibility`] so an approximate structure's decisions come out in the same form.

use crate::direct::{self, Shading};
use crate::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_core::{Image, Vec3};
use glimpse_scene::{Scene, SceneFrame};
use glimpse_trace::{GBuffer, Visibility};
use rayon::prelude::*;
use std::f32::consts::PI;

pub struct LightsExact {
    /// How many of the scene's punctual lights to use (from the start of the list).
    pub lights: u32,
    pub settings: Settings,
}

impl LightsExact {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "lights-exact",
            family: "many lights",
            reference: None,
            description: "direct diffuse light from every punctual light, one exact shadow ray each, noise-free (lights=N: first N only)",
            create: |scene: &Scene, settings, params| {
                crate::require(scene, "lights-exact", crate::Need::PunctualLights)?;
                Ok(Box::new(LightsExact::new(scene, settings, params)?))
            },
        }
    }

    pub fn new(scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let all = (scene.lights.len() as u32).max(1);
        Ok(Self { lights: params.u32("lights", all, 1, u32::MAX)?, settings: *settings })
    }
}

impl Technique for LightsExact {
    fn id(&self) -> &'static str {
        "lights-exact"
    }

    fn prepare(&mut self, _ctx: &FrameContext) -> Result<Stats, RenderError> {
        Ok(Stats::default())
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let mut stats = Stats { memory_bytes: ctx.tracer.memory_bytes(), ..Default::default() };
        let lights = &ctx.frame.lights[..ctx.frame.lights.len().min(self.lights as usize)];
        stats.rays = stats.time("shade", || {
            direct::shade_pixels(ctx, gbuffer, self.settings.seed, out, |i, _rng| {
                let Some(s) = Shading::from_gbuffer(gbuffer, i) else {
                    return (Vec3::ZERO, 0);
                };
                let (e, rays) = direct::punctual_irradiance(lights, &ctx.tracer, &s);
                (s.albedo / PI * e, rays)
            })
        })?;
        Ok(stats)
    }
}

/// Per-pixel, per-light shadow decisions as bitset rows of `words_per_pixel` words
/// (bit `l % 64` of word `l / 64` of pixel `i`'s row is light `l`).
#[derive(Clone, Debug, PartialEq)]
pub struct LightVisibility {
    pub lights: usize,
    pub words_per_pixel: usize,
    /// The shadow segment from the pixel's point to the light is unblocked. Computed for every
    /// (pixel with geometry, light) pair, facing or not; 0 for pixels without geometry.
    pub visible: Vec<u64>,
    /// The light can reach the pixel at all: it lies above the surface (geometric and shading
    /// normals) and its irradiance there is non-zero (inside a spot's cone). Metrics that judge
    /// only decisions that matter for shading mask `visible` with this.
    pub facing: Vec<u64>,
}

impl LightVisibility {
    fn bit(bits: &[u64], words: usize, pixel: usize, light: usize) -> bool {
        bits[pixel * words + light / 64] >> (light % 64) & 1 == 1
    }

    pub fn visible(&self, pixel: usize, light: usize) -> bool {
        Self::bit(&self.visible, self.words_per_pixel, pixel, light)
    }

    pub fn facing(&self, pixel: usize, light: usize) -> bool {
        Self::bit(&self.facing, self.words_per_pixel, pixel, light)
    }

    /// Pixel `pixel`'s row of visibility bits.
    pub fn row(&self, pixel: usize) -> &[u64] {
        &self.visible[pixel * self.words_per_pixel..(pixel + 1) * self.words_per_pixel]
    }
}

/// The shadow decisions of `vis` for the first `lights` punctual lights at every GBuffer pixel
/// (the exact ones with `&ctx.tracer`), with the same shadow segments as `lights-exact`.
pub fn light_visibility(frame: &SceneFrame, gbuffer: &GBuffer, vis: &dyn Visibility, lights: usize) -> LightVisibility {
    let lights = &frame.lights[..frame.lights.len().min(lights)];
    let words = lights.len().div_ceil(64);
    let mut visible = vec![0u64; gbuffer.len() * words];
    let mut facing = vec![0u64; gbuffer.len() * words];
    if words > 0 {
        visible.par_chunks_mut(words).zip(facing.par_chunks_mut(words)).enumerate().for_each(|(i, (vrow, frow))| {
            let Some(s) = Shading::from_gbuffer(gbuffer, i) else {
                return;
            };
            for (l, light) in lights.iter().enumerate() {
                let ps = direct::punctual(light, s.position, s.normal, s.error_scale);
                if s.cos(ps.wi) > 0.0 && ps.irradiance.max_element() > 0.0 {
                    frow[l / 64] |= 1 << (l % 64);
                }
                if !vis.occluded(&ps.shadow, ps.t_max) {
                    vrow[l / 64] |= 1 << (l % 64);
                }
            }
        });
    }
    LightVisibility { lights: lights.len(), words_per_pixel: words, visible, facing }
}
