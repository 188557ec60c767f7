//! glimpse-scene: what is rendered. A [`Scene`] is plain data linked by index (meshes,
//! materials, textures, instances, lights, an environment, a camera) plus animation as a function
//! of time; [`Scene::at`] evaluates it into a [`SceneFrame`] of world-space data that the
//! tracer and the techniques consume.
//!
//! Loaders: glTF 2.0 ([`gltf_loader`]), OBJ+MTL ([`obj_loader`]), `scene.toml`
//! ([`toml_loader`]), Mitsuba 3 XML ([`mitsuba_loader`]), PLY ([`ply_loader`]), and the built-in scenes ([`builtin`]). [`load`] picks by name or extension.

pub mod animation;
pub mod auto;
pub mod builtin;
pub mod camera;
pub mod cutouts;
pub mod environment;
pub mod error;
pub mod film;
pub mod frame;
pub mod gltf_loader;
pub mod light;
pub mod mitsuba_loader;
pub mod model;
pub mod obj_loader;
pub mod orient;
pub mod overrides;
pub mod ply_loader;
pub mod procedural;
pub mod render_hints;
pub mod rescale;
pub mod toml_loader;
pub mod validate;

pub use animation::{Deformation, Motion, Transform, TransformKey};
pub use camera::{Camera, FovAxis};
pub use cutouts::Cutouts;
pub use environment::{BrightPart, EnvSample, Environment, SphereGrid};
pub use error::SceneError;
pub use film::{Film, Filter};
pub use frame::{EmissiveTriangle, SceneFrame, WorldLight};
pub use light::{Light, LightKind};
pub use model::{
    AlphaMask, Bitangent, BumpShadowing, EmissionMap, Instance, Material, MaterialModel, Mesh, MetallicRoughnessMap, NormalMap,
    NormalMapShadowing, Scene,
};
pub use overrides::SceneOverrides;
pub use render_hints::RenderHints;

use std::path::Path;

/// Loads a scene by built-in name (see [`builtin::NAMES`]) or by file path (`.gltf`, `.glb`,
/// `.obj`, `.ply`, `.toml`, Mitsuba 3 `.xml`), then validates it (see [`validate`]).
pub fn load(spec: &str) -> Result<Scene, SceneError> {
    let path = Path::new(spec);
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    let mut scene = match ext.as_deref() {
        Some("gltf" | "glb") => gltf_loader::load(path)?,
        Some("obj") => obj_loader::load(path)?,
        Some("toml") => toml_loader::load(path)?,
        Some("xml") => mitsuba_loader::load(path)?,
        Some("ply") => ply_loader::load(path)?,
        Some(other) if !builtin::NAMES.contains(&spec) => {
            return Err(SceneError::Unsupported {
                path: path.to_owned(),
                message: format!("unknown scene file extension '.{other}' (use .gltf, .glb, .obj, .ply, .toml or a Mitsuba 3 .xml)"),
            });
        }
        _ => builtin::build(spec)?,
    };
    // The scene's meshes as the tracer will hold them (every instance, with its BVH), before
    // anything builds on them.
    let (vertices, triangles) = scene
        .instances
        .iter()
        .filter_map(|i| scene.meshes.get(i.mesh as usize))
        .fold((0u64, 0u64), |(v, t), m| (v + m.positions.len() as u64, t + m.indices.len() as u64));
    glimpse_core::memory_budget::check_mesh(format!("scene {spec} ({triangles} triangles)"), vertices, triangles)
        .map_err(|e| SceneError::Invalid { source_name: spec.to_owned(), message: e.to_string() })?;
    // Mirrored placements keep their faces' orientation (once, on the composed scene).
    orient::orient_mirrored_instances(&mut scene);
    validate::validate(&mut scene, spec)?;
    Ok(scene)
}
