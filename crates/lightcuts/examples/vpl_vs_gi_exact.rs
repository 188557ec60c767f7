//! How the VPL ground truth relates to `gi-exact` (one-bounce diffuse GI with exact rays): renders
//! both, direct + indirect, on one scene and prints the mean luminance of each and their RMSE.
//! Both include the same direct light estimator types; they differ in the indirect part: VPLs
//! (4096 from the RSM, 1/d² clamped) against cosine-sampled bounce rays.
//!
//! `cargo run --release -p glimpse-lightcuts --example vpl_vs_gi_exact -- cornell 160x120 512`

use glimpse_core::{Image, luminance};
use glimpse_render::metrics::rmse;
use glimpse_render::{FrameContext, Params, Registry, Settings, Technique};

fn run(t: &mut dyn Technique, ctx: &FrameContext, g: &glimpse_trace::GBuffer) -> Image {
    t.prepare(ctx).expect("prepare");
    let mut img = ctx.image();
    t.render(ctx, g, &mut img).expect("render");
    img
}

fn mean(img: &Image) -> f64 {
    img.pixels.iter().map(|p| luminance(*p) as f64).sum::<f64>() / img.pixels.len() as f64
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene_spec = args.get(1).map_or("cornell", |s| s.as_str());
    let (w, h) =
        args.get(2).and_then(|s| s.split_once('x')).map_or((160, 120), |(a, b)| (a.parse().unwrap_or(160), b.parse().unwrap_or(120)));
    let spp: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(512);
    let scene = match glimpse_scene::load(scene_spec) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("cannot load {scene_spec}: {e}");
            std::process::exit(1);
        }
    };
    let ctx = FrameContext::new(&scene, 0.0, w, h);
    let g = ctx.gbuffer();
    let registry = Registry::new(glimpse_render::techniques().into_iter().chain(glimpse_lightcuts::techniques()));
    let params = Params::default();
    let mut gi = registry.create("gi-exact", &scene, &Settings { spp, seed: 1 }, &params).expect("gi-exact");
    let mut vpl = registry.create("vpl-exact", &scene, &Settings { spp: 1, seed: 1 }, &params).expect("vpl-exact");
    let (a, b) = (run(gi.as_mut(), &ctx, &g), run(vpl.as_mut(), &ctx, &g));
    let mut gi_ind = registry
        .create("gi-exact", &scene, &Settings { spp, seed: 1 }, &Params::parse(&["include_direct=false"]).unwrap())
        .expect("gi-exact");
    let mut vpl_ind = registry
        .create("vpl-exact", &scene, &Settings { spp: 1, seed: 1 }, &Params::parse(&["include_direct=false"]).unwrap())
        .expect("vpl-exact");
    let (ai, bi) = (run(gi_ind.as_mut(), &ctx, &g), run(vpl_ind.as_mut(), &ctx, &g));
    println!(
        "{scene_spec} {w}x{h}: direct+indirect mean luminance gi-exact ({spp} spp) {:.5}, vpl-exact {:.5}; RMSE {:.5}",
        mean(&a),
        mean(&b),
        rmse(&b, &a, None).unwrap_or(f64::NAN)
    );
    println!(
        "indirect only: gi-exact {:.5}, vpl-exact {:.5} (ratio {:.3}); RMSE {:.5}",
        mean(&ai),
        mean(&bi),
        mean(&bi) / mean(&ai),
        rmse(&bi, &ai, None).unwrap_or(f64::NAN)
    );
}
