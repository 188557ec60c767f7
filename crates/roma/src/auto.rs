//! `n=auto`, the default angular resolution of `ao-roma` and `gi-roma`, chosen from the scene
//! (ours; the paper's n = 4 is `profile=paper` or `n=4`).
//!
//! A ray is snapped to the nearest of the n² candidate directions, so its hit moves sideways by
//! about its length times the snap angle: nothing for a ray that leaves the scene, most for a
//! ray that crosses a closed room. Measured at 96×64 after 16 frames (FLIP of `ao-roma` against
//! `ao-exact`, n = 4 → 8): `sponza-interior` 0.313 → 0.233, `interior-openings` 0.289 → 0.238,
//! `warehouse-objects` (objects on a ground under the sky) 0.051 → 0.048, `thin-leaves` 0.023 →
//! 0.024, while a frame costs about 3.5× (the n² maps' generation). So n = 8 where most AO rays
//! from the visible surfaces stay in the scene, and the paper's 4 elsewhere.

use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Rng};
use glimpse_scene::{Camera, SceneFrame};
use glimpse_trace::{ExactTracer, GBuffer};

/// Side of the probe GBuffer (32² primary rays, one AO ray each).
const PROBE_SIZE: u32 = 32;
/// Below this share of escaping AO rays the scene counts as closed and gets n = 8.
pub const CLOSED_ESCAPE_FRACTION: f32 = 0.25;

/// The share of cosine-distributed rays from the surfaces the camera sees that hit nothing (1 for
/// a scene the camera sees nothing of).
pub fn escape_fraction(frame: &SceneFrame, tracer: &ExactTracer, camera: &Camera, seed: u64) -> f32 {
    let g = GBuffer::new(frame, tracer, camera, PROBE_SIZE, PROBE_SIZE);
    let (mut hits, mut escaped) = (0u32, 0u32);
    for i in 0..g.len() {
        let Some((p, n, e)) = g.point(i) else { continue };
        let mut rng = Rng::for_pixel(seed, i as u64, 0);
        let dir = Frame::from_z(n).to_world(cosine_hemisphere(rng.next_2d()));
        hits += 1;
        escaped += u32::from(!tracer.occluded(&glimpse_core::Ray::spawn(p, n, e, dir), f32::INFINITY));
    }
    if hits == 0 { 1.0 } else { escaped as f32 / hits as f32 }
}

/// n for a scene whose AO rays escape with share `escape`.
pub fn choose_n(escape: f32) -> u32 {
    if escape < CLOSED_ESCAPE_FRACTION { 8 } else { 4 }
}
