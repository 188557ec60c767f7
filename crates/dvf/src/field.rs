//! CS4 of the paper (§3.2.2, Figs. 9–11, Algorithm 2 lines 1–26 fused): per task (a run of one
//! triangle's point samples), place each sample (Eq. 2), trace its N_r rotated cosine-weighted
//! Hammersley rays with the exact tracer, and OR the outcome into the sample's cell: a ray that
//! hits sets its octahedral pixel in the occlusion map, one that escapes sets it in the visibility
//! map (erratum E1: the printed Algorithm 2 swaps them; E8: misses must be recorded too).
//!
//! Choices: the sample normal is the triangle's winding normal (CS1), rays leave through
//! `Ray::spawn` off it as the runtime's do; each sample's rotation is drawn from the PCG stream
//! of its global id (see [`crate::points`]) and the frame, so the field is deterministic. With
//! `atomics=sample` (default) a sample's rays are first OR-ed into a local map and the map is
//! OR-ed into the cell with one atomic per non-zero word; `atomics=ray` issues one atomic OR per
//! ray as the paper's shader does. OR is associative and commutative, so both give the same bits
//! in any order (tests check it). No dilation (the GPU paper does not mention Algorithm 2's).
//! `sides=both` (not the paper) also traces each sample's back hemisphere into the same cell,
//! for meshes whose winding does not face the viewer.

use crate::areas::WorldMesh;
use crate::grid::{Grid, MAX_WORDS, Masks, octahedral_pixel};
use crate::points::{PointSampling, Task, point_and_error_scale, sample_uv};
use crate::rays::RaySet;
use glimpse_core::{Ray, Rng, Vec3};
use glimpse_trace::Visibility;
use rayon::prelude::*;

/// One point sample s = (p, n) and the rotation of its rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointSample {
    pub position: Vec3,
    /// The ray offset's scale ([`glimpse_core::ray::error_scale`]).
    pub error_scale: f32,
    pub normal: Vec3,
    pub rays: RaySetKey,
}

/// What fixes a sample's ray set: its random offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RaySetKey {
    pub shift: glimpse_core::Vec2,
}

/// How the build writes the masks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Atomics {
    /// One atomic OR per non-zero word of each sample's local map.
    PerSample,
    /// One atomic OR per ray (the paper's shader).
    PerRay,
}

/// What CS4 needs besides the geometry.
#[derive(Clone, Copy, Debug)]
pub struct SampleSettings {
    pub sampling: PointSampling,
    pub rays: u32,
    pub rotate_about_normal: bool,
    pub seed: u64,
    pub frame_index: u32,
}

/// Sample `i` of task `t`'s triangle (needs the triangle's normal and first global id).
pub fn point_sample(mesh: &WorldMesh, normal: Vec3, first_id: u64, t: &Task, i: u32, s: &SampleSettings) -> PointSample {
    let k = t.triangle as usize;
    let uv = sample_uv(s.sampling, mesh.indices[k], i, t.of);
    let (position, error_scale) = point_and_error_scale(mesh.triangle(k), uv);
    let mut rng = Rng::new(s.seed ^ 0xd1f_5eed, glimpse_core::sampling::mix64(first_id + i as u64) ^ s.frame_index as u64);
    PointSample { position, error_scale, normal, rays: RaySetKey { shift: rng.next_2d() } }
}

/// Traces one sample's rays into local maps; returns the number of rays traced. The ray set is
/// formed as a block ([`crate::raybatch::form`]: the same directions and pixels as
/// [`RaySet::direction`] and [`octahedral_pixel`], 8 at a time) and the rays above the horizon
/// go to the tracer as one batch; the bits set are [`trace_sample_per_ray`]'s (unit test).
pub fn trace_sample(
    vis: &dyn Visibility,
    p: &PointSample,
    s: &SampleSettings,
    resolution: u32,
    visible: &mut [u64],
    occluded: &mut [u64],
) -> u64 {
    use crate::raybatch::{self, Block, MAX_RAYS};
    let set = RaySet::new(p.normal, s.rays, p.rays.shift, s.rotate_about_normal);
    if set.count as usize > MAX_RAYS {
        return trace_sample_per_ray(vis, p, s, resolution, visible, occluded);
    }
    let mut block = Block::default();
    raybatch::form(&set, p.normal, p.normal, resolution, raybatch::default_former(), &mut block);
    let mut rays: Vec<(Ray, f32)> = Vec::with_capacity(set.count as usize);
    let mut pixels: Vec<u32> = Vec::with_capacity(set.count as usize);
    for (w, &bits) in block.used.iter().enumerate() {
        let mut b = bits;
        while b != 0 {
            let k = w * 64 + b.trailing_zeros() as usize;
            b &= b - 1;
            rays.push((Ray::spawn(p.position, p.normal, p.error_scale, block.direction(k)), f32::INFINITY));
            pixels.push(block.pixel[k]);
        }
    }
    let mut hits = vec![false; rays.len()];
    vis.occluded_batch(&rays, &mut hits);
    for (&pixel, &hit) in pixels.iter().zip(&hits) {
        let word = if hit { &mut occluded[pixel as usize / 64] } else { &mut visible[pixel as usize / 64] };
        *word |= 1 << (pixel % 64);
    }
    rays.len() as u64
}

/// [`trace_sample`] one ray at a time (the first version; kept as its reference).
pub fn trace_sample_per_ray(
    vis: &dyn Visibility,
    p: &PointSample,
    s: &SampleSettings,
    resolution: u32,
    visible: &mut [u64],
    occluded: &mut [u64],
) -> u64 {
    let set = RaySet::new(p.normal, s.rays, p.rays.shift, s.rotate_about_normal);
    let mut traced = 0;
    for k in 0..s.rays {
        let d = set.direction(k);
        if p.normal.dot(d) <= 0.0 {
            continue;
        }
        traced += 1;
        let hit = vis.occluded(&Ray::spawn(p.position, p.normal, p.error_scale, d), f32::INFINITY);
        let pixel = octahedral_pixel(d, resolution);
        let word = if hit { &mut occluded[pixel as usize / 64] } else { &mut visible[pixel as usize / 64] };
        *word |= 1 << (pixel % 64);
    }
    traced
}

/// CS4 over `tasks` (in parallel, or in the given order when `parallel` is false). Returns the
/// rays traced.
#[allow(clippy::too_many_arguments)]
pub fn build_masks(
    vis: &dyn Visibility,
    mesh: &WorldMesh,
    normals: &[Vec3],
    first_ids: &[u64],
    tasks: &[Task],
    grid: &Grid,
    masks: &Masks,
    s: &SampleSettings,
    atomics: Atomics,
    parallel: bool,
) -> u64 {
    let words = masks.words_per_mask;
    let r = masks.resolution;
    let run = |t: &Task| -> u64 {
        let k = t.triangle as usize;
        let mut rays = 0;
        for i in t.first..t.first + t.count {
            let p = point_sample(mesh, normals[k], first_ids[k], t, i, s);
            let cell = grid.cell_of(p.position);
            let (mut v, mut o) = ([0u64; MAX_WORDS], [0u64; MAX_WORDS]);
            rays += trace_sample(vis, &p, s, r, &mut v[..words], &mut o[..words]);
            if mesh.back[k] {
                let back = PointSample { normal: -p.normal, ..p };
                rays += trace_sample(vis, &back, s, r, &mut v[..words], &mut o[..words]);
            }
            match atomics {
                Atomics::PerSample => masks.or_words(cell, &v[..words], &o[..words]),
                Atomics::PerRay => {
                    for (w, (&vw, &ow)) in v[..words].iter().zip(&o[..words]).enumerate() {
                        for (bits, hit) in [(vw, false), (ow, true)] {
                            let mut b = bits;
                            while b != 0 {
                                masks.or_pixel(cell, (w * 64) as u32 + b.trailing_zeros(), hit);
                                b &= b - 1;
                            }
                        }
                    }
                }
            }
        }
        rays
    };
    if parallel { tasks.par_iter().map(run).sum() } else { tasks.iter().map(run).sum() }
}
