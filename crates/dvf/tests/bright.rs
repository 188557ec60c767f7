//! `bright` (ours): rays toward the map's brightest texels are traced whatever the masks say.
//! The bright set against the map it comes from, `auto`'s choice, and the image of a room lit
//! by a small sun through a slit in its roof against `env-exact` on the same rays.

mod common;

use glimpse_core::{Image, Mat4, Vec2, Vec3, luminance};
use glimpse_dvf::bright::{BrightDirections, RESOLUTION};
use glimpse_dvf::grid::octahedral_pixel;
use glimpse_dvf::technique::EnvDvf;
use glimpse_render::env::EnvExact;
use glimpse_render::metrics::rmse;
use glimpse_render::{FrameContext, Params, Settings, Stats, Technique};
use glimpse_scene::{Camera, Environment, Material, Mesh, Scene};

/// A map of `background` with a `size`-texel square of `radiance` at texel (x, y).
fn map_with_square(w: u32, h: u32, background: f32, radiance: f32, (x, y): (u32, u32), size: u32) -> Environment {
    let image = Image::from_fn(w, h, |i, j| {
        let inside = (x..x + size).contains(&i) && (y..y + size).contains(&j);
        Vec3::splat(if inside { radiance } else { background })
    });
    Environment::new(image, 1.0)
}

#[test]
fn the_bright_set_is_the_maps_brightest_texels() {
    let env = map_with_square(256, 128, 1.0, 1e4, (100, 40), 4);
    let b = BrightDirections::new(&env, 0.2, 8).expect("a map with a bright square");
    let texel = |x: f32, y: f32| Environment::uv_to_dir(Vec2::new(x / 256.0, y / 128.0));
    let inside = texel(102.0, 42.0);
    let far = -inside;
    println!(
        "square of 16 texels at 1e4 on 1.0: threshold {}, {:.4} sr, {:.1} % of the power; {} of {} fine pixels marked",
        b.threshold,
        b.part.solid_angle,
        100.0 * b.part.power_fraction,
        b.pixels.iter().map(|w| w.count_ones()).sum::<u32>(),
        RESOLUTION * RESOLUTION
    );
    // The 16 texels fit in 0.2 sr; the background is tied at 1.0 and stays out.
    assert_eq!(b.threshold, 1.0);
    assert!(b.part.power_fraction > 0.8 && b.part.solid_angle < 0.01);
    assert!(b.may_hold(octahedral_pixel(inside, 8)) && b.holds(inside, &|| env.radiance(inside)));
    assert!(!b.holds(far, &|| env.radiance(far)));
    // Every direction that reads the square through the bilinear lookup is marked, also at its
    // border (a lookup point within one texel of a bright texel's centre).
    let mut rng = glimpse_core::Rng::new(3, 0);
    let mut checked = 0;
    for _ in 0..20_000 {
        let u = rng.next_2d();
        let d = texel(98.5 + 7.0 * u.x, 38.5 + 7.0 * u.y);
        if luminance(env.radiance(d)) > b.threshold {
            checked += 1;
            assert!(b.may_hold(octahedral_pixel(d, 8)) && b.holds(d, &|| env.radiance(d)), "{d:?}");
        }
    }
    println!("{checked} directions reading the square: every one bright");
    assert!(checked > 5_000);
    // A constant map has nothing brighter than the rest; a black one no light.
    assert!(BrightDirections::new(&Environment::constant(Vec3::ONE), 0.2, 8).is_none());
    assert!(BrightDirections::new(&Environment::constant(Vec3::ZERO), 0.2, 8).is_none());
    // `auto`: on for a map whose rays are noisy (a small sun), off for a smooth one.
    let sun = Environment::procedural_sky(128, Vec3::new(0.2, 1.0, 0.1), 5000.0);
    let smooth = map_with_square(64, 32, 1.0, 2.0, (10, 10), 8);
    let (n_sun, n_smooth) = (glimpse_dvf::cosine_estimator_noise(&sun, 128), glimpse_dvf::cosine_estimator_noise(&smooth, 128));
    println!(
        "auto: a 5,000 sun's noise {n_sun:.3} → {}; a smooth map's {n_smooth:.3} → {}",
        glimpse_dvf::choose_bright(n_sun),
        glimpse_dvf::choose_bright(n_smooth)
    );
    assert!(glimpse_dvf::choose_bright(n_sun) && !glimpse_dvf::choose_bright(n_smooth));
}

/// A floor under a roof with a slit, the sun straight above the slit.
fn slit_room() -> Scene {
    let quad = |x0: f32, x1: f32, y: f32, z0: f32, z1: f32, up: bool| {
        let p = [Vec3::new(x0, y, z0), Vec3::new(x1, y, z0), Vec3::new(x1, y, z1), Vec3::new(x0, y, z1)];
        let indices = if up { vec![[0, 2, 1], [0, 3, 2]] } else { vec![[0, 1, 2], [0, 2, 3]] };
        Mesh { name: "quad".into(), positions: p.to_vec(), indices, ..Default::default() }
    };
    let mut s = Scene { name: "slit room".into(), ..Default::default() };
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    for mut mesh in [quad(-2.0, 2.0, 0.0, -2.0, 2.0, true), quad(-2.0, -0.1, 1.0, -2.0, 2.0, false), quad(0.1, 2.0, 1.0, -2.0, 2.0, false)]
    {
        mesh.material = m;
        s.add_mesh(mesh, Mat4::IDENTITY);
    }
    s.environment = Some(Environment::procedural_sky(256, Vec3::new(0.05, 1.0, 0.0), 5000.0));
    s.camera = Some(Camera::look_at(Vec3::new(0.0, 0.6, 1.8), Vec3::new(0.0, 0.0, 0.0), Vec3::Y, 60.0));
    s
}

/// The image and the render's stats.
fn render(t: &mut dyn Technique, ctx: &FrameContext) -> (Image, Stats) {
    let (img, _, stats) = common::render(t, ctx);
    (img, stats)
}

#[test]
fn a_sun_through_a_slit_is_traced() {
    let scene = slit_room();
    let ctx = FrameContext::new(&scene, 0.0, 48, 36);
    let settings = Settings { spp: 1, seed: 4 };
    let (reference, exact_stats) = render(&mut EnvExact::new(&settings, &Params::parse(&["rays=32"]).unwrap()).unwrap(), &ctx);
    let mut results = Vec::new();
    // A sparse field, a few samples per cell (as `sponza-interior`'s 10,000 at 320 × 180): a
    // cell whose samples lie under the roof marks the sun's pixel occluded for the stripe the
    // slit lights too (RMSE 1.17 without `bright`, with the sun at 5,000). One cell's masks
    // (`footprint=cell`): the default neighbourhood footprint also catches this stripe (RMSE
    // 0.0046 without `bright`), by tracing 87 % of env-exact's rays in a room this small.
    for bright in ["bright=off", "bright=auto"] {
        let keys = ["rays=32", "points=600", "grid=12", "footprint=cell", bright];
        let mut t = EnvDvf::new(&settings, &Params::parse(&keys).unwrap()).unwrap();
        let (img, stats) = render(&mut t, &ctx);
        let e = rmse(&img, &reference, None).unwrap();
        println!("{bright}: RMSE {e:.5} against env-exact on the same rays; {} rays ({} for env-exact)", stats.rays, exact_stats.rays);
        results.push((e, stats.rays));
    }
    let ((off, off_rays), (on, on_rays)) = (results[0], results[1]);
    assert!(on < 0.02 && on < 0.05 * off, "bright: {on} vs {off}");
    assert!(on_rays > off_rays && on_rays < exact_stats.rays, "the sun's rays cost few: {on_rays} vs {off_rays}");
}
