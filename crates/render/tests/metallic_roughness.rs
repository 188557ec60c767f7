//! A metallic-roughness texture is read per texel by the reference: a floor whose texture makes
//! its half x < 0 a glossy metal and its half x > 0 a rough dielectric renders as two floors
//! with those two materials, not as one floor of their mean.

use glimpse_core::{Image, Mat4, Vec2, Vec3};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::{Camera, Environment, Material, Mesh, MetallicRoughnessMap, Scene};

const BASE: Vec3 = Vec3::new(0.9, 0.6, 0.3);

/// (metallic, roughness) of the floor's two halves.
const METAL: (f32, f32) = (1.0, 0.2);
const DIELECTRIC: (f32, f32) = (0.0, 1.0);

enum Floor {
    /// One quad, the halves set by a 64 × 1 texture (G roughness, B metallic).
    Textured,
    /// Two quads with the halves' materials.
    Split,
    /// One quad of the texture's mean (the loader's material-level values).
    Mean,
}

fn scene(floor: Floor) -> Scene {
    let mut s = Scene::default();
    let material = |s: &mut Scene, name: &str, (metallic, roughness): (f32, f32)| {
        s.add_material(Material { metallic, roughness, ..Material::diffuse(name, BASE) })
    };
    let c = Vec3::new;
    let quad = |name: &str, material: u32, x0: f32, x1: f32, u0: f32, u1: f32| {
        let mut m = Mesh::quad(name, material, [c(x0, 0., -2.), c(x1, 0., -2.), c(x1, 0., 2.), c(x0, 0., 2.)]);
        m.uvs = vec![Vec2::new(u0, 0.0), Vec2::new(u1, 0.0), Vec2::new(u1, 1.0), Vec2::new(u0, 1.0)];
        m
    };
    let mean = ((METAL.0 + DIELECTRIC.0) / 2.0, (METAL.1 + DIELECTRIC.1) / 2.0);
    match floor {
        Floor::Textured => {
            let texture = s.textures.len() as u32;
            s.textures.push(Image::from_fn(64, 1, |x, _| {
                let (metallic, roughness) = if x < 32 { METAL } else { DIELECTRIC };
                Vec3::new(0.0, roughness, metallic)
            }));
            let map = MetallicRoughnessMap { texture, metallic: 1.0, roughness: 1.0 };
            let m = s.add_material(Material { metallic_roughness_map: Some(map), ..Material::diffuse("floor", BASE) });
            let m_mean = &mut s.materials[m as usize];
            (m_mean.metallic, m_mean.roughness) = mean;
            s.add_mesh(quad("floor", m, -2.0, 2.0, 0.0, 1.0), Mat4::IDENTITY);
        }
        Floor::Split => {
            let (metal, dielectric) = (material(&mut s, "metal", METAL), material(&mut s, "dielectric", DIELECTRIC));
            s.add_mesh(quad("metal", metal, -2.0, 0.0, 0.0, 0.5), Mat4::IDENTITY);
            s.add_mesh(quad("dielectric", dielectric, 0.0, 2.0, 0.5, 1.0), Mat4::IDENTITY);
        }
        Floor::Mean => {
            let m = material(&mut s, "floor", mean);
            s.add_mesh(quad("floor", m, -2.0, 2.0, 0.0, 1.0), Mat4::IDENTITY);
        }
    }
    // The sun behind the floor's far end: its glossy reflection faces the camera.
    s.environment = Some(Environment::procedural_sky(256, Vec3::new(0.0, 0.5, -1.0), 50.0));
    s.camera = Some(Camera::look_at(c(0.0, 1.5, 3.0), c(0.0, 0.0, -0.5), Vec3::Y, 60.0));
    s
}

/// The radiance (mean of the channels) of the pixels whose floor point lies well inside each
/// half (u in 0.05–0.45 and 0.55–0.95: away from the seam and the texture's repeat at u = 0, 1).
fn halves(scene: &Scene) -> [Vec<f64>; 2] {
    let ctx = FrameContext::new(scene, 0.0, 32, 24);
    let g = ctx.gbuffer();
    let mut img = ctx.image();
    let mut pt = PathTracer::new(&Settings { spp: 32, seed: 3 }, &Params::default()).unwrap();
    pt.prepare(&ctx).unwrap();
    pt.render(&ctx, &g, &mut img).unwrap();
    let mut halves = [Vec::new(), Vec::new()];
    for (i, p) in img.pixels.iter().enumerate() {
        let u = g.uv[i].x;
        if g.depth[i].is_finite() && (0.05..0.95).contains(&u) && (u - 0.5).abs() > 0.05 {
            halves[usize::from(u > 0.5)].push((p.x + p.y + p.z) as f64 / 3.0);
        }
    }
    assert!(halves.iter().all(|h| h.len() > 20), "{} and {} pixels", halves[0].len(), halves[1].len());
    halves
}

/// RMS difference of `a` from `b`, relative to `b`'s RMS.
fn relative_rms(a: &[f64], b: &[f64]) -> f64 {
    let sq = |x: f64| x * x;
    (a.iter().zip(b).map(|(a, b)| sq(a - b)).sum::<f64>() / b.iter().map(|&b| sq(b)).sum::<f64>()).sqrt()
}

#[test]
fn the_reference_reads_metallic_and_roughness_per_texel() {
    let (textured, split, mean) = (halves(&scene(Floor::Textured)), halves(&scene(Floor::Split)), halves(&scene(Floor::Mean)));
    for h in 0..2 {
        let (t, m) = (relative_rms(&textured[h], &split[h]), relative_rms(&mean[h], &split[h]));
        println!(
            "half {h} ({} pixels): relative RMS difference from two materials: textured {t:.4}, the mean material {m:.4}",
            split[h].len()
        );
        assert!(t < 0.02, "half {h}: {t}");
        // The test can fail: the mean material is far from either half.
        assert!(m > 0.1, "half {h}: {m}");
    }
}
