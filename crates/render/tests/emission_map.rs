//! An emissive texture lights the scene per texel: a quad whose texture emits on its half
//! x > 0 only lights the floor under `pt` as that half drawn as geometry does (its light
//! samples take the sampled point's texel, its BSDF hits the hit's texel), not as the whole
//! quad at the texture's mean.

use glimpse_core::{Image, Mat4, Vec2, Vec3};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::{Camera, EmissionMap, Material, Mesh, Scene};

enum Lamp {
    /// The whole quad, a 64 × 1 texture: 0 on its half x < 0, 1 on the other.
    Textured,
    /// The half x > 0 as geometry, emitting the texture's bright value.
    Half,
    /// The whole quad at the texture's mean (what the loader did before).
    Mean,
}

fn scene(lamp: Lamp) -> Scene {
    let mut s = Scene::default();
    let floor = s.add_material(Material::diffuse("floor", Vec3::splat(0.8)));
    let factor = Vec3::new(6.0, 5.0, 4.0);
    let material = match lamp {
        Lamp::Textured => {
            s.textures.push(Image::from_fn(64, 1, |x, _| Vec3::splat(if x < 32 { 0.0 } else { 1.0 })));
            Material { emission_map: Some(EmissionMap { texture: 0, factor }), ..Material::emissive("lamp", factor * 0.5) }
        }
        Lamp::Half => Material::emissive("lamp", factor),
        Lamp::Mean => Material::emissive("lamp", factor * 0.5),
    };
    let lamp_material = s.add_material(material);
    let c = Vec3::new;
    s.add_mesh(Mesh::quad("floor", floor, [c(-3., 0., -3.), c(3., 0., -3.), c(3., 0., 3.), c(-3., 0., 3.)]), Mat4::IDENTITY);
    // Facing down; u = 0 at x = −0.5 and u = 1 at x = 0.5.
    let (x0, u0) = if let Lamp::Half = lamp { (0.0, 0.5) } else { (-0.5, 0.0) };
    let mut m = Mesh::quad("lamp", lamp_material, [c(x0, 0.6, -0.5), c(0.5, 0.6, -0.5), c(0.5, 0.6, 0.5), c(x0, 0.6, 0.5)]);
    m.uvs = vec![Vec2::new(u0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(u0, 1.0)];
    s.add_mesh(m, Mat4::IDENTITY);
    s.camera = Some(Camera::look_at(c(0.0, 2.0, 2.0), Vec3::ZERO, Vec3::Y, 60.0));
    s
}

/// The floor's radiance in the image's left and right thirds (under the dark and the bright
/// half).
fn thirds(scene: &Scene) -> [f64; 2] {
    let ctx = FrameContext::new(scene, 0.0, 30, 24);
    let mut img = ctx.image();
    let mut pt = PathTracer::new(&Settings { spp: 64, seed: 5 }, &Params::default()).unwrap();
    pt.prepare(&ctx).unwrap();
    pt.render(&ctx, &ctx.gbuffer(), &mut img).unwrap();
    let mean = |x0: u32, x1: u32| {
        let px: Vec<f64> = (0..24).flat_map(|y| (x0..x1).map(move |x| (x, y))).map(|(x, y)| img.get(x, y).y as f64).collect();
        px.iter().sum::<f64>() / px.len() as f64
    };
    [mean(0, 10), mean(20, 30)]
}

#[test]
fn an_emissive_texture_lights_per_texel() {
    let (textured, half, mean) = (thirds(&scene(Lamp::Textured)), thirds(&scene(Lamp::Half)), thirds(&scene(Lamp::Mean)));
    println!("floor radiance (left, right third): textured {textured:.4?}, the bright half as geometry {half:.4?}, the mean {mean:.4?}");
    for k in 0..2 {
        assert!((textured[k] / half[k] - 1.0).abs() < 0.03, "third {k}: {} vs {}", textured[k], half[k]);
    }
    // The test can fail: the mean lights both sides alike.
    assert!(mean[1] / mean[0] < 0.8 * half[1] / half[0], "{mean:?} vs {half:?}");
}
