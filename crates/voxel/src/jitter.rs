//! Per-frame sub-cell jitter of voxel grids (ROMA §4.1: the BOM is jittered every frame so that
//! accumulated frames see different voxelizations).

use glimpse_core::{Rng, Vec3};

/// Halton radical inverse of `i` in `base`.
fn radical_inverse(mut i: u32, base: u32) -> f32 {
    let (mut inv, mut f) = (0.0f64, 1.0f64 / base as f64);
    while i > 0 {
        inv += (i % base) as f64 * f;
        i /= base;
        f /= base as f64;
    }
    inv as f32
}

/// The sub-cell jitter of frame `frame_index` (cells, each component in [−0.5, 0.5)): the
/// Halton (2, 3, 5) point of index `frame_index + 1`, Cranley–Patterson rotated by the seed.
pub fn frame_jitter(seed: u64, frame_index: u32) -> Vec3 {
    let mut rng = Rng::new(seed, 0x6a17);
    let shift = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let h = Vec3::new(radical_inverse(frame_index + 1, 2), radical_inverse(frame_index + 1, 3), radical_inverse(frame_index + 1, 5));
    let v = h + shift;
    v - v.floor() - Vec3::splat(0.5)
}
