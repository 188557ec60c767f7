//! Wavefront OBJ + MTL loader, on top of `tobj`.
//!
//! What becomes what:
//! * Geometry: `tobj` (with `triangulate` and `single_index`) starts a new model at every `o`/`g`
//!   and at every `usemtl` change, so each model has one material; each model with at least one
//!   triangle becomes one [`Mesh`] with one fixed identity [`Instance`](crate::Instance).
//!   Polygons are split as fans (how the shared scenes' README counts triangles). Points and
//!   lines (`p`, `l`, faces with fewer than 3 vertices) are not surfaces: they are dropped with a
//!   warning that counts them.
//! * Texture coordinates: OBJ's v runs up the image, ours down (glTF convention), so `v = 1 − v`.
//! * Vertex colours (`v x y z r g b`, the common extension) multiply the base colour; they are
//!   sRGB-decoded (the tools that write them, MeshLab and scanners, store display colours).
//! * Normals are kept when every vertex of the model has one; a model where only some faces
//!   carry `vn` gets none (warning), and consumers compute them.
//! * Materials (MTL):
//!   * `Kd` → `base_color` (absent: the default 0.8 grey); `Ke` → `emission`, read as radiance
//!     in W/(m²·sr) (McGuire's Cornell box light: `Ke 17 12 4`). `Ka`, `Ks`, `Ni`, `illum`
//!     are ignored (`d`: below). A colour with one number (`Kd 0.5`) means grey, as the MTL spec says.
//!   * `map_Kd` → base-colour texture, the path relative to the `.mtl`; its `-s u v` (scale) and
//!     `-o u v` (offset) options map the object's uvs as `uv · s + o` (in the file's uv space,
//!     before v is flipped); other options (`-clamp`, `-bm`, …) are ignored with a warning; PNG/JPEG are sRGB-decoded to linear by
//!     [`glimpse_core::Image::read`]. A texture that cannot be read is a warning, not an error:
//!     the material keeps its `Kd`.
//!   * `map_d` → a cut-out ([`crate::AlphaMask`], as glTF's alpha mode MASK with cutoff 0.5):
//!     the texture's alpha channel, or its first channel where it has none, raw (coverage is
//!     data, not colour; [`glimpse_core::Image::read_coverage`]), times `d` where given. A
//!     `d` under 1 without `map_d` (translucency) stays opaque, with a warning.
//!   * `Ns` → roughness with ONE mapping: Walter et al. 2007 (eq. 30) match a Phong lobe of
//!     exponent `Ns` to a Beckmann lobe of width `α_b = sqrt(2 / (Ns + 2))`; we take GGX
//!     `α = α_b`, and since our `roughness` is perceptual (`α = roughness²`),
//!     **`roughness = (2 / (Ns + 2))^(1/4)`**, clamped to [0, 1]. So `Ns 0` → 1, `Ns 10` → 0.639,
//!     `Ns 100` → 0.374, `Ns 1000` → 0.211. Without `Ns` the roughness is 1.
//!   * The PBR extension's `Pr` (roughness) and `Pm` (metallic) override, when present.
//!   * A missing or unreadable `.mtl` is a warning and the faces get the default material; so do
//!     faces whose `usemtl` names no material. Files without materials (Sponza) get one default
//!     material.
//! * Errors name the file: unreadable → [`SceneError::Io`]; malformed → [`SceneError::Parse`] with
//!   the line number. Face indices are checked here before `tobj` sees them (`tobj` reports
//!   out-of-range indices only at the end of the object, without a line, and absurd ones overflow
//!   its arithmetic), and so are MTL colours with a wrong count of numbers (which `tobj` would
//!   panic on). NaN coordinates and degenerate triangles are left to [`crate::validate`].

use crate::{AlphaMask, Material, Mesh, Scene, SceneError};
use glimpse_core::bounded_read::{limit, read_bounded};
use glimpse_core::image::srgb_decode;
use glimpse_core::{Image, Mat4, Vec2, Vec3};
use std::cell::RefCell;
use std::collections::{BTreeSet, HashMap};
use std::io::Cursor;
use std::path::{Path, PathBuf};

pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let bytes = read_bounded(path, "OBJ file", limit::MESH).map_err(|e| SceneError::io(path, e.reason()))?;
    // Lossy: a stray Latin-1 byte in a comment must not make the whole file unreadable.
    let text = String::from_utf8_lossy(&bytes);
    let stats = check_records(&text).map_err(|m| SceneError::parse(path, m))?;

    let dir = path.parent().unwrap_or(Path::new("")).to_owned();
    let mtl_problems = RefCell::new(MtlProblems::default());
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let mut reader = Cursor::new(text.as_bytes());
    let result = guard(path, "OBJ", || tobj::load_obj_buf(&mut reader, &options, |mtl| load_mtl(&dir.join(mtl), &mtl_problems)))?;
    let (models, materials) = result.map_err(|e| {
        let line = line_of(text.as_bytes(), reader.position() as usize);
        SceneError::parse(path, format!("line {line}: {e}"))
    })?;
    let problems = mtl_problems.into_inner();
    if let Some(e) = problems.error {
        return Err(e);
    }

    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut scene = Scene { name, ..Default::default() };
    let source = path.display();
    scene.warnings.extend(problems.warnings);
    if stats.ignored_non_faces > 0 {
        scene.warnings.push(format!("{source}: ignored {} point and line records (not surfaces)", stats.ignored_non_faces));
    }
    // tobj returns an error here only when every mtllib failed: that is already a warning.
    let materials = materials.unwrap_or_default();
    let known: BTreeSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    let unknown: Vec<&str> = stats.usemtl.iter().map(String::as_str).filter(|n| !known.contains(n)).collect();
    if !unknown.is_empty() {
        scene.warnings.push(format!("{source}: usemtl names no loaded material ({}); those faces use the default", unknown.join(", ")));
    }

    let mut textures = TextureCache::default();
    // Each material's texture uv map (`-s`, `-o`), applied to the uvs of the faces that use it.
    let uv_maps: Vec<(Vec2, Vec2)> = materials
        .iter()
        .map(|m| {
            let statement = m.unknown_param.get(MAP_KD_STATEMENT).map_or("", String::as_str);
            let (scale, offset, ignored) = texture_uv_options(statement);
            if !ignored.is_empty() {
                scene.warnings.push(format!(
                    "{source}: material '{}': map_Kd options {} ignored (the texture repeats, unblended)",
                    m.name,
                    ignored.join(", ")
                ));
            }
            (scale, offset)
        })
        .collect();
    let material_ids: Vec<u32> = materials
        .iter()
        .map(|m| {
            let mat = convert_material(m, &mut textures, &mut scene, path);
            scene.add_material(mat)
        })
        .collect();
    let mut default_material = None;

    let mut partial_attributes = 0;
    for model in models {
        let m = model.mesh;
        if m.indices.len() < 3 {
            continue;
        }
        let material = match m.material_id.and_then(|i| material_ids.get(i)) {
            Some(&id) => id,
            None => *default_material.get_or_insert_with(|| scene.add_material(Material::default())),
        };
        let vertices = m.positions.len() / 3;
        let positions: Vec<Vec3> = m.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let mut normals: Vec<Vec3> = m.normals.chunks_exact(3).map(|n| Vec3::new(n[0], n[1], n[2])).collect();
        let (scale, offset) = m.material_id.and_then(|i| uv_maps.get(i)).copied().unwrap_or((Vec2::ONE, Vec2::ZERO));
        // The texture's own uv map, then v flipped to glTF's convention (v = 0 the top row).
        let mut uvs: Vec<Vec2> =
            m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], t[1]) * scale + offset).map(|t| Vec2::new(t.x, 1.0 - t.y)).collect();
        if normals.len() != vertices && !normals.is_empty() {
            normals.clear();
            partial_attributes += 1;
        }
        if uvs.len() != vertices && !uvs.is_empty() {
            uvs.clear();
            partial_attributes += 1;
        }
        let mut colors: Vec<Vec3> = m.vertex_color.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2]).map(srgb_decode)).collect();
        if colors.len() != vertices && !colors.is_empty() {
            colors.clear();
            partial_attributes += 1;
        }
        let indices = m.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let mesh = Mesh { name: model.name, positions, normals, uvs, colors, indices, material, ..Default::default() };
        scene.add_mesh(mesh, Mat4::IDENTITY);
    }
    if partial_attributes > 0 {
        scene.warnings.push(format!(
            "{source}: {partial_attributes} normal, texture-coordinate or colour sets cover only some faces of their object and were dropped"
        ));
    }
    if scene.meshes.is_empty() {
        return Err(SceneError::Invalid {
            source_name: source.to_string(),
            message: "the OBJ file is empty: it has no faces with 3 or more vertices".into(),
        });
    }
    Ok(scene)
}

/// Runs third-party parsing code so that a panic inside it (a bug on input we did not foresee)
/// becomes an error naming the file instead of taking the program down.
pub(crate) fn guard<T>(path: &Path, what: &str, f: impl FnOnce() -> T) -> Result<T, SceneError> {
    glimpse_core::catch_panic::catch(f)
        .map_err(|m| SceneError::parse(path, format!("the {what} reader failed on this input (internal panic: {m})")))
}

/// The 1-based number of the last line that a reader which stopped at byte `pos` has read.
fn line_of(text: &[u8], pos: usize) -> usize {
    let consumed = &text[..pos.min(text.len())];
    let newlines = consumed.iter().filter(|&&b| b == b'\n').count();
    // A line still being read (no newline yet) counts too.
    if consumed.last().is_none_or(|&b| b != b'\n') { newlines + 1 } else { newlines }
}

/// What the pre-pass over the OBJ text found.
#[derive(Default)]
struct ObjStats {
    ignored_non_faces: usize,
    usemtl: BTreeSet<String>,
}

/// Checks every face index (positive ones against the file's totals, as `tobj` resolves them at
/// the end; negative ones against the counts so far), so that bad input is one error with a line.
fn check_records(text: &str) -> Result<ObjStats, String> {
    let mut total = [0usize; 3];
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("v") => total[0] += 1,
            Some("vt") => total[1] += 1,
            Some("vn") => total[2] += 1,
            _ => {}
        }
    }
    const KIND: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let mut so_far = [0usize; 3];
    let mut stats = ObjStats::default();
    for (n, line) in text.lines().enumerate() {
        let line_no = n + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => so_far[0] += 1,
            Some("vt") => so_far[1] += 1,
            Some("vn") => so_far[2] += 1,
            Some("l" | "p") => stats.ignored_non_faces += 1,
            Some("usemtl") => {
                if let Some((_, name)) = line.trim().split_once(' ') {
                    stats.usemtl.insert(name.trim().to_owned());
                }
            }
            Some("f") => {
                let corners: Vec<&str> = words.collect();
                if corners.len() < 3 {
                    stats.ignored_non_faces += 1;
                }
                for corner in corners {
                    let parts: Vec<&str> = corner.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(format!("line {line_no}: face corner '{corner}' is not v, v/vt, v//vn or v/vt/vn"));
                    }
                    for (k, part) in parts.iter().enumerate().filter(|(_, p)| !p.is_empty()) {
                        let x: i64 =
                            part.parse().map_err(|_| format!("line {line_no}: face corner '{corner}': '{part}' is not an index"))?;
                        if x == 0 {
                            return Err(format!("line {line_no}: face corner '{corner}': index 0 is invalid (OBJ indices start at 1)"));
                        }
                        let defined = if x > 0 { total[k] } else { so_far[k] };
                        if x.unsigned_abs() > defined as u64 {
                            let (kind, where_) = (KIND[k], if x > 0 { "in the file" } else { "before this line" });
                            return Err(format!(
                                "line {line_no}: face corner '{corner}' refers to {kind} {x}, but {defined} are defined {where_}"
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(stats)
}

/// What went wrong while reading `.mtl` files (the `tobj` callback cannot return our errors).
#[derive(Default)]
struct MtlProblems {
    warnings: Vec<String>,
    error: Option<SceneError>,
}

/// Reads one `.mtl` for `tobj`: a missing file is a warning; malformed content is an error
/// naming the `.mtl` and its line. Texture paths are made relative to the `.mtl`'s folder here,
/// where that folder is known.
fn load_mtl(path: &Path, problems: &RefCell<MtlProblems>) -> tobj::MTLLoadResult {
    // Bounded: a regular file under the text limit (an `mtllib /dev/zero` is a warning, not a read).
    let bytes = match read_bounded(path, "material library", limit::TEXT) {
        Ok(b) => b,
        Err(e) => {
            problems.borrow_mut().warnings.push(format!("{e}; using the default material"));
            return Err(tobj::LoadError::OpenFileFailed);
        }
    };
    let fail = |message: String| {
        problems.borrow_mut().error.get_or_insert(SceneError::parse(path, message));
        Err(tobj::LoadError::MaterialParseError)
    };
    let text = match normalize_mtl(&String::from_utf8_lossy(&bytes)) {
        Ok(t) => t,
        Err(m) => return fail(m),
    };
    let mut reader = Cursor::new(text.as_bytes());
    let result = match guard(path, "MTL", || tobj::load_mtl_buf(&mut reader)) {
        Ok(r) => r,
        Err(e) => {
            problems.borrow_mut().error.get_or_insert(e);
            return Err(tobj::LoadError::MaterialParseError);
        }
    };
    match result {
        Ok((mut materials, names)) => {
            let dir = path.parent().unwrap_or(Path::new(""));
            for m in &mut materials {
                if let Some(tex) = m.diffuse_texture.clone() {
                    m.diffuse_texture = Some(dir.join(texture_file_name(&tex)).to_string_lossy().into_owned());
                    m.unknown_param.insert(MAP_KD_STATEMENT.to_owned(), tex);
                }
                if let Some(tex) = m.dissolve_texture.clone() {
                    m.dissolve_texture = Some(dir.join(texture_file_name(&tex)).to_string_lossy().into_owned());
                }
            }
            Ok((materials, names))
        }
        Err(e) => fail(format!("line {}: {e}", line_of(text.as_bytes(), reader.position() as usize))),
    }
}

/// Rewrites colour statements so `tobj` can take them: a single number means grey (MTL spec);
/// trailing `#` comments go. Two numbers or none are errors (`tobj` would panic on them).
fn normalize_mtl(text: &str) -> Result<String, String> {
    let mut out = String::with_capacity(text.len() + 64);
    for (n, line) in text.lines().enumerate() {
        let code = line.split('#').next().unwrap_or("");
        let words: Vec<&str> = code.split_whitespace().collect();
        match words.first() {
            Some(&key @ ("Ka" | "Kd" | "Ks" | "Ke")) => match words.len() {
                2 => out.push_str(&format!("{key} {0} {0} {0}", words[1])),
                1 | 3 => return Err(format!("line {}: '{key}' needs r g b (or one grey value), found '{}'", n + 1, code.trim())),
                _ => out.push_str(code),
            },
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    Ok(out)
}

/// Where the loader keeps a material's whole `map_Kd` statement (its options) beside tobj's
/// unknown parameters (no MTL key has a space).
const MAP_KD_STATEMENT: &str = "map_Kd statement";

/// A texture statement's uv map: `-s u [v [w]]` scales and `-o u [v [w]]` offsets the uvs (the
/// MTL spec's defaults: 1 and 0; w is for 3D textures), and the names of the options ignored.
fn texture_uv_options(statement: &str) -> (Vec2, Vec2, Vec<String>) {
    let words: Vec<&str> = statement.split_whitespace().collect();
    let (mut scale, mut offset, mut ignored) = (Vec2::ONE, Vec2::ZERO, Vec::new());
    let mut i = 0;
    // Options come before the name, each a `-key` and its numbers.
    while i + 1 < words.len() && words[i].starts_with('-') {
        let key = words[i];
        let numbers: Vec<f32> = words[i + 1..words.len() - 1].iter().map_while(|w| w.parse().ok()).collect();
        let (u, v) = (numbers.first().copied(), numbers.get(1).copied());
        match (key, u) {
            ("-s", Some(u)) => scale = Vec2::new(u, v.unwrap_or(u)),
            ("-o", Some(u)) => offset = Vec2::new(u, v.unwrap_or(0.0)),
            _ => ignored.push(key.to_owned()),
        }
        // A non-numeric argument (`-clamp on`, `-imfchan l`) is one word.
        i += 1 + numbers.len().max(1);
    }
    (scale, offset, ignored)
}

/// The file name in a `map_Kd` statement: options (`-s 1 1 1 -bm 0.5 name.png`) come first, so
/// with options the name is the last word; without, the whole rest (names may hold spaces).
fn texture_file_name(statement: &str) -> String {
    let s = statement.trim();
    let name = if s.starts_with('-') { s.split_whitespace().last().unwrap_or(s) } else { s };
    name.replace('\\', "/")
}

/// The mapping from Phong exponent `Ns` to perceptual roughness (see the module doc).
pub fn roughness_from_ns(ns: f32) -> f32 {
    (2.0 / (ns.max(0.0) + 2.0)).powf(0.25).clamp(0.0, 1.0)
}

/// How a texture file is read: colour (sRGB-decoded), coverage ([`Image::read_coverage`]) or
/// raw data ([`Image::read_raw`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum TextureRead {
    Colour,
    Coverage,
    Raw,
}

/// Loads each texture file once per [`TextureRead`] into [`Scene::textures`]; a file that
/// cannot be read is a warning naming it.
#[derive(Default)]
pub(crate) struct TextureCache {
    by_path: HashMap<(PathBuf, TextureRead), Option<u32>>,
}

impl TextureCache {
    /// The texture's index in `scene.textures`, or `None` (with a warning) when it cannot be read.
    pub(crate) fn load(&mut self, path: &Path, scene: &mut Scene, referrer: &Path) -> Option<u32> {
        self.load_as(path, TextureRead::Colour, scene, referrer)
    }

    /// [`TextureCache::load`] of a coverage texture ([`Image::read_coverage`]).
    pub(crate) fn load_coverage(&mut self, path: &Path, scene: &mut Scene, referrer: &Path) -> Option<u32> {
        self.load_as(path, TextureRead::Coverage, scene, referrer)
    }

    pub(crate) fn load_as(&mut self, path: &Path, how: TextureRead, scene: &mut Scene, referrer: &Path) -> Option<u32> {
        let key = (path.to_owned(), how);
        if let Some(&id) = self.by_path.get(&key) {
            return id;
        }
        let read = match how {
            TextureRead::Colour => Image::read(path),
            TextureRead::Coverage => Image::read_coverage(path),
            TextureRead::Raw => Image::read_raw(path),
        };
        let id = match read {
            Ok(img) => {
                scene.textures.push(img);
                Some(scene.textures.len() as u32 - 1)
            }
            Err(e) => {
                scene.warnings.push(format!("{}: texture not loaded ({e}); using the colour factor alone", referrer.display()));
                None
            }
        };
        self.by_path.insert(key, id);
        id
    }
}

fn convert_material(m: &tobj::Material, textures: &mut TextureCache, scene: &mut Scene, obj: &Path) -> Material {
    let rgb = |c: [f32; 3]| Vec3::from_array(c);
    let mut mat = Material { name: m.name.clone(), ..Default::default() };
    if let Some(kd) = m.diffuse {
        mat.base_color = rgb(kd);
    }
    let ke = m.emissive.or_else(|| m.unknown_param.get("Ke").and_then(|s| parse3(s)));
    if let Some(ke) = ke {
        mat.emission = rgb(ke);
    }
    // An ambient colour above 1 is a light in some exporters' files (embree's Cornell box, as
    // tinyobjloader ships it: `Ka 20 20 20`, no `Ke`); MTL has no such meaning, so it is said,
    // not guessed.
    if let (None, Some(ka)) = (ke, m.ambient)
        && ka.iter().any(|&c| c > 1.0)
    {
        let ka = format!("{} {} {}", ka[0], ka[1], ka[2]);
        scene.warnings.push(format!(
            "{}: material '{}': 'Ka {ka}' is brighter than 1 and there is no 'Ke': some exporters store emission in Ka, glimpse reads it from Ke only (add 'Ke {ka}' to make it a light)",
            obj.display(),
            m.name,
        ));
    }
    if let Some(ns) = m.shininess {
        mat.roughness = roughness_from_ns(ns);
    }
    let mut scalar = |key: &str| -> Option<f32> {
        let s = m.unknown_param.get(key)?;
        let v = s.split_whitespace().next().and_then(|w| w.parse().ok());
        if v.is_none() {
            scene.warnings.push(format!("{}: material '{}': '{key} {s}' is not a number; ignored", obj.display(), m.name));
        }
        v
    };
    if let Some(pr) = scalar("Pr") {
        mat.roughness = pr;
    }
    if let Some(pm) = scalar("Pm") {
        mat.metallic = pm;
    }
    if let Some(tex) = &m.diffuse_texture {
        mat.base_color_texture = textures.load(Path::new(tex), scene, obj);
    }
    let dissolve = m.dissolve.unwrap_or(1.0);
    if let Some(tex) = &m.dissolve_texture {
        // A coverage texture that cannot be read leaves the material opaque (a warning).
        if let Some(texture) = textures.load_coverage(Path::new(tex), scene, obj) {
            mat.alpha_mask = Some(AlphaMask { texture: Some(texture), factor: dissolve, cutoff: 0.5 });
        }
    } else if dissolve < 1.0 {
        scene.warnings.push(format!("{}: material '{}': 'd {dissolve}' (translucency) is drawn opaque", obj.display(), m.name));
    }
    mat
}

fn parse3(s: &str) -> Option<[f32; 3]> {
    let v: Vec<f32> = s.split_whitespace().take(3).map(str::parse).collect::<Result<_, _>>().ok()?;
    match v[..] {
        [r] => Some([r; 3]),
        [r, g, b] => Some([r, g, b]),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ns_mapping_matches_the_documented_formula() {
        for (ns, expected) in [(0.0, 1.0), (10.0, 0.638_943), (100.0, 0.374_20), (1000.0, 0.211_37)] {
            let r = roughness_from_ns(ns);
            println!("Ns {ns} -> roughness {r:.5} (GGX alpha {:.5})", r * r);
            assert!((r - expected).abs() < 1e-4, "Ns {ns}: {r}");
            // α = roughness² equals Walter's Beckmann width sqrt(2 / (Ns + 2)).
            assert!((r * r - (2.0 / (ns + 2.0)).sqrt()).abs() < 1e-6);
        }
        assert_eq!(roughness_from_ns(-5.0), 1.0);
    }

    #[test]
    fn line_numbers_count_from_one() {
        let t = b"a\nb\nc";
        assert_eq!(line_of(t, 0), 1);
        assert_eq!(line_of(t, 2), 1, "after the first newline the first line has been read");
        assert_eq!(line_of(t, 4), 2);
        assert_eq!(line_of(t, 5), 3, "last line without a newline");
    }

    #[test]
    fn mtl_colours_are_normalized_or_rejected() {
        let out = normalize_mtl("newmtl a\nKd 0.5 # grey\nKe 1 2 3\n").unwrap();
        assert!(out.contains("Kd 0.5 0.5 0.5\n") && out.contains("Ke 1 2 3"), "{out}");
        let e = normalize_mtl("newmtl a\n\nKd 0.5 0.2\n").unwrap_err();
        assert!(e.starts_with("line 3:"), "{e}");
        assert!(normalize_mtl("Ks\n").is_err());
    }

    #[test]
    fn texture_statements_lose_their_options() {
        assert_eq!(texture_file_name("-s 1 1 1 -o 0 0 0 tex.png"), "tex.png");
        let (s, o, ignored) = texture_uv_options("-s 2 3 1 -o 0.5 0.25 0 -clamp on -bm 0.5 tex.png");
        assert_eq!((s, o, ignored), (Vec2::new(2.0, 3.0), Vec2::new(0.5, 0.25), vec!["-clamp".to_owned(), "-bm".to_owned()]));
        assert_eq!(texture_uv_options("-s 4 tex.png"), (Vec2::splat(4.0), Vec2::ZERO, vec![]));
        assert_eq!(texture_uv_options("tex.png"), (Vec2::ONE, Vec2::ZERO, vec![]));
        assert_eq!(texture_file_name("my tex.png "), "my tex.png");
        assert_eq!(texture_file_name("textures\\a.png"), "textures/a.png");
    }

    #[test]
    fn face_index_check_names_the_line() {
        let e = check_records("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n").err().unwrap();
        println!("{e}");
        assert!(e.starts_with("line 4:") && e.contains("99") && e.contains("3 are defined"), "{e}");
        assert!(check_records("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").is_ok());
        assert!(check_records("v 0 0 0\nf -2 -1 1\n").is_err());
        assert!(check_records("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n").is_err(), "no vt defined");
        assert!(check_records("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n").is_err(), "0 is not an OBJ index");
        assert!(check_records("f 1 2 99999999999999999999999\n").is_err());
        let s = check_records("v 0 0 0\nv 1 0 0\nl 1 2\nf 1 2\n").unwrap();
        assert_eq!(s.ignored_non_faces, 2);
    }
}
