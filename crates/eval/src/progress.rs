//! Progress on the terminal for long steps: a spinner naming a step (a prepare, a tracer build)
//! and a bar of finished pixels for a render, each shown only once the step has run for a
//! second. indicatif draws nothing when stderr is not a terminal, so logs and tests stay clean.

use glimpse_render::{FrameContext, Progress};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Runs `f`, showing a spinner named `label` with the elapsed time if it takes over a second.
pub fn with_spinner<T>(label: &str, f: impl FnOnce() -> T) -> T {
    watch(label, None, f)
}

/// Runs `f`, a render of `ctx`'s frame, showing a bar of its finished pixels named `label` if it
/// takes over a second.
pub fn with_progress<T>(label: &str, ctx: &FrameContext, f: impl FnOnce() -> T) -> T {
    ctx.progress.reset();
    watch(label, Some((ctx.width as u64 * ctx.height as u64, ctx.progress.clone())), f)
}

/// Runs `f` while a watcher thread draws a spinner (no `pixels`) or a pixel bar.
fn watch<T>(label: &str, pixels: Option<(u64, Progress)>, f: impl FnOnce() -> T) -> T {
    let done = Arc::new(AtomicBool::new(false));
    let watcher = {
        let (done, label) = (done.clone(), label.to_owned());
        std::thread::spawn(move || {
            let start = Instant::now();
            let mut bar: Option<indicatif::ProgressBar> = None;
            while !done.load(Ordering::Relaxed) {
                // Woken early when the work is done, so a short step does not wait out a tick.
                std::thread::park_timeout(Duration::from_millis(50));
                if bar.is_none() && start.elapsed() > Duration::from_secs(1) {
                    bar = Some(match &pixels {
                        None => {
                            let s = indicatif::ProgressBar::new_spinner().with_message(label.clone());
                            s.set_style(indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})").expect("valid template"));
                            s
                        }
                        Some((total, _)) => {
                            let b = indicatif::ProgressBar::new(*total).with_message(label.clone());
                            let style =
                                indicatif::ProgressStyle::with_template("{msg} {elapsed_precise} [{bar:40}] {percent}% pixels, eta {eta}");
                            b.set_style(style.expect("valid template").progress_chars("=> "));
                            b
                        }
                    });
                }
                match (&bar, &pixels) {
                    (Some(b), Some((total, progress))) => b.set_position(progress.done().min(*total)),
                    (Some(s), None) => s.tick(),
                    _ => {}
                }
            }
            if let Some(b) = bar {
                b.finish_and_clear();
            }
        })
    };
    let out = f();
    done.store(true, Ordering::Relaxed);
    watcher.thread().unpark();
    let _ = watcher.join();
    out
}
