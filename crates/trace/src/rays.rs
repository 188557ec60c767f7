//! Reusable, seeded ray sets for benchmarks and cross-checks: every backend (the exact tracer,
//! Embree, `obvhs`, the approximate techniques) is timed and compared on the *same* rays.
//!
//! All three sets start from the points of a [`GBuffer`] (the camera's primary hits), in pixel
//! order, with each pixel's random numbers drawn from its own [`Rng::for_pixel`] stream, so a
//! set depends only on the scene, the camera, the resolution and the seed — not on threads.
//! Origins go through [`GBuffer::spawn`], directions are unit vectors, and each ray comes with the
//! `t_max` of its query.
//!
//! - [`ao_rays`]: ambient occlusion, cosine-weighted around the geometric normal, `t_max` = radius.
//! - [`shadow_rays`]: towards every punctual light and to random points on emissive triangles,
//!   `t_max` = distance·(1−1e-4) so the light's own surface is not counted as a blocker.
//! - [`bounce_rays`]: a diffuse bounce, cosine-weighted around the shading normal, `t_max` = ∞.

use crate::{ExactTracer, GBuffer, SceneFrame};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Ray, Rng, Vec3};
use glimpse_scene::{Camera, LightKind};

/// `Rng::for_pixel` pass numbers, so the three sets differ for the same seed.
const PASS_AO: u64 = 0;
const PASS_SHADOW: u64 = 1;
const PASS_BOUNCE: u64 = 2;

/// Shadow rays stop this fraction short of their target.
pub const SHADOW_SHORTEN: f32 = 1e-4;

/// `rays_per_pixel` ambient-occlusion rays from each GBuffer point of a `width × height` view:
/// cosine-weighted in the hemisphere of the geometric normal, `t_max = radius` (∞ allowed).
#[allow(clippy::too_many_arguments)]
pub fn ao_rays(
    frame: &SceneFrame,
    tracer: &ExactTracer,
    camera: &Camera,
    width: u32,
    height: u32,
    rays_per_pixel: u32,
    radius: f32,
    seed: u64,
) -> Vec<(Ray, f32)> {
    ao_rays_from(&GBuffer::new(frame, tracer, camera, width, height), rays_per_pixel, radius, seed)
}

/// [`ao_rays`] from an existing GBuffer.
pub fn ao_rays_from(gbuffer: &GBuffer, rays_per_pixel: u32, radius: f32, seed: u64) -> Vec<(Ray, f32)> {
    let mut rays = Vec::new();
    for i in (0..gbuffer.len()).filter(|&i| gbuffer.is_hit(i)) {
        let n = gbuffer.normal[i];
        let frame = Frame::from_z(n);
        let mut rng = Rng::for_pixel(seed, i as u64, PASS_AO);
        for _ in 0..rays_per_pixel {
            let d = frame.to_world(cosine_hemisphere(rng.next_2d())).normalize_or(n);
            rays.push((gbuffer.spawn(i, d), radius));
        }
    }
    rays
}

/// Shadow rays from each GBuffer point: one to every punctual light (a directional light's
/// ray is infinite) and `area_samples_per_pixel` to uniformly chosen points on emissive
/// triangles (triangles picked by power, as the renderer does).
#[allow(clippy::too_many_arguments)]
pub fn shadow_rays(
    frame: &SceneFrame,
    tracer: &ExactTracer,
    camera: &Camera,
    width: u32,
    height: u32,
    area_samples_per_pixel: u32,
    seed: u64,
) -> Vec<(Ray, f32)> {
    shadow_rays_from(frame, &GBuffer::new(frame, tracer, camera, width, height), area_samples_per_pixel, seed)
}

/// [`shadow_rays`] from an existing GBuffer of `frame`.
pub fn shadow_rays_from(frame: &SceneFrame, gbuffer: &GBuffer, area_samples_per_pixel: u32, seed: u64) -> Vec<(Ray, f32)> {
    let mut rays = Vec::new();
    for i in (0..gbuffer.len()).filter(|&i| gbuffer.is_hit(i)) {
        for light in &frame.lights {
            match light.kind {
                LightKind::Directional => rays.push((gbuffer.spawn(i, -light.direction), f32::INFINITY)),
                LightKind::Point | LightKind::Spot { .. } => rays.extend(segment(gbuffer, i, light.position)),
            }
        }
        let Some(dist) = &frame.emissive_distribution else { continue };
        let mut rng = Rng::for_pixel(seed, i as u64, PASS_SHADOW);
        for _ in 0..area_samples_per_pixel {
            let (k, _) = dist.sample_discrete(rng.next_f32());
            let target = frame.emissive[k].sample_point(rng.next_2d());
            rays.extend(segment(gbuffer, i, target));
        }
    }
    rays
}

/// The shadow ray from pixel `i`'s surface point to `target`, if they are apart.
fn segment(gbuffer: &GBuffer, i: usize, target: Vec3) -> Option<(Ray, f32)> {
    let dir = (target - gbuffer.position[i]).try_normalize()?;
    let mut ray = gbuffer.spawn(i, dir);
    let to = target - ray.origin;
    let distance = to.length();
    ray.dir = to.try_normalize()?;
    Some((ray, distance * (1.0 - SHADOW_SHORTEN)))
}

/// `rays_per_pixel` diffuse-bounce rays from each GBuffer point: cosine-weighted around the
/// shading normal, `t_max = ∞`.
#[allow(clippy::too_many_arguments)]
pub fn bounce_rays(
    frame: &SceneFrame,
    tracer: &ExactTracer,
    camera: &Camera,
    width: u32,
    height: u32,
    rays_per_pixel: u32,
    seed: u64,
) -> Vec<(Ray, f32)> {
    bounce_rays_from(&GBuffer::new(frame, tracer, camera, width, height), rays_per_pixel, seed)
}

/// [`bounce_rays`] from an existing GBuffer.
pub fn bounce_rays_from(gbuffer: &GBuffer, rays_per_pixel: u32, seed: u64) -> Vec<(Ray, f32)> {
    let mut rays = Vec::new();
    for i in (0..gbuffer.len()).filter(|&i| gbuffer.is_hit(i)) {
        let ns = gbuffer.shading_normal[i];
        let frame = Frame::from_z(ns);
        let mut rng = Rng::for_pixel(seed, i as u64, PASS_BOUNCE);
        for _ in 0..rays_per_pixel {
            let d = frame.to_world(cosine_hemisphere(rng.next_2d())).normalize_or(ns);
            rays.push((gbuffer.spawn(i, d), f32::INFINITY));
        }
    }
    rays
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_scene::Scene;

    fn cornell() -> Scene {
        glimpse_scene::load("cornell").unwrap()
    }

    #[test]
    fn every_set_is_deterministic_for_a_seed_and_changes_with_it() {
        let scene = cornell();
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let cam = scene.camera_or_default(1.0);
        type Gen<'a> = Box<dyn Fn(u64) -> Vec<(Ray, f32)> + 'a>;
        let sets: [(&str, Gen); 3] = [
            ("ao", Box::new(|s| ao_rays(&frame, &tracer, &cam, 32, 32, 2, 0.5, s))),
            ("shadow", Box::new(|s| shadow_rays(&frame, &tracer, &cam, 32, 32, 2, s))),
            ("bounce", Box::new(|s| bounce_rays(&frame, &tracer, &cam, 32, 32, 2, s))),
        ];
        for (name, generate) in &sets {
            let (a, b, c) = (generate(7), generate(7), generate(8));
            assert!(!a.is_empty(), "{name}: no rays");
            assert_eq!(a, b, "{name}: same seed, different rays");
            assert_ne!(a, c, "{name}: another seed gives the same rays");
            assert!(a.iter().all(|(r, _)| (r.dir.length() - 1.0).abs() < 1e-4), "{name}: directions are not unit");
        }
    }

    #[test]
    fn ao_rays_stay_in_the_normals_hemisphere_and_leave_the_surface() {
        let scene = cornell();
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), 48, 48);
        let per_pixel = 3;
        let rays = ao_rays_from(&g, per_pixel, 0.25, 1);
        let hits: Vec<usize> = (0..g.len()).filter(|&i| g.is_hit(i)).collect();
        assert_eq!(rays.len(), hits.len() * per_pixel as usize);
        for (k, (ray, t_max)) in rays.iter().enumerate() {
            let i = hits[k / per_pixel as usize];
            assert!(ray.dir.dot(g.normal[i]) >= 0.0, "AO ray below its surface");
            assert!((ray.origin - g.position[i]).dot(g.normal[i]) > 0.0, "origin not pushed off the surface");
            assert_eq!(*t_max, 0.25);
        }
    }

    #[test]
    fn shadow_rays_stop_just_short_of_their_targets() {
        let scene = cornell();
        let frame = scene.at(0.0);
        assert!(!frame.emissive.is_empty(), "the Cornell box has an area light");
        let tracer = ExactTracer::build(&frame);
        let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), 24, 24);
        let rays = shadow_rays_from(&frame, &g, 4, 3);
        assert!(!rays.is_empty());
        for (ray, t_max) in &rays {
            // The end point lies (within rounding) on an emissive triangle's plane or at a light.
            let end = ray.at(*t_max / (1.0 - SHADOW_SHORTEN));
            let on_light = frame.emissive.iter().any(|e| (end - e.vertices[0]).dot(e.normal).abs() < 1e-3)
                || frame.lights.iter().any(|l| (end - l.position).length() < 1e-3);
            assert!(on_light, "shadow ray does not end on a light: {end}");
            // Not blocked by the light itself.
            assert!(t_max.is_finite() && *t_max > 0.0);
        }
    }

    #[test]
    fn bounce_rays_are_infinite_and_follow_the_shading_normal() {
        let scene = cornell();
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), 24, 24);
        let rays = bounce_rays_from(&g, 2, 5);
        let hits: Vec<usize> = (0..g.len()).filter(|&i| g.is_hit(i)).collect();
        assert_eq!(rays.len(), hits.len() * 2);
        for (k, (ray, t_max)) in rays.iter().enumerate() {
            assert_eq!(*t_max, f32::INFINITY);
            assert!(ray.dir.dot(g.shading_normal[hits[k / 2]]) >= 0.0, "bounce ray below its shading normal");
        }
    }
}
