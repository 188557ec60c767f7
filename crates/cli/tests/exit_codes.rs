//! docs/cli.md's exit codes: 0 on success, 1 with one `error:` line on a failure — a panic in the
//! main thread or in a worker included (never 101 and pages of backtraces) — and 2 for usage
//! errors; with RUST_BACKTRACE set the backtrace is still printed.

use std::process::{Command, Output};

fn glimpse(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_glimpse"));
    c.args(args).env_remove("RUST_BACKTRACE");
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("the glimpse binary runs")
}

fn show(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    println!("exit {:?}, {} stderr lines: {}", out.status.code(), stderr.lines().count(), stderr.lines().next().unwrap_or(""));
    stderr
}

#[test]
fn success_is_0_failure_1_usage_2() {
    let ok = glimpse(&["scenes"], &[]);
    show(&ok);
    assert_eq!(ok.status.code(), Some(0));
    let failure = glimpse(&["render", "/nonexistent/scene.gltf", "-t", "ao-exact", "-o", "/tmp/x.png"], &[]);
    let stderr = show(&failure);
    assert_eq!(failure.status.code(), Some(1));
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    let usage = glimpse(&["render", "--no-such-flag"], &[]);
    show(&usage);
    assert_eq!(usage.status.code(), Some(2));
}

#[test]
fn a_panic_in_any_thread_is_one_error_line_and_status_1() {
    for place in ["main", "worker"] {
        let out = glimpse(&["scenes"], &[("GLIMPSE_PANIC_FOR_TEST", place)]);
        let stderr = show(&out);
        assert_eq!(out.status.code(), Some(1), "{place}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{place}: exactly one line: {stderr}");
        assert!(stderr.starts_with("error: internal error") && stderr.contains("panic requested"), "{stderr}");
    }
    let out = glimpse(&["scenes"], &[("GLIMPSE_PANIC_FOR_TEST", "worker"), ("RUST_BACKTRACE", "1")]);
    let stderr = show(&out);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr.contains("stack backtrace") && stderr.lines().last().unwrap().starts_with("error: "), "{stderr}");
}
