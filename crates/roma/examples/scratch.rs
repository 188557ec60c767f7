use glimpse_core::{Rng, Vec3};
use glimpse_roma::{Roma, RomaParams};
use glimpse_trace::{ExactTracer, GBuffer, Visibility, rays};
use std::time::Instant;

fn main() {
    let spec = std::env::args().nth(1).unwrap_or("cornell".into());
    let scene = glimpse_scene::load(&spec).unwrap();
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), 256, 256);
    let rays = rays::ao_rays_from(&g, 20, f32::INFINITY, 0);
    let roma = Roma::build(&frame, &RomaParams::default(), 0, 0);
    let t = Instant::now();
    let mut acc = 0usize;
    for (r, _) in &rays {
        acc += roma.select(r.dir).0;
    }
    println!("select: {:.1} ns/ray ({acc})", t.elapsed().as_nanos() as f64 / rays.len() as f64);
    let sel: Vec<(usize, f32)> = rays.iter().map(|(r, _)| roma.select(r.dir)).collect();
    let t = Instant::now();
    let mut hits = 0usize;
    for ((r, _), &(k, s)) in rays.iter().zip(&sel) {
        hits += roma.any_hit_snapped(k, s, r.origin, f32::INFINITY) as usize;
    }
    println!("trace given (k, sign): {:.1} ns/ray ({hits})", t.elapsed().as_nanos() as f64 / rays.len() as f64);
    let t = Instant::now();
    let mut hits = 0usize;
    for (r, tm) in &rays {
        hits += roma.occluded(r, *tm) as usize;
    }
    println!("occluded (1 thread): {:.1} ns/ray ({hits})", t.elapsed().as_nanos() as f64 / rays.len() as f64);
    let t = Instant::now();
    let mut hits = 0usize;
    for (r, tm) in &rays {
        hits += tracer.occluded(r, *tm) as usize;
    }
    println!("exact (1 thread): {:.1} ns/ray ({hits})", t.elapsed().as_nanos() as f64 / rays.len() as f64);
    let _ = (Rng::new(0, 0), Vec3::ZERO);
}
