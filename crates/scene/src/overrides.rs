//! Scene overrides from the command line (`--scale`, `--env`, `--sun`, `--light`, `--camera`,
//! `--filter`, `--film-samples`), applied the same way by every command that takes a scene (`render`, `eval`,
//! `play`, `bench`, `view`), then the default light for a scene that still has none
//! ([`crate::auto::ensure_light`]).

use crate::{Camera, Environment, Filter, Light, Scene};
use glimpse_core::{Image, Vec3};
use std::path::PathBuf;

#[derive(Clone, Debug, PartialEq)]
pub struct SceneOverrides {
    /// Every length times this (the same picture in other units, [`Scene::rescale`]); applied
    /// first, so the other overrides' positions are in the scaled units.
    pub scale: f32,
    pub filter: Option<Filter>,
    pub film_samples: Option<u32>,
    /// Equirectangular .hdr/.exr replacing the scene's environment, and its scale.
    pub env: Option<PathBuf>,
    pub env_scale: f32,
    /// A sun coming *from* this direction, with this irradiance (white).
    pub sun: Option<Vec3>,
    pub sun_radiance: f32,
    pub lights: Vec<Light>,
    pub camera: Option<Camera>,
}

impl Default for SceneOverrides {
    fn default() -> Self {
        Self {
            scale: 1.0,
            filter: None,
            film_samples: None,
            env: None,
            env_scale: 1.0,
            sun: None,
            sun_radiance: 3.0,
            lights: Vec::new(),
            camera: None,
        }
    }
}

impl SceneOverrides {
    /// Applies the overrides, then the default light if the scene still has none. Returns
    /// whether that default light was added (the caller says so once); the error names the
    /// option.
    pub fn apply(&self, scene: &mut Scene) -> Result<bool, String> {
        if self.scale != 1.0 {
            scene.rescale(self.scale)?;
        }
        if let Some(filter) = self.filter {
            scene.film.filter = filter;
        }
        if let Some(n) = self.film_samples {
            scene.film.samples = n;
        }
        if !(self.env_scale.is_finite() && self.env_scale >= 0.0) {
            return Err(format!("--env-scale {}: must be a finite number ≥ 0", self.env_scale));
        }
        if !(self.sun_radiance.is_finite() && self.sun_radiance >= 0.0) {
            return Err(format!("--sun-radiance {}: must be a finite number ≥ 0", self.sun_radiance));
        }
        if let Some(path) = &self.env {
            let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
            if !matches!(ext.as_deref(), Some("hdr" | "exr")) {
                return Err(format!("--env {}: the environment map must be a .hdr or .exr file", path.display()));
            }
            let image = Image::read(path).map_err(|e| format!("--env {}: {e}", path.display()))?;
            scene.environment = Some(Environment::new(image, self.env_scale));
        }
        if let Some(dir) = self.sun {
            // The light travels away from the sun.
            scene.lights.push(Light::directional(-dir, Vec3::splat(self.sun_radiance)));
        }
        scene.lights.extend(self.lights.iter().cloned());
        if let Some(camera) = &self.camera {
            scene.camera = Some(camera.clone());
        }
        Ok(crate::auto::ensure_light(scene))
    }

    /// A stable description for cache keys (a reference rendered with other overrides is another
    /// image). The environment is named by path, size and modification time.
    pub fn cache_key(&self) -> String {
        let env = self.env.as_ref().map(|p| {
            let meta = std::fs::metadata(p).ok();
            let stamp = meta.as_ref().and_then(|m| m.modified().ok()).and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok());
            format!("{}:{}:{:?}", p.display(), meta.map_or(0, |m| m.len()), stamp)
        });
        format!(
            "{} {:?} {:?} {env:?} {} {:?} {} {:?} {:?}",
            self.scale, self.filter, self.film_samples, self.env_scale, self.sun, self.sun_radiance, self.lights, self.camera
        )
    }
}
