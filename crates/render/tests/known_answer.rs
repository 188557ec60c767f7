//! Known-answer tests of the exact references (as pbrt-v4 keeps them): tiny scenes built here
//! whose answer is known in closed form, or two independent estimators of the same quantity.
//! Each test prints its numbers (docs/references.md quotes them).

use glimpse_core::glam::DVec3;
use glimpse_core::{Image, Mat4, Vec3, luminance};
use glimpse_render::lights::light_visibility;
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Registry, Settings, Technique};
use glimpse_scene::{Camera, Environment, Light, Material, Mesh, Scene};
use glimpse_trace::GBuffer;
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Scene pieces

/// A planar quad, corners in order; the front face is (b − a) × (c − a).
fn quad(name: &str, material: u32, c: [Vec3; 4]) -> Mesh {
    Mesh { name: name.into(), material, positions: c.to_vec(), indices: vec![[0, 1, 2], [0, 2, 3]], ..Default::default() }
}

/// A horizontal square of half-size `half` at height `y`, front face up.
fn floor(material: u32, half: f32, y: f32) -> Mesh {
    let h = half;
    quad("floor", material, [Vec3::new(-h, y, -h), Vec3::new(-h, y, h), Vec3::new(h, y, h), Vec3::new(h, y, -h)])
}

/// A flat-faceted UV sphere (no vertex normals: an exactly convex polyhedron).
fn sphere(material: u32, radius: f32, rings: u32, segments: u32) -> Mesh {
    let mut m = glimpse_scene::builtin::sphere_mesh("sphere", material, rings, segments);
    m.positions.iter_mut().for_each(|p| *p *= radius);
    m.normals.clear();
    m.uvs.clear();
    m
}

/// The `segments` vertices of a regular polygon of circumradius `radius` at height `y`, and a
/// triangle fan over them facing down (−y).
fn disc_down(material: u32, radius: f32, y: f32, segments: u32) -> (Mesh, Vec<Vec3>) {
    let rim: Vec<Vec3> = (0..segments)
        .map(|k| {
            let phi = std::f32::consts::TAU * k as f32 / segments as f32;
            Vec3::new(radius * phi.cos(), y, radius * phi.sin())
        })
        .collect();
    let mut positions = vec![Vec3::new(0.0, y, 0.0)];
    positions.extend_from_slice(&rim);
    // (rim_k − c) × (rim_{k+1} − c) points down for φ increasing from +x towards +z.
    let indices = (0..segments).map(|k| [0, 1 + k, 1 + (k + 1) % segments]).collect();
    (Mesh { name: "disc".into(), material, positions, indices, ..Default::default() }, rim)
}

fn finish(mut scene: Scene) -> Scene {
    glimpse_scene::validate::validate(&mut scene, "test scene").unwrap();
    scene
}

// ---------------------------------------------------------------------------------------------
// Rendering

fn registry() -> Registry {
    Registry::new(glimpse_render::techniques())
}

/// Renders `scene` with technique `id` at `w × h`.
fn render(scene: &Scene, id: &str, spp: u32, seed: u64, set: &[&str], w: u32, h: u32) -> (Image, GBuffer) {
    let params = Params::parse(set).unwrap();
    let mut t = registry().create(id, scene, &Settings { spp, seed }, &params).unwrap();
    let ctx = FrameContext::new(scene, 0.0, w, h);
    let g = ctx.gbuffer();
    t.prepare(&ctx).unwrap();
    let mut img = ctx.image();
    t.render(&ctx, &g, &mut img).unwrap();
    (img, g)
}

/// `pt`, checking that no path was non-finite.
fn render_pt(scene: &Scene, spp: u32, seed: u64, set: &[&str], w: u32, h: u32) -> (Image, GBuffer) {
    let params = Params::parse(set).unwrap();
    let mut t = PathTracer::new(&Settings { spp, seed }, &params).unwrap();
    params.finish("pt").unwrap();
    let ctx = FrameContext::new(scene, 0.0, w, h);
    let g = ctx.gbuffer();
    t.prepare(&ctx).unwrap();
    let mut img = ctx.image();
    t.render(&ctx, &g, &mut img).unwrap();
    assert_eq!(t.nonfinite_paths(), 0, "NaN or infinite paths");
    (img, g)
}

/// Mean and standard error of the values.
fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, (var / n).sqrt())
}

/// The pixels that see instance `instance`.
fn on_instance(img: &Image, g: &GBuffer, instance: u32) -> Vec<usize> {
    let v: Vec<usize> = (0..img.len()).filter(|&i| g.instance[i] == instance).collect();
    assert!(!v.is_empty(), "no pixel sees instance {instance}");
    v
}

// ---------------------------------------------------------------------------------------------
// Furnace: a convex diffuse sphere under L_env = 1 cannot see itself, so its radiance is ρ.

const RHO: f32 = 0.8;

fn furnace(material: Material) -> Scene {
    let mut s = Scene { name: "furnace".into(), ..Default::default() };
    let m = s.add_material(material);
    s.add_mesh(sphere(m, 1.0, 24, 48), Mat4::IDENTITY);
    s.environment = Some(Environment::constant(Vec3::ONE));
    s.camera = Some(Camera::look_at(Vec3::new(0.0, 0.5, 4.0), Vec3::ZERO, Vec3::Y, 35.0));
    finish(s)
}

#[test]
fn furnace_env_exact_is_rho_exactly() {
    let scene = furnace(Material::diffuse("grey", Vec3::splat(RHO)));
    let (img, g) = render(&scene, "env-exact", 1, 7, &[], 32, 32);
    let sphere = on_instance(&img, &g, 0);
    let worst = sphere.iter().map(|&i| (img.pixels[i] - Vec3::splat(RHO)).abs().max_element()).fold(0.0f32, f32::max);
    let background =
        (0..img.len()).filter(|&i| !g.is_hit(i)).map(|i| (img.pixels[i] - Vec3::ONE).abs().max_element()).fold(0.0f32, f32::max);
    println!(
        "env-exact furnace (128 rays): {} sphere pixels, worst |L − ρ| = {worst:e}, worst background |L − 1| = {background:e}",
        sphere.len()
    );
    assert!(worst < 1e-5 && background < 1e-6);

    // The converged mode (MIS with the map's importance sampling) is ρ in expectation.
    let (img, g) = render(&scene, "env-exact", 1, 7, &["converged=true", "rays=256"], 32, 32);
    let v: Vec<f64> = on_instance(&img, &g, 0).iter().map(|&i| img.pixels[i].x as f64).collect();
    let (mean, se) = mean_se(&v);
    println!("env-exact converged furnace (256 rays, MIS): mean {mean:.6} ± {se:.6} (ρ = {RHO}), error {:.2e}", mean - RHO as f64);
    assert!((mean - RHO as f64).abs() < 4.0 * se + 1e-6);
}

#[test]
fn furnace_pt_diffuse_is_rho() {
    let scene = furnace(Material::diffuse("grey", Vec3::splat(RHO)));
    let (img, g) = render_pt(&scene, 64, 3, &["brdf=lambert"], 32, 32);
    let v: Vec<f64> = on_instance(&img, &g, 0).iter().map(|&i| img.pixels[i].x as f64).collect();
    let (mean, se) = mean_se(&v);
    println!(
        "pt furnace, Lambert ρ = {RHO}, 64 spp: mean {mean:.5} ± {se:.5}, error {:+.2e} ({:.1} σ)",
        mean - RHO as f64,
        (mean - RHO as f64) / se
    );
    assert!((mean - RHO as f64).abs() < 4.0 * se);
}

/// Directional albedo ∫ f(ωo, ωi) cos θi dωi of the glTF metallic-roughness BRDF with a white
/// base colour, at cos θo = `mu`, by midpoint quadrature over ωi (written here independently of
/// `bsdf.rs`): f = (1 − m)(1 − F_d)/π + F D G₂ / (4 cos θo cos θi).
fn white_albedo(metallic: f64, roughness: f64, mu: f64) -> f64 {
    let a2 = (roughness * roughness).powi(2);
    let wo = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let lambda = |z: f64| 0.5 * ((1.0 + a2 * (1.0 - z * z) / (z * z)).sqrt() - 1.0);
    let schlick = |f0: f64, c: f64| f0 + (1.0 - f0) * (1.0 - c).powi(5);
    let f0 = 0.04 + (1.0 - 0.04) * metallic;
    let (nt, np) = (256, 256);
    let mut sum = 0.0;
    for it in 0..nt {
        let th = (it as f64 + 0.5) / nt as f64 * PI / 2.0;
        for ip in 0..np {
            // φ over [0, π], doubled: the integrand is symmetric about ωo's plane.
            let ph = (ip as f64 + 0.5) / np as f64 * PI;
            let wi = DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
            let h = (wi + wo).normalize();
            let c = wo.dot(h);
            let t = (h.x * h.x + h.y * h.y) / a2 + h.z * h.z;
            let d = 1.0 / (PI * a2 * t * t);
            let g2 = 1.0 / (1.0 + lambda(mu) + lambda(wi.z));
            let f = (1.0 - metallic) * (1.0 - schlick(0.04, c)) / PI + schlick(f0, c) * d * g2 / (4.0 * mu * wi.z);
            sum += f * wi.z * th.sin();
        }
    }
    sum * 2.0 * (PI / 2.0 / nt as f64) * (PI / np as f64)
}

#[test]
fn furnace_pt_glossy_matches_quadrature() {
    // A white sphere under L = 1: each pixel's radiance is the BRDF's directional albedo at its
    // viewing angle. Single-scattering GGX loses energy, so a rough white metal is < 1; glTF's
    // Appendix B layering is not exactly energy conserving at grazing views, so a white
    // dielectric can slightly exceed 1 (the quadrature says so too).
    for (name, metallic, roughness) in [("metal roughness 0.7", 1.0, 0.7), ("dielectric roughness 0.5", 0.0, 0.5)] {
        let table: Vec<f64> = (0..=64).map(|k| white_albedo(metallic as f64, roughness as f64, (k as f64 / 64.0).max(1e-3))).collect();
        let albedo = |mu: f64| {
            let x = mu.clamp(0.0, 1.0) * 64.0;
            let k = (x as usize).min(63);
            table[k] + (table[k + 1] - table[k]) * (x - k as f64)
        };
        let mat = Material { name: name.into(), base_color: Vec3::ONE, metallic, roughness, ..Default::default() };
        let scene = furnace(mat);
        let (img, g) = render_pt(&scene, 32, 5, &[], 32, 32);
        let pixels = on_instance(&img, &g, 0);
        let diff: Vec<f64> = pixels.iter().map(|&i| img.pixels[i].x as f64 - albedo(g.normal[i].dot(-g.view_dir[i]) as f64)).collect();
        let expected = pixels.iter().map(|&i| albedo(g.normal[i].dot(-g.view_dir[i]) as f64)).sum::<f64>() / pixels.len() as f64;
        let (err, se) = mean_se(&diff);
        println!(
            "pt furnace, white {name}, 32 spp: mean {:.5}, quadrature {expected:.5} (albedo at normal view {:.4}), error {err:+.2e} ± {se:.1e}",
            expected + err,
            table[64]
        );
        assert!(err.abs() < 4.0 * se, "{name}: {err} ± {se}");
        if metallic == 1.0 {
            assert!(expected + err < 1.0, "a white single-scattering metal loses energy");
        }
    }
    // A clear coat (γ = 1, smooth, F0 = 0.04) over the white dielectric: under L = 1 the coat
    // reflects F_c of the environment and passes (1 − F_c) of the base's albedo:
    // L = F_c(μ) + (1 − F_c(μ)) · A(μ), F_c = Schlick(0.04, μ) at the shading normal.
    let table: Vec<f64> = (0..=64).map(|k| white_albedo(0.0, 0.5, (k as f64 / 64.0).max(1e-3))).collect();
    let albedo = |mu: f64| {
        let x = mu.clamp(0.0, 1.0) * 64.0;
        let k = (x as usize).min(63);
        table[k] + (table[k + 1] - table[k]) * (x - k as f64)
    };
    let mat =
        Material { name: "coated".into(), base_color: Vec3::ONE, metallic: 0.0, roughness: 0.5, clearcoat: 1.0, ..Default::default() };
    let (img, g) = render_pt(&furnace(mat), 32, 6, &[], 32, 32);
    let pixels = on_instance(&img, &g, 0);
    let expected = |i: usize| {
        let fc = 0.04 + 0.96 * (1.0 - (g.shading_normal[i].dot(-g.view_dir[i]) as f64).clamp(0.0, 1.0)).powi(5);
        fc + (1.0 - fc) * albedo(g.normal[i].dot(-g.view_dir[i]) as f64)
    };
    let diff: Vec<f64> = pixels.iter().map(|&i| img.pixels[i].x as f64 - expected(i)).collect();
    let (err, se) = mean_se(&diff);
    let mean_expected = pixels.iter().map(|&i| expected(i)).sum::<f64>() / pixels.len() as f64;
    println!("pt furnace, clear-coated white dielectric (γ = 1), 32 spp: expected {mean_expected:.5}, error {err:+.2e} ± {se:.1e}");
    assert!(err.abs() < 4.0 * se, "clear coat: {err} ± {se}");
    // A nearly smooth white metal reflects almost everything (F = 1, little masking).
    let mat = Material { name: "smooth metal".into(), base_color: Vec3::ONE, metallic: 1.0, roughness: 0.2, ..Default::default() };
    let (img, g) = render_pt(&furnace(mat), 32, 5, &[], 32, 32);
    let (mean, se) = mean_se(&on_instance(&img, &g, 0).iter().map(|&i| img.pixels[i].x as f64).collect::<Vec<_>>());
    println!("pt furnace, white metal roughness 0.2: mean {mean:.5} ± {se:.5} (expected just below 1)");
    assert!(mean > 0.98 && mean < 1.0 + 4.0 * se);
}

#[test]
fn open_plane_under_a_sky_matches_quadrature() {
    // An open plane (normal +y) under a procedural sky with a sun: every pixel is ρ E / π with
    // E = ∫ L(ω) cos θ dω over the upper hemisphere, here by midpoint quadrature of the map's own
    // radiance lookup (independent of the importance sampling that env-exact converged and pt use).
    let rho = 0.7f32;
    let mut s = Scene::default();
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(rho)));
    s.add_mesh(floor(m, 50.0, 0.0), Mat4::IDENTITY);
    s.environment = Some(Environment::procedural_sky(256, Vec3::new(0.4, 0.6, -0.3), 50.0));
    s.camera = Some(Camera::look_at(Vec3::new(0.0, 2.0, 2.0), Vec3::ZERO, Vec3::Y, 50.0));
    let scene = finish(s);
    let env = scene.environment.as_ref().unwrap();
    let (nt, np) = (1024, 2048);
    let mut e = 0.0f64;
    for it in 0..nt {
        let th = (it as f64 + 0.5) / nt as f64 * PI / 2.0;
        for ip in 0..np {
            let ph = (ip as f64 + 0.5) / np as f64 * 2.0 * PI;
            let d = Vec3::new((th.sin() * ph.cos()) as f32, th.cos() as f32, (th.sin() * ph.sin()) as f32);
            e += luminance(env.radiance(d)) as f64 * th.cos() * th.sin();
        }
    }
    e *= (PI / 2.0 / nt as f64) * (2.0 * PI / np as f64);
    let expected = rho as f64 * e / PI;
    for (label, id, spp, set) in [
        ("env-exact, 128 rays", "env-exact", 1, &[][..]),
        ("env-exact converged, 1024 rays", "env-exact", 1, &["converged=true", "rays=1024"][..]),
        ("env-exact rotation=normal (DVF's wording), 128 rays", "env-exact", 1, &["rotation=normal"][..]),
        ("pt max_depth=1 lambert, 64 spp", "pt", 64, &["max_depth=1", "brdf=lambert"][..]),
    ] {
        let (img, g) = if id == "pt" { render_pt(&scene, spp, 4, set, 24, 24) } else { render(&scene, id, spp, 4, set, 24, 24) };
        let v: Vec<f64> = on_instance(&img, &g, 0).iter().map(|&i| luminance(img.pixels[i]) as f64).collect();
        let (mean, se) = mean_se(&v);
        println!(
            "sky over an open plane, {label}: mean luminance {mean:.4} ± {se:.4}, quadrature ρE/π = {expected:.4} ({:+.2} σ)",
            (mean - expected) / se
        );
        if set.contains(&"rotation=normal") {
            // Fixed elevations: a quadrature in θ that a 2° sun falls between. Printed, not
            // asserted: docs/references.md quotes the bias as the reason `cp` is the default.
            continue;
        }
        assert!((mean - expected).abs() < 4.0 * se + 1e-4 * expected, "{label}: {mean} vs {expected}");
    }
}

// ---------------------------------------------------------------------------------------------
// Ambient occlusion of an open plane is 1.

#[test]
fn ao_of_an_open_plane_is_one() {
    let mut s = Scene::default();
    let m = s.add_material(Material::diffuse("white", Vec3::ONE));
    s.add_mesh(floor(m, 20.0, 0.0), Mat4::IDENTITY);
    s.camera = Some(Camera::look_at(Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO, Vec3::Y, 50.0));
    let scene = finish(s);
    let (img, g) = render(&scene, "ao-exact", 16, 1, &[], 24, 24);
    let hits = on_instance(&img, &g, 0);
    let worst = hits.iter().map(|&i| (img.pixels[i].x - 1.0).abs()).fold(0.0f32, f32::max);
    println!("ao-exact on an open plane: {} pixels, worst |AO − 1| = {worst}", hits.len());
    assert_eq!(worst, 0.0);
}

// ---------------------------------------------------------------------------------------------
// Irradiance from a polygonal (disc) light: Lambert's closed form.

/// Irradiance at `p` (normal `n`) from a uniform Lambertian polygon of radiance `l` entirely
/// above `p`'s horizon: E = L/2 Σ_k θ_k n·normalize(a_k × a_{k+1}) (Lambert 1760).
fn polygon_irradiance(p: Vec3, n: Vec3, polygon: &[Vec3], l: f64) -> f64 {
    let a: Vec<DVec3> = polygon.iter().map(|v| (*v - p).as_dvec3().normalize()).collect();
    let n = n.as_dvec3();
    let mut sum = 0.0;
    for k in 0..a.len() {
        let (u, v) = (a[k], a[(k + 1) % a.len()]);
        sum += u.dot(v).clamp(-1.0, 1.0).acos() * n.dot(u.cross(v).normalize());
    }
    0.5 * l * sum.abs()
}

#[test]
fn soft_exact_matches_disc_light_irradiance() {
    let (radius, height, radiance, segments) = (0.5f32, 1.0f32, 3.0f32, 64);
    let mut s = Scene::default();
    let white = s.add_material(Material::diffuse("white", Vec3::ONE));
    let light = s.add_material(Material::emissive("light", Vec3::splat(radiance)));
    s.add_mesh(floor(white, 3.0, 0.0), Mat4::IDENTITY);
    let (disc, rim) = disc_down(light, radius, height, segments);
    s.add_mesh(disc, Mat4::IDENTITY);
    s.camera = Some(Camera::look_at(Vec3::new(0.0, 0.45, 2.2), Vec3::new(0.0, 0.0, 0.3), Vec3::Y, 60.0));
    let scene = finish(s);
    assert!(scene.at(0.0).emissive.iter().all(|e| e.normal.y < -0.999), "the disc faces down");

    let (img, g) = render(&scene, "soft-exact", 256, 11, &[], 32, 32);
    let mut rel = Vec::new();
    for i in on_instance(&img, &g, 0) {
        let e = polygon_irradiance(g.position[i], g.normal[i], &rim, radiance as f64);
        rel.push(img.pixels[i].x as f64 * PI / e - 1.0);
    }
    let (mean, se) = mean_se(&rel);
    let worst = rel.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    let (h, r, l) = (height as f64, radius as f64, radiance as f64);
    let disc_axis = PI * l * r * r / (h * h + r * r);
    let poly_axis = polygon_irradiance(Vec3::ZERO, Vec3::Y, &rim, l);
    println!(
        "disc light (r={r}, h={h}, L={l}, {segments}-gon): on-axis E disc {disc_axis:.5}, polygon {poly_axis:.5}; \
         soft-exact 256 spp over {} floor pixels: mean relative error {mean:+.2e} ± {se:.1e}, worst pixel {worst:.3}",
        rel.len()
    );
    assert!((poly_axis / disc_axis - 1.0).abs() < 0.005, "a 64-gon is within 0.5% of the disc");
    assert!(mean.abs() < 4.0 * se, "biased: {mean} ± {se}");
    assert!(worst < 0.25, "one pixel is off by {worst}");

    // Unshadowed equals shadowed here (nothing blocks the light): same samples, same image.
    let (free, _) = render(&scene, "soft-exact", 256, 11, &["shadows=false"], 32, 32);
    assert_eq!(free.pixels, img.pixels);
}

// ---------------------------------------------------------------------------------------------
// Punctual lights over a plane with a square blocker: I cos θ / d² · ρ/π, shadows analytic.

const BLOCKER_Y: f32 = 1.0;
const BLOCKER_HALF: f32 = 0.25;

/// Does the segment from `p` towards `wi` (length `d`) pass through the blocker square? `None`
/// when it passes within 1e-3 of the square's edge (too close to call in floating point).
fn blocked(p: Vec3, wi: Vec3, d: f32) -> Option<bool> {
    if p.y >= BLOCKER_Y - 1e-4 || wi.y <= 0.0 {
        return Some(false);
    }
    let t = (BLOCKER_Y - p.y) / wi.y;
    if t >= d {
        return Some(false);
    }
    let x = p + wi * t;
    let margin = BLOCKER_HALF - x.x.abs().max(x.z.abs());
    if margin.abs() < 1e-3 { None } else { Some(margin > 0.0) }
}

#[test]
fn lights_exact_matches_point_and_directional_lights() {
    let rho = 0.5f32;
    let mut s = Scene::default();
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(rho)));
    s.add_mesh(floor(m, 4.0, 0.0), Mat4::IDENTITY);
    s.add_mesh(floor(m, BLOCKER_HALF, BLOCKER_Y), Mat4::IDENTITY);
    let point = Light::point(Vec3::new(0.3, 2.0, -0.2), Vec3::new(10.0, 8.0, 6.0));
    let sun = Light::directional(Vec3::new(-0.3, -1.0, 0.2), Vec3::new(1.0, 2.0, 3.0));
    s.lights = vec![point.clone(), sun.clone()];
    s.camera = Some(Camera::look_at(Vec3::new(0.0, 3.5, 3.5), Vec3::ZERO, Vec3::Y, 55.0));
    let scene = finish(s);
    let frame = scene.at(0.0);

    for (set, n_lights) in [(&["lights=1"][..], 1usize), (&[][..], 2)] {
        let (img, g) = render(&scene, "lights-exact", 1, 0, set, 32, 32);
        let bits = light_visibility(&frame, &g, &FrameContext::new(&scene, 0.0, 32, 32).tracer, n_lights);
        let (mut worst, mut checked, mut shadowed, mut bit_errors) = (0.0f32, 0, 0, 0);
        for i in (0..img.len()).filter(|&i| g.is_hit(i)) {
            let (p, n) = (g.position[i], g.normal[i]);
            let mut expected = Vec3::ZERO;
            let mut decided = true;
            for (l, light) in frame.lights[..n_lights].iter().enumerate() {
                let (wi, d, e) = light.incident(p);
                let cos = n.dot(wi).max(0.0);
                match blocked(p, wi, d) {
                    None => decided = false,
                    Some(b) => {
                        shadowed += (b && cos > 0.0) as u32;
                        bit_errors += (bits.visible(i, l) == b) as u32 + (bits.facing(i, l) != (cos > 0.0)) as u32;
                        if !b {
                            expected += e * cos * rho / std::f32::consts::PI;
                        }
                    }
                }
            }
            if decided {
                checked += 1;
                worst = worst.max(((img.pixels[i] - expected).abs() / expected.max(Vec3::splat(1e-3))).max_element());
            }
        }
        println!(
            "lights-exact, {n_lights} light(s): {checked} pixels checked ({shadowed} shadowed pixel-lights), worst relative error {worst:.2e}, {bit_errors} visibility-bit disagreements"
        );
        assert!(checked > 500 && shadowed > 10);
        assert!(worst < 1e-4);
        assert_eq!(bit_errors, 0);
    }
}

#[test]
fn pt_direct_light_equals_lights_exact_with_many_lights() {
    // 12 coloured point and spot lights (more than pt evaluates at every vertex, so it picks one
    // uniformly): pt with max_depth=1 and Lambertian BRDFs is lights-exact in expectation.
    let mut s = Scene::default();
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.6)));
    s.add_mesh(floor(m, 4.0, 0.0), Mat4::IDENTITY);
    s.add_mesh(sphere(m, 0.5, 12, 24), Mat4::from_translation(Vec3::new(0.0, 0.5, 0.0)));
    for k in 0..12 {
        let phi = k as f32 * 0.52;
        let p = Vec3::new(1.5 * phi.cos(), 1.0 + 0.1 * k as f32, 1.5 * phi.sin());
        let colour = Vec3::new(1.0 + (k % 3) as f32, 1.0 + (k % 4) as f32, 1.0 + (k % 5) as f32) * 0.3;
        s.lights.push(if k % 4 == 3 { Light::spot(p, -p, colour * 3.0, 0.3, 0.6) } else { Light::point(p, colour) });
    }
    s.camera = Some(Camera::look_at(Vec3::new(0.0, 2.5, 3.5), Vec3::new(0.0, 0.3, 0.0), Vec3::Y, 50.0));
    let scene = finish(s);
    let (exact, g) = render(&scene, "lights-exact", 1, 0, &[], 24, 24);
    let (pt, _) = render_pt(&scene, 256, 21, &["max_depth=1", "brdf=lambert"], 24, 24);
    let diff: Vec<f64> = (0..g.len()).filter(|&i| g.is_hit(i)).map(|i| luminance(pt.pixels[i] - exact.pixels[i]) as f64).collect();
    let (err, se) = mean_se(&diff);
    println!(
        "12 lights: lights-exact mean luminance {:.5}, pt (max_depth=1, lambert, 256 spp) {:.5}; mean difference {err:+.2e} ± {se:.1e}",
        luminance(exact.mean()),
        luminance(pt.mean())
    );
    assert!(err.abs() < 4.0 * se, "{err} ± {se}");
}

// ---------------------------------------------------------------------------------------------
// gi-exact (direct + one bounce) = pt with max_depth=2 and Lambertian BRDFs, in expectation.

#[test]
fn gi_exact_equals_one_bounce_pt_on_cornell() {
    let mut scene = glimpse_scene::load("cornell").unwrap();
    // Something of every light kind: the area light, a point light and an environment seen
    // through the open front.
    scene.lights.push(Light::point(Vec3::new(0.15, 0.4, 0.2), Vec3::splat(0.05)));
    scene.environment = Some(Environment::procedural_sky(32, Vec3::new(0.2, 0.3, -1.0), 20.0));
    let (w, h, seeds) = (16, 16, 8u64);
    let means = |id: &str, spp: u32, set: &[&str]| -> Vec<[f64; 3]> {
        (0..seeds)
            .map(|seed| {
                let (img, _) =
                    if id == "pt" { render_pt(&scene, spp, 100 + seed, set, w, h) } else { render(&scene, id, spp, 100 + seed, set, w, h) };
                let m = img.mean();
                [m.x as f64, m.y as f64, m.z as f64]
            })
            .collect()
    };
    let gi = means("gi-exact", 64, &[]);
    let pt = means("pt", 64, &["max_depth=2", "brdf=lambert"]);
    let direct = means("pt", 64, &["max_depth=1", "brdf=lambert"]);
    for c in 0..3 {
        let (a, sa) = mean_se(&gi.iter().map(|m| m[c]).collect::<Vec<_>>());
        let (b, sb) = mean_se(&pt.iter().map(|m| m[c]).collect::<Vec<_>>());
        let (d, _) = mean_se(&direct.iter().map(|m| m[c]).collect::<Vec<_>>());
        let z = (a - b) / (sa * sa + sb * sb).sqrt();
        println!(
            "channel {c}: gi-exact image mean {a:.5} ± {sa:.5}, pt max_depth=2 {b:.5} ± {sb:.5} ({z:+.2} σ); direct only {d:.5} (the bounce adds {:.1}%)",
            100.0 * (b / d - 1.0)
        );
        assert!(z.abs() < 4.0, "channel {c}: {a} vs {b}");
        assert!(b > d * 1.05, "the bounce must matter for the check to mean anything");
    }
}

// ---------------------------------------------------------------------------------------------
// pt converges: MSE against a high-spp render falls as 1/spp.

#[test]
fn pt_mse_falls_as_one_over_spp() {
    let scene = glimpse_scene::load("cornell").unwrap();
    let (w, h) = (32, 32);
    let (reference, _) = render_pt(&scene, 4096, 999, &[], w, h);
    let mut pts = Vec::new();
    for (k, spp) in [4u32, 16, 64].into_iter().enumerate() {
        let (img, _) = render_pt(&scene, spp, 10 + k as u64, &[], w, h);
        let mse = img.pixels.iter().zip(&reference.pixels).map(|(a, b)| ((*a - *b).powf(2.0)).element_sum() as f64 / 3.0).sum::<f64>()
            / img.len() as f64;
        println!("pt cornell {w}x{h}: {spp:>3} spp MSE {mse:.4e} (image luminance {:.4})", luminance(img.mean()));
        pts.push(((spp as f64).ln(), mse.ln()));
    }
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    println!("log-log slope of MSE against spp: {slope:.3} (expected −1)");
    assert!((-1.3..=-0.7).contains(&slope), "slope {slope}");
}

#[test]
fn furnace_pt_material_models() {
    // Under L = 1 a white smooth glass sphere passes everything: each path leaves it with
    // throughput (1/η²)·η² = 1 (reflections weigh 1), so with unbounded depth every pixel is 1
    // in expectation. A white perfect conductor (η = 0, k = 1, roughness 0) reflects everything
    // (F = 1, α = 1e-3 barely masks). A white `diffuse` sphere is 1 at max_depth = 1.
    use glimpse_scene::MaterialModel;
    let white = |model| Material { name: "white".into(), base_color: Vec3::ONE, roughness: 0.0, model, ..Default::default() };
    for (name, model, set) in [
        ("glass ior 1.5, max_depth=-1", MaterialModel::Dielectric { ior: 1.5 }, &["max_depth=-1"][..]),
        ("perfect conductor", MaterialModel::PERFECT_CONDUCTOR, &[][..]),
        ("diffuse, max_depth=1", MaterialModel::Diffuse, &["max_depth=1"][..]),
    ] {
        let (img, g) = render_pt(&furnace(white(model)), 16, 9, set, 32, 32);
        let v: Vec<f64> = on_instance(&img, &g, 0).iter().map(|&i| img.pixels[i].x as f64).collect();
        let (mean, se) = mean_se(&v);
        println!("pt furnace, white {name}, 16 spp: mean {mean:.5} ± {se:.5} (expected 1)");
        assert!((mean - 1.0).abs() < 4.0 * se + 2e-3, "{name}: {mean} ± {se}");
    }
    // A grey diffuse sphere is ρ whatever `brdf` says (its model is Lambert already).
    let grey = Material { model: MaterialModel::Diffuse, base_color: Vec3::splat(RHO), metallic: 1.0, ..Default::default() };
    let (img, g) = render_pt(&furnace(grey), 16, 4, &["max_depth=1"], 32, 32);
    let (mean, se) = mean_se(&on_instance(&img, &g, 0).iter().map(|&i| img.pixels[i].x as f64).collect::<Vec<_>>());
    assert!((mean - RHO as f64).abs() < 4.0 * se + 1e-3, "diffuse ignores metallic: {mean}");
}
