//! `--device` without the `gpu` feature: `--device gpu` (and a `gpu-*` bench backend) is one
//! error line that says how to rebuild, never a CPU render in disguise.
#![cfg(not(feature = "gpu"))]

use std::process::Command;

#[test]
fn device_gpu_without_the_feature_says_how_to_rebuild() {
    // Paths that do not exist, in a folder removed when the test ends (also when it fails).
    let tmp = tempfile::Builder::new().prefix("glimpse-device-").tempdir().unwrap();
    let out = tmp.path().join("device.png");
    let out = out.to_str().unwrap();
    let dir = tmp.path().join("eval");
    let commands: [&[&str]; 4] = [
        &["render", "cornell", "-t", "ao-exact", "--size", "8x8", "--device", "gpu", "-o", out],
        &["eval", "cornell", "-t", "ao-roma", "--size", "8x8", "--device", "gpu", "-o", dir.to_str().unwrap()],
        &["play", "cornell", "-t", "ao-exact", "--frames", "1", "--size", "8x8", "--device", "gpu"],
        &["bench", "rays", "cornell", "--rays", "100", "--backends", "gpu-exact"],
    ];
    for args in commands {
        let o = Command::new(env!("CARGO_BIN_EXE_glimpse")).args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        println!("{}: {}", args[0], stderr.trim());
        assert!(!o.status.success() && !stderr.contains("panicked"), "{stderr}");
        assert!(stderr.contains("built without the GPU backend") && stderr.contains("--features gpu"), "{stderr}");
    }
    assert!(!std::path::Path::new(out).exists(), "no image from a refused render");
}
