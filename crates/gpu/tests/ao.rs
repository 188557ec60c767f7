//! GPU `ao-exact` against the CPU technique on the same GBuffer and the same directions: the
//! images must be equal (every ray decided alike), so the RMSE is 0.
#![cfg(feature = "gpu")]

mod common;

use common::context;
use glimpse_core::Image;
use glimpse_gpu::{GpuScene, GpuTimer, GpuTracer, ao};
use glimpse_render::Progress;
use glimpse_trace::{ExactTracer, GBuffer};

#[test]
fn gpu_ao_exact_equals_the_cpu_image() {
    let Some(ctx) = context("ao-exact") else { return };
    let mut tracer = GpuTracer::new(&ctx).unwrap();
    for (name, radius) in [("cornell", f32::INFINITY), ("glossy", 0.5), ("many-lights", 2.0)] {
        let scene = glimpse_scene::load(name).unwrap();
        let frame = scene.at(0.0);
        let cpu = ExactTracer::build(&frame);
        let g = GBuffer::new(&frame, &cpu, &scene.camera_or_default(1.0), 40, 30);
        let (spp, seed, pass) = (8, 17, 2);
        let mut cpu_image = Image::new(g.width, g.height);
        glimpse_render::ao::ambient_occlusion(&g, &cpu, spp, radius, seed, pass, &Progress::default(), &mut cpu_image);
        let gscene = GpuScene::new(&ctx, &frame, &mut GpuTimer::new(&ctx, 1)).unwrap();
        let gpu_image = ao::ambient_occlusion(&ctx, &mut tracer, &gscene, &g, spp, radius, seed, pass).unwrap();
        let differ = cpu_image.pixels.iter().zip(&gpu_image.pixels).filter(|(a, b)| a != b).count();
        let mse = cpu_image.pixels.iter().zip(&gpu_image.pixels).map(|(a, b)| (a.x - b.x).powi(2) as f64).sum::<f64>()
            / cpu_image.pixels.len() as f64;
        let mean = gpu_image.pixels.iter().map(|p| p.x as f64).sum::<f64>() / gpu_image.pixels.len() as f64;
        println!(
            "{name:12} radius {radius}: {} pixels × {spp} rays, mean AO {mean:.4}, {differ} pixels differ, RMSE {:.2e}",
            g.len(),
            mse.sqrt()
        );
        assert_eq!(differ, 0, "{name}: the GPU image differs from the CPU's");
    }
}
