//! `ao-df` and `soft-df`: the same shading as `ao-roma` and `soft-roma` (same samples, same
//! 1.5-cell offsets of the segment ends along the surface normals, same accumulation over
//! frames), with the
//! distance field's sphere tracing as the visibility. Rays are traced along their own direction
//! (a distance field needs no snapping). `soft-df` defaults to 16 iterations, the setting of the
//! paper's soft-shadow timing (§7.3); `ao-df` to 64 (§6).

use crate::{DfParams, DfScene, SphereTraceParams};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Image, Rng, Vec3};
use glimpse_render::direct::area_light_segment;
use glimpse_render::direct::{self, Shading};
use glimpse_render::focus::FocusCache;
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_scene::Scene;
use glimpse_trace::GBuffer;
use glimpse_voxel::{Accumulator, DEFAULT_ACCUMULATE};
use rayon::prelude::*;
use std::f32::consts::PI;

struct DfState {
    params: DfParams,
    settings: Settings,
    df: Option<DfScene>,
    focus: FocusCache,
    accumulator: Accumulator,
}

impl DfState {
    fn new(settings: &Settings, params: &Params, defaults: DfParams) -> Result<Self, RenderError> {
        direct::require_spp(settings)?;
        let p = defaults.read(params)?;
        let window = params.u32("accumulate", DEFAULT_ACCUMULATE, 1, 1 << 20)?;
        Ok(Self { params: p, settings: *settings, df: None, focus: FocusCache::default(), accumulator: Accumulator::new(window) })
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        // The BOM (R³ bits), the jump flood's seed per cell (4 B) and the field's three levels of
        // u16 (R³ · (1 + 1/8 + 1/64) · 2 B < 3 B per cell).
        let r = self.params.resolution as u64;
        glimpse_core::memory_budget::check(format!("the {r}³ distance field"), r * r * r * 7 + r * r * r / 8)?;
        let df = DfScene::build_cached(&ctx.frame, &self.params, &mut self.focus, self.settings.seed, ctx.frame_index);
        let mut stats = Stats { memory_bytes: df.field.memory_bytes(), ..Default::default() };
        if self.params.focus {
            stats.stage("focus", df.timings.focus_ms);
        }
        stats.stage("bom", df.timings.voxelize_ms);
        stats.stage("jump flood", df.timings.jump_flood_ms);
        stats.metrics.push(("cell_m".to_owned(), df.cell_size_world() as f64));
        if let Some(share) = df.focus_share {
            stats.metrics.push(("focus_share".to_owned(), share as f64));
        }
        self.df = Some(df);
        Ok(stats)
    }

    fn df(&self, id: &str) -> Result<&DfScene, RenderError> {
        self.df.as_ref().ok_or_else(|| RenderError::Unsupported { technique: id.into(), message: "render called before prepare".into() })
    }
}

/// `ao-df`.
pub struct AoDf {
    state: DfState,
    pub radius: f32,
}

impl AoDf {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "ao-df",
            family: "ambient occlusion",
            reference: Some("ao-exact"),
            description: "distance-field AO (the ROMA paper's baseline): 3D jump flooding on the same BOM, 3 mips, sphere tracing (resolution=128 steps=64 focus=auto as ao-roma)",
            create: |_: &Scene, settings, params| Ok(Box::new(AoDf::new(settings, params)?)),
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let state = DfState::new(settings, params, DfParams::default())?;
        Ok(Self { state, radius: params.f32("radius", f32::INFINITY, 0.0, f32::INFINITY)? })
    }
}

impl Technique for AoDf {
    fn id(&self) -> &'static str {
        "ao-df"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        self.state.prepare(ctx)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let df = self.state.df("ao-df")?;
        let mut stats = Stats { memory_bytes: df.field.memory_bytes(), ..Default::default() };
        let (spp, seed, radius, frame_index) = (self.state.settings.spp, self.state.settings.seed, self.radius, ctx.frame_index);
        let offset = df.params.origin_offset_cells * df.cell_size_world();
        stats.rays = stats.time("trace", || {
            let width = gbuffer.width as usize;
            out.pixels.par_chunks_mut(width).enumerate().for_each(|(row, pixels)| {
                for (x, px) in pixels.iter_mut().enumerate() {
                    let i = row * width + x;
                    if !gbuffer.is_hit(i) {
                        *px = Vec3::ONE;
                        continue;
                    }
                    let origin = gbuffer.position[i] + gbuffer.normal[i] * offset;
                    let basis = Frame::from_z(gbuffer.shading_normal[i]);
                    let mut rng = Rng::for_pixel(seed, i as u64, frame_index as u64);
                    let open = (0..spp).filter(|_| !df.blocked(origin, basis.to_world(cosine_hemisphere(rng.next_2d())), radius)).count();
                    *px = Vec3::splat(open as f32 / spp as f32);
                }
                ctx.progress.add(pixels.len() as u64);
            });
            gbuffer.instance.iter().filter(|&&i| i != glimpse_trace::gbuffer::NO_HIT).count() as u64 * spp as u64
        });
        stats.time("accumulate", || self.state.accumulator.blend(ctx.frame_index, out));
        Ok(stats)
    }
}

/// `soft-df`.
pub struct SoftDf {
    state: DfState,
}

impl SoftDf {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "soft-df",
            family: "soft shadows",
            reference: Some("soft-exact"),
            description: "distance-field soft shadows (the ROMA paper's baseline): area-light samples as soft-exact, sphere-traced shadow rays (steps=16 focus=auto)",
            create: |scene: &Scene, settings, params| {
                glimpse_render::require(scene, "soft-df", glimpse_render::Need::AreaLights)?;
                Ok(Box::new(SoftDf::new(settings, params)?))
            },
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let defaults = DfParams { trace: SphereTraceParams { max_steps: 16, ..SphereTraceParams::default() }, ..DfParams::default() };
        Ok(Self { state: DfState::new(settings, params, defaults)? })
    }
}

impl Technique for SoftDf {
    fn id(&self) -> &'static str {
        "soft-df"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        self.state.prepare(ctx)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let df = self.state.df("soft-df")?;
        let mut stats = Stats { memory_bytes: df.field.memory_bytes(), ..Default::default() };
        let (spp, seed) = (self.state.settings.spp, self.state.settings.seed);
        let offset = df.params.origin_offset_cells * df.cell_size_world();
        let frame = &ctx.frame;
        stats.rays = stats.time("trace", || {
            direct::shade_pixels(ctx, gbuffer, seed, out, |i, rng| {
                let Some(s) = Shading::from_gbuffer(gbuffer, i) else {
                    return (Vec3::ZERO, 0);
                };
                let (mut e, mut rays) = (Vec3::ZERO, 0u64);
                for _ in 0..spp {
                    let Some((ls, from, to)) = area_light_segment(frame, &s, rng.next_f32(), rng.next_2d(), offset) else { continue };
                    rays += 1;
                    let d = to - from;
                    let len = d.length();
                    if len <= 0.0 || !df.blocked(from, d / len, len) {
                        e += ls.radiance * (s.cos(ls.wi) / ls.pdf);
                    }
                }
                (s.albedo / PI * e / spp as f32, rays)
            })
        })?;
        stats.time("accumulate", || self.state.accumulator.blend(ctx.frame_index, out));
        Ok(stats)
    }
}
