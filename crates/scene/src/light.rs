//! Punctual lights (KHR_lights_punctual's model). Area lights are not here: every triangle
//! whose material emits is an area light (see [`crate::frame::EmissiveTriangle`]).

use crate::Motion;
use glimpse_core::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Radiant intensity `intensity` (W/sr) in every direction.
    Point,
    /// A point light limited to a cone around `direction`, with smooth falloff between the
    /// inner and outer half-angles (radians), as glTF's spot.
    Spot { inner_angle: f32, outer_angle: f32 },
    /// Parallel light travelling along `direction`; `intensity` is irradiance (W/m²) on a
    /// surface facing it.
    Directional,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub kind: LightKind,
    /// RGB intensity (W/sr for point and spot, W/m² for directional).
    pub intensity: Vec3,
    /// Position in the light's local frame (ignored for directional lights).
    pub position: Vec3,
    /// Direction the light travels, in the local frame (spot and directional).
    pub direction: Vec3,
    /// Local-to-world motion, applied to `position` and `direction`.
    pub motion: Motion,
}

impl Light {
    pub fn point(position: Vec3, intensity: Vec3) -> Self {
        Self { kind: LightKind::Point, intensity, position, direction: -Vec3::Y, motion: Motion::default() }
    }

    pub fn spot(position: Vec3, direction: Vec3, intensity: Vec3, inner_angle: f32, outer_angle: f32) -> Self {
        Self {
            kind: LightKind::Spot { inner_angle, outer_angle },
            intensity,
            position,
            direction: direction.normalize(),
            motion: Motion::default(),
        }
    }

    pub fn directional(direction: Vec3, irradiance: Vec3) -> Self {
        Self {
            kind: LightKind::Directional,
            intensity: irradiance,
            position: Vec3::ZERO,
            direction: direction.normalize(),
            motion: Motion::default(),
        }
    }

    pub fn with_motion(mut self, motion: Motion) -> Self {
        self.motion = motion;
        self
    }
}
