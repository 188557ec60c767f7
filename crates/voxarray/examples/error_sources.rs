//! Where the voxel array's wrong shadow decisions come from on a scene: for every (pixel, light)
//! pair the exact tracer and the array disagree on, the segment's length and, for a missed
//! occluder, how far (in cells) the exact blocker is from either end.
//!
//! cargo run --release -p glimpse-voxarray --example error_sources -- SCENE [W H] [key=value…]
//!
//! `lights=N` replaces the scene's lights by N white point lights on its surfaces (uniform by area,
//! one cell off the surface, seeded): the paper's setting of hundreds to thousands of VPL-like
//! lights, where ε_s (signed per pixel) can average out; with a scene's few lights it cannot.
//! Ends with ε_v and |ε_s| as `lights-voxarray` reports them, without and with `refine` (the
//! occluded answers confirmed by exact rays) on the array built with the given offsets.

use glimpse_render::Params;
use glimpse_render::direct::{self, Shading};
use glimpse_trace::{ExactTracer, GBuffer};
use glimpse_voxarray::{VoxArray, VoxArrayParams};

/// `n` point lights at uniformly drawn surface points, `offset` along the face normal (toward
/// the side the normal faces; both sides of a thin surface are equally likely to be lit).
fn surface_lights(scene: &glimpse_scene::Scene, n: usize, offset: f32) -> Vec<glimpse_scene::Light> {
    let tris = scene.at(0.0).world_triangles();
    let areas: Vec<f32> = tris.iter().map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()).collect();
    let cdf: Vec<f32> = areas
        .iter()
        .scan(0.0, |acc, a| {
            *acc += a;
            Some(*acc)
        })
        .collect();
    let total = cdf.last().copied().unwrap_or(0.0);
    let mut rng = glimpse_core::Rng::new(7, 0);
    (0..n)
        .map(|_| {
            let i = cdf.partition_point(|&c| c < rng.next_f32() * total).min(tris.len() - 1);
            let t = tris[i];
            let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let normal = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            let side = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
            let p = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v + normal * (side * offset);
            glimpse_scene::Light::point(p, glimpse_core::Vec3::splat(1.0))
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_name = args.first().cloned().unwrap_or_else(|| "many-lights".into());
    let w: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(96);
    let h: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(64);
    let params = Params::parse(&args[3.min(args.len())..]).expect("key=value");
    let lights = params.u32("lights", 0, 0, 1 << 16).unwrap() as usize;
    let p = VoxArrayParams::default().read(&params).unwrap();
    let mut scene = glimpse_scene::load(&scene_name).unwrap();
    if lights > 0 {
        let cell = scene.bounds().extent().max_element() / p.resolution as f32;
        scene.lights = surface_lights(&scene, lights, cell);
    }
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let camera = scene.camera_or_default(w as f32 / h as f32);
    let g = GBuffer::new(&frame, &tracer, &camera, w, h);
    let a = VoxArray::build(&frame, &p);
    let cell = a.grid().cell_size_world();
    println!("{scene_name}: {} lights, cell {cell:.3} m", frame.lights.len());
    if let Some(c) = a.compression() {
        println!(
            "compression: {} rows, {} distinct, dictionary {}, mapped per step {:?}, random {} ({:.2} %)",
            c.rows,
            c.distinct_rows,
            c.dictionary_rows,
            c.mapped_at_step,
            c.random,
            100.0 * c.random as f64 / c.rows.max(1) as f64
        );
    }
    // Histograms in cells: [0,1), [1,2), [2,4), [4,8), [8,16), [16,∞).
    let bin = |c: f32| match c {
        c if c < 1.0 => 0,
        c if c < 2.0 => 1,
        c if c < 4.0 => 2,
        c if c < 8.0 => 3,
        c if c < 16.0 => 4,
        _ => 5,
    };
    let (mut fv_start, mut fv_end, mut fi_len, mut all_len) = ([0u64; 6], [0u64; 6], [0u64; 6], [0u64; 6]);
    let (mut fv, mut fi, mut n, mut back) = (0u64, 0u64, 0u64, 0u64);
    // How far the true segment's ends leave the row through its midpoint (cells): the angular
    // snapping to the nearest of n×n directions, grown with the segment's length.
    let (mut drift_all, mut drift_fi, mut drift_fv) = ([0u64; 6], [0u64; 6], [0u64; 6]);
    let drift = |a: glimpse_core::Vec3, b: glimpse_core::Vec3| {
        let (i, j) = glimpse_voxarray::directions::discretize(b - a, p.directions);
        let n = p.directions;
        let row = glimpse_voxarray::directions::row_direction(
            glimpse_voxarray::directions::angle_rad(n, i),
            glimpse_voxarray::directions::angle_rad(n, j),
        );
        let d = b - a;
        0.5 * d.cross(row).length() / cell
    };
    for i in 0..g.len() {
        let Some(s) = Shading::from_gbuffer(&g, i) else { continue };
        for light in &frame.lights {
            let ps = direct::punctual(light, s.position, s.normal, s.error_scale);
            let facing = ps.wi.dot(s.normal) > 0.0;
            let exact = tracer.closest_hit(&ps.shadow, ps.t_max);
            let vox = a.occluded_from_surface(&ps, s.normal);
            let len = ps.t_max.min(1e6) / cell;
            let (sa, sb) = a.surface_segment(&ps, s.normal);
            let dr = bin(8.0 * drift(sa, sb)); // eighths of a cell
            n += 1;
            all_len[bin(len)] += 1;
            drift_all[dr] += 1;
            match (exact, vox) {
                (Some(hit), false) => {
                    fv += 1;
                    drift_fv[dr] += 1;
                    back += u64::from(!facing);
                    fv_start[bin(hit.t / cell)] += 1;
                    fv_end[bin((ps.t_max - hit.t) / cell)] += 1;
                }
                (None, true) => {
                    fi += 1;
                    drift_fi[dr] += 1;
                    back += u64::from(!facing);
                    fi_len[bin(len)] += 1;
                }
                _ => {}
            }
        }
    }
    println!(
        "decisions {n}: wrongly visible {fv} ({:.2} %), wrongly shadowed {fi} ({:.2} %), of which light behind the surface {back}",
        100.0 * fv as f64 / n as f64,
        100.0 * fi as f64 / n as f64
    );
    println!("bins (cells):            [0,1) [1,2) [2,4) [4,8) [8,16) [16,∞)");
    println!("segment length, all:     {all_len:?}");
    println!("wrongly visible, blocker from start: {fv_start:?}");
    println!("wrongly visible, blocker from light: {fv_end:?}");
    println!("wrongly shadowed, segment length:    {fi_len:?}");
    println!("end drift off the row, all:          {drift_all:?}");
    println!("end drift, wrongly visible:          {drift_fv:?}");
    println!("end drift, wrongly shadowed:         {drift_fi:?}");
    let e = glimpse_render::metrics::epsilon::epsilon(&frame, &g, &tracer, frame.lights.len(), |_, ps, s| {
        a.occluded_from_surface(ps, s.normal)
    });
    println!("{} lights: ε_v {:.2} %, |ε_s| {:.2} %", e.lights, 100.0 * e.all.epsilon_v(), 100.0 * e.all.epsilon_s_abs());
    // `refine` (lights-voxarray's default under 128 lights): the occluded answers confirmed by
    // the exact ray, so only the missed occluders are left.
    let traced = std::sync::atomic::AtomicU64::new(0);
    let e = glimpse_render::metrics::epsilon::epsilon(&frame, &g, &tracer, frame.lights.len(), |_, ps, s| {
        a.occluded_from_surface(ps, s.normal) && {
            traced.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            tracer.occluded(&ps.shadow, ps.t_max)
        }
    });
    println!(
        "refined: ε_v {:.2} %, |ε_s| {:.2} %, exact rays for {} of {n} decisions",
        100.0 * e.all.epsilon_v(),
        100.0 * e.all.epsilon_s_abs(),
        traced.into_inner()
    );
    // `refine_near`: the visible answers also checked by the exact ray over their first cells,
    // where the start offsets step over contact occluders.
    let cell = a.grid().cell_size_world();
    for cells in [1.0f32, 2.0, 3.0, 4.0] {
        let near = cells * cell;
        let e = glimpse_render::metrics::epsilon::epsilon(&frame, &g, &tracer, frame.lights.len(), |_, ps, s| {
            if a.occluded_from_surface(ps, s.normal) {
                tracer.occluded(&ps.shadow, ps.t_max)
            } else {
                tracer.occluded(&ps.shadow, ps.t_max.min(near))
            }
        });
        println!(
            "refined, near {cells} cells ({near:.3} m) exact: ε_v {:.2} %, |ε_s| {:.2} %",
            100.0 * e.all.epsilon_v(),
            100.0 * e.all.epsilon_s_abs()
        );
    }
}
