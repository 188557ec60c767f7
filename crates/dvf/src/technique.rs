//! `env-dvf`: the runtime of Xu et al.'s Algorithm 3 (the paper's §2.1.2, "used as-is") on the
//! field built in `prepare` every frame, with the spec's corrections: the occluded-region test
//! belongs to the `l_occ = 0` branch (E2) and `E = E_unshad − E_occ` comes after the ray loop
//! (E3; the prose's "l_occ = 1" there is also E3).
//!
//! Per pixel: the cell c of the surface point; the same N_r rays as `env-exact` (same pixel RNG,
//! same Hammersley set, same rotation, same spawn, same below-surface rule); then
//! - `l_occ(c) = 1`: trace only rays whose octahedral pixel is set in O_c^V; E = (1/N_r) Σ_miss L;
//! - `l_occ(c) = 0`: trace only rays set in O_c^O; E = E_unshad(n) − (1/N_r) Σ_hit L,
//!
//! and L_out = ρ E. `unknown=trace` (a deviation, not the paper) also traces rays whose pixel is
//! set in neither mask (directions no sample of the cell saw, e.g. in under-sampled cells, which
//! the paper's rule shades unshadowed or black). Normalisation (spec §3.2): (1/N_r) Σ L V estimates E/π under cosine-weighted
//! rays, so E_unshad is the SH irradiance ÷ π. L_i(ω) of traced rays is the map's radiance (as the
//! reference), not its SH reconstruction. Choices where the paper is silent: E is clamped at 0
//! per channel (SH ringing can make E_unshad − E_occ negative); the SH coefficients are projected
//! from the map's texels once (stage "sh", the paper's "precomputed constant values").

use crate::rays::RaySet;
use crate::{Dvf, DvfParams, Unshadowed};
use glimpse_core::sh::Sh9;
use glimpse_core::{Image, Vec3};
use glimpse_render::direct::{self, Shading};
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_scene::{Environment, Scene};
use glimpse_trace::{GBuffer, Visibility};
use rayon::prelude::*;
use std::f32::consts::{PI, TAU};

pub struct EnvDvf {
    pub params: DvfParams,
    pub settings: Settings,
    /// This frame's field (after `prepare`).
    pub dvf: Option<Dvf>,
    /// SH of the environment (projected on the first `prepare`).
    pub sh: Option<Sh9>,
    /// Forces every cell's label (tests of the estimator identities); `None`: the field's.
    pub force_label: Option<u8>,
    /// The map's relative N_r-ray noise, when `unshadowed=auto` measured it.
    pub map_noise: Option<f32>,
}

impl EnvDvf {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "env-dvf",
            family: "environment lighting",
            reference: Some("env-exact"),
            description: "discrete visibility field rebuilt per frame (Günay and Akyüz 2025 / Xu et al. 2022): rays=128 points=10000000 grid=77 octahedral=8 sampling=hash|hammersley rounding=ceil|round rotation=cp|normal; ours: unknown=skip|trace unshadowed=auto|sh|rays sides=both|front build_rays; profile=paper (sides=front)",
            create: |scene: &Scene, settings, params| {
                glimpse_render::technique::require(scene, "env-dvf", glimpse_render::technique::Need::Environment)?;
                Ok(Box::new(EnvDvf::new(settings, params)?))
            },
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        Ok(Self {
            params: DvfParams::default().read(params)?,
            settings: *settings,
            dvf: None,
            sh: None,
            force_label: None,
            map_noise: None,
        })
    }
}

/// Order-2 SH of the environment's radiance, by midpoint quadrature over an equirectangular grid
/// of at least the map's resolution (and at least 128×64, so that tiny maps such as a constant
/// 1×1 are integrated through `radiance`'s bilinear lookup, not as one texel).
pub fn project_environment(env: &Environment) -> Sh9 {
    let (w, h) = (env.image.width.max(128), env.image.height.max(64));
    let rows: Vec<Sh9> = (0..h)
        .into_par_iter()
        .map(|y| {
            let th0 = PI * y as f32 / h as f32;
            let th1 = PI * (y + 1) as f32 / h as f32;
            let d_omega = TAU / w as f32 * (th0.cos() - th1.cos());
            let mut sh = Sh9::default();
            for x in 0..w {
                let d = Environment::uv_to_dir(glimpse_core::Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32));
                sh.add_sample(d, env.radiance(d), d_omega);
            }
            sh
        })
        .collect();
    let mut sum = Sh9::default();
    for r in rows {
        for (c, v) in sum.coeffs.iter_mut().zip(r.coeffs) {
            *c += v;
        }
    }
    sum
}

/// The exact estimate `env-exact` makes with this ray set: (1/N_r) Σ_unoccluded L (rays traced).
pub fn brute_force(vis: &dyn Visibility, env: &Environment, s: &Shading, set: &RaySet) -> (Vec3, u64) {
    let (mut sum, mut rays) = (Vec3::ZERO, 0u64);
    for k in 0..set.count {
        let d = set.direction(k);
        if s.cos(d) <= 0.0 {
            continue;
        }
        rays += 1;
        if !vis.occluded(&s.spawn(d), f32::INFINITY) {
            sum += env.radiance(d) * (1.0 / set.count as f32);
        }
    }
    (sum, rays)
}

/// What the runtime needs besides the field.
pub struct Runtime<'a> {
    pub dvf: &'a Dvf,
    pub vis: &'a dyn Visibility,
    pub env: &'a Environment,
    pub sh: &'a Sh9,
    pub unshadowed: Unshadowed,
    /// Also trace rays whose pixel is in neither mask (`unknown=trace`; the paper skips them).
    pub trace_unknown: bool,
    pub force_label: Option<u8>,
}

impl Runtime<'_> {
    /// Algorithm 3 for one fragment: (E/π, rays traced).
    pub fn irradiance(&self, s: &Shading, set: &RaySet) -> (Vec3, u64) {
        let cell = self.dvf.grid.cell_of(s.position);
        let label = self.force_label.unwrap_or(self.dvf.labels[cell]);
        let r = self.dvf.masks.resolution;
        let inv = 1.0 / set.count as f32;
        let (mut sum, mut unshadowed, mut rays) = (Vec3::ZERO, Vec3::ZERO, 0u64);
        for k in 0..set.count {
            let d = set.direction(k);
            if s.cos(d) <= 0.0 {
                continue;
            }
            let pixel = crate::grid::octahedral_pixel(d, r);
            let (v, o) = self.dvf.masks.bits(cell, pixel);
            if label == 1 {
                // Mostly occluded: trace inside the visible region, add what escapes.
                if v || (self.trace_unknown && !o) {
                    rays += 1;
                    if !self.vis.occluded(&s.spawn(d), f32::INFINITY) {
                        sum += self.env.radiance(d) * inv;
                    }
                }
            } else {
                if self.unshadowed == Unshadowed::Rays {
                    unshadowed += self.env.radiance(d) * inv;
                }
                // Mostly visible: trace inside the occluded region, add what is blocked.
                if o || (self.trace_unknown && !v) {
                    rays += 1;
                    if self.vis.occluded(&s.spawn(d), f32::INFINITY) {
                        sum += self.env.radiance(d) * inv;
                    }
                }
            }
        }
        if label == 1 {
            return (sum, rays);
        }
        let e_unshad = match self.unshadowed {
            Unshadowed::Sh => self.sh.irradiance(s.shading_normal) / PI,
            Unshadowed::Rays => unshadowed,
        };
        ((e_unshad - sum).max(Vec3::ZERO), rays)
    }
}

impl Technique for EnvDvf {
    fn id(&self) -> &'static str {
        "env-dvf"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        let mut stats = Stats::default();
        if let (None, Some(env)) = (&self.sh, ctx.frame.scene.environment.as_ref()) {
            self.sh = Some(stats.time("sh", || project_environment(env)));
            if self.params.auto.unshadowed {
                // Once per map, as the SH: how noisy N_r rays of it are decides E_unshad's source.
                let noise = stats.time("map noise", || crate::cosine_estimator_noise(env, self.params.rays));
                self.params.unshadowed = crate::choose_unshadowed(noise);
                self.map_noise = Some(noise);
            }
        }
        if let Some(noise) = self.map_noise {
            stats.metrics.push(("map_noise".to_owned(), noise as f64));
            stats.metrics.push(("unshadowed_rays".to_owned(), (self.params.unshadowed == Unshadowed::Rays) as u8 as f64));
        }
        let reuse = self.dvf.take().map(|d| d.masks);
        // The sample budget for this frame's size and triangle count (`points=auto` …).
        let p = self.params.for_frame(ctx.width as u64 * ctx.height as u64, ctx.frame.scene.triangle_count());
        let dvf = Dvf::build(&ctx.frame, &ctx.tracer, &p, self.settings.seed, ctx.frame_index, reuse, &mut stats);
        stats.metrics.push(("points".to_owned(), p.points as f64));
        stats.metrics.push(("grid".to_owned(), p.grid as f64));
        stats.metrics.push(("build_rays".to_owned(), dvf.rays_traced as f64));
        stats.memory_bytes = stats.memory_bytes.max(dvf.memory_bytes());
        self.dvf = Some(dvf);
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let dvf = self
            .dvf
            .as_ref()
            .ok_or_else(|| RenderError::Unsupported { technique: "env-dvf".into(), message: "render called before prepare".into() })?;
        let mut stats = Stats { memory_bytes: dvf.memory_bytes(), ..Default::default() };
        let env = ctx.frame.scene.environment.as_ref();
        let sh = self.sh.unwrap_or_default();
        let (n, about_normal) = (self.params.rays, self.params.rotate_about_normal);
        let rt = env.map(|env| Runtime {
            dvf,
            vis: &ctx.tracer,
            env,
            sh: &sh,
            unshadowed: self.params.unshadowed,
            trace_unknown: self.params.trace_unknown,
            force_label: self.force_label,
        });
        stats.rays = stats.time("shade", || {
            direct::shade_pixels(ctx, gbuffer, self.settings.seed, out, |i, rng| {
                let (Some(s), Some(rt)) = (Shading::from_gbuffer(gbuffer, i), rt.as_ref()) else {
                    return (Vec3::ZERO, 0);
                };
                // The reference's draw: one 2-D shift per pixel.
                let set = RaySet::new(s.shading_normal, n, rng.next_2d(), about_normal);
                let (e, rays) = rt.irradiance(&s, &set);
                (s.albedo * e, rays)
            })
        })?;
        Ok(stats)
    }
}
