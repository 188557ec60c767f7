//! Watertight ray–triangle intersection (Woop, Benthin and Wald 2013, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1)): no ray slips between two triangles that share an edge, which the
//! exact tracer must guarantee to be a ground truth. Double precision is used only when an edge
//! function is exactly zero.

use glimpse_core::{Ray, Vec3A};

/// A ray prepared for the watertight test and for slab tests against boxes.
#[derive(Clone, Copy, Debug)]
pub struct PreparedRay {
    pub origin: Vec3A,
    pub dir: Vec3A,
    /// 1/dir, with zero components replaced by a tiny signed value so slab tests never see NaN.
    pub inv_dir: Vec3A,
    /// The axis along which `dir` is largest in magnitude (the paper's `kz`).
    kz: usize,
    /// `dir[kx] / dir[kz]`, `dir[ky] / dir[kz]`, `1 / dir[kz]`, where kx, ky follow kz cyclically.
    shear: Vec3A,
}

impl PreparedRay {
    pub fn new(ray: &Ray) -> Self {
        let origin = Vec3A::from(ray.origin);
        let dir = Vec3A::from(ray.dir);
        let safe = |d: f32| if d.abs() > 1e-30 { d } else { 1e-30f32.copysign(d) };
        let inv_dir = Vec3A::new(1.0 / safe(dir.x), 1.0 / safe(dir.y), 1.0 / safe(dir.z));
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        // The paper swaps kx and ky when dir[kz] < 0 to keep the triangles' winding; the test
        // here is two-sided, and a swap only negates u, v, w, det and t_scaled exactly, so it is
        // left out (the results are bit-for-bit the same).
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        let shear = Vec3A::new(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
        Self { origin, dir, inv_dir, kz, shear }
    }

    /// Returns `(t, b1, b2)` for a hit with `0 < t < t_max`, where the hit point is
    /// `v0·(1−b1−b2) + v1·b1 + v2·b2`. Both faces are hit (no culling).
    #[inline]
    pub fn intersect_triangle(&self, v: &[Vec3A; 3], t_max: f32) -> Option<(f32, f32, f32)> {
        // One copy of the test per major axis, so the coordinates are picked at compile time
        // (indexing a SIMD vector by a run-time axis goes through memory). The branch goes the
        // same way for every triangle a ray meets.
        match self.kz {
            0 => self.intersect_along::<0>(v, t_max),
            1 => self.intersect_along::<1>(v, t_max),
            _ => self.intersect_along::<2>(v, t_max),
        }
    }

    #[inline(always)]
    fn intersect_along<const KZ: usize>(&self, v: &[Vec3A; 3], t_max: f32) -> Option<(f32, f32, f32)> {
        let (kx, ky) = ((KZ + 1) % 3, (KZ + 2) % 3);
        let a = v[0] - self.origin;
        let b = v[1] - self.origin;
        let c = v[2] - self.origin;
        let (sx, sy, sz) = (self.shear.x, self.shear.y, self.shear.z);
        let ax = a[kx] - sx * a[KZ];
        let ay = a[ky] - sy * a[KZ];
        let bx = b[kx] - sx * b[KZ];
        let by = b[ky] - sy * b[KZ];
        let cx = c[kx] - sx * c[KZ];
        let cy = c[ky] - sy * c[KZ];
        let mut u = cx * by - cy * bx;
        let mut vv = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || vv == 0.0 || w == 0.0 {
            // Exactly on an edge in single precision: decide the edge in double precision.
            let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
            u = (cx * by - cy * bx) as f32;
            vv = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + vv + w;
        if det == 0.0 {
            return None;
        }
        let az = sz * a[KZ];
        let bz = sz * b[KZ];
        let cz = sz * c[KZ];
        let t_scaled = u * az + vv * bz + w * cz;
        // Compare t = t_scaled / det against (0, t_max) without dividing, for either sign of det.
        let (t_scaled, det_abs) = if det < 0.0 { (-t_scaled, -det) } else { (t_scaled, det) };
        if t_scaled <= 0.0 || t_scaled >= t_max * det_abs {
            return None;
        }
        let inv = 1.0 / det;
        Some((t_scaled / det_abs, vv * inv, w * inv))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::{Rng, Vec3};

    fn tri() -> [Vec3A; 3] {
        [Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(0.0, 1.0, 0.0)]
    }

    #[test]
    fn hits_inside_with_correct_distance_and_barycentrics() {
        let r = PreparedRay::new(&Ray::new(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0)));
        let (t, b1, b2) = r.intersect_triangle(&tri(), f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-6 && (b1 - 0.25).abs() < 1e-6 && (b2 - 0.5).abs() < 1e-6);
        let back = PreparedRay::new(&Ray::new(Vec3::new(0.25, 0.5, -2.0), Vec3::new(0.0, 0.0, 1.0)));
        assert!(back.intersect_triangle(&tri(), f32::INFINITY).is_some(), "back faces are hit");
        assert!(r.intersect_triangle(&tri(), 1.9).is_none(), "t_max excludes");
        let behind = PreparedRay::new(&Ray::new(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.0, 0.0, 1.0)));
        assert!(behind.intersect_triangle(&tri(), f32::INFINITY).is_none());
    }

    #[test]
    fn no_ray_slips_through_a_shared_edge() {
        // Two triangles sharing the diagonal of a unit quad; rays aimed at the diagonal must hit
        // at least one of them, every time.
        let t0 = [Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(1.0, 1.0, 0.0)];
        let t1 = [Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(1.0, 1.0, 0.0), Vec3A::new(0.0, 1.0, 0.0)];
        let mut rng = Rng::new(11, 0);
        let mut misses = 0;
        for _ in 0..100_000 {
            let s = rng.next_f32();
            let target = Vec3::new(s, s, 0.0);
            let origin = Vec3::new(rng.next_f32() * 4.0 - 2.0, rng.next_f32() * 4.0 - 2.0, 1.0 + rng.next_f32());
            let r = PreparedRay::new(&Ray::new(origin, target - origin));
            if r.intersect_triangle(&t0, f32::INFINITY).is_none() && r.intersect_triangle(&t1, f32::INFINITY).is_none() {
                misses += 1;
            }
        }
        println!("rays through the shared edge that missed both triangles: {misses} of 100000");
        assert_eq!(misses, 0);
    }
}
