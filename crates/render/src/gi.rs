//! `gi-exact`: one-bounce diffuse global illumination with exact rays, the reference for the
//! one-bounce GI techniques. Everything is Lambertian (ρ/π with the base colour).
//!
//! Per pixel, `spp` samples. Each draws a cosine-weighted bounce ray around the shading normal
//! (so f cos / pdf = ρ) and traces it exactly; at its first hit x the *direct* light is
//! estimated as in [`direct_irradiance`] (one area-light sample by power with an exact shadow
//! ray, every punctual light with its shadow ray, one importance sample of the environment with
//! its shadow ray) and reflected: L(x) = ρ(x)/π · E_direct(x). The indirect radiance is
//! ρ · mean L(x). Emission seen by a bounce ray and the environment seen by a bounce ray that
//! escapes are *direct* light of the pixel, not indirect, so they are not counted here.
//!
//! `include_direct` (default true) adds the pixel's own direct light with the same estimator
//! (one area and one environment sample per bounce sample; the punctual lights once), so the
//! image is direct + one bounce — in expectation the same as `pt` with `max_depth=2
//! brdf=lambert`. `include_direct=false` gives the indirect light alone.

use crate::direct::{self, Shading};
use crate::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Image, Rng, Vec3};
use glimpse_scene::{Scene, SceneFrame};
use glimpse_trace::{GBuffer, SurfacePoint, Visibility};
use std::f32::consts::PI;

pub struct GiExact {
    pub include_direct: bool,
    pub settings: Settings,
}

impl GiExact {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "gi-exact",
            family: "global illumination",
            reference: None,
            description: "one-bounce diffuse GI with exact rays: spp cosine bounce rays, direct light at the hits by NEE (include_direct=true adds the pixel's direct light)",
            create: |scene: &Scene, settings, params| {
                crate::require(scene, "gi-exact", crate::Need::AnyLight)?;
                Ok(Box::new(GiExact::new(settings, params)?))
            },
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        direct::require_spp(settings)?;
        Ok(Self { include_direct: params.bool("include_direct", true)?, settings: *settings })
    }
}

/// One-sample estimate of the direct irradiance at `s` from area lights, punctual lights and
/// the environment, with exact shadow rays through `vis`; returns (irradiance, rays).
pub fn direct_irradiance(frame: &SceneFrame, vis: &dyn Visibility, s: &Shading, rng: &mut Rng) -> (Vec3, u64) {
    let (a, ra) = direct::area_irradiance(frame, vis, s, rng);
    let (p, rp) = direct::punctual_irradiance(&frame.lights, vis, s);
    let (e, re) = direct::env_irradiance(frame.scene.environment.as_ref(), vis, s, rng);
    (a + p + e, ra + rp + re)
}

impl Technique for GiExact {
    fn id(&self) -> &'static str {
        "gi-exact"
    }

    fn prepare(&mut self, _ctx: &FrameContext) -> Result<Stats, RenderError> {
        Ok(Stats::default())
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let mut stats = Stats { memory_bytes: ctx.tracer.memory_bytes(), ..Default::default() };
        let (spp, include_direct) = (self.settings.spp, self.include_direct);
        let frame = &ctx.frame;
        let env = frame.scene.environment.as_ref();
        stats.rays = stats.time("shade", || {
            direct::shade_pixels(ctx, gbuffer, self.settings.seed, out, |i, rng| {
                let Some(s) = Shading::from_gbuffer(gbuffer, i) else {
                    return (Vec3::ZERO, 0);
                };
                let basis = Frame::from_z(s.shading_normal);
                let (mut direct_e, mut indirect, mut rays) = (Vec3::ZERO, Vec3::ZERO, 0u64);
                if include_direct {
                    let (e, r) = direct::punctual_irradiance(&frame.lights, &ctx.tracer, &s);
                    direct_e += e * spp as f32;
                    rays += r;
                }
                for _ in 0..spp {
                    if include_direct {
                        let (a, ra) = direct::area_irradiance(frame, &ctx.tracer, &s, rng);
                        let (e, re) = direct::env_irradiance(env, &ctx.tracer, &s, rng);
                        direct_e += a + e;
                        rays += ra + re;
                    }
                    let d = basis.to_world(cosine_hemisphere(rng.next_2d()));
                    if s.cos(d) <= 0.0 {
                        continue; // below the geometric surface: blocked
                    }
                    let ray = s.spawn(d);
                    rays += 1;
                    let Some(hit) = ctx.tracer.closest_hit(&ray, f32::INFINITY) else {
                        continue;
                    };
                    let x = Shading::from_surface(frame, &SurfacePoint::from_hit(frame, &ray, &hit));
                    if x.albedo.max_element() <= 0.0 {
                        continue;
                    }
                    let (e, r) = direct_irradiance(frame, &ctx.tracer, &x, rng);
                    indirect += x.albedo / PI * e;
                    rays += r;
                }
                (s.albedo * (direct_e / PI + indirect) / spp as f32, rays)
            })
        })?;
        Ok(stats)
    }
}
