//! Long steps show progress, and the summary's parts add up to its total (issue #16).

use std::process::Command;

/// The summary's "tracer A ms + prepare B ms [...] + render C ms [...] + other D ms (...) = total E ms".
fn parts(summary: &str) -> (Vec<f64>, f64) {
    let number_before = |key: &str| -> f64 {
        let at = summary.find(key).unwrap_or_else(|| panic!("no '{key}' in {summary}")) + key.len();
        summary[at..].trim_start().split(' ').next().unwrap().parse().unwrap()
    };
    (
        vec![number_before("tracer"), number_before("+ prepare"), number_before("+ render"), number_before("+ other")],
        number_before("= total"),
    )
}

/// A fresh folder, removed when the test ends (also when it fails): it outlives the `glimpse` runs.
fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("glimpse-{name}-")).tempdir().unwrap()
}

#[test]
fn the_summary_lists_every_stage_and_they_add_up() {
    let dir = temp_dir("progress");
    let out = dir.path().join("progress.png");
    let o = Command::new(env!("CARGO_BIN_EXE_glimpse"))
        .args(["render", "cornell", "-t", "soft-roma", "--size", "32x32", "-o"])
        .arg(&out)
        .env("GLIMPSE_CACHE", "")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    println!("{stdout}");
    assert!(o.status.success());
    let (parts, total) = parts(&stdout);
    let sum: f64 = parts.iter().sum();
    assert!((sum - total).abs() < 0.3, "{parts:?} sum to {sum}, total {total}");
    assert!(
        stdout.contains("[focus ") && stdout.contains(", bom ") && stdout.contains("generate "),
        "the prepare's stages are listed: {stdout}"
    );
}

/// Under a terminal (`script` gives the child a pty), a prepare longer than a second shows a
/// spinner naming it.
#[test]
fn a_long_prepare_shows_a_spinner_on_a_terminal() {
    if Command::new("script").arg("--version").output().is_err() {
        println!("skipped: `script` (util-linux) is not installed");
        return;
    }
    let dir = temp_dir("spinner");
    let out = dir.path().join("spinner.png");
    // A voxel array of 60 × 60 directions: a few seconds of build.
    let cmd = format!(
        "{} render many-lights -t lights-voxarray --size 16x16 --set epsilon=false --set disk_cache=false --set resolution=64 --set directions=60 -o {}",
        env!("CARGO_BIN_EXE_glimpse"),
        out.display()
    );
    let o = Command::new("script").args(["-qec", &cmd, "/dev/null"]).env("GLIMPSE_CACHE", "").output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}");
    let prepare_ms = parts(text.lines().find(|l| l.contains("= total")).expect("a summary line")).0[1];
    println!("prepare {prepare_ms:.0} ms; spinner shown: {}", text.contains("preparing lights-voxarray"));
    if prepare_ms > 1500.0 {
        assert!(text.contains("preparing lights-voxarray"), "no spinner during a {prepare_ms} ms prepare: {text}");
    }
}

/// `eval`'s reference render (here 64×64 AO at 4,096 spp: seconds on 2 cores) shows a pixel bar
/// naming the reference under a terminal, as `render` does.
#[test]
fn an_eval_reference_render_shows_a_progress_bar_on_a_terminal() {
    if Command::new("script").arg("--version").output().is_err() {
        println!("skipped: `script` (util-linux) is not installed");
        return;
    }
    let dir = temp_dir("eval-progress");
    let out = dir.path().join("eval");
    let cmd = format!(
        "{} eval cornell -t ao-roma --size 64x64 --spp 1 --ref-spp 4096 --no-sweep --no-cache -o {}",
        env!("CARGO_BIN_EXE_glimpse"),
        out.display()
    );
    let start = std::time::Instant::now();
    let o = Command::new("script").args(["-qec", &cmd, "/dev/null"]).env("GLIMPSE_CACHE", "").output().unwrap();
    let seconds = start.elapsed().as_secs_f64();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}");
    let shown = text.contains("rendering ao-exact") && text.contains("% pixels");
    println!("eval took {seconds:.1} s; reference bar shown: {shown}");
    // The reference is most of the run: a run over 3 s had a reference render over a second.
    if seconds > 3.0 {
        assert!(shown, "no progress bar during a {seconds:.1} s eval: {text}");
    }
}
