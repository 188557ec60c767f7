//! The voxel array's size is checked against the memory budget before it is built (issue #15:
//! "a memory estimate before the big allocations … voxel structures").

use std::process::Command;

/// A fresh folder, removed when the test ends (also when it fails): it outlives the `glimpse` runs.
fn temp_dir() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("glimpse-memory-").tempdir().unwrap()
}

#[test]
fn an_array_over_the_budget_is_refused_before_it_is_built() {
    let dir = temp_dir();
    let out = dir.path().join("memory.png");
    let o = Command::new(env!("CARGO_BIN_EXE_glimpse"))
        .args(["--max-memory", "500M", "render", "many-lights", "-t", "lights-voxarray", "--size", "16x16", "-o"])
        .arg(&out)
        .env("GLIMPSE_CACHE", "")
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    println!("{e}");
    assert_eq!(o.status.code(), Some(1), "{e}");
    // Streamed into its compression: 32-bit ids and packed indices of up to 24 bits (the default
    // dictionary's 16M-row cap), 886 MiB.
    assert!(e.contains("128³ × 90²") && e.contains("streamed") && e.contains("885.9 MiB") && e.contains("500.0 MiB"), "{e}");
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
}

/// Every technique's own structure is estimated before it is built and refused over the budget,
/// with one error naming it, the size and the budget (issue #15).
#[test]
fn each_technique_structure_over_the_budget_is_refused() {
    // (scene, technique, --set, budget, what the error names, the estimate as printed)
    type Case<'a> = (&'a str, &'a str, &'a [&'a str], &'a str, &'a str, &'a str);
    let cases: &[Case] = &[
        ("many-lights", "lights-shadowmap", &[], "100M", "1024 cube shadow maps of 6 × 128² depths", "384.0 MiB"),
        ("many-lights", "lights-ism", &[], "50M", "1024 imperfect shadow maps of 128² depths", "66.0 MiB"),
        ("cornell", "ao-roma", &[], "4M", "ROMA: 4² occupancy maps of 128³ bits", "4.5 MiB"),
        ("cornell", "gi-roma", &["rsm=4096"], "100M", "gi-roma: 1 reflective shadow map of 4096² texels", "960.0 MiB"),
        ("cornell", "vpl-lightcuts", &["rsm_resolution=4096"], "500M", "vpl-lightcuts: a 4096² reflective shadow map", "GiB"),
        ("cornell", "ao-df", &[], "8M", "the 128³ distance field", "14.2 MiB"),
        ("sky", "env-dvf", &["grid=2048"], "1G", "env-dvf:", "GiB"),
        ("glossy", "wavecache", &["cache=false"], "1M", "wavecache: the cache points and tree headers", "2.7 MiB"),
        // Over the estimate's budget, the Haar coefficients are checked as they grow.
        ("glossy", "wavecache", &["cache=false"], "6M", "wavecache: the radiance cache (points and Haar coefficients) so far", "MiB"),
    ];
    let dir = temp_dir();
    for (i, (scene, technique, sets, budget, what, size)) in cases.iter().enumerate() {
        let out = dir.path().join(format!("memory-{i}.png"));
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_glimpse"));
        cmd.args(["--max-memory", budget, "render", scene, "-t", technique, "--size", "16x16"]);
        for s in sets.iter() {
            cmd.args(["--set", s]);
        }
        let o = cmd.arg("-o").arg(&out).env("GLIMPSE_CACHE", "").output().unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        println!("{technique} under {budget}: {}", e.trim());
        assert_eq!(o.status.code(), Some(1), "{technique}: {e}");
        assert!(e.contains(what) && e.contains(size) && e.contains("memory budget"), "{technique}: {e}");
        assert_eq!(e.lines().filter(|l| l.starts_with("error:")).count(), 1, "{e}");
        assert!(!out.exists());
    }
}
