//! Issue #15 from the user's side: outputs are written atomically and never replace what is not a
//! regular file; files that are not regular or too big are refused; a run that would not fit in
//! memory is refused up front; degenerate animation and camera values are errors.

use std::process::{Command, Output};

fn glimpse(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_glimpse")).args(args).env("GLIMPSE_CACHE", "").output().expect("the glimpse binary runs")
}

/// A fresh folder, removed when the test ends (also when it fails): it outlives the `glimpse` runs.
fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("glimpse-robust-").tempdir().unwrap()
}

/// Status 1, exactly one stderr line, starting `error:` and containing every needle.
fn assert_one_error(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    println!("exit {:?}: {}", out.status.code(), stderr.trim());
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(lines.len(), 1, "one line: {stderr}");
    for n in needles {
        assert!(lines[0].starts_with("error: ") && lines[0].contains(n), "error line lacks '{n}': {}", lines[0]);
    }
}

fn render_to(out: &str, extra: &[&str]) -> Output {
    let mut args = vec!["render", "cornell", "-t", "ao-exact", "--size", "8x8", "--spp", "1", "-o", out];
    args.extend_from_slice(extra);
    glimpse(&args)
}

#[test]
fn outputs_never_replace_devices_or_folders_and_leave_old_files() {
    let dir = scratch();
    let tmp = |name: &str| dir.path().join(name);
    for ext in ["png", "hdr", "exr"] {
        let good = tmp(&format!("good.{ext}"));
        let ok = render_to(good.to_str().unwrap(), &[]);
        assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
        let before = std::fs::read(&good).unwrap();
        // A folder in the way of the output: refused, named, and nothing else changes.
        let folder = tmp(&format!("folder.{ext}"));
        std::fs::create_dir_all(&folder).unwrap();
        assert_one_error(&render_to(folder.to_str().unwrap(), &[]), &[&format!("folder.{ext}"), "not a regular file"]);
        assert!(folder.is_dir());
        assert_eq!(std::fs::read(&good).unwrap(), before);
    }
    if std::path::Path::new("/dev/full").exists() {
        assert_one_error(&render_to("/dev/full", &[]), &["/dev/full"]);
        use std::os::unix::fs::FileTypeExt;
        assert!(std::fs::metadata("/dev/full").unwrap().file_type().is_char_device(), "the device is untouched");
    }
    let leftovers: Vec<_> =
        std::fs::read_dir(dir.path()).unwrap().flatten().filter(|e| e.file_name().to_string_lossy().contains(".tmp")).collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn work_over_the_memory_budget_is_refused_up_front() {
    let dir = scratch();
    let tmp = |name: &str| dir.path().join(name);
    let out = tmp("big.png");
    let r = glimpse(&["render", "cornell", "-t", "ao-exact", "--size", "16384x16384", "--max-memory", "1G", "-o", out.to_str().unwrap()]);
    assert_one_error(&r, &["16384x16384", "41.0 GiB", "1.0 GiB", "--max-memory"]);
    let toml = tmp("divisions.toml");
    std::fs::write(&toml, "[[quad]]\ndivisions = [4096, 4096]\n").unwrap();
    let r = render_to(out.to_str().unwrap(), &[]);
    assert!(r.status.success());
    let r =
        glimpse(&["render", toml.to_str().unwrap(), "-t", "ao-exact", "--size", "8x8", "--max-memory", "1G", "-o", out.to_str().unwrap()]);
    assert_one_error(&r, &["divisions.toml", "4096x4096 divisions", "1.0 GiB"]);
    let r = glimpse(&["render", "cornell", "--max-memory", "lots", "-o", out.to_str().unwrap()]);
    assert_eq!(r.status.code(), Some(2), "a malformed --max-memory is a usage error");
}
