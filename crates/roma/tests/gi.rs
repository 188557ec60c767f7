//! `gi-roma` against `gi-exact`: the bounce (`include_direct=false`, so only ROMA's part is
//! compared) accumulated over 16 frames, against the exact bounce at many samples. On a scene
//! lit by the environment alone the bounce comes from the map's directional RSMs
//! (`env_lights`); without them (`env_lights=0`, the paper) it is black. Measured (session 36):
//! under the sky 0.936× `gi-exact`'s mean bounce (0.976× with `env_rsm=1024`: what is left is
//! the maps' texels, 13 cm here, against the box's edges), the Cornell box 1.004×.

use glimpse_core::Image;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_roma::technique::GiRoma;
use glimpse_scene::Scene;

const SIZE: u32 = 48;
const FRAMES: u32 = 16;

/// A white box on a white floor under a uniform sky, nothing else: every bounce is the sky's
/// light reflected by the floor or the box. The camera looks down and sees no sky (a pixel that
/// sees the map shows it whatever the technique).
fn box_under_a_sky() -> Scene {
    let toml = "[camera]\nposition = [1.8, 2.2, 2.0]\ntarget = [0.0, 0.2, 0.0]\nfov_y_degrees = 45.0\n\
        [environment]\nconstant = [1.0, 1.0, 1.0]\n\
        [[quad]]\nsize = [24.0, 24.0]\nmaterial = { base_color = [0.8, 0.8, 0.8] }\n\
        [[box]]\nsize = [1.0, 1.0, 1.0]\ntranslate = [0.0, 0.5, 0.0]\nmaterial = { base_color = [0.8, 0.8, 0.8] }\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    glimpse_scene::load(path.to_str().unwrap()).unwrap()
}

/// `gi-roma`'s bounce accumulated over [`FRAMES`] frames of 4 samples, with `extra` parameters.
fn roma_bounce(ctx: &mut FrameContext, extra: &[&str]) -> Image {
    let g = ctx.gbuffer();
    let mut pairs = vec!["include_direct=false", "accumulate=16"];
    pairs.extend_from_slice(extra);
    let params = Params::parse(&pairs).unwrap();
    let mut t = GiRoma::new(ctx.frame.scene, &Settings { spp: 4, seed: 1 }, &params).unwrap();
    params.finish("gi-roma").unwrap();
    let mut img = ctx.image();
    for k in 0..FRAMES {
        ctx.frame_index = k;
        t.prepare(ctx).unwrap();
        t.render(ctx, &g, &mut img).unwrap();
    }
    ctx.frame_index = 0;
    img
}

fn exact_bounce(ctx: &FrameContext, spp: u32) -> Image {
    let g = ctx.gbuffer();
    let params = Params::parse(&["include_direct=false"]).unwrap();
    let mut t = glimpse_render::gi::GiExact::new(&Settings { spp, seed: 2 }, &params).unwrap();
    let mut img = ctx.image();
    t.prepare(ctx).unwrap();
    t.render(ctx, &g, &mut img).unwrap();
    img
}

fn mean(img: &Image) -> f64 {
    img.pixels.iter().map(|p| p.x as f64 + p.y as f64 + p.z as f64).sum::<f64>() / (3 * img.pixels.len()) as f64
}

fn rmse(a: &Image, b: &Image) -> f64 {
    let se: f64 = a.pixels.iter().zip(&b.pixels).map(|(x, y)| (*x - *y).length_squared() as f64 / 3.0).sum();
    (se / a.pixels.len() as f64).sqrt()
}

#[test]
fn the_environments_bounce_matches_gi_exact() {
    let scene = box_under_a_sky();
    let mut ctx = FrameContext::new(&scene, 0.0, SIZE, SIZE);
    let exact = exact_bounce(&ctx, 1024);
    let roma = roma_bounce(&mut ctx, &[]);
    let paper = roma_bounce(&mut ctx, &["profile=paper"]);
    let (m_exact, m_roma, m_paper) = (mean(&exact), mean(&roma), mean(&paper));
    let relative = rmse(&roma, &exact) / m_exact;
    println!(
        "bounce under a sky, {SIZE}² after {FRAMES} frames: mean gi-exact {m_exact:.4}, gi-roma {m_roma:.4} \
         ({:.3}×), RMSE {:.1} % of the mean; profile=paper (no environment RSMs) {m_paper:.4}",
        m_roma / m_exact,
        100.0 * relative
    );
    assert!(m_exact > 0.05, "the scene has a bounce to compare: {m_exact}");
    assert!((m_roma / m_exact - 1.0).abs() < 0.15, "gi-roma's mean bounce {m_roma} against gi-exact's {m_exact}");
    assert!(relative < 0.5, "RMSE {:.1} % of the mean", 100.0 * relative);
    assert_eq!(m_paper, 0.0, "without the environment's RSMs no light reaches the bounce");
}

#[test]
fn the_cornell_boxs_bounce_matches_gi_exact() {
    let scene = glimpse_scene::builtin::cornell();
    let mut ctx = FrameContext::new(&scene, 0.0, SIZE, SIZE);
    let exact = exact_bounce(&ctx, 1024);
    let roma = roma_bounce(&mut ctx, &[]);
    let (m_exact, m_roma) = (mean(&exact), mean(&roma));
    let relative = rmse(&roma, &exact) / m_exact;
    println!(
        "Cornell box bounce, {SIZE}² after {FRAMES} frames: mean gi-exact {m_exact:.4}, gi-roma {m_roma:.4} ({:.3}×), RMSE {:.1} % of the mean",
        m_roma / m_exact,
        100.0 * relative
    );
    assert!((m_roma / m_exact - 1.0).abs() < 0.15, "gi-roma's mean bounce {m_roma} against gi-exact's {m_exact}");
    assert!(relative < 0.5, "RMSE {:.1} % of the mean", 100.0 * relative);
}
