//! `env-exact`: diffuse environment lighting with exact visibility, the ground truth of DVF.
//! Per pixel, L = ρ/π · E(n) with E(n) = ∫ V(ω) L_env(ω) cos θ dω, estimated as DVF does with
//! N_r cosine-weighted rays (`rays`, default 128 = the DVF paper's N_r): the N_r points of a
//! Hammersley set, shifted per pixel by a random Cranley-Patterson rotation, mapped to the
//! cosine-weighted hemisphere of the shading normal; each ray is traced exactly and contributes
//! V · L_env, so L = ρ · (1/N_r) Σ V L_env. `settings.spp` is not used (the ray count is `rays`).
//!
//! The rotation makes every point uniform on [0,1)², so the estimator is unbiased.
//! `rotation=normal` instead rotates the whole Hammersley set by one random angle about the
//! normal, which is the DVF paper's wording ("each of these rays is rotated randomly around the
//! normal"): the azimuths are then random but the elevations are the set's fixed values, a
//! quadrature in θ with an O(1/N_r) bias. Use it only to reproduce the paper's ground truth.
//!
//! `converged=true` is the converged reference for maps with small bright sources (a sun): the
//! default becomes 4096 rays, half of them (rounded down) drawn from the environment's
//! importance sampling (luminance × sin θ) and half cosine-weighted Hammersley as above,
//! combined by multi-sample MIS with the power heuristic (Veach 1997).

use crate::direct::{self, Shading};
use crate::{FrameContext, ParamError, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_core::sampling::{cosine_hemisphere, cosine_hemisphere_pdf, hammersley, rotate_sample};
use glimpse_core::{Frame, Image, Rng, Vec3};
use glimpse_scene::{Environment, Scene};
use glimpse_trace::{GBuffer, Visibility};
use std::f32::consts::PI;

/// The DVF paper's N_r.
pub const DVF_RAYS: u32 = 128;
/// Rays per pixel of the converged mode.
pub const CONVERGED_RAYS: u32 = 4096;

pub struct EnvExact {
    pub rays: u32,
    pub converged: bool,
    /// Rotate the Hammersley set about the normal only (DVF's wording) instead of a
    /// Cranley-Patterson shift.
    pub rotate_about_normal: bool,
    pub settings: Settings,
}

impl EnvExact {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "env-exact",
            family: "environment lighting",
            reference: None,
            description: "diffuse environment light with exact visibility: rays=128 rotated-Hammersley cosine rays (converged=true: 4096, MIS with the map's importance sampling; rotation=cp|normal)",
            create: |scene: &Scene, settings, params| {
                crate::require(scene, "env-exact", crate::Need::Environment)?;
                Ok(Box::new(EnvExact::new(settings, params)?))
            },
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let converged = params.bool("converged", false)?;
        let rays = params.u32("rays", if converged { CONVERGED_RAYS } else { DVF_RAYS }, 1, 1 << 20)?;
        if converged && rays < 2 {
            return Err(ParamError::Invalid {
                key: "rays".into(),
                value: rays.to_string(),
                message: "converged=true needs at least 2 (one per strategy)".into(),
            }
            .into());
        }
        let rotate_about_normal = params.choice("rotation", "cp", &["cp", "normal"])? == "normal";
        Ok(Self { rays, converged, rotate_about_normal, settings: *settings })
    }
}

impl Technique for EnvExact {
    fn id(&self) -> &'static str {
        "env-exact"
    }

    fn prepare(&mut self, _ctx: &FrameContext) -> Result<Stats, RenderError> {
        Ok(Stats::default())
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let mut stats = Stats { memory_bytes: ctx.tracer.memory_bytes(), ..Default::default() };
        let env = ctx.frame.scene.environment.as_ref();
        stats.rays = stats.time("shade", || {
            direct::shade_pixels(ctx, gbuffer, self.settings.seed, out, |i, rng| {
                let (Some(s), Some(env)) = (Shading::from_gbuffer(gbuffer, i), env) else {
                    return (Vec3::ZERO, 0);
                };
                self.shade_point(&s, env, rng, &ctx.tracer)
            })
        })?;
        Ok(stats)
    }
}

impl EnvExact {
    /// One shading point's reflected environment light and the rays it traced through `vis`
    /// (the CPU tracer here; the GPU port replays the GPU's answers through the same code).
    pub fn shade_point<V: Visibility + ?Sized>(&self, s: &Shading, env: &Environment, rng: &mut Rng, vis: &V) -> (Vec3, u64) {
        let (n, rotate_about_normal) = (self.rays, self.rotate_about_normal);
        // Strategy counts: all cosine-weighted, or cosine + importance-sampled map (MIS).
        let n_env = if self.converged { n / 2 } else { 0 };
        let n_cos = n - n_env;
        let frame = Frame::from_z(s.shading_normal);
        let shift = rng.next_2d();
        let (sin_a, cos_a) = (std::f32::consts::TAU * shift.x).sin_cos();
        let local = |k: u32| {
            if rotate_about_normal {
                let d = cosine_hemisphere(hammersley(k, n_cos));
                Vec3::new(d.x * cos_a - d.y * sin_a, d.x * sin_a + d.y * cos_a, d.z)
            } else {
                cosine_hemisphere(rotate_sample(hammersley(k, n_cos), shift))
            }
        };
        let (mut sum, mut rays) = (Vec3::ZERO, 0u64);
        // Cosine-weighted: f cos / pdf = ρ, so each unblocked ray adds ρ L (ρ applied last).
        // The point's rays are asked together ([`direct::sum_unblocked`]); L is read only for
        // the unblocked ones.
        let cosine_rays = (0..n_cos).filter_map(|k| {
            let d = frame.to_world(local(k));
            let cos = s.cos(d);
            if cos <= 0.0 {
                return None;
            }
            let w = if n_env > 0 {
                let p_cos = n_cos as f32 * cosine_hemisphere_pdf(cos);
                direct::power_heuristic(p_cos, n_env as f32 * env.pdf(d))
            } else {
                1.0
            };
            Some(((d, w), s.spawn(d), f32::INFINITY))
        });
        let (cosine_sum, cosine_count) = direct::sum_unblocked(vis, cosine_rays, |&(d, w)| env.radiance(d) * (w / n_cos as f32));
        sum += cosine_sum;
        rays += cosine_count;
        // Importance-sampled map: (ρ/π) L cos / pdf, weighted.
        for _ in 0..n_env {
            let (d, l, pdf) = env.sample(rng.next_2d());
            let cos = s.cos(d);
            if pdf <= 0.0 || cos <= 0.0 {
                continue;
            }
            let w = direct::power_heuristic(n_env as f32 * pdf, n_cos as f32 * cosine_hemisphere_pdf(cos));
            rays += 1;
            if !vis.occluded(&s.spawn(d), f32::INFINITY) {
                sum += l * (w * cos / (PI * pdf * n_env as f32));
            }
        }
        (s.albedo * sum, rays)
    }
}
