//! `--device gpu` end to end (built with `--features gpu`; CI runs it on lavapipe): each GPU
//! technique's image beside the CPU technique's on the same scene, size, spp and seed — they
//! trace the same rays, so they agree except where the GPU decides an edge ray differently
//! (none on lavapipe) — plus the errors and `bench rays --backends gpu-exact`. Skipped, with the
//! reason printed, on a machine without any Vulkan driver.
#![cfg(feature = "gpu")]

use glimpse_core::Image;
use std::process::{Command, Output};

fn glimpse(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_glimpse")).args(args).output().expect("the glimpse binary runs")
}

/// A fresh folder, removed when it is dropped (also when the test fails): keep it alive while
/// `glimpse` runs on its files.
fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("glimpse-gpu-device-").tempdir().unwrap()
}

/// Whether a Vulkan adapter exists, asked once per process. With every test creating and
/// dropping its own context at once, this binary crashed (SIGSEGV) on an NVIDIA H200 (driver
/// 580.159.04) while its six tests all passed with `--test-threads=1`; one context made once is
/// the mitigation, not yet run on that driver.
fn has_adapter(test: &str) -> bool {
    static ADAPTER: std::sync::OnceLock<Result<String, String>> = std::sync::OnceLock::new();
    match ADAPTER.get_or_init(|| glimpse_gpu::GpuContext::new().map(|c| c.describe()).map_err(|e| e.to_string())) {
        Ok(adapter) => {
            println!("{test}: adapter {adapter}");
            true
        }
        Err(e) => {
            println!("SKIPPED {test}: {e}");
            false
        }
    }
}

fn ok(out: &Output) -> String {
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "glimpse failed:\n{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    format!("{stdout}{stderr}")
}

/// Renders `technique` on `scene` on `device` (with more command-line `args`) and reads the
/// image back.
fn render(scene: &str, technique: &str, device: &str, set: &[&str], args: &[&str]) -> (Image, String) {
    let dir = scratch();
    let out = dir.path().join(format!("{scene}-{technique}-{device}.exr"));
    let mut args = [&["render", scene, "-t", technique, "--size", "24x18", "--spp", "4", "--seed", "3", "--device", device], args].concat();
    for s in set {
        args.extend(["--set", s]);
    }
    args.extend(["-o", out.to_str().unwrap()]);
    let log = ok(&glimpse(&args));
    let image = Image::read(&out).unwrap();
    (image, log)
}

/// Pixels that differ, RMSE and the largest channel difference of `a` against `b`.
fn compare(a: &Image, b: &Image) -> (usize, f64, f32) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut differ = 0;
    let (mut se, mut max) = (0.0f64, 0.0f32);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let d = (*p - *q).abs();
        differ += (d.max_element() > 0.0) as usize;
        max = max.max(d.max_element());
        se += (d * d).element_sum() as f64 / 3.0;
    }
    (differ, (se / a.pixels.len() as f64).sqrt(), max)
}

fn gpu_agrees_with_cpu(scene: &str, technique: &str, set: &[&str]) {
    gpu_agrees_with_cpu_with(scene, technique, set, &[]);
}

/// [`gpu_agrees_with_cpu`] with more command-line `args` (a time, lights).
fn gpu_agrees_with_cpu_with(scene: &str, technique: &str, set: &[&str], args: &[&str]) {
    let (cpu, _) = render(scene, technique, "cpu", set, args);
    let (gpu, log) = render(scene, technique, "gpu", set, args);
    assert!(log.contains("device: gpu, adapter"), "the adapter line: {log}");
    let (differ, rmse, max) = compare(&gpu, &cpu);
    let mean = cpu.pixels.iter().map(|p| p.element_sum() as f64 / 3.0).sum::<f64>() / cpu.pixels.len() as f64;
    println!(
        "{technique:16} on {scene}: {} pixels, mean {mean:.4}, {differ} differ, RMSE {rmse:.3e}, max diff {max:.3e}",
        cpu.pixels.len()
    );
    assert!(mean > 0.0, "{technique}: a black image proves nothing");
    // The same rays on both sides: only a GPU edge decision may move a pixel, and rarely.
    assert!(differ * 100 <= cpu.pixels.len(), "{technique}: {differ} of {} pixels differ", cpu.pixels.len());
    assert!(rmse <= 0.01 * mean.max(1e-3), "{technique}: RMSE {rmse} against mean {mean}");
}

#[test]
fn gpu_references_agree_with_the_cpu_ones() {
    if !has_adapter("gpu_references_agree_with_the_cpu_ones") {
        return;
    }
    gpu_agrees_with_cpu("cornell-lit", "ao-exact", &[]);
    gpu_agrees_with_cpu("glossy", "ao-exact", &["radius=0.5"]);
    gpu_agrees_with_cpu("cornell-lit", "lights-exact", &[]);
    gpu_agrees_with_cpu("many-lights", "lights-exact", &["lights=16"]);
    gpu_agrees_with_cpu("cornell-lit", "env-exact", &["rays=16"]);
}

#[test]
fn gpu_techniques_agree_with_the_cpu_ones() {
    if !has_adapter("gpu_techniques_agree_with_the_cpu_ones") {
        return;
    }
    gpu_agrees_with_cpu("cornell-lit", "ao-roma", &[]);
    gpu_agrees_with_cpu("cornell-lit", "soft-roma", &[]);
    gpu_agrees_with_cpu("cornell-lit", "soft-roma", &["snap=true"]);
    gpu_agrees_with_cpu("cornell-lit", "gi-roma", &[]);
    gpu_agrees_with_cpu("cornell-lit", "lights-voxarray", &["resolution=64", "directions=16", "disk_cache=false"]);
    // Moving scenes: rigid instances (Alg. 5; point lights added, it has only an area light)
    // and deforming meshes (Alg. 6, its sun).
    let small = ["resolution=32", "directions=8", "type_resolution=32", "disk_cache=false"];
    let lights = ["--light", "point:0.2,0.45,0.3:0.3", "--light", "point:0.4,0.45,0.2:0.3"];
    gpu_agrees_with_cpu_with("cornell-dynamic", "lights-voxarray", &small, &[&["--time", "0.5"], &lights[..]].concat());
    gpu_agrees_with_cpu_with("deforming", "lights-voxarray", &small, &["--time", "0.5"]);
}

/// `env-dvf`: the field is the CPU's bit for bit (glimpse-dvf's own GPU tests), but the shading's
/// map lookups use WGSL's atan2/acos, so pixels differ by float rounding: bounded, not counted.
#[test]
fn gpu_env_dvf_is_close_to_the_cpu_one() {
    if !has_adapter("gpu_env_dvf_is_close_to_the_cpu_one") {
        return;
    }
    let set = ["rays=16", "points=2500", "grid=8"];
    let (cpu, _) = render("cornell-lit", "env-dvf", "cpu", &set, &[]);
    let (gpu, log) = render("cornell-lit", "env-dvf", "gpu", &set, &[]);
    assert!(log.contains("device: gpu, adapter"), "the adapter line: {log}");
    let (differ, rmse, max) = compare(&gpu, &cpu);
    let mean = cpu.pixels.iter().map(|p| p.element_sum() as f64 / 3.0).sum::<f64>() / cpu.pixels.len() as f64;
    println!("env-dvf on cornell-lit: {} pixels, mean {mean:.4}, {differ} differ, RMSE {rmse:.3e}, max diff {max:.3e}", cpu.pixels.len());
    assert!(mean > 0.0, "a black image proves nothing");
    assert!(rmse <= 1e-3 * mean && max <= 1e-2 * mean as f32, "env-dvf: RMSE {rmse}, max {max} against mean {mean}");
}

#[test]
fn cpu_only_techniques_are_an_error_on_the_gpu() {
    let tmp = scratch();
    let out = tmp.path().join("refused.png");
    let o = glimpse(&["render", "cornell-lit", "-t", "soft-exact", "--device", "gpu", "--size", "8x8", "-o", out.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    println!("{}", stderr.trim());
    assert!(!o.status.success() && !stderr.contains("panicked"));
    assert!(stderr.contains("technique 'soft-exact' has no GPU implementation") && stderr.contains("ao-exact, lights-exact, env-exact"));
    if has_adapter("cpu_only_techniques_are_an_error_on_the_gpu") {
        // What the ROMA kernels do not support is an error naming the parameter.
        for (technique, set, key) in
            [("soft-roma", "resolution=64", "resolution=64"), ("gi-roma", "voxelization=conservative", "voxelization")]
        {
            let args = ["render", "cornell-lit", "-t", technique, "--device", "gpu", "--size", "8x8", "--set", set];
            let o = glimpse(&[&args[..], &["-o", out.to_str().unwrap()]].concat());
            let stderr = String::from_utf8_lossy(&o.stderr);
            println!("{}", stderr.trim());
            assert!(!o.status.success() && !stderr.contains("panicked") && stderr.contains(key), "{stderr}");
        }
    }
}

#[test]
fn eval_and_play_run_on_the_gpu() {
    if !has_adapter("eval_and_play_run_on_the_gpu") {
        return;
    }
    let tmp = scratch();
    let dir = tmp.path().join("eval");
    let log = ok(&glimpse(&[
        "eval",
        "cornell-lit",
        "-t",
        "ao-roma,soft-roma,gi-roma",
        "--device",
        "gpu",
        "--size",
        "16x12",
        "--spp",
        "2",
        "--ref-spp",
        "8",
        "--no-sweep",
        "--no-cache",
        "-o",
        dir.to_str().unwrap(),
    ]));
    println!("{log}");
    assert!(log.lines().any(|l| l.starts_with("ao-roma") && l.contains("ao-exact")), "{log}");
    // References without a GPU port (soft-exact, gi-exact) render on the CPU for the comparison.
    assert!(log.lines().any(|l| l.starts_with("soft-roma") && l.contains("soft-exact")), "{log}");
    assert!(log.lines().any(|l| l.starts_with("gi-roma") && l.contains("gi-exact")), "{log}");
    assert!(dir.join("results.json").exists());
    let log = ok(&glimpse(&["play", "cornell-lit", "-t", "ao-roma", "--device", "gpu", "--frames", "2", "--size", "16x12", "--spp", "1"]));
    println!("{log}");
    assert!(log.contains("frame    1") && log.contains("mean over 2 frames"), "{log}");
}

#[test]
fn bench_rays_prints_gpu_rows_beside_the_cpu_ones() {
    if !has_adapter("bench_rays_prints_gpu_rows_beside_the_cpu_ones") {
        return;
    }
    let log = ok(&glimpse(&["bench", "rays", "cornell", "--rays", "4000", "--size", "32x32", "--backends", "roma,gpu-exact,gpu-roma"]));
    println!("{log}");
    let row = |name: &str| log.lines().find(|l| l.split_whitespace().next() == Some(name)).unwrap_or_else(|| panic!("no {name} row"));
    row("exact");
    row("roma");
    let agreement = |name: &str| -> f64 { row(name).split_whitespace().last().unwrap().trim_end_matches('%').parse().unwrap() };
    assert!(agreement("gpu-exact") >= 99.9, "gpu-exact agrees with exact on {} %", agreement("gpu-exact"));
    // The GPU ROMA answers as the CPU ROMA, so it agrees with the exact tracer as much.
    assert!((agreement("gpu-roma") - agreement("roma")).abs() <= 0.1, "gpu-roma {} vs roma {}", agreement("gpu-roma"), agreement("roma"));
    assert!(log.contains("GPU adapter:") && log.contains("kernel time"), "{log}");
}
