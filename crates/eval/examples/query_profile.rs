//! Where a shadow query's time goes (issue #14: "the measured ceiling with a profile"): the same
//! shadow rays (1280×720 GBuffer, as `bench rays --kind shadow`) through the exact tracer and the
//! compressed voxel array at its defaults, `repeats` times each, alternating, in batches of
//! [`glimpse_eval::bench::BATCH_RAYS`] over all threads. The array comes from the disk cache after the first run, so a
//! profiler sees the queries rather than the build.
//!
//!     cargo run --release -p glimpse-eval --example query_profile -- SCENE [rays] [repeats] [both|exact|voxarray]
//!     perf record -F 999 target/release/examples/query_profile many-lights 16000000 5 voxarray

use glimpse_eval::bench::{RayKind, answer_batches, generate_rays};
use glimpse_trace::{ExactTracer, GBuffer, Visibility};
use glimpse_voxarray::{VoxArray, VoxArrayParams, disk_cache};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let spec = args.first().map_or("many-lights", |s| s.as_str());
    let count: usize = args.get(1).map_or(8_000_000, |s| s.parse().expect("rays: a count"));
    let repeats: usize = args.get(2).map_or(3, |s| s.parse().expect("repeats: a count"));
    let which = args.get(3).map_or("both", |s| s.as_str());

    let scene = glimpse_scene::load(spec).expect("the scene loads");
    let frame = scene.at(0.0);
    let exact = ExactTracer::build(&frame);
    let camera = scene.camera_or_default(16.0 / 9.0);
    let gbuffer = GBuffer::new(&frame, &exact, &camera, 1280, 720);
    let rays = generate_rays(&frame, &gbuffer, RayKind::Shadow, count, f32::INFINITY, 0);

    let p = VoxArrayParams::default();
    let triangles = frame.world_triangles();
    let path = glimpse_render::cache_dir().map(|d| disk_cache::path_for(&d, &triangles, None, &p));
    let array = match path.as_ref().and_then(|path| disk_cache::load(path, &p)) {
        Some(a) => a,
        None => {
            let a = VoxArray::from_triangles(&triangles, &p);
            if let Some(path) = &path {
                disk_cache::store(path, &a).expect("the array is cached");
            }
            a
        }
    };
    println!("{spec}: {} shadow rays, {} threads", rays.len(), rayon::current_num_threads());

    let time = |vis: &dyn Visibility| -> f64 {
        let mut out = vec![false; rays.len()];
        let start = Instant::now();
        answer_batches(vis, &rays, &mut out);
        start.elapsed().as_secs_f64() * 1e9 / rays.len() as f64
    };
    let (mut e, mut v) = (Vec::new(), Vec::new());
    for _ in 0..repeats {
        if which != "voxarray" {
            e.push(time(&exact));
        }
        if which != "exact" {
            v.push(time(&array));
        }
    }
    let median = |x: &mut Vec<f64>| -> f64 {
        x.sort_by(f64::total_cmp);
        x.get(x.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let (e, v) = (median(&mut e), median(&mut v));
    println!("wall ns per query (median of {repeats}): exact {e:.1}, voxarray (compressed) {v:.1}; ratio {:.2}x", e / v);
}
