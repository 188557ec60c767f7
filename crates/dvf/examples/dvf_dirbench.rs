//! Micro-benchmark of the runtime's per-ray work that does not trace: direction, octahedral
//! pixel and mask lookup (single thread). `cargo run --release -p glimpse-dvf --example dvf_dirbench`

use glimpse_core::{Rng, Vec3};
use glimpse_dvf::grid::{Masks, octahedral_pixel};
use glimpse_dvf::rays::RaySet;

fn main() {
    let n = 20_000u32;
    let mut rng = Rng::new(1, 1);
    let masks = Masks::new(1000, 8);
    let sets: Vec<RaySet> =
        (0..n).map(|_| RaySet::new(glimpse_core::sampling::uniform_sphere(rng.next_2d()), 128, rng.next_2d(), false)).collect();
    let t = std::time::Instant::now();
    let mut acc = Vec3::ZERO;
    for s in &sets {
        for k in 0..128 {
            acc += s.direction(k);
        }
    }
    let dir_ns = t.elapsed().as_secs_f64() * 1e9 / (n as f64 * 128.0);
    let t = std::time::Instant::now();
    let mut hits = 0u32;
    for (i, s) in sets.iter().enumerate() {
        let cell = i % 1000;
        for k in 0..128 {
            let p = octahedral_pixel(s.direction(k), 8);
            let (v, o) = masks.bits(cell, p);
            hits += v as u32 + o as u32;
        }
    }
    let all_ns = t.elapsed().as_secs_f64() * 1e9 / (n as f64 * 128.0);
    println!("direction {dir_ns:.1} ns, direction + octahedral + 2 lookups {all_ns:.1} ns per ray ({acc} {hits})");
}
