//! [`GpuContext`]: a headless wgpu adapter, device and queue.
//!
//! The adapter comes from `InstanceDescriptor::new_without_display_handle_from_env()`, so
//! `WGPU_BACKEND` (and wgpu's other variables) choose the backend; with none set, the default
//! backends are asked for a high-performance adapter. The device gets the adapter's own limits
//! (not wgpu's conservative defaults), so a large GPU can hold a large scene, and timestamp
//! queries whenever the adapter offers them. Validation errors that wgpu would otherwise raise
//! as panics are collected and returned by [`GpuContext::check`].

use crate::GpuError;
use std::sync::{Arc, Mutex};
use wgpu::{Adapter, AdapterInfo, Device, Features, Limits, Queue};

pub struct GpuContext {
    pub adapter: Adapter,
    pub device: Device,
    pub queue: Queue,
    pub info: AdapterInfo,
    /// The device's limits (the adapter's, or lowered by [`GpuContext::with_limits`]).
    pub limits: Limits,
    /// The device's features: `TIMESTAMP_QUERY` (and the `INSIDE_*` variants) and
    /// `SHADER_F64` when offered.
    pub features: Features,
    /// Validation errors raised outside an error scope, kept until [`GpuContext::check`].
    errors: Arc<Mutex<Vec<String>>>,
}

impl GpuContext {
    /// The default adapter with its full limits.
    pub fn new() -> Result<Self, GpuError> {
        Self::with_limits(|_| {})
    }

    /// The default adapter, with `adjust` applied to its limits before the device is opened
    /// (tests lower `max_storage_buffer_binding_size` to reach the error paths).
    pub fn with_limits(adjust: impl FnOnce(&mut Limits)) -> Result<Self, GpuError> {
        pollster::block_on(Self::open(adjust))
    }

    async fn open(adjust: impl FnOnce(&mut Limits)) -> Result<Self, GpuError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let options = wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::from_env().unwrap_or(wgpu::PowerPreference::HighPerformance),
            ..Default::default()
        };
        let adapter = instance.request_adapter(&options).await.map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        // Timestamps for timing; f64 so the watertight test's exact fallback matches the CPU's.
        let wanted = Features::TIMESTAMP_QUERY
            | Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
            | Features::TIMESTAMP_QUERY_INSIDE_PASSES
            | Features::SHADER_F64;
        let features = adapter.features() & wanted;
        let mut limits = adapter.limits();
        adjust(&mut limits);
        let desc = wgpu::DeviceDescriptor {
            label: Some("glimpse-gpu"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        };
        let (device, queue) = adapter.request_device(&desc).await.map_err(|e| GpuError::Device(e.to_string()))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut list) = sink.lock() {
                list.push(e.to_string());
            }
        }));
        let info = adapter.get_info();
        Ok(Self { limits: device.limits(), features: device.features(), adapter, device, queue, info, errors })
    }

    /// For tests: the context, or `None` after printing why `test` is skipped (no Vulkan driver
    /// on this machine; CI installs lavapipe, so there the tests run).
    pub fn for_test(test: &str) -> Option<GpuContext> {
        match GpuContext::new() {
            Ok(ctx) => {
                println!("{test}: adapter {}", ctx.describe());
                Some(ctx)
            }
            Err(e) => {
                println!("SKIPPED {test}: {e}");
                None
            }
        }
    }

    /// One line naming the adapter: name, type, backend, driver.
    pub fn describe(&self) -> String {
        let i = &self.info;
        format!("{} ({:?}, {:?}, driver {} {})", i.name, i.device_type, i.backend, i.driver, i.driver_info)
    }

    /// A CPU implementation of the API (lavapipe, llvmpipe, SwiftShader, WARP), whose timings
    /// say nothing about a GPU.
    pub fn is_software(&self) -> bool {
        let name = self.info.name.to_ascii_lowercase();
        self.info.device_type == wgpu::DeviceType::Cpu || ["llvmpipe", "lavapipe", "swiftshader"].iter().any(|s| name.contains(s))
    }

    /// The line callers print next to any timing: `Some` on a software adapter.
    pub fn software_note(&self) -> Option<&'static str> {
        self.is_software().then_some("software adapter (lavapipe): timings not meaningful")
    }

    /// Whether compute passes can carry timestamp writes.
    pub fn has_timestamps(&self) -> bool {
        self.features.contains(Features::TIMESTAMP_QUERY)
    }

    /// Errors if `bytes` cannot be one storage binding (or one buffer) on this device. Called
    /// before creating a buffer, because wgpu reports an oversized buffer as a validation error
    /// (a panic by default), not as a value.
    pub fn check_storage_size(&self, what: &str, bytes: u64) -> Result<(), GpuError> {
        let binding = self.limits.max_storage_buffer_binding_size;
        if bytes > binding {
            return Err(GpuError::BindingTooLarge { what: what.to_owned(), needed: bytes, limit: binding });
        }
        if bytes > self.limits.max_buffer_size {
            return Err(GpuError::BufferTooLarge { what: what.to_owned(), needed: bytes, limit: self.limits.max_buffer_size });
        }
        Ok(())
    }

    /// Waits until the queue is idle.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Device(e.to_string()))?;
        self.check()
    }

    /// The validation errors raised since the last call, as one error.
    pub fn check(&self) -> Result<(), GpuError> {
        let mut list = self.errors.lock().map_err(|_| GpuError::Validation("error list poisoned".into()))?;
        if list.is_empty() {
            return Ok(());
        }
        let message = list.join("; ");
        list.clear();
        Err(GpuError::Validation(message))
    }
}
