//! glimpse-render: the [`Technique`] interface and registry, and the exact reference techniques
//! that every approximate technique is compared with.

pub mod ao;
pub mod bsdf;
pub mod context;
pub mod direct;
pub mod env;
pub mod gi;
pub mod lights;
pub mod metrics;
pub mod params;
pub mod progress;
pub mod pt;
pub mod registry;
pub mod rsm;
pub mod soft;
pub mod stats;
pub mod technique;

pub use context::FrameContext;
pub use params::{ParamError, Params};
pub use progress::Progress;
pub use registry::{Registry, TechniqueInfo};
pub use stats::{Stats, Stopwatch};
pub use technique::{Need, RenderError, Settings, Technique, require};

/// The techniques this crate provides, for the registry.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![
        ao::AoExact::info(),
        soft::SoftExact::info(),
        lights::LightsExact::info(),
        env::EnvExact::info(),
        gi::GiExact::info(),
        pt::PathTracer::info(),
    ]
}
