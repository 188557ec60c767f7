//! Loader tests: the shared test scenes with the triangle counts of their README, small files
//! written here for every feature (glTF hierarchy, lights, camera, animation; OBJ materials;
//! scene.toml), and bad input, each error checked for the file's name and the problem.

use glimpse_core::{Image, ToneMap, Vec2, Vec3, luminance};
use glimpse_scene::{LightKind, Motion, Scene, SceneError};
use std::path::{Path, PathBuf};

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

mod common;
use common::{load, scratch, shared_scenes, write};

fn load_err(path: &Path) -> String {
    match load(path) {
        Ok(s) => panic!("{} loaded ({} triangles) but should fail", path.display(), s.triangle_count()),
        Err(e) => {
            println!("{}: error as printed: {e}", path.file_name().unwrap().to_string_lossy());
            e.to_string()
        }
    }
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-4
}

#[test]
fn shared_scenes_load_with_the_readme_triangle_counts() {
    let Some(shared) = shared_scenes() else { return };
    let repo = crate_dir().join("../..");
    let mitsuba = "cornell-box-mitsuba/meshes";
    let cases: Vec<(PathBuf, usize)> = vec![
        (shared.join("stanford-bunny/stanford-bunny.obj"), 69_451),
        (shared.join("spot/spot.obj"), 5_856),
        (shared.join("teapot/teapot.obj"), 6_320),
        (shared.join("suzanne/suzanne.obj"), 968),
        (shared.join("cornell-box-mcguire/CornellBox-Original.obj"), 36),
        (shared.join("cornell-box-tinyobjloader/cornell_box.obj"), 36),
        (shared.join("sponza-dabrovic/sponza.obj"), 66_447),
        (shared.join(format!("{mitsuba}/cbox_back.obj")), 2),
        (shared.join(format!("{mitsuba}/cbox_ceiling.obj")), 2),
        (shared.join(format!("{mitsuba}/cbox_floor.obj")), 2),
        (shared.join(format!("{mitsuba}/cbox_greenwall.obj")), 2),
        (shared.join(format!("{mitsuba}/cbox_redwall.obj")), 2),
        (shared.join(format!("{mitsuba}/cbox_luminaire.obj")), 2),
        (shared.join(format!("{mitsuba}/cbox_smallbox.obj")), 12),
        (shared.join(format!("{mitsuba}/cbox_largebox.obj")), 12),
        (repo.join("scenes/cbox-mitsuba.toml"), 12),
        (repo.join("scenes/spot.toml"), 5_856 + 2),
        (repo.join("scenes/bunny-turntable.toml"), 69_451 + 96 * 96 * 2 + 12 + 64 * 31 * 2),
    ];
    for (path, expected) in cases {
        let t0 = std::time::Instant::now();
        let scene = load(&path).unwrap_or_else(|e| panic!("{e}"));
        let tris = scene.triangle_count();
        let removed = expected - tris;
        let b = scene.bounds();
        println!(
            "{}: {tris} triangles (expected {expected}, {removed} degenerate removed), {} meshes, {} materials, {} textures, {} lights, \
             bounds {:.4} .. {:.4}, {:.0} ms",
            path.file_name().unwrap().to_string_lossy(),
            scene.meshes.len(),
            scene.materials.len(),
            scene.textures.len(),
            scene.lights.len(),
            b.min,
            b.max,
            t0.elapsed().as_secs_f64() * 1e3
        );
        for w in &scene.warnings {
            println!("    warning: {w}");
        }
        assert!(removed * 1000 <= expected, "{}: more than 0.1% of the triangles removed", path.display());
        if removed > 0 {
            let said = scene.warnings.iter().any(|w| w.contains(&format!("removed {removed} degenerate")));
            let said_split = scene.warnings.iter().filter(|w| w.contains("degenerate")).count() > 0;
            assert!(said || said_split, "the removed triangles are reported");
        }
    }
}

#[test]
fn mcguire_light_emits_and_spot_has_its_texture() {
    let Some(shared) = shared_scenes() else { return };
    let scene = load(&shared.join("cornell-box-mcguire/CornellBox-Original.obj")).unwrap();
    let light = scene.materials.iter().find(|m| m.name == "light").expect("a material named light");
    let frame = scene.at(0.0);
    let area: f32 = frame.emissive.iter().map(|e| e.area).sum();
    println!(
        "McGuire light: Kd {} Ke {}, {} emissive triangles of {area:.4} m², roughness {:.3}",
        light.base_color,
        light.emission,
        frame.emissive.len(),
        light.roughness
    );
    assert_eq!(light.emission, Vec3::new(17.0, 12.0, 4.0));
    assert_eq!(frame.emissive.len(), 2);
    assert!((light.roughness - glimpse_scene::obj_loader::roughness_from_ns(10.0)).abs() < 1e-6, "Ns 10");
    let left = scene.materials.iter().find(|m| m.name == "leftWall").unwrap();
    assert_eq!(left.base_color, Vec3::new(0.63, 0.065, 0.05));

    // The Mitsuba box as scenes/cbox-mitsuba.toml composes it: the luminaire 1 cm below the
    // ceiling, facing down, with cbox.xml's radiance.
    let cbox = load(&crate_dir().join("../../scenes/cbox-mitsuba.toml")).unwrap();
    let f = cbox.at(0.0);
    let y: Vec<f32> = f.emissive.iter().flat_map(|e| e.vertices.map(|v| v.y)).collect();
    println!(
        "cbox-mitsuba: {} emissive triangles at y {:?}, normal {}, radiance {}",
        f.emissive.len(),
        y,
        f.emissive[0].normal,
        f.emissive[0].radiance
    );
    assert_eq!(f.emissive.len(), 2);
    assert!(y.iter().all(|&y| (y - 0.99).abs() < 1e-6) && close(f.emissive[0].normal, Vec3::NEG_Y));
    assert_eq!(f.emissive[0].radiance, Vec3::new(18.387, 13.9873, 6.75357));
    assert!((cbox.camera.as_ref().unwrap().fov.to_degrees() - 39.3077).abs() < 1e-4);

    let spot = load(&crate_dir().join("../../scenes/spot.toml")).unwrap();
    let cow = &spot.meshes[0];
    let tex = cow.positions.len();
    let mat = &spot.materials[cow.material as usize];
    let img = &spot.textures[mat.base_color_texture.expect("spot's texture") as usize];
    let (lo, hi) = cow.uvs.iter().fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(lo, hi), uv| (lo.min(*uv), hi.max(*uv)));
    let colours: Vec<Vec3> = cow.uvs.iter().step_by(97).map(|uv| spot.base_color(cow.material, *uv)).collect();
    let spread = colours.iter().map(|c| luminance(*c)).fold((f32::MAX, f32::MIN), |(a, b), l| (a.min(l), b.max(l)));
    println!(
        "spot: {tex} vertices with {} uvs in {lo}..{hi}; texture {}×{} mean {:.3}; texture luminance at vertices {:.3}..{:.3}; environment {:?}",
        cow.uvs.len(),
        img.width,
        img.height,
        img.mean(),
        spread.0,
        spread.1,
        spot.environment.as_ref().map(|e| (e.image.width, e.image.height, e.scale))
    );
    assert_eq!(cow.uvs.len(), tex);
    // spot.obj's vt span u -0.0522421..0.989055, v 0.111175..1.00065: v comes out flipped.
    assert!((lo - Vec2::new(-0.0522421, 1.0 - 1.00065)).abs().max_element() < 1e-5, "{lo}");
    assert!((hi - Vec2::new(0.989055, 1.0 - 0.111175)).abs().max_element() < 1e-5, "{hi}");
    assert_eq!((img.width, img.height), (1024, 1024));
    assert!(spread.1 > spread.0 + 0.1, "the texture varies over the cow");
}

#[test]
fn environment_maps_load_through_a_scene_toml() {
    let Some(shared) = shared_scenes() else { return };
    let dir = scratch("env");
    for (file, mean_lum) in [("studio_small_03_1k.hdr", 1.848f32), ("empty_warehouse_01_1k.hdr", 0.6478)] {
        let hdr = shared.join("envmaps").join(file);
        let toml = format!("[[quad]]\nsize = [2, 2]\n\n[environment]\nfile = {:?}\nscale = 2.0\n", hdr.to_str().unwrap());
        let scene = load(&write(&dir, "env.toml", toml)).unwrap();
        let env = scene.environment.as_ref().unwrap();
        let mean = env.image.pixels.iter().map(|p| luminance(*p) as f64).sum::<f64>() / env.image.pixels.len() as f64;
        let up = env.radiance(Vec3::Y);
        println!(
            "{file}: {}×{}, scale {}, mean luminance {mean:.4} (README {mean_lum}), radiance from +y {up}",
            env.image.width, env.image.height, env.scale
        );
        assert_eq!((env.image.width, env.image.height, env.scale), (1024, 512, 2.0));
        assert!((mean as f32 - mean_lum).abs() < 0.01 * mean_lum);
    }
}

/// Standard base64 (for `data:` URIs).
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for i in 0..4 {
            out.push(if i <= c.len() { A[(n >> (18 - 6 * i) & 63) as usize] as char } else { '=' });
        }
    }
    out
}

/// The test glTF's binary buffer: a triangle (positions, normals, uvs, indices) and two
/// animation tracks (parent translation, LINEAR; child scale, STEP).
fn gltf_buffer() -> Vec<u8> {
    let mut b = Vec::new();
    let mut f = |v: &[f32]| v.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes()));
    f(&[0., 0., 0., 1., 0., 0., 0., 1., 0.]); // 0: positions
    f(&[0., 0., 1., 0., 0., 1., 0., 0., 1.]); // 36: normals
    f(&[0., 0., 1., 0., 0., 1.]); // 72: uvs
    for i in [0u16, 1, 2, 0] {
        b.extend_from_slice(&i.to_le_bytes()); // 96: indices + 2 bytes padding
    }
    let mut f = |v: &[f32]| v.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes()));
    f(&[0., 2.]); // 104: translation key times
    f(&[1., 0., 0., 3., 0., 0.]); // 112: translations
    f(&[0., 1.5]); // 136: scale key times
    f(&[1., 1., 1., 2., 2., 2.]); // 144: scales
    assert_eq!(b.len(), 168);
    b
}

/// A 2×1 PNG: left pixel linear (0.5, 0, 0), right (0, 0, 0.5), stored sRGB-encoded.
fn png_bytes() -> Vec<u8> {
    // A folder of its own per call (tests run in parallel), removed when this returns.
    let dir = scratch("png");
    let path = dir.join("tex.png");
    Image::from_fn(2, 1, |x, _| if x == 0 { Vec3::new(0.5, 0.0, 0.0) } else { Vec3::new(0.0, 0.0, 0.5) })
        .write(&path, ToneMap::default())
        .unwrap();
    std::fs::read(path).unwrap()
}

/// The test glTF's JSON; `uri` is the buffer's (None: the GLB's BIN chunk). Its base colour
/// texture is [`png_bytes`] in a `data:` URI.
fn gltf_json(uri: Option<&str>) -> String {
    let image = format!("data:image/png;base64,{}", base64(&png_bytes()));
    let buffer = match uri {
        Some(u) => format!(r#"{{"byteLength": 168, "uri": "{u}"}}"#),
        None => r#"{"byteLength": 168}"#.to_owned(),
    };
    let s = std::f32::consts::FRAC_1_SQRT_2;
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
  "scene": 0,
  "scenes": [{{"nodes": [0, 2, 3]}}],
  "nodes": [
    {{"name": "parent", "translation": [1, 0, 0], "rotation": [0, {s}, 0, {s}], "children": [1, 4]}},
    {{"name": "child", "translation": [0, 0, -2], "mesh": 0}},
    {{"name": "camera", "translation": [0, 1, 5], "camera": 0}},
    {{"name": "lamp", "translation": [0, 3, 0], "extensions": {{"KHR_lights_punctual": {{"light": 0}}}}}},
    {{"name": "spot", "translation": [0, 2, 0], "rotation": [-{s}, 0, 0, {s}], "extensions": {{"KHR_lights_punctual": {{"light": 1}}}}}}
  ],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.7, "znear": 0.1, "aspectRatio": 1.5}}}}],
  "extensions": {{"KHR_lights_punctual": {{"lights": [
    {{"type": "point", "color": [1, 0.5, 0.25], "intensity": 10}},
    {{"type": "spot", "intensity": 20, "spot": {{"innerConeAngle": 0.3, "outerConeAngle": 0.6}}}}
  ]}}}},
  "materials": [{{
    "name": "glow",
    "pbrMetallicRoughness": {{"baseColorFactor": [0.5, 0.6, 0.7, 1], "roughnessFactor": 0.25, "metallicFactor": 0.1,
                             "baseColorTexture": {{"index": 0}}}},
    "emissiveFactor": [1, 0.5, 0],
    "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 4}}}}
  }}],
  "meshes": [{{"name": "tri", "primitives": [
    {{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3, "material": 0}},
    {{"attributes": {{"POSITION": 0}}, "mode": 1}}
  ]}}],
  "animations": [{{
    "channels": [{{"sampler": 0, "target": {{"node": 0, "path": "translation"}}}}, {{"sampler": 1, "target": {{"node": 1, "path": "scale"}}}}],
    "samplers": [{{"input": 4, "output": 5, "interpolation": "LINEAR"}}, {{"input": 6, "output": 7, "interpolation": "STEP"}}]
  }}],
  "images": [{{"uri": "{image}"}}],
  "textures": [{{"source": 0}}],
  "buffers": [{buffer}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 36}},
    {{"buffer": 0, "byteOffset": 36, "byteLength": 36}},
    {{"buffer": 0, "byteOffset": 72, "byteLength": 24}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 6}},
    {{"buffer": 0, "byteOffset": 104, "byteLength": 8}},
    {{"buffer": 0, "byteOffset": 112, "byteLength": 24}},
    {{"buffer": 0, "byteOffset": 136, "byteLength": 8}},
    {{"buffer": 0, "byteOffset": 144, "byteLength": 24}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}},
    {{"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"}},
    {{"bufferView": 4, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [2]}},
    {{"bufferView": 5, "componentType": 5126, "count": 2, "type": "VEC3"}},
    {{"bufferView": 6, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1.5]}},
    {{"bufferView": 7, "componentType": 5126, "count": 2, "type": "VEC3"}}
  ]
}}"#
    )
}

/// A binary glTF container: header, JSON chunk (space-padded), BIN chunk (zero-padded).
fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let pad = |mut v: Vec<u8>, with: u8| {
        while !v.len().is_multiple_of(4) {
            v.push(with);
        }
        v
    };
    let (j, b) = (pad(json.as_bytes().to_vec(), b' '), pad(bin.to_vec(), 0));
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + j.len() + 8 + b.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}

/// Everything the test glTF says, checked on a loaded scene moved by `offset`.
fn check_test_gltf(scene: &Scene, offset: Vec3) {
    let at = |t: f32, p: Vec3| scene.instances[0].motion.at(t).transform_point3(p) - offset;
    println!(
        "{} meshes, {} instances, {} lights, warnings {:?}\n  vertex (1,0,0) at t=0 {}, t=1 {}, t=1.4 {}, t=1.5 {}, t=1.6 {}",
        scene.meshes.len(),
        scene.instances.len(),
        scene.lights.len(),
        scene.warnings,
        at(0.0, Vec3::X),
        at(1.0, Vec3::X),
        at(1.4, Vec3::X),
        at(1.5, Vec3::X),
        at(1.6, Vec3::X)
    );
    assert_eq!((scene.meshes.len(), scene.instances.len(), scene.lights.len()), (1, 1, 2));
    assert!(scene.warnings.iter().any(|w| w.contains("mode Lines is not triangles")), "the lines primitive is skipped with a warning");
    // World = parent (T (1,0,0) · R_y 90°) · child (T (0,0,-2) · S), the parent sliding to x = 3 over 2 s.
    assert!(matches!(scene.instances[0].motion, Motion::Keyframes(_)));
    assert!(close(at(0.0, Vec3::ZERO), Vec3::new(-1.0, 0.0, 0.0)));
    assert!(close(at(0.0, Vec3::X), Vec3::new(-1.0, 0.0, -1.0)));
    assert!(close(at(1.0, Vec3::ZERO), Vec3::ZERO), "mid key time: parent at x = 2");
    assert!(close(at(1.4, Vec3::X), Vec3::new(0.4, 0.0, -1.0)), "STEP scale still 1 before its key");
    assert!(close(at(1.5, Vec3::X), Vec3::new(0.5, 0.0, -2.0)), "STEP scale 2 from its key on");
    assert!(close(at(1.6, Vec3::X), Vec3::new(0.6, 0.0, -2.0)));
    assert!(close(at(5.0, Vec3::ZERO), Vec3::new(1.0, 0.0, 0.0)), "held after the last key");

    let mesh = &scene.meshes[0];
    assert_eq!((mesh.positions.len(), mesh.normals.len(), mesh.uvs.len(), mesh.indices.len()), (3, 3, 3, 1));
    assert_eq!(mesh.uvs[1], Vec2::new(1.0, 0.0), "glTF uvs are kept as they are");
    let m = &scene.materials[mesh.material as usize];
    println!("  material {m:?}");
    assert_eq!((m.base_color, m.roughness, m.metallic), (Vec3::new(0.5, 0.6, 0.7), 0.25, 0.1));
    assert_eq!(m.emission, Vec3::new(4.0, 2.0, 0.0), "emissiveFactor × emissiveStrength 4");
    let tex = &scene.textures[m.base_color_texture.expect("the base colour texture") as usize];
    println!("  texture {}×{} {:?}", tex.width, tex.height, tex.pixels);
    assert_eq!((tex.width, tex.height, scene.textures.len()), (2, 1, 1));
    assert!(
        (tex.pixels[0] - Vec3::new(0.5, 0.0, 0.0)).length() < 0.01 && (tex.pixels[1] - Vec3::new(0.0, 0.0, 0.5)).length() < 0.01,
        "sRGB decoded"
    );

    // Lights come in depth-first node order: the spot (a child of the parent) first.
    let frame = scene.at(1.0);
    let (spot, point) = (frame.lights[0], frame.lights[1]);
    println!("  t=1: point {point:?}\n  t=1: spot {spot:?}\n  t=0 spot at {}", scene.at(0.0).lights[0].position - offset);
    assert_eq!(point.kind, LightKind::Point);
    assert!(close(point.position - offset, Vec3::new(0.0, 3.0, 0.0)) && close(point.intensity, Vec3::new(10.0, 5.0, 2.5)));
    assert_eq!(spot.kind, LightKind::Spot { inner_angle: 0.3, outer_angle: 0.6 });
    assert!(close(scene.at(0.0).lights[0].position - offset, Vec3::new(1.0, 2.0, 0.0)));
    assert!(close(spot.position - offset, Vec3::new(2.0, 2.0, 0.0)), "the spot rides on the animated parent");
    assert!(close(spot.direction, Vec3::NEG_Y) && close(spot.intensity, Vec3::splat(20.0)));

    let cam = scene.camera.as_ref().unwrap();
    println!("  camera {cam:?}");
    assert!(close(cam.position - offset, Vec3::new(0.0, 1.0, 5.0)) && close(cam.target - offset, Vec3::new(0.0, 1.0, 4.0)));
    assert!(close(cam.up, Vec3::Y) && cam.fov == 0.7);
    assert_eq!(scene.at(0.0).emissive.len(), 1);
}

#[test]
fn gltf_hierarchy_camera_lights_material_and_animation() {
    let dir = scratch("gltf");
    let uri = format!("data:application/octet-stream;base64,{}", base64(&gltf_buffer()));
    let path = write(&dir, "test.gltf", gltf_json(Some(&uri)));
    check_test_gltf(&load(&path).unwrap(), Vec3::ZERO);

    // The same with an external .bin, placed by a scene.toml 10 m up (the file's camera is used).
    write(&dir, "test.bin", gltf_buffer());
    write(&dir, "external.gltf", gltf_json(Some("test.bin")));
    let toml = write(&dir, "placed.toml", "[[mesh]]\nfile = \"external.gltf\"\ntranslate = [0, 10, 0]\n");
    println!("via {}:", toml.display());
    check_test_gltf(&load(&toml).unwrap(), Vec3::new(0.0, 10.0, 0.0));
}

#[test]
fn glb_round_trip_matches_the_gltf() {
    let dir = scratch("glb");
    let path = write(&dir, "test.glb", glb(&gltf_json(None), &gltf_buffer()));
    check_test_gltf(&load(&path).unwrap(), Vec3::ZERO);
}

#[test]
fn obj_materials_textures_uv_flip_and_warnings() {
    let dir = scratch("obj");
    // A 2×1 texture: left pixel red, right pixel blue (PNG is sRGB; 0.5 linear round-trips).
    Image::from_fn(2, 1, |x, _| if x == 0 { Vec3::new(0.5, 0.0, 0.0) } else { Vec3::new(0.0, 0.0, 0.5) })
        .write(&dir.join("tex.png"), ToneMap::default())
        .unwrap();
    write(
        &dir,
        "m.mtl",
        "newmtl shiny\nKd 0.2 0.4 0.6\nNs 100\nmap_Kd -s 1 1 1 tex.png\n\n\
         newmtl lamp\nKd 0.5\nKe 3 2 1\nPr 0.3\nPm 0.7\n\n\
         newmtl lost\nKd 0.1 0.1 0.1\nmap_Kd missing.png\n\n\
         newmtl ambient_lamp\nKa 20 20 20\nKd 1 1 1\n",
    );
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n\
               usemtl shiny\nf 1/1/1 2/2/1 3/3/1 4/4/1\n\
               usemtl lamp\nf 1 2 3\n\
               usemtl lost\nf 1 3 4\n\
               usemtl nowhere\nf 2 3 4\nl 1 2\n";
    let scene = load(&write(&dir, "m.obj", obj)).unwrap();
    println!("{} meshes, {} materials, {} textures, warnings:", scene.meshes.len(), scene.materials.len(), scene.textures.len());
    scene.warnings.iter().for_each(|w| println!("    {w}"));
    let mat = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap();
    let (shiny, lamp, lost) = (mat("shiny"), mat("lamp"), mat("lost"));
    println!("shiny {shiny:?}\nlamp {lamp:?}\nlost {lost:?}");
    assert_eq!(scene.meshes.len(), 4);
    assert_eq!(shiny.base_color, Vec3::new(0.2, 0.4, 0.6));
    assert!((shiny.roughness - 0.3742).abs() < 1e-3, "Ns 100 → (2/102)^¼");
    assert_eq!((lamp.base_color, lamp.emission, lamp.roughness, lamp.metallic), (Vec3::splat(0.5), Vec3::new(3.0, 2.0, 1.0), 0.3, 0.7));
    assert_eq!((lost.base_color_texture, scene.textures.len()), (None, 1));
    assert!(scene.warnings.iter().any(|w| w.contains("missing.png")), "a missing texture is a warning naming it");
    assert!(scene.warnings.iter().any(|w| w.contains("nowhere")), "an unknown usemtl is a warning");
    assert!(scene.warnings.iter().any(|w| w.contains("1 point and line")));
    // embree's Cornell box (as tinyobjloader ships it) puts its light in Ka: said, not read.
    assert!(
        scene.warnings.iter().any(|w| w.contains("'ambient_lamp'") && w.contains("Ke 20 20 20")),
        "an ambient colour above 1 is a warning that says how to make it a light"
    );
    assert!(!scene.warnings.iter().any(|w| w.contains("'shiny'") && w.contains("Ka")), "no warning for an ordinary material");

    let quad = &scene.meshes[0];
    let tex = shiny.base_color_texture.unwrap();
    println!("quad uvs {:?}, normals {:?}", quad.uvs, quad.normals);
    assert_eq!(quad.indices.len(), 2, "the quad is split in two");
    assert_eq!(quad.uvs[0], Vec2::new(0.0, 1.0), "v flipped: OBJ (0,0) is the image's bottom-left");
    assert_eq!(quad.normals.len(), 4);
    let left = scene.base_color(quad.material, Vec2::new(0.25, 0.5));
    println!("texture {:?}; base colour at u=0.25: {left}", scene.textures[tex as usize].pixels);
    assert!((scene.textures[tex as usize].pixels[0] - Vec3::new(0.5, 0.0, 0.0)).length() < 0.01, "sRGB PNG decoded to linear");
    assert_eq!(scene.meshes[3].material as usize, scene.materials.iter().position(|m| m.name == "default").unwrap());

    // No .mtl at all: a warning and the default material.
    let scene = load(&write(&dir, "nomtl.obj", "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n")).unwrap();
    println!("missing mtl: materials {:?}, warnings {:?}", scene.materials.iter().map(|m| &m.name).collect::<Vec<_>>(), scene.warnings);
    assert_eq!(scene.materials.len(), 1);
    assert!(scene.warnings.iter().any(|w| w.contains("gone.mtl")));
}

#[test]
fn toml_shapes_lights_and_animation() {
    let dir = scratch("toml");
    write(&dir, "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let toml = r#"
name = "features"
[camera]
position = [0, 1, 5]
target = [0, 1, 0]
fov_y_degrees = 50

[environment]
constant = [0.1, 0.2, 0.3]
scale = 2.0

[[mesh]]
file = "tri.obj"
translate = [5, 0, 0]
spin = { period_s = 4.0 }
material = { base_color = [0.1, 0.2, 0.3], roughness = 0.4, metallic = 1.0, emission = [1, 1, 1], clearcoat = 0.5 }
wave = { amplitude = 0.5, wavelength = 2.0, period_s = 1.0 }

[[mesh]]
file = "tri.obj"
keyframes = [{ time = 0, translate = [0, 0, 0] }, { time = 2, translate = [2, 0, 0], rotate_y_degrees = 90, scale = [1, 2, 1] }]

[[quad]]
size = [4, 2]
divisions = [4, 2]
matrix = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,-1,0,1]

[[box]]
size = [2, 4, 6]
rotate = { axis = [1, 0, 0], degrees = 90 }

[[sphere]]
radius = 0.5
segments = 8
scale = 2.0

[[light]]
kind = "point"
position = [1, 0, 0]
intensity = 3
color = [1, 0.5, 0]
orbit = { period_s = 4.0 }

[[light]]
kind = "spot"
position = [0, 4, 0]
target = [0, 0, 0]
outer_angle_degrees = 30

[[light]]
kind = "directional"
direction = [0, -1, 0]
intensity = 5
"#;
    let scene = load(&write(&dir, "features.toml", toml)).unwrap();
    let f0 = scene.at(0.0);
    let f1 = scene.at(1.0);
    let spun = f1.transforms[0].transform_point3(Vec3::new(6.0, 0.0, 0.0) - Vec3::new(5.0, 0.0, 0.0));
    let keyed = f1.transforms[1];
    let box_b = glimpse_core::Aabb::from_points(&scene.meshes[3].positions).transform(&f0.transforms[3]);
    let sphere_b = glimpse_core::Aabb::from_points(&scene.meshes[4].positions).transform(&f0.transforms[4]);
    println!(
        "{} '{}': {} triangles, animated {}, lights at t=1 {:?}\n  spun vertex {spun}, keyed translation {}, box {:?}, sphere {:?}, quad y {}",
        scene.name,
        scene.name,
        scene.triangle_count(),
        scene.is_animated(),
        f1.lights.iter().map(|l| l.position).collect::<Vec<_>>(),
        keyed.w_axis,
        (box_b.min, box_b.max),
        (sphere_b.min, sphere_b.max),
        f0.transforms[2].w_axis.y
    );
    assert_eq!(scene.name, "features");
    assert_eq!(scene.triangle_count(), 1 + 1 + 16 + 12 + 8 * 4 * 2 - 2 * 8);
    assert!(scene.is_animated());
    // Spin: a quarter turn about +y through (5,0,0) in 1 s of 4: the vertex (1,0,0) in object space (6,0,0) goes to (5,0,-1).
    assert!(close(f1.transforms[0].transform_point3(Vec3::X), Vec3::new(5.0, 0.0, -1.0)), "{spun}");
    assert!(close(keyed.w_axis.truncate(), Vec3::new(1.0, 0.0, 0.0)));
    assert!(close(box_b.min, Vec3::new(-1.0, -3.0, -2.0)) && close(box_b.max, Vec3::new(1.0, 3.0, 2.0)), "size [2,4,6] turned 90° about x");
    assert!(close(sphere_b.max, Vec3::ONE), "radius 0.5 × scale 2");
    assert_eq!(f0.transforms[2].w_axis.y, -1.0);
    assert!(matches!(scene.meshes[0].deformation, Some(glimpse_scene::Deformation::Wave { .. })));
    let m = &scene.materials[scene.meshes[0].material as usize];
    assert_eq!((m.base_color, m.roughness, m.metallic, m.emission, m.clearcoat), (Vec3::new(0.1, 0.2, 0.3), 0.4, 1.0, Vec3::ONE, 0.5));
    assert!(close(f1.lights[0].position, Vec3::new(0.0, 0.0, -1.0)) && close(f1.lights[0].intensity, Vec3::new(3.0, 1.5, 0.0)));
    assert!(close(f1.lights[1].direction, Vec3::NEG_Y));
    assert_eq!(f1.lights[1].kind, LightKind::Spot { inner_angle: 0.0, outer_angle: 30f32.to_radians() });
    assert_eq!((f1.lights[2].kind, f1.lights[2].intensity), (LightKind::Directional, Vec3::splat(5.0)));
    let env = scene.environment.as_ref().unwrap();
    assert_eq!(env.radiance(Vec3::X), Vec3::new(0.2, 0.4, 0.6));
    assert_eq!(scene.camera.as_ref().unwrap().fov, 50f32.to_radians());
}

#[test]
fn sky_environment_and_file_camera_from_toml() {
    let dir = scratch("sky");
    let toml = "[[box]]\n[environment]\nsky = { sun_direction = [0.6, 0.8, 0], sun_radiance = 100.0, width = 512 }\nscale = 0.5\n";
    let scene = load(&write(&dir, "sky.toml", toml)).unwrap();
    let env = scene.environment.as_ref().unwrap();
    let (sun, zenith) = (env.radiance(Vec3::new(0.6, 0.8, 0.0)), env.radiance(Vec3::Y));
    println!(
        "sky {}×{}, scale {}, towards the sun {sun}, zenith {zenith}, camera {:?}",
        env.image.width, env.image.height, env.scale, scene.camera
    );
    assert_eq!((env.image.width, env.image.height, env.scale), (512, 256, 0.5));
    assert!(sun.x > 40.0 && zenith.x < 1.0, "the sun disk is where it was put");
    assert!(scene.camera.is_none(), "no camera anywhere: the renderer frames the scene");
}

#[test]
fn missing_files_are_io_errors_naming_the_file() {
    let dir = scratch("missing");
    for name in ["nope.obj", "nope.gltf", "nope.glb", "nope.toml"] {
        let path = dir.join(name);
        let e = load(&path).unwrap_err();
        println!("{name}: {e}");
        assert!(matches!(e, SceneError::Io { .. }), "{e:?}");
        assert!(e.to_string().contains(path.to_str().unwrap()) && e.to_string().contains("No such file"));
    }
    // A scene.toml naming a missing mesh or environment: the error names that file and the toml.
    let toml = write(&dir, "refs.toml", "[[mesh]]\nfile = \"gone.obj\"\n");
    let e = load_err(&toml);
    assert!(e.contains("gone.obj") && e.contains("No such file") && e.contains("refs.toml"), "{e}");
    let toml = write(&dir, "env.toml", "[[box]]\n[environment]\nfile = \"gone.hdr\"\n");
    let e = load_err(&toml);
    assert!(e.contains("gone.hdr") && e.contains("env.toml"), "{e}");
}

#[test]
fn malformed_obj_is_a_parse_error_with_its_line() {
    let dir = scratch("bad-obj");
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases = [
        ("index.obj", format!("{tri}f 1 2 99\n"), "line 4", "99"),
        ("negative.obj", format!("{tri}f -1 -2 -7\n"), "line 4", "-7"),
        ("zero.obj", format!("{tri}f 0 1 2\n"), "line 4", "index 0 is invalid"),
        ("garbage-v.obj", "v 0 0 0\nv 1 2 abc\nv 0 1 0\nf 1 2 3\n".to_string(), "line 2", "position parse error"),
        ("garbage-f.obj", format!("{tri}f 1 two 3\n"), "line 4", "'two' is not an index"),
        ("vt.obj", format!("{tri}f 1/5 2/5 3/5\n"), "line 4", "texture coordinate 5"),
    ];
    for (name, content, line, what) in cases {
        let path = write(&dir, name, content);
        let e = load_err(&path);
        assert!(e.contains(path.to_str().unwrap()) && e.contains("malformed") && e.contains(line) && e.contains(what), "{e}");
    }
    // A malformed .mtl is an error naming the .mtl and its line (tobj would panic on `Kd 1 2`).
    write(&dir, "bad.mtl", "newmtl a\nKd 1 2\n");
    let e = load_err(&write(&dir, "badmtl.obj", format!("mtllib bad.mtl\n{tri}usemtl a\nf 1 2 3\n")));
    assert!(e.contains("bad.mtl") && e.contains("line 2"), "{e}");
}

#[test]
fn malformed_gltf_is_a_parse_error() {
    let dir = scratch("bad-gltf");
    let full = gltf_json(Some("test.bin"));
    write(&dir, "test.bin", gltf_buffer());
    let truncated = write(&dir, "truncated.gltf", &full[..full.len() / 2]);
    let e = load_err(&truncated);
    assert!(e.contains("truncated.gltf") && e.contains("malformed") && e.contains("EOF while parsing") && e.contains("line"), "{e}");
    let e = load_err(&write(&dir, "badref.gltf", full.replace(r#""mesh": 0"#, r#""mesh": 7"#)));
    assert!(e.contains("badref.gltf") && e.contains("nodes[1].mesh"), "{e}");
    let e = load_err(&write(&dir, "nobin.gltf", full.replace("test.bin", "gone.bin")));
    assert!(e.contains("nobin.gltf") && e.contains("gone.bin"), "{e}");
    let e = load_err(&write(&dir, "short.glb", &glb(&gltf_json(None), &gltf_buffer())[..200]));
    assert!(e.contains("short.glb") && e.contains("malformed"), "{e}");
    // Accessors the gltf readers would trip over: a VEC2 position, a rotation of u32.
    let e = load_err(&write(
        &dir,
        "vec2pos.gltf",
        full.replace(r#""count": 3, "type": "VEC3", "min""#, r#""count": 3, "type": "VEC2", "min""#),
    ));
    assert!(e.contains("vec2pos.gltf") && e.contains("POSITION"), "{e}");
    let e = load_err(&write(&dir, "nothing.gltf", r#"{"asset": {"version": "2.0"}}"#));
    assert!(e.contains("nothing.gltf") && e.contains("empty"), "{e}");
}

#[test]
fn malformed_toml_is_a_parse_error_naming_the_key() {
    let dir = scratch("bad-toml");
    let cases = [
        ("syntax.toml", "[[box]]\nsize = [1, 2\n", vec!["line 2", "malformed"]),
        ("unknown.toml", "[[box]]\nsize = [1, 2, 3]\ncolour = [1, 0, 0]\n", vec!["line 3", "unknown field `colour`"]),
        ("type.toml", "[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\nfov_y_degrees = \"wide\"\n", vec!["line 4", "invalid type"]),
        ("scale.toml", "[[box]]\nscale = \"big\"\n", vec!["line 2", "scale must be a number or [x, y, z]"]),
        ("kind.toml", "[[box]]\n[[light]]\nkind = \"laser\"\nposition = [0, 0, 0]\n", vec!["line 3", "laser"]),
        ("length.toml", "[[box]]\ntranslate = [1, 2]\n", vec!["line 2", "length"]),
        ("light.toml", "[[box]]\n[[light]]\nkind = \"point\"\n", vec!["[[light]] 0 (point): needs `position`"]),
        ("both.toml", "[[box]]\nspin = { period_s = 1 }\nkeyframes = [{ time = 0 }]\n", vec!["either `keyframes` or `spin`"]),
        ("period.toml", "[[box]]\nspin = { period_s = 0 }\n", vec!["period_s must be a finite non-zero number"]),
        ("env.toml", "[[box]]\n[environment]\nconstant = [1, 1, 1]\nfile = \"a.hdr\"\n", vec!["exactly one of"]),
        ("ext.toml", "[[mesh]]\nfile = \"a.ply\"\n", vec!["must be .obj, .gltf or .glb"]),
        ("coat.toml", "[[box]]\nmaterial = { clearcoat = 1.5 }\n", vec!["clearcoat 1.5 must lie in [0, 1]"]),
    ];
    for (name, content, needles) in cases {
        let path = write(&dir, name, content);
        let e = load_err(&path);
        assert!(e.contains(path.to_str().unwrap()), "{e}");
        for n in needles {
            assert!(e.contains(n), "{name}: '{n}' not in: {e}");
        }
    }
}

#[test]
fn invalid_geometry_is_caught_by_validation() {
    let dir = scratch("invalid");
    let cases = [
        ("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "NaN"),
        ("only-degenerate.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 1 2\n", "all 1 triangles are degenerate"),
        ("empty.obj", "# nothing here\n", "empty"),
        ("no-faces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "empty"),
        ("one-point.obj", "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\nf 3 2 1\n", "zero area"),
        ("one-line.obj", "v 0 0 0\nv 1 1 1\nv 2 2 2\nv 3 3 3\nf 1 2 3\nf 2 3 4\n", "zero area"),
    ];
    for (name, content, what) in cases {
        let path = write(&dir, name, content);
        let e = load_err(&path);
        assert!(e.contains(path.to_str().unwrap()) && e.contains(what), "{e}");
    }
    let scene = load(&write(&dir, "one-bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 2\n")).unwrap();
    println!("one good, one degenerate: {} triangle, warnings {:?}", scene.triangle_count(), scene.warnings);
    assert_eq!(scene.triangle_count(), 1);
    assert!(scene.warnings.iter().any(|w| w.contains("one-bad.obj") && w.contains("removed 1 degenerate")));
    // Through a scene.toml the NaN is reported against the mesh file that holds it.
    let toml = write(&dir, "nan.toml", "[[mesh]]\nfile = \"nan.obj\"\n");
    let e = load_err(&toml);
    assert!(e.contains("nan.obj") && e.contains("NaN") && e.contains("nan.toml"), "{e}");
}

/// Every prefix of every test file, and every file with single bytes changed, loads or fails
/// cleanly: no panic, and none caught inside a parser either (the "internal panic" error).
#[test]
fn truncated_and_corrupted_files_never_panic() {
    let dir = scratch("fuzz");
    let uri = format!("data:application/octet-stream;base64,{}", base64(&gltf_buffer()));
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\no a\nusemtl m\nf 1/1/1 2/2/1 3/2/1\ng b\nf -3 -2 -1\n";
    write(&dir, "m.mtl", "newmtl m\nKd 0.5 0.5 0.5\nKe 1 1 1\nNs 20\nmap_Kd t.png\n");
    let toml = "name = \"x\"\n[camera]\nposition = [0, 0, 3]\ntarget = [0, 0, 0]\n[[mesh]]\nfile = \"f.obj\"\nspin = { period_s = 2 }\n\
                [[sphere]]\nradius = 0.5\n[[light]]\nkind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\n";
    write(&dir, "f.obj", obj);
    let files: Vec<(&str, Vec<u8>, usize)> = vec![
        ("f.gltf", gltf_json(Some(&uri)).into_bytes(), 7),
        ("f.glb", glb(&gltf_json(None), &gltf_buffer()), 5),
        ("g.obj", obj.as_bytes().to_vec(), 1),
        ("f.toml", toml.as_bytes().to_vec(), 1),
    ];
    let (mut ok, mut failed) = (0, 0);
    let mut check = |name: &str, bytes: &[u8]| {
        let path = write(&dir, name, bytes);
        match load(&path) {
            Ok(_) => ok += 1,
            Err(e) => {
                failed += 1;
                let e = e.to_string();
                assert!(!e.contains("internal panic") && e.contains(name), "{e}");
            }
        }
    };
    for (name, bytes, step) in &files {
        for end in (0..bytes.len()).step_by(*step) {
            check(name, &bytes[..end]);
        }
    }
    // GLIMPSE_FUZZ_FLIPS=1,2,4,... flips every byte with each value (slow, run by hand); by
    // default every (3 × truncation step)-th byte is flipped with 0x5a.
    let flips: Vec<u8> = std::env::var("GLIMPSE_FUZZ_FLIPS").map_or(vec![0x5a], |v| v.split(',').filter_map(|x| x.parse().ok()).collect());
    for (name, bytes, step) in &files {
        for i in (0..bytes.len()).step_by(if flips.len() > 1 { 1 } else { 3 * step }) {
            for &x in &flips {
                let mut b = bytes.clone();
                b[i] ^= x;
                check(name, &b);
            }
        }
    }
    println!("{ok} loaded, {failed} failed cleanly");
    assert!(ok > 0 && failed > 0);
}

#[test]
fn material_models_and_fov_axis_from_toml() {
    let dir = scratch("models");
    let path = dir.join("models.toml");
    let text = r#"
[camera]
position = [0, 0, 5]
target = [0, 0, 0]
fov_degrees = 30
fov_axis = "x"
[[quad]]
material = { model = "diffuse", base_color = [0.5, 0.5, 0.5] }
[[box]]
material = { model = "conductor", roughness = 0.2, eta = [0.2, 0.9, 1.1], k = [3.9, 2.4, 2.2] }
[[sphere]]
material = { model = "dielectric", ior = 1.33 }
"#;
    std::fs::write(&path, text).unwrap();
    let scene = glimpse_scene::load(path.to_str().unwrap()).unwrap();
    let cam = scene.camera.as_ref().unwrap();
    assert_eq!(cam.fov_axis, glimpse_scene::FovAxis::X);
    assert!((cam.fov - 30f32.to_radians()).abs() < 1e-6);
    let m = &scene.materials;
    assert_eq!(m[0].model, glimpse_scene::MaterialModel::Diffuse);
    assert_eq!(m[1].model, glimpse_scene::MaterialModel::Conductor { eta: Vec3::new(0.2, 0.9, 1.1), k: Vec3::new(3.9, 2.4, 2.2) });
    assert_eq!((m[1].roughness, m[1].base_color), (0.2, Vec3::ONE));
    assert_eq!(m[2].model, glimpse_scene::MaterialModel::Dielectric { ior: 1.33 });
    for (bad, needle) in [
        ("material = { model = \"glass\" }", "material model \"glass\""),
        ("material = { model = \"diffuse\", ior = 1.5 }", "`ior` does not apply"),
        ("material = { model = \"dielectric\", ior = -1.0 }", "ior -1"),
    ] {
        std::fs::write(&path, format!("[[quad]]\n{bad}\n")).unwrap();
        let e = glimpse_scene::load(path.to_str().unwrap()).unwrap_err().to_string();
        assert!(e.contains("models.toml") && e.contains(needle), "{bad}: {e}");
    }
}

#[test]
fn film_filter_and_samples_from_toml() {
    let dir = scratch("film");
    let path = dir.join("film.toml");
    std::fs::write(&path, "[film]\nfilter = \"tent\"\nsamples = 8\n[[quad]]\n").unwrap();
    let scene = glimpse_scene::load(path.to_str().unwrap()).unwrap();
    assert_eq!(scene.film, glimpse_scene::Film { filter: glimpse_scene::Filter::Tent, samples: 8 });
    std::fs::write(&path, "[[quad]]\n").unwrap();
    assert_eq!(glimpse_scene::load(path.to_str().unwrap()).unwrap().film, glimpse_scene::Film::default(), "box, 1 sample by default");
    for (bad, needle) in
        [("filter = \"lanczos\"", "unknown filter 'lanczos'"), ("samples = 0", "film samples = 0"), ("radius = 2", "radius")]
    {
        std::fs::write(&path, format!("[film]\n{bad}\n[[quad]]\n")).unwrap();
        let e = glimpse_scene::load(path.to_str().unwrap()).unwrap_err().to_string();
        println!("{bad}: {e}");
        assert!(e.contains("film.toml") && e.contains(needle), "{bad}: {e}");
    }
}

/// A quad mirrored upside down by its placement (scale y = −1) emits downwards, as its normals
/// say and as glTF and pbrt define a mirrored instance; one mirrored the same way by a rotation
/// does too, and an unmirrored emitter keeps its side (`glimpse_scene::orient`).
#[test]
fn a_mirrored_emitter_lights_the_side_its_placement_turned_it_to() {
    let dir = scratch("mirrored_emitter");
    let path = dir.join("mirror.toml");
    let text = "[[quad]]\nsize = [1.0, 1.0]\nscale = [1.0, -1.0, 1.0]\ntranslate = [0.0, 2.0, 0.0]\n\
        material = { base_color = [0.0, 0.0, 0.0], emission = [5.0, 5.0, 5.0] }\n\
        [[quad]]\nsize = [1.0, 1.0]\nrotate = { axis = [1.0, 0.0, 0.0], degrees = 180.0 }\ntranslate = [3.0, 2.0, 0.0]\n\
        material = { base_color = [0.0, 0.0, 0.0], emission = [5.0, 5.0, 5.0] }\n\
        [[quad]]\nsize = [1.0, 1.0]\ntranslate = [6.0, 0.0, 0.0]\nmaterial = { emission = [1.0, 1.0, 1.0] }\n";
    std::fs::write(&path, text).unwrap();
    let scene = glimpse_scene::load(path.to_str().unwrap()).unwrap();
    let frame = scene.at(0.0);
    for e in &frame.emissive {
        let x = e.vertices[0].x;
        let expected = if x < 5.0 { -1.0 } else { 1.0 };
        println!("emitter triangle at x ≈ {x:.1}: normal {:?}", e.normal);
        assert!((e.normal.y - expected).abs() < 1e-5, "at x {x}: normal {:?}", e.normal);
    }
    assert_eq!(frame.emissive.len(), 6);
}

/// `KHR_texture_transform` on the base colour texture moves the primitive's uvs by offset ·
/// rotation · scale (the extension's order); without it they are kept as they are (above).
#[test]
fn gltf_texture_transform_moves_the_uvs() {
    let dir = scratch("gltf_texture_transform");
    let uri = format!("data:application/octet-stream;base64,{}", base64(&gltf_buffer()));
    let (rotation, [sx, sy], [ox, oy]) = (0.3f32, [2.0f32, 3.0f32], [0.5f32, -0.25f32]);
    let json = gltf_json(Some(&uri)).replace(
        r#""baseColorTexture": {"index": 0}"#,
        &format!(
            r#""baseColorTexture": {{"index": 0, "extensions": {{"KHR_texture_transform": {{"offset": [{ox}, {oy}], "rotation": {rotation}, "scale": [{sx}, {sy}]}}}}}}"#
        ),
    );
    assert!(json.contains("KHR_texture_transform"));
    let scene = load(&write(&dir, "transformed.gltf", json)).unwrap();
    let (sin, cos) = rotation.sin_cos();
    let expected = |u: f32, v: f32| Vec2::new(cos * sx * u + sin * sy * v + ox, -sin * sx * u + cos * sy * v + oy);
    let uvs = &scene.meshes[0].uvs;
    println!("uvs {uvs:?}");
    for (uv, (u, v)) in uvs.iter().zip([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]) {
        assert!((*uv - expected(u, v)).length() < 1e-6, "{uv} vs {}", expected(u, v));
    }
}

/// An MTL texture's `-s` and `-o` options map the uvs (in the OBJ's uv space, before v is
/// flipped to glTF's); the other options are named in a warning.
#[test]
fn obj_texture_options_scale_and_offset_the_uvs() {
    let dir = scratch("obj_texture_options");
    Image::from_fn(2, 1, |x, _| Vec3::splat(x as f32)).write(&dir.join("tex.png"), ToneMap::default()).unwrap();
    write(&dir, "m.mtl", "newmtl tiled\nKd 1 1 1\nmap_Kd -s 2 3 1 -o 0.5 0.25 0 -clamp on tex.png\n");
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl tiled\nf 1/1 2/2 3/3\n";
    let scene = load(&write(&dir, "t.obj", obj)).unwrap();
    let uvs = &scene.meshes[0].uvs;
    println!("uvs {uvs:?}, warnings {:?}", scene.warnings);
    let expected = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)].map(|(u, v)| Vec2::new(u * 2.0 + 0.5, 1.0 - (v * 3.0 + 0.25)));
    assert_eq!(uvs[..], expected[..]);
    assert!(scene.warnings.iter().any(|w| w.contains("'tiled'") && w.contains("-clamp")), "{:?}", scene.warnings);
}

/// A transmitting glTF material becomes smooth glass with its `KHR_materials_ior`; an
/// extension the loader does not read is named in a warning.
#[test]
fn gltf_glass_and_unread_extensions() {
    let dir = scratch("gltf_glass");
    let uri = format!("data:application/octet-stream;base64,{}", base64(&gltf_buffer()));
    let json = gltf_json(Some(&uri))
        .replace(
            r#""extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"]"#,
            r#""extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_clearcoat"]"#,
        )
        .replace(
            r#""extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}"#,
            r#""extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}, "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.33}}"#,
        );
    assert!(json.contains("transmissionFactor") && json.contains("KHR_materials_clearcoat"));
    let scene = load(&write(&dir, "glass.gltf", json)).unwrap();
    let m = &scene.materials[scene.meshes[0].material as usize];
    println!("material {m:?}\nwarnings {:?}", scene.warnings);
    assert_eq!(m.model, glimpse_scene::MaterialModel::Dielectric { ior: 1.33 });
    assert!(scene.warnings.iter().any(|w| w.contains("ignored glTF extensions KHR_materials_clearcoat")), "{:?}", scene.warnings);
    assert!(scene.warnings.iter().any(|w| w.contains("roughness of transmitting materials")), "{:?}", scene.warnings);
}

/// MTL `map_d`: a cut-out from the texture's alpha channel, or its first channel raw where it
/// has none, times `d`, at cutoff 0.5; `d` under 1 alone is translucency, drawn opaque with a
/// warning.
#[test]
fn obj_map_d_is_a_cut_out() {
    let dir = scratch("obj_map_d");
    // Grey, no alpha: 0 on the left, 1 on the right (0 and 255 whatever the encoding).
    Image::from_fn(2, 1, |x, _| Vec3::splat(x as f32)).write(&dir.join("grey.png"), ToneMap::default()).unwrap();
    // RGBA: alpha 51 (0.2) on the left, 255 on the right, the colour channels the other way.
    let rgba = image::RgbaImage::from_raw(2, 1, vec![255, 255, 255, 51, 0, 0, 0, 255]).unwrap();
    rgba.save(dir.join("rgba.png")).unwrap();
    write(
        &dir,
        "m.mtl",
        "newmtl grey\nKd 0.5 0.5 0.5\nmap_d -clamp on grey.png\nnewmtl rgba\nKd 0.5 0.5 0.5\nd 0.9\nmap_d rgba.png\nnewmtl glass\nKd 1 1 1\nd 0.3\n",
    );
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
               usemtl grey\nf 1/1 2/2 3/3\nusemtl rgba\nf 1/1 3/3 4/4\nusemtl glass\nf 2/2 3/3 4/4\n";
    let scene = load(&write(&dir, "m.obj", obj)).unwrap();
    println!("warnings {:?}", scene.warnings);
    let by_name = |n: &str| scene.materials.iter().position(|m| m.name == n).unwrap() as u32;
    let (grey, rgba, glass) = (by_name("grey"), by_name("rgba"), by_name("glass"));
    let mask = scene.materials[grey as usize].alpha_mask.expect("map_d makes a mask");
    assert_eq!((mask.factor, mask.cutoff), (1.0, 0.5));
    let mask = scene.materials[rgba as usize].alpha_mask.unwrap();
    assert_eq!(mask.factor, 0.9, "d multiplies the texture");
    let texels = &scene.textures[mask.texture.unwrap() as usize].pixels;
    assert!((texels[0].x - 0.2).abs() < 1e-6 && texels[1].x == 1.0, "the alpha channel, raw: {texels:?}");
    // u = 0.25 reads the left texel, 0.75 the right.
    let cut = |m: u32, u: f32| scene.cut_out(m, Vec2::new(u, 0.5));
    assert!(cut(grey, 0.25) && !cut(grey, 0.75));
    assert!(cut(rgba, 0.25) && !cut(rgba, 0.75), "0.9 × 0.2 is under the cutoff, 0.9 × 1 over");
    assert!(scene.materials[glass as usize].alpha_mask.is_none());
    assert!(scene.warnings.iter().any(|w| w.contains("'d 0.3' (translucency) is drawn opaque")), "{:?}", scene.warnings);
}

/// glTF's alpha mode MASK: the base colour texture's alpha channel (raw, not sRGB-decoded)
/// times the factor's alpha, against `alphaCutoff`, makes holes ([`Scene::cut_out`]); a texture
/// without alpha leaves the factor alone; BLEND is drawn opaque with a warning.
#[test]
fn gltf_alpha_mask_reads_the_coverage() {
    let dir = scratch("gltf_alpha_mask");
    // 2 × 1 RGBA: alpha 51 (0.2) on the left, 255 on the right.
    let rgba = image::RgbaImage::from_raw(2, 1, vec![200, 100, 50, 51, 200, 100, 50, 255]).unwrap();
    let mut png = std::io::Cursor::new(Vec::new());
    rgba.write_to(&mut png, image::ImageFormat::Png).unwrap();
    let rgba_uri = format!("data:image/png;base64,{}", base64(png.get_ref()));
    let uri = format!("data:application/octet-stream;base64,{}", base64(&gltf_buffer()));
    let base = gltf_json(Some(&uri));
    let with = |mode: &str, image: Option<&str>| {
        let mut json = base.replace(r#""baseColorFactor": [0.5, 0.6, 0.7, 1]"#, r#""baseColorFactor": [0.5, 0.6, 0.7, 0.8]"#);
        json = json.replace(r#""name": "glow","#, &format!(r#""name": "glow", "alphaMode": "{mode}", "alphaCutoff": 0.3,"#));
        if let Some(image) = image {
            let old = json.split(r#""images": [{"uri": ""#).nth(1).unwrap().split('"').next().unwrap().to_owned();
            json = json.replace(&old, image);
        }
        assert!(json.contains(mode) && json.contains("0.8]"));
        load(&write(&dir, &format!("{mode}.gltf"), json)).unwrap()
    };
    let scene = with("MASK", Some(&rgba_uri));
    let mid = scene.meshes[0].material;
    let mask = scene.materials[mid as usize].alpha_mask.expect("a MASK material has a mask");
    println!("mask {mask:?}\nwarnings {:?}", scene.warnings);
    assert_eq!((mask.factor, mask.cutoff), (0.8, 0.3));
    let coverage = &scene.textures[mask.texture.expect("the texture's alpha") as usize];
    assert!((coverage.pixels[0].x - 0.2).abs() < 1e-6 && coverage.pixels[1].x == 1.0, "{:?}", coverage.pixels);
    // u = 0.25: the left texel (0.8 × 0.2 < 0.3); 0.75: the right; 0.9: between them (0.61).
    let cut = |u: f32| scene.cut_out(mid, Vec2::new(u, 0.5));
    assert!(cut(0.25) && !cut(0.75) && !cut(0.9));
    assert!(scene.warnings.iter().any(|w| w.contains("alpha mode MASK")), "{:?}", scene.warnings);
    // The test's own texture is RGB: the factor alone (0.8 ≥ 0.3), no coverage texture.
    let scene = with("MASK", None);
    let mask = scene.materials[scene.meshes[0].material as usize].alpha_mask.unwrap();
    assert_eq!(mask.texture, None);
    assert!(!scene.cut_out(scene.meshes[0].material, Vec2::new(0.25, 0.5)));
    let scene = with("BLEND", Some(&rgba_uri));
    assert!(scene.materials.iter().all(|m| m.alpha_mask.is_none()));
    assert!(scene.warnings.iter().any(|w| w.contains("alpha mode BLEND (drawn opaque)")), "{:?}", scene.warnings);
}

/// The test glTF with `image` (written as a PNG: sRGB-encoded) as its texture 1, for a material
/// slot to name. The new image goes first: texture 0 (the base colour) takes image 1, texture 1
/// image 0.
fn gltf_with_texture_1(dir: &Path, image: Image) -> String {
    let path = dir.join("texture1.png");
    image.write(&path, ToneMap::default()).unwrap();
    let png = format!("data:image/png;base64,{}", base64(&std::fs::read(&path).unwrap()));
    let uri = format!("data:application/octet-stream;base64,{}", base64(&gltf_buffer()));
    gltf_json(Some(&uri))
        .replace(r#""textures": [{"source": 0}]"#, r#""textures": [{"source": 1}, {"source": 0}]"#)
        .replace(r#""images": [{"uri": ""#, &format!(r#""images": [{{"uri": "{png}"}}, {{"uri": ""#))
}

/// A metallic-roughness texture (raw, not sRGB-decoded; G roughness, B metallic) is read per
/// texel ([`Scene::metallic_roughness`]), and its mean scales the material's factors: real
/// assets leave the factors at 1 and put the values in the texture, which read alone would make
/// every such material a fully rough metal. A texture on other uvs than the base colour's
/// leaves the mean alone, with a warning.
#[test]
fn gltf_metallic_roughness_texture_is_read_per_texel() {
    let dir = scratch("gltf_metallic_roughness");
    // Stored sRGB-encoded: raw G is srgb_encode(0.2) in both texels, raw B 1 and 0.
    let image = Image::from_fn(2, 1, |x, _| Vec3::new(0.0, 0.2, if x == 0 { 1.0 } else { 0.0 }));
    let json = gltf_with_texture_1(&dir, image)
        .replace(r#""roughnessFactor": 0.25, "metallicFactor": 0.1,"#, r#""metallicRoughnessTexture": {"index": 1},"#);
    assert!(json.contains("metallicRoughnessTexture") && json.contains(r#"{"source": 1}"#));
    let scene = load(&write(&dir, "mr.gltf", json.clone())).unwrap();
    let m = &scene.materials[scene.meshes[0].material as usize];
    let roughness = (glimpse_core::image::srgb_encode(0.2) * 255.0).round() / 255.0;
    println!("roughness {} (expected {roughness}), metallic {} (expected 0.5); warnings {:?}", m.roughness, m.metallic, scene.warnings);
    assert!((m.roughness - roughness).abs() < 1e-3 && (m.metallic - 0.5).abs() < 1e-3);
    let mid = scene.meshes[0].material;
    let (left, right) = (scene.metallic_roughness(mid, Vec2::new(0.25, 0.5)), scene.metallic_roughness(mid, Vec2::new(0.75, 0.5)));
    println!("per texel (metallic, roughness): left {left:?}, right {right:?}");
    assert!((left.0 - 1.0).abs() < 1e-6 && right.0.abs() < 1e-6, "{left:?} {right:?}");
    assert!((left.1 - roughness).abs() < 1e-6 && (right.1 - roughness).abs() < 1e-6, "{left:?} {right:?}");
    assert!(!scene.warnings.iter().any(|w| w.contains("metallic-roughness")), "{:?}", scene.warnings);
    // On TEXCOORD_1 (not read): the mean alone.
    let other_uvs =
        json.replace(r#""metallicRoughnessTexture": {"index": 1}"#, r#""metallicRoughnessTexture": {"index": 1, "texCoord": 1}"#);
    let scene = load(&write(&dir, "mr1.gltf", other_uvs)).unwrap();
    let m = &scene.materials[scene.meshes[0].material as usize];
    assert!(m.metallic_roughness_map.is_none() && (m.metallic - 0.5).abs() < 1e-3);
    assert!(scene.warnings.iter().any(|w| w.contains("metallic-roughness textures whose uvs differ")), "{:?}", scene.warnings);
}

/// A normal texture (raw, not sRGB-decoded) with its scale becomes the material's [`NormalMap`];
/// on other uvs than the base colour texture's it is ignored with a warning.
#[test]
fn gltf_normal_texture_is_read_raw_with_its_scale() {
    let dir = scratch("gltf_normal_texture");
    // Stored sRGB-encoded by `write`: the raw value read back is srgb_encode(0.2) etc.
    let json = gltf_with_texture_1(&dir, Image::from_fn(1, 1, |_, _| Vec3::new(0.2, 0.5, 1.0)))
        .replace(r#""name": "glow","#, r#""name": "glow", "normalTexture": {"index": 1, "scale": 0.5},"#);
    assert!(json.contains("normalTexture"));
    let scene = load(&write(&dir, "n.gltf", json.clone())).unwrap();
    let m = &scene.materials[scene.meshes[0].material as usize];
    let map = m.normal_map.expect("a normal map");
    let texel = scene.textures[map.texture as usize].pixels[0];
    let raw = (glimpse_core::image::srgb_encode(0.2) * 255.0).round() / 255.0;
    println!("normal map {map:?}, texel {texel}; warnings {:?}", scene.warnings);
    assert_eq!(map.scale, 0.5);
    // glTF's viewers (and pbrt-v4) shade the bent normal's cosine alone.
    assert_eq!(map.shadowing, glimpse_scene::NormalMapShadowing::None);
    assert!((texel.x - raw).abs() < 1e-6 && texel.z == 1.0, "raw channels, not decoded: {texel}");
    assert!(!scene.warnings.iter().any(|w| w.contains("normal textures")), "{:?}", scene.warnings);
    let other_uvs = json.replace(r#""normalTexture": {"index": 1, "scale": 0.5}"#, r#""normalTexture": {"index": 1, "texCoord": 1}"#);
    let scene = load(&write(&dir, "n1.gltf", other_uvs)).unwrap();
    assert!(scene.materials.iter().all(|m| m.normal_map.is_none()));
    assert!(scene.warnings.iter().any(|w| w.contains("normal textures whose uvs differ")), "{:?}", scene.warnings);
}

/// An emissive texture (sRGB colour, decoded) × the factor is the emission per texel
/// ([`Scene::emission`]); the material's own emission is the texture's mean × the factor. On
/// other uvs than the base colour texture's the mean alone is used, with a warning.
#[test]
fn gltf_emissive_texture_is_read_per_texel() {
    let dir = scratch("gltf_emissive_texture");
    // 2 × 1: black on the left, white on the right (exact in sRGB).
    let json = gltf_with_texture_1(&dir, Image::from_fn(2, 1, |x, _| Vec3::splat(x as f32)))
        .replace(r#""emissiveFactor": [1, 0.5, 0],"#, r#""emissiveFactor": [1, 0.5, 0], "emissiveTexture": {"index": 1},"#);
    assert!(json.contains("emissiveTexture"));
    let scene = load(&write(&dir, "e.gltf", json.clone())).unwrap();
    let mid = scene.meshes[0].material;
    let m = &scene.materials[mid as usize];
    let (left, right) = (scene.emission(mid, Vec2::new(0.25, 0.5)), scene.emission(mid, Vec2::new(0.75, 0.5)));
    println!("emission: material {}, map {:?}, left {left}, right {right}; warnings {:?}", m.emission, m.emission_map, scene.warnings);
    let factor = Vec3::new(4.0, 2.0, 0.0); // emissiveFactor × emissiveStrength 4
    assert_eq!(m.emission_map.map(|e| e.factor), Some(factor));
    assert!((m.emission - factor * 0.5).length() < 1e-5, "the mean × the factor: {}", m.emission);
    assert!(left.length() < 1e-6 && (right - factor).length() < 1e-5, "{left} {right}");
    assert!(!scene.warnings.iter().any(|w| w.contains("emissive textures")), "{:?}", scene.warnings);
    let other_uvs = json.replace(r#""emissiveTexture": {"index": 1}"#, r#""emissiveTexture": {"index": 1, "texCoord": 1}"#);
    let scene = load(&write(&dir, "e1.gltf", other_uvs)).unwrap();
    let m = &scene.materials[scene.meshes[0].material as usize];
    assert!(m.emission_map.is_none() && (m.emission - factor * 0.5).length() < 1e-5, "{m:?}");
    assert!(scene.warnings.iter().any(|w| w.contains("emissive textures whose uvs differ")), "{:?}", scene.warnings);
}

/// Vertex colours multiply the base colour: glTF's COLOR_0 (linear), OBJ's `v x y z r g b` and
/// PLY's red/green/blue (display colours, sRGB-decoded); a material on a coloured mesh varies.
#[test]
fn vertex_colours_are_read_from_gltf_obj_and_ply() {
    let dir = scratch("vertex_colours");
    // glTF: the normals' accessor, (0, 0, 1) at each vertex, read again as COLOR_0.
    let uri = format!("data:application/octet-stream;base64,{}", base64(&gltf_buffer()));
    let json = gltf_json(Some(&uri)).replace(r#""NORMAL": 1, "TEXCOORD_0": 2"#, r#""NORMAL": 1, "COLOR_0": 1, "TEXCOORD_0": 2"#);
    assert!(json.contains("COLOR_0"));
    let scene = load(&write(&dir, "c.gltf", json)).unwrap();
    println!("glTF colours {:?}", scene.meshes[0].colors);
    assert_eq!(scene.meshes[0].colors, vec![Vec3::Z; 3]);
    assert!(scene.base_color_varies(scene.meshes[0].material));

    let obj = "v 0 0 0 1 0.5 0\nv 1 0 0 1 0.5 0\nv 0 1 0 1 0.5 0\nf 1 2 3\n";
    let scene = load(&write(&dir, "c.obj", obj)).unwrap();
    let half = glimpse_core::image::srgb_decode(0.5);
    println!("OBJ colours {:?}", scene.meshes[0].colors);
    assert_eq!(scene.meshes[0].colors, vec![Vec3::new(1.0, half, 0.0); 3]);
    let plain = load(&write(&dir, "p.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")).unwrap();
    assert!(plain.meshes[0].colors.is_empty() && !plain.base_color_varies(plain.meshes[0].material));

    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n";
    let scene = load(&write(&dir, "c.ply", ply)).unwrap();
    println!("PLY colours {:?}", scene.meshes[0].colors);
    assert_eq!(scene.meshes[0].colors, vec![Vec3::X, Vec3::Y, Vec3::Z]);
}

/// glTF's TANGENT (VEC4 floats) is read per vertex; an accessor of another type is ignored with
/// a warning that names it.
#[test]
fn gltf_tangents_are_read() {
    let dir = scratch("tangents");
    let uri = format!("data:application/octet-stream;base64,{}", base64(&gltf_buffer()));
    // A VEC4 view over the buffer's animation floats (bytes 104..152), as the tangents.
    let json = gltf_json(Some(&uri))
        .replace(r#""NORMAL": 1, "TEXCOORD_0": 2"#, r#""NORMAL": 1, "TANGENT": 8, "TEXCOORD_0": 2"#)
        .replace(
            r#"{"buffer": 0, "byteOffset": 144, "byteLength": 24}"#,
            r#"{"buffer": 0, "byteOffset": 144, "byteLength": 24}, {"buffer": 0, "byteOffset": 104, "byteLength": 48}"#,
        )
        .replace(
            r#"{"bufferView": 7, "componentType": 5126, "count": 2, "type": "VEC3"}"#,
            r#"{"bufferView": 7, "componentType": 5126, "count": 2, "type": "VEC3"}, {"bufferView": 8, "componentType": 5126, "count": 3, "type": "VEC4"}"#,
        );
    assert!(json.contains(r#""TANGENT": 8"#) && json.contains(r#""bufferView": 8"#));
    let scene = load(&write(&dir, "t.gltf", json.clone())).unwrap();
    println!("tangents {:?}", scene.meshes[0].tangents);
    let v = glimpse_core::Vec4::new;
    assert_eq!(scene.meshes[0].tangents, vec![v(0., 2., 1., 0.), v(0., 3., 0., 0.), v(0., 1.5, 1., 1.)]);
    // The normals' VEC3 accessor as TANGENT: not read, and said.
    let scene = load(&write(&dir, "t3.gltf", json.replace(r#""TANGENT": 8"#, r#""TANGENT": 1"#))).unwrap();
    println!("warnings {:?}", scene.warnings);
    assert!(scene.meshes[0].tangents.is_empty());
    assert!(scene.warnings.iter().any(|w| w.contains("TANGENT")), "{:?}", scene.warnings);
}
