//! ε_v / ε_s of the voxel array against exact ray tracing on a scene, with build time and memory.
//!
//! cargo run --release -p glimpse-voxarray --example epsilon -- [scene=many-lights] [size=64]
//!     [lights=1024] [resolution=128] [directions=90] [bias=1] [bias_light=1] [normal_offset=1]
//!     [compress=false] [dictionary=1048576] [steps=4] [alg6=false] [skip_start_run=false]
//!
//! Prints one line for the query with the normal offset (what `lights-voxarray` renders) and one
//! for the `Visibility` trait (no normal; what `bench rays` measures).

use glimpse_render::Params;
use glimpse_trace::{ExactTracer, GBuffer, Visibility};
use glimpse_voxarray::{VoxArray, VoxArrayParams, epsilon};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let params = Params::parse(&args).expect("arguments are key=value");
    let scene_name = params.choice("scene", "many-lights", &["many-lights", "cornell", "cornell-dynamic", "deforming", "sky"]).unwrap();
    let size = params.u32("size", 64, 1, 4096).unwrap();
    let p = VoxArrayParams { compress: None, ..VoxArrayParams::default() }.read(&params).unwrap();
    let scene = glimpse_scene::load(&scene_name).unwrap();
    let lights = params.u32("lights", scene.lights.len() as u32, 1, u32::MAX).unwrap() as usize;
    let alg6 = params.bool("alg6", false).unwrap();
    params.finish("epsilon").unwrap();
    let scene = if scene_name == "many-lights" { glimpse_scene::builtin::many_lights(lights) } else { scene };
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let camera = scene.camera_or_default(1.0);
    let g = GBuffer::new(&frame, &tracer, &camera, size, size);
    let sw = std::time::Instant::now();
    // alg6=true: the per-frame rebuild by fragment rotation (uncompressed) instead of Alg. 1.
    let a = if alg6 {
        glimpse_voxarray::dynamic::rebuild(&frame, &VoxArrayParams { compress: None, ..p })
    } else {
        VoxArray::build(&frame, &p)
    };
    let total_ms = sw.elapsed().as_secs_f64() * 1e3;
    let mib = |b: f64| b / (1u64 << 20) as f64;
    let comp = a.compression().map_or("uncompressed".to_string(), |c| {
        format!(
            "compressed in {:.0} ms ({} distinct rows, dictionary {}, mapped per step {:?}, random {})",
            c.ms, c.distinct_rows, c.dictionary_rows, c.mapped_at_step, c.random
        )
    });
    println!(
        "{scene_name} ({} triangles), {lights} lights, {size}², {}{}³, {}×{} directions, bias {}/{} cells, normal offset {} cells (cell {:.3} m): build {:.0} ms, total {total_ms:.0} ms, {comp}; memory {:.1} MiB (uncompressed {:.1} MiB)",
        scene.triangle_count(),
        if alg6 { "Alg. 6 " } else { "" },
        p.resolution,
        p.directions,
        p.directions,
        p.bias_start_cells,
        p.bias_end_cells,
        p.normal_offset_cells,
        a.grid().cell_size_world(),
        a.build_ms(),
        mib(a.memory_bytes() as f64),
        mib(a.uncompressed_bytes() as f64)
    );
    let sw = std::time::Instant::now();
    let e = epsilon::epsilon(&frame, &g, &tracer, lights, |_, ps, s| a.occluded_from_surface(ps, s.normal));
    let eps_ms = sw.elapsed().as_secs_f64() * 1e3;
    let t = epsilon::epsilon(&frame, &g, &tracer, lights, |_, ps, _| a.occluded(&ps.shadow, ps.t_max));
    let pc = |x: f64| 100.0 * x;
    println!(
        "  with normal offset: ε_v {:.2}%  ε_s {:.2}% (signed {:+.2}%)  facing-only ε_v {:.2}% ε_s {:.2}%  over {} pixels ({eps_ms:.0} ms)",
        pc(e.all.epsilon_v()),
        pc(e.all.epsilon_s_abs()),
        pc(e.all.epsilon_s_signed()),
        pc(e.facing.epsilon_v()),
        pc(e.facing.epsilon_s_abs()),
        e.all.pixels()
    );
    println!(
        "  Visibility trait:   ε_v {:.2}%  ε_s {:.2}% (signed {:+.2}%)  facing-only ε_v {:.2}% ε_s {:.2}%",
        pc(t.all.epsilon_v()),
        pc(t.all.epsilon_s_abs()),
        pc(t.all.epsilon_s_signed()),
        pc(t.facing.epsilon_v()),
        pc(t.facing.epsilon_s_abs())
    );
}
