//! The AVX2 replica of glibc's `sincosf` ([`glimpse_dvf::raybatch::sincos_lanes`]) against the
//! platform's `sin_cos` on every f32 in [−1, 2.5] (the concentric map's angles lie in
//! [−π/4, 3π/4]), or on `STEP`-strided ones: `cargo run --release -p glimpse-dvf --example
//! dvf_sincos_check [STEP]`. Prints the count compared, the mismatches (the first few listed).

use rayon::prelude::*;

/// θ, sin, platform sin, cos, platform cos.
type Mismatch = (f32, f32, f32, f32, f32);

fn main() {
    let step: u32 = std::env::args().nth(1).map_or(1, |s| s.parse().expect("STEP"));
    if glimpse_dvf::raybatch::sincos_lanes([0.0; 8]).is_none() {
        println!("no AVX2 + FMA here: nothing to check");
        return;
    }
    // Both signs' bit ranges: [0, 2.5] and [−1, −0].
    let ranges = [(0u32, 2.5f32.to_bits()), ((-0.0f32).to_bits(), (-1.0f32).to_bits())];
    let t = std::time::Instant::now();
    let (mut compared, mut bad) = (0u64, Vec::new());
    for (a, b) in ranges {
        let chunks: Vec<u32> = (a..=b).step_by(8 * 4096 * step as usize).collect();
        let (c, m): (u64, Vec<Mismatch>) = chunks
            .par_iter()
            .map(|&start| {
                let (mut c, mut m) = (0u64, Vec::new());
                let mut bits = start;
                while bits < start.saturating_add(8 * 4096 * step) && bits <= b {
                    let th: [f32; 8] = std::array::from_fn(|i| f32::from_bits((bits + i as u32 * step).min(b)));
                    let (s, co) = glimpse_dvf::raybatch::sincos_lanes(th).expect("in range");
                    for i in 0..8 {
                        let (rs, rc) = std::hint::black_box(th[i]).sin_cos();
                        if s[i].to_bits() != rs.to_bits() || co[i].to_bits() != rc.to_bits() {
                            m.push((th[i], s[i], rs, co[i], rc));
                        }
                        c += 1;
                    }
                    bits += 8 * step;
                }
                (c, m)
            })
            .reduce(
                || (0, Vec::new()),
                |(c0, mut m0), (c1, m1)| {
                    m0.extend(m1);
                    (c0 + c1, m0)
                },
            );
        compared += c;
        bad.extend(m);
    }
    for (t, s, rs, c, rc) in bad.iter().take(10) {
        println!("θ {t:e} ({:#x}): sin {s:e} vs {rs:e}, cos {c:e} vs {rc:e}", t.to_bits());
    }
    println!("{compared} angles compared in {:.1} s: {} differ", t.elapsed().as_secs_f64(), bad.len());
    if !bad.is_empty() {
        std::process::exit(1);
    }
}
