//! glimpse-gpu: the GPU compute backend (wgpu 30 + WGSL compute, headless Vulkan).
//!
//! Everything lives behind the `gpu` feature; without it this crate is empty, so the default
//! workspace build never compiles wgpu.
//!
//! - [`context`]: [`GpuContext`], the adapter and device, with clear errors instead of panics.
//! - [`compute`]: the small helper API technique crates build their kernels on: storage
//!   buffers from `bytemuck` slices, WGSL modules, compute pipelines, dispatch, read-back.
//! - [`timer`]: [`GpuTimer`], named kernel times from timestamp queries.
//! - [`layout`]: the plain-data structs shared with the WGSL code (nodes, triangles, rays, hits).
//! - [`scene`]: [`GpuScene`], world-space triangles and the 4-wide BVH in GPU buffers.
//! - [`tracer`]: [`GpuTracer`], any-hit and closest-hit for ray batches, with the CPU's
//!   watertight triangle test (`trace.wgsl`).
//! - [`ao`]: `ao-exact` on the GPU: the CPU technique's rays, traced by [`GpuTracer`].
//! - [`replay`]: a CPU pixel shader written against `&dyn Visibility`, its rays recorded,
//!   traced on the GPU in batches and the answers replayed.
//! - [`references`]: `ao-exact`, `lights-exact`, `env-exact` as glimpse-render `Technique`s on
//!   the GPU (`--device gpu`).
//!
//! lavapipe (Mesa's CPU Vulkan driver) runs all of it in CI; its timings mean nothing, which
//! [`GpuContext::software_note`] says for callers to print.

#[cfg(feature = "gpu")]
pub mod ao;
#[cfg(feature = "gpu")]
pub mod compute;
#[cfg(feature = "gpu")]
pub mod context;
#[cfg(feature = "gpu")]
pub mod error;
#[cfg(feature = "gpu")]
pub mod layout;
#[cfg(feature = "gpu")]
pub mod references;
#[cfg(feature = "gpu")]
pub mod replay;
#[cfg(feature = "gpu")]
pub mod scene;
#[cfg(feature = "gpu")]
pub mod timer;
#[cfg(feature = "gpu")]
pub mod tracer;

#[cfg(feature = "gpu")]
pub use wgpu;
#[cfg(feature = "gpu")]
pub use {
    context::GpuContext,
    error::GpuError,
    scene::GpuScene,
    timer::{GpuTimer, KernelTime},
    tracer::{GpuHit, GpuTracer},
};
