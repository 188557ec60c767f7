//! The environment's direct light at glossy pixels (`env_direct`, ours; see
//! [`crate::WavecacheParams::env_direct`]).
//!
//! A radiance map of N² texels cannot resolve a light smaller than a texel (a studio softbox,
//! a sun), and Eq. 20's texel product Σ f̄_q L̄_q then aliases it: a lobe whose peak shares a
//! texel with the softbox reads it whether or not it reaches it. With `env_direct` the maps keep
//! the environment's direct light out and store, per texel, the share of it that arrives
//! unoccluded (weighted by the map's radiance: [`crate::bake::Integrator::radiance_map`]). The
//! runtime then integrates the pixel's own BSDF against the environment map at the map's own
//! resolution, times that visibility, with no rays:
//!
//! ∫ f(ω) cos θ L_env(ω) V(ω) dω ≈ Σ_k f cos L_env V / (n_b p_bsdf + n_e p_env)
//!
//! over n_b BSDF samples and n_e environment samples (Veach's balance heuristic over both).
//!
//! The environment is sampled from its own texels dilated by one (each texel's density is its
//! 3 × 3 neighbourhood's brightest): the map's radiance is bilinear, so a sun's light reaches
//! half a texel into its dim neighbours, where the map's own piecewise-constant density is near
//! zero, and a BSDF sample landing there was a firefly of many times the pixel.

use glimpse_core::distribution::Distribution2D;
use glimpse_core::sampling::{hammersley, rotate_sample};
use glimpse_core::{Rng, Vec2, Vec3, luminance};
use glimpse_render::bsdf::Bsdf;
use glimpse_scene::Environment;
use std::f32::consts::PI;

/// The environment's importance sampler for [`estimate`].
pub struct EnvSampler {
    dist: Distribution2D,
}

impl EnvSampler {
    pub fn new(env: &Environment) -> Self {
        let (w, h) = (env.image.width as usize, env.image.height as usize);
        let lum: Vec<f32> = env.image.pixels.iter().map(|&p| luminance(p).max(0.0)).collect();
        let func: Vec<f32> = (0..h)
            .flat_map(|y| {
                let sin_theta = (PI * (y as f32 + 0.5) / h as f32).sin();
                let lum = &lum;
                (0..w).map(move |x| {
                    let mut m = 0.0f32;
                    for yy in y.saturating_sub(1)..(y + 2).min(h) {
                        for dx in [w - 1, 0, 1] {
                            m = m.max(lum[yy * w + (x + dx) % w]);
                        }
                    }
                    m * sin_theta
                })
            })
            .collect();
        Self { dist: Distribution2D::new(&func, w, h) }
    }

    /// A direction and its solid-angle density (0 where the map is black).
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (uv, pdf_uv) = self.dist.sample(u);
        let sin_theta = (PI * uv.y).sin();
        let d = Environment::uv_to_dir(uv);
        if pdf_uv <= 0.0 || sin_theta <= 0.0 { (d, 0.0) } else { (d, pdf_uv / (2.0 * PI * PI * sin_theta)) }
    }

    pub fn pdf(&self, d: Vec3) -> f32 {
        let uv = Environment::dir_to_uv(d);
        let sin_theta = (PI * uv.y).sin();
        if sin_theta <= 0.0 { 0.0 } else { self.dist.pdf(uv) / (2.0 * PI * PI * sin_theta) }
    }
}

/// ∫ f cos L_env V dω at a point of geometric normal `ng` with BSDF `b`, by `n` samples (half
/// of the BSDF, half of `sampler`). `visibility(ω)` ∈ [0, 1].
pub fn estimate(
    b: &Bsdf,
    ng: Vec3,
    env: &Environment,
    sampler: &EnvSampler,
    visibility: impl Fn(Vec3) -> f32,
    n: u32,
    rng: &mut Rng,
) -> Vec3 {
    let n_bsdf = n / 2;
    let n_env = n - n_bsdf;
    let (nb, ne) = (n_bsdf as f32, n_env as f32);
    // Each strategy's samples are a Hammersley set under a random toroidal shift (per call):
    // stratified, so a small bright source is met about as often as its share says.
    let shifted = |k: u32, count: u32, shift: Vec2| rotate_sample(hammersley(k, count), shift);
    let (shift_bsdf, shift_env) = (rng.next_2d(), rng.next_2d());
    let mut sum = Vec3::ZERO;
    for k in 0..n_bsdf {
        let Some(bs) = b.sample(rng.next_f32(), shifted(k, n_bsdf, shift_bsdf)) else {
            continue;
        };
        if bs.pdf <= 0.0 || bs.wi.dot(ng) <= 0.0 {
            continue;
        }
        let v = visibility(bs.wi);
        if v > 0.0 {
            sum += bs.f * env.radiance(bs.wi) * (bs.cos * v / (nb * bs.pdf + ne * sampler.pdf(bs.wi)));
        }
    }
    for k in 0..n_env {
        let (d, pdf) = sampler.sample(shifted(k, n_env, shift_env));
        let cos = b.cos(d);
        if pdf <= 0.0 || cos <= 0.0 {
            continue;
        }
        let v = visibility(d);
        if v > 0.0 {
            sum += b.eval(d) * env.radiance(d) * (cos * v / (nb * b.pdf(d) + ne * pdf));
        }
    }
    sum
}
