//! A mesh's authored tangents (glTF's `TANGENT`) frame its normal texture: on a floor whose uvs
//! run along z while its tangents point along +x, a texel bent towards the tangent bends the
//! shading normal towards +x (the uv frame would bend it along z), the bitangent is w · N × T,
//! and a mirroring placement keeps the bend where the author put it.

use glimpse_core::{Image, Mat4, Ray, Vec2, Vec3, Vec4};
use glimpse_scene::{Bitangent, Material, Mesh, NormalMap, NormalMapShadowing, Scene};
use glimpse_trace::{ExactTracer, SurfacePoint};

/// A 2 × 2 floor facing +y whose single texel bends the normal by 40° towards tangent-space
/// `towards` (+x or +y), with tangents `tangent` (empty: none), placed by `placement`.
fn floor(towards: Vec3, tangent: Option<Vec4>, placement: Mat4) -> Scene {
    let mut s = Scene::default();
    let (sin, cos) = 40f32.to_radians().sin_cos();
    s.textures.push(Image::from_fn(1, 1, |_, _| (towards * sin + Vec3::Z * cos + Vec3::ONE) * 0.5));
    let normal_map = NormalMap { texture: 0, scale: 1.0, bitangent: Bitangent::ImageUp, shadowing: NormalMapShadowing::None };
    let m = s.add_material(Material { normal_map: Some(normal_map), ..Material::diffuse("floor", Vec3::splat(0.5)) });
    let c = Vec3::new;
    let mut quad = Mesh::quad("floor", m, [c(-1., 0., -1.), c(-1., 0., 1.), c(1., 0., 1.), c(1., 0., -1.)]);
    // u runs along +z, v along +x: the uv frame's tangent is +z.
    quad.uvs = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
    quad.normals = vec![Vec3::Y; 4];
    quad.tangents = tangent.map_or(Vec::new(), |t| vec![t; 4]);
    s.add_mesh(quad, placement);
    s
}

fn shading_normal(scene: &Scene) -> Vec3 {
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let ray = Ray::new(Vec3::new(0.2, 3.0, 0.1), -Vec3::Y);
    let hit = tracer.closest_hit(&ray, f32::INFINITY).expect("the floor");
    SurfacePoint::from_hit(&frame, &ray, &hit).shading_normal
}

#[test]
fn authored_tangents_frame_the_normal_texture() {
    let (sin, cos) = 40f32.to_radians().sin_cos();
    let along = |d: Vec3| d * sin + Vec3::Y * cos;
    let x = Vec4::new(1.0, 0.0, 0.0, 1.0);
    let cases = [
        ("towards T, tangents +x", floor(Vec3::X, Some(x), Mat4::IDENTITY), along(Vec3::X)),
        // B = w · N × T = y × x = −z; w = −1 turns it to +z.
        ("towards B, w = +1", floor(Vec3::Y, Some(x), Mat4::IDENTITY), along(-Vec3::Z)),
        ("towards B, w = −1", floor(Vec3::Y, Some(Vec4::new(1.0, 0.0, 0.0, -1.0)), Mat4::IDENTITY), along(Vec3::Z)),
        // Mirrored in x: T becomes −x, B (−z) stays where the author put it.
        ("mirrored: towards T", floor(Vec3::X, Some(x), Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))), along(-Vec3::X)),
        ("mirrored: towards B", floor(Vec3::Y, Some(x), Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))), along(-Vec3::Z)),
        // Without tangents the uvs' frame: T = dp/du = +z.
        ("no tangents: towards T", floor(Vec3::X, None, Mat4::IDENTITY), along(Vec3::Z)),
    ];
    for (what, scene, expected) in cases {
        let n = shading_normal(&scene);
        println!("{what}: shading normal {n:.4} (expected {expected:.4})");
        assert!((n - expected).length() < 1e-3, "{what}: {n} vs {expected}");
    }
    // A tangent per vertex or none, finite: anything else is an error naming the mesh.
    let mut bad = floor(Vec3::X, Some(x), Mat4::IDENTITY);
    bad.meshes[0].tangents.pop();
    let e = glimpse_scene::validate::validate(&mut bad, "test").unwrap_err().to_string();
    assert!(e.contains("3 tangents for 4 vertices"), "{e}");
    let mut bad = floor(Vec3::X, Some(Vec4::new(f32::NAN, 0.0, 0.0, 1.0)), Mat4::IDENTITY);
    let e = glimpse_scene::validate::validate(&mut bad, "test").unwrap_err().to_string();
    assert!(e.contains("tangent is NaN"), "{e}");
}
