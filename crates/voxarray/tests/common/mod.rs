//! Shared by the voxel array's test files: a seeded random scene, a lit moving scene, a dome
//! on a large ground.
// Each test file uses some of these.
#![allow(dead_code)]

use glimpse_core::{Rng, Vec3};

/// A closed box with `count` random triangles inside (seeded).
pub fn scene(seed: u64, count: usize) -> Vec<[Vec3; 3]> {
    let mut rng = Rng::new(seed, 0);
    let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
    let mut tris = Vec::new();
    for _ in 0..count {
        let c = v() * 0.8;
        tris.push([c + v() * 0.25, c + v() * 0.25, c + v() * 0.25]);
    }
    // Floor and back wall, so many rays start on or graze a surface.
    let q = |a: Vec3, b: Vec3, c: Vec3, d: Vec3| [[a, b, c], [a, c, d]];
    tris.extend(q(Vec3::new(-1., -1., -1.), Vec3::new(1., -1., -1.), Vec3::new(1., -1., 1.), Vec3::new(-1., -1., 1.)));
    tris.extend(q(Vec3::new(-1., -1., -1.), Vec3::new(1., -1., -1.), Vec3::new(1., 1., -1.), Vec3::new(-1., 1., -1.)));
    tris
}

/// `cornell-dynamic` (rigid moving instances: Alg. 5) with `count` point lights added inside the
/// box (it has only an area light, which `lights-voxarray` does not use).
pub fn cornell_dynamic_lit(count: usize) -> glimpse_scene::Scene {
    let mut scene = glimpse_scene::load("cornell-dynamic").unwrap();
    let b = scene.at(0.0).bounds;
    for k in 0..count {
        let f = Vec3::new(0.2 + 0.08 * k as f32, 0.8, 0.3 + 0.05 * k as f32);
        scene.lights.push(glimpse_scene::Light::point(b.min + (b.max - b.min) * f, Vec3::splat(2.0)));
    }
    scene
}

/// A dome (a squashed sphere) resting on a 2 km ground, seen from 14 m up, a sun and a point
/// light over it: `focus=auto` builds the array around the dome.
pub fn dome_on_ground() -> glimpse_scene::Scene {
    let toml = "[camera]\nposition = [0.0, 14.0, 22.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y_degrees = 30.0\n\
        [[quad]]\nsize = [2000.0, 2000.0]\n\
        [[sphere]]\nradius = 6.0\nscale = [1.0, 0.6, 1.0]\ntranslate = [0.0, 3.6, 0.0]\n\
        [[light]]\nkind = \"directional\"\ndirection = [0.3, -0.5, 0.6]\nintensity = 2.0\n\
        [[light]]\nkind = \"point\"\nposition = [-10.0, 15.0, -5.0]\nintensity = 300.0\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    glimpse_scene::load(path.to_str().unwrap()).unwrap()
}
