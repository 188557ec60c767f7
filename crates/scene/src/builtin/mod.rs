//! Scenes that need no files. Each is a function returning a [`Scene`]; [`NAMES`] lists them and
//! [`describe`] says what each is for.

mod cornell;
mod cornell_dynamic;
mod cornell_lit;
mod deforming;
mod glossy;
mod many_lights;
mod sky;

use crate::{Mesh, Motion, Scene, SceneError, Transform, TransformKey};
use glimpse_core::{Vec2, Vec3};

pub use cornell::cornell;
pub use cornell_dynamic::cornell_dynamic;
pub use cornell_lit::cornell_lit;
pub use deforming::deforming;
pub use glossy::glossy;
pub use many_lights::{DEFAULT_LIGHT_COUNT, many_lights};
pub use sky::sky;

/// Every built-in scene, in the order `glimpse scenes` lists them.
pub const NAMES: &[&str] = &["cornell", "cornell-lit", "cornell-dynamic", "many-lights", "deforming", "sky", "glossy"];

/// Animated built-in scenes are authored over `0..CLIP_S` seconds: keyframe tracks do not loop,
/// so each one covers the whole clip (and holds its last key after it).
pub const CLIP_S: f32 = 10.0;

pub fn describe(name: &str) -> &'static str {
    match name {
        "cornell" => "the Cornell box with its published dimensions (metres) and ceiling area light",
        "cornell-lit" => {
            "the Cornell box with its area light, four point lights inside and a smooth sky through the open front: every technique applies (the demo's scene)"
        }
        "cornell-dynamic" => "the Cornell box with a spinning block, a bouncing ball and a sliding cylinder (10 s clip)",
        "many-lights" => {
            "a night-time town of boxes, towers and domes lit only by 1,024 small coloured point lights orbiting in the streets"
        }
        "deforming" => "vertex animation: a waving cloth canopy on posts and a squash-and-stretch bouncing ball, sun plus sky light",
        "sky" => {
            "an arch, a table, boxes and spheres on a large ground under a procedural sky with a low visible sun; one ball circles them"
        }
        "glossy" => {
            "static glossy objects (GGX roughness 0.25–0.45: gold sphere, red box, clear-coated blue sphere) on a rough floor under a smooth sky and a ceiling area light"
        }
        _ => "",
    }
}

pub fn build(name: &str) -> Result<Scene, SceneError> {
    let scene = match name {
        "cornell" => cornell(),
        "cornell-lit" => cornell_lit(),
        "cornell-dynamic" => cornell_dynamic(),
        "many-lights" => many_lights(DEFAULT_LIGHT_COUNT),
        "deforming" => deforming(),
        "sky" => sky(),
        "glossy" => glossy(),
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
pub fn box_mesh(name: &str, material: u32, half: Vec3) -> Mesh {
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
pub fn sphere_mesh(name: &str, material: u32, rings: u32, segments: u32) -> Mesh {
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

/// A flat `size.x × size.y` rectangle in the xz-plane centred at the origin, facing +y, cut into
/// `divisions[0] × divisions[1]` cells of two triangles each; normals +y, uvs over [0,1]².
pub(crate) fn plane_mesh(name: &str, material: u32, size: Vec2, divisions: [u32; 2]) -> Mesh {
    let [nx, nz] = divisions.map(|d| d.max(1));
    let mut m = Mesh { name: name.into(), material, ..Default::default() };
    for j in 0..=nz {
        for i in 0..=nx {
            let uv = Vec2::new(i as f32 / nx as f32, j as f32 / nz as f32);
            m.positions.push(Vec3::new((uv.x - 0.5) * size.x, 0.0, (uv.y - 0.5) * size.y));
            m.normals.push(Vec3::Y);
            m.uvs.push(uv);
        }
    }
    let row = nx + 1;
    for j in 0..nz {
        for i in 0..nx {
            let v00 = j * row + i;
            let (v10, v01, v11) = (v00 + 1, v00 + row, v00 + row + 1);
            m.indices.push([v00, v01, v10]);
            m.indices.push([v10, v01, v11]);
        }
    }
    m
}

/// A closed cylinder of radius 1 around the y axis from y = −1 to 1 (the unit size of
/// [`box_mesh`] and [`sphere_mesh`]): `segments` side quads with smooth normals and two flat caps
/// with their own vertices.
pub(crate) fn cylinder_mesh(name: &str, material: u32, segments: u32) -> Mesh {
    let n = segments.max(3);
    let mut m = Mesh { name: name.into(), material, ..Default::default() };
    let ring = |s: u32| {
        let (sin, cos) = (std::f32::consts::TAU * (s % n) as f32 / n as f32).sin_cos();
        Vec2::new(cos, sin)
    };
    for s in 0..=n {
        let r = ring(s);
        for y in [-1.0, 1.0] {
            m.positions.push(Vec3::new(r.x, y, r.y));
            m.normals.push(Vec3::new(r.x, 0.0, r.y));
            m.uvs.push(Vec2::new(s as f32 / n as f32, (1.0 - y) * 0.5));
        }
    }
    for s in 0..n {
        let (b0, t0, b1, t1) = (2 * s, 2 * s + 1, 2 * s + 2, 2 * s + 3);
        m.indices.push([b0, t0, b1]);
        m.indices.push([b1, t0, t1]);
    }
    for y in [-1.0f32, 1.0] {
        let centre = m.positions.len() as u32;
        m.positions.push(Vec3::new(0.0, y, 0.0));
        m.normals.push(Vec3::new(0.0, y, 0.0));
        m.uvs.push(Vec2::splat(0.5));
        for s in 0..n {
            let r = ring(s);
            m.positions.push(Vec3::new(r.x, y, r.y));
            m.normals.push(Vec3::new(0.0, y, 0.0));
            m.uvs.push(Vec2::splat(0.5) + r * 0.5);
        }
        for s in 0..n {
            let (a, b) = (centre + 1 + s, centre + 1 + (s + 1) % n);
            m.indices.push(if y > 0.0 { [centre, b, a] } else { [centre, a, b] });
        }
    }
    m
}

/// A rigid track sampling `f` every `step` seconds over `0..=duration` (a motion meant to repeat
/// is written out over the whole clip, since [`Motion::Keyframes`] does not loop).
pub(crate) fn sampled_track(duration: f32, step: f32, f: impl Fn(f32) -> Transform) -> Motion {
    let n = (duration / step).round() as u32;
    Motion::Keyframes(
        (0..=n)
            .map(|i| {
                let time = i as f32 * step;
                TransformKey { time, transform: f(time) }
            })
            .collect(),
    )
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
            assert!(scene.triangle_count() <= 50_000, "{name} is too heavy for the tests");
            assert!(scene.camera.is_some(), "{name} has no camera");
            assert!(scene.warnings.is_empty(), "{name}: {:?}", scene.warnings);
            assert_eq!(
                scene.is_animated(),
                !["cornell", "cornell-lit", "glossy"].contains(name),
                "{name}: only cornell, cornell-lit and glossy are static"
            );
        }
    }

    #[test]
    fn unknown_scene_is_a_clear_error() {
        let e = crate::load("nope").unwrap_err().to_string();
        assert!(e.contains("unknown scene 'nope'") && e.contains("cornell"), "{e}");
    }

    #[test]
    fn box_and_sphere_normals_point_outwards() {
        for m in [box_mesh("b", 0, Vec3::ONE), sphere_mesh("s", 0, 8, 16), cylinder_mesh("c", 0, 12)] {
            for t in &m.indices {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                let n = (b - a).cross(c - a);
                assert!(n.dot((a + b + c) / 3.0) > 0.0, "{} has an inward face", m.name);
                // Shading normals, where given, agree with the winding.
                for &i in t {
                    assert!(m.normals.is_empty() || m.normals[i as usize].dot(n) > 0.0, "{}: vertex {i} normal disagrees", m.name);
                }
            }
        }
    }

    #[test]
    fn plane_faces_up_and_cylinder_is_closed() {
        let p = plane_mesh("p", 0, Vec2::new(4.0, 2.0), [8, 4]);
        assert_eq!(p.indices.len(), 64);
        let area: f32 = p
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| p.positions[i as usize]);
                let n = (b - a).cross(c - a);
                assert!(n.y > 0.0 && n.x == 0.0 && n.z == 0.0, "plane triangle {t:?} faces {n}");
                0.5 * n.length()
            })
            .sum();
        println!("plane area {area} (expected 8), bounds {:?}", p.bounds());
        assert!((area - 8.0).abs() < 1e-5 && p.normals.iter().all(|n| *n == Vec3::Y));
        assert!((p.bounds().min - Vec3::new(-2.0, 0.0, -1.0)).length() < 1e-6);

        // Every edge of the closed cylinder is shared by exactly two triangles, once each way.
        let c = cylinder_mesh("c", 0, 16);
        let key = |p: Vec3| [p.x, p.y, p.z].map(|v| (v * 1e4).round() as i32);
        let mut edges = std::collections::HashMap::new();
        for t in &c.indices {
            for k in 0..3 {
                let (a, b) = (key(c.positions[t[k] as usize]), key(c.positions[t[(k + 1) % 3] as usize]));
                *edges.entry((a, b)).or_insert(0) += 1;
            }
        }
        let open = edges.iter().filter(|((a, b), n)| **n != 1 || edges.get(&(*b, *a)) != Some(&1)).count();
        println!("cylinder: {} triangles, {} directed edges, {open} unmatched", c.indices.len(), edges.len());
        assert_eq!(open, 0);
        assert_eq!(c.indices.len(), 4 * 16);
    }
}
