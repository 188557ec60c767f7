//! The half-cube map parameterization (paper Sec. 4.2–4.3: "half-cube map", z = the shading
//! normal; texel solid angles after Driscoll [29]). The paper gives no layout; this is the spec's
//! proposal (§5.4): an unfolded hemicube in one N×N square with scaled coordinates u, v ∈ [−2, 2]:
//! the centre |u|,|v| ≤ 1 is the top face (+z), the four strips are the half side faces, the four
//! corner squares are unused (zero solid angle, zero value). All texels have the same size on the
//! cube, so Σ ΔΩ = 2π exactly.

use glimpse_core::{Vec2, Vec3};

/// Driscoll's A(x, y) = atan2(xy, √(x²+y²+1)): the solid angle of the face rectangle
/// [0,x]×[0,y] at unit distance.
fn area_element(x: f64, y: f64) -> f64 {
    (x * y).atan2((x * x + y * y + 1.0).sqrt())
}

/// Face coordinates (a, b) of (u, v) and which face: 0 top, 1..4 sides, `None` in a corner.
/// On a side face, `b` ∈ [0, 1] is the height above the horizon and `a` ∈ [−1, 1] the lateral
/// coordinate.
fn face_coords(u: f64, v: f64) -> Option<(u8, f64, f64)> {
    let (au, av) = (u.abs(), v.abs());
    if au <= 1.0 && av <= 1.0 {
        Some((0, u, v))
    } else if au > 1.0 && av <= 1.0 {
        Some((if u > 0.0 { 1 } else { 2 }, v, 2.0 - au))
    } else if av > 1.0 && au <= 1.0 {
        Some((if v > 0.0 { 3 } else { 4 }, u, 2.0 - av))
    } else {
        None
    }
}

/// The unnormalized cube point of (u, v) (outside the corners).
fn cube_point(u: f32, v: f32) -> Option<Vec3> {
    let (au, av) = (u.abs(), v.abs());
    if au <= 1.0 && av <= 1.0 {
        Some(Vec3::new(u, v, 1.0))
    } else if au > 1.0 && av <= 1.0 {
        Some(Vec3::new(u.signum(), v, 2.0 - au))
    } else if av > 1.0 && au <= 1.0 {
        Some(Vec3::new(u, v.signum(), 2.0 - av))
    } else {
        None
    }
}

/// A half-cube map layout of N×N texels (N a power of two, at least 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HalfCube {
    pub n: u32,
}

impl HalfCube {
    pub fn new(n: u32) -> Self {
        debug_assert!(n.is_power_of_two() && n >= 4);
        Self { n }
    }

    pub fn texels(&self) -> usize {
        (self.n * self.n) as usize
    }

    /// (u, v) ∈ [−2, 2]² of a point of texel (x, y) at fractional offset `f` ∈ [0,1)².
    pub fn uv(&self, x: u32, y: u32, f: Vec2) -> Vec2 {
        let s = 4.0 / self.n as f32;
        Vec2::new(-2.0 + (x as f32 + f.x) * s, -2.0 + (y as f32 + f.y) * s)
    }

    /// Unit direction (local frame, z ≥ 0) of (u, v); `None` in the unused corners.
    pub fn direction(uv: Vec2) -> Option<Vec3> {
        cube_point(uv.x, uv.y).map(|p| p.normalize())
    }

    /// Unit direction through the centre of texel (x, y); `None` for a corner texel.
    pub fn texel_direction(&self, x: u32, y: u32) -> Option<Vec3> {
        Self::direction(self.uv(x, y, Vec2::splat(0.5)))
    }

    /// (u, v) of a direction with z ≥ 0 (the spec's inverse).
    pub fn uv_of(d: Vec3) -> Vec2 {
        let (ax, ay, z) = (d.x.abs(), d.y.abs(), d.z.max(0.0));
        if z >= ax.max(ay) {
            Vec2::new(d.x / z, d.y / z)
        } else if ax >= ay {
            Vec2::new(d.x.signum() * (2.0 - z / ax), d.y / ax)
        } else {
            Vec2::new(d.x / ay, d.y.signum() * (2.0 - z / ay))
        }
    }

    /// Texel (x, y) containing direction `d` (z ≥ 0); never a corner texel.
    pub fn texel_of(&self, d: Vec3) -> (u32, u32) {
        let uv = Self::uv_of(d);
        let n = self.n as f32;
        let x = (((uv.x + 2.0) * 0.25 * n) as i64).clamp(0, self.n as i64 - 1) as u32;
        let y = (((uv.y + 2.0) * 0.25 * n) as i64).clamp(0, self.n as i64 - 1) as u32;
        // Rounding at a face edge can land in a corner: move back to the nearer strip.
        let q = self.n / 4;
        let corner = |c: u32| c < q || c >= 3 * q;
        if corner(x) && corner(y) {
            let (fu, fv) = (uv.x.abs(), uv.y.abs());
            if fu < fv { (x.clamp(q, 3 * q - 1), y) } else { (x, y.clamp(q, 3 * q - 1)) }
        } else {
            (x, y)
        }
    }

    /// Solid angle of texel (x, y) (Driscoll), 0 for a corner texel.
    pub fn solid_angle(&self, x: u32, y: u32) -> f64 {
        let s = 4.0 / self.n as f64;
        let (u0, v0) = (-2.0 + x as f64 * s, -2.0 + y as f64 * s);
        let (uc, vc) = (u0 + 0.5 * s, v0 + 0.5 * s);
        let Some((face, _, _)) = face_coords(uc, vc) else {
            return 0.0;
        };
        // Face rectangle [a0,a1]×[b0,b1] (b is the height on side faces).
        let (a0, a1, b0, b1) = match face {
            0 => (u0, u0 + s, v0, v0 + s),
            1 | 2 => {
                let (p, q) = ((2.0 - u0.abs()), (2.0 - (u0 + s).abs()));
                (v0, v0 + s, p.min(q), p.max(q))
            }
            _ => {
                let (p, q) = ((2.0 - v0.abs()), (2.0 - (v0 + s).abs()));
                (u0, u0 + s, p.min(q), p.max(q))
            }
        };
        (area_element(a0, b0) - area_element(a0, b1) - area_element(a1, b0) + area_element(a1, b1)).abs()
    }

    /// All texel solid angles, row-major.
    pub fn solid_angles(&self) -> Vec<f64> {
        (0..self.n).flat_map(|y| (0..self.n).map(move |x| (x, y))).map(|(x, y)| self.solid_angle(x, y)).collect()
    }

    /// dΩ/d(u,v) at a point of a face: the cube Jacobian 1/|p|³ times the texel scale (a side
    /// face point at (1, a, b) has |p|² = 1 + a² + b²).
    pub fn jacobian(uv: Vec2) -> f32 {
        cube_point(uv.x, uv.y).map_or(0.0, |p| 1.0 / (p.length_squared() * p.length()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobian_integrates_to_the_texel_solid_angle() {
        let h = HalfCube::new(16);
        for (x, y) in [(8, 8), (13, 7), (2, 9), (6, 1), (0, 0), (12, 3)] {
            let mut s = 0.0f64;
            let k = 64;
            let texel_area = (4.0 / 16.0f64).powi(2);
            for i in 0..k {
                for j in 0..k {
                    let f = Vec2::new((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                    s += HalfCube::jacobian(h.uv(x, y, f)) as f64 * texel_area / (k * k) as f64;
                }
            }
            let exact = h.solid_angle(x, y);
            println!("texel ({x},{y}): ∫J = {s:.6e}, Driscoll {exact:.6e}");
            assert!((s - exact).abs() <= 1e-4 * exact.max(1e-9) + 1e-12);
        }
    }
}

/// The tangent frame of every half-cube map and of ω_o at runtime (spec §5.4: the BRDF and the
/// radiance must share the tangent orientation, not just the normal). Duff et al.'s frame without
/// its sign switch, which flips the tangents where n.z changes sign (every floor and wall has
/// n.z = 0), built in a fixed rotated space so that its one singular direction (rapid twist) is
/// the unusual world direction [`SINGULAR`] instead of −z.
pub fn map_frame(n: Vec3) -> glimpse_core::Frame {
    // Rotation R taking SINGULAR to −z (fixed; rows are the rotated axes).
    let (rx, ry, rz) = rotated_axes();
    let m = Vec3::new(rx.dot(n), ry.dot(n), rz.dot(n));
    let a = -1.0 / (1.0 + m.z).max(1e-7);
    let b = m.x * m.y * a;
    let x = Vec3::new(1.0 + m.x * m.x * a, b, -m.x);
    let y = Vec3::new(b, 1.0 + m.y * m.y * a, -m.y);
    // Back to world: v_world = Rᵀ v.
    let back = |v: Vec3| rx * v.x + ry * v.y + rz * v.z;
    glimpse_core::Frame { x: back(x).normalize(), y: back(y).normalize(), z: n }
}

/// The world direction where [`map_frame`] twists fastest (pointing down and sideways, which
/// glossy surfaces rarely face exactly).
pub const SINGULAR: Vec3 = Vec3::new(0.267_261_24, -0.801_783_7, 0.534_522_5);

fn rotated_axes() -> (Vec3, Vec3, Vec3) {
    let z = -SINGULAR;
    let helper = if z.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let x = helper.cross(z).normalize();
    let y = z.cross(x);
    (x, y, z)
}

#[cfg(test)]
mod frame_tests {
    use super::*;

    #[test]
    fn map_frame_is_orthonormal_and_continuous_across_z0() {
        for n in [Vec3::Y, Vec3::X, Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.3, 0.0, -0.95).normalize(), -Vec3::Y] {
            let f = map_frame(n);
            println!("n {n}: x {} y {}", f.x, f.y);
            assert!(f.x.dot(f.y).abs() < 1e-5 && f.x.dot(n).abs() < 1e-5 && f.y.dot(n).abs() < 1e-5);
            assert!((f.x.cross(f.y) - n).length() < 1e-4, "right-handed");
        }
        let (a, b) = (map_frame(Vec3::new(0.0, 1.0, 1e-7).normalize()), map_frame(Vec3::new(0.0, 1.0, -1e-7).normalize()));
        assert!((a.x - b.x).length() < 1e-4, "no flip at n.z = 0");
    }
}
