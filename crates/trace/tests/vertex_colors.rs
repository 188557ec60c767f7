//! Vertex colours multiply the base colour at every surface point: a quad with red corners on
//! its left and blue ones on its right has the interpolated colour × the material's base colour
//! (× its texture) wherever a ray hits it, so the GBuffer and every path vertex carry it.

use glimpse_core::{Mat4, Ray, Vec3};
use glimpse_scene::{Material, Mesh, Scene};
use glimpse_trace::{ExactTracer, SurfacePoint};

#[test]
fn the_base_colour_is_multiplied_by_the_interpolated_vertex_colour() {
    let mut s = Scene::default();
    let m = s.add_material(Material::diffuse("quad", Vec3::new(0.5, 1.0, 0.8)));
    let c = Vec3::new;
    let mut quad = Mesh::quad("quad", m, [c(-1., -1., 0.), c(1., -1., 0.), c(1., 1., 0.), c(-1., 1., 0.)]);
    quad.colors = vec![Vec3::X, Vec3::Z, Vec3::Z, Vec3::X];
    s.add_mesh(quad, Mat4::IDENTITY);
    let frame = s.at(0.0);
    let tracer = ExactTracer::build(&frame);
    for x in [-0.5f32, 0.0, 0.5] {
        let ray = Ray::new(c(x, 0.3, 1.0), -Vec3::Z);
        let hit = tracer.closest_hit(&ray, f32::INFINITY).expect("the quad");
        let base = SurfacePoint::from_hit(&frame, &ray, &hit).base_color(&frame);
        let t = (x + 1.0) / 2.0; // from the red edge to the blue one
        let expected = Vec3::new(0.5 * (1.0 - t), 0.0, 0.8 * t);
        println!("x = {x}: base colour {base} (expected {expected})");
        assert!((base - expected).length() < 1e-5, "{base} vs {expected}");
    }
    // A colour per vertex or none: another count is an error naming the mesh.
    let mut bad = s.clone();
    bad.meshes[0].colors.pop();
    let e = glimpse_scene::validate::validate(&mut bad, "test").unwrap_err().to_string();
    assert!(e.contains("3 vertex colours for 4 vertices"), "{e}");
}
