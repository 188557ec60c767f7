//! Alpha-masked surfaces (glTF `alphaMode: MASK`): the exact tracer passes through a triangle
//! where its coverage is under the cutoff, for closest-hit, any-hit and shadow-cached queries,
//! on static and moving instances, as pbrt's and Mitsuba's alpha tests do.

use glimpse_core::{Image, Mat4, Ray, Vec3};
use glimpse_scene::{AlphaMask, Instance, Material, Mesh, Motion, Scene};
use glimpse_trace::{ExactTracer, ShadowCache};

/// A 4 × 4 m opaque wall at z = −1 behind a 2 × 2 m masked quad at z = 0 (uv u = (x + 1)/2),
/// whose coverage texture is 0 in its left texel and 1 in its right (bilinear between the
/// texel centres at u = 0.25 and 0.75); a moving copy of the quad 5 m up; and a quad at z = 0.5,
/// 10 m to the right, whose factor (0.3) alone is under the cutoff.
fn scene() -> Scene {
    let mut s = Scene::default();
    let wall = s.add_material(Material::diffuse("wall", Vec3::splat(0.5)));
    let coverage = s.textures.len() as u32;
    s.textures.push(Image::from_fn(2, 1, |x, _| Vec3::splat(x as f32)));
    let mask = AlphaMask { texture: Some(coverage), factor: 1.0, cutoff: 0.5 };
    let leaf = s.add_material(Material { alpha_mask: Some(mask), ..Material::diffuse("leaf", Vec3::splat(0.5)) });
    let faint = AlphaMask { texture: None, factor: 0.3, cutoff: 0.5 };
    let ghost = s.add_material(Material { alpha_mask: Some(faint), ..Material::diffuse("ghost", Vec3::splat(0.5)) });
    let quad = |z: f32, h: f32| [Vec3::new(-h, -h, z), Vec3::new(h, -h, z), Vec3::new(h, h, z), Vec3::new(-h, h, z)];
    s.add_mesh(Mesh::quad("wall", wall, quad(-1.0, 20.0)), Mat4::IDENTITY);
    let leaf_mesh = s.add_mesh(Mesh::quad("leaf", leaf, quad(0.0, 1.0)), Mat4::IDENTITY);
    s.add_mesh(Mesh::quad("ghost", ghost, quad(0.5, 1.0)), Mat4::from_translation(Vec3::new(10.0, 0.0, 0.0)));
    s.instances.push(Instance {
        mesh: leaf_mesh,
        motion: Motion::Orbit {
            base: Mat4::from_translation(Vec3::new(0.0, 5.0, 0.0)),
            center: Vec3::new(0.0, 5.0, 0.0),
            axis: Vec3::Z,
            period_s: 1e6,
            phase: 0.0,
        },
    });
    s
}

fn down(x: f32, y: f32) -> Ray {
    Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z)
}

#[test]
fn masked_texels_are_holes_for_every_query() {
    let scene = scene();
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    // (x, y, what the ray should meet first at z = 0 or pass to the wall at z = −1).
    let cases = [
        (-0.8, -0.5, "hole"), // u = 0.1: coverage 0
        (-0.3, -0.8, "hole"), // u = 0.35: coverage 0.2
        (0.1, -0.8, "leaf"),  // u = 0.55: coverage 0.6
        (0.8, 0.5, "leaf"),   // u = 0.9: coverage 1
        (-0.8, 5.5, "hole"),  // the moving copy
        (0.8, 4.5, "leaf"),   // the moving copy
        (10.5, 0.5, "hole"),  // the faint quad: its factor is under the cutoff everywhere
        (-1.5, -1.5, "hole"), // beside the quad
    ];
    for (x, y, want) in cases {
        let hit = tracer.closest_hit(&down(x, y), f32::INFINITY).expect("the wall is behind everything");
        let got = if (hit.t - 1.0).abs() < 1e-4 { "leaf" } else { "hole" };
        println!("ray at ({x}, {y}): t = {:.4}, {got}", hit.t);
        assert_eq!(got, want, "ray at ({x}, {y})");
        if want == "hole" {
            assert!((hit.t - 2.0).abs() < 1e-4, "through the hole to the wall: t = {}", hit.t);
        }
        // Any-hit before the wall: only the leaf's opaque part.
        assert_eq!(tracer.occluded(&down(x, y), 1.5), want == "leaf", "occluded at ({x}, {y})");
    }
    // The shadow cache remembers a triangle hit in its opaque part; a ray through the same
    // triangle's hole must not be answered from it.
    let mut cache = ShadowCache::default();
    assert!(tracer.occluded_cached(&down(0.8, -0.5), 1.5, &mut cache));
    assert!(!tracer.occluded_cached(&down(-0.3, -0.8), 1.5, &mut cache), "a hole answered from the shadow cache");
    assert!(tracer.occluded_cached(&down(0.8, -0.5), 1.5, &mut cache));
}

/// Rays traced together (`occluded_many`, a static scene's packets) see the same holes, and
/// a triangle remembered from one packet's opaque part answers nothing through its holes.
#[test]
fn packets_see_the_holes() {
    let mut scene = scene();
    scene.instances.retain(|i| i.motion.is_static());
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let rays: Vec<(Ray, f32)> = (0..40 * 40).map(|k| (down(-1.2 + 0.06 * (k % 40) as f32, -1.2 + 0.06 * (k / 40) as f32), 1.5)).collect();
    let mut packed = vec![false; rays.len()];
    tracer.occluded_many(&rays, &mut packed);
    let one_by_one: Vec<bool> = rays.iter().map(|(r, t)| tracer.occluded(r, *t)).collect();
    let blocked = one_by_one.iter().filter(|&&b| b).count();
    println!("{blocked} of {} rays blocked by the leaf's opaque texels", rays.len());
    assert!(blocked > 100 && blocked < rays.len() - 100, "both holes and leaf are crossed");
    assert_eq!(packed, one_by_one);
}

/// A scene without masks builds no coverage at all, and the same quad unmasked is opaque.
#[test]
fn an_unmasked_quad_is_opaque_everywhere() {
    let mut scene = scene();
    scene.materials.iter_mut().for_each(|m| m.alpha_mask = None);
    assert!(!scene.has_alpha_masks());
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    for (x, y) in [(-0.8, -0.5), (-0.3, -0.8), (0.8, 0.5), (10.5, 0.5)] {
        assert!(tracer.occluded(&down(x, y), 1.5), "ray at ({x}, {y})");
        let t = tracer.closest_hit(&down(x, y), f32::INFINITY).unwrap().t;
        let want = if x > 5.0 { 0.5 } else { 1.0 };
        assert!((t - want).abs() < 1e-4, "ray at ({x}, {y}): t = {t}");
    }
}
