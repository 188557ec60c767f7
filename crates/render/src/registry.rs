//! Techniques by id (pbrt-v4's integrator registry). Each technique crate exposes its entries;
//! the command line assembles them, so a crate never needs to know the crates above it.

use crate::{Params, RenderError, Settings, Technique};
use glimpse_scene::Scene;

pub type Constructor = fn(&Scene, &Settings, &Params) -> Result<Box<dyn Technique>, RenderError>;

#[derive(Clone)]
pub struct TechniqueInfo {
    pub id: &'static str,
    /// The family it belongs to ("ambient occlusion", ...).
    pub family: &'static str,
    /// The exact technique this one approximates; `None` for references.
    pub reference: Option<&'static str>,
    pub description: &'static str,
    pub create: Constructor,
}

#[derive(Clone, Default)]
pub struct Registry {
    entries: Vec<TechniqueInfo>,
}

impl Registry {
    pub fn new(entries: impl IntoIterator<Item = TechniqueInfo>) -> Self {
        Self { entries: entries.into_iter().collect() }
    }

    pub fn all(&self) -> &[TechniqueInfo] {
        &self.entries
    }

    pub fn get(&self, id: &str) -> Result<&TechniqueInfo, RenderError> {
        self.entries.iter().find(|e| e.id == id).ok_or_else(|| RenderError::UnknownTechnique {
            id: id.to_owned(),
            known: self.entries.iter().map(|e| e.id).collect::<Vec<_>>().join(", "),
        })
    }

    /// Creates a technique, rejecting parameters it does not know.
    pub fn create(&self, id: &str, scene: &Scene, settings: &Settings, params: &Params) -> Result<Box<dyn Technique>, RenderError> {
        let info = self.get(id)?;
        let t = (info.create)(scene, settings, params)?;
        params.finish(id)?;
        note_material_fallback(id, scene);
        Ok(t)
    }
}

/// Only `pt` renders conductors and glass; every other technique shades them as diffuse
/// `base_color` (the closest model it has). Said once per process on stderr.
fn note_material_fallback(id: &str, scene: &Scene) {
    use std::sync::atomic::{AtomicBool, Ordering};
    static SAID: AtomicBool = AtomicBool::new(false);
    if id == "pt" {
        return;
    }
    if let Some(m) = scene.materials.iter().find(|m| m.needs_path_tracer())
        && !SAID.swap(true, Ordering::Relaxed)
    {
        eprintln!(
            "note: material '{}' is a {}: only pt renders it as such; {id} and the other techniques shade conductor and dielectric materials as diffuse base_color",
            m.name,
            m.model.name()
        );
    }
}
