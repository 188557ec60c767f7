//! `ao-exact`: cosine-weighted ambient occlusion with exact rays, the reference for `ao-roma`
//! and `ao-df`. Per pixel, `spp` rays leave the GBuffer point over the cosine-weighted
//! hemisphere of the shading normal; the pixel is the fraction that reach `radius` unblocked
//! (so AO = 1 is fully open). The default radius is infinite, as ROMA's AO (spec §5.1).

use crate::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Image, Ray, Rng, Vec3};
use glimpse_scene::Scene;
use glimpse_trace::{GBuffer, Visibility};
use rayon::prelude::*;

pub struct AoExact {
    pub radius: f32,
    pub settings: Settings,
}

impl AoExact {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "ao-exact",
            family: "ambient occlusion",
            reference: None,
            description: "cosine-weighted ambient occlusion with exact rays (radius=inf by default)",
            create: |_: &Scene, settings, params| Ok(Box::new(AoExact::new(settings, params)?)),
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        Ok(Self { radius: params.f32("radius", f32::INFINITY, 0.0, f32::INFINITY)?, settings: *settings })
    }
}

/// Ambient occlusion of every GBuffer pixel against any [`Visibility`]; pixels that see no
/// geometry are 1 (open sky). Shared by every AO technique so they differ only in visibility.
#[allow(clippy::too_many_arguments)]
pub fn ambient_occlusion(
    gbuffer: &GBuffer,
    vis: &dyn Visibility,
    spp: u32,
    radius: f32,
    seed: u64,
    pass: u64,
    progress: &crate::Progress,
    out: &mut Image,
) -> u64 {
    out.pixels.par_iter_mut().enumerate().for_each(|(i, px)| {
        progress.add(1);
        let Some((p, n, e)) = gbuffer.point(i) else {
            *px = Vec3::ONE;
            return;
        };
        let frame = Frame::from_z(n);
        let mut rng = Rng::for_pixel(seed, i as u64, pass);
        let open =
            (0..spp).filter(|_| !vis.occluded(&Ray::spawn(p, n, e, frame.to_world(cosine_hemisphere(rng.next_2d()))), radius)).count();
        *px = Vec3::splat(open as f32 / spp as f32);
    });
    gbuffer.instance.iter().filter(|&&i| i != glimpse_trace::gbuffer::NO_HIT).count() as u64 * spp as u64
}

impl Technique for AoExact {
    fn id(&self) -> &'static str {
        "ao-exact"
    }

    fn prepare(&mut self, _ctx: &FrameContext) -> Result<Stats, RenderError> {
        Ok(Stats::default())
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let mut stats = Stats { memory_bytes: ctx.tracer.memory_bytes(), ..Default::default() };
        stats.rays = stats.time("trace", || {
            ambient_occlusion(
                gbuffer,
                &ctx.tracer,
                self.settings.spp,
                self.radius,
                self.settings.seed,
                ctx.frame_index as u64,
                &ctx.progress,
                out,
            )
        });
        Ok(stats)
    }
}
