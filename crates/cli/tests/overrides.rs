//! Scene overrides (`--light`, `--sun`, `--camera`, `--env`, `--filter`, …) on every command that
//! takes a scene, not only `render` (issue #16), and in `eval`'s reference cache key.

use std::path::Path;
use std::process::{Command, Output};

fn glimpse(args: &[&str], cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_glimpse")).args(args).env("GLIMPSE_CACHE", cache).output().expect("the glimpse binary runs")
}

/// A fresh folder, removed when the test ends (also when it fails): it outlives the `glimpse` runs.
fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("glimpse-{name}-")).tempdir().unwrap()
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

#[test]
fn eval_play_and_bench_take_the_scene_overrides() {
    let tmp = temp_dir("overrides");
    let dir = tmp.path();
    // A bare OBJ: a floor and a small box, no lights.
    let obj = dir.join("floor.obj");
    std::fs::write(
        &obj,
        "v -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\nv -0.3 0.5 -0.3\nv 0.3 0.5 -0.3\nv 0.3 0.5 0.3\nf 1 3 2\nf 1 4 3\nf 5 6 7\n",
    )
    .unwrap();
    let obj = obj.to_str().unwrap();
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    let cache = dir.join("cache");
    let eval = |extra: &[&str]| {
        let mut args =
            vec!["eval", obj, "-t", "lights-shadowmap", "--size", "24x24", "--spp", "1", "--ref-spp", "1", "--no-sweep", "-o", out];
        args.extend_from_slice(extra);
        glimpse(&args, &cache)
    };
    // Without a punctual light the shadow-map baseline has nothing to do.
    let bare = eval(&[]);
    assert!(!bare.status.success() && text(&bare).contains("punctual"), "{}", text(&bare));
    // --light and --sun add them, in eval as in render.
    let lit = eval(&["--light", "point:0,2,0:5", "--sun", "1,2,1"]);
    assert!(lit.status.success(), "{}", text(&lit));
    let results = std::fs::read_to_string(dir.join("out/results.json")).unwrap();
    assert!(results.contains("lights-shadowmap"));
    // Another camera is another reference image: not taken from the cache.
    let moved = eval(&["--light", "point:0,2,0:5", "--sun", "1,2,1", "--camera", "pos=3,2,3:target=0,0,0"]);
    assert!(moved.status.success(), "{}", text(&moved));
    let results = std::fs::read_to_string(dir.join("out/results.json")).unwrap();
    assert!(results.contains("\"reference_cached\": false"), "a reference of another view came from the cache");
    let again = eval(&["--light", "point:0,2,0:5", "--sun", "1,2,1", "--camera", "pos=3,2,3:target=0,0,0"]);
    assert!(again.status.success());
    let results = std::fs::read_to_string(dir.join("out/results.json")).unwrap();
    assert!(results.contains("\"reference_cached\": true"), "the same view's reference is cached");

    let play = glimpse(&["play", obj, "-t", "lights-exact", "--frames", "1", "--size", "16x16", "--light", "point:0,2,0:5"], &cache);
    assert!(play.status.success(), "play: {}", text(&play));
    let bench = glimpse(&["bench", "rays", obj, "--kind", "shadow", "--rays", "500", "--only", "exact", "--sun", "1,2,1"], &cache);
    assert!(bench.status.success(), "bench: {}", text(&bench));
    let bad = glimpse(&["play", obj, "-t", "ao-exact", "--frames", "1", "--size", "16x16", "--env", "sky.png"], &cache);
    assert!(!bad.status.success() && text(&bad).contains("--env sky.png"), "{}", text(&bad));
}

/// `--scale` renders the same picture in other units; a scale that is not a positive number is
/// an error naming the option.
#[test]
fn scale_keeps_the_picture_and_rejects_nonsense() {
    let tmp = temp_dir("scale");
    let dir = tmp.path();
    // The --light is in the scaled units (the overrides come after the scale).
    let render = |scale: &str, light: &str| {
        let out = dir.join(format!("scale-{scale}.exr"));
        let o = glimpse(
            &["render", "glossy", "-t", "lights-exact", "--light", light, "--size", "16x12", "--scale", scale, "-o", out.to_str().unwrap()],
            dir,
        );
        (o, out)
    };
    let (a, a_out) = render("1", "point:0,1.5,0:4");
    let (b, b_out) = render("100", "point:0,150,0:40000");
    assert!(a.status.success() && b.status.success(), "{}{}", text(&a), text(&b));
    let (a, b) = (glimpse_core::Image::read(&a_out).unwrap(), glimpse_core::Image::read(&b_out).unwrap());
    let worst = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (*p - *q).abs().max_element() / p.max_element().max(1e-3)).fold(0.0, f32::max);
    println!("--scale 100 vs 1: worst relative pixel difference {worst:e}");
    assert!(worst < 1e-3, "--scale 100 changed the picture: {worst}");
    let (bad, _) = render("0", "point:0,1.5,0:4");
    assert!(!bad.status.success() && text(&bad).contains("--scale 0"), "{}", text(&bad));
}
