//! The viewer's render thread: it owns the scene's frame context and the techniques, renders
//! progressively (a quarter-size preview, then full-size film passes averaged while the view is
//! still) and sends each image back. The window never waits on it: a new request from the window
//! replaces the current one between passes, and a long `prepare` only delays images.

use glimpse_core::Image;
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
    },
    /// A technique was built: its parameters as it read them (keys and effective values).
    Params {
        generation: u64,
        which: Which,
        params: std::collections::BTreeMap<String, String>,
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
    params: std::collections::BTreeMap<String, String>,
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
    let mut time = request.time;
    let mut built: [Option<Built>; 2] = [None, None];
    loop {
        let generation = request.generation;
        if request.time != time {
            ctx.advance(request.time, 0);
            time = request.time;
            built = [None, None];
        }
        ctx.camera = request.camera.clone();
        let wanted = [Some(request.technique.clone()), request.compare.clone()];
        let mut failed = false;
        for (slot, id) in built.iter_mut().zip(&wanted) {
            match id {
                None => *slot = None,
                Some(id) => {
                    let current = slot.as_ref().is_some_and(|b| &b.id == id && b.set == request.set && b.spp == request.spp);
                    if !current {
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
        if !failed && let Some(next) = render_progressively(&mut ctx, &mut built, &request, &requests, &send) {
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
    Ok(Built { id: id.to_owned(), set: request.set.clone(), spp: request.spp, technique, prepare, params: params.effective() })
}

/// Renders the preview and then full-size passes until `max_passes` or a new request (returned).
fn render_progressively(
    ctx: &mut FrameContext,
    built: &mut [Option<Built>; 2],
    request: &Request,
    requests: &Receiver<Request>,
    send: &impl Fn(Update) -> bool,
) -> Option<Request> {
    let generation = request.generation;
    let (w, h) = request.size;
    let mut sums: [Option<Image>; 2] = [None, None];
    // Pass 0 at a quarter of the size: a first image quickly, then every full-size pass.
    for pass in 0..=request.max_passes {
        let preview = pass == 0;
        (ctx.width, ctx.height) = if preview { ((w / 4).max(1), (h / 4).max(1)) } else { (w, h) };
        let film_pass = pass.saturating_sub(1);
        ctx.film_pass = film_pass;
        ctx.frame_index = film_pass;
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
