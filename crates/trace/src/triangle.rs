//! Watertight ray–triangle intersection (Woop, Benthin and Wald 2013, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1)): no ray slips between two triangles that share an edge, which the
//! exact tracer must guarantee to be a ground truth. Double precision is used only when an edge
//! function is exactly zero.

use glimpse_core::glam::Vec3Swizzles;
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
        let a = dir.abs();
        let tiny = Vec3A::splat(1e-30);
        let inv_dir = Vec3A::ONE / Vec3A::select(a.cmpgt(tiny), dir, tiny.copysign(dir));
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        // The paper swaps kx and ky when dir[kz] < 0 to keep the triangles' winding; the test
        // here is two-sided, and a swap only negates u, v, w, det and t_scaled exactly, so it is
        // left out (the results are the same values; a zero barycentric may change sign).
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        let d = dir.to_array(); // array indexing, not a branch per axis
        let shear = Vec3A::new(d[kx], d[ky], 1.0) / d[kz];
        Self { origin, dir, inv_dir, kz, shear }
    }

    /// The axis along which the direction is largest in magnitude (the paper's `kz`).
    pub fn kz(&self) -> usize {
        self.kz
    }

    /// `dir[kx] / dir[kz]`, `dir[ky] / dir[kz]`, `1 / dir[kz]` (the GPU tracer uploads these bits).
    pub fn shear(&self) -> Vec3A {
        self.shear
    }

    /// Returns `(t, b1, b2)` for a hit with `0 < t < t_max`, where the hit point is
    /// `v0·(1−b1−b2) + v1·b1 + v2·b2`. Both faces are hit (no culling).
    #[inline]
    pub fn intersect_triangle(&self, v: &[Vec3A; 3], t_max: f32) -> Option<(f32, f32, f32)> {
        match self.kz {
            0 => self.intersect_along::<0>(v, t_max),
            1 => self.intersect_along::<1>(v, t_max),
            _ => self.intersect_along::<2>(v, t_max),
        }
    }

    /// The axis along which the direction is largest in magnitude: the `KZ` that
    /// [`Self::intersect_along`] must be called with.
    pub fn major_axis(&self) -> usize {
        self.kz
    }

    /// [`Self::intersect_triangle`] for a ray whose [`Self::major_axis`] is `KZ`. One copy of
    /// the test per major axis, so the coordinates are picked at compile time (indexing a SIMD
    /// vector by a run-time axis goes through memory); the tracer picks the copy once per ray.
    ///
    /// The three vertices' coordinates sit side by side in SIMD lanes, and every lane computes
    /// exactly the scalar expression of the paper (same operands, same order), so the result is
    /// that of a scalar implementation, bit for bit.
    #[inline(always)]
    pub fn intersect_along<const KZ: usize>(&self, v: &[Vec3A; 3], t_max: f32) -> Option<(f32, f32, f32)> {
        debug_assert_eq!(KZ, self.kz);
        let (kx, ky) = ((KZ + 1) % 3, (KZ + 2) % 3);
        let a = v[0] - self.origin;
        let b = v[1] - self.origin;
        let c = v[2] - self.origin;
        // One coordinate of the three vertices: (a[k], b[k], c[k]).
        let coordinate = |k: usize| Vec3A::new(a[k], b[k], c[k]);
        let z = coordinate(KZ);
        // Sheared into the ray's space: x = (ax, bx, cx), y = (ay, by, cy).
        let x = coordinate(kx) - z * self.shear.x;
        let y = coordinate(ky) - z * self.shear.y;
        // Edge functions (w, u, v): w = bx·ay − by·ax, u = cx·by − cy·bx, v = ax·cy − ay·cx.
        let mut edges = x.yzx() * y - y.yzx() * x;
        if edges.cmpeq(Vec3A::ZERO).any() {
            // Exactly on an edge in single precision: decide the edge in double precision.
            let (ax, bx, cx) = (x.x as f64, x.y as f64, x.z as f64);
            let (ay, by, cy) = (y.x as f64, y.y as f64, y.z as f64);
            edges = Vec3A::new((bx * ay - by * ax) as f32, (cx * by - cy * bx) as f32, (ax * cy - ay * cx) as f32);
        }
        if edges.cmplt(Vec3A::ZERO).any() && edges.cmpgt(Vec3A::ZERO).any() {
            return None;
        }
        let (w, u, vv) = (edges.x, edges.y, edges.z);
        let det = u + vv + w;
        if det == 0.0 {
            return None;
        }
        // (w·cz, u·az, v·bz) with (az, bz, cz) = sz·z.
        let weighted = edges * (z * self.shear.z).zxy();
        let t_scaled = weighted.y + weighted.z + weighted.x;
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

    /// The paper's scalar algorithm, written out as the first version of this file had it
    /// (with the kx/ky swap and run-time axis indices).
    fn scalar_reference(ray: &Ray, v: &[Vec3A; 3], t_max: f32) -> Option<(f32, f32, f32)> {
        let (origin, dir) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
        let d = dir.abs();
        let kz = if d.x >= d.y && d.x >= d.z {
            0
        } else if d.y >= d.z {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let (sx, sy, sz) = (dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
        let (a, b, c) = (v[0] - origin, v[1] - origin, v[2] - origin);
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let (mut u, mut vv, mut w) = (cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax);
        if u == 0.0 || vv == 0.0 || w == 0.0 {
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
        let t_scaled = u * (sz * a[kz]) + vv * (sz * b[kz]) + w * (sz * c[kz]);
        let (t_scaled, det_abs) = if det < 0.0 { (-t_scaled, -det) } else { (t_scaled, det) };
        if t_scaled <= 0.0 || t_scaled >= t_max * det_abs {
            return None;
        }
        Some((t_scaled / det_abs, vv * (1.0 / det), w * (1.0 / det)))
    }

    /// Same hits, same t and barycentrics to the bit, except that a zero barycentric may be −0
    /// in one and +0 in the other (the reference's kx/ky swap negates the edge functions).
    #[test]
    fn simd_form_gives_exactly_the_scalar_algorithms_results() {
        let mut rng = Rng::new(21, 0);
        let mut p = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        let (mut hits, mut on_grid) = (0, 0);
        for i in 0..200_000 {
            // Every fourth case on a coarse grid, so edges and vertices are hit exactly and the
            // double-precision path runs; the others random.
            let snap = |v: Vec3| if i % 4 == 0 { (v * 4.0).round() / 4.0 } else { v };
            let v = [snap(p()), snap(p()), snap(p())].map(Vec3A::from);
            let origin = snap(p() * 3.0);
            let target = snap(p());
            let ray = Ray::new(origin, target - origin);
            let t_max = if i % 3 == 0 { f32::INFINITY } else { 0.5 + p().x.abs() };
            let (ours, reference) = (PreparedRay::new(&ray).intersect_triangle(&v, t_max), scalar_reference(&ray, &v, t_max));
            let bits = |h: Option<(f32, f32, f32)>| h.map(|(t, b1, b2)| [t, b1, b2].map(|x| (x + 0.0).to_bits()));
            assert_eq!(bits(ours), bits(reference), "case {i}: {ray:?} {v:?} t_max {t_max}: {ours:?} vs {reference:?}");
            hits += ours.is_some() as u32;
            on_grid += (i % 4 == 0 && ours.is_some()) as u32;
        }
        println!("{hits} hits ({on_grid} on the grid) of 200000, all identical");
        assert!(hits > 10_000 && on_grid > 1_000);
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
