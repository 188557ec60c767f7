//! The `lights-voxarray` [`Structure`] on the GPU, one [`GpuVoxArray`] per array it holds:
//! - a static scene's array, uploaded once;
//! - rigid instances (Alg. 5): the static array and each moving type's array, uploaded once; per
//!   frame only the instances' world-to-local transforms change. They stay on the CPU: a segment
//!   is moved into each instance's frame there by the CPU's own `transform_point3`, so the kernel
//!   tests the very segments `Instanced::occluded_segment` does;
//! - deforming meshes (Alg. 6): the array the CPU rebuilt for this frame, re-uploaded
//!   ([`GpuVoxArray::reload`], the compiled kernel kept).
//!
//! A segment is occluded when any array's answer says so. Each answer is the CPU's (the kernel
//! is bit-exact, `tests/gpu.rs`), so the decisions are the CPU structure's.

use super::GpuVoxArray;
use super::GpuVoxArrayError;
use crate::VoxArray;
use crate::dynamic::Instanced;
use crate::technique::Structure;
use glimpse_core::{Mat4, Vec3};
use glimpse_gpu::{GpuContext, KernelTime};
use rayon::prelude::*;

/// A [`Structure`]'s arrays in GPU buffers.
pub enum GpuStructure {
    /// A static scene's array, or a deforming scene's array of the current frame.
    Array(GpuVoxArray),
    Instanced(GpuInstanced),
}

/// Alg. 5's arrays on the GPU and the moving instances' current transforms.
pub struct GpuInstanced {
    static_part: Option<GpuVoxArray>,
    /// Per mesh index: the type's array, for meshes with a moving instance.
    types: Vec<Option<GpuVoxArray>>,
    /// (type = mesh index, world-to-local transform) of every moving instance: the CPU's.
    instances: Vec<(u32, Mat4)>,
    last_times: Vec<KernelTime>,
}

impl GpuStructure {
    /// Uploads every array of `s`.
    pub fn new(ctx: &GpuContext, s: &Structure) -> Result<Self, GpuVoxArrayError> {
        Ok(match s {
            Structure::Static(a) | Structure::Deforming(a) => Self::Array(GpuVoxArray::new(ctx, a)?),
            Structure::Instanced(i) => Self::Instanced(GpuInstanced::new(ctx, i)?),
        })
    }

    /// Brings the GPU copy to `s`, the CPU structure after this frame's `prepare`: a deforming
    /// scene's rebuilt array is re-uploaded, the instances' transforms copied; a static array is
    /// built once and never changes, so it stays.
    pub fn sync(&mut self, ctx: &GpuContext, s: &Structure) -> Result<(), GpuVoxArrayError> {
        match (&mut *self, s) {
            (Self::Array(_), Structure::Static(_)) => {}
            (Self::Array(g), Structure::Deforming(a)) => g.reload(ctx, a)?,
            (Self::Instanced(g), Structure::Instanced(i)) => g.instances.clone_from(&i.instances),
            // Another kind of structure than the one uploaded: upload it whole.
            (this, s) => *this = Self::new(ctx, s)?,
        }
        Ok(())
    }

    /// `out[k]` = the CPU structure's decision on `segments[k]` (world-space segments, as
    /// [`Structure::surface_segment`] forms them); kernel times in [`Self::take_times`].
    pub fn occluded_segments(&mut self, ctx: &GpuContext, segments: &[(Vec3, Vec3)]) -> Result<Vec<bool>, GpuVoxArrayError> {
        match self {
            Self::Array(g) => g.occluded_segments(ctx, segments),
            Self::Instanced(g) => g.occluded_segments(ctx, segments),
        }
    }

    /// The kernel times of the last query, taken.
    pub fn take_times(&mut self) -> Vec<KernelTime> {
        std::mem::take(match self {
            Self::Array(g) => &mut g.last_times,
            Self::Instanced(g) => &mut g.last_times,
        })
    }
}

impl GpuInstanced {
    /// Uploads the static array and the type arrays of `cpu`.
    pub fn new(ctx: &GpuContext, cpu: &Instanced) -> Result<Self, GpuVoxArrayError> {
        let upload = |a: &Option<VoxArray>| a.as_ref().map(|a| GpuVoxArray::new(ctx, a)).transpose();
        Ok(Self {
            static_part: upload(&cpu.static_part)?,
            types: cpu.types.iter().map(upload).collect::<Result<_, _>>()?,
            instances: cpu.instances.clone(),
            last_times: Vec::new(),
        })
    }

    /// `Instanced::occluded_segment` on every segment: the static array's answers, then per type
    /// one batch of the segments no array answered yet, moved into each of its instances' frames.
    pub fn occluded_segments(&mut self, ctx: &GpuContext, segments: &[(Vec3, Vec3)]) -> Result<Vec<bool>, GpuVoxArrayError> {
        self.last_times.clear();
        let mut occluded = match &mut self.static_part {
            Some(g) => {
                let o = g.occluded_segments(ctx, segments)?;
                self.last_times.append(&mut g.last_times);
                o
            }
            None => vec![false; segments.len()],
        };
        for (ty, array) in self.types.iter_mut().enumerate() {
            let Some(array) = array else { continue };
            let pending: Vec<usize> = (0..segments.len()).filter(|&k| !occluded[k]).collect();
            let (mut which, mut local) = (Vec::new(), Vec::new());
            for (_, inv) in self.instances.iter().filter(|(t, _)| *t as usize == ty) {
                which.extend_from_slice(&pending);
                local.par_extend(pending.par_iter().map(|&k| {
                    let (start, end) = segments[k];
                    (inv.transform_point3(start), inv.transform_point3(end))
                }));
            }
            if local.is_empty() {
                continue;
            }
            let answers = array.occluded_segments(ctx, &local)?;
            self.last_times.append(&mut array.last_times);
            for (k, o) in which.into_iter().zip(answers) {
                occluded[k] |= o;
            }
        }
        Ok(occluded)
    }
}
