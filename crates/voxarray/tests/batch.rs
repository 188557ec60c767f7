//! The batched query ([`glimpse_voxarray::batch`]) against the scalar query, ray by ray: the
//! answers must be identical (the batch only reorders memory traffic), on several scenes, at
//! every row width, plain and compressed, and with `skip_start_run`.

mod common;
use common::scene;
use glimpse_core::{Ray, Rng, Vec3};
use glimpse_trace::Visibility;
use glimpse_voxarray::{CompressParams, VoxArray, VoxArrayParams};

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

/// Segment sets for the SIMD pass-1 check: random, in and outside the grid, and adversarial
/// (axis-aligned, on bin boundaries, zero-length, NaN/∞ ends, d.y = 0, d.y < 0, ±0, tiny, huge).
fn extent_sets(seed: u64, n: u32) -> Vec<(&'static str, Vec<(Vec3, Vec3)>)> {
    use glimpse_voxarray::directions::{angle_rad, row_direction};
    let mut rng = Rng::new(seed, 7);
    let mut r = move || rng.next_f32();
    let mut sets = Vec::new();
    let v3 = |s: f32, r: &mut dyn FnMut() -> f32| Vec3::new(r() * 2.0 - 1.0, r() * 2.0 - 1.0, r() * 2.0 - 1.0) * s;
    sets.push(("random in grid", (0..4000).map(|_| (v3(1.0, &mut r), v3(1.0, &mut r))).collect()));
    sets.push(("random, ends outside", (0..4000).map(|_| (v3(3.0, &mut r), v3(3.0, &mut r))).collect()));
    sets.push((
        "random short",
        (0..4000)
            .map(|_| {
                let a = v3(1.1, &mut r);
                (a, a + v3(0.05, &mut r))
            })
            .collect(),
    ));
    sets.push(("far away", (0..2000).map(|_| (v3(1e4, &mut r), v3(1e4, &mut r))).collect()));
    let axes = [
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        -Vec3::X,
        -Vec3::Y,
        -Vec3::Z,
        Vec3::new(1., 1., 0.),
        Vec3::new(0., 1., 1.),
        Vec3::new(-1., 0., 1.),
        Vec3::new(1., -1., -1.),
    ];
    sets.push((
        "axis-aligned",
        (0..4000)
            .map(|k| {
                let a = v3(1.0, &mut r);
                (a, a + axes[k % axes.len()] * (0.01 + 2.0 * r()))
            })
            .collect(),
    ));
    // Exact bin centres and bin boundaries (half-steps) of θ and φ, both line orientations.
    let mut bins = Vec::new();
    for i in 0..2 * n + 1 {
        for j in 0..2 * n + 1 {
            let (t, p) = (angle_rad(4 * n, 2 * i), angle_rad(4 * n, 2 * j));
            let (tb, pb) = (angle_rad(2 * n, i), angle_rad(2 * n, j));
            for d in [row_direction(t, p), row_direction(tb, pb), row_direction(tb, p), row_direction(t, pb)] {
                let a = v3(0.9, &mut r);
                let l = 0.01 + 1.5 * r();
                bins.push((a, a + d * l));
                bins.push((a, a - d * l));
            }
        }
    }
    sets.push(("bin centres and boundaries", bins));
    let special =
        [0.0, -0.0, 1.0, -1.0, 1e-30, -1e-30, 1e-45, f32::MIN_POSITIVE, 1e20, -1e20, 3e38, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
    let mut weird = Vec::new();
    for k in 0..6000 {
        let a = v3(1.0, &mut r);
        let mut b = a + v3(1.0, &mut r);
        let pick = |r: &mut dyn FnMut() -> f32| special[(r() * special.len() as f32) as usize % special.len()];
        match k % 6 {
            0 => b = a,                        // zero length
            1 => b.y = a.y,                    // d.y = 0
            2 => b.y = a.y - r().abs() - 1e-3, // d.y < 0
            3 => {
                // special values in a random component of either end
                let c = (r() * 3.0) as usize % 3;
                if r() < 0.5 { b[c] = pick(&mut r) } else { b[c] = a[c] + pick(&mut r) }
            }
            4 => {
                let c = (r() * 3.0) as usize % 3;
                let mut a2 = a;
                a2[c] = pick(&mut r);
                weird.push((a2, b));
                continue;
            }
            _ => b = a + Vec3::new(pick(&mut r), pick(&mut r), pick(&mut r)), // tiny, huge, NaN directions
        }
        weird.push((a, b));
    }
    sets.push(("zero-length, d.y = 0, d.y < 0, NaN/inf/±0/tiny/huge", weird));
    sets
}

#[test]
fn simd_extents_equal_scalar_extents() {
    use glimpse_voxarray::batch::LANES;
    use glimpse_voxarray::extent8::{avx2_available, extents_scalar, extents_simd};
    use glimpse_voxarray::{Directions, Grid};
    println!("AVX2 used: {}", avx2_available());
    let (mut compared, mut mismatches, mut some) = (0usize, 0usize, 0usize);
    for (seed, (resolution, n)) in [(32u32, 16u32), (64, 90), (128, 90), (128, 2), (64, 30)].into_iter().enumerate() {
        let grids = [
            Grid { resolution, center: Vec3::ZERO, scale: resolution as f32 / 2.0 },
            Grid { resolution, center: Vec3::new(0.3, -0.2, 0.1), scale: resolution as f32 / 1.7 },
        ];
        let dirs = Directions::new(n);
        for grid in &grids {
            for (name, set) in extent_sets(seed as u64 + 11, n) {
                let mut set_mismatches = 0;
                for (bs, be) in [(0.0, 0.0), (0.5, 1.5), (3.0, -0.25), (1e3, 0.0)] {
                    for chunk in set.chunks_exact(LANES) {
                        let starts: [Vec3; LANES] = std::array::from_fn(|k| chunk[k].0);
                        let ends: [Vec3; LANES] = std::array::from_fn(|k| chunk[k].1);
                        let scalar = extents_scalar(grid, &dirs, &starts, &ends, bs, be);
                        let simd = extents_simd(grid, &dirs, &starts, &ends, bs, be).unwrap_or(scalar);
                        for k in 0..LANES {
                            compared += 1;
                            some += scalar[k].is_some() as usize;
                            if scalar[k] != simd[k] {
                                if set_mismatches < 5 {
                                    println!(
                                        "mismatch ({name}, N {resolution}, n {n}): {:?} → {:?}: scalar {:?}, simd {:?}",
                                        starts[k], ends[k], scalar[k], simd[k]
                                    );
                                }
                                set_mismatches += 1;
                            }
                        }
                    }
                }
                mismatches += set_mismatches;
            }
        }
    }
    println!("SIMD vs scalar extents: {compared} compared ({some} with an extent), {mismatches} mismatches");
    assert!(some > compared / 10 && some < compared);
    assert_eq!(mismatches, 0);
}
