//! The precompute's budget on scenes: planned paths, the pilot's mean rays per path, and the
//! path budget the ray budget leaves (`ray_budget`, issue #13).
//!
//! cargo run --release -p glimpse-wavecache --example path_length -- SCENE…

use glimpse_trace::ExactTracer;
use glimpse_wavecache::WavecacheParams;
use glimpse_wavecache::cache::{classes_and_areas, mean_rays_per_path, plan_points};

fn main() {
    let p = WavecacheParams::default();
    for spec in std::env::args().skip(1) {
        let scene = glimpse_scene::load(&spec).expect("scene loads");
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let (classes, areas) = classes_and_areas(&frame, &p);
        let full = plan_points(&frame, &WavecacheParams { path_budget: 0, ..p.clone() }, &classes, &areas);
        let sw = std::time::Instant::now();
        let m = mean_rays_per_path(&frame, &tracer, &p, 0);
        let budget = p.effective_path_budget(m);
        println!(
            "{spec}: {:.1}M paths without a budget; {m:.2} rays per path (pilot {:.0} ms); path budget {:.1}M → {:.0}M rays",
            full.paths as f64 / 1e6,
            sw.elapsed().as_secs_f64() * 1e3,
            budget as f64 / 1e6,
            (full.paths.min(budget) as f64 * m) / 1e6
        );
    }
}
