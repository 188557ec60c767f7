//! Closest hits of a shadow map's rays, one by one (`closest_hit`) against 8 × 8 packets
//! (`closest_hits_tiled`): 512² rays from one point downward through a square, in the order an RSM
//! traces them. `cargo run --release -p glimpse-trace --example closest_packets -- SCENE [x y z]`
//! (the point defaults to one of sponza-interior's lights).

use glimpse_core::{Ray, Vec3};
use glimpse_trace::ExactTracer;
use rayon::prelude::*;
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: closest_packets SCENE [x y z]");
        std::process::exit(2);
    };
    let scene = match glimpse_scene::load(path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(1);
        }
    };
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let xyz: Vec<f32> = args[1..].iter().filter_map(|a| a.parse().ok()).collect();
    let origin = if let [x, y, z] = xyz[..] { Vec3::new(x, y, z) } else { Vec3::new(-2.0, 2.0, -2.5) };
    let r = 512u32;
    // One cube face's grid of directions, as a spot light's map.
    let ray = |i: u32| {
        let (x, y) = ((i % r) as f32 / r as f32 * 2.0 - 1.0, (i / r) as f32 / r as f32 * 2.0 - 1.0);
        Ray::new(origin, Vec3::new(x, -1.0, y).normalize())
    };
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let a: usize = (0..r * r).into_par_iter().filter(|&i| tracer.closest_hit(&ray(i), f32::INFINITY).is_some()).count();
        let one = t.elapsed().as_secs_f64() * 1e3;
        let t = std::time::Instant::now();
        let hits = tracer.closest_hits_tiled(r, r, |i| Some(ray(i as u32)));
        let b = hits.iter().filter(|h| matches!(h, Some((_, Some(_))))).count();
        let packets = t.elapsed().as_secs_f64() * 1e3;
        println!("one by one {one:.1} ms ({a} hits), 8 × 8 packets {packets:.1} ms ({b} hits)");
    }
}
