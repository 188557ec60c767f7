//! A normal map bends the shading normal for every technique: a floor whose normal texture
//! tilts every texel's normal renders, in the GBuffer and under `pt`, as the same floor with
//! that tilted normal at its vertices, and not as the flat floor.

use glimpse_core::{Image, Mat4, Vec2, Vec3};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::{Bitangent, Camera, Environment, Material, Mesh, NormalMap, NormalMapShadowing, Scene};

/// The tilted normal, in world space (the floor's frame: T = +x, B = −z, N = +y).
fn tilted() -> Vec3 {
    Vec3::new(0.35, 1.0, 0.2).normalize()
}

enum Floor {
    /// Flat vertex normals and a 1 × 1 normal texture holding the tilt.
    Mapped,
    /// The tilt at every vertex.
    Tilted,
    Flat,
}

fn scene(floor: Floor) -> Scene {
    let mut s = Scene::default();
    let mut material = Material { roughness: 0.3, ..Material::diffuse("floor", Vec3::new(0.8, 0.6, 0.4)) };
    if let Floor::Mapped = floor {
        let n = tilted();
        let local = Vec3::new(n.x, -n.z, n.y); // (T, B, N) components
        s.textures.push(Image::from_fn(1, 1, |_, _| (local + Vec3::ONE) * 0.5));
        material.normal_map =
            Some(NormalMap { texture: 0, scale: 1.0, bitangent: Bitangent::ImageUp, shadowing: NormalMapShadowing::None });
    }
    let m = s.add_material(material);
    let c = Vec3::new;
    let mut quad = Mesh::quad("floor", m, [c(-2., 0., -2.), c(2., 0., -2.), c(2., 0., 2.), c(-2., 0., 2.)]);
    quad.uvs = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
    quad.normals = vec![if let Floor::Tilted = floor { tilted() } else { Vec3::Y }; 4];
    s.add_mesh(quad, Mat4::IDENTITY);
    s.environment = Some(Environment::procedural_sky(256, Vec3::new(0.3, 0.5, -1.0), 50.0));
    s.camera = Some(Camera::look_at(c(0.0, 1.5, 3.0), c(0.0, 0.0, -0.5), Vec3::Y, 60.0));
    s
}

fn render(scene: &Scene) -> (Vec<Vec3>, Image) {
    let ctx = FrameContext::new(scene, 0.0, 32, 24);
    let g = ctx.gbuffer();
    let mut img = ctx.image();
    let mut pt = PathTracer::new(&Settings { spp: 16, seed: 3 }, &Params::default()).unwrap();
    pt.prepare(&ctx).unwrap();
    pt.render(&ctx, &g, &mut img).unwrap();
    (g.shading_normal.clone(), img)
}

fn relative_rms(a: &Image, b: &Image) -> f64 {
    let sq = |v: Vec3| v.length_squared() as f64;
    (a.pixels.iter().zip(&b.pixels).map(|(x, y)| sq(*x - *y)).sum::<f64>() / b.pixels.iter().map(|y| sq(*y)).sum::<f64>()).sqrt()
}

#[test]
fn a_normal_map_bends_the_shading_normal() {
    let ((mapped_n, mapped), (tilted_n, tilted_img), (_, flat)) =
        (render(&scene(Floor::Mapped)), render(&scene(Floor::Tilted)), render(&scene(Floor::Flat)));
    let worst = mapped_n.iter().zip(&tilted_n).map(|(a, b)| (*a - *b).length()).fold(0.0f32, f32::max);
    let (same, apart) = (relative_rms(&mapped, &tilted_img), relative_rms(&flat, &tilted_img));
    println!(
        "GBuffer normals: largest difference {worst:.2e}; pt relative RMS from the tilted vertices: mapped {same:.2e}, flat {apart:.3}"
    );
    assert!(mapped_n.iter().any(|n| (*n - tilted()).length() < 1e-3), "the mapped floor carries the tilt");
    assert!(worst < 1e-3, "{worst}");
    assert!(same < 1e-3, "{same}");
    assert!(apart > 0.05, "the tilt changes the image (the test can fail): {apart}");
}
