//! Issue #15: files that would make a loader read or allocate without bound are refused before
//! the read or the allocation, with an error (or, for a texture or material library, a warning)
//! naming the file and the limit; degenerate animation and camera values are errors.

use glimpse_scene::SceneError;
use std::path::Path;

mod common;
use common::{scratch, write};

fn load(path: &Path) -> Result<glimpse_scene::Scene, SceneError> {
    glimpse_scene::load(path.to_str().unwrap())
}

fn load_err(path: &Path) -> String {
    let e = load(path).expect_err("must fail").to_string();
    println!("{}: {e}", path.file_name().unwrap().to_string_lossy());
    e
}

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

fn base64(bytes: &[u8]) -> String {
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for i in 0..4 {
            out.push(if i <= c.len() { B64[(n >> (18 - 6 * i) & 63) as usize] as char } else { '=' });
        }
    }
    out
}

/// A one-triangle glTF whose buffer is `buffer_uri` (36 bytes of positions), with `extra`
/// spliced into the top-level object (images, materials).
fn triangle_gltf(buffer_uri: &str, extra: &str) -> String {
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}{material}}}]}}],
  "buffers": [{{"byteLength": 36, "uri": "{buffer_uri}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}]{extra}}}"#,
        material = if extra.is_empty() { "" } else { r#", "material": 0"# },
    )
}

fn triangle_bytes() -> Vec<u8> {
    [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()).collect()
}

#[test]
fn sparse_accessor_bomb_is_refused_before_allocating() {
    let dir = scratch("bomb");
    // An accessor of 2^31 VEC3s with no bufferView and one sparse value: 24 GiB of zeros asked for
    // by a file of under a kilobyte.
    let data = [0u8, 0, 0, 0].iter().copied().chain([1f32, 2., 3.].iter().flat_map(|v| v.to_le_bytes())).collect::<Vec<u8>>();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"buffers":[{{"byteLength":16,"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":4}},{{"buffer":0,"byteOffset":4,"byteLength":12}}],
"accessors":[{{"componentType":5126,"count":2147483648,"type":"VEC3","min":[0,0,0],"max":[1,2,3],
"sparse":{{"count":1,"indices":{{"bufferView":0,"componentType":5125}},"values":{{"bufferView":1}}}}}}]}}"#,
        base64(&data)
    );
    println!("bomb: {} bytes", json.len());
    assert!(json.len() < 1024);
    let e = load_err(&write(&dir, "bomb.gltf", &json));
    assert!(e.contains("bomb.gltf") && e.contains("2147483648 elements") && e.contains("no bufferView"), "{e}");
    // Same with 2^26 (776 MB before validation used to reject it).
    let e = load_err(&write(&dir, "bomb26.gltf", json.replace("2147483648", "67108864")));
    assert!(e.contains("67108864 elements"), "{e}");
    // A sparse part that claims more values than its view holds.
    let e = load_err(&write(
        &dir,
        "sparse.gltf",
        json.replace("2147483648", "1").replace(r#""count":1,"indices""#, r#""count":1000,"indices""#),
    ));
    assert!(e.contains("sparse"), "{e}");
    // A view-backed accessor whose count runs past its view.
    write(&dir, "t.bin", triangle_bytes());
    let e = load_err(&write(&dir, "count.gltf", triangle_gltf("t.bin", "").replace(r#""count": 3"#, r#""count": 300000000"#)));
    assert!(e.contains("count.gltf") && e.contains("300000000 elements") && e.contains("36"), "{e}");
}

#[test]
fn uris_pointing_at_devices_are_refused_without_reading() {
    let dir = scratch("devzero");
    if !Path::new("/dev/zero").exists() {
        println!("skipped: no /dev/zero");
        return;
    }
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bin")).unwrap();
    for (name, uri) in [("abs.gltf", "file:///dev/zero"), ("rel.gltf", "zero.bin")] {
        let e = load_err(&write(&dir, name, triangle_gltf(uri, "")));
        assert!(e.contains(name) && e.contains("not a regular file") && e.contains("glTF buffer"), "{e}");
    }
    // A texture uri at /dev/zero: a warning, the colour factor alone, and no read.
    write(&dir, "t.bin", triangle_bytes());
    let image = r#", "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}], "textures": [{"source": 0}], "images": [{"uri": "zero.bin"}]"#;
    let scene = load(&write(&dir, "tex.gltf", triangle_gltf("t.bin", image))).unwrap();
    println!("texture warnings: {:?}", scene.warnings);
    assert!(scene.warnings.iter().any(|w| w.contains("zero.bin") && w.contains("not a regular file")));
    assert!(scene.textures.is_empty());
    // An OBJ whose mtllib is /dev/zero: a warning and the default material.
    let scene = load(&write(&dir, "m.obj", "mtllib zero.bin\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")).unwrap();
    println!("mtllib warnings: {:?}", scene.warnings);
    assert!(scene.warnings.iter().any(|w| w.contains("zero.bin") && w.contains("not a regular file")));
    // The scene file itself, and a scene.toml environment map.
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.obj")).unwrap();
    let e = load_err(&dir.join("zero.obj"));
    assert!(e.contains("not a regular file"), "{e}");
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.hdr")).unwrap();
    let e = load_err(&write(&dir, "env.toml", "[[box]]\n[environment]\nfile = \"zero.hdr\"\n"));
    assert!(e.contains("zero.hdr") && e.contains("not a regular file"), "{e}");
}

#[test]
fn degenerate_animation_and_camera_values_are_errors() {
    let dir = scratch("degenerate");
    let cases = [
        ("spin-axis.toml", "[[box]]\nspin = { axis = [0, 0, 0], period_s = 2 }\n", "spin axis"),
        (
            "orbit-axis.toml",
            "[[box]]\n[[light]]\nkind = \"point\"\nposition = [0, 2, 0]\norbit = { axis = [0, 0, 0], period_s = 4 }\n",
            "orbit axis",
        ),
        ("scale-key.toml", "[[box]]\nkeyframes = [{ time = 0 }, { time = 1, scale = 0 }]\n", "scale"),
        ("scale.toml", "[[box]]\nscale = [1, 0, 1]\n", "non-zero"),
        ("amplitude.toml", "[[quad]]\nwave = { amplitude = 1e38, wavelength = 0.1, period_s = 1 }\n", "amplitude"),
        ("fov.toml", "[camera]\nposition = [0, 0, 3]\ntarget = [0, 0, 0]\nfov_y_degrees = 179.99\n[[box]]\n", "field of view"),
    ];
    for (name, text, needle) in cases {
        let e = load_err(&write(&dir, name, text));
        assert!(e.contains(name) && e.contains(needle), "{name}: '{needle}' not in: {e}");
    }
    // Their sound neighbours still load.
    for text in [
        "[[box]]\nspin = { axis = [0, 0, 2], period_s = 2 }\n",
        "[[quad]]\nwave = { amplitude = 0.05, wavelength = 0.1, period_s = 1 }\n",
        "[camera]\nposition = [0, 0, 3]\ntarget = [0, 0, 0]\nfov_y_degrees = 170\n[[box]]\n",
    ] {
        load(&write(&dir, "ok.toml", text)).unwrap();
    }
}
