//! `glimpse suite`: every approximate technique on every scene of the scene suite
//! (`scenes/suite/*.toml`, docs/suite.md), at its defaults, beside its exact reference, through
//! [`run_eval`] one scene at a time; then one `results.json` and one `report.html` with a
//! scenes × techniques table whose cells are green or red against each technique's target.
//!
//! Choices the issue leaves open, documented here and in docs/suite.md:
//! - Speed-up is the exact reference's time at the technique's own spp and seed on the same
//!   GBuffer (prepare included) over the technique's; temporal techniques (ROMA, light cuts) are
//!   timed per frame after [`TEMPORAL_FRAMES`] frames and judged on the accumulated image.
//! - "Black where the reference is lit" compares 3 × 3 box-filtered luminances, so that a
//!   low-spp technique's per-pixel noise is not counted (see [`PixelFaults`]).
//! - Targets are checked on the measured size (the 4 GiB memory target is stated for 1280×720;
//!   at the suite's sizes a technique over it is certainly over it there too).

use crate::cache::Cache;
use crate::experiment::{EvalConfig, EvalResults, Run, run_eval};
use crate::plot::html_escape;
use anyhow::{Context, Result, bail};
use glimpse_core::{Image, luminance};
use glimpse_render::Registry;
use serde::Serialize;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Frames accumulated by temporal techniques before they are judged (the issue's 16).
pub const TEMPORAL_FRAMES: u32 = 16;
/// The memory target per technique.
pub const MEMORY_LIMIT_BYTES: u64 = 4 << 30;

#[derive(Clone, Debug)]
pub struct SuiteConfig {
    /// The folder of suite scenes (`scenes/suite`).
    pub scenes_dir: PathBuf,
    pub out_dir: PathBuf,
    /// Small sizes and fewer samples: finishes in minutes on two cores.
    pub quick: bool,
    pub cache: Cache,
    /// Only these scenes (by file stem), in this order; empty: all, sorted by name.
    pub only: Vec<String>,
}

impl SuiteConfig {
    /// (width, height, spp, reference spp).
    pub fn sizes(&self) -> (u32, u32, u32, u32) {
        if self.quick { (96, 64, 4, 64) } else { (320, 180, 16, 256) }
    }
}

/// Pixels no technique should produce: NaN or infinite values, and pixels black (under 10 % of
/// the reference, after a 3 × 3 box filter of both luminances) where the reference is lit (its
/// filtered luminance over 5 % of the image's mean); also glints, lit pixels over twice the
/// reference (same filter; the issue's bound for the wavelet cache).
///
/// For the black test the reference's 3 × 3 window drops its brightest pixel: a lone firefly of a
/// path-traced reference (at 256 spp `glints` has pixels 1,000× their neighbours' median) would
/// otherwise make a correctly dark 3 × 3 area "lit", and the technique black there. A lit area
/// two pixels wide still counts.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct PixelFaults {
    pub nan_inf: u64,
    pub black_where_lit: u64,
    /// Pixels where the reference is lit (the population `black_where_lit` is counted in).
    pub lit: u64,
    /// The reference's mean (filtered) luminance over the black-where-lit pixels, as a multiple
    /// of its image mean: near 0.05 they are its dimmest lit pixels, over 1 its bright ones.
    pub black_reference_level: f64,
    /// Lit pixels whose filtered luminance is over twice the reference's.
    pub over_twice: u64,
}

impl PixelFaults {
    pub fn count(image: &Image, reference: &Image) -> Self {
        let nan_inf = image.pixels.iter().filter(|p| !p.is_finite()).count() as u64;
        let (mut black, mut lit, mut level, mut over_twice) = (0, 0, 0.0f64, 0);
        Self::scan(image, reference, |_, fault| {
            lit += 1;
            if let Some(reference_level) = fault.black {
                black += 1;
                level += reference_level;
            }
            over_twice += u64::from(fault.over_twice);
        });
        Self { nan_inf, black_where_lit: black, lit, black_reference_level: if black > 0 { level / black as f64 } else { 0.0 }, over_twice }
    }

    /// Pixels black where lit and pixels over 2× the reference that `image` and `other` (another
    /// render against the same reference, e.g. the reference technique at the technique's own
    /// spp) share: (black in both, over 2× in both).
    pub fn shared(image: &Image, other: &Image, reference: &Image) -> (u64, u64) {
        let mut faults = vec![(false, false); image.pixels.len()];
        Self::scan(image, reference, |i, f| faults[i] = (f.black.is_some(), f.over_twice));
        let (mut black, mut over) = (0, 0);
        Self::scan(other, reference, |i, f| {
            black += u64::from(faults[i].0 && f.black.is_some());
            over += u64::from(faults[i].1 && f.over_twice);
        });
        (black, over)
    }

    /// Calls `visit(pixel, fault)` for every pixel where the reference is lit (nothing when the
    /// sizes differ).
    fn scan(image: &Image, reference: &Image, mut visit: impl FnMut(usize, LitPixel)) {
        if image.width != reference.width || image.height != reference.height {
            return;
        }
        let lum =
            |img: &Image| -> Vec<f32> { img.pixels.iter().map(|p| if p.is_finite() { luminance(*p).max(0.0) } else { 0.0 }).collect() };
        let (w, h) = (image.width as i64, image.height as i64);
        // The 3 × 3 mean, and the mean without the window's brightest pixel.
        let box3 = |l: &[f32], x: i64, y: i64| {
            let (mut s, mut n, mut max) = (0.0, 0.0, 0.0f32);
            for yy in (y - 1).max(0)..=(y + 1).min(h - 1) {
                for xx in (x - 1).max(0)..=(x + 1).min(w - 1) {
                    let v = l[(yy * w + xx) as usize];
                    s += v;
                    n += 1.0;
                    max = max.max(v);
                }
            }
            (s / n, (s - max) / (n - 1.0))
        };
        let (li, lr) = (lum(image), lum(reference));
        let mean = lr.iter().sum::<f32>() / lr.len().max(1) as f32;
        for y in 0..h {
            for x in 0..w {
                let (r, r_trimmed) = box3(&lr, x, y);
                if r > 0.05 * mean {
                    let i = box3(&li, x, y).0;
                    let black = (i < 0.1 * r_trimmed).then_some((r_trimmed / mean) as f64);
                    visit((y * w + x) as usize, LitPixel { black, over_twice: i > 2.0 * r });
                }
            }
        }
    }

    pub fn to_pairs(self) -> [(&'static str, f64); 5] {
        [
            ("nan_inf_pixels", self.nan_inf as f64),
            ("black_where_lit_pixels", self.black_where_lit as f64),
            ("lit_pixels", self.lit as f64),
            ("black_reference_level", self.black_reference_level),
            ("over_twice_pixels", self.over_twice as f64),
        ]
    }
}

/// A pixel where the reference is lit, as [`PixelFaults::scan`] finds it.
struct LitPixel {
    /// Black where lit: the reference's level there (its trimmed 3 × 3 mean / its image mean).
    black: Option<f64>,
    over_twice: bool,
}

/// One suite scene: its file and the one-line description (its leading comment).
#[derive(Clone, Debug, Serialize)]
pub struct SuiteScene {
    pub name: String,
    pub file: PathBuf,
    pub description: String,
    /// Why it cannot run here (a referenced file, usually under ../shared, is missing).
    pub missing: Option<String>,
}

/// The suite's scenes, sorted by name.
pub fn discover(dir: &Path) -> Result<Vec<SuiteScene>> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("{}: cannot read the suite folder", dir.display()))?;
    let mut files: Vec<PathBuf> =
        entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.extension().is_some_and(|e| e == "toml")).collect();
    files.sort();
    if files.is_empty() {
        bail!("{}: no .toml scenes in the suite folder", dir.display());
    }
    files
        .into_iter()
        .map(|file| {
            let text = std::fs::read_to_string(&file).with_context(|| format!("{}: cannot read", file.display()))?;
            let description =
                text.lines().take_while(|l| l.starts_with('#')).map(|l| l.trim_start_matches('#').trim()).collect::<Vec<_>>().join(" ");
            let name = file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            let missing = missing_files(&file, &text);
            Ok(SuiteScene { name, file, description, missing })
        })
        .collect()
}

/// The first file a scene names (`file = "…"`, `base_color_texture = "…"`) that does not exist.
fn missing_files(toml_path: &Path, text: &str) -> Option<String> {
    let dir = toml_path.parent().unwrap_or(Path::new(""));
    for line in text.lines().filter(|l| !l.trim_start().starts_with('#')) {
        for key in ["file = \"", "base_color_texture = \""] {
            let Some(start) = line.find(key) else { continue };
            let rest = &line[start + key.len()..];
            let Some(end) = rest.find('"') else { continue };
            let path = dir.join(&rest[..end]);
            if !path.exists() {
                return Some(format!("{} is missing", path.display()));
            }
        }
    }
    None
}

/// Whether a technique is temporal (accumulated over frames as it is used): ROMA's and the
/// light cuts' approximate techniques, and the distance-field baselines, which blend their
/// frames with ROMA's accumulator and so are compared with ROMA after the same frames.
pub fn is_temporal(id: &str) -> bool {
    matches!(id, "ao-df" | "soft-df") || glimpse_roma::techniques().iter().any(|t| t.id == id && t.reference.is_some()) || is_light_cuts(id)
}

/// The light cuts and their two baselines (`vpl-*`), whose spp is their sample budget n.
fn is_light_cuts(id: &str) -> bool {
    glimpse_lightcuts::techniques().iter().any(|t| t.id == id && t.reference.is_some())
}

/// The spp the VPL methods run at: their budget n is the size of the light cut, so the suite's
/// few samples (4 in `--quick`) would cut 4,096 VPLs into 4 nodes and judge a degenerate
/// method; they run at the thesis' n (32) unless the suite's spp is higher. Their reference,
/// `vpl-exact`, sums every VPL, so its cost does not depend on spp.
pub fn light_cuts_spp(spp: u32) -> u32 {
    spp.max(glimpse_lightcuts::THESIS_SPP)
}

/// One target check of one cell.
#[derive(Clone, Debug, Serialize)]
pub struct Check {
    pub what: String,
    pub pass: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    pub scene: String,
    pub technique: String,
    pub reference: String,
    /// Samples per pixel it ran at (the suite's, or [`light_cuts_spp`] for the VPL methods).
    pub spp: u32,
    pub ms: f64,
    pub reference_ms: Option<f64>,
    pub speedup: Option<f64>,
    pub rmse: f64,
    pub mse: f64,
    /// MSE without the worst [`TRIMMED_FRACTION`] of pixels: how much of `mse` a few outliers carry.
    pub mse_trimmed: Option<f64>,
    pub flip: f64,
    pub eps_s_pct: Option<f64>,
    /// RMSE against the reference rendered on the same samples (same spp and seed, one frame):
    /// the approximation's error without the noise both share.
    pub rmse_same_samples: Option<f64>,
    /// The reference's own RMSE at the technique's spp against its converged render: the noise
    /// floor under `rmse`.
    pub reference_rmse_same_spp: Option<f64>,
    pub memory_bytes: usize,
    pub faults: PixelFaults,
    pub frames: u32,
    pub checks: Vec<Check>,
    pub pass: bool,
    /// Measured reasons for failed checks (today: why a technique is slower than its reference).
    pub reasons: Vec<String>,
    /// Image files relative to the suite's output folder.
    pub image: String,
    pub reference_image: String,
    pub error_image: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct SuiteResults {
    pub quick: bool,
    pub size: [u32; 2],
    pub spp: u32,
    pub ref_spp: u32,
    pub temporal_frames: u32,
    pub scenes: Vec<SuiteScene>,
    pub cells: Vec<Cell>,
    /// Techniques a scene cannot run (scene, technique, reason).
    pub not_applicable: Vec<(String, String, String)>,
    pub seconds: f64,
    pub peak_rss_bytes: Option<u64>,
}

/// The cell of one run, with the target checks that apply to its technique (docs/suite.md).
fn cell(scene: &str, run: &Run, sub: &str, pixels: u64, spp: u32, ref_spp: u32) -> Cell {
    let m = |k: &str| run.metrics.get(k).copied();
    let faults = PixelFaults {
        nan_inf: m("nan_inf_pixels").unwrap_or(0.0) as u64,
        black_where_lit: m("black_where_lit_pixels").unwrap_or(0.0) as u64,
        lit: m("lit_pixels").unwrap_or(0.0) as u64,
        black_reference_level: m("black_reference_level").unwrap_or(0.0),
        over_twice: m("over_twice_pixels").unwrap_or(0.0) as u64,
    };
    let ms = run.ms["total"];
    let speedup = run.reference_ms.map(|r| r / ms.max(1e-6));
    let mut checks = vec![
        Check { what: format!("faster than {}", run.reference), pass: speedup.is_some_and(|s| s > 1.0) },
        Check { what: "no NaN/Inf".into(), pass: faults.nan_inf == 0 },
        Check { what: "no black where lit".into(), pass: faults.black_where_lit == 0 },
        Check { what: "memory ≤ 4 GiB".into(), pass: (run.memory_bytes as u64) <= MEMORY_LIMIT_BYTES },
    ];
    let mut not_judged = Vec::new();
    match run.technique.as_str() {
        "wavecache" => {
            checks.push(Check { what: "MSE ≤ 6e-4".into(), pass: m("mse").is_some_and(|v| v <= 6e-4) });
            checks.push(Check { what: "no glints over 2× pt".into(), pass: faults.over_twice == 0 });
        }
        "lights-voxarray" => checks.push(Check { what: "ε_s ≤ 3 %".into(), pass: m("eps_s_pct").is_some_and(|v| v <= 3.0) }),
        // The paper's ground truth traces the same N_r rays per fragment: judged on the same
        // samples, so only the field's decisions (and E_unshad's SH error) count. The target is
        // the issue's for low-frequency maps, which DVF assumes. A map whose N_r rays are noisy
        // (the technique's own `map_noise`, the rule of `unshadowed=auto`) is judged too when
        // `bright` traced its brightest part (`bright_power` > 0, the default there), and is
        // reported, not judged, when that was turned off.
        "env-dvf" => {
            let same = m("rmse_same_samples").or(m("rmse"));
            // With E_unshad from the map's SH the image is not on env-exact's samples in its
            // unshadowed term (the same-samples RMSE holds env-exact's own noise there): both
            // are then measured against env-exact converged. Where N_r exact rays themselves
            // are further than 0.003 from it, the target cannot be reached on N_r rays, and
            // env-dvf is judged on being no further from it than env-exact is.
            let sh = match (m("rmse_converged"), m("reference_rmse_converged")) {
                (Some(dvf), Some(exact)) if same.is_some_and(|v| v > 0.003) => Some((dvf, exact)),
                _ => None,
            };
            match m("map_noise").filter(|&n| n > glimpse_dvf::SH_MAX_RELATIVE_NOISE as f64 && m("bright_power").unwrap_or(0.0) <= 0.0) {
                None if let Some((dvf, exact)) = sh => {
                    if exact > 0.003 {
                        checks.push(Check { what: "RMSE vs env-exact converged ≤ env-exact's own at N_r".into(), pass: dvf <= exact });
                        not_judged.push(format!(
                            "RMSE ≤ 0.003 not judged: E_unshad from the map's SH is not on env-exact's samples (RMSE {:.4} on them holds env-exact's own noise); against env-exact converged (4,096 MIS rays) env-dvf has RMSE {dvf:.4} and env-exact itself on the same N_r rays {exact:.4}, so 0.003 is out of N_r rays' reach",
                            same.unwrap_or(0.0)
                        ));
                    } else {
                        checks.push(Check { what: "RMSE vs env-exact converged ≤ 0.003".into(), pass: dvf <= 0.003 });
                    }
                }
                None => checks
                    .push(Check { what: "RMSE vs env-exact on the same samples ≤ 0.003".into(), pass: same.is_some_and(|v| v <= 0.003) }),
                Some(noise) => not_judged.push(format!(
                    "RMSE ≤ 0.003 not judged: the map is not low-frequency ({noise:.2} relative noise of N_r rays > {}) and bright=off",
                    glimpse_dvf::SH_MAX_RELATIVE_NOISE
                )),
            }
        }
        _ => {}
    }
    let file = |k: &str| run.images.get(k).map(|f| format!("{sub}/{f}")).unwrap_or_default();
    let mut reasons = match (speedup, run.reference_ms) {
        (Some(s), Some(reference)) if s <= 1.0 => vec![slower_reason(run, reference, pixels)],
        _ => Vec::new(),
    };
    reasons.extend(not_judged);
    // What the reference technique itself gives at this spp: the same count, and how many of the
    // technique's faulty pixels are the same pixels (there the spp's noise alone explains them).
    let own = |count: &str, shared: &str| match (m(count), m(shared)) {
        (Some(n), Some(same)) => format!(
            "; {} itself at {spp} spp has {n:.0} such pixels against its {ref_spp}-spp render, {same:.0} of them the same pixels",
            run.reference
        ),
        (Some(n), None) => format!("; {} itself at {spp} spp has {n:.0} such pixels against its {ref_spp}-spp render", run.reference),
        _ => String::new(),
    };
    if faults.black_where_lit > 0 {
        let noise = own("reference_black_where_lit_pixels", "black_where_lit_shared_pixels");
        reasons.push(format!("{}{noise}", black_where_lit_reason(&run.technique, faults)));
    }
    if run.technique == "wavecache" && faults.over_twice > 0 {
        let noise = own("reference_over_twice_pixels", "over_twice_shared_pixels");
        reasons.push(format!(
            "{} of {} lit pixels ({:.2} %) are over 2× pt (3 × 3 means): glints of the cached radiance, or the {spp}-spp noise of traced lobes (sharp ones, and pixels beyond the cache: trace_far){noise}",
            faults.over_twice,
            faults.lit,
            100.0 * faults.over_twice as f64 / faults.lit.max(1) as f64
        ));
    }
    let dvf_rmse = m("rmse_same_samples").or(m("rmse")).filter(|&v| run.technique == "env-dvf" && v > 0.003);
    if let (Some(rmse), Some(points), Some(grid)) = (dvf_rmse, m("points"), m("grid"))
        && checks.iter().any(|c| c.what.starts_with("RMSE vs env-exact") && !c.pass)
    {
        let floor = if points as u32 <= *glimpse_dvf::AUTO_POINTS.start() { ", the floor" } else { "" };
        // With the SH's E_unshad the difference from env-exact also holds the N_r rays' own
        // noise in the unshadowed term, which the SH does not have.
        let sh = match (m("unshadowed_rays"), m("map_noise")) {
            (Some(0.0), Some(noise)) => format!(
                "; E_unshad from the map's SH (the relative noise of its N_r rays, {noise:.3}, is ≤ {}): this RMSE also holds env-exact's own noise in the unshadowed term, which the SH does not have (unshadowed=rays removes it: docs/techniques/dvf.md)",
                glimpse_dvf::SH_MAX_RELATIVE_NOISE
            ),
            _ => String::new(),
        };
        reasons.push(format!(
            "RMSE {rmse:.4} at the automatic sample budget for {pixels} pixels: {points:.0} points{floor}, grid {grid:.0} (points=auto follows the image size){sh}"
        ));
    }
    if run.memory_bytes as u64 > MEMORY_LIMIT_BYTES {
        let gib = |b: f64| b / (1u64 << 30) as f64;
        let parts = match (m("brdf_tables"), m("brdf_mib"), m("lighting_mib")) {
            (Some(n), Some(brdf), Some(light)) => {
                format!(": {n:.0} distinct BRDF tables take {:.2} GiB, the lighting cache {:.2} GiB", brdf / 1024.0, light / 1024.0)
            }
            _ => String::new(),
        };
        reasons.push(format!("its structures take {:.2} GiB, over the 4 GiB target{parts}", gib(run.memory_bytes as f64)));
    }
    if let (Some(eps), Some(cell)) = (m("eps_s_pct").filter(|&e| run.technique == "lights-voxarray" && e > 3.0), m("cell_m")) {
        reasons.push(match m("refined_pct") {
            // Refined: no false shadow is left, only occluders the array misses.
            Some(share) => match m("near_m") {
                Some(near) => format!(
                    "ε_s {eps:.1} % after exact rays confirmed its occluded answers ({share:.0} % of the decisions) and the first {near:.3} m of its visible ones: occluders the array misses beyond them, thinner than its cells of {cell:.3} m (128³, the maximum)"
                ),
                None => format!(
                    "ε_s {eps:.1} % after exact rays confirmed its occluded answers ({share:.0} % of the decisions): occluders the array misses, within the start offset or thinner than its cells of {cell:.3} m (128³, the maximum)"
                ),
            },
            None => format!(
                "ε_s {eps:.1} % with the grid at its 128³ maximum: cells of {cell:.3} m; resolution-bound (the wrong decisions are false shadows along long segments that pass within a cell of geometry and occluders missed within the 2.5-cell start offset; 64³ → 128³ cut them by 40 %: docs/suite.md; refine=exact removes the false shadows)"
            ),
        });
    }
    // An MSE target below the converged reference's own noise cannot be judged against it.
    if let (Some(mse), Some(noise)) =
        (m("mse").filter(|_| run.technique == "wavecache"), reference_noise_mse(m("reference_rmse_same_spp"), spp, ref_spp))
        && mse > 6e-4
        && noise > 6e-4
    {
        reasons.push(format!(
            "the {ref_spp}-spp reference's own noise is about MSE {noise:.1e} (from its {spp}-spp render's difference), above the 6e-4 target: the target cannot be judged at this reference"
        ));
    }
    Cell {
        scene: scene.to_owned(),
        technique: run.technique.clone(),
        reference: run.reference.clone(),
        spp,
        ms,
        reference_ms: run.reference_ms,
        speedup,
        rmse: m("rmse").unwrap_or(f64::NAN),
        mse: m("mse").unwrap_or(f64::NAN),
        mse_trimmed: m("mse_trimmed"),
        flip: m("flip").unwrap_or(f64::NAN),
        eps_s_pct: m("eps_s_pct"),
        rmse_same_samples: m("rmse_same_samples"),
        reference_rmse_same_spp: m("reference_rmse_same_spp"),
        memory_bytes: run.memory_bytes,
        faults,
        frames: run.frames,
        pass: checks.iter().all(|c| c.pass),
        checks,
        reasons,
        image: file("image"),
        reference_image: file("reference"),
        error_image: file("error"),
    }
}

/// The converged reference's own MSE, estimated from R, the RMSE between the reference rendered
/// at `spp` and at `ref_spp` (independent Monte Carlo noise, variance ∝ 1/spp): R² = σ²_spp +
/// σ²_ref with σ²_ref = σ²_spp · spp / ref_spp.
fn reference_noise_mse(rmse_same_spp: Option<f64>, spp: u32, ref_spp: u32) -> Option<f64> {
    let r = rmse_same_spp?;
    let k = spp as f64 / ref_spp.max(1) as f64;
    Some(r * r * k / (1.0 + k))
}

/// What a count of black-where-lit pixels is: how much of the lit image, how bright the
/// reference is there, and which part of the technique differs from its reference (the count is
/// of 3 × 3 means, so it is not one sample's noise).
fn black_where_lit_reason(technique: &str, f: PixelFaults) -> String {
    let cause = match technique {
        "wavecache" => "its cached, interpolated radiance is darker there",
        t if t.starts_with("vpl-") => "its VPL estimate is darker there",
        // The visibility techniques shade as their references do: only the visibility differs.
        _ => "its approximate visibility blocks light that the exact visibility lets through (the shading is the reference's)",
    };
    format!(
        "{} of {} lit pixels ({:.2} %) are under 10 % of the reference, where the reference averages {:.2}× its image mean: {cause}",
        f.black_where_lit,
        f.lit,
        100.0 * f.black_where_lit as f64 / f.lit.max(1) as f64,
        f.black_reference_level
    )
}

/// Why a technique is not faster than its reference, from the run's own times: either its
/// per-frame build (prepare) does not pay off at this size, with the pixel count where it would
/// if both costs scaled with the pixels (a build does not), or its shading itself is slower.
fn slower_reason(run: &Run, reference_ms: f64, pixels: u64) -> String {
    let (prepare, render) = (run.ms.get("prepare").copied().unwrap_or(0.0), run.ms.get("render").copied().unwrap_or(0.0));
    let why = if render < reference_ms {
        let even = pixels as f64 * prepare / (reference_ms - render);
        format!(
            "its build does not pay off at {pixels} pixels: prepare {prepare:.1} ms + shading {render:.1} ms vs the reference's {reference_ms:.1} ms (shading alone {:.1}× faster; break-even near {:.0}K pixels)",
            reference_ms / render.max(1e-6),
            even / 1000.0
        )
    } else {
        format!("its shading alone is slower: {render:.1} ms (+ prepare {prepare:.1} ms) vs the reference's {reference_ms:.1} ms")
    };
    // `lights-voxarray` with `refine`: its shading includes exact rays.
    match run.metrics.get("refined_pct") {
        Some(share) => match run.metrics.get("near_m") {
            Some(near) => format!(
                "{why}; its shading traces the exact ray for the {share:.0} % of decisions the array calls occluded, and its first {near:.2} m for the others (refine)"
            ),
            None => format!("{why}; its shading traces the exact ray for the {share:.0} % of decisions the array calls occluded (refine)"),
        },
        None => why,
    }
}

/// The share of pixels with the largest squared error that [`Cell::mse_trimmed`] sets aside
/// (0.2 %: 12 pixels at 96 × 64, 116 at 320 × 180).
pub const TRIMMED_FRACTION: f64 = 0.002;

/// The checks that compare techniques of one scene: `ao-roma` (16 frames) has lower FLIP than
/// `ao-df`; `vpl-lightcuts` is the best of the three VPL methods at equal time, judged by MSE ×
/// time per frame (an estimator's MSE at equal time scales as its MSE × its cost: the usual
/// inverse efficiency), each failure with the values compared.
fn cross_checks(cells: &mut [Cell]) {
    let get = |cells: &[Cell], id: &str, f: fn(&Cell) -> f64| cells.iter().find(|c| c.technique == id).map(f);
    let roma_df = (get(cells, "ao-roma", |c| c.flip), get(cells, "ao-df", |c| c.flip));
    let cost = |c: &Cell| c.mse * c.ms;
    let cost_trimmed = |c: &Cell| c.mse_trimmed.map(|m| m * c.ms);
    // The other VPL methods, copied out so the light cuts' cell can be changed beside them.
    let others: Vec<Cell> = cells.iter().filter(|c| ["vpl-sst", "vpl-rtslc"].contains(&c.technique.as_str())).cloned().collect();
    let vpl_trimmed = others.iter().filter_map(cost_trimmed).reduce(f64::min);
    for c in cells.iter_mut() {
        if let ("ao-roma", (Some(roma), Some(df))) = (c.technique.as_str(), roma_df) {
            // A FLIP of 0 is the reference itself: nothing can be below it (a frame that shows
            // no surface, where both equal it).
            let pass = roma < df || roma == 0.0;
            c.checks.push(Check { what: format!("FLIP below ao-df's {df:.4} after {} frames", c.frames), pass });
            if !pass {
                c.reasons.push(format!("after {} frames its FLIP is {roma:.4}, ao-df's {df:.4}", c.frames));
            }
        }
        if c.technique == "vpl-lightcuts"
            && let Some(best_cell) = others.iter().min_by(|a, b| cost(a).total_cmp(&cost(b)))
        {
            let (best_id, best, mine) = (best_cell.technique.as_str(), cost(best_cell), cost(c));
            // An MSE of 0 (no pixel that a VPL lights) cannot be beaten.
            let pass = mine < best || mine == 0.0;
            c.checks.push(Check { what: format!("MSE × ms below the other VPL methods' best ({best_id} {best:.3e})"), pass });
            if !pass {
                // Whether a few pixels decide it: the same comparison without each method's worst
                // pixels (the light cuts' bias is spread over the image; a VPL's hot spot is not).
                let outliers = match (cost_trimmed(c), vpl_trimmed) {
                    (Some(m), Some(b)) => {
                        let (standing, meaning) = if m < b {
                            ("it is ahead", "a few pixels decide it")
                        } else {
                            ("still behind", "the gap is spread over the image")
                        };
                        format!(
                            "; without each method's worst {:.1} % of pixels {standing}, {m:.3e} vs {b:.3e}: {meaning}",
                            100.0 * TRIMMED_FRACTION
                        )
                    }
                    _ => String::new(),
                };
                let ratio = |f: fn(&Cell) -> f64| {
                    let b = f(best_cell);
                    if b > 0.0 { format!("{:.2}×", f(c) / b) } else { "?".to_owned() }
                };
                let why = if best_id == "vpl-rtslc" {
                    "its estimator is vpl-rtslc's but below a stopped cluster, where it picks a VPL by intensity (cheaper steps), so their MSEs agree to about 1 % and the frame-time noise decides between them".to_owned()
                } else {
                    let rtslc_too = others.iter().any(|k| k.technique == "vpl-rtslc" && cost(k) > best);
                    format!(
                        "{best_id}'s traversals from the root sample this scene better than the light cuts{}",
                        if rtslc_too { " (vpl-rtslc, on the same cuts, is behind it too)" } else { "" }
                    )
                };
                c.reasons.push(format!(
                    "at equal time it is behind {best_id}: MSE × ms per frame {mine:.3e} vs {best:.3e}, its MSE {} and its frame {} {best_id}'s (its MSE {:.2e} in {:.1} ms){outliers}; {why}: docs/techniques/lightcuts.md, \"The cluster's light\"",
                    ratio(|k| k.mse),
                    ratio(|k| k.ms),
                    c.mse,
                    c.ms
                ));
            }
        }
        c.pass = c.checks.iter().all(|k| k.pass);
    }
}

pub fn run_suite(cfg: &SuiteConfig, registry: &Registry, mut log: impl FnMut(&str)) -> Result<SuiteResults> {
    let started = Instant::now();
    // Every cell's prepare is a build: a structure left on disk by an earlier run (the wavelet
    // cache, the voxel array) would make it a load. The references' cache stays.
    glimpse_render::set_structure_cache(false);
    let mut scenes = discover(&cfg.scenes_dir)?;
    if !cfg.only.is_empty() {
        if let Some(unknown) = cfg.only.iter().find(|n| !scenes.iter().any(|s| &s.name == *n)) {
            bail!(
                "{}: no suite scene '{unknown}' (have: {})",
                cfg.scenes_dir.display(),
                scenes.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", ")
            );
        }
        scenes = cfg.only.iter().filter_map(|n| scenes.iter().find(|s| &s.name == n).cloned()).collect();
    }
    std::fs::create_dir_all(&cfg.out_dir).with_context(|| format!("{}: cannot create the output directory", cfg.out_dir.display()))?;
    let (width, height, spp, ref_spp) = cfg.sizes();
    let mut cells = Vec::new();
    let mut not_applicable = Vec::new();
    for scene in &scenes {
        if let Some(reason) = &scene.missing {
            log(&format!("skipped: suite scene {}: {reason}", scene.name));
            continue;
        }
        log(&format!("suite scene {} ({})", scene.name, scene.description));
        let approximate: Vec<String> = registry.all().iter().filter(|t| t.reference.is_some()).map(|t| t.id.to_owned()).collect();
        let (temporal, single): (Vec<String>, Vec<String>) = approximate.into_iter().partition(|id| is_temporal(id));
        let (vpl, temporal): (Vec<String>, Vec<String>) = temporal.into_iter().partition(|id| is_light_cuts(id));
        let mut scene_cells = Vec::new();
        for (ids, frames, spp) in [(single, 1, spp), (temporal, TEMPORAL_FRAMES, spp), (vpl, TEMPORAL_FRAMES, light_cuts_spp(spp))] {
            let sub = scene.name.clone();
            let eval = EvalConfig {
                scene_spec: scene.file.display().to_string(),
                techniques: Vec::new(),
                approximate_only: true,
                width,
                height,
                spp,
                ref_spp,
                seed: 0,
                time: 0.0,
                params: Vec::new(),
                out_dir: cfg.out_dir.join(&sub),
                cache: cfg.cache.clone(),
                sweep: false,
                exposure: 0.0,
                frames,
                overrides: Default::default(),
                time_reference: true,
                tev: None,
            };
            let results =
                run_eval_subset(&eval, registry, &ids, &mut log).with_context(|| format!("suite scene {}", scene.file.display()))?;
            for run in &results.runs {
                scene_cells.push(cell(&scene.name, run, &sub, width as u64 * height as u64, spp, ref_spp));
            }
            for sk in results.skipped {
                not_applicable.push((scene.name.clone(), sk.technique, sk.reason));
            }
        }
        cross_checks(&mut scene_cells);
        cells.extend(scene_cells);
        // The report so far, so that a long run can be read (or stopped) scene by scene.
        write_results(cfg, &results_of(cfg, &scenes, &cells, &not_applicable, started))?;
    }
    let results = results_of(cfg, &scenes, &cells, &not_applicable, started);
    write_results(cfg, &results)?;
    Ok(results)
}

fn results_of(
    cfg: &SuiteConfig,
    scenes: &[SuiteScene],
    cells: &[Cell],
    not_applicable: &[(String, String, String)],
    started: Instant,
) -> SuiteResults {
    let (width, height, spp, ref_spp) = cfg.sizes();
    SuiteResults {
        quick: cfg.quick,
        size: [width, height],
        spp,
        ref_spp,
        temporal_frames: TEMPORAL_FRAMES,
        scenes: scenes.to_vec(),
        cells: cells.to_vec(),
        not_applicable: not_applicable.to_vec(),
        seconds: started.elapsed().as_secs_f64(),
        peak_rss_bytes: crate::peak_rss_bytes(),
    }
}

fn write_results(cfg: &SuiteConfig, results: &SuiteResults) -> Result<()> {
    write_atomic(&cfg.out_dir.join("results.json"), serde_json::to_string_pretty(results)?.as_bytes())?;
    write_atomic(&cfg.out_dir.join("report.html"), report_html(results).as_bytes())
}

/// [`run_eval`] over a registry of only `ids` and their references, so that its "everything the
/// scene supports" mode runs exactly these and lists the rest of them as not applicable.
fn run_eval_subset(eval: &EvalConfig, registry: &Registry, ids: &[String], log: &mut impl FnMut(&str)) -> Result<EvalResults> {
    let subset: Vec<_> = registry.all().iter().filter(|t| ids.iter().any(|id| id == t.id)).cloned().collect();
    run_eval(eval, &Registry::new(subset_with_references(registry, subset)), |m| log(m))
}

/// The techniques and the references they name (a reference must be in the registry to render).
fn subset_with_references(registry: &Registry, mut subset: Vec<glimpse_render::TechniqueInfo>) -> Vec<glimpse_render::TechniqueInfo> {
    let refs: Vec<&str> = subset.iter().filter_map(|t| t.reference).collect();
    for r in refs {
        if !subset.iter().any(|t| t.id == r)
            && let Ok(info) = registry.get(r)
        {
            subset.push(info.clone());
        }
    }
    subset
}

/// Writes a file through a temporary file in the same folder and a rename.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).with_context(|| format!("{}: cannot write", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot rename into place", path.display()))
}

/// The markdown table of docs/suite.md: one row per scene, one column per technique, each cell
/// "speed-up× / RMSE / FLIP" and ✔ or ✘ with the failed checks.
pub fn markdown_table(r: &SuiteResults) -> String {
    let mut techniques: Vec<&str> = r.cells.iter().map(|c| c.technique.as_str()).collect();
    techniques.sort();
    techniques.dedup();
    let mut s = format!("| scene | {} |\n|---|{}\n", techniques.join(" | "), "---|".repeat(techniques.len()));
    for scene in r.scenes.iter().filter(|s| s.missing.is_none()) {
        let _ = write!(s, "| {} |", scene.name);
        for t in &techniques {
            match r.cells.iter().find(|c| c.scene == scene.name && c.technique == *t) {
                Some(c) => {
                    let failed: Vec<&str> = c.checks.iter().filter(|k| !k.pass).map(|k| k.what.as_str()).collect();
                    let _ = write!(
                        s,
                        " {} {}× {:.4}/{:.3}{}{}{} |",
                        if c.pass { "✔" } else { "✘" },
                        c.speedup.map_or("?".into(), |v| format!("{v:.1}")),
                        c.rmse,
                        c.flip,
                        c.rmse_same_samples.filter(|_| c.technique == "env-dvf").map_or(String::new(), |v| format!(" same-samples {v:.4}")),
                        c.eps_s_pct.map_or(String::new(), |e| format!(" ε_s {e:.1}%")),
                        if failed.is_empty() { String::new() } else { format!(" ({})", failed.join("; ")) }
                    );
                }
                None => s += " – |",
            }
        }
        s += "\n";
    }
    let why: Vec<&Cell> = r.cells.iter().filter(|c| !c.reasons.is_empty()).collect();
    if !why.is_empty() {
        s += "\nMeasured reasons for red cells, and targets not judged:\n\n";
        for c in why {
            let _ = writeln!(s, "- {} · {}: {}", c.scene, c.technique, c.reasons.join("; "));
        }
    }
    s
}

fn report_html(r: &SuiteResults) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        r#"<!doctype html><html><head><meta charset="utf-8"><title>glimpse suite</title><style>
body{{font-family:sans-serif;margin:24px}} table{{border-collapse:collapse;font-size:12px}} td,th{{border:1px solid #ccc;padding:3px 6px;vertical-align:top}}
td.pass{{background:#d8f5d0}} td.fail{{background:#f8d0d0}} figure{{display:inline-block;margin:3px}} img{{image-rendering:pixelated;width:192px}} figcaption{{font-size:11px}}</style></head><body>
<h1>glimpse suite{}</h1>
<p>{}×{} pixels, {} spp (the VPL methods {} spp, the thesis' light-cut size; references {} spp, timed again at each technique's spp for the speed-up), temporal techniques after {} frames. {} scenes, {} cells, {:.0} s in all; peak memory {}.</p>
<p>Each cell: time per frame, speed-up over the exact reference on the same GBuffer, RMSE, FLIP, ε_s where reported, peak memory, NaN/Inf and black-where-lit pixel counts; green when every target check of docs/suite.md passes, red with the failed checks.</p>
<h2>Scenes</h2><ul>"#,
        if r.quick { " --quick" } else { "" },
        r.size[0],
        r.size[1],
        r.spp,
        light_cuts_spp(r.spp),
        r.ref_spp,
        r.temporal_frames,
        r.scenes.len(),
        r.cells.len(),
        r.seconds,
        r.peak_rss_bytes.map_or("unknown".into(), |b| format!("{:.0} MiB", b as f64 / 1048576.0))
    );
    for s in &r.scenes {
        let _ = write!(
            h,
            "<li><b>{}</b>: {}{}</li>",
            html_escape(&s.name),
            html_escape(&s.description),
            s.missing.as_ref().map_or(String::new(), |m| format!(" <i>(skipped: {})</i>", html_escape(m)))
        );
    }
    h += "</ul><h2>Scenes × techniques</h2><table><tr><th>scene</th>";
    let mut techniques: Vec<&str> = r.cells.iter().map(|c| c.technique.as_str()).collect();
    techniques.sort();
    techniques.dedup();
    for t in &techniques {
        let _ = write!(h, "<th>{}</th>", html_escape(t));
    }
    h += "</tr>";
    for scene in r.scenes.iter().filter(|s| s.missing.is_none()) {
        let _ = write!(h, "<tr><th>{}</th>", html_escape(&scene.name));
        for t in &techniques {
            match r.cells.iter().find(|c| c.scene == scene.name && c.technique == *t) {
                Some(c) => {
                    let failed: Vec<String> = c.checks.iter().filter(|k| !k.pass).map(|k| html_escape(&k.what)).collect();
                    let _ = write!(
                        h,
                        "<td class=\"{}\">{:.1} ms<br>{}<br>RMSE {:.4}{}<br>FLIP {:.4}{}<br>{:.0} MiB<br>NaN/Inf {} · black {}{}{}</td>",
                        if c.pass { "pass" } else { "fail" },
                        c.ms,
                        c.speedup.map_or("speed-up ?".into(), |s| format!("{s:.2}× ref")),
                        c.rmse,
                        match (c.rmse_same_samples, c.reference_rmse_same_spp) {
                            (Some(same), Some(noise)) => format!(" (same samples {same:.4}; the reference's own noise {noise:.4})"),
                            _ => String::new(),
                        },
                        c.flip,
                        c.eps_s_pct.map_or(String::new(), |e| format!("<br>ε_s {e:.2} %")),
                        c.memory_bytes as f64 / 1048576.0,
                        c.faults.nan_inf,
                        c.faults.black_where_lit,
                        if failed.is_empty() { String::new() } else { format!("<br><b>✘ {}</b>", failed.join("; ")) },
                        c.reasons.iter().map(|r| format!("<br><i>why: {}</i>", html_escape(r))).collect::<String>()
                    );
                }
                None => h += "<td>–</td>",
            }
        }
        h += "</tr>";
    }
    h += "</table>";
    for (scene, t, reason) in &r.not_applicable {
        let _ = write!(h, "<p>Not applicable: {} on {}: {}.</p>", html_escape(t), html_escape(scene), html_escape(reason));
    }
    h += "<h2>Images</h2><p>Technique, reference and HDR-FLIP error map.</p>";
    for c in &r.cells {
        let _ = write!(h, "<h3>{} · {}</h3>", html_escape(&c.scene), html_escape(&c.technique));
        for (file, caption) in
            [(&c.image, c.technique.as_str()), (&c.reference_image, c.reference.as_str()), (&c.error_image, "FLIP error")]
        {
            let _ = write!(
                h,
                r#"<figure><img src="{0}" alt="{1}"><figcaption>{1}</figcaption></figure>"#,
                html_escape(file),
                html_escape(caption)
            );
        }
    }
    h += "</body></html>\n";
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::Vec3;

    fn run(technique: &str, prepare: f64, render: f64, reference_ms: f64, metrics: &[(&str, f64)]) -> Run {
        Run {
            technique: technique.into(),
            reference: "exact".into(),
            ms: [("prepare", prepare), ("render", render), ("total", prepare + render)].map(|(k, v)| (k.to_owned(), v)).into(),
            memory_bytes: 0,
            rays: 0,
            metrics: metrics.iter().map(|&(k, v)| (k.to_owned(), v)).collect(),
            params: Default::default(),
            images: Default::default(),
            sweep: Vec::new(),
            reference_cached: false,
            frames: 1,
            reference_ms: Some(reference_ms),
            reference_render_ms: Some(reference_ms),
        }
    }

    /// The cross-checks: the light cuts judged at equal time by MSE × ms, ROMA against the
    /// distance field by FLIP, each failure with the values; the voxel array's ε_s over 3 % with
    /// its cell size.
    #[test]
    fn cross_checks_and_eps_carry_their_numbers() {
        let vpl = |id: &str, ms: f64, mse: f64, trimmed: f64| {
            cell("s", &run(id, 0.0, ms, 100.0, &[("mse", mse), ("rmse", mse.sqrt()), ("mse_trimmed", trimmed)]), "s", 6000, 4, 64)
        };
        // Lower MSE than vpl-sst but 3× its time: behind it at equal time, also without the
        // worst pixels.
        let mut cells = vec![vpl("vpl-lightcuts", 3.0, 1e-4, 9e-5), vpl("vpl-sst", 1.0, 2e-4, 1e-4), vpl("vpl-rtslc", 1.0, 5e-4, 4e-4)];
        cross_checks(&mut cells);
        let lc = &cells[0];
        assert!(
            !lc.pass
                && lc.reasons.iter().any(|r| r.contains("behind vpl-sst")
                    && r.contains("still behind")
                    && r.contains("its MSE 0.50× and its frame 3.00× vpl-sst's")
                    && r.contains("(vpl-rtslc, on the same cuts, is behind it too)")),
            "{:?}",
            lc.reasons
        );
        // Behind vpl-rtslc: the reason names the two as level estimators.
        let mut cells = vec![vpl("vpl-lightcuts", 1.1, 1e-4, 9e-5), vpl("vpl-rtslc", 1.0, 1e-4, 8e-5)];
        cross_checks(&mut cells);
        assert!(
            cells[0]
                .reasons
                .iter()
                .any(|r| r.contains("its MSE 1.00× and its frame 1.10× vpl-rtslc's") && r.contains("agree to about 1 %")),
            "{:?}",
            cells[0].reasons
        );
        // Behind only through a few pixels: the reason says so.
        let mut cells = vec![vpl("vpl-lightcuts", 1.0, 3e-4, 5e-5), vpl("vpl-sst", 1.0, 2e-4, 1e-4)];
        cross_checks(&mut cells);
        assert!(
            !cells[0].pass && cells[0].reasons.iter().any(|r| r.contains("it is ahead, 5.000e-5 vs 1.000e-4")),
            "{:?}",
            cells[0].reasons
        );
        let mut cells = vec![vpl("vpl-lightcuts", 1.0, 1e-4, 1e-4), vpl("vpl-sst", 1.0, 2e-4, 2e-4)];
        cross_checks(&mut cells);
        assert!(cells[0].pass, "{:?}", cells[0].checks);
        let flip = |id: &str, f: f64| cell("s", &run(id, 0.0, 1.0, 100.0, &[("flip", f)]), "s", 6000, 4, 64);
        let mut cells = vec![flip("ao-roma", 0.3), flip("ao-df", 0.2)];
        cross_checks(&mut cells);
        assert!(!cells[0].pass && cells[0].reasons.iter().any(|r| r.contains("0.3000") && r.contains("0.2000")), "{:?}", cells[0].reasons);
        // Both equal to the reference (a frame that shows no surface): nothing to be below.
        let mut cells = vec![flip("ao-roma", 0.0), flip("ao-df", 0.0)];
        cross_checks(&mut cells);
        assert!(cells[0].pass, "{:?}", cells[0].checks);
        let mut cells = vec![vpl("vpl-lightcuts", 1.0, 0.0, 0.0), vpl("vpl-sst", 0.9, 0.0, 0.0)];
        cross_checks(&mut cells);
        assert!(cells[0].pass, "{:?}", cells[0].checks);
        let c = cell("s", &run("lights-voxarray", 0.0, 1.0, 100.0, &[("eps_s_pct", 9.8), ("cell_m", 0.133)]), "s", 6000, 4, 64);
        assert!(!c.pass && c.reasons.iter().any(|r| r.contains("ε_s 9.8 %") && r.contains("0.133 m")), "{:?}", c.reasons);
        // Refined (`refine`): the reason says the rest are missed occluders, and a slower
        // shading names its exact-ray share.
        let refined = [("eps_s_pct", 3.4), ("cell_m", 0.133), ("refined_pct", 57.0)];
        let c = cell("s", &run("lights-voxarray", 0.0, 5.0, 4.0, &refined), "s", 6000, 4, 64);
        assert!(c.reasons.iter().any(|r| r.contains("ε_s 3.4 % after exact rays") && r.contains("misses")), "{:?}", c.reasons);
        assert!(c.reasons.iter().any(|r| r.contains("shading alone is slower") && r.contains("57 % of decisions")), "{:?}", c.reasons);
        // Over the memory target: the reason says how much, and the wavelet cache's parts.
        let big = [("brdf_tables", 320.0), ("brdf_mib", 7000.0), ("lighting_mib", 200.0)];
        let mut r = run("wavecache", 0.0, 5.0, 4.0, &big);
        r.memory_bytes = (7.2 * (1u64 << 30) as f64) as usize;
        let c = cell("s", &r, "s", 6000, 4, 64);
        assert!(
            c.reasons.iter().any(|r| r.contains("7.20 GiB, over the 4 GiB target") && r.contains("320 distinct BRDF tables")),
            "{:?}",
            c.reasons
        );
        // With near checks (`refine_near`) both reasons name their length.
        let near = [("eps_s_pct", 3.4), ("cell_m", 0.133), ("refined_pct", 57.0), ("near_m", 0.266)];
        let c = cell("s", &run("lights-voxarray", 0.0, 5.0, 4.0, &near), "s", 6000, 4, 64);
        assert!(c.reasons.iter().any(|r| r.contains("first 0.266 m of its visible ones") && r.contains("beyond them")), "{:?}", c.reasons);
        assert!(c.reasons.iter().any(|r| r.contains("57 % of decisions") && r.contains("first 0.27 m for the others")), "{:?}", c.reasons);
        let dvf = [("map_noise", 0.05), ("rmse_same_samples", 0.02), ("points", 10_000.0), ("grid", 20.0)];
        let c = cell("s", &run("env-dvf", 0.0, 1.0, 100.0, &dvf), "s", 6000, 4, 64);
        assert!(!c.pass && c.reasons.iter().any(|r| r.contains("RMSE 0.0200") && r.contains("10000 points, the floor")), "{:?}", c.reasons);
        assert!(!c.reasons.iter().any(|r| r.contains("SH")), "no E_unshad source reported: {:?}", c.reasons);
        // With the SH's E_unshad the reason says that the RMSE holds the rays' own noise.
        let sh = [("map_noise", 0.055), ("unshadowed_rays", 0.0), ("rmse_same_samples", 0.0074), ("points", 10_000.0), ("grid", 20.0)];
        let c = cell("s", &run("env-dvf", 0.0, 1.0, 100.0, &sh), "s", 6000, 4, 64);
        assert!(c.reasons.iter().any(|r| r.contains("RMSE 0.0074") && r.contains("map's SH") && r.contains("0.055")), "{:?}", c.reasons);
        let rays = [("map_noise", 0.055), ("unshadowed_rays", 1.0), ("rmse_same_samples", 0.0074), ("points", 10_000.0), ("grid", 20.0)];
        let c = cell("s", &run("env-dvf", 0.0, 1.0, 100.0, &rays), "s", 6000, 4, 64);
        assert!(!c.reasons.iter().any(|r| r.contains("map's SH")), "{:?}", c.reasons);
    }

    /// The VPL methods run at the thesis' light-cut size unless the suite asks for more; their
    /// reference and every other technique keep the suite's spp.
    #[test]
    fn light_cuts_run_at_the_thesis_budget() {
        assert_eq!(light_cuts_spp(4), 32);
        assert_eq!(light_cuts_spp(64), 64);
        assert!(is_light_cuts("vpl-lightcuts") && is_light_cuts("vpl-sst") && is_light_cuts("vpl-rtslc"));
        assert!(!is_light_cuts("vpl-exact") && !is_light_cuts("ao-roma"));
    }

    /// A slower cell says why, from its own times: a build that does not pay off at this size
    /// (with the break-even pixel count), or shading that is itself slower.
    #[test]
    fn slower_cells_carry_a_measured_reason() {
        // 10 ms build + 1 ms shading against 3 ms: shading 3× faster, break-even at 5× the pixels.
        let c = cell("s", &run("ao-roma", 10.0, 1.0, 3.0, &[]), "s", 6000, 4, 64);
        assert!(!c.pass && c.reasons.len() == 1, "{:?}", c.reasons);
        assert!(
            c.reasons[0].contains("does not pay off at 6000 pixels") && c.reasons[0].contains("break-even near 30K pixels"),
            "{}",
            c.reasons[0]
        );
        let c = cell("s", &run("ao-roma", 0.5, 4.0, 3.0, &[]), "s", 6000, 4, 64);
        assert!(c.reasons[0].contains("shading alone is slower"), "{}", c.reasons[0]);
        assert!(cell("s", &run("ao-roma", 0.5, 1.0, 3.0, &[]), "s", 6000, 4, 64).reasons.is_empty());
        // A wavecache MSE over target, against a reference noisier than the target: said.
        let noisy = [("mse", 0.01), ("reference_rmse_same_spp", 0.2)];
        let c = cell("s", &run("wavecache", 0.5, 1.0, 3.0, &noisy), "s", 6000, 4, 64);
        assert!(c.reasons.iter().any(|r| r.contains("cannot be judged")), "{:?}", c.reasons);
        let quiet = [("mse", 0.01), ("reference_rmse_same_spp", 0.02)];
        assert!(cell("s", &run("wavecache", 0.5, 1.0, 3.0, &quiet), "s", 6000, 4, 64).reasons.is_empty());
    }

    /// `env-dvf` is judged on the same samples as `env-exact` (the paper's ground truth traces
    /// the same N_r rays), not against the converged render whose difference is mostly noise.
    #[test]
    fn env_dvf_is_judged_on_the_same_samples() {
        let c = cell("s", &run("env-dvf", 0.1, 1.0, 3.0, &[("rmse", 0.2), ("rmse_same_samples", 0.002)]), "s", 6000, 4, 64);
        assert!(c.pass, "{:?}", c.checks);
        let c = cell("s", &run("env-dvf", 0.1, 1.0, 3.0, &[("rmse", 0.2), ("rmse_same_samples", 0.01)]), "s", 6000, 4, 64);
        assert!(!c.pass);
        // On a map that is not low-frequency the target is judged when `bright` traced its
        // brightest part, and reported as not judged when it did not.
        let c = cell("s", &run("env-dvf", 0.1, 1.0, 3.0, &[("rmse_same_samples", 0.01), ("map_noise", 1.2)]), "s", 6000, 4, 64);
        assert!(c.pass && c.reasons.iter().any(|r| r.contains("not low-frequency")), "{:?} {:?}", c.checks, c.reasons);
        let bright = [("rmse_same_samples", 0.01), ("map_noise", 1.2), ("bright_power", 0.67)];
        assert!(!cell("s", &run("env-dvf", 0.1, 1.0, 3.0, &bright), "s", 6000, 4, 64).pass);
        // E_unshad from the SH: judged against env-exact converged, where env-exact's own N_r
        // rays are too far from it for 0.003 (passes when no further than env-exact's).
        let sh = |dvf: f64, exact: f64| [("rmse_same_samples", 0.006), ("rmse_converged", dvf), ("reference_rmse_converged", exact)];
        let c = cell("s", &run("env-dvf", 0.1, 1.0, 3.0, &sh(0.005, 0.008)), "s", 6000, 4, 64);
        assert!(c.pass && c.reasons.iter().any(|r| r.contains("out of N_r rays' reach")), "{:?} {:?}", c.checks, c.reasons);
        assert!(!cell("s", &run("env-dvf", 0.1, 1.0, 3.0, &sh(0.009, 0.008)), "s", 6000, 4, 64).pass);
        // Converged rays close enough for the target: then the target is judged against them.
        assert!(!cell("s", &run("env-dvf", 0.1, 1.0, 3.0, &sh(0.0035, 0.002)), "s", 6000, 4, 64).pass);
        assert!(cell("s", &run("env-dvf", 0.1, 1.0, 3.0, &sh(0.0025, 0.002)), "s", 6000, 4, 64).pass);
    }

    #[test]
    fn pixel_faults_count_nan_and_black_where_lit_but_not_noise() {
        let reference = Image::from_fn(16, 16, |_, _| Vec3::splat(1.0));
        // A lone dark pixel (noise) is not counted; a black 4 × 4 block is; one NaN is.
        let image = Image::from_fn(16, 16, |x, y| {
            let lone = x == 2 && y == 2;
            let block = (8..12).contains(&x) && (8..12).contains(&y);
            if lone || block {
                Vec3::ZERO
            } else if x == 15 && y == 0 {
                Vec3::splat(f32::NAN)
            } else {
                Vec3::splat(1.0)
            }
        });
        let f = PixelFaults::count(&image, &reference);
        println!("faults {f:?}");
        assert_eq!(f.nan_inf, 1);
        // The 4 × 4 block's 3 × 3 means are ≤ 1/3 at its border and 0 inside: only the inner
        // 2 × 2 are under 10 % of the reference.
        assert_eq!(f.black_where_lit, 4);
        assert_eq!((f.lit, f.black_reference_level), (256, 1.0), "every pixel of a uniform reference is lit, at its mean");
        let same = PixelFaults::count(&reference, &reference);
        assert_eq!((same.nan_inf, same.black_where_lit, same.lit, same.over_twice), (0, 0, 256, 0));
        // A glint: a 3 × 3 block at 4× the reference. Its 3 × 3 means are 4 at the centre, 3 at
        // the edges, 2.33 at the corners (over twice: 9 pixels), exactly 2 beside an edge (not over).
        let glint = Image::from_fn(16, 16, |x, y| Vec3::splat(if (4..7).contains(&x) && (4..7).contains(&y) { 4.0 } else { 1.0 }));
        assert_eq!(PixelFaults::count(&glint, &reference).over_twice, 9);
        // A lone firefly of the reference in a dark area: the technique, dark there, is not black
        // where lit; a two-pixel lit area is still judged.
        let dark = Image::from_fn(16, 16, |_, _| Vec3::splat(0.01));
        let fireflies =
            Image::from_fn(16, 16, |x, y| Vec3::splat(if (x, y) == (4, 4) || ((10..12).contains(&x) && y == 10) { 50.0 } else { 0.01 }));
        let f_fly = PixelFaults::count(&dark, &fireflies);
        println!("under fireflies {f_fly:?}");
        assert!(f_fly.black_where_lit > 0 && f_fly.black_where_lit <= 12, "only around the two-pixel area: {f_fly:?}");
        let lone = Image::from_fn(16, 16, |x, y| Vec3::splat(if (x, y) == (4, 4) { 50.0 } else { 0.01 }));
        assert_eq!(PixelFaults::count(&dark, &lone).black_where_lit, 0);
        let reason = black_where_lit_reason("ao-roma", f);
        assert!(reason.starts_with("4 of 256 lit pixels (1.56 %)") && reason.contains("1.00× its image mean"), "{reason}");
        // Faults two renders share: the black block and the glint against one with the same
        // glint and another black block overlapping one column of the first's inner 2 × 2.
        let other = Image::from_fn(16, 16, |x, y| {
            let glint = (4..7).contains(&x) && (4..7).contains(&y);
            let block = (9..13).contains(&x) && (8..12).contains(&y);
            Vec3::splat(if glint {
                4.0
            } else if block {
                0.0
            } else {
                1.0
            })
        });
        let both =
            Image::from_fn(16, 16, |x, y| if (4..7).contains(&x) && (4..7).contains(&y) { Vec3::splat(4.0) } else { image.get(x, y) });
        assert_eq!(PixelFaults::shared(&both, &other, &reference), (2, 9));
        assert_eq!(PixelFaults::shared(&reference, &other, &reference), (0, 0));
    }

    #[test]
    fn every_suite_scene_loads_and_has_a_description() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/suite");
        let scenes = discover(&dir).unwrap();
        assert!(scenes.len() >= 8, "the suite has {} scenes, the issue asks for at least 8", scenes.len());
        for s in &scenes {
            assert!(!s.description.is_empty(), "{} has no description comment", s.name);
            match &s.missing {
                Some(reason) => println!("skipped: {}: {reason}", s.name),
                None => {
                    let scene = glimpse_scene::load(&s.file.display().to_string()).unwrap();
                    let triangles: usize = scene.meshes.iter().map(|m| m.indices.len()).sum();
                    println!(
                        "{}: {triangles} triangles, {} lights, environment {}",
                        s.name,
                        scene.lights.len(),
                        scene.environment.is_some()
                    );
                    assert!(triangles > 0);
                    if s.name == "million-triangles" {
                        assert!(triangles >= 1_000_000, "{triangles} triangles");
                    }
                }
            }
        }
    }
}
