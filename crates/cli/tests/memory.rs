//! The voxel array's size is checked against the memory budget before it is built (issue #15:
//! "a memory estimate before the big allocations … voxel structures").

use std::process::Command;

#[test]
fn an_array_over_the_budget_is_refused_before_it_is_built() {
    let out = std::env::temp_dir().join(format!("glimpse-memory-{}.png", std::process::id()));
    let o = Command::new(env!("CARGO_BIN_EXE_glimpse"))
        .args(["--max-memory", "500M", "render", "many-lights", "-t", "lights-voxarray", "--size", "16x16", "-o"])
        .arg(&out)
        .env("GLIMPSE_CACHE", "")
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    println!("{e}");
    assert_eq!(o.status.code(), Some(1), "{e}");
    // Streamed into its compression: ids and packed indices, 823 MiB.
    assert!(e.contains("128³ × 90²") && e.contains("streamed") && e.contains("822.7 MiB") && e.contains("500.0 MiB"), "{e}");
    assert_eq!(e.lines().filter(|l| l.starts_with("error:")).count(), 1);
    // Uncompressed, the whole plain array is estimated.
    let o = Command::new(env!("CARGO_BIN_EXE_glimpse"))
        .args([
            "--max-memory",
            "500M",
            "render",
            "many-lights",
            "-t",
            "lights-voxarray",
            "--size",
            "16x16",
            "--set",
            "compress=false",
            "-o",
        ])
        .arg(&out)
        .env("GLIMPSE_CACHE", "")
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.code() == Some(1) && e.contains("2.0 GiB"), "{e}");
    // Smaller settings fit.
    let o = Command::new(env!("CARGO_BIN_EXE_glimpse"))
        .args(["--max-memory", "500M", "render", "many-lights", "-t", "lights-voxarray", "--size", "16x16"])
        .args(["--set", "resolution=32", "--set", "directions=16", "--set", "epsilon=false", "-o"])
        .arg(&out)
        .env("GLIMPSE_CACHE", "")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_file(&out).ok();
}
