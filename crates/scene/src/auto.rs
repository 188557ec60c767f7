//! What a bare mesh gets when its file says nothing: an automatic camera and a default light.
//!
//! The camera stays outside the scene's bounding sphere and looks at its centre; of a few
//! candidate directions it picks the one that sees the most front-facing surface (area × cos),
//! so an open box (a Cornell box, an atrium without a roof) is seen through its opening rather
//! than from behind a wall. The light, when a scene has none of any kind, is a uniform white
//! environment: every technique that needs some light can then run, and the choice is said once.

use crate::{Camera, Environment, Scene};
use glimpse_core::Vec3;

/// The automatic camera's preferred direction (from the centre towards the camera): in front, a
/// little above. It is kept unless another candidate sees clearly more surface.
const PREFERRED: Vec3 = Vec3::new(0.0, 0.25, 1.0);

/// How much more visible area another direction needs to replace the preferred one; a closed
/// object looks about the same from everywhere, and the front view is the expected one.
const SWITCH_MARGIN: f32 = 1.25;

/// The camera for a scene whose file has none (see the module comment).
pub fn camera(scene: &Scene, aspect: f32) -> Camera {
    let frame = scene.at(0.0);
    let bounds = frame.bounds;
    // Area-weighted face normals in world space, gathered once.
    let mut normals: Vec<Vec3> = Vec::new();
    for (ii, inst) in scene.instances.iter().enumerate() {
        let m = frame.transforms[ii];
        let pos = &frame.positions[inst.mesh as usize];
        for tri in &scene.meshes[inst.mesh as usize].indices {
            let v = tri.map(|i| m.transform_point3(pos[i as usize]));
            // Half the cross product: its length is the triangle's area.
            normals.push((v[1] - v[0]).cross(v[2] - v[0]) * 0.5);
        }
    }
    let seen = |dir: Vec3| -> f32 { normals.iter().map(|n| n.dot(dir).max(0.0)).sum() };
    let preferred = PREFERRED.normalize();
    let mut best = (preferred, seen(preferred) * SWITCH_MARGIN);
    for elevation in [15f32, 50.0] {
        for k in 0..8 {
            let azimuth = (k as f32 * 45.0).to_radians();
            let (e, a) = (elevation.to_radians(), azimuth);
            let dir = Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos());
            let s = seen(dir);
            if s > best.1 {
                best = (dir, s);
            }
        }
    }
    Camera::framing_from(bounds, aspect, best.0)
}

/// The sentence said on stderr when [`ensure_light`] adds the default environment.
pub const DEFAULT_LIGHT_NOTE: &str =
    "the scene has no lights; lighting it with a uniform white environment (radiance 1); add --env, --sun or --light to choose";

/// Adds a uniform white environment (radiance 1) when the scene has no punctual light, no
/// emissive material and no environment; returns whether it did.
pub fn ensure_light(scene: &mut Scene) -> bool {
    let has_emissive = scene.instances.iter().any(|i| scene.materials[scene.meshes[i.mesh as usize].material as usize].is_emissive());
    if !scene.lights.is_empty() || scene.environment.is_some() || has_emissive {
        return false;
    }
    scene.environment = Some(Environment::constant(Vec3::ONE));
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Material, Mesh};
    use glimpse_core::Mat4;

    /// A box open towards −z: floor, ceiling, two side walls and a back wall at +z, all facing in.
    fn open_box() -> Scene {
        let mut scene = Scene::default();
        let mat = scene.add_material(Material::diffuse("white", Vec3::splat(0.8)));
        let quad = |a: Vec3, b: Vec3, c: Vec3, d: Vec3| Mesh {
            name: "wall".into(),
            positions: vec![a, b, c, d],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            material: mat,
            ..Default::default()
        };
        let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        // Counter-clockwise seen from inside the box.
        let walls = [
            quad(p(0., 0., 0.), p(0., 0., 1.), p(1., 0., 1.), p(1., 0., 0.)), // floor, +y
            quad(p(0., 1., 0.), p(1., 1., 0.), p(1., 1., 1.), p(0., 1., 1.)), // ceiling, −y
            quad(p(0., 0., 1.), p(0., 1., 1.), p(1., 1., 1.), p(1., 0., 1.)), // back, −z
            quad(p(0., 0., 0.), p(0., 1., 0.), p(0., 1., 1.), p(0., 0., 1.)), // left, +x
            quad(p(1., 0., 0.), p(1., 0., 1.), p(1., 1., 1.), p(1., 1., 0.)), // right, −x
        ];
        for w in walls {
            scene.add_mesh(w, Mat4::IDENTITY);
        }
        scene
    }

    #[test]
    fn open_box_is_seen_through_its_opening_from_outside() {
        let scene = open_box();
        let c = camera(&scene, 1.0);
        assert!(c.position.z < 0.0, "camera {:?} should look in through the open −z side", c.position);
        let radius = scene.bounds().extent().length() * 0.5;
        assert!((c.position - scene.bounds().center()).length() > radius, "camera inside the bounding sphere");
    }

    #[test]
    fn default_light_only_when_there_is_none() {
        let mut scene = open_box();
        assert!(ensure_light(&mut scene));
        assert!(scene.environment.is_some());
        assert!(!ensure_light(&mut scene), "a second call adds nothing");
    }
}
