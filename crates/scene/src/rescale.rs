//! The same scene in other length units (`--scale S`): every length times `S`, the picture
//! unchanged. Real content comes in metres, centimetres or millimetres (glTF says metres; OBJ and
//! PLY say nothing), so a default that hides an absolute length shows up as a different image of
//! the same scene; `crates/eval/tests/scale_invariance.rs` renders every technique at several
//! scales and compares.
//!
//! What is scaled: vertex positions (and deformation keyframes, wave amplitude and wavelength),
//! the translation of every rigid motion (fixed, keyframed, orbit base and centre), light
//! positions, the camera's position and target. Radiance is kept: emission and the environment
//! are unchanged, directional irradiance too, and point and spot intensities are multiplied by
//! `S²` so that their irradiance `I / d²` at the scaled distances is the same.

use crate::{Deformation, Motion, Scene};
use glimpse_core::Mat4;

impl Scene {
    /// Multiplies every length by `s` (finite, > 0) keeping the image; see the module comment.
    pub fn rescale(&mut self, s: f32) -> Result<(), String> {
        if !(s.is_finite() && s > 0.0) {
            return Err(format!("--scale {s}: must be a finite number > 0"));
        }
        for mesh in &mut self.meshes {
            mesh.positions.iter_mut().for_each(|p| *p *= s);
            match &mut mesh.deformation {
                Some(Deformation::Keyframes { positions, .. }) => positions.iter_mut().flatten().for_each(|p| *p *= s),
                Some(Deformation::Wave { amplitude, wavelength, .. }) => {
                    *amplitude *= s;
                    *wavelength *= s;
                }
                None => {}
            }
        }
        for instance in &mut self.instances {
            instance.motion.scale_translation(s);
        }
        for light in &mut self.lights {
            light.position *= s;
            light.motion.scale_translation(s);
            if !matches!(light.kind, crate::LightKind::Directional) {
                light.intensity *= s * s;
            }
        }
        if let Some(camera) = &mut self.camera {
            camera.position *= s;
            camera.target *= s;
        }
        Ok(())
    }
}

impl Motion {
    /// Multiplies the translation of the motion by `s`: with positions also times `s`, the
    /// world positions are `s` times the old ones at every time (`M (s p) + s t = s (M p + t)`).
    fn scale_translation(&mut self, s: f32) {
        let scale = |m: &mut Mat4| m.w_axis = (m.w_axis.truncate() * s).extend(m.w_axis.w);
        match self {
            Motion::Fixed(m) => scale(m),
            Motion::Keyframes(keys) => keys.iter_mut().for_each(|k| k.transform.translation *= s),
            Motion::Orbit { base, center, .. } => {
                scale(base);
                *center *= s;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::Scene;

    /// Every world position of every frame (triangles, lights, camera) scales by `s`.
    #[test]
    fn world_positions_scale_at_every_time() {
        for name in ["cornell-lit", "cornell-dynamic", "deforming"] {
            let scene = crate::load(name).unwrap();
            let mut scaled = scene.clone();
            scaled.rescale(100.0).unwrap();
            for t in [0.0, 0.7] {
                let (a, b) = (scene.at(t), scaled.at(t));
                let (ta, tb) = (a.world_triangles(), b.world_triangles());
                assert_eq!(ta.len(), tb.len());
                for (x, y) in ta.iter().flatten().zip(tb.iter().flatten()) {
                    assert!((*x * 100.0 - *y).length() <= 1e-3 * (1.0 + y.length()), "{name} t={t}: {x} → {y}");
                }
                for (x, y) in a.lights.iter().zip(&b.lights) {
                    assert!((x.position * 100.0 - y.position).length() <= 1e-3 * (1.0 + y.position.length()), "{name}: light");
                }
            }
        }
        let mut s = Scene::default();
        assert!(s.rescale(0.0).is_err() && s.rescale(f32::NAN).is_err() && s.rescale(-1.0).is_err());
    }
}
