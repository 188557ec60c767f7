//! How small each scene's light sources are, as `trace_disagree=auto` judges them: the area
//! lights' and the environment's brighter half, in sr, and the verdict.
//!
//! cargo run --release -p glimpse-wavecache --example light_sizes -- SCENE…

fn main() {
    for spec in std::env::args().skip(1) {
        let scene = match glimpse_scene::load(&spec) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{spec}: {e}");
                continue;
            }
        };
        let frame = scene.at(0.0);
        let emitters = glimpse_wavecache::emitters_half_power_solid_angle(&frame);
        let env = scene.environment.as_ref().map(|e| e.half_power_solid_angle());
        let small = glimpse_wavecache::small_cached_sources(&frame);
        println!("{spec}: area lights {emitters:?} sr, environment {env:?} sr, small sources: {small}");
    }
}
