//! The command line as a user meets it: each bad input gives one `error:` line naming the file or
//! argument and a non-zero exit, never a panic; good input writes the image it promises.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn glimpse(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_glimpse")).args(args).output().expect("the glimpse binary runs")
}

/// A test's scratch folder, removed with its files when dropped (at the end of the test, also
/// when it fails): keep it alive while `glimpse` runs on its files.
struct Scratch(tempfile::TempDir);

fn scratch() -> Scratch {
    Scratch(tempfile::Builder::new().prefix("glimpse-cli-").tempdir().unwrap())
}

impl Scratch {
    /// A path in the folder.
    fn tmp(&self, name: &str) -> PathBuf {
        self.0.path().join(name)
    }

    /// Writes `text` to `name` in the folder.
    fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.tmp(name);
        std::fs::write(&p, text).unwrap();
        p
    }
}

/// Asserts a clean failure: non-zero exit, no panic, and an error line containing every `needle`.
fn assert_error(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("exit {:?}: {}", out.status.code(), stderr.trim());
    assert!(!out.status.success(), "expected failure");
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    let line = stderr.lines().find(|l| l.starts_with("error")).unwrap_or_else(|| panic!("no error line in: {stderr}"));
    for n in needles {
        assert!(line.contains(n), "error line lacks '{n}': {line}");
    }
}

fn render(scene: &str, extra: &[&str]) -> Output {
    let dir = scratch();
    let out = dir.tmp("out.png");
    let mut args = vec!["render", scene, "-t", "ao-exact", "--size", "16x16", "--spp", "2", "-o", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    glimpse(&args)
}

#[test]
fn renders_the_builtin_cornell_box_to_png_and_exr() {
    let t = scratch();
    for ext in ["png", "exr"] {
        let out = t.tmp(&format!("cornell.{ext}"));
        let o = glimpse(&["render", "cornell", "-t", "ao-exact", "--size", "32x24", "--spp", "4", "-o", out.to_str().unwrap()]);
        let stdout = String::from_utf8_lossy(&o.stdout);
        println!("{}", stdout.trim());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(stdout.contains("Mrays/s") && stdout.contains("ms"), "summary line: {stdout}");
        let img = glimpse_core::Image::read(&out).unwrap();
        assert_eq!((img.width, img.height), (32, 24));
    }
}

#[test]
fn same_command_gives_the_same_image() {
    let t = scratch();
    let a = t.tmp("det-a.exr");
    let b = t.tmp("det-b.exr");
    for p in [&a, &b] {
        assert!(
            glimpse(&["render", "cornell", "-t", "ao-exact", "--size", "24x24", "--spp", "3", "--seed", "5", "-o", p.to_str().unwrap()])
                .status
                .success()
        );
    }
    assert_eq!(glimpse_core::Image::read(&a).unwrap(), glimpse_core::Image::read(&b).unwrap());
}

#[test]
fn lists_scenes_and_techniques() {
    let s = String::from_utf8_lossy(&glimpse(&["scenes"]).stdout).to_string();
    assert!(s.contains("cornell") && s.contains("many-lights"), "{s}");
    let t = String::from_utf8_lossy(&glimpse(&["techniques"]).stdout).to_string();
    assert!(t.contains("ao-exact") && t.contains("pt"), "{t}");
}

#[test]
fn missing_file_names_the_file() {
    assert_error(&render("/nonexistent/scene.obj", &[]), &["/nonexistent/scene.obj"]);
    assert_error(&render("/nonexistent/scene.gltf", &[]), &["/nonexistent/scene.gltf"]);
    assert_error(&render("/nonexistent/scene.toml", &[]), &["/nonexistent/scene.toml"]);
}

#[test]
fn malformed_files_name_the_file() {
    let t = scratch();
    let obj = t.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n");
    assert_error(&render(obj.to_str().unwrap(), &[]), &["bad.obj"]);
    let gltf = t.write("bad.gltf", "{ \"asset\": { \"version\": \"2.0\" }, \"meshes\": [ ");
    assert_error(&render(gltf.to_str().unwrap(), &[]), &["bad.gltf", "malformed"]);
    let toml = t.write("bad.toml", "name = \"x\"\n[[mesh]\nfile = 3\n");
    assert_error(&render(toml.to_str().unwrap(), &[]), &["bad.toml"]);
    let unknown_key = t.write("typo.toml", "name = \"x\"\nnmae = 2\n");
    assert_error(&render(unknown_key.to_str().unwrap(), &[]), &["typo.toml", "nmae"]);
}

#[test]
fn invalid_geometry_is_an_error() {
    let t = scratch();
    let nan = t.write("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_error(&render(nan.to_str().unwrap(), &[]), &["nan.obj", "NaN"]);
    let inf = t.write("inf.obj", "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_error(&render(inf.to_str().unwrap(), &[]), &["inf.obj"]);
    let degenerate = t.write("degenerate.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    assert_error(&render(degenerate.to_str().unwrap(), &[]), &["degenerate.obj", "degenerate"]);
    let empty = t.write("empty.obj", "# nothing here\n");
    assert_error(&render(empty.to_str().unwrap(), &[]), &["empty.obj", "empty"]);
    let flat = t.write("line.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3\nf 2 3 4\n");
    assert_error(&render(flat.to_str().unwrap(), &[]), &["line.obj"]);
}

#[test]
fn unknown_names_and_absurd_arguments_are_errors() {
    let t = scratch();
    assert_error(&render("no-such-scene", &[]), &["unknown scene 'no-such-scene'"]);
    let out = t.tmp("x.png");
    let o = out.to_str().unwrap();
    assert_error(&glimpse(&["render", "cornell", "-t", "no-such-technique", "-o", o]), &["no-such-technique"]);
    assert_error(&glimpse(&["render", "cornell", "-t", "ao-exact", "--size", "0x10", "-o", o]), &["0x10"]);
    assert_error(&glimpse(&["render", "cornell", "-t", "ao-exact", "--size", "1000000x10", "-o", o]), &["1000000x10"]);
    assert_error(&glimpse(&["render", "cornell", "-t", "ao-exact", "--spp", "0", "-o", o]), &["--spp"]);
    assert_error(&glimpse(&["render", "cornell", "-t", "ao-exact", "--spp", "999999999", "-o", o]), &["--spp"]);
    assert_error(&glimpse(&["render", "cornell", "-t", "ao-exact", "--time", "nan", "-o", o]), &["--time"]);
    assert_error(&glimpse(&["render", "cornell", "-t", "ao-exact", "--set", "radius=-1", "-o", o]), &["radius"]);
    assert_error(&glimpse(&["render", "cornell", "-t", "ao-exact", "--set", "bogus=1", "-o", o]), &["bogus", "ao-exact"]);
    assert_error(&glimpse(&["render", "cornell", "-t", "ao-exact", "-o", t.tmp("x.bmp").to_str().unwrap()]), &["x.bmp"]);
    assert_error(&glimpse(&["render", "cornell", "-t", "lights-exact", "-o", o]), &["lights-exact", "no punctual"]);
    assert_error(&glimpse(&["bench", "rays", "cornell", "--kind", "bogus"]), &["bogus"]);
    assert_error(&glimpse(&["play", "cornell", "-t", "ao-exact", "--frames", "0"]), &["--frames"]);
}

#[test]
fn eval_writes_results_json_and_report() {
    let t = scratch();
    let dir = t.tmp("eval");
    let o = glimpse(&[
        "eval",
        "cornell",
        "-t",
        "ao-exact",
        "--size",
        "16x16",
        "--spp",
        "2",
        "--ref-spp",
        "8",
        "--no-cache",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    let run = &json["runs"][0];
    println!("{}", serde_json::to_string(run).unwrap());
    assert_eq!(json["size"], serde_json::json!([16, 16]));
    assert_eq!(run["technique"], "ao-exact");
    for k in ["rmse", "mse", "relmse", "psnr", "ssim", "flip"] {
        assert!(run["metrics"][k].is_number(), "metric {k}");
    }
    for k in ["prepare", "render", "total"] {
        assert!(run["ms"][k].is_number(), "timing {k}");
    }
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(html.contains("<table") && html.contains("ao-exact.png"));
    assert!(Path::new(&dir.join("ao-exact.png")).exists() && Path::new(&dir.join("ao-exact-error.png")).exists());
}

/// Measures a technique reports of itself (here ε_v/ε_s of shadow-map decisions against exact
/// rays) reach results.json's metrics and the report's "other" column.
#[test]
fn eval_reports_shadow_epsilon() {
    let t = scratch();
    let dir = t.tmp("eval-eps");
    let o = glimpse(&[
        "eval",
        "many-lights",
        "-t",
        "lights-shadowmap",
        "--size",
        "24x16",
        "--set",
        "lights=16",
        "--set",
        "resolution=32",
        "--no-sweep",
        "--no-cache",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    let m = &json["runs"][0]["metrics"];
    println!("{m}");
    let (eps_v, eps_s) = (m["eps_v_pct"].as_f64().unwrap(), m["eps_s_pct"].as_f64().unwrap());
    assert!((0.0..=100.0).contains(&eps_v) && eps_s <= eps_v);
    assert!(std::fs::read_to_string(dir.join("report.html")).unwrap().contains("eps_v_pct"));
}

#[test]
fn bench_rays_reports_the_exact_tracer() {
    let o = glimpse(&["bench", "rays", "cornell", "--kind", "ao", "--rays", "20000", "--size", "32x32", "--only", "exact", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    println!("{json}");
    assert_eq!(json["backends"][0]["name"], "exact");
    assert_eq!(json["backends"][0]["agreement"], 1.0);
    assert!(json["rays"].as_u64().unwrap() > 0);
}

#[test]
fn play_prints_per_frame_timings_and_writes_frames() {
    let t = scratch();
    let dir = t.tmp("play");
    let o = glimpse(&[
        "play",
        "cornell-dynamic",
        "-t",
        "ao-exact",
        "--frames",
        "3",
        "--size",
        "16x16",
        "--spp",
        "1",
        "-o",
        dir.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    println!("{stdout}");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(stdout.lines().filter(|l| l.starts_with("frame")).count(), 3);
    assert!(stdout.contains("mean over 3 frames"));
    assert!(dir.join("frame-0002.png").exists());
}

#[test]
fn a_mitsuba_scene_gives_render_its_size_spp_and_depth_and_bad_xml_is_one_error_line() {
    let t = scratch();
    let scene = t.write(
        "hints.xml",
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="2"/></sampler>
        <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
    <shape type="rectangle"><transform name="to_world"><translate z="-1"/><scale value="3"/></transform></shape>
</scene>
"#,
    );
    let out_png = t.tmp("hints.png");
    let out = glimpse(&["render", scene.to_str().unwrap(), "-t", "pt", "-o", out_png.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success());
    assert!(stdout.contains("at 12x8, 2 spp"), "the film's size and the sampler's count: {stdout}");
    // max_depth 3 in Mitsuba is glimpse's 2; a contradicting --set wins over the file.
    let out =
        glimpse(&["render", scene.to_str().unwrap(), "-t", "pt", "--size", "4x4", "--set", "max_depth=1", "-o", out_png.to_str().unwrap()]);
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("at 4x4, 2 spp"));

    let bad = t.write("bad.xml", "<scene version=\"3.0.0\">\n<shape type=\"disk\"/>\n</scene>\n");
    let out = glimpse(&["render", bad.to_str().unwrap(), "-t", "pt", "-o", out_png.to_str().unwrap()]);
    assert_error(&out, &["bad.xml", "line 2", "<shape type='disk'>"]);
}

/// `eval --frames N`: a temporal technique judged after N frames has a lower error than after one
/// (ROMA blends its frames; the count is in results.json).
#[test]
fn eval_frames_accumulates_temporal_techniques() {
    let t = scratch();
    let rmse = |frames: &str| {
        let dir = t.tmp(&format!("frames-{frames}"));
        let o = glimpse(&[
            "eval",
            "cornell",
            "-t",
            "ao-roma",
            "--size",
            "24x24",
            "--spp",
            "1",
            "--ref-spp",
            "32",
            "--no-sweep",
            "--no-cache",
            "--frames",
            frames,
            "-o",
            dir.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
        assert_eq!(json["runs"][0]["frames"].as_u64(), Some(frames.parse().unwrap()));
        json["runs"][0]["metrics"]["rmse"].as_f64().unwrap()
    };
    let (one, eight) = (rmse("1"), rmse("8"));
    println!("ao-roma RMSE after 1 frame {one:.4}, after 8 frames {eight:.4}");
    assert!(eight < one * 0.8, "accumulating 8 frames must lower the error: {one} -> {eight}");
    assert_error(&glimpse(&["eval", "cornell", "--frames", "0", "-o", t.tmp("f0").to_str().unwrap()]), &["0"]);
}

/// `glimpse suite`: a scene naming a missing file is skipped with the reason; an unknown `--only`
/// name is an error naming it.
#[test]
fn suite_skips_scenes_with_missing_files_and_rejects_unknown_names() {
    let t = scratch();
    let scenes = t.tmp("suite-scenes");
    std::fs::create_dir_all(&scenes).unwrap();
    std::fs::write(scenes.join("gone.toml"), "# Needs a mesh that is not there.\n[[mesh]]\nfile = \"nowhere/missing.obj\"\n").unwrap();
    let out = t.tmp("suite-out");
    let o = glimpse(&["suite", "--quick", "--scenes", scenes.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    println!("{stderr}");
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("skipped: suite scene gone") && stderr.contains("missing.obj is missing"));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(json["cells"].as_array().map(Vec::len), Some(0));
    assert!(out.join("report.html").exists());
    let o = glimpse(&["suite", "--scenes", scenes.to_str().unwrap(), "--only", "nope", "-o", out.to_str().unwrap()]);
    assert_error(&o, &["nope", "gone"]);
}

/// A unit cube as OBJ text (counter-clockwise faces seen from outside), with no light.
const BARE_CUBE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

fn mean_luminance(img: &glimpse_core::Image) -> f32 {
    img.pixels.iter().map(|p| glimpse_core::luminance(*p)).sum::<f32>() / img.pixels.len() as f32
}

#[test]
fn a_bare_mesh_gets_a_default_light_said_once_and_renders_lit() {
    let t = scratch();
    let obj = t.write("bare-cube.obj", BARE_CUBE);
    let out = t.tmp("bare-cube.exr");
    let o = glimpse(&["render", obj.to_str().unwrap(), "-t", "pt", "--size", "24x24", "--spp", "4", "-o", out.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert_eq!(stderr.matches("uniform white environment").count(), 1, "said once: {stderr}");
    let img = glimpse_core::Image::read(&out).unwrap();
    let mean = mean_luminance(&img);
    println!("mean luminance {mean}");
    assert!(mean > 0.2, "the default environment lights the frame: mean {mean}");
}

#[test]
fn scene_overrides_apply_and_bad_values_are_errors() {
    let t = scratch();
    let obj = t.write("override-cube.obj", BARE_CUBE);
    let scene = obj.to_str().unwrap();
    let out = t.tmp("override.exr");
    // A point light and a sun replace the default light; a camera looking away sees only black.
    let lit = glimpse(&[
        "render",
        scene,
        "-t",
        "pt",
        "--size",
        "16x16",
        "--spp",
        "2",
        "--light",
        "point:0.5,3,0.5:10",
        "--sun",
        "1,2,1",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(lit.status.success(), "{}", String::from_utf8_lossy(&lit.stderr));
    assert!(!String::from_utf8_lossy(&lit.stderr).contains("uniform white"), "lights given: no default");
    assert!(mean_luminance(&glimpse_core::Image::read(&out).unwrap()) > 0.0);
    let away = glimpse(&[
        "render",
        scene,
        "-t",
        "pt",
        "--size",
        "16x16",
        "--spp",
        "2",
        "--light",
        "point:0.5,3,0.5:10",
        "--camera",
        "pos=0.5,0.5,5:target=0.5,0.5,10",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(away.status.success(), "{}", String::from_utf8_lossy(&away.stderr));
    assert_eq!(mean_luminance(&glimpse_core::Image::read(&out).unwrap()), 0.0, "the camera override looks away from the cube");
    assert_error(&render(scene, &["--camera", "pos=1,2,3"]), &["--camera", "needs pos"]);
    assert_error(&render(scene, &["--light", "spot:0,1,0:5"]), &["--light", "unknown light kind"]);
    assert_error(&render(scene, &["--sun", "0,0,0"]), &["--sun", "zero"]);
    assert_error(&render(scene, &["--env", "/nonexistent/sky.hdr"]), &["/nonexistent/sky.hdr"]);
    assert_error(&render(scene, &["--env", "sky.png"]), &["--env", ".hdr or .exr"]);
    assert_error(&render(scene, &["--env-scale", "-1", "--env", "/nonexistent/sky.hdr"]), &["--env-scale"]);
    assert!(render(scene, &["--threads", "1"]).status.success(), "--threads 1 renders");
}

/// The automatic camera shows geometry for every shared scene: most pixels' primary rays hit
/// the scene (read from the `depth` AOV), and the AO image is not one flat value except where the
/// whole view is an unoccluded exterior under the default white sky (Sponza seen from outside).
#[test]
fn no_shared_scene_renders_as_a_blank_frame() {
    let t = scratch();
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    if !shared.is_dir() {
        println!("skipped: {} is missing (the shared test scenes are not on this machine)", shared.display());
        return;
    }
    for rel in [
        "stanford-bunny/stanford-bunny.obj",
        "spot/spot.obj",
        "teapot/teapot.obj",
        "suzanne/suzanne.obj",
        "cornell-box-mcguire/CornellBox-Original.obj",
        "cornell-box-tinyobjloader/cornell_box.obj",
        "sponza-dabrovic/sponza.obj",
    ] {
        let path = shared.join(rel);
        let out = t.tmp("shared.exr");
        let o = glimpse(&[
            "render",
            path.to_str().unwrap(),
            "-t",
            "ao-exact",
            "--size",
            "32x32",
            "--spp",
            "4",
            "--aov",
            "depth",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{rel}: {}", String::from_utf8_lossy(&o.stderr));
        let exr = exr::prelude::read_all_flat_layers_from_file(&out).unwrap();
        let depth = exr.layer_data[0].channel_data.list.iter().find(|c| c.name.to_string() == "depth.Z").expect("depth AOV");
        let depths: Vec<f32> = depth.sample_data.values_as_f32().collect();
        let hits = depths.iter().filter(|d| d.is_finite()).count() as f32 / depths.len() as f32;
        let img = glimpse_core::Image::read(&out).unwrap();
        let mut lum: Vec<f32> = img.pixels.iter().map(|p| glimpse_core::luminance(*p)).collect();
        lum.sort_by(f32::total_cmp);
        let median = lum[lum.len() / 2];
        let differing = lum.iter().filter(|l| (*l - median).abs() > 0.05).count() as f32 / lum.len() as f32;
        println!(
            "{rel}: {:.0}% of pixels see geometry; {:.1}% of pixels away from the median AO {median:.3}",
            hits * 100.0,
            differing * 100.0
        );
        // The camera frames the scene: a good part of the view is geometry (a camera inside a
        // wall sees it everywhere at depth ~0; one facing away sees none).
        assert!(hits > 0.15, "{rel}: only {:.0}% of the view is geometry", hits * 100.0);
        if !rel.starts_with("sponza") {
            assert!(differing > 0.01, "{rel} renders as a flat frame");
        }
    }
}

#[test]
fn typos_get_a_did_you_mean_and_unwritable_outputs_fail_before_work() {
    let t = scratch();
    assert_error(&render("cornel", &[]), &["unknown scene 'cornel'", "did you mean 'cornell'"]);
    let o = t.tmp("dym.png");
    assert_error(&glimpse(&["render", "cornell", "-t", "ao-exac", "-o", o.to_str().unwrap()]), &["ao-exac", "did you mean 'ao-exact'"]);
    // A file where the output's directory should be: refused before the scene is even loaded.
    let file = t.write("not-a-dir", "x");
    let bad = file.join("out.png");
    let started = std::time::Instant::now();
    assert_error(&glimpse(&["render", "cornell", "-t", "pt", "--size", "2000x2000", "-o", bad.to_str().unwrap()]), &["not-a-dir"]);
    println!("refused after {:?}", started.elapsed());
}

#[test]
fn bench_only_rejects_unknown_backends() {
    assert_error(&glimpse(&["bench", "rays", "cornell", "--only", "romaa", "--rays", "100"]), &["--only romaa", "did you mean 'roma'"]);
}

/// `render --aov` writes the GBuffer's albedo, normal, depth and position as channel groups of
/// the EXR beside the unchanged image; a non-EXR output or an unknown AOV is an error up front.
#[test]
fn aovs_are_written_as_exr_channels_beside_the_image() {
    let t = scratch();
    let (with, without) = (t.tmp("aov.exr"), t.tmp("no-aov.exr"));
    let args = |out: &std::path::Path| {
        ["render", "cornell", "-t", "ao-exact", "--size", "24x16", "--spp", "2", "-o", out.to_str().unwrap()].map(str::to_owned).to_vec()
    };
    let mut a = args(&with);
    a.extend(["--aov".to_owned(), "albedo,normal,depth,position".to_owned()]);
    let o = glimpse(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = glimpse(&args(&without).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success());
    let image = exr::prelude::read_all_flat_layers_from_file(&with).expect("the EXR reads back");
    let layer = &image.layer_data[0];
    let channel = |name: &str| -> Vec<f32> {
        let c = layer.channel_data.list.iter().find(|c| c.name.to_string() == name).unwrap_or_else(|| panic!("no channel {name}"));
        c.sample_data.values_as_f32().collect()
    };
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    println!("channels: {names:?}");
    assert_eq!(names.len(), 3 + 3 + 3 + 1 + 3);
    // The image itself is the render without AOVs.
    let plain = glimpse_core::Image::read(&without).unwrap();
    for (k, c) in ["R", "G", "B"].iter().enumerate() {
        assert!(channel(c).iter().zip(&plain.pixels).all(|(a, p)| *a == p[k]), "channel {c} differs from the plain render");
    }
    // Hits: unit normals, finite positive depth equal to the distance from the camera, an albedo
    // of the box's colours (all within [0, 1]).
    let (nx, ny, nz, depth) = (channel("normal.X"), channel("normal.Y"), channel("normal.Z"), channel("depth.Z"));
    let (px, py, pz) = (channel("position.X"), channel("position.Y"), channel("position.Z"));
    let scene = glimpse_scene::load("cornell").unwrap();
    let eye = scene.camera.expect("cornell has a camera").position;
    let mut hits = 0;
    for i in 0..depth.len() {
        if depth[i].is_finite() {
            hits += 1;
            let n = (nx[i] * nx[i] + ny[i] * ny[i] + nz[i] * nz[i]).sqrt();
            let d = (glimpse_core::Vec3::new(px[i], py[i], pz[i]) - eye).length();
            assert!(
                (n - 1.0).abs() < 1e-3 && depth[i] > 0.0 && (d - depth[i]).abs() < 1e-3 * depth[i].max(1.0),
                "pixel {i}: |n| {n}, depth {} vs {d}",
                depth[i]
            );
        }
    }
    assert!(hits > depth.len() / 2, "{hits} hits");
    assert!(channel("albedo.G").iter().all(|v| (0.0..=1.0).contains(v)) && channel("albedo.R").iter().any(|v| *v > 0.1));
    assert_error(
        &glimpse(&["render", "cornell", "-t", "ao-exact", "--aov", "albedo", "-o", t.tmp("aov.png").to_str().unwrap()]),
        &["--aov", ".exr"],
    );
    assert_error(
        &glimpse(&["render", "cornell", "-t", "ao-exact", "--aov", "albdeo", "-o", with.to_str().unwrap()]),
        &["albdeo", "albedo"],
    );
}

/// The tev packets of one connection: (type, payload after the type byte), checking each
/// packet's length prefix.
fn tev_packets(bytes: &[u8]) -> TevPackets {
    let mut out = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let n = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        assert!(n >= 5 && at + n <= bytes.len(), "packet length {n} at {at} of {}", bytes.len());
        out.push((bytes[at + 4], bytes[at + 5..at + n].to_vec()));
        at += n;
    }
    out
}

/// `render --tev HOST:PORT` speaks tev's protocol: CreateImage, then one UpdateImageV3 per film
/// pass whose last one is the written image; an unreachable tev is an error before rendering.
#[test]
fn tev_receives_the_image_as_it_converges() {
    let t = scratch();
    use std::io::Read;
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let server = std::thread::spawn(move || {
        let (mut s, _) = listener.accept().unwrap();
        let mut bytes = Vec::new();
        s.read_to_end(&mut bytes).unwrap();
        bytes
    });
    let out = t.tmp("tev.exr");
    let o = glimpse(&[
        "render",
        "cornell",
        "-t",
        "ao-exact",
        "--size",
        "20x12",
        "--spp",
        "1",
        "--film-samples",
        "3",
        "--tev",
        &address,
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let packets = tev_packets(&server.join().unwrap());
    println!("{} packets: types {:?}", packets.len(), packets.iter().map(|p| p.0).collect::<Vec<_>>());
    assert_eq!(packets.iter().map(|p| p.0).collect::<Vec<_>>(), [4, 6, 6, 6]);
    // CreateImage: grab focus, name, 20 × 12, 3 channels R, G, B.
    let create = &packets[0].1;
    let name = b"ao-exact cornell\0";
    assert_eq!(&create[1..1 + name.len()], name);
    let ints: Vec<i32> = create[1 + name.len()..1 + name.len() + 12].chunks(4).map(|c| i32::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(ints, [20, 12, 3]);
    assert_eq!(&create[1 + name.len() + 12..], b"R\0G\0B\0");
    // The last update's samples are the written image.
    let update = &packets[3].1;
    let header = 1 + name.len() + 4 + 6 + 16 + 48;
    let samples: Vec<f32> = update[header..].chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    let image = glimpse_core::Image::read(&out).unwrap();
    assert_eq!(samples.len(), 20 * 12 * 3);
    assert!(samples.chunks(3).zip(&image.pixels).all(|(s, p)| s == [p.x, p.y, p.z]), "the last update is the image");
    assert_error(
        &glimpse(&["render", "cornell", "-t", "ao-exact", "--size", "8x8", "--tev", "127.0.0.1:1", "-o", out.to_str().unwrap()]),
        &["tev", "127.0.0.1:1"],
    );
}

/// A tev stand-in: accepts connections until `glimpse` has exited, and returns each connection's
/// packets (a connection that sends nothing is the reachability probe).
/// One connection's tev packets: (type, payload).
type TevPackets = Vec<(u8, Vec<u8>)>;

fn tev_server_run(args_after: impl FnOnce(&str) -> Output) -> (Output, Vec<TevPackets>) {
    use std::io::Read;
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    listener.set_nonblocking(true).unwrap();
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let server = {
        let done = done.clone();
        std::thread::spawn(move || {
            let mut connections = Vec::new();
            loop {
                match listener.accept() {
                    Ok((mut s, _)) => {
                        s.set_nonblocking(false).unwrap();
                        let mut bytes = Vec::new();
                        s.read_to_end(&mut bytes).unwrap();
                        connections.push(tev_packets(&bytes));
                    }
                    Err(_) if done.load(std::sync::atomic::Ordering::SeqCst) => break,
                    Err(_) => std::thread::sleep(std::time::Duration::from_millis(5)),
                }
            }
            connections
        })
    };
    let out = args_after(&address);
    // Connections the process opened are queued before it exits; give the loop time to drain.
    std::thread::sleep(std::time::Duration::from_millis(200));
    done.store(true, std::sync::atomic::Ordering::SeqCst);
    (out, server.join().unwrap())
}

/// `play --tev` sends every frame to one tev image; `eval --tev` sends each reference and each
/// technique's image as its own tev image, after checking tev is reachable.
#[test]
fn play_and_eval_stream_to_tev() {
    let t = scratch();
    let (o, connections) = tev_server_run(|address| {
        glimpse(&["play", "cornell", "-t", "ao-exact", "--frames", "3", "--size", "16x16", "--spp", "1", "--tev", address])
    });
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let types: Vec<Vec<u8>> = connections.iter().map(|c| c.iter().map(|p| p.0).collect()).collect();
    println!("play: {types:?}");
    assert_eq!(types, [vec![4, 6, 6, 6]], "one image, one update per frame");
    let dir = t.tmp("eval-tev");
    let (o, connections) = tev_server_run(|address| {
        glimpse(&[
            "eval",
            "cornell",
            "-t",
            "ao-roma",
            "--size",
            "16x16",
            "--spp",
            "2",
            "--ref-spp",
            "4",
            "--no-cache",
            "--tev",
            address,
            "-o",
            dir.to_str().unwrap(),
        ])
    });
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names: Vec<String> = connections
        .iter()
        .filter(|c| !c.is_empty())
        .map(|c| {
            let create = &c[0].1;
            String::from_utf8_lossy(&create[1..create.iter().skip(1).position(|&b| b == 0).unwrap() + 1]).into_owned()
        })
        .collect();
    println!("eval: {} connections, images {names:?}", connections.len());
    assert!(connections[0].is_empty(), "the reachability probe comes first");
    assert_eq!(names, ["ref ao-exact seed 0", "ao-roma"]);
    assert_error(
        &glimpse(&["eval", "cornell", "-t", "ao-roma", "--size", "8x8", "--tev", "127.0.0.1:1", "-o", dir.to_str().unwrap()]),
        &["tev", "127.0.0.1:1"],
    );
}
