//! How `glimpse` ends (docs/cli.md, "Exit codes"): 0 on success, 1 with one `error:` line on any
//! failure — a panic included, in any thread — and 2 for clap's usage errors.
//!
//! A panic is a bug, but the user still gets the promised one line and status 1, not hundreds of
//! lines of backtraces from every rayon worker and status 101. The panic hook prints the line and
//! exits at the first panic, before other threads report theirs; with `RUST_BACKTRACE` set, the
//! standard report with its backtrace is printed first. Outputs are written to temporary files and
//! renamed (`glimpse_core::atomic_file`), so exiting mid-run never leaves a truncated file.

use std::panic::PanicHookInfo;

/// Environment variable that makes `glimpse` panic on purpose (`main` or `worker`), so the tests
/// can check what a user sees when a bug panics.
pub const PANIC_FOR_TEST: &str = "GLIMPSE_PANIC_FOR_TEST";

/// On Ctrl-C (SIGINT, and SIGTERM): remove the temporary files of writes in progress, so the
/// outputs keep their previous content and nothing is left beside them, then exit with 130 and
/// one `error:` line.
pub fn install_interrupt_handler() {
    let _ = ctrlc::set_handler(|| {
        eprintln!("error: interrupted");
        glimpse_core::atomic_file::remove_in_flight_and_exit(130);
    });
}

pub fn install_panic_hook() {
    let standard = std::panic::take_hook();
    // The first panicking thread reports and exits; any other waits here until the process ends.
    static FIRST: std::sync::Mutex<()> = std::sync::Mutex::new(());
    std::panic::set_hook(Box::new(move |info| {
        // A loader contains its readers' panics and reports them as an error naming the file.
        if glimpse_core::catch_panic::is_catching() {
            return;
        }
        let _only_one = FIRST.lock();
        let backtrace = std::env::var_os("RUST_BACKTRACE").is_some_and(|v| !v.is_empty() && v != "0");
        if backtrace {
            standard(info);
        }
        eprintln!("error: {}", one_line(info));
        std::process::exit(1);
    }));
}

fn one_line(info: &PanicHookInfo) -> String {
    let payload = info.payload();
    let message =
        payload.downcast_ref::<&str>().copied().or_else(|| payload.downcast_ref::<String>().map(String::as_str)).unwrap_or("panic");
    let at = info.location().map(|l| format!(" at {}:{}", l.file(), l.line())).unwrap_or_default();
    let text = format!("internal error (a bug in glimpse, please report it): {message}{at}");
    text.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join("; ")
}

/// Panics when [`PANIC_FOR_TEST`] asks for it: in the main thread, or in a rayon worker.
pub fn panic_if_asked() {
    match std::env::var(PANIC_FOR_TEST).as_deref() {
        Ok("main") => panic!("panic requested by {PANIC_FOR_TEST}=main"),
        Ok("worker") => {
            use rayon::prelude::*;
            (0..64).into_par_iter().for_each(|i| {
                if i % 2 == 1 {
                    panic!("panic requested by {PANIC_FOR_TEST}=worker (item {i})");
                }
            });
        }
        _ => {}
    }
}
