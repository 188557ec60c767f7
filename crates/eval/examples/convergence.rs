//! FLIP and RMSE of approximate techniques against their exact references over accumulated
//! frames of a static scene (what `glimpse eval` measures for one frame, continued over the
//! frames `glimpse play` would render), with mean build and trace times per frame.
//!
//! ```text
//! cargo run --release -p glimpse-eval --example convergence -- SCENE \
//!     [-t ao-roma,ao-df] [--size 256] [--frames 16] [--spp 1] [--ref-spp 256] [--seed 0] [--set key=value]...
//! ```
//! Frame k is rendered with `frame_index = k` (so ROMA re-draws its candidates and jitter);
//! every technique keeps its own history, so frame k shows k + 1 accumulated frames (within its
//! `accumulate` window — pass `--set accumulate=16` for a plain mean of 16 frames).

use glimpse_render::metrics::Metrics;
use glimpse_render::{FrameContext, Params, Settings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut scene_spec = None;
    let (mut ids, mut size, mut frames, mut spp, mut ref_spp, mut seed, mut set) =
        (vec!["ao-roma".to_string()], 256u32, 16u32, 1u32, 256u32, 0u64, Vec::new());
    let mut i = 0;
    while i < args.len() {
        let value = || args.get(i + 1).cloned().ok_or(format!("{} needs a value", args[i]));
        match args[i].as_str() {
            "-t" => ids = value()?.split(',').map(str::to_owned).collect(),
            "--size" => size = value()?.parse()?,
            "--frames" => frames = value()?.parse()?,
            "--spp" => spp = value()?.parse()?,
            "--ref-spp" => ref_spp = value()?.parse()?,
            "--seed" => seed = value()?.parse()?,
            "--set" => set.push(value()?),
            s if scene_spec.is_none() && !s.starts_with('-') => {
                scene_spec = Some(s.to_owned());
                i += 1;
                continue;
            }
            s => return Err(format!("unknown argument {s}").into()),
        }
        i += 2;
    }
    let scene_spec = scene_spec.ok_or("usage: convergence SCENE [-t ids] [--size N] [--frames N] [--spp N] [--ref-spp N] [--set k=v]")?;
    let scene = glimpse_scene::load(&scene_spec)?;
    let registry = glimpse_eval::registry();
    let mut ctx = FrameContext::new(&scene, 0.0, size, size);
    let gbuffer = ctx.gbuffer();
    println!("{scene_spec}: {size}x{size}, {spp} spp per frame, {frames} frames, references at {ref_spp} spp, set {set:?}");
    println!("{:<11} {:>6} {:>9} {:>9} {:>11} {:>11}", "technique", "frames", "FLIP", "RMSE", "build ms", "trace ms");
    for id in &ids {
        let info = registry.get(id)?;
        let ref_id = info.reference.unwrap_or(info.id);
        let ref_params = Params::parse(&set)?;
        let mut reference = (registry.get(ref_id)?.create)(&scene, &Settings { spp: ref_spp, seed: seed + 0x5eed }, &ref_params)?;
        ctx.frame_index = 0;
        reference.prepare(&ctx)?;
        let mut ref_image = ctx.image();
        reference.render(&ctx, &gbuffer, &mut ref_image)?;
        let params = Params::parse(&set)?;
        let mut technique = registry.create(id, &scene, &Settings { spp, seed }, &params)?;
        let (mut build_ms, mut trace_ms) = (0.0, 0.0);
        for k in 0..frames {
            ctx.frame_index = k;
            let p = technique.prepare(&ctx)?;
            let mut image = ctx.image();
            let r = technique.render(&ctx, &gbuffer, &mut image)?;
            build_ms += p.total_ms();
            trace_ms += r.stages.iter().filter(|s| s.0 == "trace").map(|s| s.1).sum::<f64>();
            let n = k + 1;
            if n.is_power_of_two() || n == frames {
                let m = Metrics::compute(&image, &ref_image)?;
                println!("{:<11} {:>6} {:>9.5} {:>9.5} {:>11.1} {:>11.1}", id, n, m.flip, m.rmse, build_ms / n as f64, trace_ms / n as f64);
            }
        }
    }
    Ok(())
}
