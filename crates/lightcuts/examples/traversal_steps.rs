//! Thesis Fig. 7.2 analogue: mean traversal steps per sample (and samples per pixel, mock-cut
//! share) of `vpl-lightcuts`, `vpl-sst` and `vpl-rtslc` on one scene, 4096 VPLs (12 levels).
//!
//! `cargo run --release -p glimpse-lightcuts --example traversal_steps -- crates/lightcuts/scenes/sponza.toml 240x135 32`

use glimpse_lightcuts::{Variant, VplTechnique};
use glimpse_render::{FrameContext, Params, Settings, Technique};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene_spec = args.get(1).map_or("cornell", |s| s.as_str());
    let (w, h) =
        args.get(2).and_then(|s| s.split_once('x')).map_or((160, 120), |(a, b)| (a.parse().unwrap_or(160), b.parse().unwrap_or(120)));
    let spp: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(32);
    let scene = match glimpse_scene::load(scene_spec) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("cannot load {scene_spec}: {e}");
            std::process::exit(1);
        }
    };
    let ctx = FrameContext::new(&scene, 0.0, w, h);
    let g = ctx.gbuffer();
    let mut base = 0.0;
    for v in [Variant::Lightcuts, Variant::Sst, Variant::Rtslc] {
        let mut t = match VplTechnique::new(v, &Settings { spp, seed: 0 }, &Params::default()) {
            Ok(t) => t,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        let mut img = ctx.image();
        if let Err(e) = t.prepare(&ctx).and_then(|_| t.render(&ctx, &g, &mut img)) {
            eprintln!("{e}");
            std::process::exit(1);
        }
        let Some(r) = t.report.as_ref() else { continue };
        if v == Variant::Lightcuts {
            base = r.steps_per_sample;
        }
        println!(
            "{scene_spec} {w}x{h} n={spp}: {:14} {:5.2} steps/sample ({:.1}× proposed), {:5.2} samples/pixel, mock cuts {:.2} % of pixels",
            v.id(),
            r.steps_per_sample,
            r.steps_per_sample / base.max(1e-9),
            r.samples_per_pixel,
            100.0 * r.mock_fraction
        );
    }
}
