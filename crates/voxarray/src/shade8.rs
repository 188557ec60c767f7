//! The tiled shader of `lights-voxarray` ([`crate::technique`]): one tile of pixels × one light
//! at a time, the tile's GBuffer held in structure-of-arrays form, the shadow segments of eight
//! pixels formed at once with AVX2, then every row load of the tile × light in flight together
//! ([`Array::occluded_rows`]).
//!
//! Per light and group of eight pixels: the facing test (`Shading::cos`) and the irradiance
//! (`WorldLight::incident`), the shadow segment (`direct::punctual` → `direct::segment` with
//! `Ray::spawn`'s offset, then [`Array::surface_segment`]: the far cut and the normal offset),
//! the extent ([`crate::extent8`]); then the row queries of the valid extents; then the
//! Lambertian sum of the unoccluded lights. Every lane performs exactly the scalar code's float
//! operations in the same order (glam's `dot` as `(x·x + y·y) + z·z`, `max_element` as
//! `if a > b { a } else { b }` = `maxps`, Rust's `f32::max`/`min` NaN rules, no FMA), so the
//! segments, the extents, the decisions and the image are bit-identical to the per-sample path
//! (`tests/shade.rs` renders both). Point lights take the AVX2 path; spot and directional lights
//! (and a group with a non-finite distance) form their segments with the scalar code, lane by
//! lane, and still share the rest. Without AVX2 (or with `simd` off) every lane is scalar.

use crate::batch::{LANES, RowQuery};
use crate::query;
use crate::row::Row;
use crate::{Array, extent8};
use glimpse_core::Vec3;
use glimpse_render::direct::{self, Shading};
use glimpse_scene::{LightKind, WorldLight};
use glimpse_trace::GBuffer;

/// The shadow segments of eight lanes (structure of arrays) and which lanes need a query.
#[derive(Clone, Copy, Debug, Default)]
struct Lanes {
    start: [[f32; LANES]; 3],
    end: [[f32; LANES]; 3],
    /// Irradiance × cosine of each lane (added where the light is not occluded).
    contrib: [[f32; LANES]; 3],
    /// Bit `k`: lane `k` faces the light with some irradiance (a shadow decision is made).
    active: u32,
}

/// Per-thread buffers of one tile, reused from tile to tile.
#[derive(Default)]
pub struct Tile {
    /// Pixel (within the tile) of each slot; slots are the tile's hit pixels, padded to a
    /// multiple of [`LANES`] with copies of the last one (masked off).
    pixel: Vec<usize>,
    shading: Vec<Shading>,
    /// Position, geometric normal and shading normal of each slot, by component.
    p: [Vec<f32>; 3],
    n: [Vec<f32>; 3],
    sn: [Vec<f32>; 3],
    /// The irradiance summed over the lights so far, by component.
    e: [Vec<f32>; 3],
    /// Per group of [`LANES`] slots: the lanes' segments and contributions for the current light.
    lanes: Vec<Lanes>,
    /// Per group: lanes that receive the current light (active and not occluded).
    visible: Vec<u32>,
    queries: Vec<RowQuery>,
    /// Slot of each query.
    query_slot: Vec<u32>,
    /// Hit pixels (slots before the padding).
    hits: usize,
}

impl Tile {
    /// Loads pixels `base..base + len` of the GBuffer (the hit ones) and clears the sums.
    pub fn load(&mut self, gbuffer: &GBuffer, base: usize, len: usize) {
        self.pixel.clear();
        self.shading.clear();
        for k in 0..len {
            if let Some(s) = Shading::from_gbuffer(gbuffer, base + k) {
                self.pixel.push(k);
                self.shading.push(s);
            }
        }
        self.hits = self.pixel.len();
        if let (Some(&k), Some(&s)) = (self.pixel.last(), self.shading.last()) {
            while !self.pixel.len().is_multiple_of(LANES) {
                self.pixel.push(k);
                self.shading.push(s);
            }
        }
        let slots = self.pixel.len();
        for c in 0..3 {
            let get = |v: Vec3| v.to_array()[c];
            for (dst, f) in [(&mut self.p[c], 0), (&mut self.n[c], 1), (&mut self.sn[c], 2)] {
                dst.clear();
                dst.extend(self.shading.iter().map(|s| get([s.position, s.normal, s.shading_normal][f])));
            }
            self.e[c].clear();
            self.e[c].resize(slots, 0.0);
        }
        self.lanes.clear();
        self.lanes.resize(slots / LANES, Lanes::default());
        self.visible.clear();
        self.visible.resize(slots / LANES, 0);
    }

    /// Hit pixels of the tile: `(pixel within the tile, shading, summed irradiance)`.
    pub fn results(&self) -> impl Iterator<Item = (usize, &Shading, Vec3)> + '_ {
        (0..self.hits).map(|i| (self.pixel[i], &self.shading[i], Vec3::new(self.e[0][i], self.e[1][i], self.e[2][i])))
    }

    /// Adds `light`'s unoccluded Lambertian term to every hit pixel of the tile; returns the
    /// shadow decisions made (the lights that face the pixel with some irradiance).
    pub fn shade_light<R: Row>(&mut self, array: &Array<R>, light: &WorldLight, simd: bool) -> u64 {
        let groups = self.lanes.len();
        let far = 0.87 * array.grid.resolution as f32 / array.grid.scale;
        let offset = array.normal_offset_cells / array.grid.scale;
        self.queries.clear();
        self.query_slot.clear();
        let mut decisions = 0u64;
        for g in 0..groups {
            let real = lane_mask(self.hits.saturating_sub(g * LANES));
            let at = g * LANES..(g + 1) * LANES;
            #[cfg(target_arch = "x86_64")]
            if simd && extent8::avx2_available() {
                // SAFETY: AVX2 was detected on this CPU; the slices hold LANES floats.
                let formed = unsafe {
                    avx2::form_point(light, soa(&self.p, &at), soa(&self.n, &at), soa(&self.sn, &at), array.grid.center, far, offset)
                };
                let lanes = formed.unwrap_or_else(|| form_scalar(array, light, &self.shading[at.clone()]));
                let active = lanes.active & real;
                // SAFETY: as above.
                let raw = unsafe { avx2::extents(array, &lanes) };
                self.push_group(g, lanes, active, |k| raw.extent(k), R::BITS);
                decisions += active.count_ones() as u64;
                continue;
            }
            let lanes = form_scalar(array, light, &self.shading[at]);
            let active = lanes.active & real;
            let extent = |k: usize| {
                let v = |x: &[[f32; LANES]; 3]| Vec3::new(x[0][k], x[1][k], x[2][k]);
                query::extent(&array.grid, &array.dirs, v(&lanes.start), v(&lanes.end), array.bias_start_cells, array.bias_end_cells)
            };
            self.push_group(g, lanes, active, extent, R::BITS);
            decisions += active.count_ones() as u64;
        }
        let (visible, slots) = (&mut self.visible, &self.query_slot);
        array.occluded_rows(&mut self.queries, |q| {
            let slot = slots[q] as usize;
            visible[slot / LANES] &= !(1 << (slot % LANES));
        });
        for (g, (lanes, &visible)) in self.lanes.iter().zip(&self.visible).enumerate() {
            #[cfg(target_arch = "x86_64")]
            if simd && extent8::avx2_available() {
                let at = g * LANES..(g + 1) * LANES;
                let [ex, ey, ez] = &mut self.e;
                // SAFETY: AVX2 was detected on this CPU; the slices hold LANES floats.
                unsafe { avx2::accumulate([&mut ex[at.clone()], &mut ey[at.clone()], &mut ez[at]], &lanes.contrib, visible) };
                continue;
            }
            for k in 0..LANES {
                if visible >> k & 1 != 0 {
                    for c in 0..3 {
                        self.e[c][g * LANES + k] += lanes.contrib[c][k];
                    }
                }
            }
        }
        decisions
    }

    /// Records group `g`'s lanes: the active lanes with an extent become row queries, the
    /// active lanes without one (the segment covers no voxel) are unoccluded.
    #[inline]
    fn push_group(&mut self, g: usize, lanes: Lanes, active: u32, extent: impl Fn(usize) -> Option<query::Extent>, n_res: u32) {
        let mut bits = active;
        while bits != 0 {
            let k = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            if let Some(x) = extent(k) {
                self.queries.push(RowQuery::new(&x, n_res));
                self.query_slot.push((g * LANES + k) as u32);
            }
        }
        self.visible[g] = active;
        self.lanes[g] = lanes;
    }
}

/// Slots `at` of the three components.
#[inline]
fn soa<'a>(v: &'a [Vec<f32>; 3], at: &std::ops::Range<usize>) -> [&'a [f32]; 3] {
    [&v[0][at.clone()], &v[1][at.clone()], &v[2][at.clone()]]
}

/// Bits `0..n.min(LANES)`.
#[inline]
fn lane_mask(n: usize) -> u32 {
    if n >= LANES { (1 << LANES) - 1 } else { (1 << n) - 1 }
}

/// The per-sample path's code, lane by lane: `direct::punctual`, the facing test and
/// [`Array::surface_segment`].
fn form_scalar<R: Row>(array: &Array<R>, light: &WorldLight, shading: &[Shading]) -> Lanes {
    let mut lanes = Lanes::default();
    for (k, s) in shading.iter().enumerate() {
        let ps = direct::punctual(light, s.position, s.normal);
        let cos = s.cos(ps.wi);
        if cos <= 0.0 || ps.irradiance.max_element() <= 0.0 {
            continue;
        }
        lanes.active |= 1 << k;
        let c = ps.irradiance * cos;
        let (a, b) = array.surface_segment(&ps, s.normal);
        for (i, ((a, b), c)) in a.to_array().into_iter().zip(b.to_array()).zip(c.to_array()).enumerate() {
            lanes.start[i][k] = a;
            lanes.end[i][k] = b;
            lanes.contrib[i][k] = c;
        }
    }
    lanes
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::*;
    use crate::extent8::avx2::{Raw, V, abs, extents_raw, neg, rmax, rmin, select, splat};
    use std::arch::x86_64::*;

    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(x: &[f32]) -> V {
        assert!(x.len() >= LANES);
        // SAFETY: eight floats are readable at `x`.
        unsafe { _mm256_loadu_ps(x.as_ptr()) }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn store(x: &mut [f32; LANES], v: V) {
        // SAFETY: eight floats are writable at `x`.
        unsafe { _mm256_storeu_ps(x.as_mut_ptr(), v) }
    }

    /// glam's `Vec3::dot`: `(x·x' + y·y') + z·z'`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn dot(a: [V; 3], b: [V; 3]) -> V {
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])), _mm256_mul_ps(a[2], b[2]))
    }

    /// glam's `max_element`: `max(x, max(y, z))` with `if a > b { a } else { b }` (`maxps`).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn max_element(a: [V; 3]) -> V {
        _mm256_max_ps(a[0], _mm256_max_ps(a[1], a[2]))
    }

    /// `if mask { -a } else { a }` per lane (exact: a sign flip).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn flip(mask: V, a: [V; 3]) -> [V; 3] {
        a.map(|x| select(mask, neg(x), x))
    }

    /// The segments, contributions and active lanes of a point light at eight surface points
    /// (`p`, geometric normal `n`, shading normal `sn`), or `None` if the light is not a point
    /// light or a lane's distance is not finite (the caller then runs [`form_scalar`]).
    /// `far` is [`Array::segment`]'s `0.87 · N / scale`, `offset` the normal offset in world units.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn form_point(
        light: &WorldLight,
        p: [&[f32]; 3],
        n: [&[f32]; 3],
        sn: [&[f32]; 3],
        center: Vec3,
        far: f32,
        offset: f32,
    ) -> Option<Lanes> {
        if light.kind != LightKind::Point {
            return None;
        }
        let zero = _mm256_setzero_ps();
        let p = p.map(|x| load(x));
        let n = n.map(|x| load(x));
        let sn = sn.map(|x| load(x));
        let lp = [splat(light.position.x), splat(light.position.y), splat(light.position.z)];
        // `WorldLight::incident`: to = L − p, d² = max(|to|², 1e-12), d = √d², wi = to / d, E = I / d².
        let to = [_mm256_sub_ps(lp[0], p[0]), _mm256_sub_ps(lp[1], p[1]), _mm256_sub_ps(lp[2], p[2])];
        let d2 = rmax(dot(to, to), splat(1e-12));
        let d = _mm256_sqrt_ps(d2);
        // `direct::punctual` takes the segment branch where d is finite: here, every lane.
        let finite = _mm256_cmp_ps::<_CMP_LT_OQ>(abs(d), splat(f32::INFINITY));
        if _mm256_movemask_ps(finite) != 0xff {
            return None;
        }
        let wi = to.map(|x| _mm256_div_ps(x, d));
        let irr = [
            _mm256_div_ps(splat(light.intensity.x), d2),
            _mm256_div_ps(splat(light.intensity.y), d2),
            _mm256_div_ps(splat(light.intensity.z), d2),
        ];
        // `Shading::cos`: 0 where n·wi ≤ 0, else max(sn·wi, 0).
        let cos = select(_mm256_cmp_ps::<_CMP_LE_OQ>(dot(n, wi), zero), zero, rmax(dot(sn, wi), zero));
        let skip = _mm256_or_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(cos, zero), _mm256_cmp_ps::<_CMP_LE_OQ>(max_element(irr), zero));
        let active = (!_mm256_movemask_ps(skip) as u32) & 0xff;
        // `direct::segment(p, n, L)`: `Ray::spawn(p, n, L − p).origin`, then the unit direction
        // and length to L.
        let n1 = flip(_mm256_cmp_ps::<_CMP_LT_OQ>(dot(n, to), zero), n);
        let scale = rmax(max_element(p.map(|x| abs(x))), splat(1.0));
        let k = _mm256_mul_ps(splat(1e-4), scale);
        let origin = [0, 1, 2].map(|c| _mm256_add_ps(p[c], _mm256_mul_ps(n1[c], k)));
        let to2 = [0, 1, 2].map(|c| _mm256_sub_ps(lp[c], origin[c]));
        let len = _mm256_sqrt_ps(dot(to2, to2));
        let div = rmax(len, splat(f32::MIN_POSITIVE));
        let dir = to2.map(|x| _mm256_div_ps(x, div));
        // `Array::segment`: the end at min(t_max, |origin − centre| + far) along the ray.
        let oc = [0, 1, 2].map(|c| _mm256_sub_ps(origin[c], splat(center.to_array()[c])));
        let t = rmin(len, _mm256_add_ps(_mm256_sqrt_ps(dot(oc, oc)), splat(far)));
        let end = [0, 1, 2].map(|c| _mm256_add_ps(origin[c], _mm256_mul_ps(dir[c], t)));
        // `Array::surface_segment`: the start moved along the normal, on the ray's side.
        let n2 = flip(_mm256_cmp_ps::<_CMP_LT_OQ>(dot(n, dir), zero), n);
        let start = [0, 1, 2].map(|c| _mm256_add_ps(origin[c], _mm256_mul_ps(n2[c], splat(offset))));
        let mut lanes = Lanes { active, ..Lanes::default() };
        for c in 0..3 {
            store(&mut lanes.start[c], start[c]);
            store(&mut lanes.end[c], end[c]);
            store(&mut lanes.contrib[c], _mm256_mul_ps(irr[c], cos));
        }
        Some(lanes)
    }

    /// The extents of the eight segments of `lanes` ([`extents_raw`]).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn extents<R: Row>(array: &Array<R>, lanes: &Lanes) -> Raw {
        let s = [0, 1, 2].map(|c| load(&lanes.start[c]));
        let e = [0, 1, 2].map(|c| load(&lanes.end[c]));
        // SAFETY: the caller's.
        unsafe {
            extents_raw(&array.grid, &array.dirs, (s[0], s[1], s[2]), (e[0], e[1], e[2]), array.bias_start_cells, array.bias_end_cells)
        }
    }

    /// `e[c][k] += contrib[c][k]` for the lanes `k` set in `visible`.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn accumulate(e: [&mut [f32]; 3], contrib: &[[f32; LANES]; 3], visible: u32) {
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let mask = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(visible as i32), bits), bits));
        for (e, c) in e.into_iter().zip(contrib) {
            let x = load(e);
            let sum = select(mask, _mm256_add_ps(x, load(c)), x);
            assert!(e.len() >= LANES);
            // SAFETY: eight floats are writable at `e`.
            unsafe { _mm256_storeu_ps(e.as_mut_ptr(), sum) }
        }
    }
}
