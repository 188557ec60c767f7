//! Shared by the voxel array's test files: a seeded random scene.

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
