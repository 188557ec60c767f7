//! `soft-exact`: soft shadows from the area lights, the reference for the soft-shadow
//! techniques. Per pixel, `spp` light samples: an emissive triangle chosen by power, a uniform
//! point on it, one exact shadow ray each; the pixel is the Lambertian reflection
//! ρ/π · (1/N) Σ L_e cos θ / pdf_ω. `shadows=false` gives the unshadowed image (same samples,
//! no shadow rays), so a technique's shadowing can be judged apart from its light integration.

use crate::direct::{self, Shading, Unoccluded};
use crate::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_core::{Image, Vec3};
use glimpse_scene::Scene;
use glimpse_trace::{GBuffer, Visibility};
use std::f32::consts::PI;

pub struct SoftExact {
    /// Trace shadow rays (default true).
    pub shadows: bool,
    pub settings: Settings,
}

impl SoftExact {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "soft-exact",
            family: "soft shadows",
            reference: None,
            description: "direct diffuse light from the area lights: spp light samples by power, exact shadow rays (shadows=false: unshadowed)",
            create: |scene: &Scene, settings, params| {
                crate::require(scene, "soft-exact", crate::Need::AreaLights)?;
                Ok(Box::new(SoftExact::new(settings, params)?))
            },
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        direct::require_spp(settings)?;
        Ok(Self { shadows: params.bool("shadows", true)?, settings: *settings })
    }
}

impl Technique for SoftExact {
    fn id(&self) -> &'static str {
        "soft-exact"
    }

    fn prepare(&mut self, _ctx: &FrameContext) -> Result<Stats, RenderError> {
        Ok(Stats::default())
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let mut stats = Stats { memory_bytes: ctx.tracer.memory_bytes(), ..Default::default() };
        let vis: &dyn Visibility = if self.shadows { &ctx.tracer } else { &Unoccluded };
        let spp = self.settings.spp;
        let rays = stats.time("shade", || {
            direct::shade_pixels(ctx, gbuffer, self.settings.seed, out, |i, rng| {
                let Some(s) = Shading::from_gbuffer(gbuffer, i) else {
                    return (Vec3::ZERO, 0);
                };
                let (mut e, mut rays) = (Vec3::ZERO, 0);
                for _ in 0..spp {
                    let (de, dr) = direct::area_irradiance(&ctx.frame, vis, &s, rng);
                    e += de;
                    rays += dr;
                }
                (s.albedo / PI * e / spp as f32, rays)
            })
        })?;
        stats.rays = if self.shadows { rays } else { 0 };
        Ok(stats)
    }
}
