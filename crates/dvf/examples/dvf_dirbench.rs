//! Micro-benchmark of the runtime's per-ray work that does not trace: direction, octahedral
//! pixel and mask lookup (single thread), per ray as the per-ray loop does it, then as the
//! batched runtime does it (`raybatch::form` with each former, plus one mask lookup per ray).
//! `cargo run --release -p glimpse-dvf --example dvf_dirbench`

use glimpse_core::{Rng, Vec3};
use glimpse_dvf::grid::{Masks, octahedral_pixel};
use glimpse_dvf::raybatch::{self, Block, Former};
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
    println!("per ray: direction {dir_ns:.1} ns, direction + octahedral + 2 lookups {all_ns:.1} ns per ray ({acc} {hits})");
    let mut formers = vec![Former::Scalar];
    if raybatch::simd_enabled() {
        formers.push(Former::Simd);
    }
    let mut b = Box::<Block>::default();
    for former in formers {
        let t = std::time::Instant::now();
        let mut selected = 0u32;
        for (i, s) in sets.iter().enumerate() {
            raybatch::form(s, s.frame.z, s.frame.z, 8, former, &mut b);
            let word = masks.visible[i % 1000].load(std::sync::atomic::Ordering::Relaxed) | 0x5555_5555_5555_5555;
            let mut trace = [0u64; raybatch::RAY_WORDS];
            for (k, &p) in b.pixel[..128].iter().enumerate() {
                trace[k / 64] |= ((word >> (p & 63)) & 1) << (k % 64);
            }
            selected += trace.iter().zip(b.used).map(|(t, u)| (t & u).count_ones()).sum::<u32>();
        }
        let ns = t.elapsed().as_secs_f64() * 1e9 / (n as f64 * 128.0);
        println!("block ({former:?}): direction + octahedral + horizon + lookup {ns:.1} ns per ray ({selected})");
    }
}
