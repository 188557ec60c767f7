//! `snap_weight=cos` (ours): a snapped sample weighted by its candidate's cosine over its
//! stratum's mean cosine ([`glimpse_roma::CandidateSet::cosine_weight`]). The paper's count
//! lets each wide stratum's uniformly jittered candidate stand for a cosine-weighted share, so
//! occluders low on a surface's horizon count too much: a ground metres from a wall is darker
//! than `ao-exact` however many frames are averaged.

use glimpse_core::Image;
use glimpse_render::ao::AoExact;
use glimpse_render::{FrameContext, Params, Settings, Technique};

mod common;

/// A 20 m ground and a 4 × 1.5 m wall 4 m ahead of the camera, which looks down at the ground
/// in front of it: every pixel's occluder (the wall) is low on its horizon.
fn ground_before_a_wall() -> glimpse_scene::Scene {
    let toml = "[camera]\nposition = [0.0, 1.2, 3.0]\ntarget = [0.0, 0.0, 0.5]\nfov_y_degrees = 40.0\n\
        [[quad]]\nsize = [20.0, 20.0]\n\
        [[box]]\nsize = [4.0, 1.5, 0.1]\ntranslate = [0.0, 0.75, -1.0]\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    glimpse_scene::load(path.to_str().unwrap()).unwrap()
}

fn mean(image: &Image) -> f64 {
    image.pixels.iter().map(|p| p.x as f64).sum::<f64>() / image.pixels.len() as f64
}

#[test]
fn weighted_snapping_removes_the_ground_s_darkening() {
    let scene = ground_before_a_wall();
    let mut ctx = FrameContext::new(&scene, 0.0, 48, 32);
    let mut reference = ctx.image();
    AoExact::new(&Settings { spp: 1024, seed: 9 }, &Params::default()).unwrap().render(&ctx, &ctx.gbuffer(), &mut reference).unwrap();
    let exact = mean(&reference);
    let counted = mean(&common::accumulated_ao_roma(&mut ctx, 4, 5, 64, "snap_weight=none").0) - exact;
    let weighted = mean(&common::accumulated_ao_roma(&mut ctx, 4, 5, 64, "snap_weight=cos").0) - exact;
    println!("mean AO: ao-exact (1024 spp) {exact:.4}; ao-roma after 64 frames × 4 spp: counted {counted:+.4}, weighted {weighted:+.4}");
    assert!(counted < -0.01, "the paper's count darkens the ground: {counted:+.4}");
    assert!(weighted.abs() < 0.3 * counted.abs(), "weighted {weighted:+.4} against counted {counted:+.4}");
}
