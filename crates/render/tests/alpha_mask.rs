//! A cut-out emitter (glTF alpha MASK on an emissive quad) lights the scene as the part that is
//! there: `pt`'s light samples that fall in the cut-out count nothing (the density over the
//! whole triangle keeps the estimate unbiased), and its BSDF rays pass through it.

use glimpse_core::{Image, Mat4, Vec3};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::{AlphaMask, Camera, Material, Mesh, Scene};

/// A floor under a 1 m emissive square, 0.6 m up, facing down; `cut`: its half x < 0 cut out
/// by a mask, else geometry of the half x > 0 alone (the same emitter, drawn as geometry).
fn scene(cut: bool) -> Scene {
    let mut s = Scene::default();
    let floor = s.add_material(Material::diffuse("floor", Vec3::splat(0.8)));
    let coverage = s.textures.len() as u32;
    s.textures.push(Image::from_fn(2, 1, |x, _| Vec3::splat(x as f32)));
    let mask = cut.then_some(AlphaMask { texture: Some(coverage), factor: 1.0, cutoff: 0.5 });
    let lamp = s.add_material(Material { alpha_mask: mask, ..Material::emissive("lamp", Vec3::splat(5.0)) });
    let c = Vec3::new;
    s.add_mesh(Mesh::quad("floor", floor, [c(-3., 0., -3.), c(3., 0., -3.), c(3., 0., 3.), c(-3., 0., 3.)]), Mat4::IDENTITY);
    // Corners in order give u = 0 at x = −0.5 and u = 1 at x = 0.5; covered where u ≥ 0.5.
    let x0 = if cut { -0.5 } else { 0.0 };
    let (uv0, uv1) = if cut { (0.0, 1.0) } else { (0.5, 1.0) };
    let mut m = Mesh::quad("lamp", lamp, [c(x0, 0.6, -0.5), c(0.5, 0.6, -0.5), c(0.5, 0.6, 0.5), c(x0, 0.6, 0.5)]);
    m.uvs = vec![
        glimpse_core::Vec2::new(uv0, 0.0),
        glimpse_core::Vec2::new(uv1, 0.0),
        glimpse_core::Vec2::new(uv1, 1.0),
        glimpse_core::Vec2::new(uv0, 1.0),
    ];
    s.add_mesh(m, Mat4::IDENTITY);
    s.camera = Some(Camera::look_at(c(0.0, 2.0, 2.0), Vec3::ZERO, Vec3::Y, 60.0));
    s
}

fn mean_floor(scene: &Scene) -> f64 {
    let ctx = FrameContext::new(scene, 0.0, 24, 24);
    let mut img = ctx.image();
    let mut pt = PathTracer::new(&Settings { spp: 64, seed: 5 }, &Params::default()).unwrap();
    pt.prepare(&ctx).unwrap();
    pt.render(&ctx, &ctx.gbuffer(), &mut img).unwrap();
    img.pixels.iter().map(|p| p.x as f64).sum::<f64>() / img.pixels.len() as f64
}

#[test]
fn a_cut_out_emitter_lights_as_its_covered_part() {
    let (cut, half) = (mean_floor(&scene(true)), mean_floor(&scene(false)));
    println!("mean radiance: masked whole quad {cut:.4}, the covered half as geometry {half:.4}");
    assert!((cut / half - 1.0).abs() < 0.03, "{cut} vs {half}");
}
