//! The exact tracer's costs, single-thread: BVH build time, and any-hit and closest-hit
//! throughput on ambient-occlusion rays (256×256 GBuffer, 4 rays per pixel, radius 10% of the
//! scene diagonal and ∞) on the Cornell box and the Stanford bunny (skipped when `../shared` or
//! the OBJ loader is missing).
//!
//! ```text
//! cargo bench -p glimpse-trace --bench trace
//! ```
//!
//! Throughput is reported in rays/s ("elem/s"). For Embree and `obvhs` on the same rays see
//! `examples/compare_backends.rs`.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glimpse_core::Ray;
use glimpse_scene::Scene;
use glimpse_trace::{ExactTracer, GBuffer, rays};
use std::hint::black_box;
use std::time::Duration;

const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/scenes/stanford-bunny/stanford-bunny.obj");

fn scenes() -> Vec<(&'static str, Scene)> {
    let mut scenes = vec![("cornell", glimpse_scene::load("cornell").expect("built-in scene"))];
    if !std::path::Path::new(BUNNY).exists() {
        println!("bunny skipped: {BUNNY} not found (../shared is absent)");
    } else {
        match glimpse_scene::load(BUNNY) {
            Ok(s) => scenes.push(("bunny", s)),
            Err(e) => println!("bunny skipped: the OBJ loader could not load it: {e}"),
        }
    }
    scenes
}

/// A one-thread rayon pool, so the build (parallel with rayon) is timed on one core too.
fn one_thread() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("rayon pool")
}

fn build(c: &mut Criterion) {
    let pool = one_thread();
    let mut group = c.benchmark_group("build (1 thread)");
    group.sample_size(10).measurement_time(Duration::from_secs(3));
    for (name, scene) in scenes() {
        let frame = scene.at(0.0);
        group.throughput(Throughput::Elements(scene.triangle_count() as u64));
        group.bench_function(BenchmarkId::from_parameter(name), |b| b.iter(|| pool.install(|| ExactTracer::build(black_box(&frame)))));
    }
    group.finish();
}

fn trace(c: &mut Criterion) {
    for (name, scene) in scenes() {
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let gbuffer = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), 256, 256);
        let diagonal = frame.bounds.extent().length();
        let mut group = c.benchmark_group(format!("ao rays {name}"));
        group.sample_size(10).measurement_time(Duration::from_secs(3));
        for (radius_name, radius) in [("r=10%", 0.1 * diagonal), ("r=inf", f32::INFINITY)] {
            let rays: Vec<(Ray, f32)> = rays::ao_rays_from(&gbuffer, 4, radius, 1);
            group.throughput(Throughput::Elements(rays.len() as u64));
            group.bench_function(format!("any-hit {radius_name}"), |b| {
                b.iter(|| rays.iter().filter(|(r, t)| tracer.occluded(black_box(r), *t)).count())
            });
            group.bench_function(format!("closest-hit {radius_name}"), |b| {
                b.iter(|| rays.iter().filter_map(|(r, t)| tracer.closest_hit(black_box(r), *t)).count())
            });
        }
        group.finish();
    }
}

criterion_group!(benches, build, trace);
criterion_main!(benches);
