//! glimpse-render: the [`Technique`] interface and registry, and the exact reference techniques
//! that every approximate technique is compared with.

pub mod ao;
pub mod bsdf;
pub mod context;
pub mod direct;
pub mod env;
pub mod focus;
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

/// The revision of what the references and precomputations compute, part of every disk-cache
/// key that stores their results (reference images, the wavelet cache). The crate version alone
/// never changed, so a cache written by older code was read back after the tracing changed.
/// Bump it with any change that moves a reference's pixels: 2 = ray offsets relative to each
/// point's error scale (session 10); 3 = VPLs' own error scales at their shadow rays' end;
/// 4 = mirrored instances keep their faces' orientation (`glimpse_scene::orient`, session 25);
/// 5 = glTF alpha masks cut out by the exact tracer (session 28); 6 = glTF metallic-roughness
/// textures read per texel by the path tracer, normal textures bending the shading normal and
/// emissive textures emitting per texel (session 29); 7 = Mitsuba's normal maps shadow their
/// bend, glTF's `TANGENT` frames normal textures (session 30).
pub const RESULTS_REVISION: u32 = 7;

/// Where glimpse keeps data that is slow to compute (reference images, precomputations):
/// `$GLIMPSE_CACHE`, else `$XDG_CACHE_HOME/glimpse`, else `~/.cache/glimpse`. `GLIMPSE_CACHE`
/// set but empty turns disk caches off (`None`): an empty path would otherwise mean the current
/// directory. An empty `XDG_CACHE_HOME` is ignored, as the XDG spec says.
pub fn cache_dir() -> Option<std::path::PathBuf> {
    use std::path::PathBuf;
    if let Some(d) = std::env::var_os("GLIMPSE_CACHE") {
        return (!d.is_empty()).then(|| PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d).join("glimpse"));
    }
    std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache/glimpse"))
}

static STRUCTURE_CACHE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(true);

/// Turns the techniques' on-disk caches of their built structures (the wavelet cache, the voxel
/// array) on or off for this process. `glimpse suite` turns them off, so a cell's prepare time is
/// always a build, never a load left by an earlier run.
pub fn set_structure_cache(on: bool) {
    STRUCTURE_CACHE.store(on, std::sync::atomic::Ordering::Relaxed);
}

/// Where a technique may store and load its built structure: [`cache_dir`], unless
/// [`set_structure_cache`] turned such caches off.
pub fn structure_cache_dir() -> Option<std::path::PathBuf> {
    if STRUCTURE_CACHE.load(std::sync::atomic::Ordering::Relaxed) { cache_dir() } else { None }
}

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
