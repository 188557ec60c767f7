//! The exact tracer against Intel Embree on the same rays: random rays through the scene and
//! ambient-occlusion rays from the GBuffer (radius 10% of the scene diagonal, and ∞), for
//! any-hit and closest-hit, on the Cornell box and the Stanford bunny. The two use different
//! triangle tests (watertight vs Embree's), so rays grazing an edge may differ: agreement must
//! be at least 99.99%.
#![cfg(feature = "embree")]

use glimpse_core::sampling::uniform_sphere;
use glimpse_core::{Ray, Rng, Vec3};
use glimpse_scene::{Scene, SceneFrame};
use glimpse_trace::embree::EmbreeScene;
use glimpse_trace::{ClosestHit, ExactTracer, Visibility, rays};

const REQUIRED: f64 = 0.9999;

fn random_rays(frame: &SceneFrame, n: usize, seed: u64) -> Vec<(Ray, f32)> {
    let b = frame.bounds;
    let mut rng = Rng::new(seed, 0);
    (0..n)
        .map(|i| {
            let o = b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.2 - b.extent() * 0.1;
            let d = uniform_sphere(rng.next_2d());
            let t_max = if i % 3 == 0 { f32::INFINITY } else { rng.next_f32() * b.extent().length() };
            (Ray::new(o, d), t_max)
        })
        .collect()
}

/// (any-hit agreement, closest-hit agreement, fraction of rays occluded) over `rays`.
fn agreement(ours: &ExactTracer, embree: &EmbreeScene, rays: &[(Ray, f32)]) -> (f64, f64, f64) {
    let (mut any_ok, mut closest_ok, mut blocked) = (0usize, 0usize, 0usize);
    for (ray, t_max) in rays {
        let occluded = ours.occluded(ray, *t_max);
        blocked += occluded as usize;
        any_ok += (occluded == Visibility::occluded(embree, ray, *t_max)) as usize;
        let same = match (ours.closest_hit(ray, *t_max), embree.closest_hit(ray, *t_max)) {
            (None, None) => true,
            // The same triangle, or a tie in t (a shared edge, coplanar triangles).
            (Some(a), Some(b)) => (a.instance, a.triangle) == (b.instance, b.triangle) || (a.t - b.t).abs() <= 1e-5 * a.t.max(1.0),
            _ => false,
        };
        closest_ok += same as usize;
    }
    let n = rays.len().max(1) as f64;
    (any_ok as f64 / n, closest_ok as f64 / n, blocked as f64 / n)
}

fn check_scene(name: &str, scene: &Scene) {
    let frame = scene.at(0.0);
    let ours = ExactTracer::build(&frame);
    let embree = EmbreeScene::build(&frame).expect("Embree device");
    assert_eq!(embree.triangle_count(), ours.triangle_count());
    let diagonal = frame.bounds.extent().length();
    let camera = scene.camera_or_default(1.0);
    let sets = [
        ("random rays", random_rays(&frame, 100_000, 17)),
        ("AO rays r=10% diag", rays::ao_rays(&frame, &ours, &camera, 128, 128, 4, 0.1 * diagonal, 1)),
        ("AO rays r=inf", rays::ao_rays(&frame, &ours, &camera, 128, 128, 4, f32::INFINITY, 2)),
    ];
    for (set, rays) in &sets {
        assert!(rays.len() > 10_000, "{name}: too few {set}");
        let (any, closest, blocked) = agreement(&ours, &embree, rays);
        println!(
            "{name} ({} triangles), {} {set} ({:.1}% occluded): any-hit agreement {:.4}%, closest-hit agreement {:.4}%",
            ours.triangle_count(),
            rays.len(),
            blocked * 100.0,
            any * 100.0,
            closest * 100.0
        );
        assert!(any >= REQUIRED, "{name}, {set}: any-hit agreement {any}");
        assert!(closest >= REQUIRED, "{name}, {set}: closest-hit agreement {closest}");
    }
}

#[test]
fn cornell_agrees_with_embree() {
    check_scene("cornell", &glimpse_scene::load("cornell").unwrap());
}

#[test]
fn bunny_agrees_with_embree() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/scenes/stanford-bunny/stanford-bunny.obj");
    if !std::path::Path::new(path).exists() {
        println!("skipped: {path} not found (../shared is absent)");
        return;
    }
    let scene = match glimpse_scene::load(path) {
        Ok(s) => s,
        Err(e) => {
            println!("skipped: the OBJ loader could not load the bunny: {e}");
            return;
        }
    };
    check_scene("bunny", &scene);
}
