//! The viewer window: the image (or technique | reference split, or their error), a side panel
//! with the technique, compare mode, tone mapping, stage times and the camera, and mouse/keyboard
//! camera control (orbit: left drag; pan: right drag; dolly: wheel; fly: W A S D Q E).

use super::worker::{History, MAX_SCRUB_STEP_S, Request, StageTimes, Update, Which};
use eframe::egui;
use glimpse_core::{Image, ToneMap, Vec3};
use glimpse_render::metrics::{ErrorMapKind, error_map, magma};
use glimpse_render::params::{ParamInfo, ParamKind};
use glimpse_scene::Camera;
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, Sender};
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compare {
    Off,
    /// Technique left of a draggable divider, reference right.
    Split,
    /// The reference alone (a toggle).
    Reference,
    /// FLIP error of the technique against the converging reference.
    Error,
}

/// Headless runs: after `frames` full-size passes are shown, save a screenshot of the image and
/// close.
pub struct Script {
    pub frames: u32,
    pub screenshot: PathBuf,
    /// Applied once the first full-size pass is shown, before counting frames: a camera orbit
    /// (degrees around the up axis) and a technique switch, to exercise both paths.
    pub orbit_degrees: Option<f32>,
    pub switch_to: Option<String>,
    /// Parameters set once the first image is shown, through the path a widget's release takes.
    pub set_params: Vec<(String, String)>,
    /// Time steps of 1/[`PLAY_FPS`] s taken after that, each once the view has converged, through
    /// the path the time slider takes (each continues the temporal history).
    pub step_time: u32,
}

/// Scene time per frame of the scripted time steps: `glimpse play`'s default `--fps`.
pub const PLAY_FPS: f32 = 30.0;

/// One technique parameter in the side panel: what the technique read (kind, range, default,
/// value) and the widget's state.
struct ParamWidget {
    info: ParamInfo,
    /// The slider's value (numeric kinds).
    number: f64,
    /// The text field's contents (text, and the fallback beside a slider whose range is clamped).
    text: String,
}

impl ParamWidget {
    fn new(info: ParamInfo) -> Self {
        let number = info.value.parse().unwrap_or(0.0);
        Self { text: info.value.clone(), number, info }
    }
}

/// A slider for a numeric parameter: its range, and how it moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SliderRange {
    pub lo: f64,
    pub hi: f64,
    pub integer: bool,
    /// Logarithmic where the range spans three orders of magnitude or more.
    pub logarithmic: bool,
    /// The parameter's own range is wider than the slider's (u32::MAX, infinity): a text field
    /// beside the slider takes any value `--set` takes.
    pub clamped: bool,
}

/// The slider for a numeric kind with this default, or `None` for the other kinds. A range
/// wider than 100 times the default's magnitude (at least 1; 1000 for an infinite default) is
/// clamped to that; the slider is logarithmic where its range spans a factor of 1000 or more
/// (from the smallest positive value it can reach: 1 for integers).
pub fn slider_range(kind: &ParamKind, default: &str) -> Option<SliderRange> {
    let (min, max, integer) = match *kind {
        ParamKind::F32 { min, max } => (min as f64, max as f64, false),
        ParamKind::U32 { min, max } => (min as f64, max as f64, true),
        ParamKind::I64 { min, max } => (min as f64, max as f64, true),
        _ => return None,
    };
    let default: f64 = default.parse().unwrap_or(0.0);
    let span = if default.is_finite() { 100.0 * default.abs().max(1.0) } else { 1000.0 };
    let (lo, hi) = (min.max(-span), max.min(span.max(min + 1.0)));
    let smallest = if lo > 0.0 {
        lo
    } else if integer {
        1.0
    } else {
        hi * 1e-4
    };
    let logarithmic = lo >= 0.0 && hi / smallest >= 1000.0;
    Some(SliderRange { lo, hi, integer, logarithmic, clamped: lo > min || hi < max })
}

/// The range or choices of a kind, for a hover text.
fn describe_kind(kind: &ParamKind) -> String {
    match kind {
        ParamKind::F32 { min, max } => format!("a number in [{min}, {max}]"),
        ParamKind::U32 { min, max } => format!("an integer in [{min}, {max}]"),
        ParamKind::I64 { min, max } => format!("an integer in [{min}, {max}]"),
        ParamKind::Bool => "true or false".to_owned(),
        ParamKind::Choice(c) => format!("one of {}", c.join(", ")),
        ParamKind::Text => "a word or a number".to_owned(),
    }
}

/// A slider value as `--set` spells it: an integer, or the float the technique would read.
fn format_number(v: f64, integer: bool) -> String {
    if integer { format!("{}", v.round() as i64) } else { (v as f32).to_string() }
}

pub struct ViewerApp {
    pub request: Request,
    pub techniques: Vec<String>,
    pub references: Vec<Option<String>>,
    pub scene_camera: Camera,
    /// The scene as given on the command line and its overrides, for "save eval".
    pub scene_spec: String,
    pub overrides: glimpse_scene::SceneOverrides,
    requests: Sender<Request>,
    updates: Receiver<Update>,
    compare: Compare,
    split: f32,
    exposure: f32,
    images: [Option<(Image, u32)>; 2],
    texture: Option<egui::TextureHandle>,
    shown: Option<(u64, Which, u32, Compare, f32, f32)>,
    stage: Option<String>,
    error: Option<String>,
    times: (StageTimes, StageTimes),
    /// Rays per second and memory of the technique's last pass.
    throughput: (f64, usize),
    /// The technique's parameters as it read them, with their widgets' state.
    params: Vec<ParamWidget>,
    /// The temporal history of the last image.
    history: History,
    /// When the current generation was requested, and the time to its first image on screen
    /// (milliseconds, and the image's size).
    first_frame: Option<(f64, (u32, u32))>,
    /// The render thread's side of it: request to picked up, and to image ready (milliseconds).
    first_frame_worker: Option<(f64, f64)>,
    /// The scene time the window started at (scripted time steps count from it).
    start_time: f32,
    steps_done: u32,
    false_colour: bool,
    /// Animated scenes: playing, and the scene time when play started.
    pub animated: bool,
    playing: Option<(Instant, f32)>,
    last_frame: Instant,
    fps: f32,
    pub script: Option<Script>,
    scripted: bool,
    full_frames_seen: u32,
    screenshot_requested: bool,
}

/// The camera as `--camera`'s value (`pos=…:target=…:fov=…`).
fn camera_arg(c: &Camera) -> String {
    let v = |p: Vec3| format!("{},{},{}", p.x, p.y, p.z);
    format!("pos={}:target={}:fov={}", v(c.position), v(c.target), c.fov.to_degrees())
}

impl ViewerApp {
    pub fn new(
        request: Request,
        scene_camera: Camera,
        scene_spec: String,
        overrides: glimpse_scene::SceneOverrides,
        requests: Sender<Request>,
        updates: Receiver<Update>,
    ) -> Self {
        let registry = glimpse_eval::registry();
        let techniques: Vec<String> = registry.all().iter().map(|t| t.id.to_owned()).collect();
        let references = registry.all().iter().map(|t| t.reference.map(str::to_owned)).collect();
        let compare = if request.compare.is_some() { Compare::Split } else { Compare::Off };
        let start_time = request.time;
        let app = Self {
            start_time,
            request,
            techniques,
            references,
            scene_camera,
            scene_spec,
            overrides,
            requests,
            updates,
            compare,
            split: 0.5,
            exposure: 0.0,
            images: [None, None],
            texture: None,
            shown: None,
            stage: None,
            error: None,
            times: (Vec::new(), Vec::new()),
            throughput: (0.0, 0),
            params: Vec::new(),
            history: History::default(),
            first_frame: None,
            first_frame_worker: None,
            steps_done: 0,
            false_colour: false,
            animated: false,
            playing: None,
            last_frame: Instant::now(),
            fps: 0.0,
            script: None,
            scripted: false,
            full_frames_seen: 0,
            screenshot_requested: false,
        };
        let _ = app.requests.send(app.request.clone());
        app
    }

    /// Sends the current request as a new generation; images of older ones are dropped.
    fn resubmit(&mut self) {
        self.request.generation += 1;
        self.images = [None, None];
        self.error = None;
        self.request.sent = Instant::now();
        self.first_frame = None;
        self.first_frame_worker = None;
        let _ = self.requests.send(self.request.clone());
    }

    fn reference_of(&self, id: &str) -> Option<String> {
        let i = self.techniques.iter().position(|t| t == id)?;
        self.references[i].clone()
    }

    fn set_technique(&mut self, id: String) {
        if id != self.request.technique {
            // Another technique reads other keys: start from its defaults.
            self.request.set.clear();
            self.params.clear();
        }
        self.request.compare = if self.compare == Compare::Off { None } else { self.reference_of(&id) };
        self.request.technique = id;
        self.resubmit();
    }

    /// Sets one technique parameter (what a widget does on release, and `--set-param`): the key
    /// joins the request's `--set` list, replacing an earlier value, and the view restarts.
    fn apply_param(&mut self, key: &str, value: &str) {
        let current = self.params.iter().find(|p| p.info.key == key).map(|p| p.info.value.as_str());
        let given = self.request.set.iter().any(|kv| kv.split_once('=').is_some_and(|(k, _)| k.trim() == key));
        if current == Some(value) && !given {
            return;
        }
        self.request.set.retain(|kv| kv.split_once('=').is_none_or(|(k, _)| k.trim() != key));
        self.request.set.push(format!("{key}={value}"));
        if let Some(p) = self.params.iter_mut().find(|p| p.info.key == key) {
            p.info.value = value.to_owned();
        }
        self.resubmit();
    }

    /// Moves the scene to `time` (the slider, play, and scripted steps): the render thread
    /// advances its technique there, carrying a temporal history over a forward step.
    fn set_time(&mut self, time: f32, playing: bool) {
        if time != self.request.time {
            self.request.time = time;
            self.request.playing = playing;
            self.resubmit();
        }
    }

    /// The parameter widgets: a slider per numeric key (integer, logarithmic or clamped with a
    /// text field beside it as the range asks), a checkbox per bool, a combo box per choice and a
    /// text field per text key. A change applies when the slider is released (a drag does not
    /// restart the render every frame), a box is ticked, a choice made or a field left.
    fn param_widgets(&mut self, ui: &mut egui::Ui) {
        let mut apply: Option<(String, String)> = None;
        for p in &mut self.params {
            let key = p.info.key.clone();
            let hover = format!("default {}; {}", p.info.default, describe_kind(&p.info.kind));
            ui.horizontal(|ui| match &p.info.kind {
                ParamKind::Bool => {
                    let mut on = p.info.value == "true";
                    if ui.checkbox(&mut on, key.as_str()).on_hover_text(&hover).changed() {
                        apply = Some((key.clone(), on.to_string()));
                    }
                }
                ParamKind::Choice(choices) => {
                    let mut chosen = p.info.value.clone();
                    egui::ComboBox::from_label(key.as_str()).selected_text(&chosen).show_ui(ui, |ui| {
                        for c in choices {
                            ui.selectable_value(&mut chosen, c.clone(), c);
                        }
                    });
                    if chosen != p.info.value {
                        apply = Some((key.clone(), chosen));
                    }
                }
                kind => match slider_range(kind, &p.info.default) {
                    Some(range) => {
                        let slider = egui::Slider::new(&mut p.number, range.lo..=range.hi)
                            .logarithmic(range.logarithmic)
                            .clamping(egui::SliderClamping::Edits)
                            .update_while_editing(false)
                            .text(key.as_str());
                        let slider = if range.integer { slider.integer() } else { slider.smallest_positive(range.hi * 1e-4) };
                        let r = ui.add(slider).on_hover_text(&hover);
                        if r.drag_stopped() || (r.changed() && !r.dragged()) {
                            apply = Some((key.clone(), format_number(p.number, range.integer)));
                        }
                        if range.clamped {
                            let r = ui.add(egui::TextEdit::singleline(&mut p.text).desired_width(60.0)).on_hover_text(&hover);
                            if r.lost_focus() {
                                apply = Some((key.clone(), p.text.trim().to_owned()));
                            }
                        }
                    }
                    None => {
                        ui.label(key.as_str());
                        if ui.text_edit_singleline(&mut p.text).on_hover_text(&hover).lost_focus() {
                            apply = Some((key.clone(), p.text.trim().to_owned()));
                        }
                    }
                },
            });
        }
        if let Some((key, value)) = apply {
            self.apply_param(&key, &value);
        }
    }

    fn receive(&mut self) {
        while let Ok(u) = self.updates.try_recv() {
            match u {
                Update::Stage { generation, text } if generation == self.request.generation => self.stage = Some(text),
                Update::Error { generation, message } if generation == self.request.generation => {
                    self.stage = None;
                    self.error = Some(message);
                }
                Update::Frame {
                    generation,
                    which,
                    image,
                    passes,
                    prepare,
                    render,
                    rays,
                    memory_bytes,
                    history,
                    picked_up_ms,
                    ready_ms,
                } if generation == self.request.generation => {
                    self.stage = None;
                    if which == Which::Technique {
                        self.first_frame_worker.get_or_insert((picked_up_ms, ready_ms));
                        self.history = history;
                        let ms: f64 = render.iter().map(|s| s.1).sum();
                        self.throughput = (rays as f64 / (ms.max(1e-6) * 1e-3), memory_bytes);
                        self.times = (prepare, render);
                    }
                    self.images[which as usize] = Some((image, passes));
                }
                Update::Params { generation, which: Which::Technique, params } if generation == self.request.generation => {
                    self.params = params.into_iter().map(ParamWidget::new).collect();
                }
                _ => {}
            }
        }
    }

    /// What the image area shows now, tone mapped.
    fn composed(&self) -> Option<Image> {
        let (technique, _) = self.images[0].as_ref()?;
        let reference = self.images[1].as_ref().map(|(r, _)| r).filter(|r| (r.width, r.height) == (technique.width, technique.height));
        Some(match (self.compare, reference) {
            (Compare::Reference, Some(r)) => r.clone(),
            (Compare::Split, Some(r)) => {
                let divide = (self.split * technique.width as f32) as u32;
                Image::from_fn(technique.width, technique.height, |x, y| if x < divide { technique.get(x, y) } else { r.get(x, y) })
            }
            (Compare::Error, Some(r)) => error_map(technique, r, ErrorMapKind::FlipHdr).unwrap_or_else(|_| technique.clone()),
            _ if self.false_colour => {
                // Luminance × 2^exposure on the magma map, 1 at the top.
                let scale = self.exposure.exp2();
                Image::from_fn(technique.width, technique.height, |x, y| {
                    let p = technique.get(x, y);
                    magma((0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z) * scale)
                })
            }
            _ => technique.clone(),
        })
    }

    /// "save eval": `glimpse eval` of the current technique at the current camera, time, size,
    /// spp and parameters, in the background, into `glimpse-view-eval-<technique>-<n>/`.
    fn save_eval(&mut self) {
        let r = &self.request;
        let out_dir = PathBuf::from(format!("glimpse-view-eval-{}-{}", r.technique, r.generation));
        let cfg = glimpse_eval::experiment::EvalConfig {
            scene_spec: self.scene_spec.clone(),
            techniques: vec![r.technique.clone()],
            approximate_only: false,
            width: r.size.0,
            height: r.size.1,
            spp: r.spp,
            ref_spp: 256,
            seed: 0,
            time: r.time,
            params: r.set.clone(),
            out_dir: out_dir.clone(),
            cache: glimpse_eval::cache::Cache { dir: glimpse_eval::cache::Cache::default_dir() },
            sweep: false,
            exposure: self.exposure,
            frames: r.max_passes.min(16),
            overrides: glimpse_scene::SceneOverrides { camera: Some(r.camera.clone()), ..self.overrides.clone() },
            time_reference: true,
            tev: None,
        };
        eprintln!("saving an eval run to {} (in the background)", out_dir.display());
        std::thread::spawn(move || match glimpse_eval::experiment::run_eval(&cfg, &glimpse_eval::registry(), |m| eprintln!("{m}")) {
            Ok(_) => eprintln!("eval saved: {}", out_dir.join("report.html").display()),
            Err(e) => eprintln!("error: save eval: {e:#}"),
        });
    }

    /// Writes the image as shown (linear EXR and tone-mapped PNG) to the current folder.
    fn save(&mut self) {
        let Some(img) = self.composed() else { return };
        let stem = format!("glimpse-view-{}-{}", self.request.technique, self.request.generation);
        for ext in ["png", "exr"] {
            let path = PathBuf::from(format!("{stem}.{ext}"));
            self.error = img.write(&path, ToneMap { exposure: self.exposure }).err().map(|e| e.to_string());
            if self.error.is_none() {
                eprintln!("saved {}", path.display());
            }
        }
    }

    fn camera_controls(&mut self, response: &egui::Response, ui: &egui::Ui) -> bool {
        let cam = &mut self.request.camera;
        let mut moved = false;
        let to_eye = cam.position - cam.target;
        let distance = to_eye.length().max(1e-6);
        let forward = -to_eye / distance;
        let right = forward.cross(cam.up).normalize_or(Vec3::X);
        if response.dragged_by(egui::PointerButton::Primary) {
            let d = response.drag_delta();
            let yaw = glimpse_core::glam::Quat::from_axis_angle(cam.up.normalize_or(Vec3::Y), -d.x * 0.01);
            let pitch = glimpse_core::glam::Quat::from_axis_angle(right, -d.y * 0.01);
            let eye = pitch * (yaw * to_eye);
            // Stay off the poles, where the up vector and the view direction meet.
            if eye.normalize_or(Vec3::Y).dot(cam.up.normalize_or(Vec3::Y)).abs() < 0.995 {
                cam.position = cam.target + eye;
                moved = true;
            }
        }
        if response.dragged_by(egui::PointerButton::Secondary) {
            let d = response.drag_delta();
            let up = right.cross(forward);
            let shift = (-right * d.x + up * d.y) * distance * 0.002;
            cam.position += shift;
            cam.target += shift;
            moved = true;
        }
        let scroll = if response.hovered() { ui.input(|i| i.smooth_scroll_delta.y) } else { 0.0 };
        if scroll != 0.0 {
            cam.position = cam.target + to_eye * (-scroll * 0.002).exp();
            moved = true;
        }
        let step = distance * 0.02;
        let keys = [
            (egui::Key::W, forward),
            (egui::Key::S, -forward),
            (egui::Key::D, right),
            (egui::Key::A, -right),
            (egui::Key::E, cam.up),
            (egui::Key::Q, -cam.up),
        ];
        for (key, dir) in keys {
            if ui.input(|i| i.key_down(key)) {
                cam.position += dir * step;
                cam.target += dir * step;
                moved = true;
            }
        }
        moved
    }

    fn side_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("glimpse view");
        let mut technique = self.request.technique.clone();
        egui::ComboBox::from_label("technique").selected_text(&technique).show_ui(ui, |ui| {
            for t in &self.techniques {
                ui.selectable_value(&mut technique, t.clone(), t);
            }
        });
        if technique != self.request.technique {
            self.set_technique(technique);
        }
        let before = self.compare;
        ui.horizontal(|ui| {
            ui.label("compare");
            ui.selectable_value(&mut self.compare, Compare::Off, "off");
            ui.selectable_value(&mut self.compare, Compare::Split, "split");
            ui.selectable_value(&mut self.compare, Compare::Reference, "reference");
            ui.selectable_value(&mut self.compare, Compare::Error, "FLIP");
        });
        if (before == Compare::Off) != (self.compare == Compare::Off) {
            self.set_technique(self.request.technique.clone());
        }
        if self.compare == Compare::Split {
            ui.add(egui::Slider::new(&mut self.split, 0.0..=1.0).text("divider"));
        }
        ui.add(egui::Slider::new(&mut self.exposure, -8.0..=8.0).text("exposure (stops)"));
        ui.checkbox(&mut self.false_colour, "false colour (luminance)");
        ui.horizontal(|ui| {
            if ui.button("save PNG + EXR").clicked() {
                self.save();
            }
            if ui.button("save eval").clicked() {
                self.save_eval();
            }
        });
        if self.animated {
            let mut time = self.request.time;
            ui.horizontal(|ui| {
                let label = if self.playing.is_some() { "pause" } else { "play" };
                if ui.button(label).clicked() {
                    self.playing = if self.playing.is_some() { None } else { Some((Instant::now(), time)) };
                }
                ui.add(egui::Slider::new(&mut time, 0.0..=10.0).text("time (s)"));
            });
            if let Some((start, t0)) = self.playing {
                // One step per image, as `play` renders one frame per time: the time moves on
                // (in real time) once the last step's frame is up, or it failed.
                let shown = self.images[0].as_ref().is_some_and(|(_, p)| *p >= 1) || self.error.is_some();
                if shown {
                    time = t0 + start.elapsed().as_secs_f32();
                }
                ui.ctx().request_repaint();
            }
            if time != self.request.time {
                self.set_time(time, self.playing.is_some());
            }
            ui.label(format!(
                "forward steps (play, scrubs of ≤ {MAX_SCRUB_STEP_S} s) carry a temporal history; \
                 a backwards scrub or a larger jump restarts it"
            ));
        }
        if !self.params.is_empty() {
            ui.label("parameters (--set; hover for the default and range)");
            self.param_widgets(ui);
        }
        let mut spp = self.request.spp;
        ui.add(egui::Slider::new(&mut spp, 1..=256).logarithmic(true).text("spp per pass"));
        if spp != self.request.spp {
            self.request.spp = spp;
            self.resubmit();
        }
        ui.separator();
        let passes = self.images[0].as_ref().map_or(0, |(_, p)| *p);
        ui.label(format!("{:.0} fps (window), pass {passes} of {}", self.fps, self.request.max_passes));
        let (rays_per_s, memory) = self.throughput;
        let rays = if rays_per_s > 0.0 { format!("{:.2} M queries/s", rays_per_s * 1e-6) } else { "no rays traced".to_owned() };
        ui.label(format!("{rays}, {:.1} MiB", memory as f64 / (1 << 20) as f64));
        if let Some((ms, (w, h))) = self.first_frame {
            let (picked, ready) = self.first_frame_worker.unwrap_or_default();
            ui.label(format!(
                "first image after the last change: {ms:.0} ms ({w}×{h}; ready after {ready:.0} ms, picked up after {picked:.0} ms)"
            ));
        }
        let temporal = self.times.1.iter().any(|(s, _)| s == "accumulate");
        let window = self.params.iter().find(|p| p.info.key == "accumulate").map(|p| p.info.value.clone());
        if temporal {
            let window = window.map(|w| format!(", window {w}")).unwrap_or_default();
            ui.label(format!("temporal history: {} frames{window} ({})", self.history.frames, self.history.note));
        } else {
            ui.label(format!("no temporal history: {passes} passes of this time averaged; a time step starts a new average"));
        }
        if let Some(stage) = &self.stage {
            ui.horizontal(|ui| {
                ui.spinner();
                ui.label(stage);
            });
        }
        if let Some(e) = &self.error {
            ui.colored_label(egui::Color32::LIGHT_RED, e);
        }
        for (what, stages) in [("prepare", &self.times.0), ("last pass", &self.times.1)] {
            let total: f64 = stages.iter().map(|s| s.1).sum();
            ui.label(format!("{what}: {total:.1} ms"));
            for (name, ms) in stages {
                ui.label(format!("   {name}: {ms:.1} ms"));
            }
        }
        if let (Compare::Split | Compare::Error | Compare::Reference, Some((t, _)), Some((r, rp))) =
            (self.compare, &self.images[0], &self.images[1])
            && (t.width, t.height) == (r.width, r.height)
            && let Ok(m) = glimpse_render::metrics::Metrics::compute(t, r)
        {
            ui.label(format!("vs reference ({rp} passes): RMSE {:.4}, FLIP {:.4}", m.rmse, m.flip));
        }
        ui.separator();
        let arg = format!("--camera {}", camera_arg(&self.request.camera));
        ui.label("camera");
        ui.add(egui::TextEdit::multiline(&mut arg.clone()).desired_rows(2));
        ui.horizontal(|ui| {
            if ui.button("copy").clicked() {
                ui.ctx().copy_text(arg.clone());
            }
            if ui.button("reset").clicked() {
                self.request.camera = self.scene_camera.clone();
                self.resubmit();
            }
        });
        let mut fov = self.request.camera.fov.to_degrees();
        if ui.add(egui::Slider::new(&mut fov, 5.0..=120.0).text("fov (°)")).changed() {
            self.request.camera.fov = fov.to_radians();
            self.resubmit();
        }
    }

    fn run_script(&mut self, ctx: &egui::Context) {
        let Some(script) = &self.script else { return };
        let full = self.images[0].as_ref().is_some_and(|(_, p)| *p >= 1);
        if !full {
            return;
        }
        let passes = self.images[0].as_ref().map_or(0, |(_, p)| *p);
        if !self.scripted {
            self.scripted = true;
            let (orbit, switch, set) = (script.orbit_degrees, script.switch_to.clone(), script.set_params.clone());
            if let Some(deg) = orbit {
                let cam = &mut self.request.camera;
                let q = glimpse_core::glam::Quat::from_axis_angle(cam.up.normalize_or(Vec3::Y), deg.to_radians());
                cam.position = cam.target + q * (cam.position - cam.target);
            }
            match switch {
                Some(id) => self.set_technique(id),
                None if orbit.is_some() => self.resubmit(),
                None => {}
            }
            for (key, value) in set {
                self.apply_param(&key, &value);
            }
            return;
        }
        // Time steps, each once the view has converged at the last time (so every step gets
        // the same number of frames, whatever the machine's speed).
        if self.steps_done < script.step_time {
            if passes >= self.request.max_passes {
                self.steps_done += 1;
                // As `play` computes its frames' times.
                let time = self.start_time + self.steps_done as f32 / PLAY_FPS;
                self.set_time(time, false);
            }
            ctx.request_repaint();
            return;
        }
        // The frame after the one that first shows enough passes: the texture is on screen then.
        if passes >= script.frames && !self.screenshot_requested {
            self.full_frames_seen += 1;
        }
        if self.full_frames_seen >= 2 && !self.screenshot_requested {
            self.screenshot_requested = true;
            let path = script.screenshot.clone();
            let (w, h) = self.request.size;
            // What to pass to `glimpse render` for the same view.
            println!("camera: {}", camera_arg(&self.request.camera));
            println!("technique: {}", self.request.technique);
            println!("time: {}", self.request.time);
            println!("set: {}", self.request.set.join(" "));
            println!("history: {} frames ({})", self.history.frames, self.history.note);
            println!("window: {:.0} ms per frame", 1e3 / self.fps.max(1e-3));
            let ctx2 = ctx.clone();
            ctx.request_screenshot(move |shot| {
                // The image is drawn at one texel per physical pixel at the window's top-left
                // corner of the central panel: crop that region; the whole window goes beside it.
                let save = |img: &egui::ColorImage, path: &std::path::Path| {
                    let rgb: Vec<u8> = img.pixels.iter().flat_map(|c| [c.r(), c.g(), c.b()]).collect();
                    let (w, h) = (img.size[0] as u32, img.size[1] as u32);
                    match ::image::RgbImage::from_raw(w, h, rgb).map(|i| i.save(path)) {
                        Some(Ok(())) => eprintln!("screenshot -> {}", path.display()),
                        other => eprintln!("error: {}: cannot save the screenshot: {other:?}", path.display()),
                    }
                };
                save(&shot.region_by_pixels([0, 0], [w as usize, h as usize]), &path);
                let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                save(&shot, &path.with_file_name(format!("{stem}-window.png")));
                ctx2.send_viewport_cmd(egui::ViewportCommand::Close);
            });
        }
        ctx.request_repaint();
    }
}

impl eframe::App for ViewerApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let now = Instant::now();
        let dt = now.duration_since(self.last_frame).as_secs_f32();
        self.last_frame = now;
        self.fps = if self.fps == 0.0 { 1.0 / dt.max(1e-3) } else { 0.9 * self.fps + 0.1 / dt.max(1e-3) };
        self.receive();
        let ctx = ui.ctx().clone();
        self.run_script(&ctx);
        // The image first, from the window's top-left corner, so a screenshot crop finds it there;
        // the panel has a fixed width (the window is the image's width plus it), so however wide
        // its contents, the image is never squeezed.
        egui::Panel::right("controls")
            .exact_size(300.0)
            .resizable(false)
            .show(ui, |ui| egui::ScrollArea::vertical().show(ui, |ui| self.side_panel(ui)));
        egui::CentralPanel::no_frame().show(ui, |ui| {
            let key = self.images[0].as_ref().map(|(_, p)| *p).zip(Some(self.request.generation));
            let state = key.map(|(p, g)| (g, Which::Technique, p, self.compare, self.split, self.exposure));
            if state != self.shown
                && let Some(img) = self.composed()
            {
                let rgb = img.to_srgb8(ToneMap { exposure: self.exposure });
                let color = egui::ColorImage::from_rgb([img.width as usize, img.height as usize], rgb.as_raw());
                match &mut self.texture {
                    Some(t) => t.set(color, egui::TextureOptions::NEAREST),
                    None => self.texture = Some(ui.ctx().load_texture("render", color, egui::TextureOptions::NEAREST)),
                }
                self.shown = state;
                if self.first_frame.is_none() {
                    // Request to first image uploaded (it is drawn at the end of this frame).
                    let ms = self.request.sent.elapsed().as_secs_f64() * 1e3;
                    self.first_frame = Some((ms, (img.width, img.height)));
                    if self.script.is_some() {
                        let (picked, ready) = self.first_frame_worker.unwrap_or_default();
                        println!(
                            "first frame: {ms:.0} ms ({} {}x{}, generation {}; render thread: picked up after {picked:.0} ms, image ready after {ready:.0} ms)",
                            self.request.technique, img.width, img.height, self.request.generation
                        );
                    }
                }
            }
            let (w, h) = self.request.size;
            let ppp = ui.ctx().pixels_per_point();
            let size = egui::vec2(w as f32, h as f32) / ppp;
            let response = match &self.texture {
                Some(t) => ui.add(egui::Image::new((t.id(), size)).sense(egui::Sense::click_and_drag())),
                None => ui.allocate_response(size, egui::Sense::click_and_drag()),
            };
            if self.compare == Compare::Split && self.images[1].is_some() {
                let x = response.rect.left() + self.split * response.rect.width();
                ui.painter().vline(x, response.rect.y_range(), egui::Stroke::new(1.0, egui::Color32::WHITE));
            }
            if self.camera_controls(&response, ui) {
                self.resubmit();
            }
        });
        if self.stage.is_some() || self.script.is_some() {
            ui.ctx().request_repaint();
        }
    }
}
