//! `focus=auto` (ours): ROMA's grid surrounds the triangles other than the scene's supporting
//! planes, which every query tests exactly. A 400 m ground under a 2 m ball made the paper's
//! cube's cells 4.4 m wide at 128³: the 1.5-cell origin offset lifted every AO ray 6.6 m, above
//! the ball, and the 10 cm gap under it was one cell with the ground.

use glimpse_core::{Image, Ray, Vec3};
use glimpse_render::ao::AoExact;
use glimpse_render::{FrameContext, Params, Settings, Stats, Technique};
use glimpse_roma::{Roma, RomaParams};
use glimpse_trace::{ClosestHit, Visibility};

mod common;
use common::ball_over_ground as scene;

fn rmse(a: &Image, b: &Image) -> f64 {
    let sum: f64 = a.pixels.iter().zip(&b.pixels).map(|(p, q)| ((p.x - q.x) as f64).powi(2)).sum();
    (sum / a.pixels.len() as f64).sqrt()
}

/// `ao-roma` after 16 frames of 2 samples, and the last frame's stats.
fn ao_roma(ctx: &mut FrameContext, focus: &str) -> (Image, Stats) {
    common::accumulated_ao_roma(ctx, 2, 3, 16, focus)
}

fn metric(stats: &Stats, key: &str) -> Option<f64> {
    stats.metrics.iter().find(|(k, _)| k == key).map(|(_, v)| *v)
}

#[test]
fn a_focused_grid_keeps_the_contact_shadow_a_scene_wide_one_loses() {
    let scene = scene();
    let mut ctx = FrameContext::new(&scene, 0.0, 64, 48);
    let mut reference = ctx.image();
    AoExact::new(&Settings { spp: 256, seed: 9 }, &Params::default()).unwrap().render(&ctx, &ctx.gbuffer(), &mut reference).unwrap();
    let (wide, wide_stats) = ao_roma(&mut ctx, "focus=scene");
    let (focused, focused_stats) = ao_roma(&mut ctx, "focus=auto");
    let (e_wide, e_focused) = (rmse(&wide, &reference), rmse(&focused, &reference));
    println!(
        "ao-roma vs ao-exact (256 spp) after 16 frames: scene-wide cube (cell {:.2} m) RMSE {e_wide:.4}; focused (cell {:.3} m, \
         focus {:.4} of the scene's diagonal) RMSE {e_focused:.4}",
        metric(&wide_stats, "cell_m").unwrap(),
        metric(&focused_stats, "cell_m").unwrap(),
        metric(&focused_stats, "focus_share").unwrap(),
    );
    assert!(metric(&wide_stats, "focus_share").is_none());
    assert!(metric(&focused_stats, "cell_m").unwrap() < 0.05 * metric(&wide_stats, "cell_m").unwrap());
    assert!(e_wide > 0.1, "the scene-wide cube must lose the ball's occlusion: RMSE {e_wide}");
    assert!(e_focused < 0.4 * e_wide && e_focused < 0.07, "RMSE {e_wide} → {e_focused}");
}

#[test]
fn the_ground_left_out_of_the_grid_is_hit_exactly() {
    let scene = scene();
    let frame = scene.at(0.0);
    let roma = Roma::build(&frame, &RomaParams { focus: true, ..RomaParams::default() }, 1, 0);
    assert!(roma.focus_share().is_some_and(|s| s < 0.05), "focused: {:?}", roma.focus_share());
    // 50 m from the ball, 0.5 m over the ground: outside the grid, only the ground below.
    let p = Vec3::new(50.0, 0.5, 0.0);
    let (k, sign) = roma.select(-Vec3::Y);
    let d = roma.candidates().dirs[k] * sign;
    let t = roma.closest_hit_snapped(k, sign, p, f32::INFINITY).expect("the ground below");
    println!("closest hit down the snapped direction {d:?}: {t} m (exact {} m)", 0.5 / -d.y);
    assert!((t - 0.5 / -d.y).abs() < 1e-4, "{t}");
    assert!(roma.any_hit_snapped(k, sign, p, f32::INFINITY));
    assert!(!roma.any_hit_snapped(k, sign, p, 0.4), "the ground is beyond t_max");
    let (k_up, sign_up) = roma.select(Vec3::Y);
    assert!(!roma.any_hit_snapped(k_up, sign_up, p, f32::INFINITY), "nothing above");
    // The bare-ray backends (`bench rays`) and the un-snapped segments see it too.
    assert!(roma.occluded(&Ray::new(p, -Vec3::Y), f32::INFINITY));
    assert!(roma.closest_hit(&Ray::new(p, -Vec3::Y), f32::INFINITY).is_some_and(|h| (h.t - 0.5 / -d.y).abs() < 1e-3));
    assert!(roma.any_hit_unsnapped(p, p - Vec3::Y, 8));
    assert!(!roma.any_hit_unsnapped(p, p + Vec3::Y, 8));
    // The ball is in the grid: a ray from the ground's far side... from under it, up, is blocked.
    let under = Vec3::new(0.0, 0.02, 0.0);
    let (k, sign) = roma.select(Vec3::Y);
    assert!(roma.any_hit_snapped(k, sign, under, f32::INFINITY), "the ball above");
}
