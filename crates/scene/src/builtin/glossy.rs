//! Glossy objects for all-frequency GI (the `wavecache` technique against `pt`): on a rough grey
//! floor (6 × 6 m, roughness 1), a gold metal sphere (GGX roughness 0.25), a red plastic box
//! (roughness 0.45, turned 30°) and a small blue plastic sphere (roughness 0.35) under a clear coat (γ = 1), lit by a
//! procedural sky whose "sun" is no brighter than the sky (a smooth environment) and a 0.8 × 0.8 m
//! emissive ceiling panel 2.4 m up, facing down. Static: precomputed caches stay valid.

use super::{box_mesh, plane_mesh, quads_mesh, sphere_mesh};
use crate::{Camera, Environment, Material, Scene};
use glimpse_core::{Mat4, Vec2, Vec3};

/// The area light's radiance (W/(m²·sr) per channel).
pub const PANEL_RADIANCE: f32 = 12.0;

pub fn glossy() -> Scene {
    let mut s = Scene { name: "glossy".into(), ..Default::default() };
    let floor = s.add_material(Material::diffuse("floor", Vec3::new(0.55, 0.55, 0.52)));
    let gold = s.add_material(Material {
        name: "gold".into(),
        base_color: Vec3::new(1.0, 0.78, 0.34),
        roughness: 0.25,
        metallic: 1.0,
        ..Default::default()
    });
    let red = s.add_material(Material {
        name: "red plastic".into(),
        base_color: Vec3::new(0.65, 0.12, 0.08),
        roughness: 0.45,
        metallic: 0.0,
        ..Default::default()
    });
    let blue = s.add_material(Material {
        name: "blue clear-coated plastic".into(),
        base_color: Vec3::new(0.1, 0.25, 0.7),
        roughness: 0.35,
        metallic: 0.0,
        clearcoat: 1.0,
        ..Default::default()
    });
    let panel = s.add_material(Material::emissive("panel", Vec3::splat(PANEL_RADIANCE)));

    s.add_mesh(plane_mesh("floor", floor, Vec2::splat(6.0), [12, 12]), Mat4::IDENTITY);
    s.add_mesh(
        sphere_mesh("gold sphere", gold, 32, 64),
        Mat4::from_translation(Vec3::new(-0.55, 0.5, 0.0)) * Mat4::from_scale(Vec3::splat(0.5)),
    );
    s.add_mesh(
        box_mesh("red box", red, Vec3::splat(0.3)),
        Mat4::from_translation(Vec3::new(0.6, 0.3, 0.25)) * Mat4::from_rotation_y(30f32.to_radians()),
    );
    s.add_mesh(
        sphere_mesh("blue sphere", blue, 24, 48),
        Mat4::from_translation(Vec3::new(0.15, 0.22, 0.85)) * Mat4::from_scale(Vec3::splat(0.22)),
    );
    // The panel faces down: corners wound so that (b − a) × (c − a) points along −y.
    let h = 0.4;
    let corners = [Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.0, -h), Vec3::new(h, 0.0, h), Vec3::new(-h, 0.0, h)];
    s.add_mesh(quads_mesh("ceiling panel", panel, &[corners]), Mat4::from_translation(Vec3::new(0.2, 2.4, 0.4)));

    let sun = Vec3::new(-0.4, 0.6, -0.5).normalize();
    s.environment = Some(Environment::procedural_sky(128, sun, 1.0));
    s.camera = Some(Camera::look_at(Vec3::new(0.2, 1.5, 3.4), Vec3::new(0.0, 0.35, 0.0), Vec3::Y, 40.0));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panel_faces_down_and_roughness_is_glossy() {
        let s = glossy();
        let panel = s.meshes.iter().find(|m| m.name == "ceiling panel").unwrap();
        for t in &panel.indices {
            let [a, b, c] = t.map(|i| panel.positions[i as usize]);
            assert!((b - a).cross(c - a).y < 0.0, "the panel must emit downwards");
        }
        let glossy: Vec<f32> = s.materials.iter().filter(|m| m.roughness < 1.0).map(|m| m.roughness).collect();
        println!("glossy roughness values {glossy:?}, {} triangles", s.triangle_count());
        assert!(glossy.len() >= 2 && glossy.iter().all(|r| (0.1..=0.5).contains(r)));
        assert!(!s.is_animated());
    }
}
