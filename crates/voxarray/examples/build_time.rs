//! Alg. 1 + Alg. 2 build time and peak memory of one scene's array (no disk cache).
//!
//! cargo run --release -p glimpse-voxarray --example build_time -- SCENE [resolution=128]
//!     [directions=90] [compress=true] …

use glimpse_render::Params;
use glimpse_voxarray::{VoxArray, VoxArrayParams};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let spec = args.first().expect("usage: build_time SCENE [key=value …]");
    let params = Params::parse(&args[1..]).expect("arguments are key=value");
    let p = VoxArrayParams::default().read(&params).expect("valid parameters");
    let scene = glimpse_scene::load(spec).expect("scene loads");
    let triangles = scene.at(0.0).world_triangles();
    if p.cluster_cells > 0.0 {
        let grid = glimpse_voxarray::voxelize::Grid::around(&triangles, p.resolution);
        let sw = std::time::Instant::now();
        let c = glimpse_voxarray::voxelize::cluster_vertices(&triangles, &grid, p.cluster_cells);
        println!(
            "clustering at {} cells: {} -> {} triangles in {:.2} s",
            p.cluster_cells,
            triangles.len(),
            c.len(),
            sw.elapsed().as_secs_f64()
        );
    }
    // Compressed arrays are built streamed (Alg. 1 slab by slab into Alg. 2): one figure.
    let sw = std::time::Instant::now();
    let a = VoxArray::from_triangles(&triangles, &p);
    let build = sw.elapsed().as_secs_f64();
    let peak = std::fs::read_to_string("/proc/self/status").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("VmHWM:"))
            .map(|l| l.split_whitespace().nth(1).unwrap_or("0").parse::<f64>().unwrap_or(0.0) / 1024.0)
    });
    println!(
        "{spec}: {} triangles, {}³, {}² directions, compress {}: build {build:.2} s; {:.0} MiB stored; peak RSS {} MiB",
        triangles.len(),
        p.resolution,
        p.directions,
        p.compress.is_some(),
        a.memory_bytes() as f64 / 1048576.0,
        peak.map_or("?".into(), |m| format!("{m:.0}"))
    );
}
