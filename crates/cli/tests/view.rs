//! `glimpse view` run headless under Xvfb (with Mesa's lavapipe as the GPU): the screenshot of
//! the window's image matches a CPU `glimpse render` of the same view within a FLIP bound, after
//! a scripted camera orbit and technique switch too. Built only with `--features viewer`; skips
//! with a printed reason where `xvfb-run` is missing.
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

/// The screenshot against `glimpse render` of the same technique, camera and passes.
fn check_against_cpu(dir: &Path, name: &str, stdout: &str, size: &str, spp: &str, passes: &str) -> f64 {
    let shot = dir.join(format!("{name}.png"));
    let cpu = dir.join(format!("{name}-cpu.png"));
    let status = glimpse()
        .args(["render", "cornell", "-t", line(stdout, "technique:"), "--size", size, "--spp", spp, "--film-samples", passes])
        .args(["--camera", line(stdout, "camera:"), "-o"])
        .arg(&cpu)
        .status()
        .unwrap();
    assert!(status.success());
    let (a, b) = (Image::read(&shot).unwrap(), Image::read(&cpu).unwrap());
    let mean = a.mean();
    let spread = a.pixels.iter().map(|p| (p.x - mean.x).abs()).sum::<f32>() / a.len() as f32;
    assert!(mean.max_element() > 0.02 && spread > 0.01, "{name}: the screenshot is blank (mean {mean}, spread {spread})");
    let (flip, _) = glimpse_render::metrics::flip_ldr(&a, &b).unwrap();
    println!("{name}: screenshot vs CPU render: mean LDR-FLIP {flip:.5}");
    flip
}

#[test]
fn the_window_shows_what_the_cpu_renders_and_follows_a_scripted_move_and_switch() {
    if !has_xvfb() {
        println!("skipped: xvfb-run is not installed (apt-get install xvfb mesa-vulkan-drivers)");
        return;
    }
    let dir = std::env::temp_dir().join(format!("glimpse-view-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();

    let still = view(&["cornell", "-t", "ao-exact", "--size", "160x96", "--spp", "2", "--frames", "3"], &dir.join("still.png"));
    assert!(check_against_cpu(&dir, "still", &still, "160x96", "2", "3") < 0.01);
    assert!(dir.join("still-window.png").exists(), "the whole window is saved beside the image");

    // Orbit 30° and switch from ao-roma to soft-exact once the first image is up.
    let moved = view(
        &["cornell", "-t", "ao-roma", "--size", "160x96", "--spp", "2", "--frames", "2", "--orbit", "30", "--switch-to", "soft-exact"],
        &dir.join("moved.png"),
    );
    assert_eq!(line(&moved, "technique:"), "soft-exact");
    assert_ne!(line(&moved, "camera:"), line(&still, "camera:"), "the orbit moved the camera");
    assert!(check_against_cpu(&dir, "moved", &moved, "160x96", "2", "2") < 0.01);
    std::fs::remove_dir_all(&dir).ok();
}
