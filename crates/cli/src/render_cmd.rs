//! `glimpse render SCENE -t ID -o OUT`: one image, with a progress bar for long renders and a
//! summary line.

use crate::args::{check_output, check_scene, check_technique, parse_size, parse_spp, parse_time};
use crate::scene_args::SceneArgs;
use anyhow::{Context, Result};
use clap::Args;
use glimpse_core::ToneMap;
use glimpse_eval::progress::{with_progress, with_spinner};
use glimpse_render::{FrameContext, Params, Settings, Stopwatch};
use std::path::PathBuf;

#[derive(Args)]
pub struct RenderArgs {
    /// A built-in scene (see `glimpse scenes`) or a .gltf, .glb, .obj, .ply, .toml or Mitsuba 3 .xml file.
    pub scene: String,
    /// Technique id (see `glimpse techniques`).
    #[arg(short, long)]
    pub technique: String,
    /// Image size, WIDTHxHEIGHT [default: the scene file's (Mitsuba film), else 512x512].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Samples per pixel [default: the scene file's (Mitsuba sampler), else 16].
    #[arg(long, value_parser = parse_spp)]
    pub spp: Option<u32>,
    /// Scene time in seconds (for animated scenes).
    #[arg(long, default_value_t = 0.0, value_parser = parse_time)]
    pub time: f32,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Technique parameter, key=value (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Output image: .png (tone-mapped sRGB), .exr or .hdr (linear).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write these AOVs as channel groups of the .exr output: albedo, normal, depth,
    /// position (comma-separated; e.g. for a denoiser).
    #[arg(long, value_name = "LIST", value_parser = crate::aov::parse_aovs)]
    pub aov: Option<crate::aov::AovList>,
    /// Stream the image to a running tev (HOST:PORT, default 127.0.0.1:14158) after every film
    /// pass (`--film-samples N` gives N updates as the image converges).
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1, default_missing_value = glimpse_core::tev::DEFAULT_ADDRESS)]
    pub tev: Option<String>,
    /// Where the technique runs: cpu, or gpu (ao-exact, lights-exact, env-exact, ao-roma,
    /// lights-voxarray; built with `--features gpu`).
    #[arg(long, value_enum, default_value_t = crate::device::Device::Cpu)]
    pub device: crate::device::Device,
    #[command(flatten)]
    pub overrides: SceneArgs,
}

pub fn run(a: RenderArgs) -> Result<()> {
    check_output(&a.output)?;
    if a.aov.is_some() && !a.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        anyhow::bail!("--aov: AOVs are written as channels of an .exr output, not {}", a.output.display());
    }
    if !a.exposure.is_finite() || a.exposure.abs() > 64.0 {
        anyhow::bail!("--exposure {}: must be a finite number of stops within ±64", a.exposure);
    }
    check_technique(&a.technique)?;
    check_scene(&a.scene)?;
    let registry = crate::device::registry(a.device, &[&a.technique])?;
    let mut scene = glimpse_scene::load(&a.scene)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    a.overrides.apply(&mut scene)?;
    // A scene file's own settings (Mitsuba's film, sampler, integrator) stand in for flags not given.
    let hints = &scene.render_hints;
    let (width, height) = a.size.or(hints.size).unwrap_or((512, 512));
    glimpse_core::memory_budget::check_frame(width, height)?;
    let spp = a.spp.or(hints.spp).unwrap_or(16);
    let mut set = a.set.clone();
    if let Some(depth) = hints.max_depth
        && a.technique == "pt"
        && !set.iter().any(|s| s.starts_with("max_depth="))
    {
        set.push(format!("max_depth={depth}"));
    }
    let params = Params::parse(&set)?;
    let settings = Settings { spp, seed: a.seed };
    let mut technique = registry.create(&a.technique, &scene, &settings, &params)?;

    let total = Stopwatch::start();
    let sw = Stopwatch::start();
    let mut ctx = with_spinner("building the scene's tracer", || FrameContext::new(&scene, a.time, width, height));
    let tracer_ms = sw.ms();
    // tev: an image named after the technique and scene, updated after every pass.
    let mut tev = match &a.tev {
        Some(address) => {
            let name = format!("{} {}", a.technique, a.scene);
            Some(
                glimpse_core::tev::Tev::connect(address, &name, width, height)
                    .with_context(|| format!("--tev: cannot reach tev at {address}"))?,
            )
        }
        None => None,
    };
    let prepare = with_spinner(&format!("preparing {}", a.technique), || technique.prepare(&ctx))?;
    let mut stream = |partial: &glimpse_core::Image| {
        // A viewer that went away does not stop the render.
        if let Some(Err(e)) = tev.as_mut().map(|t| t.update(partial)) {
            eprintln!("warning: --tev: {e}; not streaming any more");
            tev = None;
        }
    };
    let listening = a.tev.is_some();
    let (image, render) =
        render_film(technique.as_mut(), &mut ctx, listening.then_some(&mut stream as &mut dyn FnMut(&glimpse_core::Image)))?;
    let total_ms = total.ms();

    match &a.aov {
        // The first pass's GBuffer (the film's first sample of every pixel).
        Some(aovs) => {
            (ctx.film_pass, ctx.frame_index) = (0, 0);
            image.write_exr_with_channels(&a.output, &crate::aov::channels(&ctx.gbuffer(), &aovs.0))
        }
        None => image.write(&a.output, ToneMap { exposure: a.exposure }),
    }
    .context("writing the image")?;
    // A "ray" is whatever the technique counts as one visibility query; a technique that traces
    // none (wavecache reads a cache) gets no figure rather than a meaningless 0.00.
    let throughput = match render.rays {
        0 => "no rays traced".to_owned(),
        rays => format!("{:.2} Mrays/s (visibility queries during render)", rays as f64 / (render.total_ms().max(1e-9) * 1e3)),
    };
    // Every stage, so the parts add up to the total: the tracer, the technique's own stages, and
    // what is neither (the GBuffers, untimed measurements such as ε, writing the image).
    let stages = |s: &glimpse_render::Stats| s.stages.iter().map(|(n, ms)| format!("{n} {ms:.1}")).collect::<Vec<_>>().join(", ");
    let other = total_ms - tracer_ms - prepare.total_ms() - render.total_ms();
    println!(
        "{} on {} at {width}x{height}, {} spp, {} filter x {} samples: tracer {tracer_ms:.1} ms + prepare {:.1} ms [{}] + render {:.1} ms [{}] + other {other:.1} ms (GBuffers, untimed measurements) = total {:.1} ms, {} -> {}",
        a.technique,
        a.scene,
        spp,
        ctx.film.filter.name(),
        ctx.film.samples,
        prepare.total_ms(),
        stages(&prepare),
        render.total_ms(),
        stages(&render),
        total_ms,
        throughput,
        a.output.display()
    );
    // What the technique measured or chose from the scene (ε, the automatic budgets, the cell
    // size a fixed resolution gives this scene), so a parameter that could not be chosen well
    // is visible beside the time.
    let measured: Vec<String> = prepare.metrics.iter().chain(&render.metrics).map(|(k, v)| format!("{k}={}", format_measure(*v))).collect();
    if !measured.is_empty() {
        println!("{}: {}", a.technique, measured.join(", "));
    }
    Ok(())
}

/// Whole numbers as such, small ones in scientific notation, others to 4 decimals.
fn format_measure(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else if v.abs() < 1e-3 {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}

/// Renders `ctx.film.samples` passes, pass `p` shading primary sample `p` of every pixel (and
/// drawing its random numbers as frame `p`), and averages them; a technique that blends its own
/// history (it times an `accumulate` stage) already returns the average. Returns the image and
/// the passes' summed stats.
fn render_film(
    technique: &mut dyn glimpse_render::Technique,
    ctx: &mut FrameContext,
    mut on_pass: Option<&mut dyn FnMut(&glimpse_core::Image)>,
) -> Result<(glimpse_core::Image, glimpse_render::Stats)> {
    let passes = ctx.film.samples.max(1);
    let mut sum = ctx.image();
    let mut stats = glimpse_render::Stats::default();
    let mut image = ctx.image();
    for pass in 0..passes {
        ctx.film_pass = pass;
        ctx.frame_index = pass;
        let gbuffer = ctx.gbuffer();
        let label = if passes > 1 {
            format!("rendering {} (pass {}/{passes})", technique.id(), pass + 1)
        } else {
            format!("rendering {}", technique.id())
        };
        let s = with_progress(&label, ctx, || technique.render(ctx, &gbuffer, &mut image))?;
        let self_accumulating = s.stages.iter().any(|(stage, _)| stage == "accumulate");
        if self_accumulating || passes == 1 {
            sum = image.clone();
            if let Some(f) = on_pass.as_mut() {
                f(&sum);
            }
        } else {
            sum.pixels.iter_mut().zip(&image.pixels).for_each(|(t, p)| *t += *p / passes as f32);
            if let Some(f) = on_pass.as_mut() {
                // The passes so far, at full brightness (only made for a listener).
                let mut so_far = sum.clone();
                so_far.pixels.iter_mut().for_each(|p| *p *= passes as f32 / (pass + 1) as f32);
                f(&so_far);
            }
        }
        stats.merge(s);
    }
    Ok((sum, stats))
}
