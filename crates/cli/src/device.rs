//! `--device cpu|gpu` of `render`, `eval` and `play`: the registry their techniques come from.
//!
//! On `gpu` the registry holds only the techniques that have a GPU implementation
//! ([`GPU_TECHNIQUES`], the one place a GPU port is added), under their usual ids, so the
//! commands run them unchanged; naming any other technique is an error that lists the GPU ones
//! (no silent CPU fallback). One `GpuContext` serves the whole process; its adapter (and the
//! note that a software adapter's timings mean nothing) is printed once on stderr.

use anyhow::Result;
use glimpse_render::Registry;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Device {
    /// The CPU (every technique).
    #[default]
    Cpu,
    /// The GPU (wgpu; techniques with a GPU implementation only; needs `--features gpu`).
    Gpu,
}

/// The ids `--device gpu` runs, for messages and `--help` (the same list as [`GPU_TECHNIQUES`]).
pub const GPU_IDS: &[&str] = &["ao-exact", "lights-exact", "env-exact", "ao-roma", "soft-roma", "gi-roma", "lights-voxarray", "env-dvf"];

/// The registry to create techniques from on `device`, after checking that every id in `named`
/// runs there.
pub fn registry(device: Device, named: &[&str]) -> Result<Registry> {
    match device {
        Device::Cpu => Ok(glimpse_eval::registry()),
        Device::Gpu => {
            for id in named {
                if !GPU_IDS.contains(id) && glimpse_eval::registry().get(id).is_ok() {
                    anyhow::bail!("--device gpu: technique '{id}' has no GPU implementation; on the GPU: {}", GPU_IDS.join(", "));
                }
            }
            gpu_registry()
        }
    }
}

#[cfg(not(feature = "gpu"))]
fn gpu_registry() -> Result<Registry> {
    anyhow::bail!(
        "--device gpu: this glimpse was built without the GPU backend; rebuild with `cargo build --release -p glimpse --features gpu`"
    )
}

#[cfg(feature = "gpu")]
fn gpu_registry() -> Result<Registry> {
    gpu::registry()
}

#[cfg(feature = "gpu")]
mod gpu {
    use anyhow::Result;
    use glimpse_gpu::GpuContext;
    use glimpse_gpu::references::{GpuAoExact, GpuEnvExact, GpuLightsExact};
    use glimpse_render::registry::Constructor;
    use glimpse_render::{Registry, RenderError, TechniqueInfo};
    use std::sync::{Arc, Mutex};

    /// The extension point: every technique `--device gpu` runs, by id, with its constructor
    /// (each takes the process's shared context). A new GPU port adds one line here and its id
    /// to [`super::GPU_IDS`].
    pub const GPU_TECHNIQUES: &[(&str, Constructor)] = &[
        ("ao-exact", |scene, settings, params| Ok(Box::new(GpuAoExact::new(context_for("ao-exact")?, scene, settings, params)?))),
        ("lights-exact", |scene, settings, params| {
            Ok(Box::new(GpuLightsExact::new(context_for("lights-exact")?, scene, settings, params)?))
        }),
        ("env-exact", |scene, settings, params| Ok(Box::new(GpuEnvExact::new(context_for("env-exact")?, scene, settings, params)?))),
        ("ao-roma", |scene, settings, params| {
            Ok(Box::new(glimpse_roma::gpu::technique::GpuAoRoma::new(context_for("ao-roma")?, scene, settings, params)?))
        }),
        ("soft-roma", |scene, settings, params| {
            Ok(Box::new(glimpse_roma::gpu::technique::GpuSoftRoma::new(context_for("soft-roma")?, scene, settings, params)?))
        }),
        ("gi-roma", |scene, settings, params| {
            Ok(Box::new(glimpse_roma::gpu::technique::GpuGiRoma::new(context_for("gi-roma")?, scene, settings, params)?))
        }),
        ("lights-voxarray", |scene, settings, params| {
            Ok(Box::new(glimpse_voxarray::gpu::technique::GpuLightsVoxArray::new(
                context_for("lights-voxarray")?,
                scene,
                settings,
                params,
            )?))
        }),
        ("env-dvf", |_, settings, params| Ok(Box::new(glimpse_dvf::gpu::GpuEnvDvf::new(context_for("env-dvf")?, settings, params)?))),
    ];

    static CONTEXT: Mutex<Option<Arc<GpuContext>>> = Mutex::new(None);

    /// The process's one `GpuContext`, opened on first use (its adapter printed once on stderr).
    pub fn shared_context() -> Result<Arc<GpuContext>, glimpse_gpu::GpuError> {
        let mut slot = CONTEXT.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some(ctx) = slot.as_ref() {
            return Ok(ctx.clone());
        }
        let ctx = Arc::new(GpuContext::new()?);
        eprintln!("device: gpu, adapter {}", ctx.describe());
        if let Some(note) = ctx.software_note() {
            eprintln!("note: {note}");
        }
        *slot = Some(ctx.clone());
        Ok(ctx)
    }

    fn context_for(technique: &str) -> Result<Arc<GpuContext>, RenderError> {
        shared_context().map_err(|e| RenderError::Unsupported { technique: technique.into(), message: format!("--device gpu: {e}") })
    }

    /// The GPU techniques under their CPU entries' ids, families, references and descriptions,
    /// then the CPU entries of the references that have no GPU port (`soft-exact`, `gi-exact`):
    /// `eval` renders a technique's reference from this registry. Naming one of those with `-t`
    /// is still refused ([`super::registry`] checks the names against [`super::GPU_IDS`]).
    pub fn registry() -> Result<Registry> {
        // Open the adapter now: a machine without one fails before any work.
        shared_context().map_err(|e| anyhow::anyhow!("--device gpu: {e}"))?;
        let cpu = glimpse_eval::registry();
        let mut entries = GPU_TECHNIQUES
            .iter()
            .map(|&(id, create)| Ok(TechniqueInfo { create, ..cpu.get(id)?.clone() }))
            .collect::<Result<Vec<_>, RenderError>>()?;
        let cpu_references: Vec<&str> = entries.iter().filter_map(|t| t.reference).filter(|r| !super::GPU_IDS.contains(r)).collect();
        for id in cpu_references {
            if !entries.iter().any(|t| t.id == id) {
                entries.push(cpu.get(id)?.clone());
            }
        }
        Ok(Registry::new(entries))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_only_techniques_are_refused_on_the_gpu() {
        let e = registry(Device::Gpu, &["soft-exact"]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("'soft-exact' has no GPU implementation") && e.contains("ao-exact, lights-exact"), "{e}");
        // Every GPU id is a known technique.
        let cpu = glimpse_eval::registry();
        assert!(GPU_IDS.iter().all(|id| cpu.get(id).is_ok()));
    }

    #[cfg(feature = "gpu")]
    #[test]
    fn the_id_list_is_the_constructor_table() {
        assert_eq!(gpu::GPU_TECHNIQUES.iter().map(|t| t.0).collect::<Vec<_>>(), GPU_IDS);
    }
}
