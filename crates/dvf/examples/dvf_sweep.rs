//! Same-ray comparison and parameter sweeps of `env-dvf` against `env-exact` in one process:
//! one scene load, one GBuffer, one reference (`env-exact` with the SAME seed, so at equal N_r
//! both estimate with identical rays and the difference is the field's alone; `glimpse eval`
//! seeds its references differently, which adds the reference's own noise).
//!
//! `cargo run --release -p glimpse-dvf --example dvf_sweep -- SCENE WxH RAYS 'k=v k=v' ['k=v' ...]`
//! Prints, per configuration: build stages (ms), shade ms, samples, rays per pixel, RMSE,
//! HDR-FLIP (eval's metric) and LDR-FLIP (linear clamped to [0,1], sRGB, 8 bits).

use glimpse_core::Image;
use glimpse_dvf::technique::EnvDvf;
use glimpse_render::env::EnvExact;
use glimpse_render::metrics::Metrics;
use glimpse_render::{FrameContext, Params, Settings, Technique};

/// CPU seconds this process has used, all threads (Linux `/proc/self/stat` utime + stime, at
/// the usual 100 ticks per second): a load-independent cost measure on a shared machine.
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<f64> = after.split_whitespace().map(|x| x.parse().unwrap_or(0.0)).collect();
    if f.len() > 12 { (f[11] + f[12]) / 100.0 } else { 0.0 }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        eprintln!("usage: dvf_sweep SCENE WxH RAYS 'k=v k=v' ['k=v' ...]");
        std::process::exit(2);
    }
    let scene = glimpse_scene::load(&args[1]).expect("scene");
    let (w, h) = args[2].split_once('x').map(|(a, b)| (a.parse().unwrap(), b.parse().unwrap())).expect("WxH");
    let rays: u32 = args[3].parse().expect("rays");
    let ctx = FrameContext::new(&scene, 0.0, w, h);
    let g = ctx.gbuffer();
    let hits = (0..(w * h) as usize).filter(|&i| g.is_hit(i)).count().max(1);
    let settings = Settings { spp: 1, seed: 0 };
    let mut exact = EnvExact::new(&settings, &Params::parse(&[format!("rays={rays}")]).unwrap()).unwrap();
    let sw = std::time::Instant::now();
    let cpu0 = cpu_s();
    exact.prepare(&ctx).unwrap();
    let mut reference = Image::new(w, h);
    let r = exact.render(&ctx, &g, &mut reference).unwrap();
    let exact_ms = sw.elapsed().as_secs_f64() * 1e3;
    let exact_cpu = cpu_s() - cpu0;
    println!(
        "scene {} {}x{} ({} triangles), env-exact rays={rays}: {exact_ms:.0} ms ({exact_cpu:.1} CPU s), {:.1} rays/pixel",
        args[1],
        w,
        h,
        ctx.tracer.triangle_count(),
        r.rays as f64 / hits as f64
    );
    if let Ok(dir) = std::env::var("DVF_OUT") {
        reference.write(&std::path::Path::new(&dir).join("exact.png"), Default::default()).ok();
    }
    for (ci, cfg) in args[4..].iter().enumerate() {
        let mut pairs = vec![format!("rays={rays}")];
        pairs.extend(cfg.split_whitespace().map(str::to_owned));
        let params = Params::parse(&pairs).unwrap();
        let mut t = EnvDvf::new(&settings, &params).unwrap();
        let sw = std::time::Instant::now();
        let cpu0 = cpu_s();
        let prep = t.prepare(&ctx).unwrap();
        let prep_cpu = cpu_s() - cpu0;
        let prep_ms = sw.elapsed().as_secs_f64() * 1e3;
        let mut img = Image::new(w, h);
        let sw = std::time::Instant::now();
        let rend = t.render(&ctx, &g, &mut img).unwrap();
        let shade_ms = sw.elapsed().as_secs_f64() * 1e3;
        let shade_cpu = cpu_s() - cpu0 - prep_cpu;
        let m = Metrics::compute(&img, &reference).unwrap();
        let ldr = glimpse_render::metrics::flip_ldr(&img, &reference).unwrap().0;
        let d = t.dvf.as_ref().unwrap();
        let stages: Vec<String> = prep.stages.iter().map(|(s, ms)| format!("{s} {ms:.1}")).collect();
        println!(
            "[{cfg}] grid {:?} samples {} build {prep_ms:.0} ms ({}) | shade {shade_ms:.0} ms, {:.1} rays/px, occluded cells {}/{} | total {:.0} ms = {:.2}x faster; CPU s build {prep_cpu:.1} + shade {shade_cpu:.1} = {:.2}x less | RMSE {:.6} FLIP {:.6} (LDR-FLIP {ldr:.6})",
            d.grid.dims,
            d.samples,
            stages.join(", "),
            rend.rays as f64 / hits as f64,
            d.occluded_cells(),
            d.labels.len(),
            prep_ms + shade_ms,
            exact_ms / (prep_ms + shade_ms),
            exact_cpu / (prep_cpu + shade_cpu).max(1e-9),
            m.rmse,
            m.flip
        );
        if let Ok(dir) = std::env::var("DVF_OUT") {
            img.write(&std::path::Path::new(&dir).join(format!("dvf-{ci}.png")), Default::default()).ok();
        }
    }
}
