//! Animation as a function of time `t` in seconds: rigid motion of instances and lights
//! ([`Motion`]) and vertex deformation of meshes ([`Deformation`]). Everything is evaluated
//! directly from `t` (no hidden state), so any frame can be rendered on its own.

use glimpse_core::{Mat4, Quat, Vec3};
use std::f32::consts::TAU;

/// Translation, rotation, scale; the matrix is `T · R · S` (glTF's order).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE }
    }
}

impl Transform {
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// One keyframe of a rigid track.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransformKey {
    pub time: f32,
    pub transform: Transform,
}

/// Rigid motion: the object-to-world matrix at time `t`.
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    Fixed(Mat4),
    /// Keys sorted by time; translation and scale are interpolated linearly, rotation by slerp;
    /// before the first key and after the last the end key holds (glTF's clamping).
    Keyframes(Vec<TransformKey>),
    /// `base`, then a rotation about the line through `center` along `axis`, by
    /// `2π (t / period_s + phase)`. A light at `center + r` orbits; an object centred on `center`
    /// spins in place.
    Orbit {
        base: Mat4,
        center: Vec3,
        axis: Vec3,
        period_s: f32,
        phase: f32,
    },
}

impl Default for Motion {
    fn default() -> Self {
        Motion::Fixed(Mat4::IDENTITY)
    }
}

impl Motion {
    pub fn is_static(&self) -> bool {
        match self {
            Motion::Fixed(_) => true,
            Motion::Keyframes(k) => k.len() <= 1,
            Motion::Orbit { .. } => false,
        }
    }

    pub fn at(&self, t: f32) -> Mat4 {
        match self {
            Motion::Fixed(m) => *m,
            Motion::Keyframes(keys) => interpolate_keys(keys, t).matrix(),
            Motion::Orbit { base, center, axis, period_s, phase } => {
                let angle = TAU * (t / period_s + phase);
                let rot = Mat4::from_translation(*center)
                    * Mat4::from_axis_angle(axis.normalize_or(Vec3::Y), angle)
                    * Mat4::from_translation(-*center);
                rot * *base
            }
        }
    }
}

fn interpolate_keys(keys: &[TransformKey], t: f32) -> Transform {
    let Some(first) = keys.first() else { return Transform::default() };
    if t <= first.time || keys.len() == 1 {
        return first.transform;
    }
    let i = keys.partition_point(|k| k.time <= t);
    if i >= keys.len() {
        return keys[keys.len() - 1].transform;
    }
    let (a, b) = (&keys[i - 1], &keys[i]);
    let s = ((t - a.time) / (b.time - a.time).max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
    Transform {
        translation: a.transform.translation.lerp(b.transform.translation, s),
        rotation: a.transform.rotation.slerp(b.transform.rotation, s),
        scale: a.transform.scale.lerp(b.transform.scale, s),
    }
}

/// Vertex animation of a mesh, in object space.
#[derive(Clone, Debug, PartialEq)]
pub enum Deformation {
    /// Whole-mesh position keyframes (each the mesh's vertex count), interpolated linearly and
    /// clamped at the ends.
    Keyframes { times: Vec<f32>, positions: Vec<Vec<Vec3>> },
    /// A travelling sine wave: `p + displacement · amplitude · sin(2π (p·direction / wavelength − t / period_s))`.
    Wave { amplitude: f32, wavelength: f32, period_s: f32, direction: Vec3, displacement: Vec3 },
}

impl Deformation {
    /// Positions at time `t`, given the rest positions.
    pub fn positions_at(&self, rest: &[Vec3], t: f32) -> Vec<Vec3> {
        match self {
            Deformation::Keyframes { times, positions } => {
                if times.is_empty() {
                    return rest.to_vec();
                }
                let i = times.partition_point(|&k| k <= t);
                if i == 0 {
                    return positions[0].clone();
                }
                if i >= times.len() {
                    return positions[times.len() - 1].clone();
                }
                let s = ((t - times[i - 1]) / (times[i] - times[i - 1]).max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
                positions[i - 1].iter().zip(&positions[i]).map(|(a, b)| a.lerp(*b, s)).collect()
            }
            Deformation::Wave { amplitude, wavelength, period_s, direction, displacement } => rest
                .iter()
                .map(|p| *p + *displacement * (amplitude * (TAU * (p.dot(*direction) / wavelength - t / period_s)).sin()))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keyframes_interpolate_and_clamp() {
        let key = |time, x| TransformKey { time, transform: Transform { translation: Vec3::new(x, 0.0, 0.0), ..Default::default() } };
        let m = Motion::Keyframes(vec![key(0.0, 0.0), key(2.0, 4.0)]);
        assert_eq!(m.at(-1.0).w_axis.x, 0.0);
        assert_eq!(m.at(1.0).w_axis.x, 2.0);
        assert_eq!(m.at(5.0).w_axis.x, 4.0);
        assert!(!m.is_static());
    }

    #[test]
    fn orbit_returns_after_one_period() {
        let m = Motion::Orbit {
            base: Mat4::from_translation(Vec3::new(1.0, 0.0, 0.0)),
            center: Vec3::ZERO,
            axis: Vec3::Y,
            period_s: 4.0,
            phase: 0.0,
        };
        let p = |t| m.at(t).transform_point3(Vec3::ZERO);
        assert!((p(0.0) - Vec3::X).length() < 1e-5);
        assert!((p(1.0) - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-5, "quarter turn about +y: {}", p(1.0));
        assert!((p(4.0) - Vec3::X).length() < 1e-4);
    }

    #[test]
    fn wave_moves_vertices_along_displacement() {
        let d = Deformation::Wave { amplitude: 0.5, wavelength: 2.0, period_s: 1.0, direction: Vec3::X, displacement: Vec3::Y };
        let rest = vec![Vec3::new(0.5, 0.0, 0.0)];
        assert!((d.positions_at(&rest, 0.0)[0].y - 0.5).abs() < 1e-5);
        assert!((d.positions_at(&rest, 0.5)[0].y + 0.5).abs() < 1e-5);
    }
}
