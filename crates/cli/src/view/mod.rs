//! `glimpse view`: an interactive window (eframe/egui on wgpu) to fly through a scene and watch a
//! technique beside its reference. Rendering is the CPU code `render` and `eval` use, on a thread
//! of its own ([`worker`]); the window ([`app`]) only shows images and sends requests, so it never
//! blocks on a long prepare. Built only with `--features viewer`.

mod app;
mod worker;

use crate::args::{check_scene, check_technique, parse_size, parse_spp, parse_time};
use crate::scene_args::SceneArgs;
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ViewArgs {
    /// A built-in scene (see `glimpse scenes`) or a scene file.
    pub scene: String,
    /// Technique shown first (any other can be picked in the window).
    #[arg(short, long, default_value = "ao-roma")]
    pub technique: String,
    /// Show the technique's reference beside it (split screen) from the start.
    #[arg(long)]
    pub compare: bool,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size, default_value = "320x180")]
    pub size: (u32, u32),
    /// Samples per pixel of each pass.
    #[arg(long, value_parser = parse_spp, default_value_t = 1)]
    pub spp: u32,
    /// Scene time in seconds.
    #[arg(long, default_value_t = 0.0, value_parser = parse_time)]
    pub time: f32,
    /// Technique parameter, key=value (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Full-size passes averaged while the view is still.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub passes: u32,
    /// Headless runs: after N full-size passes, save a screenshot (--screenshot) and exit.
    #[arg(long, value_name = "N", requires = "screenshot")]
    pub frames: Option<u32>,
    /// Where --frames saves the screenshot of the image (PNG).
    #[arg(long, value_name = "FILE.png", requires = "frames")]
    pub screenshot: Option<PathBuf>,
    /// Scripted run: orbit the camera this many degrees once the first image is shown.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub orbit: Option<f32>,
    /// Scripted run: switch to this technique once the first image is shown.
    #[arg(long, value_name = "TECHNIQUE")]
    pub switch_to: Option<String>,
    /// Scripted run: set a technique parameter once the first image is shown, as its widget
    /// does (repeatable).
    #[arg(long, value_name = "KEY=VALUE")]
    pub set_param: Vec<String>,
    /// Scripted run: then step the scene time N times by 1/30 s (play's default frame rate),
    /// each once the view has converged, as the time slider does.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub step_time: u32,
    #[command(flatten)]
    pub overrides: SceneArgs,
}

pub fn run(a: ViewArgs) -> Result<()> {
    check_technique(&a.technique)?;
    if let Some(t) = &a.switch_to {
        check_technique(t)?;
    }
    check_scene(&a.scene)?;
    let mut scene = glimpse_scene::load(&a.scene)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    a.overrides.apply(&mut scene)?;
    let (w, h) = a.size;
    let camera = scene.camera_or_default(w as f32 / h as f32);
    let registry = glimpse_eval::registry();
    let compare = if a.compare { registry.get(&a.technique)?.reference.map(str::to_owned) } else { None };
    let request = worker::Request {
        generation: 0,
        technique: a.technique.clone(),
        compare,
        camera: camera.clone(),
        size: a.size,
        time: a.time,
        spp: a.spp,
        set: a.set.clone(),
        max_passes: a.frames.map_or(a.passes, |f| f.max(1)),
        playing: false,
        sent: std::time::Instant::now(),
    };
    // The window lives as long as the process: the render thread may keep a reference to it.
    let scene: &'static glimpse_scene::Scene = Box::leak(Box::new(scene));
    let (scene_spec, overrides) = (a.scene.clone(), a.overrides.overrides());
    let set_params = a
        .set_param
        .iter()
        .map(|kv| kv.split_once('=').map(|(k, v)| (k.trim().to_owned(), v.trim().to_owned())))
        .collect::<Option<Vec<_>>>()
        .with_context(|| format!("--set-param {}: expected key=value", a.set_param.join(" ")))?;
    let script = a.frames.zip(a.screenshot.clone()).map(|(frames, screenshot)| app::Script {
        frames,
        screenshot,
        orbit_degrees: a.orbit,
        switch_to: a.switch_to.clone(),
        set_params,
        step_time: a.step_time,
    });
    let options = eframe::NativeOptions {
        viewport: eframe::egui::ViewportBuilder::default()
            .with_inner_size([w as f32 + 320.0, (h as f32).max(560.0)])
            .with_title("glimpse view"),
        ..Default::default()
    };
    eframe::run_native(
        "glimpse view",
        options,
        Box::new(move |cc| {
            // One texel per physical pixel, so a screenshot crop is the image itself.
            cc.egui_ctx.set_pixels_per_point(1.0);
            let (req_tx, req_rx) = std::sync::mpsc::channel();
            let (upd_tx, upd_rx) = std::sync::mpsc::channel();
            let ctx = cc.egui_ctx.clone();
            worker::spawn(scene, req_rx, upd_tx, move || ctx.request_repaint());
            let mut app = app::ViewerApp::new(request, camera, scene_spec, overrides, req_tx, upd_rx);
            app.script = script;
            app.animated = scene.is_animated();
            Ok(Box::new(app))
        }),
    )
    .map_err(|e| anyhow::anyhow!("the viewer window: {e}"))
    .context("glimpse view needs a display (X11 or Wayland) and a GPU or Mesa's lavapipe")
}
