//! Ctrl-C at any moment of a render leaves the previous output whole (issue #15 item 5): the
//! image is written to a temporary file and renamed over the old one, so an interrupt either
//! comes before the rename (the old file stays) or after it (the new file is complete).
//! The interrupts are spread over the whole run, the write included, on PNG, HDR and EXR.

use glimpse_core::Image;
use std::process::{Command, Stdio};
use std::time::Instant;

fn render(out: &std::path::Path) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_glimpse"))
        .args(["render", "cornell", "-t", "ao-exact", "--size", "768x768", "--spp", "1", "-o"])
        .arg(out)
        .env("GLIMPSE_CACHE", "")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the glimpse binary runs")
}

#[test]
fn an_interrupted_render_never_leaves_a_truncated_image() {
    // Removed when the test ends (also when it fails); every render is waited for before that.
    let tmp = tempfile::Builder::new().prefix("glimpse-interrupt-").tempdir().unwrap();
    let dir = tmp.path();
    for ext in ["png", "hdr", "exr"] {
        let out = dir.join(format!("image.{ext}"));
        // The previous image: a small one, so an interrupted run is told apart from a finished one.
        Image::new(4, 4).write(&out, Default::default()).unwrap();
        let old = std::fs::read(&out).unwrap();
        // One uninterrupted run measures how long a run takes here.
        let start = Instant::now();
        assert!(render(&out).wait().unwrap().success());
        let full = start.elapsed();
        let (mut kept, mut replaced, mut leftovers) = (0, 0, 0);
        let tries = 12;
        for k in 0..tries {
            std::fs::write(&out, &old).unwrap();
            let mut child = render(&out);
            // Interrupts from early in the run to just past its usual end.
            std::thread::sleep(full.mul_f64(0.3 + 0.8 * k as f64 / tries as f64));
            Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
            let status = child.wait().unwrap();
            assert!(status.success() || status.code() == Some(130), "{ext}, try {k}: exit {status:?}");
            let now = std::fs::read(&out).unwrap_or_default();
            if now == old {
                kept += 1;
            } else {
                let img = Image::read(&out)
                    .unwrap_or_else(|e| panic!("{ext}, try {k}: the output is neither the old image nor a whole new one: {e}"));
                assert_eq!((img.width, img.height), (768, 768), "{ext}, try {k}");
                replaced += 1;
            }
            // The interrupt handler removes the temporary file of a write in progress.
            for e in std::fs::read_dir(dir).unwrap().filter_map(|e| e.ok()) {
                if e.file_name().to_string_lossy().contains(".tmp") {
                    leftovers += 1;
                    std::fs::remove_file(e.path()).unwrap();
                }
            }
        }
        println!(
            "{ext}: a full run takes {full:?}; of {tries} interrupted runs {kept} kept the old image, {replaced} left a whole new one ({leftovers} temporary files left)"
        );
        assert_eq!(kept + replaced, tries);
        assert_eq!(leftovers, 0, "{ext}: interrupted writes left temporary files");
    }
}
