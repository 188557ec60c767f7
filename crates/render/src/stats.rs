//! Timings and memory that `prepare` and `render` report, stage by stage.

use std::time::Instant;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// (stage name, milliseconds), in the order the stages ran.
    pub stages: Vec<(String, f64)>,
    /// Bytes held by the technique's data structures after the call.
    pub memory_bytes: usize,
    /// Rays traced (any kind), for rays-per-second summaries.
    pub rays: u64,
    /// Error measures the technique took of its own decisions against the exact tracer, outside
    /// the timed stages (e.g. `eps_v`, `eps_s` of `lights-voxarray`'s shadow decisions, in %);
    /// `glimpse eval` adds them to the run's metrics.
    pub metrics: Vec<(String, f64)>,
}

impl Stats {
    pub fn total_ms(&self) -> f64 {
        self.stages.iter().fold(0.0, |acc, s| acc + s.1)
    }

    pub fn stage(&mut self, name: &str, ms: f64) {
        self.stages.push((name.to_owned(), ms));
    }

    /// Runs `f`, recording its wall time as stage `name`.
    pub fn time<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        let sw = Stopwatch::start();
        let out = f();
        self.stage(name, sw.ms());
        out
    }

    pub fn merge(&mut self, other: Stats) {
        self.stages.extend(other.stages);
        self.memory_bytes = self.memory_bytes.max(other.memory_bytes);
        self.rays += other.rays;
        self.metrics.extend(other.metrics);
    }
}

pub struct Stopwatch(Instant);

impl Stopwatch {
    pub fn start() -> Self {
        Self(Instant::now())
    }

    pub fn ms(&self) -> f64 {
        self.0.elapsed().as_secs_f64() * 1e3
    }
}
