//! Everything that can go wrong on the GPU side, as values: no adapter, limits too small for a
//! scene, a shader that does not compile, a device lost. Callers print them; nothing panics.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found ({0}); install a Vulkan driver (e.g. `apt-get install mesa-vulkan-drivers libvulkan1`) or set WGPU_BACKEND"
    )]
    NoAdapter(String),
    #[error("could not open the GPU device: {0}")]
    Device(String),
    #[error("{what} needs {needed} bytes in one storage binding, but the adapter allows {limit} (max_storage_buffer_binding_size)")]
    BindingTooLarge { what: String, needed: u64, limit: u64 },
    #[error("{what} needs a {needed}-byte buffer, but the adapter allows {limit} (max_buffer_size)")]
    BufferTooLarge { what: String, needed: u64, limit: u64 },
    #[error("the BVH is {depth} levels deep; the GPU traversal stack holds {max} levels")]
    TreeTooDeep { depth: usize, max: usize },
    #[error("the scene has {0} triangles; the GPU layout indexes at most 2^32 − 2")]
    TooManyTriangles(usize),
    #[error("material '{0}' is alpha-masked (glTF MASK), which the GPU tracer does not test; use the CPU techniques")]
    AlphaMask(String),
    #[error("shader '{label}': {message}")]
    Shader { label: String, message: String },
    #[error("GPU validation error: {0}")]
    Validation(String),
    #[error("reading back from the GPU failed: {0}")]
    ReadBack(String),
}
