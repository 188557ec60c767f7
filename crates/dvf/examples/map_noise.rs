//! Prints the relative noise of an N_r-ray estimate of each scene's environment (what
//! `unshadowed=auto` decides on) and the resulting choice.
//! `cargo run --release -p glimpse-dvf --example map_noise -- SCENE… [--rays N]`

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rays = args.iter().position(|a| a == "--rays").and_then(|i| args.get(i + 1)).map_or(128, |v| v.parse().expect("--rays N"));
    for spec in args.iter().filter(|a| !a.starts_with("--") && a.parse::<u32>().is_err()) {
        match glimpse_scene::load(spec) {
            Ok(scene) => match scene.environment.as_ref() {
                Some(env) => {
                    let noise = glimpse_dvf::cosine_estimator_noise(env, rays);
                    println!(
                        "{spec}: relative noise of {rays} rays {noise:.4} -> unshadowed={:?} in an open scene",
                        glimpse_dvf::choose_unshadowed(noise, 0.0)
                    );
                }
                None => println!("{spec}: no environment"),
            },
            Err(e) => println!("{spec}: {e}"),
        }
    }
}
