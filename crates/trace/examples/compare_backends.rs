//! Single-thread throughput of the exact tracer against Intel Embree and the `obvhs` crate on
//! the SAME ambient-occlusion rays (from a 256×256 GBuffer, 4 rays per pixel, radius 10% of the
//! scene diagonal and ∞), any-hit and closest-hit, in Mrays/s.
//!
//! ```text
//! cargo run --release -p glimpse-trace --example compare_backends --features embree,obvhs-compare [SCENE...]
//! ```
//!
//! SCENE: built-in names or scene files; by default `cornell` and the Stanford bunny from
//! `../shared` (skipped if absent or unloadable). Without the features only our tracer runs.
//! Every backend traces all the rays in the same order on the calling thread. Timings are taken
//! in rounds, each round one full pass of every query (so a busy machine slows all backends
//! alike), and each query's best pass is kept; every backend's hit count is printed so
//! disagreements show. `GLIMPSE_MEASURE_MS` sets the minimum measuring time per query (default
//! 1500).

use glimpse_core::Ray;
use glimpse_scene::Scene;
#[cfg(feature = "embree")]
use glimpse_trace::{ClosestHit, Visibility};
use glimpse_trace::{ExactTracer, rays};
use std::hint::black_box;
use std::time::{Duration, Instant};

const WIDTH: u32 = 256;
const HEIGHT: u32 = 256;
const RAYS_PER_PIXEL: u32 = 4;
/// Rounds go on until every query has had at least this much time and five passes.
fn min_measure() -> Duration {
    let ms = std::env::var("GLIMPSE_MEASURE_MS").ok().and_then(|v| v.parse().ok()).unwrap_or(1500);
    Duration::from_millis(ms)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let specs = if args.is_empty() {
        vec!["cornell".to_string(), concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/scenes/stanford-bunny/stanford-bunny.obj").into()]
    } else {
        args
    };
    println!(
        "single thread, {WIDTH}x{HEIGHT} GBuffer, {RAYS_PER_PIXEL} AO rays per hit pixel; Mrays/s, best full pass of >= {:?} per query",
        min_measure()
    );
    for spec in specs {
        match glimpse_scene::load(&spec) {
            Ok(scene) => compare(&short_name(&spec), &scene),
            Err(e) => println!("\n{spec}: skipped ({e})"),
        }
    }
}

fn short_name(spec: &str) -> String {
    std::path::Path::new(spec).file_stem().map_or(spec.into(), |s| s.to_string_lossy().into_owned())
}

/// A query that answers true (occluded, or hit) or false.
type Query<'a> = Box<dyn Fn(&Ray, f32) -> bool + 'a>;
/// A closest-hit query: the distance to the hit.
type Distance<'a> = Box<dyn Fn(&Ray, f32) -> Option<f32> + 'a>;

/// A backend under test: its name and its any-hit and closest-hit queries.
struct Backend<'a> {
    name: &'static str,
    occluded: Query<'a>,
    closest: Distance<'a>,
}

fn compare(name: &str, scene: &Scene) {
    let frame = scene.at(0.0);
    let t = Instant::now();
    let ours = ExactTracer::build(&frame);
    let build_ours = t.elapsed();
    println!("\n== {name}: {} triangles; ExactTracer build {:.1} ms (rayon, all cores)", ours.triangle_count(), ms(build_ours));

    #[cfg(feature = "embree")]
    let embree = {
        let t = Instant::now();
        let e = glimpse_trace::embree::EmbreeScene::build(&frame).expect("Embree device");
        println!("Embree build {:.1} ms (its own threads)", ms(t.elapsed()));
        e
    };
    #[cfg(feature = "obvhs-compare")]
    let ob = obvhs_backends::Obvhs::build(&frame);

    #[cfg_attr(not(any(feature = "embree", feature = "obvhs-compare")), allow(unused_mut, clippy::useless_vec))]
    let mut backends = vec![Backend {
        name: "ours (ExactTracer)",
        occluded: Box::new(|r, t| ours.occluded(r, t)),
        closest: Box::new(|r, t| ours.closest_hit(r, t).map(|h| h.t)),
    }];

    #[cfg(feature = "embree")]
    backends.push(Backend {
        name: "Embree 3 (rtcOccluded1/rtcIntersect1)",
        occluded: Box::new(|r, t| Visibility::occluded(&embree, r, t)),
        closest: Box::new(|r, t| embree.closest_hit(r, t).map(|h| h.t)),
    });

    #[cfg(feature = "obvhs-compare")]
    backends.extend(ob.backends());

    let camera = scene.camera_or_default(WIDTH as f32 / HEIGHT as f32);
    let gbuffer = glimpse_trace::GBuffer::new(&frame, &ours, &camera, WIDTH, HEIGHT);
    let diagonal = frame.bounds.extent().length();
    for (label, radius) in [("r = 10% diag", 0.1 * diagonal), ("r = inf", f32::INFINITY)] {
        let rays = rays::ao_rays_from(&gbuffer, RAYS_PER_PIXEL, radius, 1);
        println!("-- AO rays, {label}: {} rays", rays.len());
        let queries: Vec<Query> = backends
            .iter()
            .flat_map(|b| {
                [Box::new(|r: &Ray, t: f32| (b.occluded)(r, t)) as Query, Box::new(|r: &Ray, t: f32| (b.closest)(r, t).is_some())]
            })
            .collect();
        let results = measure(&rays, &queries);
        // Ours is first: every other line says how many times faster or slower ours is.
        let ours_rates = (results[0].0, results[1].0);
        for (i, b) in backends.iter().enumerate() {
            let ((any, occluded), (closest, hit)) = (results[2 * i], results[2 * i + 1]);
            let ratio = if i == 0 {
                String::new()
            } else {
                format!("  ours/this: any-hit {:.2}, closest-hit {:.2}", ours_rates.0 / any, ours_rates.1 / closest)
            };
            println!("  {:<40} any-hit {any:>6.2} ({occluded} occluded)  closest-hit {closest:>6.2} ({hit} hit){ratio}", b.name);
        }
    }
}

/// Per query: its best throughput (Mrays/s) over full single-thread passes, and its number of
/// `true`s. Passes go round-robin over the queries until each has had `min_measure()`.
fn measure(rays: &[(Ray, f32)], queries: &[Query]) -> Vec<(f64, usize)> {
    let pass = |q: &Query| {
        let t = Instant::now();
        let n = rays.iter().filter(|(r, t_max)| q(black_box(r), *t_max)).count();
        (t.elapsed(), black_box(n))
    };
    let counts: Vec<usize> = queries.iter().map(|q| pass(q).1).collect(); // also warms caches
    let mut best = vec![Duration::MAX; queries.len()];
    let mut total = vec![Duration::ZERO; queries.len()];
    let mut rounds = 0;
    while rounds < 5 || total.iter().any(|&t| t < min_measure()) {
        for (i, q) in queries.iter().enumerate() {
            let (d, n) = pass(q);
            assert_eq!(n, counts[i], "a backend answered differently on the same rays");
            best[i] = best[i].min(d);
            total[i] += d;
        }
        rounds += 1;
    }
    best.iter().zip(counts).map(|(b, n)| (rays.len() as f64 / b.as_secs_f64() / 1e6, n)).collect()
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

#[cfg(feature = "obvhs-compare")]
mod obvhs_backends {
    //! The `obvhs` crate (PLOC build, `medium_build` preset) as a BVH2 and as a compressed wide
    //! BVH8 (CWBVH) over the same world-space triangles, traversed with its own closures. The
    //! leaf test is our watertight test (same as ours and so the BVHs are what differs), plus
    //! one run with obvhs's own Möller–Trumbore test.

    use super::{Backend, ms};
    use glimpse_core::{Ray, Vec3A};
    use glimpse_trace::SceneFrame;
    use glimpse_trace::triangle::PreparedRay;
    use obvhs::BvhBuildParams;
    use obvhs::bvh2::{Bvh2, builder::build_bvh2_from_tris};
    use obvhs::cwbvh::{CwBvh, builder::build_cwbvh_from_tris};
    use obvhs::ray::{Ray as ORay, RayHit};
    use obvhs::triangle::Triangle;
    use std::time::{Duration, Instant};

    pub struct Obvhs {
        cwbvh: CwBvh,
        /// Triangles in `cwbvh.primitive_indices` order, for both tests.
        cw_tris: Vec<[Vec3A; 3]>,
        cw_otris: Vec<Triangle>,
        bvh2: Bvh2,
        bvh2_tris: Vec<[Vec3A; 3]>,
    }

    impl Obvhs {
        pub fn build(frame: &SceneFrame) -> Obvhs {
            let mut tris = Vec::new();
            for (ii, inst) in frame.scene.instances.iter().enumerate() {
                let m = frame.transforms[ii];
                let pos = &frame.positions[inst.mesh as usize];
                for t in &frame.scene.meshes[inst.mesh as usize].indices {
                    let [v0, v1, v2] = t.map(|i| Vec3A::from(m.transform_point3(pos[i as usize])));
                    tris.push(Triangle { v0, v1, v2 });
                }
            }
            let params = BvhBuildParams::medium_build();
            let t = Instant::now();
            let cwbvh = build_cwbvh_from_tris(&tris, params, &mut Duration::default());
            let cw_time = t.elapsed();
            let t = Instant::now();
            let bvh2 = build_bvh2_from_tris(&tris, params, &mut Duration::default());
            println!("obvhs build (medium_build, one thread): CWBVH {:.1} ms, BVH2 {:.1} ms", ms(cw_time), ms(t.elapsed()));
            let order = |idx: &[u32]| idx.iter().map(|&i| tris[i as usize]).collect::<Vec<Triangle>>();
            let as_arrays = |ts: &[Triangle]| ts.iter().map(|t| [t.v0, t.v1, t.v2]).collect::<Vec<_>>();
            let cw_otris = order(&cwbvh.primitive_indices);
            let bvh2_tris = as_arrays(&order(&bvh2.primitive_indices));
            Obvhs { cw_tris: as_arrays(&cw_otris), cw_otris, cwbvh, bvh2, bvh2_tris }
        }

        pub fn backends(&self) -> Vec<Backend<'_>> {
            let oray = |r: &Ray, t: f32| ORay::new(r.origin.into(), r.dir.into(), 0.0, t);
            let watertight = |tris: &[[Vec3A; 3]], p: &PreparedRay, i: usize, t_max: f32| {
                p.intersect_triangle(&tris[i], t_max).map_or(f32::INFINITY, |h| h.0)
            };
            vec![
                Backend {
                    name: "obvhs CWBVH + our watertight test",
                    occluded: Box::new(move |r, t| {
                        let p = PreparedRay::new(r);
                        !self.cwbvh.ray_traverse_miss(oray(r, t), |ray, i| watertight(&self.cw_tris, &p, i, ray.tmax))
                    }),
                    closest: Box::new(move |r, t| {
                        let p = PreparedRay::new(r);
                        let mut hit = RayHit::none();
                        self.cwbvh.ray_traverse(oray(r, t), &mut hit, |ray, i| watertight(&self.cw_tris, &p, i, ray.tmax)).then_some(hit.t)
                    }),
                },
                Backend {
                    name: "obvhs CWBVH + its Moller-Trumbore test",
                    occluded: Box::new(move |r, t| !self.cwbvh.ray_traverse_miss(oray(r, t), |ray, i| self.cw_otris[i].intersect(ray))),
                    closest: Box::new(move |r, t| {
                        let mut hit = RayHit::none();
                        self.cwbvh.ray_traverse(oray(r, t), &mut hit, |ray, i| self.cw_otris[i].intersect(ray)).then_some(hit.t)
                    }),
                },
                Backend {
                    name: "obvhs BVH2 + our watertight test",
                    occluded: Box::new(move |r, t| {
                        let p = PreparedRay::new(r);
                        !self.bvh2.ray_traverse_miss(oray(r, t), |ray, i| watertight(&self.bvh2_tris, &p, i, ray.tmax))
                    }),
                    closest: Box::new(move |r, t| {
                        let p = PreparedRay::new(r);
                        let mut hit = RayHit::none();
                        self.bvh2.ray_traverse(oray(r, t), &mut hit, |ray, i| watertight(&self.bvh2_tris, &p, i, ray.tmax)).then_some(hit.t)
                    }),
                },
            ]
        }
    }
}
