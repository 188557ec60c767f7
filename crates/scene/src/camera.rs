//! A pinhole perspective camera. Pixel (0,0) is the top-left corner; a pixel's continuous
//! coordinates run over [x, x+1) × [y, y+1).

use glimpse_core::{Aabb, Ray, Vec3};

/// The image axis along which [`Camera::fov`] is measured (Mitsuba's `fov_axis`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FovAxis {
    X,
    #[default]
    Y,
    /// The shorter image side.
    Smaller,
    /// The longer image side.
    Larger,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Field of view in radians, across the image along `fov_axis`.
    pub fov: f32,
    pub fov_axis: FovAxis,
}

impl Camera {
    pub fn look_at(position: Vec3, target: Vec3, up: Vec3, fov_y_degrees: f32) -> Self {
        Self::vertical(position, target, up, fov_y_degrees.to_radians())
    }

    /// A camera whose field of view `fov_y` (radians) is vertical.
    pub fn vertical(position: Vec3, target: Vec3, up: Vec3, fov_y: f32) -> Self {
        Self { position, target, up, fov: fov_y, fov_axis: FovAxis::Y }
    }

    /// The vertical field of view (radians) on an image of `width × height`: `fov` converted
    /// through equal tangent-plane scales, tan(fov_y/2) = tan(fov_x/2) · height/width.
    pub fn fov_y(&self, width: u32, height: u32) -> f32 {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        let horizontal = match self.fov_axis {
            FovAxis::X => true,
            FovAxis::Y => false,
            FovAxis::Smaller => w < h,
            FovAxis::Larger => w > h,
        };
        if horizontal { 2.0 * ((self.fov * 0.5).tan() * h / w).atan() } else { self.fov }
    }

    /// A camera on the +z side of the box, slightly above, looking at its centre from far enough
    /// that the bounding sphere fills the view.
    pub fn framing(bounds: Aabb, aspect: f32) -> Self {
        Self::framing_from(bounds, aspect, Vec3::new(0.0, 0.25, 1.0))
    }

    /// A camera in direction `dir` from the box's centre (outside its bounding sphere), looking
    /// at the centre, far enough that the bounding sphere fills the view.
    pub fn framing_from(bounds: Aabb, aspect: f32, dir: Vec3) -> Self {
        let fov_y = 45f32.to_radians();
        let center = bounds.center();
        let dir = dir.normalize_or(Vec3::Z);
        // Straight up or down would make `up` parallel to the view direction.
        let up_hint = if dir.cross(Vec3::Y).length() < 1e-3 { Vec3::Z } else { Vec3::Y };
        let forward = -dir;
        let right = forward.cross(up_hint).normalize();
        let up = right.cross(forward);
        // The nearest distance along `dir` at which every corner of the box lies in front of the
        // camera and inside the image with a 10 % border: tight around the box, not around its
        // bounding sphere (which left a compact object a sixth of the frame).
        let tan_v = (fov_y * 0.5).tan() * 0.9;
        let tan_h = tan_v * aspect.max(1e-3);
        let mut distance = 1e-3f32;
        for k in 0..8 {
            let corner = Vec3::new(
                if k & 1 == 0 { bounds.min.x } else { bounds.max.x },
                if k & 2 == 0 { bounds.min.y } else { bounds.max.y },
                if k & 4 == 0 { bounds.min.z } else { bounds.max.z },
            );
            let o = corner - center;
            let (x, y, z) = (o.dot(right), o.dot(up), o.dot(forward));
            // Depth of the corner: distance + z; in the image: |x| ≤ tan_h·depth, |y| ≤ tan_v·depth.
            distance = distance.max(-z + 1e-3).max(x.abs() / tan_h - z).max(y.abs() / tan_v - z);
        }
        if !distance.is_finite() {
            distance = (bounds.extent().length() * 0.5).max(1e-3) / (fov_y * 0.5).sin();
        }
        Self::vertical(center + dir * distance, center, up_hint, fov_y)
    }

    /// The primary ray through continuous pixel coordinates `(px, py)` of a `width × height` image.
    pub fn ray(&self, px: f32, py: f32, width: u32, height: u32) -> Ray {
        let forward = (self.target - self.position).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        let tan_half = (self.fov_y(width, height) * 0.5).tan();
        let aspect = width as f32 / height as f32;
        let sx = (2.0 * px / width as f32 - 1.0) * tan_half * aspect;
        let sy = (1.0 - 2.0 * py / height as f32) * tan_half;
        Ray::new(self.position, (forward + right * sx + up * sy).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_at_target_and_corners_are_symmetric() {
        let c = Camera::look_at(Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 60.0);
        let r = c.ray(50.0, 25.0, 100, 50);
        assert!((r.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        let tl = c.ray(0.0, 0.0, 100, 50).dir;
        assert!(tl.x < 0.0 && tl.y > 0.0, "top-left pixel looks up and left: {tl}");
        let vertical = 2.0 * (c.ray(50.0, 0.0, 100, 50).dir.y).asin();
        assert!((vertical - 60f32.to_radians()).abs() < 1e-4);
    }

    #[test]
    fn framing_sees_every_corner() {
        let b = Aabb::new(Vec3::new(-1.0, 0.0, -2.0), Vec3::new(3.0, 1.0, 0.5));
        let c = Camera::framing(b, 16.0 / 9.0);
        let forward = (c.target - c.position).normalize();
        let right = forward.cross(c.up).normalize();
        let up = right.cross(forward);
        let tan_v = (c.fov * 0.5).tan();
        let mut widest: f32 = 0.0;
        for i in 0..8 {
            let p = Vec3::new([b.min.x, b.max.x][i & 1], [b.min.y, b.max.y][(i >> 1) & 1], [b.min.z, b.max.z][i >> 2]);
            let o = p - c.position;
            let depth = o.dot(forward);
            let (x, y) = (o.dot(right) / (depth * tan_v * 16.0 / 9.0), o.dot(up) / (depth * tan_v));
            assert!(depth > 0.0 && x.abs() <= 1.0 && y.abs() <= 1.0, "corner {p} outside the view ({x}, {y})");
            widest = widest.max(x.abs()).max(y.abs());
        }
        // Tight: some corner reaches the 10 % border.
        assert!(widest > 0.85, "the box fills too little of the view: {widest}");
    }

    #[test]
    fn fov_axis_measures_the_named_side() {
        let mut c = Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 60.0);
        // The angle between the rays through the middles of opposite image edges.
        let across = |c: &Camera, w: u32, h: u32, horizontal: bool| {
            let (a, b) = if horizontal {
                (c.ray(0.0, h as f32 / 2.0, w, h).dir, c.ray(w as f32, h as f32 / 2.0, w, h).dir)
            } else {
                (c.ray(w as f32 / 2.0, 0.0, w, h).dir, c.ray(w as f32 / 2.0, h as f32, w, h).dir)
            };
            a.angle_between(b).to_degrees()
        };
        for (axis, w, h, horizontal) in [
            (FovAxis::Y, 200, 100, false),
            (FovAxis::X, 200, 100, true),
            (FovAxis::X, 100, 200, true),
            (FovAxis::Smaller, 200, 100, false),
            (FovAxis::Smaller, 100, 200, true),
            (FovAxis::Larger, 200, 100, true),
            (FovAxis::Larger, 100, 200, false),
        ] {
            c.fov_axis = axis;
            let got = across(&c, w, h, horizontal);
            assert!((got - 60.0).abs() < 1e-3, "{axis:?} on {w}x{h}: {got}°");
        }
    }
}
