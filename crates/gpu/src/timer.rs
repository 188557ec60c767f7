//! [`GpuTimer`]: named GPU times from timestamp queries.
//!
//! Each timed span (a compute pass, or a stretch of an encoder such as an upload's copies) takes
//! two query slots; spans with the same name add up (a kernel dispatched in chunks is one
//! entry). [`GpuTimer::finish`] resolves the queries and returns the times in milliseconds.
//! Without `TIMESTAMP_QUERY` the timer records nothing and returns an empty list, so callers
//! never branch on the feature. On a software adapter the numbers are CPU times of the driver
//! and mean nothing (see [`crate::GpuContext::software_note`]).

use crate::{GpuContext, GpuError};
use wgpu::{CommandEncoder, ComputePassTimestampWrites, QuerySet};

/// The GPU time of one named kernel or copy, summed over its spans.
#[derive(Clone, Debug, PartialEq)]
pub struct KernelTime {
    pub name: String,
    pub ms: f64,
    /// Spans that added up to `ms` (chunks of one kernel, say).
    pub spans: u32,
}

pub struct GpuTimer {
    queries: Option<QuerySet>,
    /// Whether `write_timestamp` works on encoders (needed by [`GpuTimer::begin`]).
    inside_encoders: bool,
    capacity: u32,
    /// The name of each span, in query order (span k uses queries 2k and 2k+1).
    names: Vec<String>,
}

impl GpuTimer {
    /// Room for `spans` timed spans.
    pub fn new(ctx: &GpuContext, spans: u32) -> Self {
        let capacity = spans.clamp(1, wgpu::QUERY_SET_MAX_QUERIES / 2);
        let queries = ctx.has_timestamps().then(|| {
            ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("glimpse-gpu timer"),
                ty: wgpu::QueryType::Timestamp,
                count: 2 * capacity,
            })
        });
        let inside_encoders = ctx.features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS);
        Self { queries, inside_encoders, capacity, names: Vec::new() }
    }

    /// Whether spans are being timed at all.
    pub fn enabled(&self) -> bool {
        self.queries.is_some()
    }

    fn next_span(&mut self, name: &str) -> Option<u32> {
        let k = self.names.len() as u32;
        (self.queries.is_some() && k < self.capacity).then(|| {
            self.names.push(name.to_owned());
            k
        })
    }

    /// Timestamp writes for a compute pass named `name` (None when not timing, or full).
    pub fn pass(&mut self, name: &str) -> Option<ComputePassTimestampWrites<'_>> {
        let k = self.next_span(name)?;
        Some(ComputePassTimestampWrites {
            query_set: self.queries.as_ref()?,
            beginning_of_pass_write_index: Some(2 * k),
            end_of_pass_write_index: Some(2 * k + 1),
        })
    }

    /// Starts a span of encoder commands (copies); returns its handle for [`GpuTimer::end`].
    /// Needs `TIMESTAMP_QUERY_INSIDE_ENCODERS`; otherwise nothing is timed.
    pub fn begin(&mut self, encoder: &mut CommandEncoder, name: &str) -> Option<u32> {
        if !self.inside_encoders {
            return None;
        }
        let k = self.next_span(name)?;
        encoder.write_timestamp(self.queries.as_ref()?, 2 * k);
        Some(k)
    }

    /// Ends a span started by [`GpuTimer::begin`].
    pub fn end(&self, encoder: &mut CommandEncoder, span: Option<u32>) {
        if let (Some(k), Some(q)) = (span, &self.queries) {
            encoder.write_timestamp(q, 2 * k + 1);
        }
    }

    /// Resolves every span recorded so far (their commands must have been submitted) and
    /// returns the times per name, in the order the names first appeared; then starts afresh.
    pub fn finish(&mut self, ctx: &GpuContext) -> Result<Vec<KernelTime>, GpuError> {
        let names = std::mem::take(&mut self.names);
        let Some(queries) = &self.queries else { return Ok(Vec::new()) };
        if names.is_empty() {
            return Ok(Vec::new());
        }
        let count = 2 * names.len() as u32;
        let bytes = count as u64 * 8;
        let resolve = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timer resolve"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.resolve_query_set(queries, 0..count, &resolve, 0);
        ctx.queue.submit([encoder.finish()]);
        let ticks: Vec<u64> = crate::compute::read_back(ctx, &resolve, count as usize)?;
        let ns_per_tick = ctx.queue.get_timestamp_period() as f64;
        let mut times: Vec<KernelTime> = Vec::new();
        for (k, name) in names.iter().enumerate() {
            // Timestamps may wrap or come back out of order on some drivers: count such a span as 0.
            let ms = ticks[2 * k + 1].saturating_sub(ticks[2 * k]) as f64 * ns_per_tick * 1e-6;
            match times.iter_mut().find(|t| &t.name == name) {
                Some(t) => {
                    t.ms += ms;
                    t.spans += 1;
                }
                None => times.push(KernelTime { name: name.clone(), ms, spans: 1 }),
            }
        }
        Ok(times)
    }
}

/// `times` as one line: `upload 0.12 ms, any-hit 3.40 ms`.
pub fn format_times(times: &[KernelTime]) -> String {
    times.iter().map(|t| format!("{} {:.3} ms", t.name, t.ms)).collect::<Vec<_>>().join(", ")
}

/// How long [`warm_up`] keeps the GPU busy before a measurement.
pub const WARM_UP: std::time::Duration = std::time::Duration::from_millis(250);

/// Runs `batch` untimed, once and then again until [`WARM_UP`] has passed: a GPU left idle for a
/// few seconds (while the CPU built a structure) lowers its clocks, and one short batch does not
/// raise them again. On an H200 the voxel array's 1M-segment kernel timed 0.35 ms after a 5 s
/// CPU build and 0.075 ms after a 1 s load of the same array, each after one warm-up batch.
pub fn warm_up<E>(mut batch: impl FnMut() -> Result<(), E>) -> Result<(), E> {
    let start = std::time::Instant::now();
    batch()?;
    while start.elapsed() < WARM_UP {
        batch()?;
    }
    Ok(())
}
