//! Checks a scene before anything renders it, so that bad input becomes one clear error naming
//! its source instead of a panic or a silently wrong image.
//!
//! Policy: non-finite numbers, out-of-range indices, an empty or zero-size scene and absurd
//! parameters are errors. Degenerate (zero-area) triangles are common in scanned and exported
//! meshes, so they are removed with a warning; a mesh left with no triangle is an error.

use crate::{LightKind, Scene, SceneError};
use glimpse_core::is_finite3;

/// The widest vertical field of view a camera may have, in degrees.
pub const MAX_FOV_DEGREES: f32 = 170.0;

pub fn validate(scene: &mut Scene, source: &str) -> Result<(), SceneError> {
    let invalid = |message: String| SceneError::Invalid { source_name: source.to_owned(), message };

    for (mi, mat) in scene.materials.iter().enumerate() {
        let name = &mat.name;
        if !is_finite3(mat.base_color)
            || !is_finite3(mat.emission)
            || !mat.roughness.is_finite()
            || !mat.metallic.is_finite()
            || !mat.clearcoat.is_finite()
        {
            return Err(invalid(format!("material {mi} '{name}' has a non-finite parameter")));
        }
        if mat.base_color.min_element() < 0.0 || mat.emission.min_element() < 0.0 {
            return Err(invalid(format!("material {mi} '{name}' has a negative colour or emission")));
        }
        if !(0.0..=1.0).contains(&mat.roughness) || !(0.0..=1.0).contains(&mat.metallic) {
            return Err(invalid(format!(
                "material {mi} '{name}': roughness {} and metallic {} must lie in [0, 1]",
                mat.roughness, mat.metallic
            )));
        }
        if !(0.0..=1.0).contains(&mat.clearcoat) {
            return Err(invalid(format!("material {mi} '{name}': clearcoat {} must lie in [0, 1]", mat.clearcoat)));
        }
        match mat.model {
            crate::MaterialModel::Conductor { eta, k }
                if !is_finite3(eta) || !is_finite3(k) || eta.min_element() < 0.0 || k.min_element() < 0.0 =>
            {
                return Err(invalid(format!("material {mi} '{name}': conductor eta {eta} and k {k} must be finite and non-negative")));
            }
            crate::MaterialModel::Dielectric { ior } if !(ior.is_finite() && ior > 0.0) => {
                return Err(invalid(format!("material {mi} '{name}': dielectric ior {ior} must be finite and positive")));
            }
            _ => {}
        }
        let textures = [
            mat.base_color_texture,
            mat.alpha_mask.and_then(|m| m.texture),
            mat.metallic_roughness_map.map(|m| m.texture),
            mat.normal_map.map(|m| m.texture),
            mat.emission_map.map(|m| m.texture),
        ];
        if let Some(t) = textures.into_iter().flatten().find(|&t| t as usize >= scene.textures.len()) {
            return Err(invalid(format!("material {mi} '{name}' uses texture {t}, but there are {}", scene.textures.len())));
        }
        if let Some(mask) = mat.alpha_mask
            && !(mask.factor.is_finite() && mask.cutoff.is_finite())
        {
            return Err(invalid(format!(
                "material {mi} '{name}': alpha mask factor {} and cutoff {} must be finite",
                mask.factor, mask.cutoff
            )));
        }
        if let Some(map) = mat.emission_map
            && !(is_finite3(map.factor) && map.factor.min_element() >= 0.0)
        {
            return Err(invalid(format!("material {mi} '{name}': emission map factor {} must be finite and non-negative", map.factor)));
        }
        if let Some(map) = mat.normal_map
            && !map.scale.is_finite()
        {
            return Err(invalid(format!("material {mi} '{name}': normal map scale {} must be finite", map.scale)));
        }
        if let Some(map) = mat.metallic_roughness_map
            && !((0.0..=1.0).contains(&map.metallic) && (0.0..=1.0).contains(&map.roughness))
        {
            return Err(invalid(format!(
                "material {mi} '{name}': metallic-roughness factors {} and {} must be in [0, 1]",
                map.metallic, map.roughness
            )));
        }
    }

    for (mi, mesh) in scene.meshes.iter_mut().enumerate() {
        let name = format!("mesh {mi} '{}'", mesh.name);
        if mesh.material as usize >= scene.materials.len() {
            return Err(invalid(format!("{name} uses material {}, but there are {}", mesh.material, scene.materials.len())));
        }
        if let Some(i) = mesh.positions.iter().position(|p| !is_finite3(*p)) {
            return Err(invalid(format!("{name}: vertex {i} has a NaN or infinite coordinate {}", mesh.positions[i])));
        }
        if !mesh.normals.is_empty() && mesh.normals.len() != mesh.positions.len() {
            return Err(invalid(format!("{name}: {} normals for {} vertices", mesh.normals.len(), mesh.positions.len())));
        }
        if !mesh.uvs.is_empty() && mesh.uvs.len() != mesh.positions.len() {
            return Err(invalid(format!("{name}: {} texture coordinates for {} vertices", mesh.uvs.len(), mesh.positions.len())));
        }
        if !mesh.colors.is_empty() && mesh.colors.len() != mesh.positions.len() {
            return Err(invalid(format!("{name}: {} vertex colours for {} vertices", mesh.colors.len(), mesh.positions.len())));
        }
        if mesh.normals.iter().any(|n| !is_finite3(*n)) || mesh.uvs.iter().any(|uv| !uv.is_finite()) {
            return Err(invalid(format!("{name}: a normal or texture coordinate is NaN or infinite")));
        }
        if mesh.colors.iter().any(|c| !is_finite3(*c) || c.min_element() < 0.0) {
            return Err(invalid(format!("{name}: a vertex colour is NaN, infinite or negative")));
        }
        if !mesh.tangents.is_empty() && mesh.tangents.len() != mesh.positions.len() {
            return Err(invalid(format!("{name}: {} tangents for {} vertices", mesh.tangents.len(), mesh.positions.len())));
        }
        if mesh.tangents.iter().any(|t| !t.is_finite()) {
            return Err(invalid(format!("{name}: a tangent is NaN or infinite")));
        }
        let n = mesh.positions.len() as u32;
        if let Some(t) = mesh.indices.iter().find(|t| t.iter().any(|&i| i >= n)) {
            return Err(invalid(format!("{name}: triangle {t:?} indexes past its {n} vertices")));
        }
        if mesh.indices.is_empty() {
            return Err(invalid(format!("{name} has no triangles")));
        }
        let before = mesh.indices.len();
        let positions = &mesh.positions;
        mesh.indices.retain(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            (b - a).cross(c - a).length_squared() > 0.0
        });
        let removed = before - mesh.indices.len();
        if mesh.indices.is_empty() {
            return Err(invalid(format!("{name}: all {before} triangles are degenerate (zero area)")));
        }
        if removed > 0 {
            scene.warnings.push(format!("{source}: {name}: removed {removed} degenerate (zero-area) triangles of {before}"));
        }
        if let Some(crate::Deformation::Keyframes { times, positions }) = &mesh.deformation {
            if times.len() != positions.len() || positions.iter().any(|p| p.len() != mesh.positions.len()) {
                return Err(invalid(format!("{name}: vertex keyframes do not match the vertex count")));
            }
            if positions.iter().flatten().any(|p| !is_finite3(*p)) {
                return Err(invalid(format!("{name}: a vertex keyframe has a NaN or infinite coordinate")));
            }
        }
    }

    if scene.instances.is_empty() {
        return Err(invalid("the scene is empty: it has no geometry".into()));
    }
    for (ii, inst) in scene.instances.iter().enumerate() {
        if inst.mesh as usize >= scene.meshes.len() {
            return Err(invalid(format!("instance {ii} uses mesh {}, but there are {}", inst.mesh, scene.meshes.len())));
        }
        let m = inst.motion.at(0.0);
        if !m.is_finite() || m.determinant() == 0.0 {
            return Err(invalid(format!("instance {ii}: its transform is singular or not finite")));
        }
    }

    for (li, l) in scene.lights.iter().enumerate() {
        if !is_finite3(l.intensity) || !is_finite3(l.position) || !is_finite3(l.direction) || l.intensity.min_element() < 0.0 {
            return Err(invalid(format!("light {li}: intensity, position and direction must be finite and intensity non-negative")));
        }
        if matches!(l.kind, LightKind::Spot { .. } | LightKind::Directional) && l.direction.length_squared() == 0.0 {
            return Err(invalid(format!("light {li}: its direction is the zero vector")));
        }
        if let LightKind::Spot { inner_angle, outer_angle } = l.kind
            && (!(0.0..=std::f32::consts::FRAC_PI_2).contains(&outer_angle) || !(0.0..=outer_angle).contains(&inner_angle))
        {
            return Err(invalid(format!("light {li}: spot angles need 0 <= inner <= outer <= 90°")));
        }
    }

    if let Some(env) = &scene.environment {
        if !env.scale.is_finite() || env.scale < 0.0 {
            return Err(invalid(format!("environment scale {} must be finite and non-negative", env.scale)));
        }
        if env.image.pixels.iter().any(|p| !is_finite3(*p) || p.min_element() < 0.0) {
            return Err(invalid("the environment map has NaN, infinite or negative texels".into()));
        }
    }

    if let Some(cam) = &scene.camera {
        if !is_finite3(cam.position) || !is_finite3(cam.target) || !is_finite3(cam.up) {
            return Err(invalid("the camera has a non-finite position, target or up vector".into()));
        }
        let forward = cam.target - cam.position;
        if forward.length_squared() == 0.0 || forward.cross(cam.up).length_squared() == 0.0 {
            return Err(invalid("the camera's target equals its position, or its up vector is parallel to its view".into()));
        }
        // Beyond 170° a pinhole image stretches its edges by more than tan(85°) ≈ 11×: 179.99°
        // is a typo or a unit mix-up, not a camera.
        if !(cam.fov > 0.0 && cam.fov <= MAX_FOV_DEGREES.to_radians()) {
            return Err(invalid(format!("the camera's field of view {}° must lie in (0°, {MAX_FOV_DEGREES}°]", cam.fov.to_degrees())));
        }
    }

    let extent = scene.bounds().extent();
    let nonzero_axes = [extent.x, extent.y, extent.z].iter().filter(|&&e| e > 0.0).count();
    if nonzero_axes < 2 || !is_finite3(extent) {
        return Err(invalid(format!("the scene has zero area (its bounds' extent is {})", extent)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AlphaMask, EmissionMap, Material, MetallicRoughnessMap, NormalMap};
    use glimpse_core::{Image, Vec3};

    /// A material's textures (base colour, alpha mask, metallic-roughness, normal, emission) must exist, and its
    /// maps' factors must be in range: a bad index would panic at the first texel read.
    #[test]
    fn material_maps_are_checked() {
        let plain = || Material::diffuse("m", Vec3::ONE);
        let map = |texture, metallic| Some(MetallicRoughnessMap { texture, metallic, roughness: 1.0 });
        let mask = |texture, factor| Some(AlphaMask { texture, factor, cutoff: 0.5 });
        let cases = [
            (Material { metallic_roughness_map: map(3, 1.0), ..plain() }, "uses texture 3, but there are 1"),
            (Material { alpha_mask: mask(Some(2), 1.0), ..plain() }, "uses texture 2, but there are 1"),
            (Material { metallic_roughness_map: map(0, 1.5), ..plain() }, "metallic-roughness factors 1.5 and 1"),
            (Material { alpha_mask: mask(None, f32::NAN), ..plain() }, "alpha mask factor NaN"),
            (
                Material {
                    normal_map: Some(NormalMap {
                        texture: 4,
                        scale: 1.0,
                        bitangent: crate::Bitangent::ImageUp,
                        shadowing: crate::NormalMapShadowing::None,
                    }),
                    ..plain()
                },
                "uses texture 4, but there are 1",
            ),
            (
                Material {
                    normal_map: Some(NormalMap {
                        texture: 0,
                        scale: f32::INFINITY,
                        bitangent: crate::Bitangent::ImageUp,
                        shadowing: crate::NormalMapShadowing::None,
                    }),
                    ..plain()
                },
                "normal map scale inf",
            ),
            (Material { emission_map: Some(EmissionMap { texture: 5, factor: Vec3::ONE }), ..plain() }, "uses texture 5, but there are 1"),
            (
                Material { emission_map: Some(EmissionMap { texture: 0, factor: -Vec3::ONE }), ..plain() },
                "emission map factor [-1, -1, -1]",
            ),
        ];
        for (material, expected) in cases {
            let mut scene = Scene::default();
            scene.textures.push(Image::from_fn(1, 1, |_, _| Vec3::ONE));
            scene.add_material(material);
            let e = validate(&mut scene, "test").expect_err("an invalid material").to_string();
            println!("{e}");
            assert!(e.contains(expected), "{e}");
        }
    }
}
