//! Frame time of `lights-voxarray` against `lights-exact` on the many-lights town with any light
//! count (the CLI's `many-lights` scene has 1,024): prepare and render timed separately, plus
//! ε_v / ε_s of the rendered decisions.
//!
//! cargo run --release -p glimpse-voxarray --example frame_time -- [lights=1024] [size=256]
//!     [resolution=128] [directions=90] [compress=true] [bias=1] [bias_light=1] [normal_offset=1.5]
//!     [sm=none|64|128|256|32,64,128|64,128,256 (lights-shadowmap cube-face resolutions)]
//!     [ism=false (lights-ism at the paper's setting)] [skip_voxarray=false]

use glimpse_baselines::ism::LightsIsm;
use glimpse_baselines::shadowmap::LightsShadowMap;
use glimpse_render::lights::LightsExact;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_voxarray::epsilon;
use glimpse_voxarray::technique::LightsVoxArray;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    // The voxel array's ε is measured below with its facing-only variant too, so its render need
    // not measure it as well.
    if !args.iter().any(|a| a.starts_with("epsilon=")) {
        args.push("epsilon=false".into());
    }
    let params = Params::parse(&args).expect("arguments are key=value");
    let size = params.u32("size", 256, 1, 4096).unwrap();
    let lights = params.u32("lights", 1024, 1, 1 << 20).unwrap() as usize;
    let scene = glimpse_scene::builtin::many_lights(lights);
    let sm_resolutions: Vec<u32> =
        match params.choice("sm", "none", &["none", "64", "128", "256", "32,64,128", "64,128,256"]).unwrap().as_str() {
            "none" => vec![],
            list => list.split(',').map(|r| r.parse().unwrap()).collect(),
        };
    let skip_vox = params.bool("skip_voxarray", false).unwrap();
    let with_ism = params.bool("ism", false).unwrap();
    let mut vox = LightsVoxArray::new(&scene, &Settings::default(), &params).unwrap();
    params.finish("frame_time").unwrap();
    let ctx = FrameContext::new(&scene, 0.0, size, size);
    let g = ctx.gbuffer();
    let mut exact = LightsExact::new(&scene, &Settings::default(), &Params::default()).unwrap();
    let mut img = ctx.image();
    let pe = exact.prepare(&ctx).unwrap();
    let re = exact.render(&ctx, &g, &mut img).unwrap();
    println!("many-lights, {lights} lights, {size}², {} threads", rayon::current_num_threads());
    println!("  lights-exact:    prepare {:.0} ms, render {:.0} ms ({} rays)", pe.total_ms(), re.total_ms(), re.rays);
    // The baselines measure ε of their own decisions in `render` (untimed, `Stats::metrics`).
    let report = |label: String, t: &mut dyn Technique, img: &mut glimpse_core::Image| {
        let ps = t.prepare(&ctx).unwrap();
        let rs = t.render(&ctx, &g, img).unwrap();
        let m = |k: &str| rs.metrics.iter().find(|(n, _)| n == k).map_or(f64::NAN, |x| x.1);
        println!(
            "  {label}: prepare {:.0} ms, render {:.0} ms, memory {:.1} MiB, ε_v {:.2}%, ε_s {:.2}% (signed {:+.2}%)",
            ps.total_ms(),
            rs.total_ms(),
            ps.memory_bytes as f64 / (1u64 << 20) as f64,
            m("eps_v_pct"),
            m("eps_s_pct"),
            m("eps_s_signed_pct")
        );
    };
    for res in &sm_resolutions {
        let smp = Params::parse(&[format!("resolution={res}")]).unwrap();
        let mut sm = LightsShadowMap::new(&scene, &Settings::default(), &smp).unwrap();
        report(format!("lights-shadowmap {res}² cube faces"), &mut sm, &mut img);
    }
    if with_ism {
        let mut ism = LightsIsm::new(&scene, &Settings::default(), &Params::default()).unwrap();
        report("lights-ism 128², 11,000 points/map".into(), &mut ism, &mut img);
    }
    if skip_vox {
        return;
    }
    let pv = vox.prepare(&ctx).unwrap();
    let rv = vox.render(&ctx, &g, &mut img).unwrap();
    let rv2 = vox.render(&ctx, &g, &mut img).unwrap();
    let stages = |s: &glimpse_render::Stats| s.stages.iter().map(|(n, ms)| format!("{n} {ms:.0} ms")).collect::<Vec<_>>().join(", ");
    println!(
        "  lights-voxarray: prepare [{}] = {:.0} ms, render {:.0} ms / {:.0} ms (two runs, {} queries), memory {:.1} MiB; render speed-up {:.1}×",
        stages(&pv),
        pv.total_ms(),
        rv.total_ms(),
        rv2.total_ms(),
        rv.rays,
        rv.memory_bytes as f64 / (1u64 << 20) as f64,
        re.total_ms() / rv.total_ms().min(rv2.total_ms())
    );
    let s = vox.structure.as_ref().unwrap();
    let e = epsilon::epsilon(&ctx.frame, &g, &ctx.tracer, lights, |_, ps, sh| s.occluded_from_surface(ps, sh.normal));
    println!(
        "  ε_v {:.2}%, ε_s {:.2}% (signed {:+.2}%), facing-only ε_v {:.2}% ε_s {:.2}%, bias {}/{} cells, normal offset {} cells",
        100.0 * e.all.epsilon_v(),
        100.0 * e.all.epsilon_s_abs(),
        100.0 * e.all.epsilon_s_signed(),
        100.0 * e.facing.epsilon_v(),
        100.0 * e.facing.epsilon_s_abs(),
        vox.params.bias_start_cells,
        vox.params.bias_end_cells,
        vox.params.normal_offset_cells
    );
}
