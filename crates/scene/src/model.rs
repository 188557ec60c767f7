//! The scene's plain data: meshes, materials, textures and instances, linked by index.

use crate::{Camera, Deformation, Environment, Light, Motion};
use glimpse_core::{Aabb, Image, Mat4, Vec2, Vec3, Vec4};

/// A triangle mesh in its own object space, with one material.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals: empty, or one per position.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates (glTF convention: v = 0 is the image's top row): empty, or
    /// one per position.
    pub uvs: Vec<Vec2>,
    /// Per-vertex colours (linear RGB) multiplying the material's base colour, as glTF's
    /// `COLOR_0`, PLY's red/green/blue and OBJ's `v x y z r g b` define it: empty, or one per
    /// position.
    pub colors: Vec<Vec3>,
    /// Per-vertex tangents for the normal texture (glTF's `TANGENT`: xyz along +u, w = ±1 the
    /// bitangent's sign, B = w · N × T): empty, or one per position. Without them (or on a
    /// deforming mesh, whose tangents would not follow) the triangle's uv frame stands in.
    pub tangents: Vec<Vec4>,
    pub indices: Vec<[u32; 3]>,
    pub material: u32,
    /// Vertex animation; `None` for a rigid mesh.
    pub deformation: Option<Deformation>,
}

impl Mesh {
    /// One planar quad (corners in order) as two triangles, uvs over [0, 1]².
    pub fn quad(name: &str, material: u32, corners: [Vec3; 4]) -> Mesh {
        crate::builtin::quads_mesh(name, material, &[corners])
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.positions)
    }

    /// Area-weighted vertex normals from the triangles (for meshes without normals and for
    /// deformed positions).
    pub fn vertex_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; positions.len()];
        for t in indices {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let face = (b - a).cross(c - a); // length = 2 × area: area weighting for free
            for &i in t {
                n[i as usize] += face;
            }
        }
        n.iter().map(|v| v.normalize_or(Vec3::Y)).collect()
    }
}

/// Which reflectance model a [`Material`] follows. The path tracer renders every model; the
/// Lambertian techniques shade `base_color` as a diffuse albedo whatever the model (and say so).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum MaterialModel {
    /// glTF 2.0 metallic-roughness: a Lambertian base under a GGX specular layer.
    #[default]
    Pbr,
    /// Lambertian: `base_color`/π, nothing else (Mitsuba's `diffuse`).
    Diffuse,
    /// A GGX conductor (α = roughness², roughness 0 is a mirror): reflectance `base_color` ×
    /// the exact conductor Fresnel term of complex IOR η + ik per channel. The default
    /// η = 0, k = 1 reflects everything at every angle (Mitsuba's `material = "none"`), so
    /// `base_color` alone is the reflectance.
    Conductor { eta: Vec3, k: Vec3 },
    /// Smooth glass: delta reflection and refraction weighted by the exact dielectric Fresnel
    /// term with relative index of refraction `ior` (inside / outside); `base_color` tints
    /// both (Mitsuba's specular reflectance = transmittance, default white).
    Dielectric { ior: f32 },
}

impl MaterialModel {
    /// A mirror-like conductor that reflects `base_color` at every angle.
    pub const PERFECT_CONDUCTOR: MaterialModel = MaterialModel::Conductor { eta: Vec3::ZERO, k: Vec3::ONE };

    pub fn name(&self) -> &'static str {
        match self {
            MaterialModel::Pbr => "pbr",
            MaterialModel::Diffuse => "diffuse",
            MaterialModel::Conductor { .. } => "conductor",
            MaterialModel::Dielectric { .. } => "dielectric",
        }
    }
}

/// A material: by default glTF 2.0's metallic-roughness model ([`MaterialModel`] says which).
/// Lambertian techniques use `base_color` as the diffuse albedo; the path tracer uses all of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub model: MaterialModel,
    pub base_color: Vec3,
    /// Index into [`Scene::textures`], multiplied with `base_color`.
    pub base_color_texture: Option<u32>,
    /// Perceptual roughness in [0,1] (GGX α = roughness²): `pbr` and `conductor`.
    pub roughness: f32,
    /// `pbr` only.
    pub metallic: f32,
    /// Emitted radiance (W/(m²·sr) per channel): a non-zero emission makes every triangle with
    /// this material an area light.
    pub emission: Vec3,
    /// Clear-coat strength γ in [0, 1] (0: none): a smooth dielectric coat (F0 = 0.04) over the
    /// base, Filament's clear coat as the wavelet-cache paper uses it (its Eqs. 11–12).
    pub clearcoat: f32,
    /// glTF's alpha mode MASK: where the coverage is under the cutoff the surface is a hole
    /// (`None`: opaque).
    pub alpha_mask: Option<AlphaMask>,
    /// Per-texel metallic and roughness (glTF's metallic-roughness texture), read by the exact
    /// references ([`Scene::metallic_roughness`]). `metallic` and `roughness` above then hold the
    /// texture's mean × the factors: the one BRDF per material that the techniques which
    /// precompute per material (the wavelet cache's BRDF tables) use.
    pub metallic_roughness_map: Option<MetallicRoughnessMap>,
    /// glTF's normal texture: the shading normal per texel, for every technique (the tracer's
    /// surface points, so the GBuffer and every path vertex, carry it).
    pub normal_map: Option<NormalMap>,
    /// glTF's emissive texture: the emitted radiance per texel ([`Scene::emission`]), read by
    /// the exact tracer's surface points and light samples. `emission` above then holds the
    /// texture's mean × the factor: the one radiance per emitter that the techniques which
    /// build lights from the emitters (the RSM's VPLs) and the light selection use.
    pub emission_map: Option<EmissionMap>,
}

/// glTF's emissive texture: at uv, emitted radiance = `factor` × the texel (colour, decoded
/// to linear; bilinear, repeating).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionMap {
    /// Index into [`Scene::textures`].
    pub texture: u32,
    /// `emissiveFactor` × `KHR_materials_emissive_strength`.
    pub factor: Vec3,
}

/// A normal texture (glTF's, Mitsuba's `normalmap`): a tangent-space normal per texel, its
/// channels raw in [0, 1] mapped to [−1, 1], x and y × `scale`, renormalized (glTF's
/// `scaledNormal`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalMap {
    /// Index into [`Scene::textures`].
    pub texture: u32,
    pub scale: f32,
    pub bitangent: Bitangent,
    pub shadowing: NormalMapShadowing,
}

/// Whether light arriving at a normal-mapped point is dimmed for the bend: the formats' renderers
/// differ, so each loader says which its format's renderer does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalMapShadowing {
    /// The bent normal's cosine alone (glTF, pbrt-v4): a plane bent by θ under a uniform sky
    /// reflects ρ (1 + cos θ)/2 of it.
    None,
    /// Mitsuba 3's `normalmap`: f × [`BumpShadowing`] of the light's direction (measured in
    /// Mitsuba 3.9.1: its BSDF at 400 directions, and a bent plane under a uniform sky, 60°: 0.283
    /// of the sky where the cosine alone gives 0.375).
    Microfacet,
}

/// Conty Estevez, Pearce and Ward's shadowing function for bent normals ("A Microfacet-Based
/// Shadowing Function to Solve the Bump Terminator Problem", Ray Tracing Gems, 2019): the bend
/// is read as a microfacet surface of GGX α² = tan²θ_d / 8 (θ_d between the authored and the
/// bent normal, α² at most 1), and light at θ_i from the authored normal is shadowed by Smith's
/// G₁ = 2 / (1 + √(1 + α² tan²θ_i)). It darkens the grazing light that a bent normal would
/// otherwise catch in full (the terminator's hard edge on a bumpy sphere).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BumpShadowing {
    /// The authored (interpolated) normal, unit.
    normal: Vec3,
    alpha2: f32,
}

impl BumpShadowing {
    /// For a point whose authored normal `authored` was bent to `bent` (both unit).
    pub fn new(authored: Vec3, bent: Vec3) -> Self {
        let cos_d = authored.dot(bent).abs().min(1.0);
        let tan2_d = (1.0 - cos_d * cos_d) / (cos_d * cos_d).max(1e-12);
        Self { normal: authored, alpha2: (0.125 * tan2_d).clamp(0.0, 1.0) }
    }

    /// The share of light arriving from unit direction `wi` that reaches the point, in (0, 1].
    pub fn factor(&self, wi: Vec3) -> f32 {
        let cos_i = self.normal.dot(wi).abs().max(1e-6);
        let tan2_i = (1.0 - cos_i * cos_i) / (cos_i * cos_i);
        2.0 / (1.0 + (1.0 + self.alpha2 * tan2_i).sqrt())
    }
}

/// Which way a normal texture's +y points on the surface: the formats differ on uv mappings
/// that are mirrored in the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bitangent {
    /// glTF (its tangents' sign, as MikkTSpace computes it): the image's up, whatever the
    /// mapping's orientation: B = n × T, turned to run against dp/dv (v = 0 is the top row).
    ImageUp,
    /// Mitsuba 3 (and pbrt-v4): B = n × T, whatever the mapping (Mitsuba's `normalmap`;
    /// measured against Mitsuba by tools/crosscheck's `textures` scene).
    NormalCrossTangent,
}

impl NormalMap {
    /// The shading normal at `uv` of a surface whose interpolated normal is `n` (unit, on the
    /// triangle's front side) and whose position moves by `dpdu`, `dpdv` per unit of u and v;
    /// `None` where the uvs do not span the surface. The tangent frame is pbrt-v4's and
    /// Mitsuba's: T = dp/du made orthogonal to `n`, B = n × T, its sign as [`Bitangent`] says
    /// (v = 0 is the image's top row, glTF's convention, which our uvs use). The frame is the
    /// triangle's, not MikkTSpace's per-vertex tangents; on a mapping without shear they agree.
    pub fn perturb(&self, texture: &Image, uv: Vec2, n: Vec3, dpdu: Vec3, dpdv: Vec3) -> Option<Vec3> {
        let t = (dpdu - n * n.dot(dpdu)).try_normalize()?;
        let b = n.cross(t);
        let b = if self.bitangent == Bitangent::ImageUp && b.dot(dpdv) > 0.0 { -b } else { b };
        self.bend(texture, uv, n, t, b)
    }

    /// [`Self::perturb`] in the frame of an authored tangent `tangent` (glTF's `TANGENT`,
    /// interpolated and in world space; made orthogonal to `n`) with B = `sign` · n × T.
    pub fn perturb_along(&self, texture: &Image, uv: Vec2, n: Vec3, tangent: Vec3, sign: f32) -> Option<Vec3> {
        let t = (tangent - n * n.dot(tangent)).try_normalize()?;
        self.bend(texture, uv, n, t, n.cross(t) * sign)
    }

    /// The texel at `uv` in the orthonormal frame (t, b, n).
    fn bend(&self, texture: &Image, uv: Vec2, n: Vec3, t: Vec3, b: Vec3) -> Option<Vec3> {
        let c = texture.sample_repeat(uv.x, uv.y) * 2.0 - Vec3::ONE;
        (t * (c.x * self.scale) + b * (c.y * self.scale) + n * c.z).try_normalize()
    }
}

/// glTF's metallic-roughness texture: at uv, roughness = `roughness` × the texel's G channel and
/// metallic = `metallic` × its B channel (raw values, not sRGB; bilinear, repeating).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetallicRoughnessMap {
    /// Index into [`Scene::textures`].
    pub texture: u32,
    /// The factors the texels multiply (glTF's `metallicFactor`, `roughnessFactor`).
    pub metallic: f32,
    pub roughness: f32,
}

/// A cut-out surface (glTF `alphaMode: MASK`): coverage α = `factor` × the texture's value at
/// the point's uv (bilinear, repeating; the texture is linear, not sRGB), and the surface is
/// there only where α ≥ `cutoff`. The exact tracer honours it, so every reference does (as
/// pbrt's and Mitsuba's alpha tests do); the approximate techniques' grids and maps are built
/// from the triangles and draw it opaque.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlphaMask {
    /// Index into [`Scene::textures`]: coverage in every channel; `None`: `factor` alone.
    pub texture: Option<u32>,
    pub factor: f32,
    /// glTF's `alphaCutoff` (default 0.5).
    pub cutoff: f32,
}

impl AlphaMask {
    /// Whether the surface is a hole at `uv`, `texture` being the one [`AlphaMask::texture`]
    /// names (the one place the coverage rule is written).
    #[inline]
    pub fn cuts(&self, texture: Option<&Image>, uv: Vec2) -> bool {
        let coverage = match texture {
            Some(t) => self.factor * t.sample_repeat(uv.x, uv.y).x,
            None => self.factor,
        };
        coverage < self.cutoff
    }
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            model: MaterialModel::Pbr,
            base_color: Vec3::splat(0.8),
            base_color_texture: None,
            roughness: 1.0,
            metallic: 0.0,
            emission: Vec3::ZERO,
            clearcoat: 0.0,
            alpha_mask: None,
            metallic_roughness_map: None,
            normal_map: None,
            emission_map: None,
        }
    }
}

impl Material {
    pub fn diffuse(name: &str, base_color: Vec3) -> Self {
        Self { name: name.into(), base_color, ..Default::default() }
    }

    pub fn emissive(name: &str, emission: Vec3) -> Self {
        Self { name: name.into(), base_color: Vec3::ZERO, emission, ..Default::default() }
    }

    /// True when only the path tracer renders this material as it is: the Lambertian
    /// techniques shade it as a diffuse `base_color` instead.
    pub fn needs_path_tracer(&self) -> bool {
        !matches!(self.model, MaterialModel::Pbr | MaterialModel::Diffuse)
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

/// One placement of a mesh in the world.
#[derive(Clone, Debug)]
pub struct Instance {
    pub mesh: u32,
    pub motion: Motion,
}

impl Instance {
    pub fn fixed(mesh: u32, transform: Mat4) -> Self {
        Self { mesh, motion: Motion::Fixed(transform) }
    }
}

#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub name: String,
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    /// Linear RGB textures.
    pub textures: Vec<Image>,
    pub instances: Vec<Instance>,
    /// Punctual lights (point, spot, directional). Area lights are emissive triangles.
    pub lights: Vec<Light>,
    pub environment: Option<Environment>,
    /// The camera from the file; `None` frames the scene's bounds (see [`Scene::camera_or_default`]).
    pub camera: Option<Camera>,
    /// Problems that did not stop loading (degenerate triangles removed, ignored features),
    /// one line each naming the file; the command line prints them.
    pub warnings: Vec<String>,
    /// Size, spp, depth and filter the file asks for (Mitsuba scenes); empty for other formats.
    pub render_hints: crate::RenderHints,
    /// Pixel filter and primary samples per pixel (`[film]` in scene.toml, Mitsuba's rfilter).
    pub film: crate::Film,
}

impl Scene {
    /// Adds a mesh and one fixed instance of it; returns the mesh index.
    pub fn add_mesh(&mut self, mesh: Mesh, transform: Mat4) -> u32 {
        let id = self.meshes.len() as u32;
        self.meshes.push(mesh);
        self.instances.push(Instance::fixed(id, transform));
        id
    }

    pub fn add_material(&mut self, m: Material) -> u32 {
        self.materials.push(m);
        self.materials.len() as u32 - 1
    }

    pub fn triangle_count(&self) -> usize {
        self.instances.iter().map(|i| self.meshes[i.mesh as usize].indices.len()).sum()
    }

    /// True when no instance moves and no mesh deforms (lights may move).
    pub fn geometry_is_static(&self) -> bool {
        self.instances.iter().all(|i| i.motion.is_static()) && self.meshes.iter().all(|m| m.deformation.is_none())
    }

    /// True when anything moves or deforms over time.
    pub fn is_animated(&self) -> bool {
        self.instances.iter().any(|i| !i.motion.is_static())
            || self.meshes.iter().any(|m| m.deformation.is_some())
            || self.lights.iter().any(|l| !l.motion.is_static())
    }

    /// World bounds at time 0.
    pub fn bounds(&self) -> Aabb {
        self.at(0.0).bounds
    }

    /// Base colour of `material` at texture coordinates `uv` (texture × factor).
    pub fn base_color(&self, material: u32, uv: Vec2) -> Vec3 {
        let m = &self.materials[material as usize];
        match m.base_color_texture {
            Some(t) => m.base_color * self.textures[t as usize].sample_repeat(uv.x, uv.y),
            None => m.base_color,
        }
    }

    /// (metallic, roughness) of `material` at `uv`: its [`MetallicRoughnessMap`]'s texel × factors
    /// where it has one, else the material's own values.
    pub fn metallic_roughness(&self, material: u32, uv: Vec2) -> (f32, f32) {
        let m = &self.materials[material as usize];
        match m.metallic_roughness_map {
            Some(map) => {
                let texel = self.textures[map.texture as usize].sample_repeat(uv.x, uv.y);
                ((map.metallic * texel.z).clamp(0.0, 1.0), (map.roughness * texel.y).clamp(0.0, 1.0))
            }
            None => (m.metallic, m.roughness),
        }
    }

    /// Radiance emitted by `material` at `uv` (its front side): its [`EmissionMap`]'s texel ×
    /// factor where it has one, else the material's emission.
    pub fn emission(&self, material: u32, uv: Vec2) -> Vec3 {
        let m = &self.materials[material as usize];
        match m.emission_map {
            Some(map) => map.factor * self.textures[map.texture as usize].sample_repeat(uv.x, uv.y),
            None => m.emission,
        }
    }

    /// Whether `material`'s base colour varies over its surfaces: a base colour texture, or
    /// vertex colours on a mesh that uses it.
    pub fn base_color_varies(&self, material: u32) -> bool {
        self.materials[material as usize].base_color_texture.is_some()
            || self.meshes.iter().any(|m| m.material == material && !m.colors.is_empty())
    }

    /// Whether the surface of `material` is a hole at `uv` ([`AlphaMask`]).
    pub fn cut_out(&self, material: u32, uv: Vec2) -> bool {
        let Some(mask) = self.materials[material as usize].alpha_mask else { return false };
        mask.cuts(mask.texture.map(|t| &self.textures[t as usize]), uv)
    }

    /// Whether some material is cut out ([`AlphaMask`]).
    pub fn has_alpha_masks(&self) -> bool {
        self.materials.iter().any(|m| m.alpha_mask.is_some())
    }

    pub fn camera_or_default(&self, aspect: f32) -> Camera {
        self.camera.clone().unwrap_or_else(|| crate::auto::camera(self, aspect))
    }
}
