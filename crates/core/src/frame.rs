//! Orthonormal frames around a normal (Duff et al. 2017, "Building an Orthonormal Basis,
//! Revisited"), for turning hemisphere samples into world directions.

use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub x: Vec3,
    pub y: Vec3,
    pub z: Vec3,
}

impl Frame {
    /// A right-handed frame whose `z` is the unit vector `n`.
    pub fn from_z(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let x = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let y = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { x, y, z: n }
    }

    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }

    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_for_many_normals() {
        let mut rng = crate::Rng::new(7, 0);
        for _ in 0..1000 {
            let n = crate::sampling::uniform_sphere(rng.next_2d());
            let f = Frame::from_z(n);
            assert!((f.x.length() - 1.0).abs() < 1e-4 && (f.y.length() - 1.0).abs() < 1e-4);
            assert!(f.x.dot(f.y).abs() < 1e-4 && f.x.dot(f.z).abs() < 1e-4 && f.y.dot(f.z).abs() < 1e-4);
            assert!((f.x.cross(f.y) - f.z).length() < 1e-3, "right-handed");
            let v = crate::sampling::uniform_sphere(rng.next_2d());
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-4);
        }
    }
}
