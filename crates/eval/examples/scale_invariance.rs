//! Every technique on the same scene in other length units (`Scene::rescale`): the picture should
//! not change, so any difference shows a default that hides an absolute length.
//!
//! ```text
//! cargo run --release -p glimpse-eval --example scale_invariance -- SCENE [SIZE] [SCALE…] [only=ID,ID…]
//! ```
//! Prints, per technique, the RMSE of each scaled render against the unscaled one (same seed),
//! relative to the unscaled image's mean, and the ratio of the image means; first, as the scale
//! of a difference that is only noise, the unscaled render with another seed.

use glimpse_render::{FrameContext, Params, Settings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (only, args): (Vec<String>, Vec<String>) = std::env::args().skip(1).partition(|a| a.starts_with("only="));
    let only: Vec<String> = only.iter().flat_map(|a| a["only=".len()..].split(',').map(str::to_owned)).collect();
    let name = args.first().map_or("cornell-lit", String::as_str);
    let size: u32 = args.get(1).map_or(Ok(48), |s| s.parse())?;
    let scales: Vec<f32> = if args.len() > 2 { args[2..].iter().map(|s| s.parse()).collect::<Result<_, _>>()? } else { vec![0.01, 100.0] };
    let registry = glimpse_eval::registry();
    let scene = glimpse_scene::load(name)?;
    print!("{name} {size}x{size}: relative RMSE (mean ratio) {:>16}", "other seed");
    scales.iter().for_each(|s| print!(" {:>16}", format!("scale {s}")));
    println!();
    for info in registry.all().iter().filter(|i| only.is_empty() || only.iter().any(|o| o == i.id)) {
        let render = |scene: &glimpse_scene::Scene, seed: u64| -> Option<glimpse_core::Image> {
            let mut t = registry.create(info.id, scene, &Settings { spp: 4, seed }, &Params::default()).ok()?;
            let ctx = FrameContext::new(scene, 0.0, size, size);
            let g = ctx.gbuffer();
            t.prepare(&ctx).ok()?;
            let mut image = ctx.image();
            t.render(&ctx, &g, &mut image).ok()?;
            Some(image)
        };
        let Some(base) = render(&scene, 1) else { continue };
        let mean =
            |img: &glimpse_core::Image| img.pixels.iter().map(|p| p.element_sum() as f64 / 3.0).sum::<f64>() / img.pixels.len() as f64;
        let m0 = mean(&base).max(1e-12);
        let compare = |img: Option<glimpse_core::Image>| match img {
            Some(img) => {
                let mse = base.pixels.iter().zip(&img.pixels).map(|(a, b)| ((*a - *b).length_squared() / 3.0) as f64).sum::<f64>()
                    / base.pixels.len() as f64;
                format!("{:.4} ({:.3})", mse.sqrt() / m0, mean(&img) / m0)
            }
            None => "error".to_owned(),
        };
        print!("{:<28} {:>16}", info.id, compare(render(&scene, 2)));
        for &s in &scales {
            let mut scaled = scene.clone();
            scaled.rescale(s)?;
            print!(" {:>16}", compare(render(&scaled, 1)));
        }
        println!();
    }
    Ok(())
}
