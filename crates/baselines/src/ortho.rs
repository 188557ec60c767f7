//! Orthographic light maps for directional lights, shared by `lights-shadowmap` and `lights-ism`
//! (the voxel-array paper's baselines have only point lights; a directional light needs a map
//! along its direction). The map is square, perpendicular to the light's direction and fitted to
//! the scene's bounds: the eight corners of the bounding box projected onto the map's plane,
//! their extent made square (square texels) and widened by one texel. Depth is the distance
//! along the light's direction from the bounds' nearest corner.

use glimpse_core::{Aabb, Frame, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrthoMap {
    /// Map axes (x, y) and the direction light travels (z).
    frame: Frame,
    /// Map-plane coordinates of texel (0, 0)'s corner, and the depth origin.
    origin: Vec3,
    /// World size of one texel.
    texel: f32,
    pub resolution: u32,
}

impl OrthoMap {
    /// The map of a light travelling along `direction` (unit) over `bounds`, `resolution²` texels.
    pub fn fit(direction: Vec3, bounds: &Aabb, resolution: u32) -> OrthoMap {
        let frame = Frame::from_z(direction.normalize_or(Vec3::NEG_Y));
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { bounds.min.x } else { bounds.max.x },
                if k & 2 == 0 { bounds.min.y } else { bounds.max.y },
                if k & 4 == 0 { bounds.min.z } else { bounds.max.z },
            );
            let q = frame.to_local(c);
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let extent = (hi.x - lo.x).max(hi.y - lo.y).max(1e-6);
        // One texel of margin on each side, so the bounds' own edges fall inside.
        let texel = extent / (resolution as f32 - 2.0).max(1.0);
        let centre = (lo + hi) * 0.5;
        let half = texel * resolution as f32 * 0.5;
        OrthoMap { frame, origin: Vec3::new(centre.x - half, centre.y - half, lo.z), texel, resolution }
    }

    /// World size of one texel (the bias unit).
    pub fn texel(&self) -> f32 {
        self.texel
    }

    /// The direction light travels.
    pub fn direction(&self) -> Vec3 {
        self.frame.z
    }

    /// `p` in map space: (x, y) in texels, depth in world units.
    #[inline]
    pub fn project(&self, p: Vec3) -> Vec3 {
        let q = self.frame.to_local(p) - self.origin;
        Vec3::new(q.x / self.texel, q.y / self.texel, q.z)
    }

    /// The texel index of map-space `q`, if inside the map.
    #[inline]
    pub fn texel_of(&self, q: Vec3) -> Option<usize> {
        let r = self.resolution as f32;
        (q.x >= 0.0 && q.y >= 0.0 && q.x < r && q.y < r).then(|| q.y as usize * self.resolution as usize + q.x as usize)
    }

    /// Rasterizes a world triangle into `map` (`resolution²` nearest depths) at texel centres,
    /// leaving out those where `hole(b1, b2)` (the texel centre's barycentrics of vertices 1 and
    /// 2: an alpha mask's cut-out; `None` in a scene without masks).
    pub fn raster(&self, map: &mut [f32], tri: &[Vec3; 3], hole: Option<impl Fn(f32, f32) -> bool>) {
        let [p0, p1, p2] = tri.map(|v| self.project(v));
        let area = (p1.x - p0.x) * (p2.y - p0.y) - (p1.y - p0.y) * (p2.x - p0.x);
        if area.abs() < 1e-12 {
            return;
        }
        let rf = self.resolution as f32;
        let x0 = (p0.x.min(p1.x).min(p2.x) - 0.5).ceil().max(0.0);
        let x1 = (p0.x.max(p1.x).max(p2.x) - 0.5).floor().min(rf - 1.0);
        let y0 = (p0.y.min(p1.y).min(p2.y) - 0.5).ceil().max(0.0);
        let y1 = (p0.y.max(p1.y).max(p2.y) - 0.5).floor().min(rf - 1.0);
        if x0 > x1 || y0 > y1 {
            return;
        }
        let inv = 1.0 / area;
        let r = self.resolution as usize;
        for y in y0 as usize..=y1 as usize {
            let py = y as f32 + 0.5;
            for x in x0 as usize..=x1 as usize {
                let px = x as f32 + 0.5;
                let b0 = ((p1.x - px) * (p2.y - py) - (p1.y - py) * (p2.x - px)) * inv;
                let b1 = ((p2.x - px) * (p0.y - py) - (p2.y - py) * (p0.x - px)) * inv;
                let b2 = 1.0 - b0 - b1;
                if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 || hole.as_ref().is_some_and(|h| h(b1, b2)) {
                    continue;
                }
                let depth = b0 * p0.z + b1 * p1.z + b2 * p2.z;
                let t = &mut map[y * r + x];
                *t = t.min(depth);
            }
        }
    }

    /// Whether the surface point `p` (normal `n`) lies behind the depth stored in `map`: the point
    /// is moved `bias` texels along the normal (towards the light) and compared with `bias`
    /// texels of tolerance, as the cube maps do.
    #[inline]
    pub fn shadowed(&self, map: &[f32], p: Vec3, n: Vec3, bias: f32) -> bool {
        let towards_light = -self.frame.z;
        let nn = if n.dot(towards_light) < 0.0 { -n } else { n };
        let q = self.project(p + nn * (bias * self.texel));
        match self.texel_of(q) {
            Some(i) => q.z > map[i] + bias * self.texel,
            None => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fitted_map_covers_the_bounds_and_a_blocker_shadows_what_is_below_it() {
        let bounds = Aabb { min: Vec3::new(-2.0, 0.0, -2.0), max: Vec3::new(2.0, 2.0, 2.0) };
        let dir = Vec3::new(0.3, -1.0, 0.2).normalize();
        let m = OrthoMap::fit(dir, &bounds, 64);
        for k in 0..8 {
            let c = Vec3::new(if k & 1 == 0 { -2.0 } else { 2.0 }, if k & 2 == 0 { 0.0 } else { 2.0 }, if k & 4 == 0 { -2.0 } else { 2.0 });
            assert!(m.texel_of(m.project(c)).is_some(), "corner {c} outside the map");
        }
        // A horizontal square blocker at y = 1 over the floor y = 0.
        let mut map = vec![f32::INFINITY; 64 * 64];
        let s = |x: f32, z: f32| Vec3::new(x, 1.0, z);
        let opaque = None::<fn(f32, f32) -> bool>;
        m.raster(&mut map, &[s(-0.5, -0.5), s(0.5, -0.5), s(0.5, 0.5)], opaque);
        m.raster(&mut map, &[s(-0.5, -0.5), s(0.5, 0.5), s(-0.5, 0.5)], opaque);
        // The point on the floor straight "below" the blocker's centre along the light.
        let t = 1.0 / -dir.y;
        let under = Vec3::new(0.0, 1.0, 0.0) + dir * t;
        assert!(m.shadowed(&map, under, Vec3::Y, 1.5), "the blocker's shadow");
        assert!(!m.shadowed(&map, Vec3::new(1.8, 0.0, 1.8), Vec3::Y, 1.5), "open floor");
        assert!(!m.shadowed(&map, s(0.0, 0.0), Vec3::Y, 1.5), "the blocker's own lit top");
    }
}
