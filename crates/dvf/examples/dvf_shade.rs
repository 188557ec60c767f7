//! The `env-dvf` shade alone, per runtime loop, in one process (one scene load, one GBuffer, one
//! field): `cargo run --release -p glimpse-dvf --example dvf_shade -- SCENE WxH [RUNS] ['k=v ...']`.
//! Runs the per-ray loop, the batched loop with the scalar former and (where enabled) with the
//! AVX2 former, interleaved RUNS times (default 3), and prints each one's shade times (wall and
//! process CPU), their medians, the rays traced, and whether every image equals the per-ray
//! loop's bit for bit. Also times `env-exact`'s render on the same GBuffer once per run.
//! `DVF_SHADE_ONLY=avx2` runs only the batched AVX2 loop (for profiles).

use glimpse_core::{Image, Vec3};
use glimpse_dvf::raybatch::{self, Former};
use glimpse_dvf::rays::RaySet;
use glimpse_dvf::technique::{EnvDvf, RuntimePath};
use glimpse_render::direct::{self, Shading};
use glimpse_render::env::EnvExact;
use glimpse_render::{FrameContext, Params, Settings, Technique};

/// CPU seconds this process has used, all threads (`/proc/self/stat`, 100 ticks per second).
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<f64> = after.split_whitespace().map(|x| x.parse().unwrap_or(0.0)).collect();
    if f.len() > 12 { (f[11] + f[12]) / 100.0 } else { 0.0 }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: dvf_shade SCENE WxH [RUNS] ['k=v ...']");
        std::process::exit(2);
    }
    let scene = glimpse_scene::load(&args[1]).expect("scene");
    let (w, h) = args[2].split_once('x').map(|(a, b)| (a.parse().unwrap(), b.parse().unwrap())).expect("WxH");
    let runs: usize = args.get(3).map_or(3, |r| r.parse().expect("RUNS"));
    let pairs: Vec<String> = args.get(4).map_or(vec![], |c| c.split_whitespace().map(str::to_owned).collect());
    let ctx = FrameContext::new(&scene, 0.0, w, h);
    let g = ctx.gbuffer();
    let settings = Settings { spp: 1, seed: 0 };
    let mut t = EnvDvf::new(&settings, &Params::parse(&pairs).unwrap()).unwrap();
    let prep = t.prepare(&ctx).unwrap();
    let rt = t.runtime(&ctx).expect("an environment");
    let dvf = rt.dvf;
    println!(
        "{} {w}x{h}: prepare {:.0} ms ({} points, grid {:?}, unshadowed {:?}), AVX2 former enabled: {}",
        args[1],
        prep.stages.iter().map(|(_, ms)| ms).sum::<f64>(),
        dvf.samples,
        dvf.grid.dims,
        t.params.unshadowed,
        raybatch::simd_enabled()
    );
    let mut paths = vec![("per-ray", RuntimePath::PerRay), ("batched scalar", RuntimePath::Batched(Former::Scalar))];
    if raybatch::simd_enabled() {
        paths.push(("batched AVX2", RuntimePath::Batched(Former::Simd)));
    }
    let only_simd = std::env::var("DVF_SHADE_ONLY").is_ok_and(|v| v == "avx2");
    if only_simd {
        paths.retain(|p| p.1 == RuntimePath::Batched(Former::Simd));
    }
    let mut times: Vec<(Vec<f64>, Vec<f64>)> = vec![(vec![], vec![]); paths.len() + 1];
    let mut reference: Option<Image> = None;
    for run in 0..runs {
        if only_simd {
            times[paths.len()].0.push(0.0);
            times[paths.len()].1.push(0.0);
        } else {
            let mut exact = EnvExact::new(&settings, &Params::parse(&["rays=128".to_owned()]).unwrap()).unwrap();
            exact.prepare(&ctx).unwrap();
            let mut img = ctx.image();
            let (sw, c0) = (std::time::Instant::now(), cpu_s());
            exact.render(&ctx, &g, &mut img).unwrap();
            times[paths.len()].0.push(sw.elapsed().as_secs_f64() * 1e3);
            times[paths.len()].1.push(cpu_s() - c0);
        }
        for (pi, &(name, path)) in paths.iter().enumerate() {
            let mut img = ctx.image();
            let (sw, c0) = (std::time::Instant::now(), cpu_s());
            let rays = direct::shade_pixels(&ctx, &g, settings.seed, &mut img, |i, rng| {
                let Some(s) = Shading::from_gbuffer(&g, i) else { return (Vec3::ZERO, 0) };
                let set = RaySet::new(s.shading_normal, t.params.rays, rng.next_2d(), t.params.rotate_about_normal);
                let (e, rays) = rt.irradiance_by(&s, &set, path);
                (s.albedo * e, rays)
            })
            .unwrap();
            let ms = sw.elapsed().as_secs_f64() * 1e3;
            let cpu = cpu_s() - c0;
            times[pi].0.push(ms);
            times[pi].1.push(cpu);
            let same = match &reference {
                None => {
                    reference = Some(img);
                    true
                }
                Some(r) => r.pixels.iter().zip(&img.pixels).all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)),
            };
            println!("run {run} {name}: shade {ms:.0} ms, {cpu:.2} CPU s, {rays} rays, identical to per-ray: {same}");
            assert!(same, "{name} differs from the per-ray image");
        }
    }
    let names: Vec<&str> = paths.iter().map(|p| p.0).chain(["env-exact render"]).collect();
    for (name, (ms, cpu)) in names.iter().zip(&mut times) {
        println!("median {name}: {:.0} ms, {:.2} CPU s", median(ms), median(cpu));
    }
}
