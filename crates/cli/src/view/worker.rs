//! The viewer's render thread: it owns the scene's frame context and the techniques, renders
//! progressively (a quarter-size preview, then full-size film passes averaged while the view is
//! still) and sends each image back. The window never waits on it: a new request from the window
//! replaces the current one between passes, and a long `prepare` only delays images.
//!
//! Time, as `glimpse play` does it: the scene is advanced in place (`FrameContext::advance`) and
//! the same technique objects are prepared again for the new time (their per-frame rebuild), so a
//! temporal technique (one that blends its own history: ROMA's, the light cuts', the distance
//! fields', which time an `accumulate` stage) keeps that history. A forward step while playing,
//! or a scrub forward by at most [`MAX_SCRUB_STEP_S`], continues the frame indices where the last
//! pass left them (the history goes on, as in an engine); a backwards scrub, a larger jump, or any
//! other change (camera, technique, parameters, spp, size) starts again at frame 0, which
//! restarts every history. Static camera only, as the accumulator is: there is no reprojection.

use glimpse_core::Image;
use glimpse_render::params::ParamInfo;
use glimpse_render::{FrameContext, Params, Settings, Stats, Technique};
use glimpse_scene::{Camera, Scene};
use std::sync::mpsc::{Receiver, Sender, TryRecvError};

/// What the window wants to see.
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// Increases with every change; images carry the generation they were rendered for.
    pub generation: u64,
    pub technique: String,
    /// The reference rendered beside the technique on the same primary samples, if any.
    pub compare: Option<String>,
    pub camera: Camera,
    pub size: (u32, u32),
    pub time: f32,
    pub spp: u32,
    /// `--set` parameters of the technique (the reference gets those it reads).
    pub set: Vec<String>,
    /// Full-size passes after which the view is converged and the thread idles.
    pub max_passes: u32,
    /// Set while playing: every forward time step continues the temporal history, however long
    /// the last frame took.
    pub playing: bool,
    /// When the window sent it (for the first-image latency).
    pub sent: std::time::Instant,
}

/// A scrub forward by at most this much scene time continues the temporal history; a larger
/// jump restarts it.
pub const MAX_SCRUB_STEP_S: f32 = 0.5;

/// The temporal history the technique's last image belongs to.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct History {
    /// Full-size frames (passes) since the history last restarted, across time steps.
    pub frames: u32,
    /// Time steps the history was carried over.
    pub steps: u32,
    /// Why it last restarted, or that it was carried over ("continued over +0.033 s").
    pub note: String,
}

/// What the history depends on besides time: a change to any of these restarts it.
#[derive(Clone, Debug, PartialEq)]
struct HistoryKey {
    technique: String,
    compare: Option<String>,
    camera: Camera,
    size: (u32, u32),
    spp: u32,
    set: Vec<String>,
}

impl HistoryKey {
    fn of(r: &Request) -> Self {
        Self {
            technique: r.technique.clone(),
            compare: r.compare.clone(),
            camera: r.camera.clone(),
            size: r.size,
            spp: r.spp,
            set: r.set.clone(),
        }
    }
}

/// The render thread's timeline: the scene time it is at and the frame indices it has used.
struct Timeline {
    time: f32,
    key: Option<HistoryKey>,
    /// The frame index the next full-size pass continues with.
    next_frame_index: u32,
    history: History,
}

impl Timeline {
    /// Moves to `request`: returns the frame index its first full-size pass uses (0 restarts
    /// every history) and whether it continues the last history.
    fn start(&mut self, request: &Request) -> (u32, bool) {
        let key = HistoryKey::of(request);
        let step = request.time - self.time;
        let same_view = self.key.as_ref() == Some(&key);
        let continues = same_view && step > 0.0 && (request.playing || step <= MAX_SCRUB_STEP_S);
        self.history = if continues {
            History { note: format!("continued over +{step:.3} s"), steps: self.history.steps + 1, ..self.history.clone() }
        } else {
            let why = if self.key.is_none() {
                "started".to_owned()
            } else if !same_view {
                "restarted: new view, technique or parameters".to_owned()
            } else if step < 0.0 {
                format!("restarted: backwards scrub ({step:+.3} s)")
            } else if step > 0.0 {
                format!("restarted: jump of {step:.3} s (> {MAX_SCRUB_STEP_S} s)")
            } else {
                "restarted".to_owned()
            };
            History { frames: 0, steps: 0, note: why }
        };
        self.key = Some(key);
        self.time = request.time;
        if !continues {
            self.next_frame_index = 0;
        }
        (self.next_frame_index, continues)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    Technique,
    Reference,
}

/// Per-stage times of the last pass, milliseconds.
pub type StageTimes = Vec<(String, f64)>;

pub enum Update {
    /// A long step started ("preparing lights-voxarray").
    Stage {
        generation: u64,
        text: String,
    },
    /// The running average of `passes` full-size passes (0: the quarter-size preview), with the
    /// last pass's stats.
    Frame {
        generation: u64,
        which: Which,
        image: Image,
        passes: u32,
        prepare: StageTimes,
        render: StageTimes,
        rays: u64,
        memory_bytes: usize,
        /// The temporal history this image belongs to (full-size frames since it restarted).
        history: History,
        /// Milliseconds from the request's sending to the render thread starting on it, and to
        /// this image being ready.
        picked_up_ms: f64,
        ready_ms: f64,
    },
    /// A technique was built: its parameters as it read them (kinds, ranges, defaults, values).
    Params {
        generation: u64,
        which: Which,
        params: Vec<ParamInfo>,
    },
    Error {
        generation: u64,
        message: String,
    },
}

/// A technique ready to render, with what it was built for.
struct Built {
    id: String,
    set: Vec<String>,
    spp: u32,
    technique: Box<dyn Technique>,
    prepare: Stats,
    params: Vec<ParamInfo>,
}

pub fn spawn(scene: &'static Scene, requests: Receiver<Request>, updates: Sender<Update>, wake: impl Fn() + Send + 'static) {
    std::thread::Builder::new()
        .name("glimpse-view-render".into())
        .spawn(move || {
            let send = |u: Update| {
                let ok = updates.send(u).is_ok();
                wake();
                ok
            };
            run(scene, requests, send);
        })
        .expect("the render thread starts");
}

fn run(scene: &'static Scene, requests: Receiver<Request>, send: impl Fn(Update) -> bool) {
    let Ok(mut request) = requests.recv() else { return };
    let mut ctx = FrameContext::new(scene, request.time, request.size.0, request.size.1);
    let mut timeline = Timeline { time: request.time, key: None, next_frame_index: 0, history: History::default() };
    let mut built: [Option<Built>; 2] = [None, None];
    loop {
        let generation = request.generation;
        let picked_up_ms = request.sent.elapsed().as_secs_f64() * 1e3;
        let time_changed = request.time != timeline.time;
        let (first_frame_index, continues) = timeline.start(&request);
        if time_changed {
            // As `play`: the scene advanced in place, then every technique's per-frame prepare.
            ctx.advance(request.time, first_frame_index);
        }
        ctx.frame_index = first_frame_index;
        ctx.camera = request.camera.clone();
        let wanted = [Some(request.technique.clone()), request.compare.clone()];
        let mut failed = false;
        for (slot, id) in built.iter_mut().zip(&wanted) {
            match id {
                None => *slot = None,
                Some(id) => {
                    let current = slot.as_ref().is_some_and(|b| &b.id == id && b.set == request.set && b.spp == request.spp);
                    if current && time_changed {
                        let b = slot.as_mut().expect("current is Some");
                        match b.technique.prepare(&ctx) {
                            Ok(stats) => b.prepare = stats,
                            Err(e) => {
                                send(Update::Error { generation, message: e.to_string() });
                                *slot = None;
                                failed = true;
                            }
                        }
                    } else if !current {
                        send(Update::Stage { generation, text: format!("preparing {id}") });
                        match build(scene, &ctx, id, &request) {
                            Ok(b) => {
                                let which = if slot_is_reference(&wanted, id, &request) { Which::Reference } else { Which::Technique };
                                send(Update::Params { generation, which, params: b.params.clone() });
                                *slot = Some(b);
                            }
                            Err(message) => {
                                send(Update::Error { generation, message });
                                *slot = None;
                                failed = true;
                            }
                        }
                    }
                }
            }
        }
        let start = Start { first_frame_index, preview: !continues, picked_up_ms };
        if !failed && let Some(next) = render_progressively(&mut ctx, &mut built, &request, start, &mut timeline, &requests, &send) {
            request = next;
            continue;
        }
        // Converged (or failed): wait for the next request.
        match requests.recv() {
            Ok(next) => request = latest(next, &requests),
            Err(_) => return,
        }
    }
}

fn slot_is_reference(wanted: &[Option<String>; 2], id: &str, request: &Request) -> bool {
    wanted[1].as_deref() == Some(id) && request.technique != id
}

/// The newest of `first` and whatever else is queued.
fn latest(mut first: Request, requests: &Receiver<Request>) -> Request {
    while let Ok(r) = requests.try_recv() {
        first = r;
    }
    first
}

fn build(scene: &Scene, ctx: &FrameContext, id: &str, request: &Request) -> Result<Built, String> {
    let registry = glimpse_eval::registry();
    let info = registry.get(id).map_err(|e| e.to_string())?;
    // The technique's own parameters; its reference reads the keys it knows and ignores the rest.
    let set: Vec<&str> = request.set.iter().map(String::as_str).collect();
    let params = Params::parse(&set).map_err(|e| e.to_string())?;
    let settings = Settings { spp: request.spp, seed: 0 };
    let mut technique = (info.create)(scene, &settings, &params).map_err(|e| e.to_string())?;
    let prepare = technique.prepare(ctx).map_err(|e| e.to_string())?;
    Ok(Built { id: id.to_owned(), set: request.set.clone(), spp: request.spp, technique, prepare, params: params.described() })
}

/// Where a request's passes start.
#[derive(Clone, Copy)]
struct Start {
    /// The frame index of the first full-size pass (0 restarts temporal histories).
    first_frame_index: u32,
    /// Whether to show a quarter-size preview first (not when a history continues: the last
    /// image stays up until the next full-size frame).
    preview: bool,
    picked_up_ms: f64,
}

/// Renders the preview and then full-size passes until `max_passes` or a new request (returned).
fn render_progressively(
    ctx: &mut FrameContext,
    built: &mut [Option<Built>; 2],
    request: &Request,
    start: Start,
    timeline: &mut Timeline,
    requests: &Receiver<Request>,
    send: &impl Fn(Update) -> bool,
) -> Option<Request> {
    let generation = request.generation;
    let (w, h) = request.size;
    let mut sums: [Option<Image>; 2] = [None, None];
    // Pass 0 at a quarter of the size: a first image quickly, then every full-size pass.
    let first = if start.preview { 0 } else { 1 };
    for pass in first..=request.max_passes {
        let preview = pass == 0;
        (ctx.width, ctx.height) = if preview { ((w / 4).max(1), (h / 4).max(1)) } else { (w, h) };
        // Pass p shades primary sample p - 1 of every pixel (as `render --film-samples`) and is
        // frame `first_frame_index + p - 1` of the timeline (frame p - 1 of a still view).
        let film_pass = pass.saturating_sub(1);
        ctx.film_pass = film_pass;
        ctx.frame_index = if preview { 0 } else { start.first_frame_index + film_pass };
        if !preview {
            timeline.history.frames += 1;
            timeline.next_frame_index = ctx.frame_index + 1;
        }
        let gbuffer = ctx.gbuffer();
        for (k, slot) in built.iter_mut().enumerate() {
            let Some(b) = slot else { continue };
            let mut image = ctx.image();
            let stats = match b.technique.render(ctx, &gbuffer, &mut image) {
                Ok(s) => s,
                Err(e) => {
                    send(Update::Error { generation, message: e.to_string() });
                    return None;
                }
            };
            let self_accumulating = stats.stages.iter().any(|(s, _)| s == "accumulate");
            let shown = if preview {
                image
            } else {
                let passes = pass as f32;
                let sum = sums[k].get_or_insert_with(|| Image::new(w, h));
                if self_accumulating {
                    *sum = image;
                } else {
                    // Running average of the passes so far.
                    sum.pixels.iter_mut().zip(&image.pixels).for_each(|(s, p)| *s += (*p - *s) / passes);
                }
                sum.clone()
            };
            let which = if k == 0 { Which::Technique } else { Which::Reference };
            let update = Update::Frame {
                generation,
                which,
                image: shown,
                passes: pass,
                prepare: b.prepare.stages.clone(),
                render: stats.stages.clone(),
                rays: stats.rays,
                memory_bytes: b.prepare.memory_bytes.max(stats.memory_bytes),
                history: timeline.history.clone(),
                picked_up_ms: start.picked_up_ms,
                ready_ms: request.sent.elapsed().as_secs_f64() * 1e3,
            };
            if !send(update) {
                return None;
            }
        }
        match requests.try_recv() {
            Ok(next) => return Some(latest(next, requests)),
            Err(TryRecvError::Empty) => {}
            Err(TryRecvError::Disconnected) => return None,
        }
    }
    (ctx.width, ctx.height) = (w, h);
    None
}
