//! `focus=auto` (ours): a static scene's array covers the triangles that can block a shadow ray,
//! not the whole scene. A ground has the scene on one side and cannot block a segment between
//! two of its points; a 2 km ground under a 12 m dome made the paper's cube's cells 44 m wide at
//! this test's 64³ (22 m at 128³), so the start offset stepped over the dome and most of its
//! shadow vanished; focused on the dome the cells are 0.29 m.

use glimpse_render::{FrameContext, Params, Settings, Stats, Technique};
use glimpse_voxarray::technique::LightsVoxArray;

mod common;
use common::dome_on_ground as scene;

fn render(scene: &glimpse_scene::Scene, focus: &str) -> Stats {
    let ctx = FrameContext::new(scene, 0.0, 64, 48);
    let g = ctx.gbuffer();
    // The array's own answers: near checks of 2 of the scene-wide cube's 44 m cells would
    // trace the whole dome exactly.
    let args = ["resolution=64", "directions=30", "disk_cache=false", "refine_near=0", focus];
    let params = Params::parse(&args).unwrap();
    let mut t = LightsVoxArray::new(scene, &Settings::default(), &params).unwrap();
    params.finish("lights-voxarray").unwrap();
    let mut stats = t.prepare(&ctx).unwrap();
    let mut img = ctx.image();
    let render = t.render(&ctx, &g, &mut img).unwrap();
    stats.metrics.extend(render.metrics);
    stats
}

fn metric(stats: &Stats, key: &str) -> Option<f64> {
    stats.metrics.iter().find(|(k, _)| k == key).map(|(_, v)| *v)
}

#[test]
fn a_focused_array_keeps_the_shadow_a_scene_wide_one_loses() {
    let scene = scene();
    let (wide, focused) = (render(&scene, "focus=scene"), render(&scene, "focus=auto"));
    let (eps_wide, eps_focused) = (metric(&wide, "eps_s_pct").unwrap(), metric(&focused, "eps_s_pct").unwrap());
    println!(
        "scene-wide cube: cell {:.1} m, ε_s {eps_wide:.2} %; focused: cell {:.2} m (focus {:.3} of the scene's diagonal), ε_s {eps_focused:.2} %",
        metric(&wide, "cell_m").unwrap(),
        metric(&focused, "cell_m").unwrap(),
        metric(&focused, "focus_share").unwrap(),
    );
    assert!(metric(&wide, "focus_share").is_none());
    assert!(metric(&focused, "cell_m").unwrap() < 0.25 * metric(&wide, "cell_m").unwrap());
    assert!(eps_wide > 3.0, "the scene-wide cube must lose the dome's shadow: ε_s {eps_wide}");
    assert!(eps_focused < 0.5 * eps_wide && eps_focused < 3.0, "ε_s {eps_wide} → {eps_focused}");
}

#[test]
fn a_room_its_occluders_fill_is_not_focused() {
    let scene = glimpse_scene::builtin::cornell_lit();
    let stats = render(&scene, "focus=auto");
    assert!(metric(&stats, "focus_share").is_none(), "the Cornell box's blocks span most of it: the scene's cube");
    let params = Params::parse(&["profile=paper"]).unwrap();
    assert!(!LightsVoxArray::new(&scene, &Settings::default(), &params).unwrap().focus, "profile=paper: the scene's cube");
}
