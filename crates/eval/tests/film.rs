//! Pixel filters (issue #12 item 2): frames shade successive primary samples drawn from the
//! film's filter, so averaging frames anti-aliases, and a technique and its reference shade
//! the same samples.

use glimpse_core::{Mat4, Vec3};
use glimpse_eval::experiment::render_frames;
use glimpse_render::{FrameContext, Params, Registry, Settings};
use glimpse_scene::{Camera, Filter, Light, Material, Mesh, Scene};

/// A lit square whose right edge runs down the middle of the middle pixel column of a
/// 9-pixel-wide image, so that column is exactly half covered.
fn half_covered(filter: Filter) -> Scene {
    let mut s = Scene { name: "edge".into(), ..Default::default() };
    let white = s.add_material(Material::diffuse("white", Vec3::ONE));
    let c = Vec3::new;
    let mesh = Mesh::quad("square", white, [c(-10., -10., 0.), c(0., -10., 0.), c(0., 10., 0.), c(-10., 10., 0.)]);
    s.add_mesh(mesh, Mat4::IDENTITY);
    s.lights.push(Light::directional(Vec3::new(0.0, 0.0, -1.0), Vec3::splat(std::f32::consts::PI)));
    s.camera = Some(Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 20.0));
    s.film.filter = filter;
    s
}

fn render(scene: &Scene, frames: u32) -> glimpse_core::Image {
    let registry = Registry::new(glimpse_render::techniques());
    let mut t = registry.create("lights-exact", scene, &Settings { spp: 1, seed: 0 }, &Params::default()).unwrap();
    let mut ctx = FrameContext::new(scene, 0.0, 9, 5);
    let g = ctx.gbuffer();
    render_frames(t.as_mut(), &mut ctx, &g, frames).unwrap().image
}

#[test]
fn averaged_frames_converge_to_the_box_filtered_edge() {
    let lit = render(&half_covered(Filter::PixelCentre), 1).pixels[2 * 9].x;
    for (filter, expected) in [(Filter::Box, 0.5), (Filter::Tent, 0.5), (Filter::Gaussian, 0.5)] {
        let img = render(&half_covered(filter), 256);
        let (left, middle, right) = (img.pixels[2 * 9 + 1].x, img.pixels[2 * 9 + 4].x, img.pixels[2 * 9 + 7].x);
        println!("{}: lit {lit:.3}; columns 1, 4, 7 of row 2: {left:.3} {middle:.3} {right:.3}", filter.name());
        assert!((middle / lit - expected).abs() < 0.06, "{filter:?}: the half-covered pixel is {middle}, not {expected} × {lit}");
        assert!(right == 0.0, "{filter:?}: pixels off the square stay black");
        assert!((left - lit).abs() < 1e-4 * lit, "{filter:?}: pixels well inside the square stay fully lit");
    }
    // The edge is 1 pixel from the neighbouring columns' centres: the box and the tent (radius
    // 1) never reach it from there, the gaussian (radius 2) sometimes does.
    for filter in [Filter::Box, Filter::Tent] {
        let img = render(&half_covered(filter), 64);
        assert_eq!((img.pixels[2 * 9 + 3].x, img.pixels[2 * 9 + 5].x), (lit, 0.0), "{filter:?}: the neighbouring columns see one side");
    }
    let gaussian = render(&half_covered(Filter::Gaussian), 256);
    let (l, r) = (gaussian.pixels[2 * 9 + 3].x, gaussian.pixels[2 * 9 + 5].x);
    println!("gaussian: columns 3 and 5: {l:.3} {r:.3}");
    assert!(r > 0.0 && l < lit && r < 0.1 && l > 0.9 * lit, "gaussian: the neighbouring columns are slightly mixed");
    // Pixel centres: one sample, on one side of the edge.
    let centre = render(&half_covered(Filter::PixelCentre), 8);
    let m = centre.pixels[2 * 9 + 4].x;
    assert!(m == 0.0 || (m - lit).abs() < 1e-4 * lit, "pixel-centre: the middle pixel is all or nothing, got {m}");
}

#[test]
fn the_same_pass_gives_the_same_gbuffer_and_passes_differ() {
    let scene = half_covered(Filter::Box);
    let mut ctx = FrameContext::new(&scene, 0.0, 9, 5);
    let a = ctx.gbuffer();
    let b = ctx.gbuffer();
    ctx.film_pass = 1;
    let c = ctx.gbuffer();
    assert_eq!(a.view_dir, b.view_dir, "a pass's samples depend only on the pixel and the pass");
    assert_ne!(a.view_dir, c.view_dir, "passes draw different samples");
    // Every sample stays inside its pixel under the box filter.
    let centre = GBufferCentre::new(&ctx);
    for (i, d) in c.view_dir.iter().enumerate() {
        let angle = d.angle_between(centre.0[i]);
        assert!(angle < centre.1, "pixel {i}: sample {angle} rad from the centre ray, a pixel is {} rad", centre.1);
    }
}

/// Pixel-centre directions and the angle half a pixel diagonal spans.
struct GBufferCentre(Vec<Vec3>, f32);

impl GBufferCentre {
    fn new(ctx: &FrameContext) -> Self {
        let g = glimpse_trace::GBuffer::new(&ctx.frame, &ctx.tracer, &ctx.camera, ctx.width, ctx.height);
        let corner = ctx.camera.ray(0.0, 0.0, ctx.width, ctx.height).dir;
        let half_diagonal = corner.angle_between(g.view_dir[0]) * 1.01;
        Self(g.view_dir, half_diagonal)
    }
}
