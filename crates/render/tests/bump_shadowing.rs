//! What a bent normal reflects under a uniform sky, as each format's renderer has it: a
//! Lambertian plane (ρ = 0.5, sky radiance 1) whose normal texture tilts every normal by θ,
//! seen from straight above by `pt`.
//!
//! - `NormalMapShadowing::None` (glTF, pbrt-v4): the bent normal's cosine over the sky that the
//!   plane sees, ρ (1 + cos θ)/2 in closed form.
//! - `NormalMapShadowing::Microfacet` (Mitsuba 3's `normalmap`, Conty Estevez et al.'s
//!   shadowing): the means Mitsuba 3.9.1 rendered for the same plane (its `path` integrator,
//!   32 × 32, 1,024 spp), which glimpse had missed by 3–40 % before it read the shadowing.

use glimpse_core::{Image, Mat4, Vec2, Vec3};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::{Bitangent, Camera, Environment, Material, MaterialModel, Mesh, NormalMap, NormalMapShadowing, Scene};

const RHO: f32 = 0.5;

/// The plane (4 × 4 m at y = 0) with every normal tilted by `degrees` towards +x, filling the
/// view of a camera 10 m above it.
fn bent_plane(degrees: f32, shadowing: NormalMapShadowing) -> Scene {
    let mut s = Scene::default();
    let (sin, cos) = degrees.to_radians().sin_cos();
    // (T, B, N) components: T = +x (dp/du), the bend about the bitangent.
    s.textures.push(Image::from_fn(1, 1, |_, _| (Vec3::new(sin, 0.0, cos) + Vec3::ONE) * 0.5));
    let m = s.add_material(Material {
        model: MaterialModel::Diffuse,
        normal_map: Some(NormalMap { texture: 0, scale: 1.0, bitangent: Bitangent::NormalCrossTangent, shadowing }),
        ..Material::diffuse("bent", Vec3::splat(RHO))
    });
    let c = Vec3::new;
    let mut quad = Mesh::quad("plane", m, [c(-2., 0., -2.), c(2., 0., -2.), c(2., 0., 2.), c(-2., 0., 2.)]);
    quad.uvs = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
    quad.normals = vec![Vec3::Y; 4];
    s.add_mesh(quad, Mat4::IDENTITY);
    s.environment = Some(Environment::constant(Vec3::ONE));
    // 20°: the view holds the plane alone (its half-width at 10 m is 1.76 m).
    s.camera = Some(Camera::look_at(c(0.0, 10.0, 0.0), Vec3::ZERO, Vec3::NEG_Z, 20.0));
    s
}

/// `pt`'s mean over the image and the standard error of that mean (from its pixels' spread).
fn mean_radiance(scene: &Scene) -> (f64, f64) {
    let ctx = FrameContext::new(scene, 0.0, 16, 16);
    let g = ctx.gbuffer();
    let mut img = ctx.image();
    let mut pt = PathTracer::new(&Settings { spp: 1024, seed: 6 }, &Params::default()).unwrap();
    pt.prepare(&ctx).unwrap();
    pt.render(&ctx, &g, &mut img).unwrap();
    let v: Vec<f64> = img.pixels.iter().map(|p| p.x as f64).collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn a_bent_plane_under_a_uniform_sky_reflects_what_its_format_says() {
    // (θ, Mitsuba 3.9.1's mean): tools/crosscheck-style renders of this plane; the last is
    // beyond the shadowing's α² clamp (θ > 70.5°).
    for (degrees, mitsuba) in [(30.0f32, 0.43933), (60.0, 0.28286), (75.0, 0.18969)] {
        let (plain, plain_se) = mean_radiance(&bent_plane(degrees, NormalMapShadowing::None));
        let (shadowed, shadowed_se) = mean_radiance(&bent_plane(degrees, NormalMapShadowing::Microfacet));
        let closed_form = RHO as f64 * (1.0 + (degrees as f64).to_radians().cos()) / 2.0;
        println!(
            "θ = {degrees}°: cosine alone {plain:.5} ± {plain_se:.5} (closed form {closed_form:.5}); \
             shadowed {shadowed:.5} ± {shadowed_se:.5} (Mitsuba {mitsuba:.5})"
        );
        // 4 standard errors, plus Mitsuba's own noise at 1,024 spp (about 1e-4).
        assert!((plain - closed_form).abs() < 4.0 * plain_se + 1e-4, "cosine alone at {degrees}°: {plain} vs {closed_form}");
        assert!((shadowed - mitsuba).abs() < 4.0 * shadowed_se + 3e-4, "shadowed at {degrees}°: {shadowed} vs {mitsuba}");
        // The two rules differ by far more than the noise (the test can fail).
        assert!(plain - shadowed > 8.0 * (plain_se + shadowed_se), "{plain} vs {shadowed}");
    }
}
