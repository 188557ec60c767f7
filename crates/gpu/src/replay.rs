//! Record and replay: a CPU pixel shader that asks `&dyn Visibility` runs unchanged with its
//! rays traced on the GPU. Each pixel is shaded twice: once against a [`Visibility`] that only
//! records the queries (and answers "open"), then, after the recorded rays of a block of pixels
//! went through [`GpuTracer::occluded`] as one batch, again against one that replays the GPU's
//! answers in order. The CPU reference's own code (sampling, RNG streams, spawn offsets,
//! shading) therefore makes the rays and the image; only the traversal moves to the GPU.
//!
//! This needs the shader's queries not to depend on earlier answers, true of every reference
//! ported here (`ao-exact`, `lights-exact`, `env-exact`: the rays of a pixel are drawn before
//! any is traced). A shader that breaks it is caught, not papered over: a replay that runs out
//! of answers, or leaves some unused, is an error.

use crate::{GpuContext, GpuError, GpuScene, GpuTracer, KernelTime};
use glimpse_core::{Ray, Vec3};
use glimpse_trace::Visibility;
use rayon::prelude::*;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Rays per GPU batch the pixel blocks aim at (bounds the CPU memory of the recorded rays).
pub const RAYS_PER_BATCH: usize = 1 << 21;

/// Pass 1: every query of one pixel, in order; answers "not occluded".
#[derive(Default)]
struct Record(Mutex<Vec<(Ray, f32)>>);

impl Visibility for Record {
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        if let Ok(mut rays) = self.0.lock() {
            rays.push((*ray, t_max));
        }
        false
    }
}

/// Pass 2: the GPU's answers to one pixel's recorded queries, handed out in order.
struct Replay<'a> {
    answers: &'a [bool],
    next: AtomicUsize,
    overrun: AtomicBool,
}

impl Visibility for Replay<'_> {
    fn occluded(&self, _ray: &Ray, _t_max: f32) -> bool {
        let k = self.next.fetch_add(1, Ordering::Relaxed);
        self.answers.get(k).copied().unwrap_or_else(|| {
            self.overrun.store(true, Ordering::Relaxed);
            false
        })
    }
}

/// What [`shade_pixels`] did: rays traced and the GPU kernel times of its batches.
#[derive(Clone, Debug, Default)]
pub struct Traced {
    pub rays: u64,
    pub kernel_times: Vec<KernelTime>,
}

/// `out[i] = shade(i, vis)` for every pixel, `vis` answering with `tracer` on `scene`. Pixels go
/// in blocks of about [`RAYS_PER_BATCH`] / `rays_per_pixel` (a hint: the block's rays are traced
/// as one batch whatever their number). `shade` must ask the same queries each time it is called
/// for a pixel, whatever the answers.
pub fn shade_pixels<F>(
    ctx: &GpuContext,
    tracer: &mut GpuTracer,
    scene: &GpuScene,
    out: &mut [Vec3],
    rays_per_pixel: usize,
    shade: F,
) -> Result<Traced, GpuError>
where
    F: Fn(usize, &dyn Visibility) -> Vec3 + Sync,
{
    let block = (RAYS_PER_BATCH / rays_per_pixel.max(1)).clamp(1, 1 << 20);
    let mut traced = Traced::default();
    for (b, pixels) in out.chunks_mut(block).enumerate() {
        let first = b * block;
        let recorded: Vec<Vec<(Ray, f32)>> = (0..pixels.len())
            .into_par_iter()
            .map(|k| {
                let record = Record::default();
                shade(first + k, &record);
                record.0.into_inner().unwrap_or_default()
            })
            .collect();
        let mut offsets = Vec::with_capacity(recorded.len() + 1);
        offsets.push(0);
        for r in &recorded {
            offsets.push(offsets.last().copied().unwrap_or(0) + r.len());
        }
        let rays: Vec<(Ray, f32)> = recorded.into_iter().flatten().collect();
        let answers = if rays.is_empty() { Vec::new() } else { tracer.occluded(ctx, scene, &rays)? };
        traced.rays += rays.len() as u64;
        traced.kernel_times.append(&mut tracer.last_times);
        let mismatched = pixels
            .par_iter_mut()
            .enumerate()
            .map(|(k, px)| {
                let replay =
                    Replay { answers: &answers[offsets[k]..offsets[k + 1]], next: AtomicUsize::new(0), overrun: AtomicBool::new(false) };
                *px = shade(first + k, &replay);
                replay.overrun.load(Ordering::Relaxed) || replay.next.load(Ordering::Relaxed) != replay.answers.len()
            })
            .filter(|&m| m)
            .count();
        if mismatched > 0 {
            return Err(GpuError::Validation(format!(
                "{mismatched} pixels asked different rays when replayed: the shader's queries depend on its answers, so it cannot run on the GPU this way"
            )));
        }
    }
    Ok(traced)
}
