//! Secondary rays leaving points on edges shared by two separate meshes (issue #12 item 1).
//!
//! A room built of five separate wall meshes whose edges coincide exactly, lit by a point
//! light inside it: every wall point sees the light, so an exactly-zero pixel on a wall is a
//! secondary ray that started outside the room. Cameras are placed so that pixel-centre rays
//! land exactly on the shared edges (a square image looking along an axis of the box puts its
//! diagonal pixels on the wall/wall edges), at several resolutions.

use glimpse_core::{Mat4, Vec3};
use glimpse_render::{FrameContext, Params, Registry, Settings};
use glimpse_scene::{Camera, Light, Material, Mesh, Scene};

/// The box [-1, 1]³ open at z = +1, one mesh per wall, lit by a point light inside it.
fn room(camera: Camera) -> Scene {
    let mut s = Scene { name: "shared-edges".into(), ..Default::default() };
    let white = s.add_material(Material::diffuse("white", Vec3::splat(0.7)));
    let c = Vec3::new;
    let walls = [
        ("floor", [c(-1., -1., -1.), c(1., -1., -1.), c(1., -1., 1.), c(-1., -1., 1.)]),
        ("ceiling", [c(-1., 1., -1.), c(-1., 1., 1.), c(1., 1., 1.), c(1., 1., -1.)]),
        ("back", [c(-1., -1., -1.), c(-1., 1., -1.), c(1., 1., -1.), c(1., -1., -1.)]),
        ("left", [c(-1., -1., -1.), c(-1., -1., 1.), c(-1., 1., 1.), c(-1., 1., -1.)]),
        ("right", [c(1., -1., -1.), c(1., 1., -1.), c(1., 1., 1.), c(1., -1., 1.)]),
    ];
    for (name, q) in walls {
        s.add_mesh(Mesh::quad(name, white, q), Mat4::IDENTITY);
    }
    s.lights.push(Light::point(Vec3::new(0.2, 0.3, 0.1), Vec3::splat(1.0)));
    s.camera = Some(camera);
    // Pixel centres, where the rays land exactly on the edges (a jittered film would rarely).
    s.film.filter = glimpse_scene::Filter::PixelCentre;
    s
}

fn cameras() -> Vec<(&'static str, Camera)> {
    vec![
        ("outside, on the axis", Camera::look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y, 39.3077)),
        ("inside, on the axis", Camera::look_at(Vec3::new(0.0, 0.0, 0.9), Vec3::new(0.0, 0.0, -1.0), Vec3::Y, 90.0)),
        ("inside, towards a corner", Camera::look_at(Vec3::new(0.3, -0.2, 0.5), Vec3::new(-1.0, 1.0, -1.0), Vec3::Y, 70.0)),
    ]
}

fn render(scene: &Scene, id: &str, set: &[&str], spp: u32, size: u32) -> (glimpse_core::Image, glimpse_trace::GBuffer) {
    let registry = Registry::new(glimpse_render::techniques());
    let params = Params::parse(set).unwrap();
    let mut t = registry.create(id, scene, &Settings { spp, seed: 7 }, &params).unwrap();
    let ctx = FrameContext::new(scene, 0.0, size, size);
    let g = ctx.gbuffer();
    t.prepare(&ctx).unwrap();
    let mut img = ctx.image();
    t.render(&ctx, &g, &mut img).unwrap();
    (img, g)
}

/// Wall pixels that are exactly black although every wall point sees the light.
#[test]
fn no_black_wall_pixels_at_shared_edges() {
    let mut total = 0;
    for (what, camera) in cameras() {
        let scene = room(camera);
        for size in [64, 101, 128, 256] {
            for (id, spp) in [("lights-exact", 1), ("pt", 2)] {
                let (img, g) = render(&scene, id, &[], spp, size);
                let black: Vec<(u32, u32)> = (0..g.len())
                    .filter(|&i| g.is_hit(i) && img.pixels[i].max_element() <= 0.0)
                    .map(|i| (i as u32 % size, i as u32 / size))
                    .collect();
                println!("{id} {what} {size}²: {} black wall pixels {:?}", black.len(), &black[..black.len().min(6)]);
                total += black.len();
            }
        }
    }
    assert_eq!(total, 0, "wall pixels black although lit");
}

/// Ambient occlusion of the pixels on the diagonal (on the shared edges when looking along the
/// box's axis) stays within noise of the pixels beside them.
#[test]
fn ambient_occlusion_on_edges_matches_its_neighbours() {
    let (what, camera) = cameras().remove(0);
    let scene = room(camera);
    let size = 128;
    let spp = 256;
    let (img, g) = render(&scene, "ao-exact", &["radius=1"], spp, size);
    let at = |x: u32, y: u32| img.pixels[(y * size + x) as usize].x;
    let (mut worst, mut sum, mut checked) = (0.0f32, 0.0f32, 0);
    for x in 2..size - 2 {
        for y in [x, size - 1 - x] {
            if !g.is_hit((y * size + x) as usize) || !g.is_hit((y * size + x + 1) as usize) || !g.is_hit((y * size + x - 1) as usize) {
                continue;
            }
            let beside = 0.5 * (at(x - 1, y) + at(x + 1, y));
            worst = worst.max((at(x, y) - beside).abs());
            sum += at(x, y) - beside;
            checked += 1;
        }
    }
    // Binomial noise of one pixel at 256 rays is at most 0.03; a neighbour one pixel away may
    // differ by the true gradient too.
    // A concave edge is where AO is lowest: on average the edge pixels must not be brighter
    // than the pixels beside them (rays escaping through the edge made them 0.3 brighter).
    let mean = sum / checked as f32;
    println!("ao-exact {what}: {checked} diagonal pixels, mean edge − neighbours {mean:.4}, worst |edge − neighbours| = {worst:.3}");
    assert!(checked > 100);
    assert!(mean < 0.01, "edge pixels brighter than their neighbours on average: {mean}");
    assert!(worst < 0.15, "edge pixels of ao-exact differ from their neighbours by {worst}");
}
