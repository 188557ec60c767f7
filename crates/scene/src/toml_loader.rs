//! `scene.toml`: a small format to place, light and animate OBJ/glTF files and simple shapes.
//! Paths are relative to the toml file. Every table rejects unknown keys (the error names the
//! key and its line). A full example, every key shown (all optional unless marked *):
//!
//! ```toml
//! name = "bunny on a table"          # default: the file's stem
//!
//! [camera]                           # default: a view framing the scene
//! position = [0.0, 1.0, 4.0]         # *
//! target = [0.0, 0.5, 0.0]           # *
//! up = [0.0, 1.0, 0.0]               # default +y
//! fov_degrees = 40.0                 # across the image along fov_axis; default 45
//! fov_axis = "y"                     # "x", "y" (default), "smaller" or "larger" image side
//! # fov_y_degrees = 40.0             # the older spelling of fov_degrees with fov_axis = "y"
//!
//! [film]
//! filter = "box"                     # pixel filter: "box" (default), "tent", "gaussian", "pixel-centre"
//! samples = 1                        # primary samples per pixel (each a pass of the technique)
//!
//! [environment]                      # exactly one of file, constant, sky
//! file = "studio.hdr"                # equirectangular .hdr/.exr/.png (+y up, centre looks along −z)
//! # constant = [0.2, 0.2, 0.2]       # the same radiance from everywhere
//! # sky = { sun_direction = [0.3, 0.8, 0.2], sun_radiance = 500.0, width = 512 }  # procedural
//! scale = 1.0                        # multiplies the radiance
//!
//! [[mesh]]                           # any number
//! file = "bunny.obj"                 # * .obj, .gltf or .glb
//! translate = [0.0, 0.0, 0.0]        # placement: object → world = translate · rotate · scale
//! rotate_y_degrees = 30.0            # or rotate = { axis = [1, 0, 0], degrees = -90 }
//! scale = 2.0                        # or [sx, sy, sz]
//! # matrix = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]  # instead of the three: 16 numbers, column-major (glTF)
//! material = { base_color = [0.8, 0.8, 0.8], base_color_texture = "fur.png", roughness = 0.5, metallic = 0.0, emission = [0.0, 0.0, 0.0], clearcoat = 0.0 }
//!                                    # overrides the given fields of every material of the file
//! # material = { roughness = 0.3, texture = { checker = { cells = 8, colors = [[0.1, 0.1, 0.1], [0.9, 0.9, 0.9]] } } }
//! #                                  # or texture = { noise = { cells = 8, octaves = 4, colors = [...], seed = 0 }, resolution = 512 }:
//! #                                  # a procedural base-colour texture over the mesh's uvs (crate::procedural)
//! # material = { model = "diffuse", base_color = [0.5, 0.5, 0.5] }      # Lambertian
//! # material = { model = "conductor", base_color = [0.9, 0.6, 0.3], roughness = 0.3, eta = [0.2, 0.9, 1.1], k = [3.9, 2.4, 2.2] }
//! # material = { model = "dielectric", ior = 1.5 }                      # smooth glass
//!                                    # model: "pbr" (default: metallic-roughness), "diffuse",
//!                                    # "conductor" (GGX; roughness default 0 = mirror; eta, k default
//!                                    # 0 and 1 = reflects base_color at every angle), "dielectric"
//!                                    # (smooth; ior default 1.5). conductor and dielectric take
//!                                    # base_color = [1, 1, 1] unless given; metallic and clearcoat
//!                                    # belong to pbr, ior to dielectric, eta and k to conductor
//! spin = { axis = [0, 1, 0], period_s = 4.0, center = [0, 0, 0], phase = 0.0 }
//!                                    # turns about the line through `center` (default: `translate`)
//!                                    # along `axis` (default +y), once per period; phase in turns
//! # keyframes = [{ time = 0.0, translate = [0, 0, 0] }, { time = 2.0, translate = [1, 0, 0], rotate_y_degrees = 90, scale = 1.0 }]
//!                                    # instead of the placement and spin: linear/slerp, held at the ends
//! wave = { amplitude = 0.01, wavelength = 0.1, period_s = 1.0, direction = [1, 0, 0], displacement = [0, 1, 0] }
//!                                    # vertex wave in the file's object space (see Deformation::Wave)
//!
//! [[quad]]                           # a size[0] × size[1] rectangle in the xz-plane facing +y, centred
//! size = [10.0, 10.0]                # default [1, 1]
//! divisions = [1, 1]                 # cells per side (more for a wave); default [1, 1]
//! material = { base_color = [0.5, 0.5, 0.5] }
//!                                    # + placement, spin or keyframes, wave as for [[mesh]]
//! [[box]]                            # centred; size = [x, y, z], default [1, 1, 1]; same extra keys
//! [[sphere]]                         # centred; radius = 1.0, segments = 64 (around; rings = half); same extra keys
//!
//! [[light]]
//! kind = "spot"                      # * "point", "spot" or "directional"
//! position = [0.0, 3.0, 0.0]         # * point and spot
//! direction = [0.0, -1.0, 0.0]       # * directional and spot (where the light travels); spot: or target
//! # target = [0.0, 0.0, 0.0]         # spot: aims the light at a point
//! color = [1.0, 0.9, 0.8]            # default white
//! intensity = 20.0                   # × color; W/sr for point and spot, W/m² for directional; default 1
//! inner_angle_degrees = 20.0         # spot: full intensity inside (default 0)
//! outer_angle_degrees = 30.0         # spot: dark outside (default 45, as glTF)
//! orbit = { center = [0, 0, 0], axis = [0, 1, 0], period_s = 8.0, phase = 0.0 }  # moves the light around
//! ```
//!
//! Choices: units are the renderer's (radiance W/(m²·sr), intensity W/sr, metres by convention);
//! a mesh file's own lights are kept (moved by the placement) and its camera is used when the
//! toml has none. Composing a file's own animation with a toml placement is exact for a fixed
//! placement (keys are composed; an orbit is moved); a toml animation over an animated file uses
//! the file's pose at time 0 (warning). Each referenced file is loaded by its own loader and
//! validated on its own, so its problems (errors and removed degenerate triangles) name it.

use crate::builtin::{box_mesh, plane_mesh, sphere_mesh};
use crate::obj_loader::TextureCache;
use crate::{
    Camera, Deformation, Environment, FovAxis, Light, Material, MaterialModel, Mesh, Motion, Scene, SceneError, Transform, TransformKey,
};
use glimpse_core::{Image, Mat4, Quat, Vec2, Vec3};
use serde::{Deserialize, Deserializer};
use std::path::{Path, PathBuf};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneDef {
    name: Option<String>,
    camera: Option<CameraDef>,
    environment: Option<EnvironmentDef>,
    #[serde(default)]
    mesh: Vec<MeshDef>,
    #[serde(default)]
    quad: Vec<QuadDef>,
    #[serde(default, rename = "box")]
    boxes: Vec<BoxDef>,
    #[serde(default)]
    sphere: Vec<SphereDef>,
    #[serde(default)]
    light: Vec<LightDef>,
    film: Option<FilmDef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilmDef {
    filter: Option<String>,
    samples: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDef {
    position: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov_degrees: Option<f32>,
    fov_axis: Option<String>,
    fov_y_degrees: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EnvironmentDef {
    file: Option<PathBuf>,
    constant: Option<[f32; 3]>,
    sky: Option<SkyDef>,
    scale: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SkyDef {
    sun_direction: [f32; 3],
    sun_radiance: f32,
    width: Option<u32>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct MaterialDef {
    model: Option<String>,
    ior: Option<f32>,
    eta: Option<[f32; 3]>,
    k: Option<[f32; 3]>,
    base_color: Option<[f32; 3]>,
    base_color_texture: Option<PathBuf>,
    /// A procedural base-colour texture (`crate::procedural`), instead of `base_color_texture`.
    texture: Option<crate::procedural::TextureDef>,
    roughness: Option<f32>,
    metallic: Option<f32>,
    emission: Option<[f32; 3]>,
    clearcoat: Option<f32>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct AxisAngle {
    axis: [f32; 3],
    degrees: f32,
}

/// `scale = 2.0` or `scale = [sx, sy, sz]`.
#[derive(Clone, Copy)]
struct Scale(Vec3);

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Uniform(f32),
            PerAxis([f32; 3]),
        }
        match Raw::deserialize(d) {
            Ok(Raw::Uniform(s)) => Ok(Scale(Vec3::splat(s))),
            Ok(Raw::PerAxis(v)) => Ok(Scale(Vec3::from_array(v))),
            Err(_) => Err(serde::de::Error::custom("scale must be a number or [x, y, z]")),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpinDef {
    axis: Option<[f32; 3]>,
    period_s: f32,
    center: Option<[f32; 3]>,
    phase: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyDef {
    time: f32,
    translate: Option<[f32; 3]>,
    rotate_y_degrees: Option<f32>,
    rotate: Option<AxisAngle>,
    scale: Option<Scale>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WaveDef {
    amplitude: f32,
    wavelength: f32,
    period_s: f32,
    direction: Option<[f32; 3]>,
    displacement: Option<[f32; 3]>,
}

/// The keys every shape table takes besides its own: placement, material, animation.
struct Common<'a> {
    translate: Option<[f32; 3]>,
    rotate_y_degrees: Option<f32>,
    rotate: Option<AxisAngle>,
    scale: Option<Scale>,
    matrix: Option<[f32; 16]>,
    material: Option<&'a MaterialDef>,
    spin: Option<&'a SpinDef>,
    keyframes: Option<&'a [KeyDef]>,
    wave: Option<&'a WaveDef>,
}

/// Declares a shape table: its own keys plus the [`Common`] ones (serde's `flatten` cannot be
/// combined with `deny_unknown_fields`, so the common keys are spelled out in each).
macro_rules! shape_table {
    ($(#[$meta:meta])* $name:ident { $($field:ident: $ty:ty),* $(,)? }) => {
        $(#[$meta])*
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct $name {
            $($field: $ty,)*
            translate: Option<[f32; 3]>,
            rotate_y_degrees: Option<f32>,
            rotate: Option<AxisAngle>,
            scale: Option<Scale>,
            matrix: Option<[f32; 16]>,
            material: Option<MaterialDef>,
            spin: Option<SpinDef>,
            keyframes: Option<Vec<KeyDef>>,
            wave: Option<WaveDef>,
        }

        impl $name {
            fn common(&self) -> Common<'_> {
                Common {
                    translate: self.translate,
                    rotate_y_degrees: self.rotate_y_degrees,
                    rotate: self.rotate,
                    scale: self.scale,
                    matrix: self.matrix,
                    material: self.material.as_ref(),
                    spin: self.spin.as_ref(),
                    keyframes: self.keyframes.as_deref(),
                    wave: self.wave.as_ref(),
                }
            }
        }
    };
}

shape_table!(MeshDef { file: PathBuf });
shape_table!(QuadDef { size: Option<[f32; 2]>, divisions: Option<[u32; 2]> });
shape_table!(BoxDef { size: Option<[f32; 3]> });
shape_table!(SphereDef { radius: Option<f32>, segments: Option<u32> });

#[derive(Deserialize, Clone, Copy, PartialEq, Debug)]
#[serde(rename_all = "lowercase")]
enum LightKindDef {
    Point,
    Spot,
    Directional,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDef {
    kind: LightKindDef,
    position: Option<[f32; 3]>,
    direction: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    color: Option<[f32; 3]>,
    intensity: Option<f32>,
    inner_angle_degrees: Option<f32>,
    outer_angle_degrees: Option<f32>,
    orbit: Option<OrbitDef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OrbitDef {
    center: Option<[f32; 3]>,
    axis: Option<[f32; 3]>,
    period_s: f32,
    phase: Option<f32>,
}

pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let text = glimpse_core::bounded_read::read_text_bounded(path, "scene file", glimpse_core::bounded_read::limit::TEXT)
        .map_err(|e| SceneError::io(path, e.reason()))?;
    let def: SceneDef = toml::from_str(&text).map_err(|e| SceneError::parse(path, one_line_toml_error(&text, &e)))?;
    Builder { toml: path, dir: path.parent().unwrap_or(Path::new("")), scene: Scene::default(), textures: TextureCache::default() }
        .build(def)
}

struct Builder<'a> {
    toml: &'a Path,
    dir: &'a Path,
    scene: Scene,
    /// Textures named in this toml (material overrides), loaded once.
    textures: TextureCache,
}

impl Builder<'_> {
    fn invalid(&self, message: String) -> SceneError {
        SceneError::Invalid { source_name: self.toml.display().to_string(), message }
    }

    fn build(mut self, def: SceneDef) -> Result<Scene, SceneError> {
        let stem = self.toml.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        self.scene.name = def.name.clone().unwrap_or(stem);

        let mut file_camera = None;
        for (i, m) in def.mesh.iter().enumerate() {
            let what = format!("[[mesh]] {i} ('{}')", m.file.display());
            let (motion, wave) = self.animation(&m.common(), &what)?;
            let camera = self.add_file(&self.dir.join(&m.file), &what, &motion, m.common().material, wave)?;
            file_camera = file_camera.or(camera);
        }
        for (i, q) in def.quad.iter().enumerate() {
            let what = format!("[[quad]] {i}");
            let size = Vec2::from_array(q.size.unwrap_or([1.0, 1.0]));
            let [nx, nz] = q.divisions.unwrap_or([1, 1]);
            if !(1..=4096).contains(&nx) || !(1..=4096).contains(&nz) {
                return Err(self.invalid(format!("{what}: divisions must lie in 1..=4096")));
            }
            let (vertices, triangles) = ((nx as u64 + 1) * (nz as u64 + 1), 2 * nx as u64 * nz as u64);
            glimpse_core::memory_budget::check_mesh(format!("{what} ({nx}x{nz} divisions)"), vertices, triangles)
                .map_err(|e| self.invalid(e.to_string()))?;
            self.add_shape(&q.common(), &what, |mat| plane_mesh(&format!("quad {i}"), mat, size, [nx, nz]))?;
        }
        for (i, b) in def.boxes.iter().enumerate() {
            let half = Vec3::from_array(b.size.unwrap_or([1.0; 3])) * 0.5;
            self.add_shape(&b.common(), &format!("[[box]] {i}"), |mat| box_mesh(&format!("box {i}"), mat, half))?;
        }
        for (i, s) in def.sphere.iter().enumerate() {
            let what = format!("[[sphere]] {i}");
            let segments = s.segments.unwrap_or(64);
            if !(4..=4096).contains(&segments) {
                return Err(self.invalid(format!("{what}: segments must lie in 4..=4096")));
            }
            let (rings, segs) = (segments as u64 / 2, segments as u64);
            glimpse_core::memory_budget::check_mesh(format!("{what} ({segments} segments)"), (rings + 1) * (segs + 1), 2 * rings * segs)
                .map_err(|e| self.invalid(e.to_string()))?;
            let radius = s.radius.unwrap_or(1.0);
            self.add_shape(&s.common(), &what, |mat| {
                let mut m = sphere_mesh(&format!("sphere {i}"), mat, segments / 2, segments);
                m.positions.iter_mut().for_each(|p| *p *= radius);
                m
            })?;
        }
        for (i, l) in def.light.iter().enumerate() {
            let light = self.light(l, &format!("[[light]] {i} ({:?})", l.kind).to_lowercase())?;
            self.scene.lights.push(light);
        }
        if let Some(env) = &def.environment {
            self.scene.environment = Some(self.environment(env)?);
        }
        self.scene.camera = match &def.camera {
            Some(c) => Some(self.camera(c)?),
            None => file_camera,
        };
        if let Some(f) = &def.film {
            let mut film = self.scene.film;
            if let Some(name) = &f.filter {
                film.filter = crate::Filter::from_name(name).map_err(|e| self.invalid(format!("[film]: {e}")))?;
            }
            film.samples = f.samples.unwrap_or(film.samples);
            film.validate().map_err(|e| self.invalid(format!("[film]: {e}")))?;
            self.scene.film = film;
        }
        Ok(self.scene)
    }

    /// The placement as a matrix (`translate · rotate · scale`, or `matrix`).
    fn placement(&self, c: &Common, what: &str) -> Result<Mat4, SceneError> {
        if let Some(m) = c.matrix {
            if c.translate.is_some() || c.rotate_y_degrees.is_some() || c.rotate.is_some() || c.scale.is_some() {
                return Err(self.invalid(format!("{what}: give either `matrix` or translate/rotate/scale, not both")));
            }
            return Ok(Mat4::from_cols_array(&m));
        }
        Ok(self.transform(c.translate, c.rotate_y_degrees, c.rotate, c.scale, what)?.matrix())
    }

    fn transform(
        &self,
        translate: Option<[f32; 3]>,
        rotate_y_degrees: Option<f32>,
        rotate: Option<AxisAngle>,
        scale: Option<Scale>,
        what: &str,
    ) -> Result<Transform, SceneError> {
        let rotation = match (rotate_y_degrees, rotate) {
            (Some(_), Some(_)) => return Err(self.invalid(format!("{what}: give either `rotate_y_degrees` or `rotate`, not both"))),
            (Some(deg), None) => Quat::from_rotation_y(deg.to_radians()),
            (None, Some(r)) => {
                let axis = Vec3::from_array(r.axis);
                if axis.length_squared() == 0.0 || !axis.is_finite() {
                    return Err(self.invalid(format!("{what}: the rotation axis must be a finite non-zero vector")));
                }
                Quat::from_axis_angle(axis.normalize(), r.degrees.to_radians())
            }
            (None, None) => Quat::IDENTITY,
        };
        let scale = scale.map_or(Vec3::ONE, |s| s.0);
        if !scale.is_finite() || scale.cmpeq(Vec3::ZERO).any() {
            return Err(self.invalid(format!("{what}: scale {scale} must be finite and non-zero in every axis")));
        }
        Ok(Transform { translation: Vec3::from_array(translate.unwrap_or([0.0; 3])), rotation, scale })
    }

    /// The shape's motion (placement, spin or keyframes) and vertex wave.
    fn animation(&self, c: &Common, what: &str) -> Result<(Motion, Option<Deformation>), SceneError> {
        let placed = c.translate.is_some() || c.rotate_y_degrees.is_some() || c.rotate.is_some() || c.scale.is_some() || c.matrix.is_some();
        let motion = match (c.keyframes, c.spin) {
            (Some(_), Some(_)) => return Err(self.invalid(format!("{what}: give either `keyframes` or `spin`, not both"))),
            (Some(_), None) if placed => {
                return Err(self.invalid(format!("{what}: with `keyframes`, put translate/rotate/scale in the keys, not beside them")));
            }
            (Some(keys), None) => {
                if keys.is_empty() {
                    return Err(self.invalid(format!("{what}: `keyframes` is empty")));
                }
                if keys.iter().any(|k| !k.time.is_finite()) || keys.windows(2).any(|w| w[1].time <= w[0].time) {
                    return Err(self.invalid(format!("{what}: keyframe times must be finite and increasing")));
                }
                let keys = keys
                    .iter()
                    .map(|k| {
                        Ok(TransformKey {
                            time: k.time,
                            transform: self.transform(k.translate, k.rotate_y_degrees, k.rotate, k.scale, what)?,
                        })
                    })
                    .collect::<Result<Vec<_>, SceneError>>()?;
                Motion::Keyframes(keys)
            }
            (None, Some(spin)) => {
                let base = self.placement(c, what)?;
                check_period(spin.period_s).map_err(|m| self.invalid(format!("{what}: spin {m}")))?;
                let center = spin.center.map_or(base.w_axis.truncate(), Vec3::from_array);
                let axis = check_axis(spin.axis).map_err(|m| self.invalid(format!("{what}: spin {m}")))?;
                Motion::Orbit { base, center, axis, period_s: spin.period_s, phase: spin.phase.unwrap_or(0.0) }
            }
            (None, None) => Motion::Fixed(self.placement(c, what)?),
        };
        let wave = match c.wave {
            Some(w) => {
                check_period(w.period_s).map_err(|m| self.invalid(format!("{what}: wave {m}")))?;
                if !(w.wavelength > 0.0 && w.wavelength.is_finite()) {
                    return Err(self.invalid(format!("{what}: wave wavelength must be a positive number")));
                }
                let reach = w.amplitude.abs() * Vec3::from_array(w.displacement.unwrap_or([0.0, 1.0, 0.0])).length();
                if !reach.is_finite() || reach > MAX_WAVE_REACH {
                    return Err(self.invalid(format!(
                        "{what}: wave amplitude {:e} × |displacement| must be finite and at most {MAX_WAVE_REACH} (scene units)",
                        w.amplitude
                    )));
                }
                Some(Deformation::Wave {
                    amplitude: w.amplitude,
                    wavelength: w.wavelength,
                    period_s: w.period_s,
                    direction: Vec3::from_array(w.direction.unwrap_or([1.0, 0.0, 0.0])).normalize_or(Vec3::X),
                    displacement: Vec3::from_array(w.displacement.unwrap_or([0.0, 1.0, 0.0])),
                })
            }
            None => None,
        };
        Ok((motion, wave))
    }

    fn camera(&self, c: &CameraDef) -> Result<Camera, SceneError> {
        let fov_axis = match c.fov_axis.as_deref() {
            None | Some("y") => FovAxis::Y,
            Some("x") => FovAxis::X,
            Some("smaller") => FovAxis::Smaller,
            Some("larger") => FovAxis::Larger,
            Some(other) => {
                return Err(self.invalid(format!("[camera]: fov_axis = \"{other}\" is not one of \"x\", \"y\", \"smaller\", \"larger\"")));
            }
        };
        let fov_degrees = match (c.fov_degrees, c.fov_y_degrees) {
            (Some(_), Some(_)) => return Err(self.invalid("[camera]: give fov_degrees or fov_y_degrees, not both".into())),
            (None, Some(_)) if fov_axis != FovAxis::Y => {
                return Err(self.invalid("[camera]: fov_y_degrees is vertical; with fov_axis, give fov_degrees".into()));
            }
            (f, g) => f.or(g).unwrap_or(45.0),
        };
        let mut camera = Camera::look_at(
            Vec3::from_array(c.position),
            Vec3::from_array(c.target),
            Vec3::from_array(c.up.unwrap_or([0.0, 1.0, 0.0])),
            fov_degrees,
        );
        camera.fov_axis = fov_axis;
        Ok(camera)
    }

    /// A material from defaults plus the given fields.
    fn apply_material(&mut self, mat: &mut Material, def: &MaterialDef, what: &str) -> Result<(), SceneError> {
        let bad = |key: &str, model: &str| self.invalid(format!("{what}: material key `{key}` does not apply to model \"{model}\""));
        let model = def.model.as_deref().unwrap_or(mat.model.name());
        if model != "dielectric" && def.ior.is_some() {
            return Err(bad("ior", model));
        }
        if model != "conductor" && (def.eta.is_some() || def.k.is_some()) {
            return Err(bad(if def.eta.is_some() { "eta" } else { "k" }, model));
        }
        if model != "pbr" && (def.metallic.is_some() || def.clearcoat.is_some()) {
            return Err(bad(if def.metallic.is_some() { "metallic" } else { "clearcoat" }, model));
        }
        if let Some(name) = &def.model {
            mat.model = match name.as_str() {
                "pbr" => MaterialModel::Pbr,
                "diffuse" => MaterialModel::Diffuse,
                "conductor" => {
                    mat.roughness = 0.0;
                    mat.base_color = Vec3::ONE;
                    MaterialModel::PERFECT_CONDUCTOR
                }
                "dielectric" => {
                    mat.base_color = Vec3::ONE;
                    MaterialModel::Dielectric { ior: 1.5 }
                }
                other => {
                    return Err(self.invalid(format!(
                        "{what}: material model \"{other}\" is not one of \"pbr\", \"diffuse\", \"conductor\", \"dielectric\""
                    )));
                }
            };
            if mat.model != MaterialModel::Pbr {
                mat.metallic = 0.0;
                mat.clearcoat = 0.0;
            }
        }
        match &mut mat.model {
            MaterialModel::Conductor { eta, k } => {
                *eta = def.eta.map_or(*eta, Vec3::from_array);
                *k = def.k.map_or(*k, Vec3::from_array);
            }
            MaterialModel::Dielectric { ior } => *ior = def.ior.unwrap_or(*ior),
            _ => {}
        }
        if let Some(c) = def.base_color {
            mat.base_color = Vec3::from_array(c);
        }
        if let Some(r) = def.roughness {
            mat.roughness = r;
        }
        if let Some(m) = def.metallic {
            mat.metallic = m;
        }
        if let Some(e) = def.emission {
            mat.emission = Vec3::from_array(e);
        }
        if let Some(c) = def.clearcoat {
            mat.clearcoat = c;
        }
        if let Some(t) = &def.base_color_texture {
            mat.base_color_texture = self.textures.load(&self.dir.join(t), &mut self.scene, self.toml);
        }
        if let Some(t) = &def.texture {
            let image = crate::procedural::bake(t).map_err(|e| self.invalid(format!("{}: {e}", mat.name)))?;
            self.scene.textures.push(image);
            mat.base_color_texture = Some(self.scene.textures.len() as u32 - 1);
        }
        Ok(())
    }

    fn add_shape(&mut self, c: &Common, what: &str, make: impl FnOnce(u32) -> Mesh) -> Result<(), SceneError> {
        let (motion, wave) = self.animation(c, what)?;
        let mut mat = Material { name: what.to_owned(), ..Default::default() };
        if let Some(def) = c.material {
            self.apply_material(&mut mat, def, what)?;
        }
        let id = self.scene.add_material(mat);
        let mut mesh = make(id);
        mesh.deformation = wave;
        self.scene.meshes.push(mesh);
        let mesh = self.scene.meshes.len() as u32 - 1;
        self.scene.instances.push(crate::Instance { mesh, motion });
        Ok(())
    }

    /// Loads and validates a referenced file and merges it in under `motion`; returns its
    /// camera (moved by the placement at time 0).
    fn add_file(
        &mut self,
        file: &Path,
        what: &str,
        motion: &Motion,
        material: Option<&MaterialDef>,
        wave: Option<Deformation>,
    ) -> Result<Option<Camera>, SceneError> {
        let ext = file.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let loaded = match ext.as_deref() {
            Some("obj") => crate::obj_loader::load(file),
            Some("gltf" | "glb") => crate::gltf_loader::load(file),
            _ => return Err(self.invalid(format!("{what}: mesh files must be .obj, .gltf or .glb"))),
        };
        let mut sub = loaded.and_then(|mut s| crate::validate::validate(&mut s, &file.display().to_string()).map(|()| s));
        sub = sub.map_err(|e| referenced_by(e, &format!("{} {what}", self.toml.display())));
        let sub = sub?;

        let (mat_offset, tex_offset, mesh_offset) =
            (self.scene.materials.len() as u32, self.scene.textures.len() as u32, self.scene.meshes.len() as u32);
        self.scene.textures.extend(sub.textures);
        for mut m in sub.materials {
            m.base_color_texture = m.base_color_texture.map(|t| t + tex_offset);
            if let Some(def) = material {
                self.apply_material(&mut m, def, what)?;
            }
            self.scene.materials.push(m);
        }
        for mut m in sub.meshes {
            m.material += mat_offset;
            if wave.is_some() {
                m.deformation = wave.clone();
            }
            self.scene.meshes.push(m);
        }
        let mut approximated = false;
        for inst in sub.instances {
            let (motion, exact) = compose(motion, &inst.motion);
            approximated |= !exact;
            self.scene.instances.push(crate::Instance { mesh: inst.mesh + mesh_offset, motion });
        }
        for light in sub.lights {
            let (m, exact) = compose(motion, &light.motion);
            approximated |= !exact;
            self.scene.lights.push(light.with_motion(m));
        }
        self.scene.warnings.extend(sub.warnings);
        if approximated {
            self.scene.warnings.push(format!(
                "{}: {what}: the file is animated and so is its placement; the file's pose at time 0 is used",
                self.toml.display()
            ));
        }
        Ok(sub.camera.map(|c| {
            let m = motion.at(0.0);
            let position = m.transform_point3(c.position);
            Camera { position, target: m.transform_point3(c.target), up: m.transform_vector3(c.up), ..c }
        }))
    }

    fn light(&self, l: &LightDef, what: &str) -> Result<Light, SceneError> {
        let v = |a: Option<[f32; 3]>| a.map(Vec3::from_array);
        let intensity = Vec3::from_array(l.color.unwrap_or([1.0; 3])) * l.intensity.unwrap_or(1.0);
        let unused = |key: &str| self.invalid(format!("{what}: `{key}` does not apply to this kind of light"));
        let needs = |key: &str| self.invalid(format!("{what}: needs `{key}`"));
        let is_spot = l.kind == LightKindDef::Spot;
        if !is_spot && l.inner_angle_degrees.or(l.outer_angle_degrees).is_some() {
            return Err(unused("inner_angle_degrees/outer_angle_degrees"));
        }
        if !is_spot && l.target.is_some() {
            return Err(unused("target"));
        }
        let light = match l.kind {
            LightKindDef::Point => {
                if l.direction.is_some() {
                    return Err(unused("direction"));
                }
                Light::point(v(l.position).ok_or_else(|| needs("position"))?, intensity)
            }
            LightKindDef::Spot => {
                let position = v(l.position).ok_or_else(|| needs("position"))?;
                let direction = match (v(l.direction), v(l.target)) {
                    (Some(d), None) => d,
                    (None, Some(t)) => t - position,
                    _ => return Err(self.invalid(format!("{what}: give exactly one of `direction` and `target`"))),
                };
                if direction.length_squared() == 0.0 || !direction.is_finite() {
                    return Err(self.invalid(format!("{what}: its direction is zero or not finite")));
                }
                let inner = l.inner_angle_degrees.unwrap_or(0.0).to_radians();
                let outer = l.outer_angle_degrees.unwrap_or(45.0).to_radians();
                Light::spot(position, direction, intensity, inner, outer)
            }
            LightKindDef::Directional => {
                if l.position.is_some() {
                    return Err(unused("position"));
                }
                let direction = v(l.direction).ok_or_else(|| needs("direction"))?;
                if direction.length_squared() == 0.0 || !direction.is_finite() {
                    return Err(self.invalid(format!("{what}: its direction is zero or not finite")));
                }
                Light::directional(direction, intensity)
            }
        };
        Ok(match &l.orbit {
            Some(o) => {
                check_period(o.period_s).map_err(|m| self.invalid(format!("{what}: orbit {m}")))?;
                let axis = check_axis(o.axis).map_err(|m| self.invalid(format!("{what}: orbit {m}")))?;
                light.with_motion(Motion::Orbit {
                    base: Mat4::IDENTITY,
                    center: Vec3::from_array(o.center.unwrap_or([0.0; 3])),
                    axis,
                    period_s: o.period_s,
                    phase: o.phase.unwrap_or(0.0),
                })
            }
            None => light,
        })
    }

    fn environment(&self, e: &EnvironmentDef) -> Result<Environment, SceneError> {
        let scale = e.scale.unwrap_or(1.0);
        let mut env = match (&e.file, e.constant, &e.sky) {
            (Some(file), None, None) => {
                let file = self.dir.join(file);
                let image = Image::read(&file).map_err(|err| SceneError::Io {
                    path: file.clone(),
                    message: format!("environment map not loaded ({err}; referenced by {})", self.toml.display()),
                })?;
                Environment::new(image, 1.0)
            }
            (None, Some(c), None) => Environment::constant(Vec3::from_array(c)),
            (None, None, Some(sky)) => {
                let width = sky.width.unwrap_or(512);
                if !(4..=8192).contains(&width) {
                    return Err(self.invalid("[environment] sky width must lie in 4..=8192".into()));
                }
                let sun = Vec3::from_array(sky.sun_direction);
                if sun.length_squared() == 0.0 || !sun.is_finite() {
                    return Err(self.invalid("[environment] sky sun_direction must be a finite non-zero vector".into()));
                }
                Environment::procedural_sky(width, sun, sky.sun_radiance)
            }
            _ => return Err(self.invalid("[environment] needs exactly one of `file`, `constant` and `sky`".into())),
        };
        env.scale = scale;
        Ok(env)
    }
}

/// The farthest a wave may move a vertex: beyond this, positions lose the float precision the
/// tracer's ray offsets rely on (and 1e38 overflows to infinity once multiplied).
pub const MAX_WAVE_REACH: f32 = 1.0e4;

/// An animation axis (default +y): finite and non-zero, normalized later by the motion.
fn check_axis(axis: Option<[f32; 3]>) -> Result<Vec3, String> {
    let a = Vec3::from_array(axis.unwrap_or([0.0, 1.0, 0.0]));
    if a.is_finite() && a.length_squared() > 0.0 { Ok(a) } else { Err(format!("axis {a} must be a finite non-zero vector")) }
}

fn check_period(period_s: f32) -> Result<(), String> {
    if period_s.is_finite() && period_s != 0.0 { Ok(()) } else { Err(format!("period_s must be a finite non-zero number, not {period_s}")) }
}

/// Adds "(referenced by …)" to an error of a referenced file, keeping its variant and its path.
pub(crate) fn referenced_by(e: SceneError, by: &str) -> SceneError {
    let note = |m: String| format!("{m} (referenced by {by})");
    match e {
        SceneError::Io { path, message } => SceneError::Io { path, message: note(message) },
        SceneError::Parse { path, message } => SceneError::Parse { path, message: note(message) },
        SceneError::Unsupported { path, message } => SceneError::Unsupported { path, message: note(message) },
        SceneError::Invalid { source_name, message } => SceneError::Invalid { source_name, message: note(message) },
        other => other,
    }
}

fn decompose(m: Mat4) -> Transform {
    let (scale, rotation, translation) = m.to_scale_rotation_translation();
    Transform { translation, rotation, scale }
}

/// `outer` applied after `inner` (a file's own motion under a toml placement). Exact when at
/// least one side is fixed (for an orbit under a placement, when the placement is a similarity);
/// otherwise the inner pose at time 0 is used and the flag is false.
fn compose(outer: &Motion, inner: &Motion) -> (Motion, bool) {
    let rekey = |keys: &[TransformKey], f: &dyn Fn(Mat4) -> Mat4| {
        Motion::Keyframes(keys.iter().map(|k| TransformKey { time: k.time, transform: decompose(f(k.transform.matrix())) }).collect())
    };
    match (outer, inner) {
        (Motion::Fixed(p), Motion::Fixed(m)) => (Motion::Fixed(*p * *m), true),
        (Motion::Fixed(p), Motion::Keyframes(keys)) => (rekey(keys, &|k| *p * k), true),
        (Motion::Fixed(p), Motion::Orbit { base, center, axis, period_s, phase }) => (
            Motion::Orbit {
                base: *p * *base,
                center: p.transform_point3(*center),
                axis: p.transform_vector3(*axis),
                period_s: *period_s,
                phase: *phase,
            },
            true,
        ),
        (Motion::Keyframes(keys), inner) => {
            let m = inner.at(0.0);
            (rekey(keys, &|k| k * m), inner.is_static())
        }
        (Motion::Orbit { base, center, axis, period_s, phase }, inner) => (
            Motion::Orbit { base: *base * inner.at(0.0), center: *center, axis: *axis, period_s: *period_s, phase: *phase },
            inner.is_static(),
        ),
    }
}

/// toml's `Display` draws the offending line with carets over several lines; the command line
/// prints one line per error, so keep the message and say where.
fn one_line_toml_error(text: &str, e: &toml::de::Error) -> String {
    let message = e.message().trim_end().replace('\n', "; ");
    match e.span() {
        Some(span) => {
            let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
            let column = span.start - text[..span.start.min(text.len())].rfind('\n').map_or(0, |i| i + 1) + 1;
            format!("line {line}, column {column}: {message}")
        }
        None => message,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documented_example_parses() {
        let source = include_str!("toml_loader.rs");
        let example: String = source
            .lines()
            .filter_map(|l| l.strip_prefix("//!"))
            .skip_while(|l| !l.trim_start().starts_with("```toml"))
            .skip(1)
            .take_while(|l| !l.trim_start().starts_with("```"))
            .map(|l| format!("{}\n", l.strip_prefix(' ').unwrap_or(l)))
            .collect();
        let def: SceneDef = toml::from_str(&example).unwrap_or_else(|e| panic!("{e}\n{example}"));
        println!(
            "example: {} lines, {} meshes, {} quads, {} boxes, {} spheres, {} lights",
            example.lines().count(),
            def.mesh.len(),
            def.quad.len(),
            def.boxes.len(),
            def.sphere.len(),
            def.light.len()
        );
        assert_eq!((def.mesh.len(), def.quad.len(), def.boxes.len(), def.sphere.len(), def.light.len()), (1, 1, 1, 1, 1));
        assert!(def.mesh[0].spin.is_some() && def.mesh[0].wave.is_some() && def.environment.is_some() && def.camera.is_some());
    }

    #[test]
    fn composing_a_fixed_placement_is_exact() {
        let p = Mat4::from_scale_rotation_translation(Vec3::splat(2.0), Quat::from_rotation_y(0.7), Vec3::new(1.0, 2.0, 3.0));
        let key =
            |time: f32, x: f32| TransformKey { time, transform: Transform { translation: Vec3::new(x, 0.0, 0.0), ..Default::default() } };
        let inner = Motion::Keyframes(vec![key(0.0, 0.0), key(1.0, 1.0)]);
        let orbit = Motion::Orbit { base: Mat4::from_translation(Vec3::X), center: Vec3::ZERO, axis: Vec3::Y, period_s: 3.0, phase: 0.0 };
        for inner in [inner, orbit] {
            let (m, exact) = compose(&Motion::Fixed(p), &inner);
            assert!(exact);
            for t in [0.0, 1.0, 2.5] {
                let (a, b) = (m.at(t), p * inner.at(t));
                assert!(a.abs_diff_eq(b, 1e-4), "t {t}: {a} vs {b}");
            }
        }
        let spin = Motion::Orbit { base: p, center: Vec3::ZERO, axis: Vec3::Y, period_s: 2.0, phase: 0.0 };
        let (m, exact) = compose(&spin, &Motion::Fixed(Mat4::from_translation(Vec3::Z)));
        assert!(exact && m.at(0.5).abs_diff_eq(spin.at(0.5) * Mat4::from_translation(Vec3::Z), 1e-5));
    }
}
