//! Mitsuba 3 XML and PLY loader tests: the shared Cornell box, small files written here for each
//! feature (defaults, transforms, camera, shapes, emitters, PLY encodings), and bad input, each
//! error checked to be one line naming the file, the line and the element.

use glimpse_core::{Vec2, Vec3};
use glimpse_scene::LightKind;
use std::path::Path;

mod common;
use common::{load, scratch, shared_scenes, write};

/// A scene file around `body`.
fn xml(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{body}\n</scene>\n")
}

/// The error of loading `path`, checked to be one line that names `file`; returns it.
fn one_line_error(path: &Path, file: &str) -> String {
    let e = load(path).err().unwrap_or_else(|| panic!("{} should not load", path.display())).to_string();
    println!("error: {e}");
    assert!(!e.contains('\n'), "one line: {e}");
    assert!(e.contains(file), "names {file}: {e}");
    e
}

#[test]
fn the_shared_cornell_box_loads_with_its_settings() {
    let Some(dir) = shared_scenes() else { return };
    let s = load(&dir.join("cornell-box-mitsuba/cbox.xml")).unwrap();
    // 6 OBJ files (luminaire, floor, ceiling, back, two walls) and two spheres.
    assert_eq!(s.meshes.len(), 8);
    let h = &s.render_hints;
    assert_eq!((h.size, h.spp, h.max_depth, h.filter.as_deref()), (Some((256, 256)), Some(128), Some(5), Some("tent")));
    assert_eq!(s.film.filter, glimpse_scene::Filter::Tent, "the rfilter is the scene's pixel filter");
    let cam = s.camera.as_ref().unwrap();
    assert!((cam.position - Vec3::new(0.0, 0.0, 4.0)).length() < 1e-6);
    assert!((cam.fov.to_degrees() - 39.3077).abs() < 1e-3, "square film: fov_axis smaller is vertical");
    let emissive: Vec<_> = s.materials.iter().filter(|m| m.is_emissive()).collect();
    assert_eq!(emissive.len(), 1);
    assert_eq!(emissive[0].emission, Vec3::new(18.387, 13.9873, 6.75357));
    // The mirror sphere: scale 0.5 then translate, so its bounds are centred at (-0.3, -0.5, 0.2).
    let b = s.at(0.0);
    let mirror = s.meshes.iter().position(|m| m.name == "mirrorsphere").unwrap();
    let inst = s.instances.iter().find(|i| i.mesh as usize == mirror).unwrap();
    let c = inst.motion.at(0.0).transform_point3(Vec3::ZERO);
    assert!((c - Vec3::new(-0.3, -0.5, 0.2)).length() < 1e-5, "{c}");
    assert!(b.bounds.extent().max_element() > 1.9);
}

#[test]
fn defaults_transforms_camera_and_emitters() {
    let dir = scratch("features");
    let path = write(
        &dir,
        "s.xml",
        xml(r#"
    <default name="w" value="200"/>
    <default name="h" value="100"/>
    <integrator type="path"><integer name="max_depth" value="-1"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="90"/>
        <transform name="to_world"><lookat origin="1, 2, 3" target="1, 2, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$w"/></sampler>
        <film type="hdrfilm"><integer name="width" value="$w"/><integer name="height" value="$h"/><rfilter type="gaussian"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale x="2" y="3"/><rotate x="1" angle="-90"/><translate y="1"/></transform>
    </shape>
    <shape type="cube"><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>
    <emitter type="point"><point name="position" x="0" y="5" z="0"/><rgb name="intensity" value="10"/></emitter>
    <emitter type="spot">
        <transform name="to_world"><lookat origin="0, 4, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
        <float name="cutoff_angle" value="30"/><float name="beam_width" value="30"/>
    </emitter>
    <emitter type="directional"><vector name="direction" x="0" y="-1" z="0"/><spectrum name="irradiance" value="2"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.5, 0.5, 0.5"/></emitter>
"#),
    );
    let s = load(&path).unwrap();
    let h = &s.render_hints;
    assert_eq!((h.size, h.spp, h.max_depth), (Some((200, 100)), Some(200), Some(-1)));
    let cam = s.camera.as_ref().unwrap();
    assert!((cam.position - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-6);
    assert!(((cam.target - cam.position).normalize() - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
    // fov 90 along x (the default axis) at 2:1 → tan(fov_y/2) = 1/2.
    assert!(((cam.fov * 0.5).tan() - 0.5).abs() < 1e-5, "{}", cam.fov.to_degrees());
    assert!(s.warnings.iter().any(|w| w.contains("fov_axis 'x' converted")), "{:?}", s.warnings);
    // The rectangle: [-1,1]² scaled (2, 3), turned to face +y, lifted by 1 → x ∈ ±2, z ∈ ±3, y = 1.
    let m = s.instances[0].motion.at(0.0);
    let world: Vec<Vec3> = s.meshes[0].positions.iter().map(|p| m.transform_point3(*p)).collect();
    let rect = glimpse_core::Aabb::from_points(&world);
    assert!((rect.min - Vec3::new(-2.0, 1.0, -3.0)).length() < 1e-5 && (rect.max - Vec3::new(2.0, 1.0, 3.0)).length() < 1e-5, "{rect:?}");
    let kinds: Vec<_> = s.lights.iter().map(|l| l.kind).collect();
    assert!(matches!(kinds[..], [LightKind::Point, LightKind::Spot { .. }, LightKind::Directional]));
    assert_eq!(s.lights[0].intensity, Vec3::splat(10.0));
    assert!((s.lights[1].direction - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-6);
    assert_eq!(s.lights[2].intensity, Vec3::splat(2.0));
    assert!(s.environment.is_some());
    assert!(s.materials.iter().any(|m| m.emission == Vec3::new(1.0, 2.0, 3.0)));
}

#[test]
fn a_mitsuba_envmap_is_turned_half_a_turn_into_glimpse_convention() {
    // A 4×2 map whose texels are distinct: Mitsuba's u = 0 (texel 0) looks along −z… through
    // atan2(x, −z) = 0, which is glimpse's u = 0.5.
    let img = glimpse_core::Image::from_fn(4, 2, |x, y| Vec3::new(x as f32, y as f32, 1.0));
    let out = glimpse_scene::mitsuba_loader::mitsuba_envmap(&img, glimpse_core::Mat4::IDENTITY);
    for y in 0..2 {
        for x in 0..4 {
            let (got, want) = (out.get(x, y), img.get((x + 2) % 4, y));
            assert_eq!(got.x, want.x, "texel ({x}, {y}): columns shift by half the width");
            // Rows: Mitsuba's at v = row/(h − 1), so glimpse's row centres v = ¼, ¾ read rows ¼ and ¾ of the way.
            assert!((got.y - [0.25, 0.75][y as usize]).abs() < 1e-6, "texel ({x}, {y}): {got}");
        }
    }
}

/// Four vertices of a unit square with normals +z and uvs, and one quad face, in each encoding.
fn ply_square(format: &str) -> Vec<u8> {
    let header = format!(
        "ply\nformat {format} 1.0\ncomment square\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n"
    );
    let verts = [
        [0.0f32, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
        [1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0],
    ];
    let mut out = header.into_bytes();
    match format {
        "ascii" => {
            for v in verts {
                out.extend(v.map(|x| x.to_string()).join(" ").bytes());
                out.push(b'\n');
            }
            out.extend(b"4 0 1 2 3\n");
        }
        _ => {
            let be = format == "binary_big_endian";
            for v in verts {
                for x in v {
                    out.extend(if be { x.to_be_bytes() } else { x.to_le_bytes() });
                }
            }
            out.push(4);
            for i in 0..4i32 {
                out.extend(if be { i.to_be_bytes() } else { i.to_le_bytes() });
            }
        }
    }
    out
}

#[test]
fn ply_ascii_and_both_binary_encodings_read_the_same_mesh() {
    let dir = scratch("ply");
    let mut meshes = Vec::new();
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let p = write(&dir, &format!("{format}.ply"), ply_square(format));
        let s = load(&p).unwrap();
        assert_eq!(s.meshes.len(), 1, "{format}");
        meshes.push(s.meshes[0].clone());
    }
    for m in &meshes {
        assert_eq!(m.positions, meshes[0].positions);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.normals, vec![Vec3::Z; 4]);
        assert_eq!(m.uvs[2], Vec2::new(1.0, 1.0));
    }
    // And through a Mitsuba scene, placed by its to_world.
    write(
        &dir,
        "s.xml",
        xml(
            r#"<shape type="ply"><string name="filename" value="ascii.ply"/><transform name="to_world"><translate x="5"/></transform></shape>"#,
        ),
    );
    let s = load(&dir.join("s.xml")).unwrap();
    assert!((s.bounds().min.x - 5.0).abs() < 1e-6);
}

// ---- bad input: one `error:` line naming the file, the line and the element -----------------

#[test]
fn malformed_xml_names_the_file_and_line() {
    let dir = scratch("malformed");
    let p = write(&dir, "bad.xml", "<scene version=\"3.0.0\">\n<shape type=\"cube\">\n</scene>\n");
    let e = one_line_error(&p, "bad.xml");
    assert!(e.contains("line 3"), "{e}");
}

#[test]
fn truncated_xml_is_an_error() {
    let dir = scratch("truncated");
    let full = xml(r#"<shape type="cube"><bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>"#);
    let p = write(&dir, "cut.xml", &full[..full.len() / 2]);
    let e = one_line_error(&p, "cut.xml");
    assert!(e.contains("XML"), "{e}");
}

#[test]
fn an_unsupported_plugin_names_its_line_and_element() {
    let dir = scratch("plugin");
    let p = write(&dir, "p.xml", xml("<bsdf type=\"plastic\" id=\"x\"/>"));
    let e = one_line_error(&p, "p.xml");
    assert!(e.contains("line 2") && e.contains("<bsdf type='plastic' id='x'>") && e.contains("BSDF 'plastic'"), "{e}");
    let p = write(&dir, "s.xml", xml("<shape type=\"disk\"/>"));
    assert!(one_line_error(&p, "s.xml").contains("shape 'disk'"));
    let p = write(&dir, "e.xml", xml("<emitter type=\"sky\"/>"));
    assert!(one_line_error(&p, "e.xml").contains("emitter 'sky'"));
    let p = write(&dir, "i.xml", xml("<integrator type=\"volpath\"/>"));
    assert!(one_line_error(&p, "i.xml").contains("integrator 'volpath'"));
}

#[test]
fn an_unknown_parameter_is_not_dropped() {
    let dir = scratch("param");
    let p = write(&dir, "p.xml", xml("<bsdf type=\"diffuse\" id=\"d\">\n<float name=\"roughness\" value=\"0.3\"/>\n</bsdf>"));
    let e = one_line_error(&p, "p.xml");
    assert!(
        e.contains("line 3") && e.contains("<float name='roughness'>") && e.contains("not supported inside <bsdf type='diffuse'"),
        "{e}"
    );
}

#[test]
fn an_undefined_substitution_or_reference_is_an_error() {
    let dir = scratch("subst");
    let p = write(&dir, "s.xml", xml("<integrator type=\"path\"><integer name=\"max_depth\" value=\"$depth\"/></integrator>"));
    assert!(one_line_error(&p, "s.xml").contains("$depth"));
    let p = write(&dir, "r.xml", xml("<shape type=\"cube\"><ref id=\"nowhere\"/></shape>"));
    let e = one_line_error(&p, "r.xml");
    assert!(e.contains("line 2") && e.contains("nowhere"), "{e}");
}

#[test]
fn a_missing_referenced_file_names_both_files() {
    let dir = scratch("missing");
    for (kind, file) in [("obj", "gone.obj"), ("ply", "gone.ply")] {
        let p = write(&dir, "m.xml", xml(&format!("<shape type=\"{kind}\">\n<string name=\"filename\" value=\"{file}\"/>\n</shape>")));
        let e = one_line_error(&p, file);
        assert!(e.contains("m.xml line 3") && e.contains("not found"), "{e}");
    }
    let p = write(&dir, "env.xml", xml("<emitter type=\"envmap\"><string name=\"filename\" value=\"sky.exr\"/></emitter>"));
    assert!(one_line_error(&p, "sky.exr").contains("env.xml"));
}

#[test]
fn malformed_ply_header_and_faces_are_errors() {
    let dir = scratch("badply");
    let p = write(&dir, "h.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty floot x\nend_header\n0\n");
    let e = one_line_error(&p, "h.ply");
    assert!(e.to_lowercase().contains("line 4"), "{e}");
    let p = write(&dir, "n.ply", "not a ply\n");
    assert!(one_line_error(&p, "n.ply").contains("line 1"));
    let text = String::from_utf8(ply_square("ascii")).unwrap().replace("4 0 1 2 3", "4 0 1 2 9");
    let p = write(&dir, "f.ply", text);
    assert!(one_line_error(&p, "f.ply").contains("face 0 refers to vertex 9"));
}

#[test]
fn truncated_ply_is_refused_before_allocation() {
    let dir = scratch("truncply");
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let bytes = ply_square(format);
        let p = write(&dir, &format!("{format}.ply"), &bytes[..bytes.len() - 20]);
        let e = one_line_error(&p, &format!("{format}.ply"));
        assert!(e.contains("truncated") || e.contains("Line 19"), "{format}: {e}");
        // A count far beyond the file is caught by the header check, with the declaring line.
        let huge = String::from_utf8_lossy(&bytes).replace("element vertex 4", "element vertex 4000000000");
        if format == "ascii" {
            let p = write(&dir, "huge.ply", huge);
            let e = one_line_error(&p, "huge.ply");
            assert!(e.contains("line 4: element 'vertex'") && e.contains("4000000000"), "{e}");
        }
    }
}

/// The cross-check's `textures` scene (tools/crosscheck/scenes/textures.xml): `normalmap` reads its
/// bitmap raw, with Mitsuba's frame (B = n × T), around a diffuse with a bitmap reflectance
/// (sRGB-decoded), and an area light's bitmap radiance is its emission per texel.
#[test]
fn normal_maps_and_textured_emitters_load_from_mitsuba() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/crosscheck/scenes/textures.xml");
    let scene = glimpse_scene::load(path.to_str().unwrap()).unwrap();
    let floor = scene.materials.iter().find(|m| m.normal_map.is_some()).expect("the normal-mapped floor");
    let map = floor.normal_map.unwrap();
    assert_eq!((map.scale, map.bitangent), (1.0, glimpse_scene::Bitangent::NormalCrossTangent));
    // Mitsuba 3's `normalmap` shadows the bend (crates/render/tests/bump_shadowing.rs).
    assert_eq!(map.shadowing, glimpse_scene::NormalMapShadowing::Microfacet);
    let normals = &scene.textures[map.texture as usize];
    let albedo = &scene.textures[floor.base_color_texture.expect("the bitmap reflectance") as usize];
    // Raw: a flat-ish normal map's z channel is near 1 (sRGB-decoding would not change 1, so
    // check x, whose raw mean is near 0.5 and decoded near 0.21).
    println!("normal map mean {}, albedo mean {}", normals.mean(), albedo.mean());
    assert!((normals.mean().x - 0.5).abs() < 0.05, "{}", normals.mean());
    let light = scene.materials.iter().find(|m| m.emission_map.is_some()).expect("the textured light");
    let e = light.emission_map.unwrap();
    assert_eq!(e.factor, Vec3::ONE);
    assert!((light.emission - scene.textures[e.texture as usize].mean()).length() < 1e-4, "{}", light.emission);
    assert!(scene.textures[e.texture as usize].pixels.iter().any(|p| p.x == 40.0), "the EXR's radiance as it is");
}

/// A PLY mesh's vertex colours are its reflectance only through a `mesh_attribute` texture
/// (`vertex_color`), read as Mitsuba 3.9.1 reads them: floats as they are (linear), integers
/// unscaled (with a warning). A mesh whose BSDF does not read them is drawn without them, as in
/// Mitsuba. Other attributes and other shapes are errors naming the file.
#[test]
fn vertex_colours_load_from_mitsuba_through_mesh_attribute() {
    let dir = scratch("mitsuba_vertex_colours");
    let ply = |name: &str, kind: &str, colours: [&str; 3]| {
        let body = format!(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             property {kind} red\nproperty {kind} green\nproperty {kind} blue\nelement face 1\n\
             property list uchar int vertex_indices\nend_header\n0 0 0 {}\n1 0 0 {}\n0 1 0 {}\n3 0 1 2\n",
            colours[0], colours[1], colours[2]
        );
        write(&dir, name, body);
    };
    ply("f.ply", "float", ["0.5 0.25 0", "0 1 0", "0 0 1"]);
    ply("u.ply", "uchar", ["128 0 0", "0 255 0", "0 0 255"]);
    let attribute = r#"<texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_color"/></texture>"#;
    let shape = |file: &str, reflectance: &str| {
        format!(r#"<shape type="ply"><string name="filename" value="{file}"/><bsdf type="diffuse">{reflectance}</bsdf></shape>"#)
    };
    let s = load(&write(&dir, "f.xml", xml(&shape("f.ply", attribute)))).unwrap();
    println!("float colours {:?}, base colour {}", s.meshes[0].colors, s.materials[0].base_color);
    assert_eq!(s.meshes[0].colors, vec![Vec3::new(0.5, 0.25, 0.0), Vec3::Y, Vec3::Z], "linear, not sRGB-decoded");
    assert_eq!(s.materials[0].base_color, Vec3::ONE);
    let s = load(&write(&dir, "u.xml", xml(&shape("u.ply", attribute)))).unwrap();
    println!("8-bit colours {:?}; warnings {:?}", s.meshes[0].colors, s.warnings);
    assert_eq!(s.meshes[0].colors[0], Vec3::new(128.0, 0.0, 0.0), "unscaled, as Mitsuba 3.9.1 reads them");
    assert!(s.warnings.iter().any(|w| w.contains("vertex colours above 1")), "{:?}", s.warnings);
    // Not read by the BSDF: no colours.
    let s = load(&write(&dir, "plain.xml", xml(&shape("f.ply", r#"<rgb name="reflectance" value="0.3"/>"#)))).unwrap();
    assert!(s.meshes[0].colors.is_empty(), "Mitsuba ignores colours its BSDF does not read");
    // Another attribute, or vertex colours on a shape that has none.
    let other = attribute.replace("vertex_color", "face_color");
    let e = one_line_error(&write(&dir, "other.xml", xml(&shape("f.ply", &other))), "other.xml");
    assert!(e.contains("only 'vertex_color'"), "{e}");
    let cube = format!(r#"<shape type="cube"><bsdf type="diffuse">{attribute}</bsdf></shape>"#);
    let e = one_line_error(&write(&dir, "cube.xml", xml(&cube)), "cube.xml");
    assert!(e.contains("only PLY files carry vertex colours"), "{e}");
    write(
        &dir,
        "none.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    );
    let e = one_line_error(&write(&dir, "none.xml", xml(&shape("none.ply", attribute))), "none.xml");
    assert!(e.contains("no red/green/blue"), "{e}");
}
