//! `report.html`: one self-contained page (images by relative path, the plot as inline SVG)
//! that opens from disk in any browser.

use crate::experiment::EvalResults;
use crate::plot::{Series, html_escape, loglog_svg};
use anyhow::{Context, Result};
use std::fmt::Write;
use std::path::Path;

/// The paper a technique implements or is a baseline of (the report groups its rows by it).
pub fn paper_of(technique: &str) -> &'static str {
    match technique {
        "ao-roma" | "soft-roma" | "gi-roma" | "ao-df" | "soft-df" => {
            "ROMA: ray-aligned occupancy map array (and its distance-field baseline)"
        }
        "lights-voxarray" | "lights-shadowmap" | "lights-ism" => "Directional voxelization array (and its shadow-map and ISM baselines)",
        "env-dvf" => "Discrete visibility fields",
        "vpl-lightcuts" | "vpl-sst" | "vpl-rtslc" => "Stochastic light cuts over VPLs (and its SST and RTSLC variants)",
        "wavecache" => "Haar-wavelet radiance caching",
        _ => "Exact references",
    }
}

/// The order papers are listed in.
const PAPERS: [&str; 6] = [
    "ROMA: ray-aligned occupancy map array (and its distance-field baseline)",
    "Directional voxelization array (and its shadow-map and ISM baselines)",
    "Discrete visibility fields",
    "Stochastic light cuts over VPLs (and its SST and RTSLC variants)",
    "Haar-wavelet radiance caching",
    "Exact references",
];

pub fn write_html(r: &EvalResults, path: &Path) -> Result<()> {
    let mut h = String::new();
    let scene = html_escape(&r.scene);
    let _ = write!(
        h,
        r#"<!doctype html><html><head><meta charset="utf-8"><title>glimpse eval: {scene}</title><style>
body{{font-family:sans-serif;margin:24px;max-width:1400px}} table{{border-collapse:collapse}} td,th{{border:1px solid #ccc;padding:4px 8px;text-align:right}}
th{{background:#f4f4f4}} td:first-child,td:nth-child(2){{text-align:left}} figure{{display:inline-block;margin:4px}} img{{image-rendering:pixelated;width:320px}}
figcaption{{font-size:12px;text-align:center}}</style></head><body>
<h1>glimpse eval: {scene}</h1>
<p>{}×{} pixels, {} spp (references {} spp), seed {}, time {} s. GBuffer {:.1} ms. Peak memory {}.</p>
<h2>Results</h2><table><tr><th>technique</th><th>reference</th><th>prepare ms</th><th>render ms</th><th>total ms</th><th>memory MB</th><th>RMSE</th><th>relMSE</th><th>PSNR dB</th><th>SSIM</th><th>FLIP</th><th>other</th></tr>"#,
        r.size[0],
        r.size[1],
        r.spp,
        r.ref_spp,
        r.seed,
        r.time,
        r.gbuffer_ms,
        r.peak_rss_bytes.map_or("unknown".into(), |b| format!("{:.1} MB", b as f64 / 1048576.0))
    );
    // Measures a technique reports of itself (Stats::metrics), e.g. ε_v and ε_s.
    let other_metrics = |run: &crate::experiment::Run| {
        let standard = ["rmse", "mse", "relmse", "psnr", "ssim", "flip", "flip_ldr"];
        run.metrics
            .iter()
            .filter(|(k, _)| !standard.contains(&k.as_str()))
            .map(|(k, v)| format!("{k} {v:.4}"))
            // Over several frames the times are the median frame's; the first holds the one-time work.
            .chain(run.ms.get("first_frame").map(|f| format!("first of {} frames {f:.1} ms", run.frames)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let metric = |run: &crate::experiment::Run, k: &str| run.metrics.get(k).map_or("–".into(), |v| format!("{v:.5}"));
    let grouped = PAPERS.iter().flat_map(|paper| {
        let runs: Vec<_> = r.runs.iter().filter(|run| paper_of(&run.technique) == *paper).collect();
        (!runs.is_empty()).then_some((paper, runs))
    });
    for (paper, runs) in grouped {
        let _ = write!(h, r#"<tr><th colspan="12" style="text-align:left">{}</th></tr>"#, html_escape(paper));
        for run in runs {
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{}{}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.2}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                html_escape(&run.technique),
                html_escape(&run.reference),
                if run.reference_cached { " (cached)" } else { "" },
                run.ms["prepare"],
                run.ms["render"],
                run.ms["total"],
                run.memory_bytes as f64 / 1048576.0,
                metric(run, "rmse"),
                metric(run, "relmse"),
                metric(run, "psnr"),
                metric(run, "ssim"),
                metric(run, "flip"),
                html_escape(&other_metrics(run))
            );
        }
    }
    h += "</table>";
    for sk in &r.skipped {
        let _ = write!(h, "<p>Not applicable: <b>{}</b>: {}.</p>", html_escape(&sk.technique), html_escape(&sk.reason));
    }
    let series: Vec<Series> = r
        .runs
        .iter()
        .map(|run| Series { name: run.technique.clone(), points: run.sweep.iter().map(|p| (p.ms, p.rmse)).collect() })
        .collect();
    if series.iter().any(|s| !s.points.is_empty()) {
        h += "<h2>Error versus time</h2><p>Each point is one render at fewer samples per pixel; x: prepare + render time (ms), y: RMSE against the reference.</p>";
        h += &loglog_svg(&series, "time (ms)", "RMSE");
    }
    h += "<h2>Images</h2><p>Technique, reference, and the FLIP error map (black: no error, bright: large error).</p>";
    for run in &r.runs {
        let _ = write!(h, "<h3>{}</h3>", html_escape(&run.technique));
        let captions = [
            ("image", format!("{} ({} spp)", run.technique, r.spp)),
            ("reference", format!("reference: {} ({} spp)", run.reference, r.ref_spp)),
            ("error", "HDR-FLIP error".to_owned()),
        ];
        for (key, caption) in &captions {
            if let Some(file) = run.images.get(*key) {
                let _ = write!(
                    h,
                    r#"<figure><img src="{}" alt="{}"><figcaption>{}</figcaption></figure>"#,
                    html_escape(file),
                    html_escape(caption),
                    html_escape(caption)
                );
            }
        }
        let stages: Vec<String> = run
            .ms
            .iter()
            .filter(|(k, _)| !matches!(k.as_str(), "prepare" | "render" | "total"))
            .map(|(k, v)| format!("{} {:.1} ms", html_escape(k), v))
            .collect();
        let params: Vec<String> = run.params.iter().map(|(k, v)| format!("{}={}", html_escape(k), html_escape(v))).collect();
        let _ = write!(
            h,
            "<p>stages: {}; parameters: {}; rays: {}</p>",
            if stages.is_empty() { "–".into() } else { stages.join(", ") },
            if params.is_empty() { "defaults".into() } else { params.join(", ") },
            run.rays
        );
    }
    h += "</body></html>\n";
    glimpse_core::atomic_file::write_bytes_atomic(path, h.as_bytes())
        .with_context(|| format!("{}: cannot write the report", path.display()))
}
