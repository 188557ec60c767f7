//! The batched query ([`glimpse_voxarray::batch`]) against the scalar query, ray by ray: the
//! answers must be identical (the batch only reorders memory traffic), on several scenes, at
//! every row width, plain and compressed, and with `skip_start_run`.

use glimpse_core::{Ray, Rng, Vec3};
use glimpse_trace::Visibility;
use glimpse_voxarray::{CompressParams, VoxArray, VoxArrayParams};

/// A closed box with `count` random triangles inside (seeded).
fn scene(seed: u64, count: usize) -> Vec<[Vec3; 3]> {
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

/// Rays from points in the box (some on the floor) in random directions, finite and infinite.
fn rays(seed: u64, count: usize) -> Vec<(Ray, f32)> {
    let mut rng = Rng::new(seed, 1);
    (0..count)
        .map(|k| {
            let mut p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.2 - 1.1;
            if k % 3 == 0 {
                p.y = -1.0; // on the floor
            }
            let d = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0).normalize_or(Vec3::Y);
            let t = if k % 4 == 0 { f32::INFINITY } else { 0.05 + 3.0 * rng.next_f32() };
            (Ray::new(p, d), t)
        })
        .collect()
}

#[test]
fn batch_answers_equal_scalar_answers() {
    let compressed = Some(CompressParams { dictionary_rows: 256, steps: 4, seed: 3 });
    let mut checked = 0;
    for (seed, tris) in [(1u64, 40usize), (2, 300), (3, 5)] {
        let tris = scene(seed, tris);
        let rays = rays(seed, 3001); // not a multiple of the lane count
        for resolution in [32, 64, 128] {
            for (compress, skip_start_run) in [(None, false), (compressed, false), (None, true)] {
                let p = VoxArrayParams { resolution, directions: 16, compress, skip_start_run, ..VoxArrayParams::default() };
                let a = VoxArray::from_triangles(&tris, &p);
                let scalar: Vec<bool> = rays.iter().map(|(r, t)| a.occluded(r, *t)).collect();
                let mut batch = vec![false; rays.len()];
                a.occluded_batch(&rays, &mut batch);
                let segments: Vec<(Vec3, Vec3)> = rays.iter().map(|(r, t)| (r.origin, r.at(t.min(10.0)))).collect();
                let seg_scalar: Vec<bool> = segments.iter().map(|&(s, e)| a.occluded_segment(s, e)).collect();
                let mut seg_batch = vec![false; segments.len()];
                a.occluded_segments(&segments, &mut seg_batch);
                let occluded = scalar.iter().filter(|&&o| o).count();
                let mismatches = scalar.iter().zip(&batch).filter(|(a, b)| a != b).count()
                    + seg_scalar.iter().zip(&seg_batch).filter(|(a, b)| a != b).count();
                println!(
                    "scene {seed}, {resolution}³, compressed {}, skip_start_run {skip_start_run}: {occluded}/{} occluded, {mismatches} mismatches",
                    compress.is_some(),
                    rays.len()
                );
                // Both answers occur, so equality is not vacuous.
                assert!(occluded > 0 && occluded < rays.len());
                assert_eq!(batch, scalar);
                assert_eq!(seg_batch, seg_scalar);
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 27);
}
