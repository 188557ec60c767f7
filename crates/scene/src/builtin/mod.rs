//! Scenes that need no files. Each is a function returning a [`Scene`]; [`NAMES`] lists them and
//! [`describe`] says what each is for.

mod cornell;

use crate::{Mesh, Scene, SceneError};
use glimpse_core::{Vec2, Vec3};

pub use cornell::cornell;

/// Every built-in scene, in the order `glimpse scenes` lists them.
pub const NAMES: &[&str] = &["cornell"];

pub fn describe(name: &str) -> &'static str {
    match name {
        "cornell" => "the Cornell box with its published dimensions (metres) and ceiling area light",
        _ => "",
    }
}

pub fn build(name: &str) -> Result<Scene, SceneError> {
    let scene = match name {
        "cornell" => cornell(),
        _ => return Err(SceneError::UnknownScene { name: name.to_owned(), known: NAMES.join(", ") }),
    };
    Ok(scene)
}

/// A mesh from planar quads (each four corners in order), split into two triangles per quad.
pub(crate) fn quads_mesh(name: &str, material: u32, quads: &[[Vec3; 4]]) -> Mesh {
    let mut m = Mesh { name: name.into(), material, ..Default::default() };
    for q in quads {
        let base = m.positions.len() as u32;
        m.positions.extend_from_slice(q);
        m.uvs.extend_from_slice(&[Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]);
        m.indices.push([base, base + 1, base + 2]);
        m.indices.push([base, base + 2, base + 3]);
    }
    m
}

/// An axis-aligned box of half-size `half` centred at the origin, faces pointing outwards.
pub(crate) fn box_mesh(name: &str, material: u32, half: Vec3) -> Mesh {
    let h = half;
    let c = |x: f32, y: f32, z: f32| Vec3::new(x * h.x, y * h.y, z * h.z);
    quads_mesh(
        name,
        material,
        &[
            [c(1., -1., -1.), c(1., 1., -1.), c(1., 1., 1.), c(1., -1., 1.)],
            [c(-1., -1., 1.), c(-1., 1., 1.), c(-1., 1., -1.), c(-1., -1., -1.)],
            [c(-1., 1., -1.), c(-1., 1., 1.), c(1., 1., 1.), c(1., 1., -1.)],
            [c(-1., -1., 1.), c(-1., -1., -1.), c(1., -1., -1.), c(1., -1., 1.)],
            [c(-1., -1., 1.), c(1., -1., 1.), c(1., 1., 1.), c(-1., 1., 1.)],
            [c(1., -1., -1.), c(-1., -1., -1.), c(-1., 1., -1.), c(1., 1., -1.)],
        ],
    )
}

/// A UV sphere of radius 1 at the origin with smooth normals.
pub(crate) fn sphere_mesh(name: &str, material: u32, rings: u32, segments: u32) -> Mesh {
    let mut m = Mesh { name: name.into(), material, ..Default::default() };
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let p = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            m.positions.push(p);
            m.normals.push(p);
            m.uvs.push(Vec2::new(s as f32 / segments as f32, r as f32 / rings as f32));
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b) = (r * row + s, (r + 1) * row + s);
            if r != 0 {
                m.indices.push([a, a + 1, b]);
            }
            if r != rings - 1 {
                m.indices.push([a + 1, b + 1, b]);
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_builds_and_validates() {
        for name in NAMES {
            let scene = crate::load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            println!("{name}: {} triangles, {} lights, animated {}", scene.triangle_count(), scene.lights.len(), scene.is_animated());
            assert!(scene.triangle_count() > 0 && !describe(name).is_empty());
        }
    }

    #[test]
    fn unknown_scene_is_a_clear_error() {
        let e = crate::load("nope").unwrap_err().to_string();
        assert!(e.contains("unknown scene 'nope'") && e.contains("cornell"), "{e}");
    }

    #[test]
    fn box_and_sphere_normals_point_outwards() {
        for m in [box_mesh("b", 0, Vec3::ONE), sphere_mesh("s", 0, 8, 16)] {
            for t in &m.indices {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                let n = (b - a).cross(c - a);
                assert!(n.dot((a + b + c) / 3.0) > 0.0, "{} has an inward face", m.name);
            }
        }
    }
}
