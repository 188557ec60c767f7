//! Where a ray leaving a surface starts: the hit point placed robustly inside its triangle, and
//! its rounding-error bound (pbrt-v4 §6.8, "Managing Rounding Error").
//!
//! Two things go wrong at a hit interpolated from a triangle's vertices:
//! - the point carries a rounding error of up to `γ₇·Σ|bᵢ·pᵢ|` per coordinate (pbrt-v4
//!   eq. 6.21), so a ray leaving it may hit the same triangle again: [`glimpse_core::Ray::spawn`]
//!   pushes the origin off the surface along the geometric normal, on the side the ray leaves,
//!   by 10⁻⁴ of the magnitude that bound is relative to (`Σ|bᵢ·pᵢ|`, [`surface_point`]'s
//!   second value), hundreds of times the bound, and with no absolute length in it;
//! - a point on an edge shared with another mesh (a wall meeting the ceiling) also lies on
//!   that mesh's plane, within the same rounding error, possibly on its far side; a normal
//!   offset does not move it off that plane, and rays into the room then start behind the wall
//!   and are blocked by it (black pixels along concave edges). So the point is first moved
//!   inside its own triangle, away from every edge, by a few times its error bound (barycentric
//!   inset): it is then strictly on the triangle's side of any surface meeting it at an edge.
//!   The shift is a few ulps of the coordinates, far below anything a pixel can show.

use glimpse_core::Vec3;

/// pbrt-v4's γₙ = nε/(1 − nε), the relative bound after n roundings (ε = half an ulp of 1).
fn gamma(n: u32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}

/// The point `b₀p₀ + b₁p₁ + b₂p₂` and the bound on its rounding error per coordinate.
pub fn interpolate(p: &[Vec3; 3], b: [f32; 3]) -> (Vec3, Vec3) {
    let point = p[0] * b[0] + p[1] * b[1] + p[2] * b[2];
    (point, glimpse_core::ray::error_magnitudes(p, b) * gamma(7))
}

/// [`inset_point`]'s point and the magnitude its error is relative to
/// ([`glimpse_core::ray::error_scale`]), which rays leaving it are offset by.
pub fn surface_point(p: &[Vec3; 3], b: [f32; 3]) -> (Vec3, f32) {
    let w = inset_barycentrics(p, b);
    (interpolate(p, w).0, glimpse_core::ray::error_scale(p, w))
}

/// How far (in multiples of the point's error bound) the inset keeps a hit from its
/// triangle's edges.
const INSET_ERRORS: f32 = 4.0;
/// The inset never moves a barycentric coordinate above this (tiny triangles far from the
/// origin, whose error bound rivals their size, keep their hit near where it was).
const MAX_INSET: f32 = 0.05;

/// The hit point for barycentrics `b` (summing to 1), moved inside the triangle so that it is at
/// least [`INSET_ERRORS`] error bounds from every edge, and its error bound.
pub fn inset_point(p: &[Vec3; 3], b: [f32; 3]) -> (Vec3, Vec3) {
    interpolate(p, inset_barycentrics(p, b))
}

/// [`inset_point`]'s barycentrics.
fn inset_barycentrics(p: &[Vec3; 3], b: [f32; 3]) -> [f32; 3] {
    let (_, error) = interpolate(p, b);
    let twice_area = (p[1] - p[0]).cross(p[2] - p[0]).length();
    let reach = INSET_ERRORS * error.length();
    if twice_area.is_nan() || twice_area <= 0.0 || reach == 0.0 {
        return b;
    }
    // The distance from the edge opposite vertex i to vertex i is 2A/|edge|; a barycentric bᵢ
    // is the point's distance from that edge over that height.
    let edges = [p[2] - p[1], p[0] - p[2], p[1] - p[0]];
    let mut inset = b;
    for (bi, edge) in inset.iter_mut().zip(edges) {
        let min = (reach * edge.length() / twice_area).min(MAX_INSET);
        *bi = bi.max(min);
    }
    let sum = inset[0] + inset[1] + inset[2];
    inset.map(|x| x / sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_on_an_edge_moves_inside_by_a_few_error_bounds_only() {
        let p = [Vec3::new(-1.0, 1.0, -1.0), Vec3::new(-1.0, 1.0, 1.0), Vec3::new(1.0, 1.0, 1.0)];
        // On the edge p0–p1 (x = −1): b2 = 0.
        let (q, e) = inset_point(&p, [0.5, 0.5, 0.0]);
        let moved = q.x + 1.0;
        println!("moved {moved:e} off the edge, error bound {:e}", e.length());
        assert!(moved > 2.0 * e.length(), "not off the edge: {moved}");
        assert!(moved < 1e-5, "moved too far: {moved}");
        // An interior point does not move.
        let (c, _) = inset_point(&p, [0.3, 0.3, 0.4]);
        assert_eq!(c, interpolate(&p, [0.3, 0.3, 0.4]).0);
    }
}
