//! Image metrics at 512×512: `cargo bench -p glimpse-render --bench metrics`.

use criterion::{Criterion, criterion_group, criterion_main};
use glimpse_core::{Image, Vec3};
use glimpse_render::metrics::{ErrorMapKind, Metrics, error_map, flip_hdr, flip_ldr, mse, psnr, relmse, ssim};
use std::hint::black_box;

const SIZE: u32 = 512;

fn hash(x: u32, y: u32) -> f32 {
    let mut h = x.wrapping_mul(0x8da6_b343) ^ y.wrapping_mul(0xd816_3841);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// An HDR "render" (gradient and a bright spot) and a noisy version of it.
fn images() -> (Image, Image) {
    let reference = Image::from_fn(SIZE, SIZE, |x, y| {
        let (u, v) = (x as f32 / SIZE as f32, y as f32 / SIZE as f32);
        let d2 = (u - 0.7).powi(2) + (v - 0.3).powi(2);
        Vec3::new(0.8, 0.6, 0.4) * (0.05 + 2.0 * u * v) + Vec3::new(30.0, 25.0, 20.0) * (-d2 * 200.0).exp()
    });
    let test = Image::from_fn(SIZE, SIZE, |x, y| reference.get(x, y) * (0.9 + 0.2 * hash(x, y)));
    (test, reference)
}

fn bench(c: &mut Criterion) {
    let (test, reference) = images();
    let mut g = c.benchmark_group("metrics_512x512");
    g.sample_size(10);
    g.bench_function("mse", |b| b.iter(|| mse(black_box(&test), black_box(&reference), None).unwrap()));
    g.bench_function("relmse", |b| b.iter(|| relmse(black_box(&test), black_box(&reference), None).unwrap()));
    g.bench_function("psnr", |b| b.iter(|| psnr(black_box(&test), black_box(&reference), None).unwrap()));
    g.bench_function("ssim", |b| b.iter(|| ssim(black_box(&test), black_box(&reference)).unwrap()));
    g.bench_function("flip_ldr", |b| b.iter(|| flip_ldr(black_box(&test), black_box(&reference)).unwrap().0));
    g.bench_function("flip_hdr", |b| b.iter(|| flip_hdr(black_box(&test), black_box(&reference)).unwrap().0));
    g.bench_function("error_map_relative_squared", |b| {
        b.iter(|| error_map(black_box(&test), black_box(&reference), ErrorMapKind::RelativeSquared { max: 0.05 }).unwrap())
    });
    g.bench_function("Metrics::compute", |b| b.iter(|| Metrics::compute(black_box(&test), black_box(&reference)).unwrap()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
