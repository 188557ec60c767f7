//! The GBuffer: what the camera sees through one primary sample per pixel (placed by the film's
//! pixel filter, or at the pixel centre), found with exact primary rays.
//! Every technique shades the same GBuffer as its reference, so their difference is only the
//! technique's own approximation. Stored as flat per-attribute arrays (GPU-friendly).

use crate::{ExactTracer, SceneFrame, SurfacePoint};
use glimpse_core::{Ray, Rng, Vec2, Vec3};
use glimpse_scene::{Camera, Filter};
use rayon::prelude::*;

/// The stream film sample positions are drawn from (independent of any technique's seed).
const FILM_SEED: u64 = 0xf11_5a3e;

/// Instance id of pixels that see no geometry.
pub const NO_HIT: u32 = u32::MAX;

#[derive(Clone, Debug)]
pub struct GBuffer {
    pub width: u32,
    pub height: u32,
    pub camera: Camera,
    pub position: Vec<Vec3>,
    /// The magnitude each position's rounding error is relative to ([`SurfacePoint::error_scale`]).
    pub error_scale: Vec<f32>,
    /// Geometric normal facing the camera.
    pub normal: Vec<Vec3>,
    /// Interpolated normal in the geometric normal's hemisphere.
    pub shading_normal: Vec<Vec3>,
    /// Distance along the primary ray (∞ on a miss).
    pub depth: Vec<f32>,
    pub material: Vec<u32>,
    /// Instance id, or [`NO_HIT`].
    pub instance: Vec<u32>,
    pub uv: Vec<Vec2>,
    /// Base colour × texture.
    pub albedo: Vec<Vec3>,
    /// Emitted radiance towards the camera.
    pub emission: Vec<Vec3>,
    /// Unit direction of each pixel's primary ray (so misses can look up the environment).
    pub view_dir: Vec<Vec3>,
}

impl GBuffer {
    /// Through every pixel's centre.
    pub fn new(frame: &SceneFrame, tracer: &ExactTracer, camera: &Camera, width: u32, height: u32) -> GBuffer {
        Self::sampled(frame, tracer, camera, width, height, Filter::PixelCentre, 0)
    }

    /// Through primary sample `pass` of every pixel: an offset from the pixel centre drawn from
    /// `filter` with random numbers that depend only on the pixel and the pass, so every
    /// technique and its reference shade the same samples.
    pub fn sampled(
        frame: &SceneFrame,
        tracer: &ExactTracer,
        camera: &Camera,
        width: u32,
        height: u32,
        filter: Filter,
        pass: u32,
    ) -> GBuffer {
        let camera_ray = |i: usize| {
            let (x, y) = (i as u32 % width, i as u32 / width);
            let offset = filter.sample(Rng::for_pixel(FILM_SEED, i as u64, pass as u64).next_2d());
            Some(camera.ray(x as f32 + 0.5 + offset.x, y as f32 + 0.5 + offset.y, width, height))
        };
        let texels: Vec<(Ray, Option<SurfacePoint>)> = tracer
            .closest_hits_tiled(width, height, camera_ray)
            .into_par_iter()
            .map(|texel| {
                let (ray, hit) = texel.expect("every pixel has a camera ray");
                (ray, hit.map(|h| SurfacePoint::from_hit(frame, &ray, &h)))
            })
            .collect();
        let n = texels.len();
        let mut g = GBuffer {
            width,
            height,
            camera: camera.clone(),
            position: Vec::with_capacity(n),
            error_scale: Vec::with_capacity(n),
            normal: Vec::with_capacity(n),
            shading_normal: Vec::with_capacity(n),
            depth: Vec::with_capacity(n),
            material: Vec::with_capacity(n),
            instance: Vec::with_capacity(n),
            uv: Vec::with_capacity(n),
            albedo: Vec::with_capacity(n),
            emission: Vec::with_capacity(n),
            view_dir: Vec::with_capacity(n),
        };
        for (ray, sp) in texels {
            g.view_dir.push(ray.dir);
            match sp {
                Some(s) => {
                    g.position.push(s.position);
                    g.error_scale.push(s.error_scale);
                    g.normal.push(s.normal);
                    g.shading_normal.push(s.shading_normal);
                    g.depth.push((s.position - ray.origin).length());
                    g.material.push(s.material);
                    g.instance.push(s.instance);
                    g.uv.push(s.uv);
                    g.albedo.push(s.base_color(frame));
                    g.emission.push(s.emission(frame));
                }
                None => {
                    g.position.push(Vec3::ZERO);
                    g.error_scale.push(0.0);
                    g.normal.push(Vec3::ZERO);
                    g.shading_normal.push(Vec3::ZERO);
                    g.depth.push(f32::INFINITY);
                    g.material.push(0);
                    g.instance.push(NO_HIT);
                    g.uv.push(Vec2::ZERO);
                    g.albedo.push(Vec3::ZERO);
                    g.emission.push(Vec3::ZERO);
                }
            }
        }
        g
    }

    pub fn len(&self) -> usize {
        self.depth.len()
    }

    pub fn is_empty(&self) -> bool {
        self.depth.is_empty()
    }

    pub fn is_hit(&self, i: usize) -> bool {
        self.instance[i] != NO_HIT
    }

    /// A secondary ray leaving pixel `i`'s surface along `dir`.
    pub fn spawn(&self, i: usize, dir: Vec3) -> Ray {
        Ray::spawn(self.position[i], self.normal[i], self.error_scale[i], dir)
    }

    /// The surface point of pixel `i`, its shading normal and its error scale, if it sees
    /// geometry (for spawning secondary rays).
    pub fn point(&self, i: usize) -> Option<(Vec3, Vec3, f32)> {
        self.is_hit(i).then(|| (self.position[i], self.shading_normal[i], self.error_scale[i]))
    }
}
