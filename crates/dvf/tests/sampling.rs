//! Where the build's samples go and what they trace.
//!
//! `sides=seen` (ours, not the default): a sample traces its back hemisphere only on the
//! instances the camera sees from behind. A one-sided surface's back rays describe where no
//! pixel looks, and they land in the cells of everything near it: under a ground plane they
//! escape, the plane's cells say "visible" downwards, and an object's underside in those cells
//! skips its downward rays, which hit the plane (lit undersides). The default stays `both`
//! (`DvfParams::back_instances` says why).

mod common;

use glimpse_core::Vec3;
use glimpse_dvf::technique::EnvDvf;
use glimpse_render::env::EnvExact;
use glimpse_render::metrics::rmse;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::{Camera, Scene};

fn courtyard() -> Scene {
    glimpse_scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/courtyard.toml")).expect("test scene loads")
}

/// The image and the prepare's stats.
fn render(t: &mut dyn Technique, ctx: &FrameContext) -> (glimpse_core::Image, glimpse_render::Stats) {
    let (img, prepared, _) = common::render(t, ctx);
    (img, prepared)
}

fn metric(stats: &glimpse_render::Stats, name: &str) -> f64 {
    stats.metrics.iter().find(|(k, _)| k == name).map(|&(_, v)| v).unwrap_or_else(|| panic!("metric {name}"))
}

#[test]
fn sides_seen_traces_back_hemispheres_only_where_the_camera_sees_back_faces() {
    let mut scene = courtyard();
    let settings = Settings { spp: 1, seed: 3 };
    let (w, h) = (64, 40);
    let measure = |scene: &Scene| {
        let ctx = FrameContext::new(scene, 0.0, w, h);
        let reference = render(&mut EnvExact::new(&settings, &Params::parse(&["rays=64"]).unwrap()).unwrap(), &ctx).0;
        // One cell's masks (`footprint=cell`): the default neighbourhood footprint already
        // traces the rays the ground's escaping back rays would skip (both sides then within
        // 1e-12 of `seen` from above).
        let run = |pairs: &[&str]| {
            let pairs: Vec<String> =
                ["rays=64", "points=4000", "unshadowed=rays", "footprint=cell"].iter().chain(pairs).map(|s| s.to_string()).collect();
            let (img, prep) = render(&mut EnvDvf::new(&settings, &Params::parse(&pairs).unwrap()).unwrap(), &ctx);
            (rmse(&img, &reference, None).unwrap(), metric(&prep, "back_side_instances"), metric(&prep, "build_rays"))
        };
        (ctx.instances_seen_from_behind(128), run(&["sides=seen"]), run(&[]), run(&["sides=front"]))
    };

    // From above: every surface in view is seen from its front, so no back hemisphere is traced.
    let (behind, seen, both, front) = measure(&scene);
    println!("from above: seen from behind {behind:?}; RMSE (same rays) seen {:.5}, both {:.5}, front {:.5}", seen.0, both.0, front.0);
    assert!(behind.is_empty());
    assert_eq!(seen.1, 0.0);
    assert_eq!(seen.0, front.0, "seen is front here");
    assert!(seen.0 < both.0, "the ground's back rays, escaping under it, must cost accuracy: {} vs {}", seen.0, both.0);
    assert!(seen.2 < both.2);

    // From under the ground plane (instance 0), looking up through it: its back is in view.
    scene.camera = Some(Camera::look_at(Vec3::new(0.5, -2.0, 5.0), Vec3::new(0.0, 0.0, 0.0), Vec3::Y, 50.0));
    let (behind, seen, both, front) = measure(&scene);
    println!("from below: seen from behind {behind:?}; RMSE (same rays) seen {:.5}, both {:.5}, front {:.5}", seen.0, both.0, front.0);
    assert_eq!(behind, vec![0]);
    assert_eq!(seen.1, 1.0);
    assert!(seen.2 > front.2 && seen.2 < both.2, "only the ground's samples trace twice");
    assert!(seen.0 < front.0, "seen from below, the ground needs its back hemisphere: {} vs {}", seen.0, front.0);
}

/// With more triangles than four samples each, `rounding=auto` takes the rounded running total
/// (`cumulative`): it keeps the budget, where Xu et al.'s `round` misses it by the sum of every
/// triangle's rounding (here over: the ground's 128 cells each round 0.7 up; on
/// `million-triangles` under: 6,270 of 10,000, the bunnies' triangles each rounding to 0).
#[test]
fn cumulative_rounding_keeps_the_budget_on_fine_meshes() {
    let scene = courtyard();
    let settings = Settings { spp: 1, seed: 5 };
    let ctx = FrameContext::new(&scene, 0.0, 64, 40);
    let triangles = ctx.frame.scene.triangle_count();
    let reference = render(&mut EnvExact::new(&settings, &Params::parse(&["rays=64"]).unwrap()).unwrap(), &ctx).0;
    let points = (triangles / 5) as u32;
    let run = |rounding: &str| {
        let pairs = [
            "rays=64".to_owned(),
            format!("points={points}"),
            "grid=8".to_owned(),
            "unshadowed=rays".to_owned(),
            format!("rounding={rounding}"),
        ];
        let mut t = EnvDvf::new(&settings, &Params::parse(&pairs).unwrap()).unwrap();
        let img = render(&mut t, &ctx).0;
        (rmse(&img, &reference, None).unwrap(), t.dvf.as_ref().unwrap().samples)
    };
    let (auto, cumulative, round) = (run("auto"), run("cumulative"), run("round"));
    println!(
        "{triangles} triangles, N_P = {points}: cumulative {} samples, RMSE {:.5}; round {} samples, RMSE {:.5}",
        cumulative.1, cumulative.0, round.1, round.0
    );
    assert_eq!(auto, cumulative, "auto picks cumulative here");
    assert_eq!(cumulative.1, points as u64, "the budget, exactly");
    assert!(round.1.abs_diff(points as u64) > points as u64 / 10, "round misses the budget");
    assert!(cumulative.0 < round.0);
}
