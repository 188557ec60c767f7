//! glimpse-eval: experiments. Runs techniques beside their exact references on the same scene,
//! GBuffer and seed; times `prepare` and `render`; computes metrics; writes `results.json` and a
//! self-contained `report.html`. Also the ray benchmark (`bench rays`) and animations (`play`).

pub mod bench;
pub mod cache;
pub mod experiment;
pub mod play;
pub mod plot;
pub mod progress;
pub mod report;
pub mod suite;

use glimpse_render::Registry;

/// Every technique glimpse knows, from every technique crate.
pub fn registry() -> Registry {
    let mut all = glimpse_render::techniques();
    all.extend(glimpse_roma::techniques());
    all.extend(glimpse_baselines::techniques());
    all.extend(glimpse_voxarray::techniques());
    all.extend(glimpse_dvf::techniques());
    all.extend(glimpse_lightcuts::techniques());
    all.extend(glimpse_wavecache::techniques());
    Registry::new(all)
}

/// Peak resident memory of this process in bytes (Linux `VmHWM`), if known.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
