//! `--aov albedo,normal,depth,position`: arbitrary output variables from the frame's GBuffer,
//! written as extra channel groups of the EXR output (`albedo.R/G/B`, `normal.X/Y/Z`,
//! `position.X/Y/Z`, `depth.Z`) for denoisers and users' own tools.
//!
//! Values are those of the first pass's primary samples (pixel centres with the default box
//! filter's first sample): albedo is base colour × texture, normal the shading normal in world
//! space, position the world-space hit point, depth the distance along the primary ray. A pixel
//! whose ray misses the scene has 0 in albedo, normal and position and +∞ in depth.

use glimpse_core::suggest::did_you_mean;
use glimpse_trace::GBuffer;
use glimpse_trace::gbuffer::NO_HIT;

/// Every AOV `--aov` accepts.
pub const AOVS: [&str; 4] = ["albedo", "normal", "depth", "position"];

/// The AOVs `--aov` named, in order (a newtype: clap would read a bare `Vec` as repeated values).
#[derive(Clone, Debug)]
pub struct AovList(pub Vec<String>);

/// `--aov`'s comma-separated list (no repeats).
pub fn parse_aovs(s: &str) -> Result<AovList, String> {
    let mut out: Vec<String> = Vec::new();
    for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        if !AOVS.contains(&name) {
            return Err(format!("unknown AOV '{name}'{}; have: {}", did_you_mean(name, AOVS), AOVS.join(", ")));
        }
        if !out.iter().any(|o| o == name) {
            out.push(name.to_owned());
        }
    }
    if out.is_empty() {
        return Err(format!("name at least one AOV: {}", AOVS.join(", ")));
    }
    Ok(AovList(out))
}

/// The channels of `aovs` from `g`, named `group.channel`.
pub fn channels(g: &GBuffer, aovs: &[String]) -> Vec<(String, Vec<f32>)> {
    let hit = |i: usize| g.instance[i] != NO_HIT;
    let n = g.instance.len();
    let vector = |group: &str, names: [&str; 3], v: &[glimpse_core::Vec3]| -> Vec<(String, Vec<f32>)> {
        (0..3).map(|k| (format!("{group}.{}", names[k]), (0..n).map(|i| if hit(i) { v[i][k] } else { 0.0 }).collect())).collect()
    };
    let mut out = Vec::new();
    for aov in aovs {
        match aov.as_str() {
            "albedo" => out.extend(vector("albedo", ["R", "G", "B"], &g.albedo)),
            "normal" => out.extend(vector("normal", ["X", "Y", "Z"], &g.shading_normal)),
            "position" => out.extend(vector("position", ["X", "Y", "Z"], &g.position)),
            _ => out.push(("depth.Z".to_owned(), (0..n).map(|i| if hit(i) { g.depth[i] } else { f32::INFINITY }).collect())),
        }
    }
    out
}
