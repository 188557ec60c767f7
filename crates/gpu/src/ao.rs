//! `ao-exact` on the GPU: the CPU technique's rays (`glimpse_render::ao::ambient_occlusion`:
//! per pixel, `spp` cosine-weighted directions around the shading normal from the pixel's own
//! `Rng::for_pixel` stream, spawned off the surface, `t_max = radius`), generated here on the
//! CPU with the same code path and traced by [`GpuTracer::occluded`]. Generating them in WGSL
//! would need a bit-identical port of the RNG, the sampling and the spawn offset; sending rays
//! keeps the image equal to the CPU's by construction of the rays.

use crate::{GpuContext, GpuError, GpuScene, GpuTracer};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Image, Ray, Rng, Vec3};
use glimpse_trace::GBuffer;

/// The AO rays of every GBuffer pixel that sees geometry, pixel by pixel, `spp` each; and the
/// pixels they belong to.
pub fn ao_rays(gbuffer: &GBuffer, spp: u32, radius: f32, seed: u64, pass: u64) -> (Vec<(Ray, f32)>, Vec<usize>) {
    let mut rays = Vec::new();
    let mut pixels = Vec::new();
    for i in 0..gbuffer.len() {
        let Some((p, n, e)) = gbuffer.point(i) else { continue };
        let frame = Frame::from_z(n);
        let mut rng = Rng::for_pixel(seed, i as u64, pass);
        for _ in 0..spp {
            rays.push((Ray::spawn(p, n, e, frame.to_world(cosine_hemisphere(rng.next_2d()))), radius));
        }
        pixels.push(i);
    }
    (rays, pixels)
}

/// The fraction of each pixel's `spp` AO rays that reach `radius` unblocked (1 where the pixel
/// sees no geometry), as the CPU `ao-exact` computes it.
#[allow(clippy::too_many_arguments)]
pub fn ambient_occlusion(
    ctx: &GpuContext,
    tracer: &mut GpuTracer,
    scene: &GpuScene,
    gbuffer: &GBuffer,
    spp: u32,
    radius: f32,
    seed: u64,
    pass: u64,
) -> Result<Image, GpuError> {
    let mut image = Image::new(gbuffer.width, gbuffer.height);
    image.pixels.iter_mut().for_each(|p| *p = Vec3::ONE);
    if spp == 0 {
        return Ok(image);
    }
    let (rays, pixels) = ao_rays(gbuffer, spp, radius, seed, pass);
    let occluded = tracer.occluded(ctx, scene, &rays)?;
    for (k, &i) in pixels.iter().enumerate() {
        let blocked = occluded[k * spp as usize..(k + 1) * spp as usize].iter().filter(|&&o| o).count();
        image.pixels[i] = Vec3::splat((spp as usize - blocked) as f32 / spp as f32);
    }
    Ok(image)
}
