//! `glimpse view` run headless under Xvfb (with Mesa's lavapipe as the GPU): the screenshot of
//! the window's image matches a CPU `glimpse render` of the same view within a FLIP bound, after
//! a scripted camera orbit and technique switch too, and after a parameter set through the path
//! its slider takes; time steps carry a temporal technique's history as `glimpse play` does.
//! Built only with `--features viewer`; skips with a printed reason where `xvfb-run` is missing.
#![cfg(feature = "viewer")]

use glimpse_core::Image;
use std::path::Path;
use std::process::Command;

fn glimpse() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_glimpse"));
    c.env("GLIMPSE_CACHE", "");
    c
}

fn has_xvfb() -> bool {
    Command::new("xvfb-run").arg("--help").output().is_ok()
}

/// Runs `glimpse view` headless; returns what it printed (the final camera and technique).
fn view(args: &[&str], screenshot: &Path) -> String {
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1280x1024x24"])
        .arg(env!("CARGO_BIN_EXE_glimpse"))
        .args(["view"])
        .args(args)
        .arg("--screenshot")
        .arg(screenshot)
        .env("GLIMPSE_CACHE", "")
        .env("MESA_SHADER_CACHE_DISABLE", "true")
        .output()
        .expect("xvfb-run runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "glimpse view failed: {}\n{stdout}", String::from_utf8_lossy(&out.stderr));
    stdout
}

fn line<'a>(stdout: &'a str, key: &str) -> &'a str {
    stdout.lines().find_map(|l| l.strip_prefix(key)).unwrap_or_else(|| panic!("no '{key}' line in {stdout}")).trim()
}

/// The screenshot against `glimpse render` of the same technique, camera and passes (and
/// `extra` arguments: `--set`, `--time`).
fn check_against_cpu(dir: &Path, name: &str, stdout: &str, size: &str, spp: &str, passes: &str, extra: &[&str]) -> f64 {
    let cpu = dir.join(format!("{name}-cpu.png"));
    let status = glimpse()
        .args(["render", "cornell", "-t", line(stdout, "technique:"), "--size", size, "--spp", spp, "--film-samples", passes])
        .args(["--camera", line(stdout, "camera:")])
        .args(extra)
        .arg("-o")
        .arg(&cpu)
        .status()
        .unwrap();
    assert!(status.success());
    let flip = flip_against(&dir.join(format!("{name}.png")), &cpu);
    println!("{name}: screenshot vs CPU render: mean LDR-FLIP {flip:.5}");
    flip
}

/// Mean LDR-FLIP of a screenshot against a CPU image, after checking it is not blank.
fn flip_against(shot: &Path, cpu: &Path) -> f64 {
    let (a, b) = (Image::read(shot).unwrap(), Image::read(cpu).unwrap());
    let mean = a.mean();
    let spread = a.pixels.iter().map(|p| (p.x - mean.x).abs()).sum::<f32>() / a.len() as f32;
    assert!(mean.max_element() > 0.02 && spread > 0.01, "{}: the screenshot is blank (mean {mean}, spread {spread})", shot.display());
    glimpse_render::metrics::flip_ldr(&a, &b).unwrap().0
}

/// A fresh folder, removed when the test ends (also when it fails): it outlives the `glimpse` runs.
fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("glimpse-view-{name}-")).tempdir().unwrap()
}

#[test]
fn the_window_shows_what_the_cpu_renders_and_follows_a_scripted_move_and_switch() {
    if !has_xvfb() {
        println!("skipped: xvfb-run is not installed (apt-get install xvfb mesa-vulkan-drivers)");
        return;
    }
    let tmp = temp_dir("still");
    let dir = tmp.path();

    let still = view(&["cornell", "-t", "ao-exact", "--size", "160x96", "--spp", "2", "--frames", "3"], &dir.join("still.png"));
    assert!(check_against_cpu(dir, "still", &still, "160x96", "2", "3", &[]) < 0.01);
    assert!(dir.join("still-window.png").exists(), "the whole window is saved beside the image");

    // Orbit 30° and switch from ao-roma to soft-exact once the first image is up.
    let moved = view(
        &["cornell", "-t", "ao-roma", "--size", "160x96", "--spp", "2", "--frames", "2", "--orbit", "30", "--switch-to", "soft-exact"],
        &dir.join("moved.png"),
    );
    assert_eq!(line(&moved, "technique:"), "soft-exact");
    assert_ne!(line(&moved, "camera:"), line(&still, "camera:"), "the orbit moved the camera");
    assert!(check_against_cpu(dir, "moved", &moved, "160x96", "2", "2", &[]) < 0.01);
}

#[test]
fn a_parameter_set_as_its_slider_does_renders_as_set_does() {
    if !has_xvfb() {
        println!("skipped: xvfb-run is not installed (apt-get install xvfb mesa-vulkan-drivers)");
        return;
    }
    let tmp = temp_dir("param");
    let dir = tmp.path();
    // radius=0.3 applied once the first image is up, through the path a slider's release takes.
    let args = ["cornell", "-t", "ao-exact", "--size", "160x96", "--spp", "2", "--frames", "2", "--set-param", "radius=0.3"];
    let out = view(&args, &dir.join("param.png"));
    for l in out.lines().filter(|l| l.starts_with("first frame:")) {
        println!("param: {l}");
    }
    assert_eq!(line(&out, "set:"), "radius=0.3");
    let with = check_against_cpu(dir, "param", &out, "160x96", "2", "2", &["--set", "radius=0.3"]);
    assert!(with < 0.01);
    // And the parameter changed the image: the default radius (infinite) renders another one.
    let without = check_against_cpu(dir, "param", &out, "160x96", "2", "2", &[]);
    assert!(without > 10.0 * with.max(1e-4), "radius=0.3 changed nothing (FLIP {without:.5} against the default)");
}

#[test]
fn time_steps_carry_a_temporal_history_as_play_does() {
    if !has_xvfb() {
        println!("skipped: xvfb-run is not installed (apt-get install xvfb mesa-vulkan-drivers)");
        return;
    }
    let tmp = temp_dir("time");
    let dir = tmp.path();
    // ao-roma blends its frames (window 10); 3 steps of 1/30 s with one frame each: frames 0..3.
    let args = ["cornell-dynamic", "-t", "ao-roma", "--size", "160x96", "--spp", "2", "--frames", "1", "--step-time", "3"];
    let out = view(&args, &dir.join("time.png"));
    let history = line(&out, "history:");
    println!("time: viewer history: {history}, time {}", line(&out, "time:"));
    assert!(history.starts_with("4 frames (continued over +0.033 s)"), "{history}");
    assert_eq!(line(&out, "time:").parse::<f32>().unwrap(), 3.0 / 30.0);
    // `glimpse play` of the same 4 frames: its last frame is the viewer's image.
    let play = dir.join("play");
    let status = glimpse()
        .args(["play", "cornell-dynamic", "-t", "ao-roma", "--size", "160x96", "--spp", "2", "--frames", "4", "-o"])
        .arg(&play)
        .status()
        .unwrap();
    assert!(status.success());
    let shot = dir.join("time.png");
    let against_play = flip_against(&shot, &play.join("frame-0003.png"));
    // A single frame at that time (no history) is another image: the history is what matches.
    let single = dir.join("single.png");
    let status = glimpse()
        .args(["render", "cornell-dynamic", "-t", "ao-roma", "--size", "160x96", "--spp", "2", "--time", line(&out, "time:"), "-o"])
        .arg(&single)
        .status()
        .unwrap();
    assert!(status.success());
    let against_single = flip_against(&shot, &single);
    println!("time: screenshot vs play's frame 3: LDR-FLIP {against_play:.5}; vs a single frame at t=0.1: {against_single:.5}");
    assert!(against_play < 0.01);
    assert!(against_single > 5.0 * against_play.max(1e-4), "the history made no difference");
}
