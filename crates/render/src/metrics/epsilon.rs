//! The paper's error metrics (§5, Tables 1–4 and 9) for an array on a frame: per pixel with n
//! lights, ε_v = (FV + FI)/n and ε_s = (FV − FI)/n against exact ray tracing, averaged over the
//! pixels that see geometry (|ε_s| averaged; the signed mean too). The reference decisions come
//! from `glimpse_render::lights::light_visibility` with the exact tracer; the test decisions are
//! taken on the same shadow segments (`direct::punctual`, as `lights-exact` and
//! `lights-voxarray` trace them), through the caller's query.
//!
//! Gap: the paper does not say whether lights behind the surface count. [`Epsilon::all`] counts
//! every light at every pixel (n = all lights, the paper's wording); [`Epsilon::facing`] counts
//! only the decisions that reach the image (lights in front of the surface; the others are
//! treated as agreeing), still over n.

use crate::direct::{self, PunctualSample, Shading};
use crate::lights::light_visibility;
use crate::metrics::{ShadowErrors, shadow_errors_from_visibility};
use glimpse_scene::SceneFrame;
use glimpse_trace::{ExactTracer, GBuffer};
use rayon::prelude::*;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epsilon {
    pub lights: usize,
    pub all: ShadowErrors,
    pub facing: ShadowErrors,
}

/// ε of the decisions `occluded(light index, sample, shading)` against `exact` for the first `lights`
/// lights at every GBuffer pixel.
pub fn epsilon(
    frame: &SceneFrame,
    gbuffer: &GBuffer,
    exact: &ExactTracer,
    lights: usize,
    occluded: impl Fn(usize, &PunctualSample, &Shading) -> bool + Sync,
) -> Epsilon {
    let reference = light_visibility(frame, gbuffer, exact, lights);
    let n = reference.lights;
    let words = reference.words_per_pixel;
    let ls = &frame.lights[..n];
    let mut test = vec![0u64; reference.visible.len()];
    if words > 0 {
        test.par_chunks_mut(words).enumerate().for_each(|(i, row)| {
            let Some(s) = Shading::from_gbuffer(gbuffer, i) else { return };
            for (l, light) in ls.iter().enumerate() {
                let ps = direct::punctual(light, s.position, s.normal, s.error_scale);
                if !occluded(l, &ps, &s) {
                    row[l / 64] |= 1 << (l % 64);
                }
            }
        });
    }
    let covered: Vec<bool> = (0..gbuffer.len()).map(|i| gbuffer.is_hit(i)).collect();
    let all = shadow_errors_from_visibility(&test, &reference.visible, n, Some(&covered)).unwrap_or_default();
    let masked = |v: &[u64]| v.iter().zip(&reference.facing).map(|(a, f)| a & f).collect::<Vec<u64>>();
    let facing = shadow_errors_from_visibility(&masked(&test), &masked(&reference.visible), n, Some(&covered)).unwrap_or_default();
    Epsilon { lights: n, all, facing }
}

impl Epsilon {
    /// The measures `glimpse eval` reports (percent): ε_v and |ε_s| over all lights, signed ε_s.
    pub fn to_metrics(&self) -> Vec<(String, f64)> {
        vec![
            ("eps_v_pct".to_owned(), 100.0 * self.all.epsilon_v()),
            ("eps_s_pct".to_owned(), 100.0 * self.all.epsilon_s_abs()),
            ("eps_s_signed_pct".to_owned(), 100.0 * self.all.epsilon_s_signed()),
        ]
    }
}
