//! Argument parsers shared by the subcommands, with the ranges that keep renders sane.

use anyhow::{Context, Result, bail};
use std::path::Path;

/// Largest accepted image side; beyond it a typo is likelier than intent.
pub const MAX_SIDE: u32 = 16_384;
pub const MAX_SPP: u32 = 1 << 16;

/// `WxH`, each side in 1..=MAX_SIDE.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT (e.g. 512x512)"))?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|_| format!("'{s}' is not WIDTHxHEIGHT (e.g. 512x512)"));
    let (w, h) = (parse(w)?, parse(h)?);
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!("size {w}x{h}: each side must be between 1 and {MAX_SIDE}"));
    }
    Ok((w, h))
}

pub fn parse_spp(s: &str) -> Result<u32, String> {
    let v: u32 = s.parse().map_err(|_| format!("'{s}' is not a positive integer"))?;
    if v == 0 || v > MAX_SPP {
        return Err(format!("{v} samples per pixel: must be between 1 and {MAX_SPP}"));
    }
    Ok(v)
}

pub fn parse_time(s: &str) -> Result<f32, String> {
    let v: f32 = s.parse().map_err(|_| format!("'{s}' is not a number of seconds"))?;
    if !v.is_finite() {
        return Err(format!("time {s} must be finite"));
    }
    Ok(v)
}

/// Checks an output image path before any work: known extension, creatable directory.
pub fn check_output(path: &Path) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("png" | "exr" | "hdr")) {
        bail!("{}: the output must end in .png, .exr or .hdr", path.display());
    }
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create the output directory", dir.display()))?;
    check_writable(dir)
}

/// Fails now, before any work, if files cannot be created in `dir` (a probe file is written and
/// removed).
pub fn check_writable(dir: &Path) -> Result<()> {
    let probe = dir.join(format!(".glimpse-write-probe-{}", std::process::id()));
    std::fs::write(&probe, b"").with_context(|| format!("{}: the output directory is not writable", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

pub use glimpse_core::suggest::did_you_mean;

/// Rejects an unknown technique id with the closest known one.
pub fn check_technique(id: &str) -> Result<()> {
    let registry = glimpse_eval::registry();
    if let Err(e) = registry.get(id) {
        bail!("{e}{}", did_you_mean(id, registry.all().iter().map(|t| t.id)));
    }
    Ok(())
}

/// Rejects a scene that is neither a built-in name nor a path with a file extension, suggesting
/// the closest built-in.
pub fn check_scene(spec: &str) -> Result<()> {
    let has_ext = Path::new(spec).extension().is_some();
    if !has_ext && !glimpse_scene::builtin::NAMES.contains(&spec) {
        bail!(
            "unknown scene '{spec}'{}; built-in scenes: {} (or give a .gltf, .glb, .obj or .toml file)",
            did_you_mean(spec, glimpse_scene::builtin::NAMES.iter().copied()),
            glimpse_scene::builtin::NAMES.join(", ")
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::suggest::edit_distance;

    #[test]
    fn sizes_and_counts_are_checked() {
        assert_eq!(parse_size("640x480"), Ok((640, 480)));
        assert!(parse_size("0x10").unwrap_err().contains("between 1 and"));
        assert!(parse_size("100000x10").is_err());
        assert!(parse_size("abc").unwrap_err().contains("WIDTHxHEIGHT"));
        assert!(parse_spp("0").is_err() && parse_spp("99999999").is_err() && parse_spp("-1").is_err());
        assert!(parse_time("nan").is_err() && parse_time("inf").is_err() && parse_time("1.5").is_ok());
    }

    #[test]
    fn did_you_mean_finds_close_names_only() {
        assert_eq!(edit_distance("cornel", "cornell"), 1);
        assert_eq!(edit_distance("ao-roam", "ao-roma"), 2);
        assert_eq!(did_you_mean("cornel", ["cornell", "sky"]), " (did you mean 'cornell'?)");
        assert_eq!(did_you_mean("ao-roam", ["ao-roma", "ao-exact"]), " (did you mean 'ao-roma'?)");
        assert_eq!(did_you_mean("zzz", ["cornell", "sky"]), "");
    }
}
