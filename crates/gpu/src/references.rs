//! The exact references on the GPU as [`Technique`]s — `ao-exact`, `lights-exact`, `env-exact` —
//! for `--device gpu`. Each is the CPU technique's pixel shader (same parameters, sampling and
//! `Rng::for_pixel` streams, same spawn offsets, same shading), run through [`replay`] so that
//! its rays are traced by [`GpuTracer`]; the image differs from the CPU's only where the GPU
//! tracer decides a ray differently (none of 120,523 rays on lavapipe, docs/gpu.md).
//!
//! `ao-exact` and `lights-exact` call glimpse-render's own per-pixel code with a GPU-backed
//! [`Visibility`]; `env-exact`'s shader is a copy of `glimpse_render::env`'s (there it is written
//! against the concrete CPU tracer), kept in step by the CLI test that compares the two images.

use crate::replay::{self, Traced};
use crate::{GpuContext, GpuError, GpuScene, GpuTimer, GpuTracer};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Image, Ray, Rng, Vec3};
use glimpse_render::ao::AoExact;
use glimpse_render::direct::{self, Shading};
use glimpse_render::env::EnvExact;
use glimpse_render::lights::LightsExact;
use glimpse_render::{FrameContext, Need, Params, RenderError, Settings, Stats, Technique};
use glimpse_scene::Scene;
use glimpse_trace::{GBuffer, Visibility};
use std::f32::consts::PI;
use std::sync::Arc;

/// A GPU failure as the technique's error (the message names the technique and the cause).
pub fn render_error(technique: &str, e: impl std::fmt::Display) -> RenderError {
    RenderError::Unsupported { technique: technique.to_owned(), message: format!("on the GPU: {e}") }
}

/// The exact tracer's side of a GPU technique: the shared context, the compiled kernels and the
/// current frame's scene in GPU buffers.
pub struct GpuExact {
    pub gpu: Arc<GpuContext>,
    tracer: Option<GpuTracer>,
    scene: Option<GpuScene>,
    /// Kernel times of the last render (empty without timestamp queries).
    pub last_times: Vec<crate::KernelTime>,
}

impl GpuExact {
    pub fn new(gpu: Arc<GpuContext>) -> Self {
        Self { gpu, tracer: None, scene: None, last_times: Vec::new() }
    }

    /// Compiles the kernels on first use and uploads the frame: every frame when the scene
    /// moves, once when it is static (its geometry is the same at every time).
    pub fn prepare(&mut self, id: &str, ctx: &FrameContext) -> Result<Stats, RenderError> {
        let mut stats = Stats::default();
        let gpu = &self.gpu;
        if self.tracer.is_none() {
            self.tracer = Some(stats.time("gpu kernels", || GpuTracer::new(gpu)).map_err(|e| render_error(id, e))?);
        }
        let scene = ctx.scene();
        let moving = scene.instances.iter().any(|i| !i.motion.is_static()) || scene.meshes.iter().any(|m| m.deformation.is_some());
        let mut timer = GpuTimer::new(gpu, 1);
        match &mut self.scene {
            Some(_) if !moving => {}
            Some(s) => stats.time("gpu upload", || s.update(gpu, &ctx.frame, &mut timer)).map_err(|e| render_error(id, e))?,
            None => {
                self.scene = Some(stats.time("gpu upload", || GpuScene::new(gpu, &ctx.frame, &mut timer)).map_err(|e| render_error(id, e))?)
            }
        }
        stats.memory_bytes = self.memory_bytes();
        Ok(stats)
    }

    pub fn memory_bytes(&self) -> usize {
        self.scene.as_ref().map_or(0, |s| s.memory_bytes() as usize)
    }

    /// `out[i] = shade(i, vis)` with `vis` the GPU tracer ([`replay::shade_pixels`]); one
    /// progress tick per pixel. Returns the rays traced.
    pub fn shade<F>(&mut self, id: &str, ctx: &FrameContext, out: &mut Image, rays_per_pixel: usize, shade: F) -> Result<u64, RenderError>
    where
        F: Fn(usize, &dyn Visibility) -> Vec3 + Sync,
    {
        let (Some(tracer), Some(scene)) = (self.tracer.as_mut(), self.scene.as_ref()) else {
            return Err(RenderError::Unsupported { technique: id.into(), message: "render called before prepare".into() });
        };
        let Traced { rays, kernel_times } = replay::shade_pixels(&self.gpu, tracer, scene, &mut out.pixels, rays_per_pixel, shade)
            .map_err(|e: GpuError| render_error(id, e))?;
        ctx.progress.add(out.pixels.len() as u64);
        self.last_times = kernel_times;
        Ok(rays)
    }
}

/// Rejects an image that does not match the GBuffer (the CPU pixel loop's check).
fn check_size(id: &str, gbuffer: &GBuffer, out: &Image) -> Result<(), RenderError> {
    if (out.width, out.height) != (gbuffer.width, gbuffer.height) {
        return Err(RenderError::Unsupported {
            technique: id.into(),
            message: format!("image is {}x{} but the GBuffer is {}x{}", out.width, out.height, gbuffer.width, gbuffer.height),
        });
    }
    Ok(())
}

/// A pixel as `direct::shade_pixels` makes it: the background where the GBuffer sees nothing,
/// else the emission plus `shade(shading point, pixel's Rng)`.
fn direct_pixel(ctx: &FrameContext, gbuffer: &GBuffer, seed: u64, i: usize, shade: impl FnOnce(&Shading, &mut Rng) -> Vec3) -> Vec3 {
    match Shading::from_gbuffer(gbuffer, i) {
        Some(s) => {
            let mut rng = Rng::for_pixel(seed, i as u64, ctx.frame_index as u64);
            gbuffer.emission[i] + shade(&s, &mut rng)
        }
        None => direct::background(&ctx.frame, gbuffer.view_dir[i]),
    }
}

/// `ao-exact` on the GPU.
pub struct GpuAoExact {
    cpu: AoExact,
    exact: GpuExact,
}

impl GpuAoExact {
    pub fn new(gpu: Arc<GpuContext>, _scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        Ok(Self { cpu: AoExact::new(settings, params)?, exact: GpuExact::new(gpu) })
    }
}

impl Technique for GpuAoExact {
    fn id(&self) -> &'static str {
        "ao-exact"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        self.exact.prepare("ao-exact", ctx)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        check_size("ao-exact", gbuffer, out)?;
        let mut stats = Stats { memory_bytes: self.exact.memory_bytes(), ..Default::default() };
        let (spp, radius, seed, pass) = (self.cpu.settings.spp, self.cpu.radius, self.cpu.settings.seed, ctx.frame_index as u64);
        // `glimpse_render::ao::ambient_occlusion`'s pixel, line for line.
        let shade = |i: usize, vis: &dyn Visibility| {
            let Some((p, n, e)) = gbuffer.point(i) else { return Vec3::ONE };
            let frame = Frame::from_z(n);
            let mut rng = Rng::for_pixel(seed, i as u64, pass);
            let open =
                (0..spp).filter(|_| !vis.occluded(&Ray::spawn(p, n, e, frame.to_world(cosine_hemisphere(rng.next_2d()))), radius)).count();
            Vec3::splat(open as f32 / spp as f32)
        };
        stats.rays = stats.time("trace", || self.exact.shade("ao-exact", ctx, out, spp as usize, shade))?;
        Ok(stats)
    }
}

/// `lights-exact` on the GPU.
pub struct GpuLightsExact {
    cpu: LightsExact,
    exact: GpuExact,
}

impl GpuLightsExact {
    pub fn new(gpu: Arc<GpuContext>, scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        glimpse_render::require(scene, "lights-exact", Need::PunctualLights)?;
        Ok(Self { cpu: LightsExact::new(scene, settings, params)?, exact: GpuExact::new(gpu) })
    }
}

impl Technique for GpuLightsExact {
    fn id(&self) -> &'static str {
        "lights-exact"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        self.exact.prepare("lights-exact", ctx)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        check_size("lights-exact", gbuffer, out)?;
        let mut stats = Stats { memory_bytes: self.exact.memory_bytes(), ..Default::default() };
        let lights = &ctx.frame.lights[..ctx.frame.lights.len().min(self.cpu.lights as usize)];
        let seed = self.cpu.settings.seed;
        let shade = |i: usize, vis: &dyn Visibility| {
            direct_pixel(ctx, gbuffer, seed, i, |s, _| s.albedo / PI * direct::punctual_irradiance(lights, vis, s).0)
        };
        stats.rays = stats.time("shade", || self.exact.shade("lights-exact", ctx, out, lights.len(), shade))?;
        Ok(stats)
    }
}

/// `env-exact` on the GPU.
pub struct GpuEnvExact {
    cpu: EnvExact,
    exact: GpuExact,
}

impl GpuEnvExact {
    pub fn new(gpu: Arc<GpuContext>, scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        glimpse_render::require(scene, "env-exact", Need::Environment)?;
        Ok(Self { cpu: EnvExact::new(settings, params)?, exact: GpuExact::new(gpu) })
    }

    /// Rays per pixel (`rays`, N_r).
    pub fn rays(&self) -> u32 {
        self.cpu.rays
    }

    /// Per-kernel GPU times of the last render (timestamps; empty without them).
    pub fn last_times(&self) -> &[crate::KernelTime] {
        &self.exact.last_times
    }
}

impl Technique for GpuEnvExact {
    fn id(&self) -> &'static str {
        "env-exact"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        self.exact.prepare("env-exact", ctx)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        check_size("env-exact", gbuffer, out)?;
        let mut stats = Stats { memory_bytes: self.exact.memory_bytes(), ..Default::default() };
        let env = ctx.frame.scene.environment.as_ref();
        let (n, seed, cpu) = (self.cpu.rays, self.cpu.settings.seed, &self.cpu);
        // `EnvExact`'s own pixel, with `vis` for the CPU tracer.
        let shade = |i: usize, vis: &dyn Visibility| {
            direct_pixel(ctx, gbuffer, seed, i, |s, rng| env.map_or(Vec3::ZERO, |env| cpu.shade_point(s, env, rng, vis).0))
        };
        stats.rays = stats.time("shade", || self.exact.shade("env-exact", ctx, out, n as usize, shade))?;
        Ok(stats)
    }
}
