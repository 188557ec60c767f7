//! Mitsuba 3 XML scenes (`<scene version="3.…">`), the subset common test scenes use:
//!
//! - `<default name value>` and `$name` substitution in every attribute;
//! - `perspective` sensor: `fov` (or `focal_length`), `fov_axis` (x, y, diagonal, smaller,
//!   larger), `to_world` (`lookat`, `matrix`, `translate`, `rotate`, `scale`, composed in order);
//!   `hdrfilm` `width`/`height` with a `box`, `tent` or `gaussian` `rfilter`; `independent`
//!   sampler `sample_count` → [`crate::RenderHints`];
//! - `path` integrator `max_depth` → [`crate::RenderHints::max_depth`] (Mitsuba counts path segments,
//!   glimpse scattering vertices: glimpse = Mitsuba − 1; −1 stays unbounded);
//! - BSDFs `diffuse`, `conductor`, `roughconductor` (GGX), `dielectric`, `twosided` or
//!   `normalmap` (a raw bitmap, [`NormalMap`]) around one of them; `rgb`, `spectrum` (one
//!   value), `float` or `bitmap` texture reflectance (`raw` or sRGB-decoded), or a PLY mesh's
//!   vertex colours (`mesh_attribute` `vertex_color`, read as Mitsuba reads them:
//!   [`PlyColors::Mitsuba`]; a mesh whose material does not read them is drawn without them);
//! - shapes `obj`, `ply`, `rectangle`, `cube`, `sphere` with `to_world`, a BSDF (nested or
//!   `ref`) and an `area` emitter (its radiance a colour or a bitmap, [`EmissionMap`]);
//! - emitters `point`, `spot`, `directional`, `envmap`, `constant`;
//! - `ref` ids to BSDFs and textures.
//!
//! Anything else (a plugin, a parameter, a value) is an error naming the file, the line and the
//! element: nothing is dropped silently. Parameters that do not change the expected image
//! (clip planes, the film's pixel format, the sampler's seed, the integrator's `rr_depth`) are
//! accepted. Choices where the models differ are documented where they are made and reported
//! as scene warnings.

use crate::builtin::{box_mesh, sphere_mesh};
use crate::obj_loader::{TextureCache, TextureRead};
use crate::ply_loader::PlyColors;
use crate::{
    Bitangent, Camera, EmissionMap, Environment, Light, Material, MaterialModel, Mesh, NormalMap, NormalMapShadowing, Scene, SceneError,
};
use glimpse_core::{Image, Mat4, Vec2, Vec3};
use roxmltree::{Document, Node};
use std::collections::HashMap;
use std::f32::consts::{PI, TAU};
use std::path::{Path, PathBuf};

/// Segments around a tessellated `sphere` (rings are half; its uvs are glimpse's sphere's, not
/// Mitsuba's, and so are the `cube`'s): fine enough that a mirror or glass
/// sphere's silhouette and reflections match the analytic sphere within a pixel at 512².
const SPHERE_SEGMENTS: u32 = 256;

pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(path, format!("cannot read the scene: {e}")))?;
    let options = roxmltree::ParsingOptions { allow_dtd: true, ..Default::default() };
    let doc = Document::parse_with_options(&text, options).map_err(|e| {
        let pos = e.pos();
        SceneError::parse(path, format!("line {}, column {}: XML: {e}", pos.row, pos.col))
    })?;
    let mut loader = Loader {
        path,
        dir: path.parent().unwrap_or(Path::new("")).to_owned(),
        doc: &doc,
        defaults: HashMap::new(),
        scene: Scene::default(),
        bsdfs: HashMap::new(),
        textures: HashMap::new(),
        texture_cache: TextureCache::default(),
    };
    loader.scene.name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    loader.scene_element(doc.root_element())?;
    Ok(loader.scene)
}

/// A BSDF's glimpse material (its emission is zero; shapes add theirs).
#[derive(Clone)]
struct BsdfDef {
    material: Material,
    /// The reflectance is the mesh's `vertex_color` attribute (a `mesh_attribute` texture): the
    /// base colour is 1 and the mesh's vertex colours multiply it. Otherwise Mitsuba ignores a
    /// mesh's colours, and so does the loader.
    vertex_colors: bool,
}

struct Loader<'a, 'input> {
    path: &'a Path,
    dir: PathBuf,
    doc: &'a Document<'input>,
    defaults: HashMap<String, String>,
    scene: Scene,
    /// Top-level BSDFs by id, and the material index once a shape used one.
    bsdfs: HashMap<String, (BsdfDef, Option<u32>)>,
    /// Top-level textures by id: index into `scene.textures`.
    textures: HashMap<String, u32>,
    texture_cache: TextureCache,
}

/// The element children of `node` (comments and text skipped).
fn elements<'a, 'i>(node: Node<'a, 'i>) -> impl Iterator<Item = Node<'a, 'i>> {
    node.children().filter(Node::is_element)
}

impl<'a, 'input> Loader<'a, 'input> {
    // ---- errors ------------------------------------------------------------------------------

    fn line(&self, node: Node) -> u32 {
        self.doc.text_pos_at(node.range().start).row
    }

    /// `<tag type='…' name='…'>` as written, to name the element in errors.
    fn describe(&self, node: Node) -> String {
        let mut s = format!("<{}", node.tag_name().name());
        for a in ["type", "name", "id"] {
            if let Some(v) = node.attribute(a) {
                s += &format!(" {a}='{v}'");
            }
        }
        s + ">"
    }

    fn malformed(&self, node: Node, message: impl std::fmt::Display) -> SceneError {
        SceneError::parse(self.path, format!("line {}: {}: {message}", self.line(node), self.describe(node)))
    }

    fn unsupported(&self, node: Node, message: impl std::fmt::Display) -> SceneError {
        SceneError::Unsupported {
            path: self.path.to_owned(),
            message: format!("line {}: {}: {message}", self.line(node), self.describe(node)),
        }
    }

    /// A child this plugin does not read.
    fn unknown_child(&self, child: Node, parent: Node) -> SceneError {
        self.unsupported(
            child,
            format!("not supported inside {} (glimpse reads the subset listed in docs/scenes.md)", self.describe(parent)),
        )
    }

    fn warn(&mut self, node: Node, message: impl std::fmt::Display) {
        let w = format!("{}: line {}: {}: {message}", self.path.display(), self.line(node), self.describe(node));
        self.scene.warnings.push(w);
    }

    // ---- attributes and values ---------------------------------------------------------------

    /// Attribute `name` with `$default` references substituted.
    fn attr(&self, node: Node, name: &str) -> Result<Option<String>, SceneError> {
        let Some(raw) = node.attribute(name) else { return Ok(None) };
        let mut out = String::new();
        let mut rest = raw;
        while let Some(i) = rest.find('$') {
            out += &rest[..i];
            let tail = &rest[i + 1..];
            let len = tail.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(tail.len());
            let key = &tail[..len];
            let value = self
                .defaults
                .get(key)
                .ok_or_else(|| self.malformed(node, format!("attribute {name}='{raw}': no <default name=\"{key}\"> defines ${key}")))?;
            out += value;
            rest = &tail[len..];
        }
        out += rest;
        Ok(Some(out))
    }

    fn required(&self, node: Node, name: &str) -> Result<String, SceneError> {
        self.attr(node, name)?.ok_or_else(|| self.malformed(node, format!("needs a '{name}' attribute")))
    }

    fn numbers(&self, node: Node, attr: &str, text: &str) -> Result<Vec<f32>, SceneError> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| {
                s.parse::<f32>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| self.malformed(node, format!("{attr}='{text}': '{s}' is not a finite number")))
            })
            .collect()
    }

    fn float(&self, node: Node) -> Result<f32, SceneError> {
        let v = self.required(node, "value")?;
        match self.numbers(node, "value", &v)?.as_slice() {
            [x] => Ok(*x),
            _ => Err(self.malformed(node, format!("value='{v}' must be one number"))),
        }
    }

    fn integer(&self, node: Node) -> Result<i64, SceneError> {
        let v = self.required(node, "value")?;
        v.trim().parse().map_err(|_| self.malformed(node, format!("value='{v}' is not an integer")))
    }

    fn boolean(&self, node: Node) -> Result<bool, SceneError> {
        match self.required(node, "value")?.trim() {
            "true" => Ok(true),
            "false" => Ok(false),
            v => Err(self.malformed(node, format!("value='{v}' must be true or false"))),
        }
    }

    fn vec3_text(&self, node: Node, attr: &str, text: &str) -> Result<Vec3, SceneError> {
        match self.numbers(node, attr, text)?.as_slice() {
            [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
            _ => Err(self.malformed(node, format!("{attr}='{text}' must be three numbers"))),
        }
    }

    /// `x`, `y`, `z` attributes (missing ones `default`) or `value="x, y, z"`.
    fn xyz(&self, node: Node, default: f32) -> Result<Vec3, SceneError> {
        if let Some(v) = self.attr(node, "value")? {
            return match self.numbers(node, "value", &v)?.as_slice() {
                [s] => Ok(Vec3::splat(*s)),
                [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
                _ => Err(self.malformed(node, format!("value='{v}' must be one or three numbers"))),
            };
        }
        let mut out = [default; 3];
        for (i, a) in ["x", "y", "z"].iter().enumerate() {
            if let Some(v) = self.attr(node, a)? {
                out[i] = match self.numbers(node, a, &v)?.as_slice() {
                    [x] => *x,
                    _ => return Err(self.malformed(node, format!("{a}='{v}' must be one number"))),
                };
            }
        }
        Ok(Vec3::from_array(out))
    }

    /// An RGB colour from `<rgb>`, a one-value `<spectrum>` or a `<float>`.
    fn color(&self, node: Node) -> Result<Vec3, SceneError> {
        match node.tag_name().name() {
            "rgb" => {
                let v = self.required(node, "value")?;
                match self.numbers(node, "value", &v)?.as_slice() {
                    [s] => Ok(Vec3::splat(*s)),
                    [r, g, b] => Ok(Vec3::new(*r, *g, *b)),
                    _ => Err(self.malformed(node, format!("value='{v}' must be one or three numbers"))),
                }
            }
            "spectrum" => {
                let v = self.required(node, "value")?;
                match self.numbers(node, "value", &v) {
                    Ok(n) if n.len() == 1 => Ok(Vec3::splat(n[0])),
                    _ => Err(self.unsupported(node, "only a constant spectrum (one value) is supported; give an <rgb>")),
                }
            }
            "float" => Ok(Vec3::splat(self.float(node)?)),
            _ => Err(self.unsupported(node, "expected an <rgb>, <spectrum> or <float> colour")),
        }
    }

    /// A colour or a texture: (factor, texture index).
    fn color_or_texture(&mut self, node: Node) -> Result<(Vec3, Option<u32>), SceneError> {
        match node.tag_name().name() {
            "texture" => Ok((Vec3::ONE, Some(self.texture(node)?))),
            "ref" => {
                let id = self.required(node, "id")?;
                match self.textures.get(&id) {
                    Some(&t) => Ok((Vec3::ONE, Some(t))),
                    None => Err(self.malformed(node, format!("no <texture id=\"{id}\"> is defined before this reference"))),
                }
            }
            _ => Ok((self.color(node)?, None)),
        }
    }

    /// Whether `node` is a `mesh_attribute` texture reading the mesh's vertex colours (the one
    /// attribute supported: `vertex_color`).
    fn is_vertex_color(&self, node: Node) -> Result<bool, SceneError> {
        if node.tag_name().name() != "texture" || self.required(node, "type")? != "mesh_attribute" {
            return Ok(false);
        }
        for c in elements(node) {
            match (c.tag_name().name(), self.attr(c, "name")?.as_deref()) {
                ("string", Some("name")) if self.required(c, "value")? == "vertex_color" => {}
                ("string", Some("name")) => return Err(self.unsupported(c, "mesh_attribute: only 'vertex_color' is supported")),
                _ => return Err(self.unknown_child(c, node)),
            }
        }
        Ok(true)
    }

    /// A file path attribute resolved against the scene's folder; the file must exist.
    fn file(&self, node: Node) -> Result<PathBuf, SceneError> {
        let name = self.required(node, "value")?;
        let file = self.dir.join(&name);
        if !file.is_file() {
            return Err(SceneError::Io {
                path: file.clone(),
                message: format!(
                    "file not found (referenced by {} line {}: {})",
                    self.path.display(),
                    self.line(node),
                    self.describe(node)
                ),
            });
        }
        Ok(file)
    }

    // ---- transforms --------------------------------------------------------------------------

    /// A `<transform>`: its operations applied in document order (each one after the previous).
    fn transform(&self, node: Node) -> Result<Mat4, SceneError> {
        let mut m = Mat4::IDENTITY;
        for op in elements(node) {
            let step = match op.tag_name().name() {
                "translate" => Mat4::from_translation(self.xyz(op, 0.0)?),
                "scale" => Mat4::from_scale(self.xyz(op, 1.0)?),
                "rotate" => {
                    let axis = self.xyz(op, 0.0)?;
                    let angle: f32 =
                        self.required(op, "angle")?.trim().parse().map_err(|_| self.malformed(op, "angle must be a number"))?;
                    if axis.length_squared() == 0.0 {
                        return Err(self.malformed(op, "the rotation axis is zero"));
                    }
                    Mat4::from_axis_angle(axis.normalize(), angle.to_radians())
                }
                "matrix" => {
                    let v = self.required(op, "value")?;
                    let n = self.numbers(op, "value", &v)?;
                    match n.len() {
                        // Row-major in the file; glam is column-major.
                        16 => Mat4::from_cols_array(&n.try_into().expect("16 numbers")).transpose(),
                        9 => {
                            let r = |i: usize| Vec3::new(n[i], n[3 + i], n[6 + i]);
                            Mat4::from_cols(r(0).extend(0.0), r(1).extend(0.0), r(2).extend(0.0), Vec3::ZERO.extend(1.0))
                        }
                        k => return Err(self.malformed(op, format!("a matrix has 9 or 16 numbers, not {k}"))),
                    }
                }
                "lookat" => {
                    let origin = self.vec3_text(op, "origin", &self.required(op, "origin")?)?;
                    let target = self.vec3_text(op, "target", &self.required(op, "target")?)?;
                    let up = match self.attr(op, "up")? {
                        Some(u) => self.vec3_text(op, "up", &u)?,
                        None => Vec3::Y,
                    };
                    let dir = (target - origin).normalize_or_zero();
                    let left = up.cross(dir).normalize_or_zero();
                    if dir == Vec3::ZERO || left == Vec3::ZERO {
                        return Err(self.malformed(op, "origin equals target, or up is parallel to the view direction"));
                    }
                    Mat4::from_cols(left.extend(0.0), dir.cross(left).extend(0.0), dir.extend(0.0), origin.extend(1.0))
                }
                _ => return Err(self.unknown_child(op, node)),
            };
            m = step * m;
        }
        if !m.is_finite() || m.determinant().abs() < 1e-20 {
            return Err(self.malformed(node, "the transform is singular or not finite"));
        }
        Ok(m)
    }

    /// Checks that a `<transform>` is named `to_world` and reads it.
    fn to_world(&self, node: Node) -> Result<Mat4, SceneError> {
        match self.attr(node, "name")?.as_deref() {
            Some("to_world") => self.transform(node),
            _ => Err(self.unsupported(node, "only name=\"to_world\" transforms are supported")),
        }
    }

    // ---- the scene ---------------------------------------------------------------------------

    fn scene_element(&mut self, root: Node) -> Result<(), SceneError> {
        if root.tag_name().name() != "scene" {
            return Err(self.malformed(root, "the root element must be <scene>"));
        }
        let version = root.attribute("version").unwrap_or("");
        if !version.starts_with('3') {
            return Err(self.unsupported(root, format!("version '{version}': only Mitsuba 3 scenes (version=\"3.x\") are read")));
        }
        // Defaults first: Mitsuba applies them wherever they appear at the top level.
        for c in elements(root).filter(|c| c.tag_name().name() == "default") {
            let name = self.required(c, "name")?;
            let value = self.required(c, "value")?;
            self.defaults.entry(name).or_insert(value);
        }
        let mut sensor_seen = false;
        for c in elements(root) {
            match c.tag_name().name() {
                "default" => {}
                "integrator" => self.integrator(c)?,
                "sensor" => {
                    if sensor_seen {
                        return Err(self.unsupported(c, "only one sensor is supported"));
                    }
                    sensor_seen = true;
                    self.sensor(c)?;
                }
                "bsdf" => {
                    let id = self.required(c, "id")?;
                    let def = self.bsdf(c)?;
                    self.bsdfs.insert(id, (def, None));
                }
                "texture" => {
                    let id = self.required(c, "id")?;
                    let t = self.texture(c)?;
                    self.textures.insert(id, t);
                }
                "shape" => self.shape(c)?,
                "emitter" => self.emitter(c)?,
                _ => return Err(self.unknown_child(c, root)),
            }
        }
        Ok(())
    }

    fn integrator(&mut self, node: Node) -> Result<(), SceneError> {
        let kind = self.required(node, "type")?;
        if kind != "path" {
            return Err(self.unsupported(node, format!("integrator '{kind}' (only 'path' is supported)")));
        }
        for c in elements(node) {
            match (c.tag_name().name(), self.attr(c, "name")?.as_deref()) {
                ("integer", Some("max_depth")) => {
                    let d = self.integer(c)?;
                    self.scene.render_hints.max_depth = Some(match d {
                        -1 => -1,
                        // Mitsuba counts segments (1: emitters seen directly); glimpse counts
                        // scattering vertices, so one less.
                        2..=1025 => (d - 1) as i32,
                        _ => return Err(self.unsupported(c, format!("max_depth {d}: glimpse needs -1 or 2..=1025"))),
                    });
                }
                // Russian roulette changes noise, not the expected image.
                ("integer", Some("rr_depth")) => {
                    self.integer(c)?;
                }
                ("boolean", Some("hide_emitters")) => {
                    if self.boolean(c)? {
                        return Err(self.unsupported(c, "hide_emitters=true is not supported"));
                    }
                }
                _ => return Err(self.unknown_child(c, node)),
            }
        }
        Ok(())
    }

    fn sensor(&mut self, node: Node) -> Result<(), SceneError> {
        let kind = self.required(node, "type")?;
        if kind != "perspective" {
            return Err(self.unsupported(node, format!("sensor '{kind}' (only 'perspective' is supported)")));
        }
        let (mut fov, mut axis, mut to_world) = (None, "x".to_owned(), Mat4::IDENTITY);
        let mut size = (768u32, 576u32); // Mitsuba's hdrfilm default
        for c in elements(node) {
            match (c.tag_name().name(), self.attr(c, "name")?.as_deref()) {
                ("float", Some("fov")) => fov = Some((self.float(c)?, None)),
                ("string", Some("focal_length")) => {
                    let v = self.required(c, "value")?;
                    let mm: f32 =
                        v.trim().trim_end_matches("mm").parse().map_err(|_| self.malformed(c, "focal_length must look like '50mm'"))?;
                    // 35 mm film: the diagonal of 36 × 24 mm, as Mitsuba converts it.
                    fov = Some(((2.0 * (36f32.hypot(24.0) / (2.0 * mm)).atan()).to_degrees(), Some("diagonal")));
                }
                ("string", Some("fov_axis")) => axis = self.required(c, "value")?,
                ("transform", _) => to_world = self.to_world(c)?,
                // A pinhole: clip planes and focus do not change the image of a closed scene.
                ("float", Some("near_clip" | "far_clip" | "focus_distance")) => {
                    self.float(c)?;
                }
                ("sampler", _) => self.sampler(c)?,
                ("film", _) => size = self.film(c)?,
                _ => return Err(self.unknown_child(c, node)),
            }
        }
        let (fov, forced_axis) = fov.unwrap_or(((2.0 * (36f32.hypot(24.0) / 100.0).atan()).to_degrees(), Some("diagonal")));
        let axis = forced_axis.map(str::to_owned).unwrap_or(axis);
        let (w, h) = (size.0 as f32, size.1 as f32);
        let tan_half = (fov.to_radians() * 0.5).tan();
        // glimpse's camera takes a vertical fov; convert at the film's aspect ratio.
        let tan_half_y = match axis.as_str() {
            "y" => tan_half,
            "x" => tan_half * h / w,
            "diagonal" => tan_half * h / w.hypot(h),
            "smaller" if w <= h => tan_half * h / w,
            "smaller" => tan_half,
            "larger" if w >= h => tan_half * h / w,
            "larger" => tan_half,
            other => return Err(self.malformed(node, format!("fov_axis '{other}' (x, y, diagonal, smaller or larger)"))),
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(self.malformed(node, format!("fov {fov} must lie in (0, 180) degrees")));
        }
        self.scene.camera = Some(self.camera(node, to_world, 2.0 * tan_half_y.atan())?);
        if axis != "y" && size.0 != size.1 {
            self.warn(
                node,
                format!(
                    "fov_axis '{axis}' converted to a vertical fov at the film's {}x{}: other image shapes see a different view",
                    size.0, size.1
                ),
            );
        }
        Ok(())
    }

    /// Mitsuba's camera looks along local +z with +y up and +x to the image's left.
    fn camera(&self, node: Node, m: Mat4, fov_y: f32) -> Result<Camera, SceneError> {
        let position = m.transform_point3(Vec3::ZERO);
        let forward = m.transform_vector3(Vec3::Z).normalize();
        let up = m.transform_vector3(Vec3::Y).normalize();
        let left = m.transform_vector3(Vec3::X);
        if left.dot(up.cross(forward)) <= 0.0 {
            return Err(self.unsupported(node, "a mirrored camera transform (negative scale) is not supported"));
        }
        Ok(Camera::vertical(position, position + forward, up, fov_y))
    }

    fn sampler(&mut self, node: Node) -> Result<(), SceneError> {
        let kind = self.required(node, "type")?;
        if kind != "independent" {
            return Err(self.unsupported(node, format!("sampler '{kind}' (only 'independent' is supported)")));
        }
        for c in elements(node) {
            match (c.tag_name().name(), self.attr(c, "name")?.as_deref()) {
                ("integer", Some("sample_count")) => {
                    let n = self.integer(c)?;
                    if !(1..=1 << 20).contains(&n) {
                        return Err(self.malformed(c, format!("sample_count {n} must lie in 1..=1048576")));
                    }
                    self.scene.render_hints.spp = Some(n as u32);
                }
                // glimpse's own --seed chooses the random numbers.
                ("integer", Some("seed")) => {
                    self.integer(c)?;
                }
                _ => return Err(self.unknown_child(c, node)),
            }
        }
        Ok(())
    }

    fn film(&mut self, node: Node) -> Result<(u32, u32), SceneError> {
        let kind = self.required(node, "type")?;
        if kind != "hdrfilm" {
            return Err(self.unsupported(node, format!("film '{kind}' (only 'hdrfilm' is supported)")));
        }
        let (mut w, mut h) = (768i64, 576i64);
        // Mitsuba 3's film filters with a Gaussian unless told otherwise.
        let mut rfilter = None;
        for c in elements(node) {
            match (c.tag_name().name(), self.attr(c, "name")?.as_deref()) {
                ("integer", Some("width")) => w = self.integer(c)?,
                ("integer", Some("height")) => h = self.integer(c)?,
                ("rfilter", _) => rfilter = Some(self.rfilter(c)?),
                // The storage format of Mitsuba's output file, not the image.
                ("string", Some("pixel_format" | "component_format" | "file_format")) => {
                    self.required(c, "value")?;
                }
                _ => return Err(self.unknown_child(c, node)),
            }
        }
        if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
            return Err(self.malformed(node, format!("film size {w}x{h}: each side must lie in 1..=16384")));
        }
        self.scene.render_hints.size = Some((w as u32, h as u32));
        let filter = rfilter.unwrap_or_else(|| "gaussian".to_owned());
        self.scene.film.filter = crate::Filter::parse(&filter).expect("rfilter() accepts only glimpse's filters");
        self.scene.render_hints.filter = Some(filter);
        Ok((w as u32, h as u32))
    }

    /// The filter's name; only Mitsuba's default widths (tent radius 1, gaussian σ 0.5).
    fn rfilter(&self, node: Node) -> Result<String, SceneError> {
        let kind = self.required(node, "type")?;
        if !matches!(kind.as_str(), "box" | "tent" | "gaussian") {
            return Err(self.unsupported(node, format!("rfilter '{kind}' (box, tent or gaussian)")));
        }
        for c in elements(node) {
            let name = self.attr(c, "name")?;
            let ok = match (kind.as_str(), c.tag_name().name(), name.as_deref()) {
                ("tent", "float", Some("radius")) => self.float(c)? == 1.0,
                ("gaussian", "float", Some("stddev")) => self.float(c)? == 0.5,
                ("box", "float", Some("radius")) => self.float(c)? == 0.5,
                _ => return Err(self.unknown_child(c, node)),
            };
            if !ok {
                return Err(self.unsupported(c, "only Mitsuba's default filter width is supported"));
            }
        }
        Ok(kind)
    }

    // ---- materials ---------------------------------------------------------------------------

    fn texture(&mut self, node: Node) -> Result<u32, SceneError> {
        let kind = self.required(node, "type")?;
        if kind != "bitmap" {
            return Err(self.unsupported(node, format!("texture '{kind}' (only 'bitmap' is supported)")));
        }
        let (mut file, mut raw) = (None, false);
        for c in elements(node) {
            match (c.tag_name().name(), self.attr(c, "name")?.as_deref()) {
                ("string", Some("filename")) => file = Some(self.file(c)?),
                ("string", Some("filter_type")) if self.required(c, "value")? == "bilinear" => {}
                ("string", Some("wrap_mode")) if self.required(c, "value")? == "repeat" => {}
                // Raw: 8-bit values taken as they are (a normal map), not sRGB-decoded.
                ("boolean", Some("raw")) => raw = self.boolean(c)?,
                _ => return Err(self.unknown_child(c, node)),
            }
        }
        let file = file.ok_or_else(|| self.malformed(node, "needs <string name=\"filename\">"))?;
        let path = self.path.to_owned();
        let before = self.scene.warnings.len();
        let how = if raw { TextureRead::Raw } else { TextureRead::Colour };
        let id = self.texture_cache.load_as(&file, how, &mut self.scene, &path);
        // A texture that does not load is an error here (Mitsuba refuses the scene too).
        id.ok_or_else(|| {
            let why = self.scene.warnings.get(before).cloned().unwrap_or_default();
            SceneError::Io { path: file.clone(), message: format!("texture not loaded (line {}: {why})", self.line(node)) }
        })
    }

    fn bsdf(&mut self, node: Node) -> Result<BsdfDef, SceneError> {
        let kind = self.required(node, "type")?;
        let name = self.attr(node, "id")?.unwrap_or_else(|| format!("{kind} (line {})", self.line(node)));
        let mut m = Material { name, ..Default::default() };
        let mut vertex_colors = false;
        match kind.as_str() {
            "twosided" => {
                // glimpse shades both sides of every surface already.
                let mut inner = elements(node);
                let (Some(b), None) = (inner.next(), inner.next()) else {
                    return Err(self.malformed(node, "twosided wraps exactly one <bsdf>"));
                };
                if b.tag_name().name() != "bsdf" {
                    return Err(self.unknown_child(b, node));
                }
                let mut def = self.bsdf(b)?;
                def.material.name = m.name;
                return Ok(def);
            }
            "normalmap" => {
                // Mitsuba's normal map: a raw bitmap's tangent-space normal in the frame of
                // dp/du and the shading normal, around one nested BSDF ([`NormalMap`]).
                let (mut texture, mut inner) = (None, None);
                for c in elements(node) {
                    match (c.tag_name().name(), self.attr(c, "name")?.as_deref()) {
                        ("texture", Some("normalmap")) => texture = Some(self.texture(c)?),
                        ("bsdf", _) if inner.is_none() => inner = Some(c),
                        _ => return Err(self.unknown_child(c, node)),
                    }
                }
                let (Some(texture), Some(inner)) = (texture, inner) else {
                    return Err(self.malformed(node, "normalmap needs a <texture name=\"normalmap\"> and one <bsdf>"));
                };
                let mut def = self.bsdf(inner)?;
                def.material.name = m.name;
                def.material.normal_map = Some(NormalMap {
                    texture,
                    scale: 1.0,
                    bitangent: Bitangent::NormalCrossTangent,
                    shadowing: NormalMapShadowing::Microfacet,
                });
                return Ok(def);
            }
            "diffuse" => {
                m.base_color = Vec3::splat(0.5);
                m.roughness = 1.0;
                m.metallic = 0.0;
                for c in elements(node) {
                    match self.attr(c, "name")?.as_deref() {
                        Some("reflectance") if self.is_vertex_color(c)? => {
                            (m.base_color, vertex_colors) = (Vec3::ONE, true);
                        }
                        Some("reflectance") => (m.base_color, m.base_color_texture) = self.color_or_texture(c)?,
                        _ => return Err(self.unknown_child(c, node)),
                    }
                }
                m.set_lambertian();
            }
            "conductor" | "roughconductor" => {
                let mut alpha = if kind == "conductor" { 0.0 } else { 0.1 };
                let (mut eta, mut k, mut tint) = (Vec3::ZERO, Vec3::ONE, Vec3::ONE);
                for c in elements(node) {
                    match (c.tag_name().name(), self.attr(c, "name")?.as_deref()) {
                        ("string", Some("material")) => {
                            let preset = self.required(c, "value")?;
                            (eta, k) = conductor_preset(&preset).ok_or_else(|| {
                                self.unsupported(c, format!("conductor material '{preset}' (known: {})", CONDUCTOR_NAMES.join(", ")))
                            })?;
                        }
                        (_, Some("eta")) => eta = self.color(c)?,
                        (_, Some("k")) => k = self.color(c)?,
                        (_, Some("specular_reflectance")) => tint = self.color(c)?,
                        ("string", Some("distribution")) if kind == "roughconductor" => {
                            let d = self.required(c, "value")?;
                            if d != "ggx" {
                                return Err(self.unsupported(c, format!("distribution '{d}' (only 'ggx')")));
                            }
                        }
                        ("float", Some("alpha")) if kind == "roughconductor" => alpha = self.float(c)?,
                        ("boolean", Some("sample_visible")) if kind == "roughconductor" => {
                            self.boolean(c)?;
                        }
                        _ => return Err(self.unknown_child(c, node)),
                    }
                }
                if kind == "roughconductor" && node.attribute("distribution").is_none() && !has_child(node, "distribution") {
                    // Mitsuba 3's default distribution is Beckmann; glimpse only has GGX.
                    return Err(self.unsupported(node, "roughconductor without <string name=\"distribution\" value=\"ggx\"> is Beckmann in Mitsuba 3; only GGX is supported"));
                }
                if !(0.0..=1.0).contains(&alpha) {
                    return Err(self.malformed(node, format!("alpha {alpha} must lie in [0, 1]")));
                }
                m.set_conductor(tint, eta, k, alpha);
            }
            "dielectric" => {
                let (mut int_ior, mut ext_ior) = (1.5046f32, 1.000277f32); // BK7 in air: Mitsuba's defaults
                for c in elements(node) {
                    match (c.tag_name().name(), self.attr(c, "name")?.as_deref()) {
                        (_, Some(which @ ("int_ior" | "ext_ior"))) => {
                            let v = match c.tag_name().name() {
                                "float" => self.float(c)?,
                                "string" => {
                                    let n = self.required(c, "value")?;
                                    ior_preset(&n)
                                        .ok_or_else(|| self.unsupported(c, format!("IOR name '{n}' (known: {})", IOR_NAMES.join(", "))))?
                                }
                                _ => return Err(self.unknown_child(c, node)),
                            };
                            if which == "int_ior" { int_ior = v } else { ext_ior = v }
                        }
                        _ => return Err(self.unknown_child(c, node)),
                    }
                }
                if !(int_ior > 0.0 && ext_ior > 0.0) {
                    return Err(self.malformed(node, "IORs must be positive"));
                }
                m.set_dielectric(int_ior / ext_ior);
            }
            _ => {
                return Err(
                    self.unsupported(node, format!("BSDF '{kind}' (supported: diffuse, conductor, roughconductor, dielectric, twosided)"))
                );
            }
        }
        Ok(BsdfDef { material: m, vertex_colors })
    }

    // ---- shapes and emitters ---------------------------------------------------------------------

    fn shape(&mut self, node: Node) -> Result<(), SceneError> {
        let kind = self.required(node, "type")?;
        let mut to_world = Mat4::IDENTITY;
        let (mut file, mut face_normals) = (None, false);
        let (mut center, mut radius) = (Vec3::ZERO, 1.0f32);
        let mut bsdf: Option<(BsdfDef, Option<String>)> = None;
        let mut emission = None;
        for c in elements(node) {
            let name = self.attr(c, "name")?;
            match (c.tag_name().name(), name.as_deref()) {
                ("transform", _) => to_world = self.to_world(c)?,
                ("string", Some("filename")) if matches!(kind.as_str(), "obj" | "ply") => file = Some(self.file(c)?),
                ("boolean", Some("face_normals")) if matches!(kind.as_str(), "obj" | "ply") => face_normals = self.boolean(c)?,
                ("boolean", Some("flip_tex_coords")) if kind == "obj" => {
                    // glimpse's OBJ loader flips v as Mitsuba does by default.
                    if !self.boolean(c)? {
                        return Err(self.unsupported(c, "flip_tex_coords=false is not supported"));
                    }
                }
                ("boolean", Some("flip_normals")) => {
                    if self.boolean(c)? {
                        return Err(self.unsupported(c, "flip_normals=true is not supported"));
                    }
                }
                ("point", Some("center")) if kind == "sphere" => center = self.xyz(c, 0.0)?,
                ("float", Some("radius")) if kind == "sphere" => radius = self.float(c)?,
                ("bsdf", _) => bsdf = Some((self.bsdf(c)?, None)),
                ("ref", _) => {
                    let id = self.required(c, "id")?;
                    let def = self.bsdfs.get(&id).map(|(d, _)| d.clone());
                    let def = def.ok_or_else(|| self.malformed(c, format!("no <bsdf id=\"{id}\"> is defined before this reference")))?;
                    bsdf = Some((def, Some(id)));
                }
                ("emitter", _) => {
                    let et = self.required(c, "type")?;
                    if et != "area" {
                        return Err(self.unsupported(c, format!("emitter '{et}' inside a shape (only 'area')")));
                    }
                    let mut radiance = (Vec3::ONE, None);
                    for r in elements(c) {
                        match self.attr(r, "name")?.as_deref() {
                            // A bitmap: the radiance per texel ([`EmissionMap`]).
                            Some("radiance") => radiance = self.color_or_texture(r)?,
                            _ => return Err(self.unknown_child(r, c)),
                        }
                    }
                    emission = Some(radiance);
                }
                _ => return Err(self.unknown_child(c, node)),
            }
        }
        let vertex_colors = bsdf.as_ref().is_some_and(|(def, _)| def.vertex_colors);
        if vertex_colors && kind != "ply" {
            return Err(
                self.unsupported(node, format!("a 'vertex_color' reflectance on a '{kind}' shape (only PLY files carry vertex colours)"))
            );
        }
        let material = self.shape_material(bsdf, emission, &kind, node);
        let label = self.attr(node, "id")?.unwrap_or_else(|| format!("{kind} (line {})", self.line(node)));
        let meshes = match kind.as_str() {
            "obj" => {
                let file = file.ok_or_else(|| self.malformed(node, "needs <string name=\"filename\">"))?;
                let sub = crate::obj_loader::load(&file).map_err(|e| crate::toml_loader::referenced_by(e, &self.where_(node)))?;
                self.scene.warnings.extend(sub.warnings);
                let mut out = Vec::new();
                for inst in &sub.instances {
                    let mut mesh = sub.meshes[inst.mesh as usize].clone();
                    transform_mesh(&mut mesh, inst.motion.at(0.0));
                    out.push(mesh);
                }
                out
            }
            "ply" => {
                let file = file.ok_or_else(|| self.malformed(node, "needs <string name=\"filename\">"))?;
                let mesh = crate::ply_loader::load_mesh_with(&file, 0, PlyColors::Mitsuba)
                    .map_err(|e| crate::toml_loader::referenced_by(e, &self.where_(node)))?;
                if vertex_colors && mesh.colors.is_empty() {
                    return Err(self.malformed(node, "its reflectance reads 'vertex_color', but the PLY file has no red/green/blue"));
                }
                if vertex_colors && mesh.colors.iter().any(|c| c.max_element() > 1.0) {
                    // Mitsuba 3.9.1 reads 8-bit colours unscaled (and warns the same way).
                    self.scene.warnings.push(format!(
                        "{}: vertex colours above 1 (integer colours are read unscaled, as Mitsuba does)",
                        self.where_(node)
                    ));
                }
                vec![mesh]
            }
            "rectangle" => vec![rectangle_mesh(&label)],
            "cube" => vec![box_mesh(&label, 0, Vec3::ONE)],
            "sphere" => {
                if radius <= 0.0 {
                    return Err(self.malformed(node, format!("radius {radius} must be positive")));
                }
                let mut m = sphere_mesh(&label, 0, SPHERE_SEGMENTS / 2, SPHERE_SEGMENTS);
                m.positions.iter_mut().for_each(|p| *p = center + *p * radius);
                vec![m]
            }
            _ => {
                return Err(self.unsupported(node, format!("shape '{kind}' (supported: obj, ply, rectangle, cube, sphere)")));
            }
        };
        for mut mesh in meshes {
            mesh.material = material;
            if !vertex_colors {
                mesh.colors.clear();
            }
            if face_normals {
                mesh.normals.clear();
            }
            if mesh.name.is_empty() {
                mesh.name = label.clone();
            }
            self.scene.add_mesh(mesh, to_world);
        }
        Ok(())
    }

    fn where_(&self, node: Node) -> String {
        format!("{} line {}", self.path.display(), self.line(node))
    }

    /// The shape's material index: a referenced BSDF's shared one, or a new one (inline BSDFs,
    /// emitters, Mitsuba's default diffuse 0.5).
    fn shape_material(
        &mut self,
        bsdf: Option<(BsdfDef, Option<String>)>,
        emission: Option<(Vec3, Option<u32>)>,
        kind: &str,
        node: Node,
    ) -> u32 {
        let (def, id) = bsdf.unwrap_or_else(|| {
            let mut m =
                Material { name: format!("{kind} (line {}) default", self.line(node)), base_color: Vec3::splat(0.5), ..Default::default() };
            m.set_lambertian();
            (BsdfDef { material: m, vertex_colors: false }, None)
        });
        if let Some((e, texture)) = emission {
            let mut m = def.material;
            // A bitmap's material emission is its mean (the light selection's weight).
            m.emission = texture.map_or(e, |t| e * self.scene.textures[t as usize].mean());
            m.emission_map = texture.map(|texture| EmissionMap { texture, factor: e });
            return self.scene.add_material(m);
        }
        match id {
            Some(id) => {
                if let Some(&(_, Some(index))) = self.bsdfs.get(&id) {
                    return index;
                }
                let index = self.scene.add_material(def.material.clone());
                self.bsdfs.insert(id, (def, Some(index)));
                index
            }
            None => self.scene.add_material(def.material),
        }
    }

    fn emitter(&mut self, node: Node) -> Result<(), SceneError> {
        let kind = self.required(node, "type")?;
        let mut to_world = None;
        let mut props: HashMap<String, Node> = HashMap::new();
        let allowed: &[&str] = match kind.as_str() {
            "point" => &["intensity", "position"],
            "spot" => &["intensity", "cutoff_angle", "beam_width"],
            "directional" => &["irradiance", "direction"],
            "envmap" => &["filename", "scale"],
            "constant" => &["radiance"],
            "area" => return Err(self.unsupported(node, "an area emitter belongs inside a <shape>")),
            _ => {
                return Err(
                    self.unsupported(node, format!("emitter '{kind}' (supported: area, point, spot, directional, envmap, constant)"))
                );
            }
        };
        for c in elements(node) {
            let name = self.attr(c, "name")?;
            match (c.tag_name().name(), name) {
                ("transform", _) if kind != "constant" => to_world = Some(self.to_world(c)?),
                (_, Some(n)) if allowed.contains(&n.as_str()) => {
                    props.insert(n, c);
                }
                _ => return Err(self.unknown_child(c, node)),
            }
        }
        let m = to_world.unwrap_or(Mat4::IDENTITY);
        let color = |s: &Self, key: &str, default: Vec3| props.get(key).map_or(Ok(default), |&c| s.color(c));
        let angle = |s: &Self, key: &str| props.get(key).map(|&c| s.float(c)).transpose();
        match kind.as_str() {
            "point" => {
                let position = match props.get("position") {
                    Some(&c) if to_world.is_some() => return Err(self.malformed(c, "give either position or to_world, not both")),
                    Some(&c) => self.xyz(c, 0.0)?,
                    None => m.transform_point3(Vec3::ZERO),
                };
                self.scene.lights.push(Light::point(position, color(self, "intensity", Vec3::ONE)?));
            }
            "spot" => {
                let cutoff = angle(self, "cutoff_angle")?.unwrap_or(20.0);
                let beam = angle(self, "beam_width")?.unwrap_or(cutoff * 0.75);
                if !(cutoff > 0.0 && cutoff <= 90.0 && beam > 0.0 && beam <= cutoff) {
                    return Err(self
                        .malformed(node, format!("cutoff_angle {cutoff} and beam_width {beam}: need 0 < beam_width ≤ cutoff_angle ≤ 90")));
                }
                if beam < cutoff {
                    // Mitsuba falls off linearly in angle, glTF (glimpse) quadratically in cosine.
                    self.warn(
                        node,
                        "the spot's falloff between beam_width and cutoff_angle follows glTF's curve, not Mitsuba's linear one",
                    );
                }
                let direction = m.transform_vector3(Vec3::Z);
                let light = Light::spot(
                    m.transform_point3(Vec3::ZERO),
                    direction,
                    color(self, "intensity", Vec3::ONE)?,
                    beam.to_radians(),
                    cutoff.to_radians(),
                );
                self.scene.lights.push(light);
            }
            "directional" => {
                let direction = match props.get("direction") {
                    Some(&c) if to_world.is_some() => return Err(self.malformed(c, "give either direction or to_world, not both")),
                    Some(&c) => self.xyz(c, 0.0)?,
                    None => m.transform_vector3(Vec3::Z),
                };
                if direction.length_squared() == 0.0 {
                    return Err(self.malformed(node, "the direction is zero"));
                }
                self.scene.lights.push(Light::directional(direction, color(self, "irradiance", Vec3::ONE)?));
            }
            "envmap" => {
                let c = *props.get("filename").ok_or_else(|| self.malformed(node, "needs <string name=\"filename\">"))?;
                let file = self.file(c)?;
                let image = Image::read(&file).map_err(|e| SceneError::Io {
                    path: file.clone(),
                    message: format!("environment map not loaded ({e}; referenced by {})", self.where_(node)),
                })?;
                let scale = angle(self, "scale")?.unwrap_or(1.0);
                self.set_environment(node, Environment::new(mitsuba_envmap(&image, m), scale))?;
            }
            "constant" => {
                let env = Environment::constant(color(self, "radiance", Vec3::ONE)?);
                self.set_environment(node, env)?;
            }
            _ => unreachable!("kinds are checked above"),
        }
        Ok(())
    }

    fn set_environment(&mut self, node: Node, env: Environment) -> Result<(), SceneError> {
        if self.scene.environment.is_some() {
            return Err(self.unsupported(node, "a second envmap/constant emitter (glimpse has one environment)"));
        }
        self.scene.environment = Some(env);
        Ok(())
    }
}

fn has_child(node: Node, name: &str) -> bool {
    elements(node).any(|c| c.attribute("name") == Some(name))
}

/// Applies `m` to a mesh's positions and normals.
fn transform_mesh(mesh: &mut Mesh, m: Mat4) {
    if m == Mat4::IDENTITY {
        return;
    }
    let normal = m.inverse().transpose();
    mesh.positions.iter_mut().for_each(|p| *p = m.transform_point3(*p));
    mesh.normals.iter_mut().for_each(|n| *n = normal.transform_vector3(*n).normalize_or_zero());
}

/// Mitsuba's `rectangle`: [−1, 1]² in the z = 0 plane, facing +z, uv = (p + 1)/2 as Mitsuba's.
fn rectangle_mesh(name: &str) -> Mesh {
    Mesh {
        name: name.into(),
        positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)],
        normals: vec![Vec3::Z; 4],
        uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        ..Default::default()
    }
}

/// Resamples a Mitsuba equirectangular map (with its `to_world`) into glimpse's convention.
/// Mitsuba looks a world direction d up at local v = to_world⁻¹·d, u = atan2(v.x, −v.z)/2π,
/// v = acos(v.y)/π, its texel columns centred at (i + ½)/width but its rows at row/(height − 1)
/// (checked against Mitsuba 3.9's `envmap.eval`); glimpse's u has an extra half turn (see
/// [`Environment::dir_to_uv`]). With an identity `to_world` and an even width the columns are an
/// exact shift by half the width; rows are resampled (bilinear), a blur below one texel.
pub fn mitsuba_envmap(image: &Image, to_world: Mat4) -> Image {
    let inv = to_world.inverse();
    Image::from_fn(image.width, image.height, |x, y| {
        let uv = Vec2::new((x as f32 + 0.5) / image.width as f32, (y as f32 + 0.5) / image.height as f32);
        let d = inv.transform_vector3(Environment::uv_to_dir(uv)).normalize();
        let u = d.x.atan2(-d.z) / TAU;
        let v = d.y.clamp(-1.0, 1.0).acos() / PI;
        // Mitsuba's rows sit at v = row / (height − 1) (the first at the zenith, the last at the
        // nadir); glimpse's sampler puts them at (row + ½) / height.
        let h = image.height as f32;
        image.sample_bilinear(u - u.floor(), (v * (h - 1.0) + 0.5) / h, false)
    })
}

const IOR_NAMES: [&str; 8] = ["vacuum", "air", "water", "acrylic glass", "polypropylene", "bk7", "diamond", "fused quartz"];

/// Mitsuba's named IORs (its `ior.h` table, the ones scenes use).
fn ior_preset(name: &str) -> Option<f32> {
    Some(match name {
        "vacuum" => 1.0,
        "air" => 1.000277,
        "water" => 1.3330,
        "acrylic glass" => 1.49,
        "polypropylene" => 1.49,
        "bk7" => 1.5046,
        "diamond" => 2.419,
        "fused quartz" => 1.458,
        _ => return None,
    })
}

const CONDUCTOR_NAMES: [&str; 6] = ["none", "Ag", "Al", "Au", "Cu", "Cr"];

/// (η, k) per RGB channel of Mitsuba's conductor presets, at the wavelengths 650, 550 and 450 nm
/// of their spectral tables (Mitsuba's `scalar_rgb` integrates the spectra against the CIE
/// curves, so these agree only to a few percent). "none" is Mitsuba's perfect mirror.
fn conductor_preset(name: &str) -> Option<(Vec3, Vec3)> {
    let v = Vec3::new;
    Some(match name {
        "none" => (Vec3::ZERO, Vec3::ONE),
        "Ag" => (v(0.155, 0.129, 0.144), v(4.283, 3.352, 2.470)),
        "Al" => (v(1.659, 0.958, 0.618), v(8.062, 6.690, 5.474)),
        "Au" => (v(0.166, 0.433, 1.362), v(3.153, 2.389, 1.876)),
        "Cu" => (v(0.214, 1.040, 1.192), v(3.672, 2.581, 2.405)),
        "Cr" => (v(3.105, 3.179, 2.270), v(3.304, 3.330, 3.245)),
        _ => return None,
    })
}

/// How Mitsuba's BSDFs map onto glimpse's material model.
trait MitsubaMaterial {
    /// `diffuse`: a Lambertian surface with the base colour as albedo.
    fn set_lambertian(&mut self);
    /// `conductor`/`roughconductor`: a GGX metal with α = `alpha` (roughness = √α) whose
    /// normal-incidence reflectance is `tint` × the Fresnel reflectance of (η, k).
    fn set_conductor(&mut self, tint: Vec3, eta: Vec3, k: Vec3, alpha: f32);
    /// `dielectric`: smooth glass with relative IOR `eta`.
    fn set_dielectric(&mut self, eta: f32);
}

impl MitsubaMaterial for Material {
    fn set_lambertian(&mut self) {
        self.model = MaterialModel::Diffuse;
        self.roughness = 1.0;
        self.metallic = 0.0;
    }

    fn set_conductor(&mut self, tint: Vec3, eta: Vec3, k: Vec3, alpha: f32) {
        self.model = MaterialModel::Conductor { eta, k };
        self.base_color = tint;
        self.base_color_texture = None;
        self.roughness = alpha.sqrt();
    }

    fn set_dielectric(&mut self, eta: f32) {
        self.model = MaterialModel::Dielectric { ior: eta };
        self.base_color = Vec3::ONE;
        self.base_color_texture = None;
    }
}
